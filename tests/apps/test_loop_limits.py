"""Tests of joint limits (issue 11): the ASF limits on the motion, DOF angles and their
derivative, the limit report, and loops that stay within the limits the input respects."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from loop_testlib import chain_skeleton

from elastic_motion.apps.loop import loop_motion
from elastic_motion.apps.loop.contact_grid import GridLift, contact_grid, lift_correction
from elastic_motion.apps.loop.limits import (
    AT_LIMIT_NOTE,
    INPUT_VIOLATES_NOTE,
    REPORTED_ONLY_NOTE,
    LimitConstraints,
    PinSchedule,
    StackedConstraints,
    joint_limit_report,
    limits_report,
    measured_on_frames,
)
from elastic_motion.apps.report import jsonable
from elastic_motion.errors import OptionError
from elastic_motion.groups import SO3
from elastic_motion.motion import Motion, read_motion, select_frames
from elastic_motion.motion.asfamc import _extrinsic, read_amc, read_asf, read_joint_limits
from elastic_motion.motion.joint_limits import (
    JointLimits,
    check_joint_limits,
    dof_angles,
    dof_angles_jacobian,
    dof_angles_with_jacobian,
)
from elastic_motion.notes import of_kind

SO3G = SO3()
AXES = ["XYZ", "ZXY", "YZX", "XZ", "ZY", "X", "Y", "Z"]


def random_frame(rng):
    return SO3G.exp(rng.normal(size=3))


@pytest.mark.parametrize("axes", AXES)
def test_dof_angles_invert_the_amc_reader(axes):
    """Angles in the AMC reader's convention come back exactly (independent: ``_extrinsic``)."""
    rng = np.random.default_rng(1)
    c = random_frame(rng)
    ang = rng.uniform(-1.3, 1.3, size=(50, len(axes)))
    rot = c @ _extrinsic(ang, axes) @ c.T
    np.testing.assert_allclose(dof_angles(rot, c, axes), ang, atol=1e-10)


@pytest.mark.parametrize("axes", AXES)
def test_dof_angles_jacobian_matches_finite_differences(axes):
    rng = np.random.default_rng(2)
    c = random_frame(rng)
    rot = SO3G.exp(rng.normal(scale=0.8, size=(6, 3)))
    jac = dof_angles_jacobian(rot, c, axes)
    eps = 1e-6
    for i in range(3):
        w = np.zeros(3)
        w[i] = eps
        fd = (dof_angles(SO3G.exp(w) @ rot, c, axes) - dof_angles(SO3G.exp(-w) @ rot, c, axes)) / (2 * eps)
        np.testing.assert_allclose(jac[..., i], fd, atol=1e-7)


@pytest.mark.parametrize("axes", ["XYZ", "ZX", "Y"])
def test_dof_angles_with_jacobian_is_both_from_one_decomposition(axes):
    """With bounds (the 3-dof choice of solution) as without: the same angles as
    :func:`dof_angles` (the Jacobian is :func:`dof_angles_jacobian`'s, checked by finite
    differences above)."""
    rng = np.random.default_rng(5)
    c = random_frame(rng)
    rot = SO3G.exp(rng.normal(scale=1.5, size=(9, 3)))
    lo, hi = np.radians([-30.0, -80.0, -10.0]), np.radians([40.0, 20.0, 170.0])
    for bounds in ((), (lo, hi)):
        ang, jac = dof_angles_with_jacobian(rot, c, axes, *bounds)
        np.testing.assert_array_equal(ang, dof_angles(rot, c, axes, *bounds))
        assert ang.shape == (9, len(axes)) and jac.shape == (9, len(axes), 3)


KNEE_FRAME = SO3G.exp(np.array([0.0, 0.5, 0.2]))


def knee_limits(lo_deg=-15.0, hi_deg=60.0):
    return JointLimits(
        ("knee", "hip"),
        ("X", "XZ"),
        np.stack([KNEE_FRAME, np.eye(3)]),
        (np.radians([lo_deg]), np.radians([-90.0, -90.0])),
        (np.radians([hi_deg]), np.radians([90.0, 90.0])),
    )


