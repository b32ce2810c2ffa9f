"""The blend's metrics pass does no work whose result nobody reads (issue 34), and its numbers
are those of the full preparation."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import elastic_motion.apps.prepare as prepare_module
from elastic_motion.apps.blend import blend_motions
from elastic_motion.apps.distance import distance_table
from elastic_motion.apps.metrics import blend_metrics
from elastic_motion.apps.prepare import PrepareOptions, prepare_motions


@pytest.fixture(scope="module")
def blended(mocap_dir: Path):
    bvh = mocap_dir / "cmu" / "bvh"
    prep = prepare_motions([bvh / "07_01.bvh", bvh / "08_02.bvh"], PrepareOptions(trim=(0.0, 1.2)))
    return blend_motions(prep, metrics=False)


def test_the_metrics_check_no_up_axis(blended, monkeypatch):
    """The metrics prepare the blend's inputs (metres, Y-up already) and the result again: the
    up-axis check (a few FK passes per motion, 0.1 s each) only adds notes nobody reads."""
    calls = []
    real = prepare_module.up_axis_warning
    monkeypatch.setattr(prepare_module, "up_axis_warning", lambda *a, **k: calls.append(1) or real(*a, **k))
    blend_metrics(blended.motion, blended.prepared, blended.weights)
    assert calls == []


def test_the_metrics_distances_are_those_of_the_full_preparation(blended):
    met = blend_metrics(blended.motion, blended.prepared, blended.weights)
    full = distance_table(
        [*blended.prepared.motions, blended.motion],
        labels=[*blended.prepared.labels, "result"],
        prepare=PrepareOptions(joints="common", drop_tpose=False),
    ).matrix
    assert np.array_equal(met.distances_to_inputs, full[2, :2])
    assert met.geodesic_expected[0] == blended.weights[1] * full[0, 1]  # d(A, B) of that metric
    # between the inputs: the table of the prepared inputs alone, `distance`'s numbers for them
    # (issue 34: one distance per pair; in the weights shared with the result they differ)
    assert np.array_equal(met.distances_between_inputs, distance_table(blended.prepared).matrix)
    assert met.distances_between_inputs[0, 1] != full[0, 1]


def test_no_motion_is_measured_twice(mocap_dir: Path, monkeypatch):
    """The contacts stage measures the inputs' feet and the cleaned blend's (foot_quality); the
    metrics take those measures instead of measuring the same motions again."""
    import elastic_motion.apps.blend.contacts as contacts_stage
    import elastic_motion.apps.metrics.blend as metrics_module

    measured = []
    real = metrics_module.foot_quality

    def counted(motion, *args, **kwargs):
        measured.append(motion)  # the object itself: an id of a freed motion may be reused
        return real(motion, *args, **kwargs)

    monkeypatch.setattr(contacts_stage, "foot_quality", counted)
    monkeypatch.setattr(metrics_module, "foot_quality", counted)
    bvh = mocap_dir / "cmu" / "bvh"
    prep = prepare_motions([bvh / "07_01.bvh", bvh / "08_02.bvh"], PrepareOptions(trim=(0.0, 1.2)))
    res = blend_motions(prep, metrics=True)
    assert res.cleanup is not None and res.cleanup.applied  # the clean-up's measure is reused too
    assert len(measured) == len({id(m) for m in measured})
    monkeypatch.undo()
    fresh = blend_metrics(res.motion, res.prepared, res.weights, res.options.contact_options)
    assert fresh.summary() == res.metrics.summary()
