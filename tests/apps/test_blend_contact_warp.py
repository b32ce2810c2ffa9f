"""The contact-guided warp by default where it helps (issue 29): ``contact_warp`` auto, on, off.

The rule (:func:`elastic_motion.apps.blend.contact_warp.guided_or_plain`) is tested on stand-in
blends whose skid counts and distances are set, so that each branch is met exactly; the blend
pipeline, the option and the report on a real pair (CMU 107_02 x 108_01, whose blend without
the clean-up skids twice where its inputs do not, with or without the guided warp)."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from blend_testlib import count_foot_quality

import elastic_motion.apps.blend as blend_package
import elastic_motion.apps.blend.contact_warp as contact_warp_module
from elastic_motion.apps.blend import blend_motions
from elastic_motion.apps.blend.contact_warp import DISTANCE_TOLERANCE, NOTE_CONTACT_WARP, guided_or_plain
from elastic_motion.apps.blend.warps import IDENTITY_WARP, Warps
from elastic_motion.apps.metrics import blend_metrics
from elastic_motion.apps.prepare import PrepareOptions, prepare_motions
from elastic_motion.cli import main
from elastic_motion.errors import OptionError
from elastic_motion.vocabulary import GAIT_KINDS
from elastic_motion.warp import WarpOptions

PLAIN_DISTANCE = 2.0


def _warps(distance: float, pairs: int) -> Warps:
    return Warps(
        (IDENTITY_WARP, IDENTITY_WARP.copy()),
        tuple((0.1 * k, 0.1 * k) for k in range(pairs)),
        WarpOptions(),
        distance=distance,
    )


def _feet(skids: int) -> SimpleNamespace:
    return SimpleNamespace(skid_count=skids, slid_m=0.1 * skids)


def _rule(monkeypatch, plain_skids: int, guided_skids: int, ratio: float, pairs: int = 4, inputs=(1, 2)):
    """The rule on stand-ins: the plain blend skids ``plain_skids`` times, the guided one
    ``guided_skids`` with ``ratio`` times the plain distance; the guided warp's solves and the
    blends built on it are counted."""
    solved, built = [], []
    guided = _warps(ratio * PLAIN_DISTANCE, pairs)

    def solve(inputs_, plain):
        solved.append(plain)
        return guided

    def build(warps):
        built.append(warps)
        return "guided blend"

    monkeypatch.setattr(contact_warp_module, "contact_guided_warp", solve)
    skids = {"plain blend": plain_skids, "guided blend": guided_skids}
    plain = _warps(PLAIN_DISTANCE, 0)
    warps, blend, choice = guided_or_plain(
        None, plain, "plain blend", build, lambda b: _feet(skids[b]), [_feet(n) for n in inputs]
    )
    return SimpleNamespace(
        warps=warps, blend=blend, choice=choice, solved=solved, built=built, plain=plain, guided=guided
    )


@pytest.mark.parametrize("ratio", [1.0, 1.015, DISTANCE_TOLERANCE])
def test_the_guided_warp_is_kept_when_it_lowers_the_skids_within_the_distance(monkeypatch, ratio):
    r = _rule(monkeypatch, plain_skids=5, guided_skids=3, ratio=ratio)
    assert r.warps is r.guided and r.blend == "guided blend"
    c = r.choice
    assert (c.kept, c.inputs_skids, c.plain_skids, c.guided_skids) == ("guided", 2, 5, 3)
    assert c.plain_distance == PLAIN_DISTANCE and c.guided_distance == pytest.approx(ratio * PLAIN_DISTANCE)
    assert c.landmark_pairs == 4


@pytest.mark.parametrize("ratio", [DISTANCE_TOLERANCE + 1e-4, 1.1])
def test_the_plain_warp_is_kept_when_the_distance_rises_more_than_2_percent(monkeypatch, ratio):
    r = _rule(monkeypatch, plain_skids=5, guided_skids=0, ratio=ratio)
    assert r.warps is r.plain and r.blend == "plain blend" and r.choice.kept == "plain"
    assert r.built and "distance" in r.choice.reason  # built and measured, then refused
    assert r.choice.guided_skids == 0


@pytest.mark.parametrize("guided_skids", [5, 6])
def test_the_plain_warp_is_kept_when_the_skids_do_not_drop(monkeypatch, guided_skids):
    r = _rule(monkeypatch, plain_skids=5, guided_skids=guided_skids, ratio=0.99)
    assert r.warps is r.plain and r.blend == "plain blend" and r.choice.kept == "plain"
    assert "skid" in r.choice.reason and r.choice.guided_skids == guided_skids


@pytest.mark.parametrize("plain_skids", [0, 2])
def test_nothing_more_runs_without_extra_skids(monkeypatch, plain_skids):
    """No more skids than the inputs' larger count (2): no guided warp solved, no blend built."""
    r = _rule(monkeypatch, plain_skids=plain_skids, guided_skids=0, ratio=1.0)
    assert r.solved == [] and r.built == []
    assert r.warps is r.plain and r.choice.kept == "plain" and r.choice.guided_skids is None