def drifting_clip(f=60):
    """The knee's DOF angle ``40 t - 30 sin(pi t)`` degrees (min -12.8) ends 40 degrees above
    its start: closing takes off a ramp and pushes it to about -30 degrees."""
    t = np.linspace(0.0, 1.0, f)
    knee = np.radians(40 * t - 30 * np.sin(np.pi * t))
    rot = np.tile(np.eye(3), (f, 4, 1, 1))
    rot[:, 2] = KNEE_FRAME @ _extrinsic(knee[:, None], "X") @ KNEE_FRAME.T
    rot[:, 1] = SO3G.exp(np.outer(np.sin(2 * np.pi * t), [0.3, 0.0, 0.1]))  # closed already
    root = np.tile([0.0, 0.9, 0.0], (f, 1))
    return Motion(chain_skeleton(), 30.0, root, rot, metres_per_unit=1.0, name="drift")


def test_limit_rows_and_stacking_match_finite_differences():
    rng = np.random.default_rng(3)
    m = drifting_clip(12)
    lim = knee_limits()
    rot = m.rotations @ SO3G.exp(rng.normal(scale=0.1, size=(12, 4, 3)))
    eu = m.root_translation
    rows = LimitConstraints(lim, m.skeleton.names, np.array([3, 5, 7]), np.array([0, 1, 2]), np.zeros(3))
    g, frames, d_rot, d_eu = rows.evaluate(rot, eu)
    ang = lim.angles(rot, m.skeleton.names)
    np.testing.assert_allclose(g, ang[[3, 5, 7], [0, 1, 2]], atol=1e-12)
    eps = 1e-6
    for r in range(3):
        f, j = frames[r, 0], rows.joint[r]
        for i in range(3):
            w = np.zeros(3)
            w[i] = eps
            rp, rm = rot.copy(), rot.copy()
            rp[f, j] = SO3G.exp(w) @ rot[f, j]
            rm[f, j] = SO3G.exp(-w) @ rot[f, j]
            fd = (rows.residual(rp, eu)[r] - rows.residual(rm, eu)[r]) / (2 * eps)
            assert abs(d_rot[r, 0, j, i] - fd) < 1e-7
        others = np.delete(np.arange(4), j)
        assert np.all(d_rot[r, 0, others] == 0) and np.all(d_eu == 0)
    both = StackedConstraints(rows, LimitConstraints(lim, m.skeleton.names, [4], [0], [0.1]))
    g2, fr2, dr2, de2 = both.evaluate(rot, eu)
    assert len(both) == 4 and fr2.shape == (4, 1) and dr2.shape == (4, 1, 4, 3) and de2.shape == (4, 1, 3)
    np.testing.assert_allclose(g2[:3], g)


def test_constrained_loop_stays_within_a_tight_limit_the_unconstrained_one_crosses():
    m = drifting_clip()
    lim = knee_limits()
    free = loop_motion(m, root="inplace", joint_limits="off", seam="c0", window=None, force=True)
    knee_free = np.degrees(lim.angles(free.motion.rotations, m.skeleton.names)[:, 0])
    assert knee_free.min() < -25  # closing pushes the knee 10 degrees past its limit
    kept = loop_motion(m, root="inplace", joint_limits=lim, seam="c0", window=None, force=True)
    knee = np.degrees(lim.angles(kept.motion.rotations, m.skeleton.names)[:, 0])
    assert knee.min() >= -15 - 0.5 and knee.max() <= 60 + 0.5  # limit_tol: 0.5 degrees
    assert kept.seam_after.seam_angle_max_deg < 1e-3
    jl = kept.joint_limits
    assert jl.mode == "keep" and jl.pinned > 0 and jl.pinned_joints == ("knee",)
    assert jl.new_violations == () and jl.before.ok and jl.after.ok
    s = json.loads(json.dumps(jsonable(kept.summary())))["joint_limits"]
    assert "knee" in s["joints_at_limit"] and s["input_violations"] == []
    (at_limit,) = of_kind(kept.notes, AT_LIMIT_NOTE)
    assert "knee" in at_limit.data["joints"] and "knee" in str(at_limit)
    # the limit costs change: the constrained loop is farther from the input than the free one
    assert kept.closing.change > free.closing.change
    # "report" reads the limits of the clip's ASF file: a synthetic clip has none
    assert loop_motion(m, root="inplace", joint_limits="report", window=None, force=True).joint_limits is None


