"""The blend's metrics pass does no work whose result nobody reads (issue 34): no up-axis check,
no motion measured twice, no warp solved again; its numbers are those of solving every warp."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from blend_testlib import count_foot_quality

import elastic_motion.apps.prepare as prepare_module
from elastic_motion.apps.align import motion_curves
from elastic_motion.apps.blend import blend_motions
from elastic_motion.apps.distance import KnownDistances, distance_table
from elastic_motion.apps.metrics import blend_metrics
from elastic_motion.apps.prepare import PrepareOptions, prepare_motions
from elastic_motion.curves import srv_transform
from elastic_motion.errors import OptionError
from elastic_motion.warp import WarpOptions


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


def test_the_metrics_distances_are_those_of_the_inputs_preparation(blended):
    """The result is measured beside its inputs in their preparation (joints, placement, the
    shared curve weights): the distance table of the three, every warp solved afresh."""
    met = blend_metrics(blended.motion, blended.prepared, blended.weights)
    prep = blended.prepared
    full = distance_table(
        replace(prep, motions=(*prep.motions, blended.motion), labels=(*prep.labels, "r"))
    ).matrix
    assert np.array_equal(met.distances_between_inputs, full[:2, :2])
    assert np.array_equal(met.distances_to_inputs, full[2, :2])
    assert full[0, 1] > 0 and np.all(full[2, :2] > 0)
    # between the inputs: `distance`'s numbers for them (issue 34: one distance per pair), the
    # same in the table with the result beside them (the inputs' own shared weights)
    assert np.array_equal(met.distances_between_inputs, distance_table(prep).matrix)
    assert np.array_equal(met.distances_between_inputs, full[:2, :2])


def _warps_solved(monkeypatch) -> list[int]:
    """Counts the distance table's warp solves (the metrics' only solver)."""
    import elastic_motion.apps.distance as distance_module

    solved: list[int] = []
    real = distance_module.optimal_warp
    monkeypatch.setattr(distance_module, "optimal_warp", lambda *a, **k: solved.append(1) or real(*a, **k))
    return solved


def test_the_metrics_reuse_the_blends_warp(mocap_dir: Path, monkeypatch):
    """A Lie blend with the default warp and no landmarks solved the metrics' warp of A and B
    already, on the metrics' own curves: the metrics solve only the result's two warps, and
    their numbers are those of solving all three again."""
    bvh = mocap_dir / "cmu" / "bvh"
    prep = prepare_motions([bvh / "07_01.bvh", bvh / "08_02.bvh"], PrepareOptions(trim=(0.0, 1.2)))
    solved = _warps_solved(monkeypatch)
    res = blend_motions(prep, metrics=True)
    assert len(solved) == 2  # result onto A, result onto B; A and B: the blend's
    warp_note = next(n for n in res.notes if n.kind == "blend.warp")
    assert res.metrics.distances_between_inputs[0, 1] == warp_note.data["distance"]
    fresh = blend_metrics(res.motion, res.prepared, res.weights, res.options.contact_options)
    assert len(solved) == 5
    assert np.array_equal(fresh.distances_between_inputs, res.metrics.distances_between_inputs)
    assert np.array_equal(fresh.distances_to_inputs, res.metrics.distances_to_inputs)


@pytest.mark.parametrize(
    "change", [{"warp": "dp"}, {"method": "euler-elastic"}, {"landmarks": [(0.3, 0.35)]}]
)
def test_a_warp_that_is_not_the_metrics_is_not_reused(blended, monkeypatch, change):
    """Another warp method, Euler curves or landmarks: the blend's warp is not the metrics'
    distance, which is solved (three warps) and is the same as without the blend's."""
    solved = _warps_solved(monkeypatch)
    res = blend_motions(blended.prepared, metrics=True, **change)
    assert len(solved) == 3
    fresh = blend_metrics(res.motion, res.prepared, res.weights, res.options.contact_options)
    assert np.array_equal(fresh.distances_between_inputs, res.metrics.distances_between_inputs)


def test_no_motion_is_measured_twice(mocap_dir: Path, monkeypatch):
    """The contacts stage measures the inputs' feet and the cleaned blend's (foot_quality); the
    metrics take those measures instead of measuring the same motions again."""
    import elastic_motion.apps.blend.contacts as contacts_stage
    import elastic_motion.apps.metrics.blend as metrics_module

    measured = count_foot_quality(monkeypatch, contacts_stage, metrics_module)
    bvh = mocap_dir / "cmu" / "bvh"
    prep = prepare_motions([bvh / "07_01.bvh", bvh / "08_02.bvh"], PrepareOptions(trim=(0.0, 1.2)))
    res = blend_motions(prep, metrics=True)
    assert res.cleanup is not None and res.cleanup.applied  # the clean-up's measure is reused too
    assert len(measured) == len({id(m) for m in measured})
    monkeypatch.undo()
    fresh = blend_metrics(res.motion, res.prepared, res.weights, res.options.contact_options)
    assert fresh.summary() == res.metrics.summary()


def test_distance_table_takes_what_it_is_given(blended):
    """Known curves are used and known distances are taken as they are (the metrics trust
    the blend's); a NaN is solved; the wrong number of curves or shape of distances is an
    error naming the argument."""
    prep = blended.prepared
    plain = distance_table(prep)
    solved = np.array([[0.0, 123.0], [123.0, 0.0]])
    taken = distance_table(prep, known=KnownDistances((None, None), solved))
    assert taken.matrix[0, 1] == 123.0 and np.array_equal(taken.unwarped, plain.unwarped)
    srvs = tuple(_srvs(prep))
    again = distance_table(prep, known=KnownDistances(srvs, np.full((2, 2), np.nan)))
    assert np.array_equal(again.matrix, plain.matrix)
    with pytest.raises(OptionError, match="known"):
        distance_table(prep, known=KnownDistances(srvs[:1]))
    with pytest.raises(OptionError, match="known"):
        distance_table(prep, known=KnownDistances(srvs, np.zeros((3, 3))))
    # the metrics' own check: a (K,) row is not broadcast into the matrix
    with pytest.raises(OptionError, match=r"^inputs_known: expected the 2 inputs' SRVs and a \(2, 2\)"):
        blend_metrics(blended.motion, prep, blended.weights, inputs_known=KnownDistances(srvs, np.ones(2)))


def _srvs(prep):
    """The SRVs distance_table builds for ``prep`` (Lie curves, default warp sampling)."""
    opts = WarpOptions()
    return [
        srv_transform(c)
        for c in motion_curves(prep, "lie", fps=opts.sample_fps, smoothing=opts.sample_smoothing)
    ]
