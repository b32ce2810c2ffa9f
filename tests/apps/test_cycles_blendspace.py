"""Gait cycles, cycle matching, blends by cycles and loops, blend spaces."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from blend_testlib import walker

from elastic_motion.apps.blend import NOTE_CYCLES, NOTE_LOOP, BlendOptions, blend_motions
from elastic_motion.apps.blendspace import blendspace, motion_speed
from elastic_motion.apps.cycles import GaitCycles, match_cycles
from elastic_motion.errors import OptionError
from elastic_motion.motion import read_motion, resample, trim


def _cycles(strikes, other=()):
    return GaitCycles("left", tuple(strikes), tuple(other), 10.0)


def test_equal_counts_match_one_to_one_with_steps_as_landmarks():
    a = _cycles([1.0, 2.0, 3.0], [1.5, 2.5])
    b = _cycles([0.5, 1.3, 2.1], [0.9, 1.7])
    m = match_cycles(a, b)
    assert (m.n, m.first_a, m.first_b) == (2, 0, 0)
    assert m.span_a == (1.0, 3.0) and m.span_b == (0.5, 2.1)
    # other-foot strike, inner boundary, other-foot strike; times from the spans' starts
    np.testing.assert_allclose(m.landmarks, [(0.5, 0.4), (1.0, 0.8), (1.5, 1.2)])


def test_fewer_cycles_meet_the_most_alike_window():
    # 2 cycles of 1 s against 3 of B, of which the last two last 1 s
    a = _cycles([0.0, 1.0, 2.0])
    b = _cycles([0.0, 0.6, 1.6, 2.6])
    m = match_cycles(a, b)
    assert (m.n, m.first_a, m.first_b) == (2, 0, 1) and "B's cycles 2-3" in m.why
    one = match_cycles(a, b, max_cycles=1)
    assert one.n == 1 and one.first_b in (1, 2)


def test_no_cycles_fall_back_and_say_so():
    m = match_cycles(_cycles([1.0]), _cycles([0.0, 1.0, 2.0]))
    assert m.n == 0 and "fall back" in m.why and "A" in m.why


def test_blend_by_cycles_falls_back_on_clips_without_steps():
    a = walker(duration=1.0, name="A")
    b = walker(duration=1.2, freq=1.2, name="B")
    res = blend_motions([a, b], 0.5, cycles=True, contacts="off")
    assert res.cycles is not None and res.cycles.n == 0
    assert any(
        n.kind == NOTE_CYCLES and "fall back" in str(n) and n.data["matched_cycles"] == 0 for n in res.notes
    )
    with pytest.raises(OptionError, match="two motions"):
        blend_motions([a, b, a], cycles=True)


@pytest.mark.mocap
def test_cmu_walks_by_cycles_and_a_looped_blend(mocap_dir):
    # trimmed to their first 6 s (start and walk; fast), and to 30 frames per second
    a = resample(trim(read_motion(mocap_dir / "cmu/bvh/131_01.bvh"), 0.0, 6.0), 30.0)
    b = resample(trim(read_motion(mocap_dir / "cmu/bvh/131_02.bvh"), 0.0, 6.0), 30.0)
    res = blend_motions([a, b], 0.5, cycles=True, warp="dp")
    c = res.cycles
    assert c.n >= 3 and c.cycles_a.n_cycles >= c.n and c.cycles_b.n_cycles >= c.n
    assert len(res.landmarks) >= c.n
    # the matched spans start and end at heel strikes: the blend lasts about their mean
    span = 0.5 * (c.span_a[1] - c.span_a[0]) + 0.5 * (c.span_b[1] - c.span_b[0])
    assert res.motion.duration == pytest.approx(span, abs=0.05)
    looped = blend_motions([a, b], 0.5, loop=True, warp="dp")
    assert looped.cycles.n == 1 and looped.loop is not None
    # (the loop keeps the cycle's contacts, so the clean-up after it barely opens the seam)
    assert looped.loop.seam_after.seam_position_max_m < 1e-3
    # closed C1: the joints' velocities match at the seam too (a C0 seam left a hitch)
    assert looped.loop.c1 and looped.loop.seam_after.seam_angular_velocity_max_deg_s < 1e-2
    ratio = looped.loop.seam_after.seam_velocity_jump_ratio
    assert any(n.kind == NOTE_LOOP and f"hitch {ratio:.2f}x" in str(n) for n in looped.notes)
    assert looped.summary()["loop"] is not None
    # the last closing must not push a foot into the floor (issue 16: at most 1 cm)
    from elastic_motion.apps.metrics import contact_skating

    assert contact_skating(looped.motion, looped.cleanup.contacts).below_floor <= 0.01


def test_blendspace_weights_and_bad_input():
    ms = [walker(duration=1.0, speed=s, name=f"w{s}") for s in (1.0, 1.5, 2.0)]
    space = blendspace(ms, contacts="off")
    np.testing.assert_allclose(space.params, [1.0, 1.5, 2.0], atol=0.02)
    np.testing.assert_allclose(space.weights(space.params[1]), [0, 1, 0], atol=1e-12)
    w = space.weights(0.25 * space.params[0] + 0.75 * space.params[1])
    np.testing.assert_allclose(w, [0.25, 0.75, 0.0], atol=1e-12)
    # a parameter sweep: speeds increase with the parameter; each input's own parameter gives it
    sweep = [motion_speed(space.at(p).motion) for p in np.linspace(space.params[0], space.params[-1], 5)]
    assert (np.diff(sweep) > 0).all()
    np.testing.assert_allclose(sweep[0], space.params[0], rtol=1e-3)
    with pytest.raises(OptionError, match="at"):
        space.at(5.0)
    with pytest.raises(OptionError, match="at least 3"):
        blendspace(ms[:2])
    with pytest.raises(OptionError, match="different parameters"):
        blendspace(ms, [1.0, 1.0, 2.0])
    with pytest.raises(OptionError, match="one per motion"):
        blendspace(ms, [1.0, 2.0])


def test_blendspace_passes_the_pose_anchoring_on(capsys, tmp_path):
    """Every blend of the space is anchored unless ``anchor=False`` (``--no-anchor``)."""
    import json

    from elastic_motion.cli import main
    from elastic_motion.motion import write_bvh

    ms = [walker(duration=1.0, speed=s, phase=0.3 * s, name=f"w{s}") for s in (1.0, 1.5, 2.0)]
    for anchor in (True, False):
        space = blendspace(ms, [1.0, 2.0, 3.0], contacts="off", anchor=anchor)
        res = space.at(1.5)
        assert (res.pose_anchor_deg is not None) == anchor and space.summary()["anchor"] == anchor
    files = []
    for m in ms:
        files.append(tmp_path / f"{m.name}.bvh")
        write_bvh(m, files[-1])
    out = tmp_path / "o.bvh"
    argv = ["blendspace", *map(str, files), "--params", "1,2,3", "--at", "1.5", "-o", str(out)]
    assert main([*argv, "--contacts", "off", "--no-anchor", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["pose_anchor_deg"] is None and report["blendspace"]["anchor"] is False


def test_blendspace_takes_the_blend_options():
    """The space's blends take one BlendOptions (or its overrides): the same space either way,
    its preparation done once (the blends get prepared motions), the options a space sets
    itself refused."""
    ms = [walker(duration=1.0, speed=s, phase=0.3 * s, name=f"w{s}") for s in (1.0, 1.5, 2.0)]
    by_options = blendspace(ms, [1.0, 2.0, 3.0], BlendOptions(method="euler-elastic", contacts="off"))
    by_keywords = blendspace(ms, [1.0, 2.0, 3.0], method="euler", contacts="off")
    assert by_options.options == by_keywords.options and by_options.method == "euler-elastic"
    assert by_options.options.prepare is None
    a, b = by_options.at(1.5), by_keywords.at(1.5)
    np.testing.assert_array_equal(a.motion.rotations, b.motion.rotations)
    assert a.cleanup is None and a.options.method == "euler-elastic"
    with pytest.raises(OptionError, match=r"^weight_curve: expected none in a blend space"):
        blendspace(ms, [1.0, 2.0, 3.0], weight_curve="0:0,1:1")
    with pytest.raises(OptionError, match=r"^cycles:"):
        blendspace(ms, [1.0, 2.0, 3.0], loop=True)
    with pytest.raises(OptionError, match=r"^at:"):
        blendspace(ms, [1.0, 2.0, 3.0], at=2.0)


def test_blendspace_speed_is_blended_once_per_trial(monkeypatch):
    """``params="speed"``: the bisection's last blend is returned, not blended again (with
    metrics: the same blend, metrics added)."""
    import elastic_motion.apps.blendspace as bs

    ms = [walker(duration=1.0, speed=s, name=f"w{s}") for s in (1.0, 1.5, 2.0)]
    space = blendspace(ms, contacts="off")
    calls = []
    real = bs.blend_motions

    def spy(prepared, w, **kw):
        calls.append(np.array(w, dtype=float))
        return real(prepared, w, **kw)

    monkeypatch.setattr(bs, "blend_motions", spy)
    p = 0.5 * (space.params[0] + space.params[1])
    res = space.at(p)
    assert abs(motion_speed(res.motion) - p) <= 0.005 * p
    assert len(calls) >= 1 and all(not np.array_equal(x, y) for x, y in itertools.pairwise(calls))
    np.testing.assert_array_equal(res.weights, calls[-1])
    calls.clear()
    with_metrics = space.at(p, metrics=True)
    assert with_metrics.metrics is not None
    assert all(not np.array_equal(x, y) for x, y in itertools.pairwise(calls))
    np.testing.assert_array_equal(with_metrics.motion.rotations, res.motion.rotations)


def test_blendspace_refuses_different_skeletons():
    from blend_testlib import NAMES

    other = walker(duration=1.0, name="x")
    names = tuple(n.replace("Spine", "Chest") for n in NAMES)
    other = other.replace(skeleton=other.skeleton.__class__(
        names, other.skeleton.parents, other.skeleton.offsets, other.skeleton.channels,
        other.skeleton.end_site_parents, other.skeleton.end_site_offsets,
    ))  # fmt: skip
    ms = [walker(duration=1.0, speed=s, name=f"w{s}") for s in (1.0, 1.5)] + [other]
    with pytest.raises(OptionError, match="skeleton"):
        blendspace(ms)


@pytest.mark.mocap
def test_bandai_speed_sweep(mocap_dir):
    d = mocap_dir / "bandai"
    files = [d / f"dataset-1_{k}_normal_001.bvh" for k in ("walk", "run", "dash")]
    space = blendspace(files, one_cycle=True)
    assert space.params[0] < 2.0 < space.params[1] < space.params[2]
    speeds = [motion_speed(space.at(p).motion) for p in np.linspace(space.params[0], space.params[-1], 5)]
    assert (np.diff(speeds) > 0).all()