def test_limits_the_input_violates_are_reported_not_enforced():
    m = drifting_clip()
    lim = knee_limits(lo_deg=-5.0)  # the input itself goes to -12.8 degrees
    res = loop_motion(m, root="inplace", joint_limits=lim, window=None, force=True)
    jl = res.joint_limits
    assert [h.joint for h in jl.before.violations] == ["knee"]
    assert jl.before.violations[0].worst_deg == pytest.approx(7.8, abs=0.2)
    (violates,) = of_kind(res.notes, INPUT_VIOLATES_NOTE)
    assert violates.data["dofs"] == ["knee.rx"] and "the input violates" in str(violates)
    assert res.closing.converged


def test_bad_joint_limits_option():
    with pytest.raises(OptionError, match="joint_limits"):
        loop_motion(drifting_clip(), joint_limits="sometimes", window=None, force=True)
    with pytest.raises(OptionError, match="limits"):
        joint_limit_report(drifting_clip())


CMU = [("02.asf", "02_01.amc"), ("backflip.asf", "backflip.amc"), ("charleston.asf", "charleston1.amc")]


@pytest.mark.parametrize(("asf", "amc"), CMU)
def test_cmu_limits_on_the_motion_and_the_amc_angles(mocap_dir, asf, amc):
    folder = mocap_dir / "cmu" / "asfamc"
    a = read_asf(folder / asf)
    m = read_amc(a, folder / amc)
    lim = read_joint_limits(m)
    assert lim is not None and lim.source == str(folder / asf) and "lfemur" in lim.joints
    k = lim.joints.index("lfemur")
    np.testing.assert_allclose(
        np.degrees([lim.lower[k], lim.upper[k]]).T, a.limits[a.skeleton.index("lfemur")]
    )
    # the DOF angles of the read rotations are the AMC values (mod 360; the other Euler
    # solution where it is less beyond the range): same rotation either way
    ang = lim.angles(m.rotations, m.skeleton.names)
    cols = np.cumsum([0, *(len(x) for x in lim.axes)])
    for j, name in enumerate(lim.joints):
        c = lim.frames[j]
        back = c @ _extrinsic(ang[:, cols[j] : cols[j + 1]], lim.axes[j]) @ c.T
        np.testing.assert_allclose(back, m.rotations[:, m.skeleton.index(name)], atol=1e-9)
    rep = check_joint_limits(m, lim)  # real clips go beyond some of their own limits
    assert not rep.ok and rep.summary()["joints_beyond_limit"]


def test_cmu_02_01_amc_values_are_the_dof_angles(mocap_dir):
    folder = mocap_dir / "cmu" / "asfamc"
    m = read_amc(read_asf(folder / "02.asf"), folder / "02_01.amc")
    lim = read_joint_limits(m)
    vals: dict[str, list] = {}
    for line in (folder / "02_01.amc").read_text().splitlines():
        t = line.split()
        if t and t[0] in lim.joints:
            vals.setdefault(t[0], []).append([float(v) for v in t[1:]])
    raw = np.concatenate([np.array(vals[j]) for j in lim.joints], axis=1)
    ang = np.degrees(lim.angles(m.rotations, m.skeleton.names))
    np.testing.assert_allclose((ang - raw + 180) % 360 - 180, 0, atol=1e-9)