def test_no_paired_events_builds_nothing(monkeypatch):
    r = _rule(monkeypatch, plain_skids=5, guided_skids=0, ratio=1.0, pairs=0)
    assert len(r.solved) == 1 and r.built == [] and r.choice.kept == "plain"


# -- the pipeline on a real pair ------------------------------------------------------------


@pytest.fixture(scope="module")
def pair(mocap_dir: Path):
    bvh = mocap_dir / "cmu" / "bvh"
    return prepare_motions([bvh / "107_02_30hz.bvh", bvh / "108_01_30hz.bvh"], PrepareOptions())


@pytest.fixture
def guided_solves(monkeypatch):
    """The contact-guided warps solved (by the rule or by ``"on"``)."""
    calls = []
    real = contact_warp_module.contact_guided_warp

    def counted(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(contact_warp_module, "contact_guided_warp", counted)
    monkeypatch.setattr(blend_package, "contact_guided_warp", counted)
    return calls


def test_the_rule_costs_one_skid_count_when_the_blend_has_no_extra_skids(pair, guided_solves, monkeypatch):
    """With the clean-up, 107 x 108 has no skids beyond its inputs': the rule measures nothing
    itself (the clean-up measured the blend and the inputs) and solves no second warp; the blend
    is that of ``"off"``."""
    measured = []
    real = blend_package.foot_quality
    monkeypatch.setattr(
        blend_package, "foot_quality", lambda m, *a, **k: measured.append(m) or real(m, *a, **k)
    )
    res = blend_motions(pair, 0.5)
    assert res.cleanup is not None and res.cleanup.applied
    assert guided_solves == [] and measured == []
    assert res.contact_warp["kept"] == "plain" and res.contact_warp["guided"] is None
    assert res.contact_warp["plain"]["skids"] <= res.contact_warp["inputs_skids"]
    off = blend_motions(pair, 0.5, contact_warp="off")
    assert np.array_equal(off.motion.rotations, res.motion.rotations)
    assert np.array_equal(off.motion.root_translation, res.motion.root_translation)
    assert off.contact_warp is None and guided_solves == []


def test_the_rule_tries_the_guided_warp_on_extra_skids(pair, guided_solves):
    """Without the clean-up (``contacts="report"``) the blend skids twice, its inputs never: the
    guided warp is solved and its blend built; it skids as often, so the plain blend is kept and
    the note gives both skid counts and both distances."""
    res = blend_motions(pair, 0.5, contacts="report")
    assert guided_solves == [1]
    cw = res.contact_warp
    assert cw["kept"] == "plain" and cw["plain"]["skids"] > cw["inputs_skids"]
    assert cw["guided"]["skids"] >= cw["plain"]["skids"] and cw["guided"]["landmark_pairs"] > 0
    assert cw["plain"]["distance"] > 0 and cw["guided"]["distance"] > 0
    assert res.landmarks == ()  # the plain warp's blend
    note = next(n for n in res.notes if n.kind == NOTE_CONTACT_WARP)
    assert f"skids plain {cw['plain']['skids']}" in str(note) and f"guided {cw['guided']['skids']}" in str(
        note
    )
    assert note.data == cw


def test_the_blend_keeps_what_the_rule_keeps(pair, guided_solves, monkeypatch):
    """When the guided warp's blend measures fewer skids (here: its skids taken away from the
    measure) within the distance (107 x 108: 1.004x), the result is the guided blend, the same
    as ``"on"``'s, with its landmarks."""
    from dataclasses import replace

    real = blend_package.foot_quality
    seen = []

    def measured(motion, *args, **kwargs):
        q = real(motion, *args, **kwargs)
        seen.append(q.skid_count)
        return q if len(seen) == 1 else replace(q, skids=())

    monkeypatch.setattr(blend_package, "foot_quality", measured)
    res = blend_motions(pair, 0.5, contacts="report")
    assert len(seen) == 2 and seen[0] > 0  # the plain blend, then the guided one
    assert res.contact_warp["kept"] == "guided" and res.contact_warp["guided"]["skids"] == 0
    assert res.landmarks and guided_solves == [1]
    on = blend_motions(pair, 0.5, contacts="report", contact_warp="on")
    assert res.landmarks == on.landmarks
    assert np.array_equal(res.motion.rotations, on.motion.rotations)
    assert np.array_equal(res.motion.root_translation, on.motion.root_translation)


def test_off_never_and_on_always(pair, guided_solves):
    off = blend_motions(pair, 0.5, contacts="report", contact_warp="off")
    assert guided_solves == [] and off.contact_warp is None and off.landmarks == ()
    on = blend_motions(pair, 0.5, contacts="report", contact_warp="on")
    assert guided_solves == [1] and on.contact_warp is None
    assert on.landmarks and {d["kind"] for d in on.landmark_pairing["pairs"]} <= set(GAIT_KINDS)


def test_the_identity_never_tries_the_guided_warp(pair, guided_solves):
    a = pair.motions[0]
    res = blend_motions([a, a], 0.5)
    assert guided_solves == [] and res.contact_warp["kept"] == "plain"
    assert res.contact_warp["plain"]["skids"] == res.contact_warp["inputs_skids"]


def test_the_option_is_checked():
    with pytest.raises(OptionError, match="contact_warp"):
        blend_package.BlendOptions(contact_warp="sometimes")
    with pytest.raises(OptionError, match="contact_warp"):
        blend_package.BlendOptions(contact_warp="on", landmarks="auto")
    with pytest.raises(OptionError, match="contact_warp"):
        blend_package.BlendOptions(contact_warp="on", cycles=True)
    with pytest.raises(OptionError, match="contact_warp"):
        blend_package.BlendOptions(contact_warp="on", warp="none")
    assert blend_package.BlendOptions(contact_warp="auto", landmarks="auto").contact_warp == "auto"


def test_on_with_three_motions_is_an_error_not_ignored(pair):
    a, b = pair.motions
    with pytest.raises(OptionError, match=r"^contact_warp: expected two motions with 'on'.*got 3"):
        blend_motions([a, b, a], [0.3, 0.3, 0.4], contact_warp="on")


def test_the_json_report_has_the_decision(mocap_dir: Path, tmp_path, capsys):
    bvh = mocap_dir / "cmu" / "bvh"
    args = [
        str(bvh / "107_02_30hz.bvh"),
        str(bvh / "108_01_30hz.bvh"),
        "--contacts",
        "report",
        "--no-metrics",
    ]
    rep = tmp_path / "r.json"
    assert main(["blend", *args, "-o", str(tmp_path / "o.bvh"), "--json", str(rep), "-q"]) == 0
    report = json.loads(rep.read_text())
    cw = report["contact_warp"]
    assert cw["kept"] == "plain" and cw["guided"]["skids"] is not None and cw["plain"]["distance"] > 0
    assert any(n.startswith("contact-guided warp: plain warp kept") for n in report["notes"])
    rep2 = tmp_path / "r2.json"
    assert (
        main(
            [
                "blend",
                *args,
                "-o",
                str(tmp_path / "o2.bvh"),
                "--json",
                str(rep2),
                "-q",
                "--contact-warp",
                "off",
            ]
        )
        == 0
    )
    report2 = json.loads(rep2.read_text())
    assert report2["contact_warp"] is None and not any("contact-guided" in n for n in report2["notes"])
    capsys.readouterr()


def test_the_rules_measures_are_the_metrics(pair, monkeypatch):
    """Without the contacts stage (``contacts="off"``) the rule measures the inputs and the
    blend itself; the metrics take those measures: no motion is measured twice."""
    import elastic_motion.apps.metrics.blend as metrics_module

    measured = count_foot_quality(monkeypatch, blend_package, metrics_module)
    res = blend_motions(pair, 0.5, contacts="off", metrics=True)
    assert res.contact_warp is not None and res.cleanup is None
    assert len(measured) == len({id(m) for m in measured}) >= 3  # A, B, the blend (and a guided one)
    monkeypatch.undo()
    fresh = blend_metrics(res.motion, res.prepared, res.weights, res.options.contact_options)
    assert fresh.summary()["feet"] == res.metrics.summary()["feet"]


def test_a_weight_of_one_never_tries_the_guided_warp(pair, guided_solves):
    res = blend_motions(pair, 1.0, contacts="report")
    assert res.contact_warp is None and guided_solves == []


def test_the_second_build_measures_the_inputs_no_more(pair, monkeypatch):
    """The guided blend's contacts stage takes the inputs' feet the plain one measured: A, B,
    the plain blend and the guided blend, each measured once."""
    import elastic_motion.apps.blend.contacts as contacts_stage

    measured = []
    real = contacts_stage.foot_quality

    def counted(motion, *args, **kwargs):
        measured.append(motion)
        return real(motion, *args, **kwargs)

    monkeypatch.setattr(contacts_stage, "foot_quality", counted)
    monkeypatch.setattr(blend_package, "foot_quality", counted)
    res = blend_motions(pair, 0.5, contacts="report")
    assert res.contact_warp["guided"] is not None
    assert len(measured) == 4 and len({id(m) for m in measured}) == 4
