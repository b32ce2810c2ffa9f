"""Joint limits in blends and means (issue 33): the result within the limits the inputs respect,
limits the inputs violate reported and not enforced, the option's forms and JSON."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from elastic_motion.apps.blend import BlendOptions, blend_motions
from elastic_motion.apps.database.mean import MeanOptions, mean_motion
from elastic_motion.apps.limit_stage import LIMITS_CHANGED_NOTE, LIMITS_INPUT_VIOLATES_NOTE
from elastic_motion.apps.loop import LoopOptions
from elastic_motion.errors import OptionError
from elastic_motion.groups import SO3
from elastic_motion.motion import read_motion, write_motion
from elastic_motion.motion.joint_limits import JointLimits, check_joint_limits, project_to_limits
from elastic_motion.notes import of_kind

NORMAL = "dataset-1_walk_normal_001.bvh"
TIRED = "dataset-1_walk_tired_001.bvh"


@pytest.fixture(scope="module")
def bandai(mocap_dir):
    a, b = mocap_dir / "bandai" / NORMAL, mocap_dir / "bandai" / TIRED
    free = blend_motions([a, b], 0.5, joint_limits="off", metrics=False)
    names = [n for n in free.motion.skeleton.names if n != "joint_Root"]
    return a, b, free, JointLimits.range_of(free.prepared.motions, names)


def test_a_motions_own_range_holds_it_exactly_and_no_more(bandai):
    """``JointLimits.range_of``: each motion inside (its DOF extremes are the bounds, touched,
    never crossed), and a motion turned a little further at one joint crosses them."""
    _, _, free, box = bandai
    for m in free.prepared.motions:
        assert check_joint_limits(m, box).ok
    m = free.prepared.motions[0]
    k = m.skeleton.index(box.joints[0])
    rot = m.rotations.copy()
    rot[:, k] = rot[:, k] @ SO3().exp(np.array([0.2, 0.0, 0.0]))  # 11.5 deg more about x, every frame
    assert not check_joint_limits(m.replace(rotations=rot), box).ok
    lo, hi = box.lower[0], box.upper[0]
    ang = np.concatenate([box.angles(x.rotations, x.skeleton.names)[:, :3] for x in free.prepared.motions])
    assert np.allclose(ang.min(axis=0), lo) and np.allclose(ang.max(axis=0), hi)


def test_blend_stays_within_tight_limits_the_plain_blend_crosses(bandai, tmp_path):
    """The inputs' own range as limits: the plain blend (its contact clean-up's leg IK) bends
    the right knee past it; the kept one, written to BVH and read back, does not."""
    a, b, free, lim = bandai
    crossed = {h.joint for h in check_joint_limits(free.motion, lim).violations}
    assert "LowerLeg_R" in crossed
    res = blend_motions([a, b], 0.5, joint_limits=lim, metrics=False)
    jl = res.joint_limits
    assert jl.mode == "keep" and not any(r.violations for r in jl.inputs)
    assert jl.after.ok and not jl.exempt.any()
    assert {r["joint"] for r in jl.changed()} >= crossed
    assert 0 < jl.changed_frames < res.motion.n_frames and 0.3 < jl.max_change_deg < 5
    (note,) = of_kind(res.notes, LIMITS_CHANGED_NOTE)
    assert note.data["frames"] == jl.changed_frames
    out = write_motion(res.motion, tmp_path / "blend.bvh")
    back = check_joint_limits(read_motion(out), lim)
    assert back.ok, back.summary()["violations"]
    summary = json.loads(json.dumps(res.summary()))["joint_limits"]
    assert summary["changed_frames"] == jl.changed_frames and summary["after"]["violations"] == []
    # eased: the change is continuous, no frame-to-frame jump larger than the plain blend's
    step = np.abs(np.diff(jl.change, axis=0)).max()
    assert step < 0.5 * np.abs(jl.change).max()


def test_limits_the_inputs_violate_are_reported_not_enforced(bandai):
    a, b, _, box = bandai
    k = box.joints.index("LowerLeg_R")
    lo, hi = box.lower[k].copy(), box.upper[k].copy()
    hi[1] = 0.5 * (lo[1] + hi[1])  # the knee's ry: half its range, both inputs go beyond
    lim = JointLimits(("LowerLeg_R",), ("XYZ",), box.frames[k : k + 1], (lo,), (hi,))
    res = blend_motions([a, b], 0.5, joint_limits=lim, metrics=False)
    jl = res.joint_limits
    assert jl.exempt_dofs == ("LowerLeg_R.ry",)
    (note,) = of_kind(res.notes, LIMITS_INPUT_VIOLATES_NOTE)
    assert note.data["dofs"] == ["LowerLeg_R.ry"]
    beyond = jl.after.excess > math.radians(jl.after.tol_deg)
    assert beyond[:, 1].sum() > 10  # not enforced where an input violates it ...
    assert not (beyond & ~jl.exempt).any()  # ... enforced everywhere else
    assert jl.after.excess[:, 1].max() > math.radians(20)  # the knee still bends as the inputs do


def test_mean_stays_within_the_limits(mocap_dir):
    files = [mocap_dir / "bandai" / NORMAL, mocap_dir / "bandai" / TIRED]
    free = mean_motion(files, n_samples=24, max_iter=3, joint_limits="off")
    m = free.motion
    names = [n for n in m.skeleton.names if n != "joint_Root"]
    box = JointLimits.range_of([m], names)
    # the mean's own range shrunk by 2 degrees: the inputs violate some of it, not all
    lim = JointLimits(
        box.joints,
        box.axes,
        box.frames,
        tuple(v + 0.035 for v in box.lower),
        tuple(v - 0.035 for v in box.upper),
    )
    assert not check_joint_limits(m, lim).ok
    res = mean_motion(files, n_samples=24, max_iter=3, joint_limits=lim)
    jl = res.joint_limits
    assert jl.changed_frames > 0
    beyond = jl.after.excess > math.radians(jl.after.tol_deg)
    assert beyond.any() == jl.exempt.any() and not (beyond & ~jl.exempt).any()
    assert json.loads(json.dumps(res.summary()))["joint_limits"]["changed_frames"] == jl.changed_frames


def knee_limits():
    frame = SO3().exp(np.array([0.1, 0.4, -0.2]))
    return JointLimits(
        ("knee", "hip"),
        ("X", "XZ"),
        np.stack([frame, np.eye(3)]),
        (np.radians([0.0]), np.array([-math.inf, -1.0])),
        (np.radians([150.0]), np.array([1.0, math.inf])),
        "test",
    )


def test_options_take_the_loops_forms_and_round_trip_through_json(mocap_dir):
    lim = knee_limits()
    mean = MeanOptions(joint_limits=lim)
    back = MeanOptions.from_json(json.loads(json.dumps(mean.to_json())))
    assert back.joint_limits.to_json() == lim.to_json()
    blend = json.loads(json.dumps(BlendOptions(joint_limits=lim).to_json()))
    assert JointLimits.from_json(blend["joint_limits"]).to_json() == lim.to_json()
    assert (
        BlendOptions().joint_limits == "keep"
        and MeanOptions(joint_limits="report").to_json()["joint_limits"] == "report"
    )
    asf = mocap_dir / "cmu" / "asfamc" / "02.asf"
    from_file = BlendOptions(joint_limits=str(asf)).joint_limits
    assert isinstance(from_file, JointLimits) and "ltibia" in from_file.joints
    assert isinstance(LoopOptions(joint_limits=asf).joint_limits, JointLimits)  # the loop's option too
    for bad in ("sometimes", 3, "walk.bvh"):
        with pytest.raises(OptionError, match="joint_limits"):
            BlendOptions(joint_limits=bad)
        with pytest.raises(OptionError, match="joint_limits"):
            MeanOptions(joint_limits=bad)


def test_projection_is_exact_and_keeps_the_other_axes():
    """Every dof within its range after the projection (to rounding); the angle about the knee's
    missing axes unchanged; untouched frames bit for bit; easing spreads the change."""
    rng = np.random.default_rng(3)
    so3 = SO3()
    rot = so3.exp(np.cumsum(rng.normal(scale=0.08, size=(120, 2, 3)), axis=0))
    lim = knee_limits()
    names = ["knee", "hip"]
    assert not check_joint_limits(rot, lim, names=names).ok
    for ease in (0, 4):
        out, change = project_to_limits(rot, names, lim, ease_frames=ease)
        assert check_joint_limits(out, lim, names=names, tol_deg=1e-6).ok
        same = ~(np.abs(change) > 0).any(axis=1)
        assert np.array_equal(out[same], rot[same])
    plain = project_to_limits(rot, names, lim)[1]
    eased = project_to_limits(rot, names, lim, ease_frames=4)[1]
    assert (np.abs(eased) > 0).sum() > (np.abs(plain) > 0).sum()
    assert np.all(np.abs(eased) >= np.abs(plain) - 1e-12)


def test_cli_flags_mirror_the_loops(mocap_dir, tmp_path, capsys):
    """``--joint-limits`` on blend, mean and loop: a policy or an .asf file; the mean's report
    says what the stage did, with the limits of the inputs' ASF file."""
    from elastic_motion.cli import build_parser, main

    asf = str(mocap_dir / "cmu" / "asfamc" / "02.asf")
    for command in ("blend", "mean", "loop"):
        parser = build_parser()
        base = {"blend": ["blend", "a.bvh", "b.bvh"], "mean": ["mean", "a.bvh"], "loop": ["loop", "a.bvh"]}
        args = parser.parse_args([*base[command], "-o", "x.bvh", "--joint-limits", asf])
        assert args.joint_limits == asf
        with pytest.raises(SystemExit):
            parser.parse_args([*base[command], "-o", "x.bvh", "--joint-limits", "sometimes"])
    capsys.readouterr()
    files = [str(mocap_dir / "cmu" / "asfamc" / f"charleston{k}.amc") for k in (1, 2)]
    out = tmp_path / "mean.bvh"
    argv = ["mean", *files, "-o", str(out), "--samples", "24", "--max-iter", "2", "--joint-limits", "report"]
    assert main([*argv, "--json", "-q"]) == 0, capsys.readouterr().err
    report = json.loads(capsys.readouterr().out)
    jl = report["joint_limits"]
    assert jl["mode"] == "report" and jl["source"].endswith("charleston.asf") and jl["changed_frames"] == 0
    assert "lwrist.ry" in jl["exempt_dofs"]  # charleston's inputs violate it: reported