def test_cmu_backflip_loop_keeps_its_limits_on_the_written_bvh(mocap_dir, tmp_path):
    path = mocap_dir / "cmu" / "asfamc" / "backflip.amc"
    free = loop_motion(path, joint_limits="report", window=None, force=True)
    assert free.joint_limits.new_violations  # the plain loop crosses limits the input respects
    res = loop_motion(path, joint_limits="keep", window=None, force=True)
    jl = res.joint_limits
    assert jl.mode == "keep" and jl.new_violations == () and jl.pinned > 0
    # the probes find most of the active set before a round is solved: 3 rounds without them
    assert jl.probes >= 1 and jl.rounds <= 2
    assert jl.before.violations  # the input's own violations: reported
    out = tmp_path / "loop.bvh"
    import elastic_motion as em

    em.write(res, out)
    written = read_motion(out)
    lim = read_joint_limits(free.original)
    before = check_joint_limits(res.original, lim)
    after = check_joint_limits(written, lim)
    # limit_tol 0.5 degrees (pins every 0.1 s: the loop may bulge between them), BVH rounding
    new = (after.excess > math.radians(0.5 + 1e-4)) & (before.excess <= math.radians(0.5))
    new[[0, -1]] = False
    assert not new.any()
    assert res.seam_after.seam_angle_max_deg < 1e-3
    s = json.loads(em.to_json(res))["joint_limits"]
    assert s["mode"] == "keep" and s["joints_at_limit"] and s["input_violations"]
    assert (s["rounds"], s["probes"]) == (jl.rounds, jl.probes)


def test_limits_kept_only_with_the_kkt_projection_of_the_lie_curve():
    """Given limits with the Euler baseline are reported, not kept, and a note of kind
    ``loop.limits_reported_only`` says why."""
    res = loop_motion(
        drifting_clip(), root="inplace", joint_limits=knee_limits(), method="euler", window=None, force=True
    )
    assert res.joint_limits.mode == "report" and res.method == "euler-elastic"
    (note,) = of_kind(res.notes, REPORTED_ONLY_NOTE)
    assert str(note) == "joint limits: reported only (keeping them needs method='lie' and solver='kkt')"


def _knee_loop_with_limit_solves(monkeypatch, replace):
    """The drifting clip looped within :func:`knee_limits`, every solve with limit rows (not
    the probes) passed through ``replace(result, kwargs)``; checks that the loop kept its
    limits and closed, and returns it."""
    import elastic_motion.apps.loop.close as close_module

    real = close_module.project_closed

    def patched(curve, **kw):
        res = real(curve, **kw)
        probe = kw["max_iter"] == PinSchedule().probe  # (a probe: where the pins take the loop)
        if isinstance(kw.get("extra"), (LimitConstraints, StackedConstraints)) and not probe:  # pins
            return replace(res, kw)
        return res

    monkeypatch.setattr(close_module, "project_closed", patched)
    m, lim = drifting_clip(), knee_limits()
    kept = loop_motion(m, root="inplace", joint_limits=lim, seam="c0", window=None, force=True)
    jl = kept.joint_limits
    assert jl.message == "" and jl.new_violations == () and jl.pinned > 0
    knee = np.degrees(lim.angles(kept.motion.rotations, m.skeleton.names)[:, 0])
    assert knee.min() >= -15 - 0.5
    assert kept.closing.converged and kept.seam_after.seam_angle_max_deg < 1e-3
    return kept


def test_limits_solve_stalled_at_the_rounding_floor_is_closed_from_there(monkeypatch):
    """Issue 33 (CMU backflip, default window): limits solves that stop with the seam shut but
    the optimality residual at the rounding floor (1e-7) counted as failed; each was retried
    with sparser pins that were the same pins, up to 6 solves of ``max_iter`` iterations (30x
    the time), and the loop kept none of the limits. Such a solve is now closed exactly from
    where it stopped and kept. Simulated: every solve with limit rows reports that stall."""
    import dataclasses

    calls = []

    def stalling(res, kw):
        calls.append(len(kw["extra"]))
        stalled = "stalled at KKT residual 9e-08 (rounding floor)"
        return dataclasses.replace(res, converged=False, message=stalled)

    _knee_loop_with_limit_solves(monkeypatch, stalling)
    assert len(calls) <= 2  # a solve with pins, a second when a round adds some; no retries


def test_limits_solve_whose_warm_start_runs_out_is_solved_from_the_clip(monkeypatch):
    """A round warm-started from the loop without limit rows that uses up its iterations
    without settling (CMU backflip's second round once did: 16 iterations, the loop 5x farther
    from the clip) is solved again from the clip itself, and that solve is kept. Simulated:
    every warm-started solve with limit rows reports running out."""
    import dataclasses

    calls = []

    def wandering(res, kw):
        warm = kw.get("start") is not None
        calls.append(warm)
        if warm:
            ran_out = {"iterations": kw["max_iter"], "message": "reached max_iter"}
            return dataclasses.replace(res, converged=False, **ran_out)
        return res

    _knee_loop_with_limit_solves(monkeypatch, wandering)
    # each round: warm, ran out, then from the clip
    assert len(calls) >= 2 and calls == [True, False] * (len(calls) // 2)


@pytest.mark.parametrize("lo_deg", [-15.0, 0.0])
def test_probes_pin_what_the_rounds_would_and_no_more(monkeypatch, lo_deg):
    """The probes (one iteration with a round's pins) only bring pins forward: the loop pins
    the same frames, and is as far from the clip, with and without them. One iteration
    overshoots by a degree or so on this knee; pinned, those crossings (30 pins instead of 12)
    moved the loop 0.8 % farther from the clip (``PinSchedule.probe_margin_deg``)."""
    import functools

    import elastic_motion.apps.loop.close as close_module

    m, lim = drifting_clip(), knee_limits(lo_deg=lo_deg)
    runs = {}
    for probe in (1, 0):
        monkeypatch.setattr(close_module, "PinSchedule", functools.partial(PinSchedule, probe=probe))
        res = loop_motion(m, root="inplace", joint_limits=lim, seam="c0", window=None, force=True)
        runs[probe] = res
    with_probes, without = runs[1].joint_limits, runs[0].joint_limits
    assert with_probes.probes >= 1 and without.probes == 0
    assert with_probes.pinned == without.pinned and with_probes.new_violations == ()
    assert runs[1].closing.change == pytest.approx(runs[0].closing.change, rel=1e-6)


def test_limit_rows_on_a_grid_hold_the_lifted_loop_at_the_clips_frames():
    """Issue 33: kept limits are solved on the kept contacts' grid. A row's rotation is the
    clip's at its own frame with the grid's correction lifted (as ``lift_correction`` writes
    it), so a frame between grid frames is pinned where the written loop has it; its
    derivative is the geodesic's weights on the two grid frames (exact on a grid frame)."""
    m = drifting_clip(61)
    lim = knee_limits()
    grid = contact_grid(m.n_frames, 120.0, 1 / 30)  # every 4th frame
    before = select_frames(m, grid)
    rng = np.random.default_rng(4)
    w = rng.normal(size=(4, 3)) * 0.05
    t = grid / (m.n_frames - 1)
    after = before.replace(rotations=SO3G.exp(np.sin(np.pi * t)[:, None, None] * w[None]) @ before.rotations)
    lift = GridLift(grid, before.rotations, m.rotations)
    lifted = lift_correction(m, grid, before, after).rotations
    np.testing.assert_allclose(lift.rotations(after.rotations), lifted, atol=1e-12)
    frames = np.array([grid[3], grid[3] + 1, grid[5] + 2])  # on the grid, between, between
    rows = LimitConstraints(lim, m.skeleton.names, frames, np.array([0, 0, 2]), np.zeros(3), lift)
    eu = after.root_translation
    g, fr, d_rot, d_eu = rows.evaluate(after.rotations, eu)
    ang = lim.angles(lifted, m.skeleton.names)
    np.testing.assert_allclose(g, ang[frames, [0, 0, 2]], atol=1e-12)
    assert fr.tolist() == [[3, -1], [3, 4], [5, 6]] and d_rot.shape == (3, 2, 4, 3) and not d_eu.any()
    eps = 1e-6
    for r in range(3):
        j = rows.joint[r]
        for s in range(2):
            if fr[r, s] < 0:
                continue
            for i in range(3):
                dw = np.zeros(3)
                dw[i] = eps
                rp, rm = after.rotations.copy(), after.rotations.copy()
                rp[fr[r, s], j] = SO3G.exp(dw) @ rp[fr[r, s], j]
                rm[fr[r, s], j] = SO3G.exp(-dw) @ rm[fr[r, s], j]
                fd = (rows.residual(rp, eu)[r] - rows.residual(rm, eu)[r]) / (2 * eps)
                # exact on the grid frame; between, first order in the correction's turn
                assert abs(d_rot[r, s, j, i] - fd) < (1e-7 if r == 0 else 2e-3), (r, s, i)


@pytest.mark.mocap
def test_cmu_charleston1_loop_keeps_its_limits_with_its_contacts_on_their_grid(mocap_dir, tmp_path):
    """Issue 33: charleston1's best cycle (frames 17..433) kept its contacts on every frame
    when limits were kept, and its contacts and closure are a hair apart (the gap stalls at
    1e-4), so every limits solve failed and the loop crossed a limit the input respects by
    16.5 degrees (in 120 s). Now the limits are solved on the contacts' grid, each stalled
    solve closed exactly from where it stopped as the contacts' own is, and every limit the
    input respects holds on every frame of the written BVH."""
    import elastic_motion as em

    path = mocap_dir / "cmu" / "asfamc" / "charleston1.amc"
    res = loop_motion(path, window=(17, 433), seam="c0", joint_limits="keep", force=True)
    jl, kept = res.joint_limits, res.contacts_kept
    assert jl.mode == "keep" and jl.message == "" and jl.new_violations == () and jl.pinned > 0
    assert kept.dropped is None and kept.grid_frames < res.motion.n_frames  # on the grid
    assert kept.polished  # the contacts' own solve stalled too: closed exactly from there
    assert res.closing.converged and res.seam_after.seam_angle_max_deg < 1e-3
    out = tmp_path / "loop.bvh"
    em.write(res, out)
    lim = read_joint_limits(res.original)
    before = check_joint_limits(res.original, lim)
    after = check_joint_limits(read_motion(out), lim)
    new = (after.excess > math.radians(0.5 + 1e-3)) & (before.excess <= math.radians(0.5))
    new[[0, -1]] = False
    assert not new.any()


def test_limits_solved_on_a_grid_are_measured_on_every_frame_written():
    """A loop solved on a grid and then lifted (and planted by IK) is measured again on every
    frame: a crossing the grid's solve did not see is a new violation and a message (the loop
    did not converge), frames 0 and ``F - 1`` are not counted, and a clean loop keeps the
    solve's message-free record."""
    m = drifting_clip(40)
    lim = knee_limits(lo_deg=-30.0)  # the input (down to -12.8 deg) respects it
    names = m.skeleton.names
    solved = limits_report(m.rotations, m.rotations, names, lim, tol_deg=0.5)
    solved = dataclasses.replace(solved, mode="keep", rounds=1, pinned=3, pinned_joints=("knee",))
    clean = measured_on_frames(solved, m.rotations, names, lim, tol_deg=0.5)
    assert clean.message == "" and clean.new_violations == () and clean.pinned == 3 and clean.rounds == 1
    loop = m.rotations.copy()
    bend = KNEE_FRAME @ _extrinsic(np.radians([[-32.0]]), "X") @ KNEE_FRAME.T
    loop[[0, 17], 2] = bend[0]  # frame 17 between two grid frames, frame 0 never counted
    out = measured_on_frames(solved, loop, names, lim, tol_deg=0.5)
    assert out.new_violations == ("knee.rx",) and out.pinned == 3
    assert out.message == (
        "joint limits: beyond a limit on the written frames (between the grid's frames or after the IK) "
        "by up to 2.00 deg: knee.rx"
    )
    assert out.after.excess[0].max() > 0  # frame 0 is beyond too, but not a new violation
    loop[17, 2] = m.rotations[17, 2]
    assert measured_on_frames(solved, loop, names, lim, tol_deg=0.5).message == ""
