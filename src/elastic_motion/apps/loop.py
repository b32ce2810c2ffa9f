"""Seamless loops of motions (paper 000, sec. 5.4) with the loop convention of game engines.

Conventions
-----------
* **Cycle and cycle transform.** A looping clip (a *cycle*) of ``F`` frames is played with
  its last frame dropped: the next cycle starts where the last frame was. The next cycle is
  the clip moved by the *cycle transform* ``T``, a rigid map of the world applied to the
  root (position and orientation; joint-local rotations are unchanged):

  - ``root="travel"``: ``T`` rotates about the up axis by the clip's heading change
    ``delta`` (the twist about the up axis of ``R_root[F-1] R_root[0]^T``, in radians) and
    moves the floor-plane root position of frame 0 to that of frame ``F-1``:
    ``T(x) = Y(delta) (x - floor(p_0)) + floor(p_{F-1})`` (``floor`` zeroes the up
    coordinate). The character travels on (and turns) from cycle to cycle.
  - ``root="inplace"``: ``T`` is the identity; the clip must come back to its start.

  A clip is a seamless (C0) loop when its last frame equals ``T`` applied to its first.
* **What closes** (:func:`loop_motion`), on the Lie curve ``R^3 x SO(3)^J``
  (:func:`elastic_motion.motion.to_lie_curve`, with its default weights):

  - ``"travel"``: every joint's local rotation (excluded joints stay free: by default the
    finger and thumb joints, whose CMU data flips by 180 degrees between frames); the root
    orientation *relative to heading*, i.e. up to a rotation about the up axis (the swing
    residual of :mod:`elastic_motion.closing`); the root height. The floor-plane root
    trajectory keeps its samples, so the displacement of one cycle is kept.
  - ``"inplace"``: all of it, floor position and heading too (paper 000's closing).

  The first frame never changes.
* **Preparation**: the input goes through the one preparation step
  (:func:`elastic_motion.apps.prepare.prepare_motions`: T-pose frame, trim, static root
  folded, metres, Y-up), so a path and a ``Motion`` give the same loop as the command line.
* **Euler baseline** (``method="euler-elastic"``): the same motion as continuous Euler
  angles in ``R^(3+3J)`` (:func:`elastic_motion.motion.to_euler_curve`, with the Lie
  curve's weights on the coordinates), closed by the Newton projection of paper 001,
  Thm. 2 (:func:`elastic_motion.closing.project_closed_rd`; C1 by
  :func:`elastic_motion.closing.close_curve`). In ``"travel"`` it closes the root height,
  every joint's three angles and the root's three angles -- except the root's outermost
  angle when that is about the up axis (then it *is* the heading and stays free). Euler
  angles have no heading coordinate otherwise, so a turning clip is turned back.
* **Units** of the metrics: angles in degrees, positions in metres when the motion's
  ``metres_per_unit`` is known (else in its length unit), times in seconds.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from elastic_motion import limits
from elastic_motion._threads import single_threaded_blas
from elastic_motion.apps.cleanup import cleanup_footskate, find_arms, find_legs
from elastic_motion.apps.loop_contacts import (
    ContactConstraints,
    contact_grid,
    fine_contacts,
    floor_rows,
    grid_step,
    lift_correction,
    row_plants,
)
from elastic_motion.apps.loop_limits import LoopLimits, limits_report, solve_within_limits
from elastic_motion.apps.loop_window import CycleWindow, cycle_candidates
from elastic_motion.apps.metrics import ContactSkating, SeamMetrics, contact_skating, seam_metrics
from elastic_motion.apps.prepare import (
    PreparedMotions,
    PrepareOptions,
    Source,
    output_motion,
    prepare_motions,
)
from elastic_motion.apps.progress import Progress
from elastic_motion.closing import ClosingResult, close_curve, project_closed, project_closed_rd
from elastic_motion.curves import DiscreteCurve, srv_distance, srv_transform
from elastic_motion.errors import OptionError
from elastic_motion.groups import SO3, Euclidean
from elastic_motion.motion import (
    Motion,
    finger_joints,
    forward_kinematics,
    from_euler_curve,
    from_lie_curve,
    lift_out_of_floor,
    select_frames,
    to_euler_curve,
    to_lie_curve,
)
from elastic_motion.motion.contacts import MISSED_STANCES_NOTE, ContactOptions, Contacts, detect_contacts
from elastic_motion.motion.joint_limits import JointLimits
from elastic_motion.motion.looping import (
    check_loop_motion,
    check_root,
    cycle_transform,
    on_belt,
    repeat_motion,
    treadmill,
    twist_angle,
)

__all__ = [
    "CLOSING_SOLVERS",
    "LOOP_CONTACTS",
    "LOOP_METHODS",
    "LoopResult",
    "SeamMetrics",
    "cycle_transform",
    "loop_motion",
    "repeat_loop",
    "repeat_motion",
    "seam_metrics",
    "treadmill",
]

_SO3 = SO3()
_AXES = "xyz"
#: What is closed: the Lie group curve (the method) or the Euler-angle curve (the baseline).
LOOP_METHODS = ("lie", "euler-elastic")
#: Closing solvers: ``"kkt"`` the closed curve nearest the input
#: (:func:`elastic_motion.closing_kkt.project_closed`), ``"gauss-newton"`` / ``"gradient"``
#: the flows of :func:`elastic_motion.closing.close_curve` (closed, nearest to first order).
CLOSING_SOLVERS = ("kkt", "gauss-newton", "gradient")
#: What the loop does with contacts: keep them (constraints of the projection), report
#: them, or ignore them.
LOOP_CONTACTS = ("keep", "report", "off")
#: What the loop does with joint limits (ASF ``limits``): keep them (an active set of the
#: projection, :mod:`elastic_motion.apps.loop_limits`), report them, or ignore them.
LOOP_JOINT_LIMITS = ("keep", "report", "off")
#: Seconds before the seam over which a contact planted on the last frame, of a joint in the
#: air on the first, is kept in the floor plane only: the joint rises there to the first
#: frame's pose without sliding (a foot lifts off in about this time: 0.1-0.2 s in walks).
LIFT_TIME = 0.15
#: How far (metres) a kept-contacts loop may go under the floor where the input itself does
#: (the floor is a robust estimate, the 2nd percentile of the lowest point: the input goes
#: under it on a few frames); deeper, the body is raised there (not on the seam frames).
FLOOR_TOLERANCE = 0.01
#: Rounds of the floor's active set (joints the loop takes under the floor pinned at their
#: deepest frame, solved again) and the most rows it adds.
FLOOR_ROUNDS = 2
MAX_FLOOR_PINS = 40
#: Kept contacts missed by at most this (metres) where the constrained projection stopped
#: short are accepted: the loop is closed exactly from there (``contacts_kept["polished"]``),
#: if that closing keeps them within twice this, and leg IK plants the feet again (a third of
#: the contacts' detection height, 3 cm: a correction IK makes without a visible pose change).
POLISH_MISS = 0.01
#: A polishing closing (above) that stopped with the seam's gap at most this is closed, whatever
#: its optimality residual did (it may stall at the rounding floor).
_POLISH_GAP = 1e-8
#: A loop that skates more than this many times as fast as its input while in contact gets a
#: ``warning:`` note saying why (:func:`_skating_warning`).
SKATING_WARN_RATIO = 1.5
#: A C0 loop whose seam's velocity jump is more than this many times a point's quickest
#: changes inside the clip (:attr:`SeamMetrics.seam_velocity_jump_ratio`) gets a note: a hitch.
HITCH_RATIO = 1.5
#: How the notes on a seam's hitch and on a whipping limb start (:func:`_hitch_note`,
#: :func:`_whip_note`; ``c1="auto"`` reads them off the loops it compares).
HITCH_NOTE = "a hitch at the seam"
WHIP_NOTE = "fast point"
#: A loop whose fastest point moves more than this many times as fast as anything in the
#: input says where (a closing that put its change into a few frames whips a limb there).
WHIP_RATIO = 1.5


@dataclass(frozen=True, eq=False)
class LoopResult:
    """A looped motion (:func:`loop_motion`).

    Attributes
    ----------
    motion : Motion
        The closed cycle: same frames, skeleton and first frame as the prepared input
        (metres when the unit is known, Y-up).
    original : Motion
        The prepared input.
    closing : ClosingResult
        The curve-level result (gap history, iterations, timing; see
        :mod:`elastic_motion.closing`).
    method : {"lie", "euler-elastic"}
    root : {"travel", "inplace"}
    c1 : bool
    closed_joints, free_joints : tuple of str
        Joints whose rotations were closed / left free.
    heading_change : float
        ``delta`` of the result's cycle transform, radians (0 for ``"inplace"``).
    displacement : ndarray, shape (3,)
        Floor-plane root displacement per cycle, motion length units (0 for ``"inplace"``).
    seam_before, seam_after : SeamMetrics
        :func:`seam_metrics` of the input and of the loop (closed joints; ``seam_after``
        with the deviation from the input).
    prepared : PreparedMotions
        The preparation step's result (its ``inputs[0]`` says what was done).
    notes : tuple of str
    skating_before, skating_after : ContactSkating or None
        Skating and depth below the floor during the input's contacts, input and loop.
    skating_on_treadmill : ContactSkating or None
        In place with contacts kept (a treadmill, :func:`treadmill`): the loop's skating with
        the belt's motion taken out (:func:`on_belt`), how much the feet slip on it;
        ``skating_after`` is in the world, where planted feet move back with the belt.
    """

    motion: Motion
    original: Motion
    closing: ClosingResult
    method: str
    root: str
    c1: bool
    closed_joints: tuple[str, ...]
    free_joints: tuple[str, ...]
    heading_change: float
    displacement: np.ndarray
    seam_before: SeamMetrics
    seam_after: SeamMetrics
    prepared: PreparedMotions
    notes: tuple[str, ...] = ()
    window: CycleWindow | None = None
    contacts: Contacts | None = None
    skating_before: ContactSkating | None = None
    skating_after: ContactSkating | None = None
    contacts_kept: dict | None = None
    joint_limits: LoopLimits | None = None
    skating_on_treadmill: ContactSkating | None = None

    def summary(self) -> dict:
        """JSON-ready fields of a report (``docs/cli.md``)."""
        c = self.closing
        return {
            "root": self.root,
            "method": self.method,
            "c1": self.c1,
            "frames": self.motion.n_frames,
            "fps": self.motion.fps,
            "closed_joints": list(self.closed_joints),
            "free_joints": list(self.free_joints),
            "heading_change_deg": math.degrees(self.heading_change),
            "displacement_m": self.displacement.tolist(),
            "closing": {
                "solver": c.method,
                "change_srv_l2": c.change,
                "kkt_residual": c.kkt_residual,
                "gap_initial": c.gap_initial,
                "gap": c.gap,
                "velocity_gap_initial": c.velocity_gap_initial,
                "velocity_gap": c.velocity_gap,
                "iterations": c.iterations,
                "converged": c.converged,
                "message": c.message,
                "time_s": c.time,
            },
            "seam_before": self.seam_before.summary(),
            "seam_after": self.seam_after.summary(),
            "window": self.window.summary() if self.window is not None else None,
            "contacts": self.contacts.summary() if self.contacts is not None else None,
            "skating_before": self.skating_before.summary() if self.skating_before is not None else None,
            "skating_after": self.skating_after.summary() if self.skating_after is not None else None,
            "skating_on_treadmill": None
            if self.skating_on_treadmill is None
            else self.skating_on_treadmill.summary(),
            "contacts_kept": self.contacts_kept,
            "joint_limits": self.joint_limits.summary() if self.joint_limits is not None else None,
            "preparation": [dataclasses.asdict(r) for r in self.prepared.inputs],
            "notes": list(self.notes),
        }


# ------------------------------------------------------------------------------------------
# Helpers
# ------------------------------------------------------------------------------------------


def _metres(motion: Motion) -> float:
    return motion.metres_per_unit if motion.metres_per_unit is not None else 1.0


def repeat_loop(result: LoopResult, cycles: int = 3, root: str | None = None) -> Motion:
    """A loop played ``cycles`` times, as ``loop --repeat`` writes it.

    :func:`repeat_motion` of ``result.motion`` with the loop's own ``root`` mode unless one
    is given, expressed in the unit the loop itself is written in (the first input's,
    :attr:`PreparedMotions.units_out`), so that the preview and the loop line up when
    imported side by side.

    Returns
    -------
    Motion
        ``cycles (F - 1) + 1`` frames, in the output unit.
    """
    played = repeat_motion(result.motion, cycles, result.root if root is None else root)
    return output_motion(played, result.prepared.units_out)


def _free(motion: Motion, free: str | Sequence[str] | None) -> list[str]:
    if free is None:
        return []
    if isinstance(free, str):
        if free != "fingers":
            raise OptionError(
                "free_joints", f"expected 'fingers', None or a list of joint names; got {free!r}"
            )
        return list(finger_joints(motion.skeleton))
    names = list(free)
    unknown = [n for n in names if n not in motion.skeleton.names]
    if unknown:
        raise OptionError(
            "free_joints",
            f"expected joint names of the skeleton {list(motion.skeleton.names)}; got unknown {unknown}",
        )
    return names


# ------------------------------------------------------------------------------------------
# Looping
# ------------------------------------------------------------------------------------------


def _solve_with_contacts(
    lie,
    motion: Motion,
    contacts: Contacts,
    *,
    max_release: int,
    solve,
    c1: bool = False,
    more_rows: Sequence = (),
    grid: np.ndarray | None = None,
    release_near: bool = False,
):
    """Close ``lie`` with the contacts kept; release contacts that conflict with closure.

    ``motion`` may be a clip's grid frames (``select_frames``, its ``fps`` the clip's): ``grid``
    gives their frame numbers in the clip (default: every frame), so :data:`LIFT_TIME` is
    measured in the clip's time.

    A contact on the last frame of a joint that is in the air on the first is kept in the
    floor plane only over its last :data:`LIFT_TIME` (closing puts the first pose, that
    joint in the air, on the last frame: it must rise there; with ``c1`` it is free there,
    to take the first frame's velocity too). When the projection fails
    (closure and contacts do not fit together), the contact that missed most at the failed
    solve is released (with any that missed at least a quarter as much). At most
    ``max_release`` contacts and three re-solves. A failed solve whose contacts all hold
    within ``POLISH_MISS`` is returned as it is (the caller closes exactly from it), unless
    ``release_near`` (the caller's exact closing from there failed): then it releases too.

    Returns the closing result, the constraints it was solved with, the released contacts
    (``joint``, ``frames`` on ``motion``'s frames, ``largest_miss_m`` at release, ``why``)
    and the contacts lifted early (``joint``, ``frames``: from the first frame without a
    height row to the end).
    """
    mask = np.array(contacts.mask)
    released: list[dict] = []
    # a contact that reaches the last frame of a joint in the air on the first cannot hold to
    # the end: closing puts the first frame's pose, that joint in the air, on the last frame.
    # It is kept in the floor plane only over its last LIFT_TIME: the joint rises there to
    # meet the first pose without sliding (height rows to the end would make it pop up
    # between the last two frames, or fail)
    lift_from: dict[str, int] = {}
    lifting: list[dict] = []
    f_count = mask.shape[0]
    frames = np.arange(f_count) if grid is None else np.asarray(grid)
    # the first grid frame of the clip's last round(LIFT_TIME fps) frames (at least one)
    lift_start = int(np.searchsorted(frames, frames[-1] + 1 - max(1, round(LIFT_TIME * motion.fps))))
    for k, name in enumerate(contacts.joints):
        if mask[-1, k] and not mask[0, k]:
            a = int(np.flatnonzero(~mask[:, k])[-1]) + 1
            lift_from[name] = max(a + 1, lift_start)
            lifting.append({"joint": name, "frames": [lift_from[name], f_count]})
    attempts = 0
    while True:
        kept = dataclasses.replace(contacts, mask=mask)
        extra = ContactConstraints(motion, kept, more_rows=more_rows, lift_from=lift_from, c1=c1)
        res = solve(lie, extra)
        attempts += 1
        if res.converged or len(released) >= max_release or attempts > 3 or not len(extra):
            break
        vals = np.asarray(res.curve.values)
        rot, eu = vals[:, 3:].reshape(-1, motion.n_joints, 3, 3), vals[:, :3]
        if not release_near and np.abs(extra.residual(rot, eu)).max() <= POLISH_MISS:
            break  # nearly held: the caller closes exactly from here, releasing nothing
        misses = [g for g in extra.gave_way(rot, eu) if g["joint"] in contacts.joints]  # no floor pins
        if not misses:
            break
        worst = max(g["largest_miss_m"] for g in misses)
        for g in sorted(misses, key=lambda g: -g["largest_miss_m"]):
            if g["largest_miss_m"] >= 0.25 * worst and len(released) < max_release:
                a, b = g["frames"]
                mask[a:b, contacts.joints.index(g["joint"])] = False
                if b == f_count and g["joint"] in lift_from:  # its lift goes with it
                    del lift_from[g["joint"]]
                    lifting[:] = [x for x in lifting if x["joint"] != g["joint"]]
                released.append({**g, "why": "missed most when the projection with it failed"})
    # (a heel whose last contact was left to its toe has no rows to lift)
    with_rows = {r.name for r in extra.rows if r.interval[1] == f_count}
    return res, extra, released, [x for x in lifting if x["joint"] in with_rows]


def _worst_miss(res: ClosingResult, extra: ContactConstraints) -> float:
    """How far (metres) the contacts of ``extra`` are from holding on ``res``'s curve."""
    v = np.asarray(res.curve.values)
    return float(np.abs(extra.residual(v[:, 3:].reshape(v.shape[0], -1, 3, 3), v[:, :3])).max(initial=0))


def _polish(
    res: ClosingResult, extra: ContactConstraints, near: float, project, lie
) -> tuple[ClosingResult, str | None, str]:
    """A constrained projection that stopped short with its contacts within ``near <=``
    :data:`POLISH_MISS` closed exactly from there, if that keeps them within twice it.

    Returns the result (converged when polished, ``change`` measured from ``lie``, the input),
    what was done (None when nothing) and, when the exact closing lost the contacts, why (the
    end of the ``dropped`` note; "" otherwise)."""
    if res.converged or near > POLISH_MISS:
        return res, None, ""
    polish = project(res.curve)
    after = _worst_miss(polish, extra)
    # closed is what counts: a polish whose optimality residual stalled at the rounding
    # floor with the seam shut (the Bandai old walk: contacts within 0.0 mm) is kept
    closed_enough = polish.converged or polish.gap <= _POLISH_GAP
    if closed_enough and after <= 2 * POLISH_MISS:
        polished = (
            f"the contacts held within {1000 * near:.1f} mm where the solver stopped "
            f"({res.message}); closed exactly from there (within {1000 * after:.1f} mm)"
        )
        change = srv_distance(polish.srv, srv_transform(lie))  # from the input
        return dataclasses.replace(polish, change=change, message=polished, converged=True), polished, ""
    failed = (
        f"; closing exactly from there missed them by {1000 * after:.1f} mm"
        if closed_enough
        else f"; closing exactly from there failed ({polish.message})"
    )
    return res, None, failed


def _floor_per_frame(motion: Motion, found: Contacts) -> np.ndarray:
    """Per frame, the height (metres) a kept-contacts loop may not go under: the floor, or
    the input's own lowest point there if lower, but never more than :data:`FLOOR_TOLERANCE`
    under the floor."""
    unit = motion.metres_per_unit if motion.metres_per_unit is not None else 1.0
    heights = forward_kinematics(motion, end_sites=True)[..., _AXES.index(motion.up_axis)]
    lowest_in = heights.min(axis=1) * unit
    floor = found.floor_heights()  # a floor that is not level, frame by frame
    return np.minimum(floor, np.maximum(lowest_in, floor - FLOOR_TOLERANCE))


def _plant_and_lift(
    motion: Motion,
    out: Motion,
    found: Contacts,
    kept_contacts: Contacts,
    lift_from: dict[str, int],
    c1: bool,
    report: dict,
    *,
    smooth: float = 0.0,
) -> Motion:
    """The loop ``out`` of ``motion`` with its kept contacts planted on every frame and its
    body out of the floor; the seam frames (and their neighbours for a C1 seam, whose
    velocities must match too) untouched. Adds ``planted_by_ik`` and ``lifted_max_m`` to
    ``report``. ``smooth``: seconds, the standard deviation of the Gaussian the IK's change
    is smoothed with (:func:`~elastic_motion.apps.cleanup.cleanup_footskate`): the grid's
    spacing when the clip was closed on a grid.

    Between the grid's frames the interpolated correction lets planted feet drift (by its
    curvature: cm on a clip changed by decimetres), and a polished solve misses them by up to
    :data:`POLISH_MISS`: leg and arm IK put them on the rows' targets
    (:func:`~elastic_motion.apps.loop_contacts.row_plants`), eased in and out of the contacts
    like a blend's clean-up. On a grid the IK runs twice: its change smoothed over the grid's
    spacing, then exactly. The drift is zero on the grid's frames and up to a millimetre
    between them, which a straight stance leg can only take up by bending its knee by degrees
    (1 mm of a 0.9 m leg is 5 deg): in one exact pass the knee flickered between straight and
    bent at the grid's rate (CMU 131_01's auto window, a 120 fps clip on a 30 fps grid: 0.1
    and 5.2 deg on alternate frames); the smoothed pass bends it on every frame, and the exact
    one then turns it by little. Kept
    feet push the change into the other frames: where that
    puts a hand or the head under the floor (or under the input's own lowest point there,
    down to :data:`FLOOR_TOLERANCE` under it), the body is raised there.
    """
    f = motion.n_frames
    seam = (0, 1, f - 2, f - 1) if c1 and f > 4 else (0, f - 1)
    unit = motion.metres_per_unit if motion.metres_per_unit is not None else 1.0
    plants = row_plants(motion, kept_contacts, out, lift_from, c1=c1)
    # only the plants here: a leg raised by IK to clear a floor the loop went decimetres under
    # bends its knee by as much; the body is raised instead, below
    no_floor = dataclasses.replace(kept_contacts, floor=-math.inf)
    limbs = find_legs(out)[0] + find_arms(out, kept_contacts.joints)  # a cartwheel's hands too
    kw = {"plants": plants, "fixed": seam, "knee_hinge": False, "legs": limbs}
    ik = cleanup_footskate(out, no_floor, smooth=smooth, **kw)
    if ik.applied:
        planted = ik.motion
        after = ik.skating_after
        if smooth > 0:
            # the smoothed change bends a straight stance knee a little on every frame; exact
            # plants from there need only small turns (no singularity at a straight knee)
            exact = cleanup_footskate(planted, no_floor, smooth=0.0, **kw)
            planted, after = (exact.motion, exact.skating_after) if exact.applied else (planted, after)
        moved = forward_kinematics(planted, end_sites=True) - forward_kinematics(out, end_sites=True)
        out = planted
        report["planted_by_ik"] = {
            "skating_before_m_s": ik.skating_before.mean_speed,
            "skating_after_m_s": after.mean_speed,
            "max_position_change_m": float(np.linalg.norm(moved, axis=-1).max()) * unit,
        }
    out, lift = lift_out_of_floor(out, _floor_per_frame(motion, found) / unit, fixed=seam)
    report["lifted_max_m"] = float(lift.max() * unit)
    return out


def _close_keeping_contacts(
    motion: Motion,
    found: Contacts,
    project,
    *,
    max_step: float,
    max_release: int,
    joint_weights: np.ndarray | None,
    translation_weight: float | None,
    c1: bool = False,
) -> tuple[Motion | None, ClosingResult, ContactConstraints, dict]:
    """Close a prepared clip with its contacts kept (``contacts="keep"``, module
    :mod:`elastic_motion.apps.loop_contacts`).

    The clip is closed on a grid of its frames (every frame while the rows fit in the
    budget, at most ``max_step`` seconds apart; 0: every frame), conflicting contacts are
    released (:func:`_solve_with_contacts`), a solve that stopped with every contact within
    :data:`POLISH_MISS` is closed exactly from there, the grid's correction is lifted to
    every frame and the body is raised where it went under the floor.

    Returns
    -------
    out : Motion or None
        The loop; None when the contacts could not be kept (the caller closes without them:
        ``kept["dropped"]`` says why).
    res : ClosingResult
        The constrained projection (on the grid), ``time`` covering every attempt.
    extra : ContactConstraints
        The rows it was solved with (on the grid's frames).
    kept : dict
        The report: rows, grid, converged, polished, released and gave way (on the clip's
        frames), lifted_max_m.
    """
    j = motion.n_joints
    step = grid_step(found, max_step) if max_step > 0 else 0.0
    grid = contact_grid(motion.n_frames, motion.fps, step, seam_cells=c1)
    coarse = select_frames(motion, grid) if grid.size < motion.n_frames else motion
    found_c = found.select_frames(grid) if coarse is not motion else found
    # bounded before the Gram matrix of the rows is made (3 rows per contact frame at most)
    limits.check_option(
        "contacts", "rows of the kept contacts (3 per contact frame):", 3 * int(found_c.mask.sum()),
        "max_constraint_rows",
    )  # fmt: skip
    lie_c = to_lie_curve(coarse, joint_weights, translation_weight=translation_weight)
    t_keep = time.perf_counter()
    pins: list = []
    with single_threaded_blas():  # rows' Gram matrices of ~1000: one BLAS thread is faster
        res, extra, released, lifting = _solve_with_contacts(
            lie_c, coarse, found_c, max_release=max_release,
            solve=lambda curve, ex: project(curve, ex, stall=6), c1=c1, grid=grid,
        )  # fmt: skip
        # an active set for the floor: joints the loop takes under it get a row at their
        # deepest frame (the input's height there) and the projection is solved again, the
        # contacts kept so far kept and none released; pins that do not fit are dropped
        kept_c = fine_contacts(found_c, np.arange(coarse.n_frames), released)  # on its own frames
        floor_c = _floor_per_frame(coarse, found_c)
        for _ in range(FLOOR_ROUNDS):
            new = floor_rows(coarse, from_lie_curve(res.curve, coarse), floor_c, extra.rows)
            if not res.converged or not new or len(pins) + len(new) > MAX_FLOOR_PINS:
                break
            # (a few rows more than a solve that converged: at most twice its iterations)
            cap = 2 * res.iterations + 4
            again = _solve_with_contacts(
                lie_c, coarse, kept_c, max_release=0,
                solve=lambda curve, ex, cap=cap: project(curve, ex, stall=6, iterations=cap), c1=c1,
                more_rows=pins + new, grid=grid,
            )  # fmt: skip
            if not again[0].converged:
                break
            pins += new
            res, extra, _, lifting = again

        near = _worst_miss(res, extra)
        res, polished, polish_failed = _polish(res, extra, near, project, lie_c)
        if polish_failed and max_release > len(released):
            # nearly held where the solver stopped, but closing exactly from there lost them
            # (CMU 131_03 "start, hop, stop" closed whole: its final stance cannot stay planted
            # on a seam 106 degrees and 0.67 m away; all its contacts were dropped and the loop
            # skated 0.34 m/s against the input's 0.16): release the worst as a failed solve
            # would, and solve again
            again = _solve_with_contacts(
                lie_c, coarse, found_c, max_release=max_release,
                solve=lambda curve, ex: project(curve, ex, stall=6), c1=c1, grid=grid, release_near=True,
            )  # fmt: skip
            near_again = _worst_miss(again[0], again[1])
            res_again, polished_again, _ = _polish(again[0], again[1], near_again, project, lie_c)
            if res_again.converged:
                res, (_, extra, released, lifting), near = res_again, again, near_again
                polished, polish_failed, pins = polished_again, "", []
    # the time of every constrained solve (released attempts, polish) is the solve's
    res = dataclasses.replace(res, time=time.perf_counter() - t_keep)
    vals = np.asarray(res.curve.values)

    def on_clip(g: dict) -> dict:
        return {**g, "frames": [int(grid[g["frames"][0]]), int(grid[g["frames"][1] - 1]) + 1]}

    kept = {
        "rows": len(extra),
        "grid_frames": int(grid.size),
        "grid_fps": float(motion.fps * (grid.size - 1) / max(motion.n_frames - 1, 1)),
        "converged": res.converged,
        "polished": polished,
        "released": [on_clip(r) for r in released],
        "lifted_early": [on_clip(r) for r in lifting],
        "floor_pins": [
            {"joint": r.name.removesuffix(" above the floor"), "frame": int(grid[r.frame])} for r in pins
        ],
        "gave_way": [on_clip(g) for g in extra.gave_way(vals[:, 3:].reshape(-1, j, 3, 3), vals[:, :3])],
    }
    if not res.converged:
        # the gap in the solver's message is the closure's and the contacts' together: say
        # how far the contacts were from holding, the part a user can judge
        kept["dropped"] = (
            f"contacts dropped ({res.message}; the contacts missed by up to {1000 * near:.1f} mm"
            f"{polish_failed}); closed without them"
        )
        return None, res, extra, kept
    out = lift_correction(motion, grid, coarse, from_lie_curve(res.curve, coarse))
    lift_fine = {g["joint"]: int(grid[g["frames"][0]]) for g in lifting}
    spacing = (
        (motion.n_frames - 1) / max(grid.size - 1, 1) / motion.fps if grid.size < motion.n_frames else 0.0
    )
    out = _plant_and_lift(
        motion, out, found, fine_contacts(found, grid, released), lift_fine, c1, kept, smooth=spacing
    )
    return out, res, extra, kept


def _close_clip(
    motion: Motion,
    closed_joint: np.ndarray,
    *,
    root: str,
    c1: bool,
    method: str,
    solver: str,
    tol: float,
    max_iter: int,
    joint_weights: np.ndarray | None,
    translation_weight: float | None,
    contacts: str = "report",
    contact_options: ContactOptions | None = None,
    contact_step: float = 1.0 / 30.0,
    max_release: int = 8,
    joint_limits: JointLimits | None = None,
    limit_step: float = 0.1,
    limit_tol: float = 0.5,
    progress: Progress | None = None,
) -> tuple[Motion, ClosingResult, dict | None]:
    """Close one prepared clip (module docstring): the looped motion, the curve result and,
    with ``contacts="keep"``, what became of the contacts (rows, which gave way). With
    ``joint_limits`` (needs ``method="lie"``, ``solver="kkt"``) the limits are kept by the
    active set of :mod:`elastic_motion.apps.loop_limits`; its :class:`LoopLimits` is returned
    under ``"joint_limits"`` in the third value."""
    names = motion.skeleton.names
    j = motion.n_joints
    up = _AXES.index(motion.up_axis)
    keep = contacts == "keep" and method == "lie"
    found = detect_contacts(motion, _level(contact_options)) if keep else None
    base, travel = motion, None
    if found is not None and found.any and root == "inplace":
        # planted feet cannot stay put while the clip comes back to its start: the body then
        # jumped back in the air (1.1 m between two frames of the DeepMimic run). They ride a
        # treadmill instead: the travel is removed at a constant rate, then the rest closed
        base, dist, turn = treadmill(motion)
        travel = {"travel_m": dist * _metres(motion), "turn_deg": float(np.degrees(turn))}
    lie = to_lie_curve(base, joint_weights, translation_weight=translation_weight)
    # per-joint closing mask (3 coordinates each), root first
    rot_mask = np.repeat(closed_joint, 3).reshape(j, 3)
    pos_mask = np.ones(3, dtype=bool)
    if root == "travel":
        pos_mask[:] = False
        pos_mask[up] = True
    kept = None
    if contacts == "keep" and (method != "lie" or solver != "kkt"):
        raise OptionError(
            "contacts",
            f"'keep' needs method='lie' and solver='kkt'; got method={method!r}, solver={solver!r}",
        )
    if method == "lie":
        if root == "travel" and closed_joint[0]:
            rot_mask[0, up] = False  # root: swing about the up axis (heading free)
        mask = np.concatenate([pos_mask, rot_mask.ravel()])
        out = None

        def project(curve, extra=None, stall=None, iterations=None):
            return project_closed(
                curve, factors=mask, c1=c1, tol=min(tol, 1e-9),
                max_iter=max(min(max_iter, iterations or max_iter), 1),
                rotation_names=list(names), extra=extra, stall_iterations=stall, progress=progress,
            )  # fmt: skip

        if found is not None and found.any:
            # kept joint limits need the clip's own frames (C1 seam rows its first and last
            # steps, which the grid keeps)
            out, res, extra, kept = _close_keeping_contacts(
                base, found, project, max_step=0.0 if joint_limits is not None else contact_step,
                max_release=max_release, joint_weights=joint_weights,
                translation_weight=translation_weight, c1=c1,
            )  # fmt: skip
            if travel is not None:
                kept["treadmill"] = travel
            if out is None:  # contacts and closure do not fit together: close without them,
                if base is not motion:  # and without the treadmill they needed
                    lie = to_lie_curve(motion, joint_weights, translation_weight=translation_weight)
                res = project(lie)
        elif solver == "kkt":
            res = project(lie)
        else:
            res = close_curve(
                lie, method=solver, tol=tol, max_iter=max_iter, factors=mask, c1=c1,
                rotation_names=list(names),
            )  # fmt: skip
        if joint_limits is not None and solver == "kkt":
            base = extra if kept is not None and "dropped" not in kept else None

            res, lim_info = solve_within_limits(
                lambda ex: project(lie, ex), lambda r: np.asarray(r.curve.values)[:, 3:].reshape(-1, j, 3, 3),
                motion.rotations, names, joint_limits, base=base, first=res,
                step=max(1, round(limit_step * motion.fps)), tol_deg=limit_tol,
            )  # fmt: skip
            if base is not None:
                vals = np.asarray(res.curve.values)
                kept["gave_way"] = base.gave_way(vals[:, 3:].reshape(-1, j, 3, 3), vals[:, :3])
            kept = {**(kept or {}), "joint_limits": lim_info}
        if out is None or (joint_limits is not None and solver == "kkt"):
            out = from_lie_curve(res.curve, motion)
    else:
        euler = to_euler_curve(motion)
        weights = lie.group.weights  # same layout: root position, then 3 per joint
        curve = DiscreteCurve(euler.values, Euclidean(3 + 3 * j, weight=weights), euler.t)
        if (
            root == "travel"
            and closed_joint[0]
            and motion.skeleton.euler_orders[0][0].lower() == motion.up_axis
        ):
            rot_mask[0, 0] = False  # outermost root angle is the heading
        mask = np.concatenate([pos_mask, rot_mask.ravel()])
        if solver == "kkt":
            res = project_closed(
                curve, factors=mask, c1=c1, tol=min(tol, 1e-9), max_iter=max(max_iter, 1), progress=progress
            )
        elif c1:
            res = close_curve(curve, method=solver, tol=tol, max_iter=max_iter, factors=mask, c1=True)
        else:
            res = project_closed_rd(curve, factors=mask, tol=tol, max_iter=max_iter)
        out = from_euler_curve(res.curve, motion)
    return out.replace(name=motion.name, source=()), res, kept


def _frames(motion: Motion, start: int, stop: int) -> Motion:
    jt = motion.joint_translations
    return motion.replace(
        root_translation=motion.root_translation[start:stop],
        rotations=motion.rotations[start:stop],
        joint_translations=jt[start:stop] if jt is not None else None,
    )


def _change_reference(clip: Motion, root: str) -> Motion:
    """What a window's loop is measured against when windows are compared (their
    ``deviation_*``): the clip itself, or in place the clip on its own treadmill (else the
    travel the treadmill takes out counts as change, and the shortest, slowest window won: a
    13-frame step of the DeepMimic run, 12 frames of a pause in CMU 107_02)."""
    return treadmill(clip)[0] if root == "inplace" else clip


def _window(
    motion: Motion,
    window: object,
    closed_joint: np.ndarray,
    closed: list[str],
    min_length: float | None,
    candidates: int,
    close,
    root: str,
    close_final=None,
) -> tuple[CycleWindow, Motion, ClosingResult]:
    """Choose the window (``"auto"`` or ``(start, stop)``), close it; also the whole clip for the report.

    The candidates are ranked by ``close``; the chosen one is closed again by
    ``close_final`` when given (kept contacts: ranking every candidate with them would cost
    a constrained projection each)."""
    f = motion.n_frames
    fps = motion.fps
    cand = None
    if isinstance(window, str):
        if window != "auto":
            raise OptionError("window", f"expected 'auto', None or (start, stop) frames; got {window!r}")
        cand = cycle_candidates(
            motion, root=root, closed=closed_joint, min_length=min_length, count=candidates
        )
        windows = list(cand.windows)
        if (0, f) not in windows:
            windows.append((0, f))  # the whole clip competes too (and is reported)
    else:
        try:
            a, b = (int(v) for v in window)  # type: ignore[union-attr]
        except (TypeError, ValueError):
            raise OptionError(
                "window", f"expected 'auto', None or (start, stop) frames; got {window!r}"
            ) from None
        if not 0 <= a < b <= f or b - a < 3:
            raise OptionError(
                "window", f"expected 0 <= start < stop <= {f} frames, at least 3 frames; got ({a}, {b})"
            )
        windows = [(a, b)]
    trials = []
    best = None
    for a, b in windows:
        sub = _frames(motion, a, b)
        try:
            out, res, kept = close(sub)
        except ValueError as exc:  # e.g. a seam at the cut locus: try the next candidate
            trials.append({"start": a, "stop": b, "error": str(exc)})
            continue
        sm = seam_metrics(out, original=_change_reference(sub, root), root=root, joints=closed)
        trials.append(
            {
                "start": a,
                "stop": b,
                "deviation_max_m": sm.deviation_max_m,
                "deviation_mean_m": sm.deviation_mean_m,
                "change_srv_l2": res.change,
                "converged": res.converged,
            }
        )
        key = (not res.converged, sm.deviation_max_m)
        if best is None or key < best[0]:
            best = (key, a, b, out, res, sm, kept)
    if best is None:
        raise OptionError("window", f"no candidate window could be closed: {trials}")
    _, a, b, out, res, sm, kept = best
    if close_final is not None:  # the chosen window, closed with what only it needs (contacts)
        out, res, kept = close_final(_frames(motion, a, b))
        sm = seam_metrics(
            out, original=_change_reference(_frames(motion, a, b), root), root=root, joints=closed
        )
    whole: dict = {}
    done = [t for t in trials if (t["start"], t["stop"]) == (0, f)]
    if done:
        whole = {k: v for k, v in done[0].items() if k not in ("start", "stop", "converged")}
    elif (a, b) != (0, f):
        try:
            w_out, w_res, _ = close(motion)
            w_sm = seam_metrics(w_out, original=_change_reference(motion, root), root=root, joints=closed)
            whole = {
                "deviation_max_m": w_sm.deviation_max_m,
                "deviation_mean_m": w_sm.deviation_mean_m,
                "change_srv_l2": w_res.change,
            }
        except ValueError as exc:
            whole = {"error": str(exc)}
    else:
        whole = {"deviation_max_m": sm.deviation_max_m, "deviation_mean_m": sm.deviation_mean_m,
                 "change_srv_l2": res.change}  # fmt: skip
    cw = CycleWindow(
        start=a,
        stop=b,
        fps=fps,
        deviation_max_m=float(sm.deviation_max_m),
        deviation_mean_m=float(sm.deviation_mean_m),
        change=res.change,
        whole=whole,
        candidates=tuple(trials),
        min_length=cand.min_length if cand is not None else None,
        min_length_default=cand.min_length_default if cand is not None else False,
        quiet_excluded=cand.quiet_excluded if cand is not None else False,
        period=cand.period if cand is not None else None,
    )
    return cw, out, res, kept


def _level(options: ContactOptions | None) -> ContactOptions:
    """A loop's contact options: heights from one floor height (a loop is periodic: closing it
    puts the end at the start's height, so a floor that rises under the clip is not the loop's;
    held above it, CMU 07_01's whole loop gave way and went 3.8 cm under it)."""
    return dataclasses.replace(options or ContactOptions(), follow_floor=False)


def _contacts(motion: Motion, mode: str, options: ContactOptions | None) -> tuple[Contacts | None, list[str]]:
    if mode == "off":
        return None, []
    c = detect_contacts(motion, _level(options))
    notes = []
    if not c.joints:
        notes.append("contacts skipped: no joint that can touch the floor (feet, toes, hands)")
    elif not c.any:
        notes.append("contacts: no joint is planted in this clip")
    notes += [f"contacts: {n}" for n in c.notes if n.startswith(MISSED_STANCES_NOTE)]
    return c, notes


def loop_motion(
    motion: Source | PreparedMotions,
    *,
    root: str = "travel",
    c1: bool | str = "auto",
    method: str = "lie",
    solver: str = "kkt",
    tol: float = 1e-6,
    max_iter: int = 100,
    free_joints: str | Sequence[str] | None = "fingers",
    prepare: PrepareOptions | None = None,
    joint_weights: np.ndarray | None = None,
    translation_weight: float | None = None,
    window: str | tuple[int, int] | None = None,
    min_length: float | None = None,
    candidates: int = 5,
    contacts: str | None = None,
    contact_options: ContactOptions | None = None,
    contact_step: float = 1.0 / 30.0,
    joint_limits: str | JointLimits = "report",
    limit_tol: float = 0.5,
    progress: Progress | None = None,
) -> LoopResult:
    """Make a motion loop seamlessly by closing its curve (paper 000, sec. 4 and 5.4).

    Parameters
    ----------
    motion : path or Motion, or PreparedMotions of one input
        At least 3 frames after preparation, finite.
    root : {"travel", "inplace"}
        Loop convention (module docstring): keep the floor-plane displacement and heading
        change of one cycle, or close them too.
    c1 : bool or "auto", default "auto"
        ``True``: also match the velocities at the seam (C1; module
        :mod:`elastic_motion.closing_kkt`, the C1 rows). ``False``: the poses only (C0, paper
        000's closing). ``"auto"``: C0, unless its seam has a hitch (the velocity jump more
        than :data:`HITCH_RATIO` times the clip's own quick changes,
        :attr:`SeamMetrics.seam_velocity_jump_ratio`); then the same window is closed C1 too
        and the C1 loop is taken when it is smoother and converged, skates at most 1.1 times
        as fast, changes the clip at most 1.5 times as much (mean, + 5 mm) and whips no limb
        the C0 loop did not; a note says which seam was taken and why.
    method : {"lie", "euler-elastic"}
        Close the Lie curve (the method) or the Euler-angle curve (the baseline).
    solver : {"kkt", "gauss-newton", "gradient"}
        ``"kkt"`` (default): the closed curve nearest the input in SRV L2
        (:func:`elastic_motion.closing_kkt.project_closed`, to a KKT point; ``tol`` is
        capped at 1e-9). ``"gauss-newton"`` / ``"gradient"``: the closing flows of
        :func:`~elastic_motion.closing.close_curve` (the Euler C0 baseline then uses the
        Newton projection of paper 001, Thm. 2).
    tol : float, default 1e-6
        Stop when the seam gap (weighted norm of the closing residual: radians for joint
        rotations, weighted metres for the root) is below this.
    max_iter : int, default 100
    free_joints : "fingers", None or sequence of str
        Joints left free (their rotations keep their samples).
    prepare : PrepareOptions, optional
        The preparation step (:mod:`elastic_motion.apps.prepare`).
    joint_weights, translation_weight
        Inner-product weights (default: those of :func:`elastic_motion.motion.to_lie_curve`).
    window : None, "auto" or (start, stop)
        Loop the whole clip (default), the best cycle (``"auto"``: the window
        ``[start, stop)`` of frames whose loop changes the motion least, see
        :mod:`elastic_motion.apps.loop_window`; the whole clip is closed too, for the report) or
        the given frames.
    min_length : float, optional
        Shortest window for ``"auto"``, seconds (default: 90 % of the clip's period, or
        half the clip when it does not repeat).
    candidates : int, default 5
        Windows closed exactly by ``"auto"`` (the best of the cheap pose/velocity match).
    contacts : {"keep", "report", "off"}, optional
        Default ``"keep"`` with ``method="lie"`` and ``solver="kkt"``, else ``"report"``.
        ``"keep"``: the input's contacts are constraints of the same projection
        (:mod:`elastic_motion.apps.loop_contacts`: a planted joint stays where the input had
        it, a contact across the seam moves as one piece, every frame of a 30 fps grid
        constrained; needs ``method="lie"`` and ``solver="kkt"``); with no contact found the
        plain projection. A contact planted on the last frame by a joint in the air on the
        first is kept in the floor plane only over its last :data:`LIFT_TIME`
        (``contacts_kept["lifted_early"]``); one that still conflicts with closure is
        released and named in the notes and ``contacts_kept["released"]``. Between the grid's
        frames and after a polished solve leg and arm IK plant feet and hands on every frame
        (``contacts_kept["planted_by_ik"]``, the seam frames untouched). Points the loop
        takes under the floor are pinned at their deepest frames and the projection solved
        again (``contacts_kept["floor_pins"]``); what is still under is lifted out
        (``contacts_kept["lifted_max_m"]``). One that is kept but
        missed is listed in
        ``contacts_kept["gave_way"]``. A solve that stalls with every contact within
        :data:`POLISH_MISS` is closed exactly from there (``contacts_kept["polished"]``);
        when that exact closing loses them, the contacts missed most are released and the
        projection solved again; when the projection still fails the clip is closed
        without contacts (a note says so). With ``window="auto"`` the candidates are ranked
        by the plain projection and the chosen window is closed with its contacts.
        ``"report"``: detect the input's contacts
        (:func:`elastic_motion.motion.contacts.detect_contacts`) and measure skating and
        depth below the floor of input and loop during them
        (:func:`elastic_motion.apps.metrics.contact_skating`); ``"keep"`` does this too.
        ``"off"``: skip.
    contact_options : ContactOptions, optional
        Thresholds of contact detection; heights are measured from one floor height whatever
        its ``follow_floor`` (a loop is periodic: :func:`_level`).
    contact_step : float, default 1/30
        With ``contacts="keep"``: a clip whose contacts need more rows than
        :data:`elastic_motion.apps.loop_contacts.ROW_BUDGET` is closed on a grid of its
        frames at most this many seconds apart, every grid frame of a contact constrained,
        and the correction interpolated to the other frames
        (:func:`~elastic_motion.apps.loop_contacts.grid_step`); 0: every frame always.
    joint_limits : {"report", "keep", "off"} or JointLimits, default "report"
        Limits of the joints' DOF angles: those of the ASF file the clip was read from
        (:func:`elastic_motion.motion.asfamc.read_joint_limits`; nothing happens when there
        are none), or the given ones (kept). ``"keep"``: the loop stays within every limit
        the input respects (:mod:`elastic_motion.apps.loop_limits`; needs ``method="lie"``
        and ``solver="kkt"``, otherwise reported only); ``"report"``: only measured.
        Either way the report lists the joints at a limit and every limit the input itself
        violates (reported, never enforced, never an error). ``"keep"`` is not the default
        because each constrained solve uses a dense Jacobian: 16 s for CMU's backflip, 108 s
        for charleston1, against under 1 s reported only.
    limit_tol : float, default 0.5
        Degrees: beyond a limit means by more than this, at a limit within it (the loop
        between two pinned frames may bulge past the limit by a fraction of a degree).
    progress : callable, optional
        ``progress(stage, done, total)`` (:mod:`elastic_motion.apps.progress`): the closing's
        iterations (``"closing"``, total unknown: 0) of the KKT solver.

    Returns
    -------
    LoopResult

    Raises
    ------
    OptionError
        Fewer than 3 frames; NaN/inf in the motion; a closed joint whose seam rotation is
        at log's cut locus (angle pi: the error names the joint; leave it free with
        ``free_joints`` to loop anyway); a ``min_length`` longer than the clip, or given
        without ``window="auto"``; bad option values.
    """
    if method not in LOOP_METHODS:
        raise OptionError("method", f"expected one of {list(LOOP_METHODS)}; got {method!r}")
    if solver not in CLOSING_SOLVERS:
        raise OptionError("solver", f"expected one of {list(CLOSING_SOLVERS)}; got {solver!r}")
    if contacts is None:
        contacts = "keep" if method == "lie" and solver == "kkt" else "report"
    if (
        isinstance(contact_step, bool)
        or not isinstance(contact_step, numbers.Real)
        or not (math.isfinite(contact_step) and contact_step >= 0)
    ):
        raise OptionError("contact_step", f"expected a non-negative number of seconds; got {contact_step!r}")
    if contacts not in LOOP_CONTACTS:
        raise OptionError("contacts", f"expected one of {list(LOOP_CONTACTS)}; got {contacts!r}")
    if not isinstance(joint_limits, JointLimits) and joint_limits not in LOOP_JOINT_LIMITS:
        raise OptionError(
            "joint_limits",
            f"expected one of {list(LOOP_JOINT_LIMITS)} or a JointLimits; got {joint_limits!r}",
        )
    if not (isinstance(limit_tol, (int, float)) and math.isfinite(limit_tol) and limit_tol >= 0):
        raise OptionError("limit_tol", f"expected a non-negative number of degrees; got {limit_tol!r}")
    if int(candidates) != candidates or candidates < 1:
        raise OptionError("candidates", f"expected a positive integer; got {candidates!r}")
    if min_length is not None and not (isinstance(window, str) and window == "auto"):
        # it bounds the sub-clips the auto window chooses from: silently ignored otherwise
        what = "the whole clip (window=None, --window whole)" if window is None else f"window={window!r}"
        raise OptionError(
            "min_length", f"expected only with window='auto' (--window auto); got it with {what}"
        )
    check_root(root)
    if not (isinstance(c1, bool) or (isinstance(c1, str) and c1 == "auto")):
        raise OptionError("c1", f"expected True, False or 'auto'; got {c1!r}")
    prepared = prepare_motions(motion if isinstance(motion, PreparedMotions) else [motion], prepare)
    if len(prepared.motions) != 1:
        raise OptionError("motion", f"expected one motion to loop; got {len(prepared.motions)}")
    if c1 == "auto":
        same = dict(
            root=root, method=method, solver=solver, tol=tol, max_iter=max_iter, free_joints=free_joints,
            joint_weights=joint_weights, translation_weight=translation_weight, contacts=contacts,
            contact_options=contact_options, contact_step=contact_step, joint_limits=joint_limits,
            limit_tol=limit_tol, progress=progress,
        )  # fmt: skip
        return _auto_seam(prepared, window, min_length, candidates, same)
    motion = check_loop_motion(prepared.motions[0])
    names = motion.skeleton.names
    up = _AXES.index(motion.up_axis)
    free = set(_free(motion, free_joints))
    closed_joint = np.array([n not in free for n in names])
    closed = [n for n, c in zip(names, closed_joint, strict=True) if c]
    limits_mode, lim = _joint_limits(motion, joint_limits)
    lim_notes = []
    if limits_mode == "keep" and (method != "lie" or solver != "kkt"):
        limits_mode = "report"
        lim_notes.append("joint limits: reported only (keeping them needs method='lie' and solver='kkt')")

    def close(clip: Motion, contacts: str = contacts) -> tuple[Motion, ClosingResult, dict | None]:
        return _close_clip(
            clip, closed_joint, root=root, c1=c1, method=method, solver=solver, tol=tol,
            max_iter=max_iter, joint_weights=joint_weights, translation_weight=translation_weight,
            contacts=contacts, contact_options=contact_options, contact_step=contact_step,
            joint_limits=lim if limits_mode == "keep" else None, limit_tol=limit_tol, progress=progress,
        )  # fmt: skip

    cw = None
    if window is None:
        out, res, kept = close(motion)
    else:
        # candidates ranked by the plain projection; the chosen window keeps its contacts
        cw, out, res, kept = _window(
            motion, window, closed_joint, closed, min_length, candidates,
            (lambda clip: close(clip, "report")) if contacts == "keep" else close, root,
            close_final=close if contacts == "keep" else None,
        )  # fmt: skip
        motion = _frames(motion, cw.start, cw.stop)
    rot, _ = cycle_transform(out, root)
    heading = twist_angle(rot, up) if root == "travel" else 0.0
    found, contact_notes = _contacts(motion, contacts, contact_options)
    lim_info = kept.pop("joint_limits", None) if kept is not None else None
    if kept is not None and not kept:
        kept = None
    if lim is not None and lim_info is None:
        lim_info = limits_report(motion.rotations, out.rotations, names, lim, tol_deg=limit_tol)
    if lim_info is not None:
        lim_notes.extend(lim_info.notes())
    contact_notes.extend(lim_notes)
    if kept is not None:
        if kept.get("treadmill") and "dropped" not in kept:
            t = kept["treadmill"]
            contact_notes.append(
                f"contacts kept on a treadmill: in place, the clip's travel ({t['travel_m']:.3g} m, "
                f"turn {t['turn_deg']:.3g} deg) is removed at a constant rate before closing, so planted "
                f"feet move back with it at {t['travel_m'] / motion.duration:.3g} m/s (the skating in the "
                "world; 'on the treadmill' takes the belt out; "
                "'changed the clip' counts the travel removed) instead of the body jumping back between "
                "two frames"
            )
        if kept.get("polished"):
            contact_notes.append(f"contacts: {kept['polished']}")
        if "dropped" in kept:
            contact_notes.append(kept["dropped"])
        for g in kept.get("released", []):
            contact_notes.append(
                f"contact released (it conflicts with closing the loop): {g['joint']} frames "
                f"{g['frames'][0]}..{g['frames'][1] - 1} ({g['why']}"
                + (f", missed by {g['largest_miss_m']:.4f} m" if g["largest_miss_m"] is not None else "")
                + ")"
            )
        for g in kept.get("lifted_early", []):
            held = "free" if c1 else "kept in the floor plane only"
            contact_notes.append(
                f"contact lifted early (planted on the last frame, in the air on the first): {g['joint']} "
                f"{held} from frame {g['frames'][0]}, rising to the first frame's pose"
            )
        for g in kept["gave_way"]:
            contact_notes.append(
                f"contact gave way: {g['joint']} frames {g['frames'][0]}..{g['frames'][1] - 1} missed by "
                f"{g['largest_miss_m']:.4f} m"
            )
    seam_before = seam_metrics(motion, root=root, joints=closed)
    whip = _whip_note(motion, out, whole=cw is None, seam=seam_before)
    if whip:
        contact_notes.append(whip)
    sk_before = sk_after = sk_belt = None
    if found is not None and found.joints:
        sk_before = contact_skating(motion, found)
        sk_after = contact_skating(out, found)
        if kept is not None and kept.get("treadmill"):
            # in place the feet ride the belt: how much they slip on it
            sk_belt = contact_skating(on_belt(out, motion), found)
        warn = _skating_warning(sk_before, sk_belt or sk_after, kept, contacts, seam_before, whole=cw is None)
        if warn:
            contact_notes.append(warn)
    seam_after = seam_metrics(out, original=motion, root=root, joints=closed)
    if not c1 and seam_after.seam_velocity_jump_ratio > HITCH_RATIO:
        contact_notes.append(
            _hitch_note(seam_after) + "; c1=True / --seam c1 matches the velocities at the seam too"
        )
    return LoopResult(
        motion=out,
        original=motion,
        closing=res,
        method=method,
        root=root,
        c1=bool(c1),
        closed_joints=tuple(closed),
        free_joints=tuple(n for n, c in zip(names, closed_joint, strict=True) if not c),
        heading_change=float(heading),
        displacement=out.root_translation[-1] - out.root_translation[0] if root == "travel" else np.zeros(3),
        seam_before=seam_before,
        seam_after=seam_after,
        prepared=prepared,
        notes=(*prepared.notes, *contact_notes),
        window=cw,
        contacts=found,
        skating_before=sk_before,
        skating_after=sk_after,
        skating_on_treadmill=sk_belt,
        contacts_kept=kept,
        joint_limits=lim_info,
    )


def _hitch_note(seam: SeamMetrics) -> str:
    """What a seam's hitch is (:attr:`SeamMetrics.seam_velocity_jump_ratio`), for the notes."""
    return (
        f"{HITCH_NOTE}: velocities jump by up to {seam.seam_velocity_max_m_s:.3g} m/s; at "
        f"{seam.seam_velocity_jump_point} {seam.seam_velocity_jump_ratio:.1f}x its quickest changes inside "
        "the clip (99th percentile)"
    )


def _auto_seam(
    prepared: PreparedMotions,
    window: str | tuple[int, int] | None,
    min_length: float | None,
    candidates: int,
    same: dict,
) -> LoopResult:
    """``loop_motion(c1="auto")``: the C0 loop, or, when its seam has a hitch, the same window
    closed C1 if that is better by every measure an animator judges (``loop_motion``'s
    ``c1``). ``same``: the other options of both closings."""
    c0 = loop_motion(prepared, c1=False, window=window, min_length=min_length, candidates=candidates, **same)
    s0 = c0.seam_after
    if s0.seam_velocity_jump_ratio <= HITCH_RATIO:
        return c0
    fixed = None if c0.window is None else (c0.window.start, c0.window.stop)
    c1 = loop_motion(prepared, c1=True, window=fixed, **same)
    s1 = c1.seam_after
    why = []
    if not c1.closing.converged:
        why.append(f"it did not converge ({c1.closing.message})")
    if s1.seam_velocity_jump_ratio >= s0.seam_velocity_jump_ratio:
        why.append(f"its seam is no smoother ({s1.seam_velocity_jump_ratio:.2f}x)")
    if c0.skating_after is not None and c1.skating_after is not None:
        k0, k1 = c0.skating_after.mean_speed, c1.skating_after.mean_speed
        if k1 > 1.1 * k0 + 1e-9:
            why.append(f"it skates {k1 / k0:.2f}x as fast ({k1:.3g} against {k0:.3g} m/s)")
    d0, d1 = s0.deviation_mean_m or 0.0, s1.deviation_mean_m or 0.0
    if d1 > 1.5 * d0 + 0.005:
        why.append(f"it changes the clip more (mean {d1:.3g} against {d0:.3g} m)")

    def whip(r: LoopResult) -> str | None:
        return next((n for n in r.notes if n.startswith(WHIP_NOTE)), None)

    if whip(c1) and not whip(c0):
        why.append(f"it whips a limb ({whip(c1)})")
    hitch = _hitch_note(s0)
    if why:
        notes = tuple(n for n in c0.notes if not n.startswith(HITCH_NOTE))
        note = f"{hitch}; closed C1 too (c1='auto') and not taken: " + "; ".join(why)
        return dataclasses.replace(c0, notes=(*notes, note))
    note = (
        f"seam C1 (c1='auto'): closed C0, {hitch}; closed C1, the joints' velocities match at the "
        f"seam too (hitch {s1.seam_velocity_jump_ratio:.2f}x; mean change {d1:.3g} m against {d0:.3g})"
    )
    win = c1.window
    if c0.window is not None:  # how the window was chosen, with the C1 loop's numbers
        win = dataclasses.replace(
            c0.window, deviation_max_m=s1.deviation_max_m, deviation_mean_m=s1.deviation_mean_m,
            change=c1.closing.change,
        )  # fmt: skip
    return dataclasses.replace(c1, notes=(*c1.notes, note), window=win)


def _skating_warning(
    before: ContactSkating,
    after: ContactSkating,
    kept: dict | None,
    contacts: str,
    seam: SeamMetrics,
    *,
    whole: bool,
) -> str | None:
    """A ``warning:`` note when the loop skates more than :data:`SKATING_WARN_RATIO` times
    the input while in contact (both measured on the input's contacts), with why: contacts
    released or dropped to close it, or not kept at all.

    A clip that does not repeat gets its change where the contacts give way: a DeepMimic
    get-up from the floor, auto window, released its final stance to close on the lying
    pose and its ankles skated 1.0-1.2 m/s against the input's 0.05-0.08; the numbers and
    the notes said so, nothing said it was wrong."""
    if before.mean_speed <= 0 or after.mean_speed <= SKATING_WARN_RATIO * before.mean_speed:
        return None
    worst = max(after.per_joint, key=lambda n: after.per_joint[n] - before.per_joint.get(n, 0.0))
    why = ""
    if kept is not None and "dropped" in kept:
        why = "; the contacts could not be kept (see the note on them)"
    elif kept is not None and kept.get("released"):
        names = sorted({g["joint"] for g in kept["released"]})
        why = f"; contacts released to close it: {names}"
    elif contacts != "keep":
        why = (
            f"; contacts not kept (contacts={contacts!r}; contacts='keep' / --contacts keep, with the "
            "Lie method and the KKT solver, plants them)"
        )
    where = ""
    if seam.seam_angle_max_deg > 20.0 or seam.seam_position_max_m > 0.2:  # far from repeating
        where = (
            f"; the clip ends {seam.seam_angle_max_deg:.0f} deg and {seam.seam_position_max_m:.2f} m from "
            "the pose it starts in"
        )
        if whole:
            where += ": window='auto' / --window auto loops the sub-clip that closes with the least change"
    return (
        f"warning: the loop skates {after.mean_speed / before.mean_speed:.1f}x as fast as the input while "
        f"in contact ({after.mean_speed:.3g} against {before.mean_speed:.3g} m/s; most added: {worst}, "
        f"{after.per_joint[worst]:.3g} against {before.per_joint.get(worst, 0.0):.3g}){why}{where}"
    )


def _whip_note(motion: Motion, out: Motion, *, whole: bool, seam: SeamMetrics) -> str | None:
    """A note when the loop ``out``'s fastest point (joint or end site, FK) moves more than
    :data:`WHIP_RATIO` times as fast as the input ``motion``'s fastest: where and how fast.

    A clip that does not end in the pose it starts in, closed whole, gets its change where
    the contacts leave room: the Bandai tired walk's right toe, lifting off in the last
    frames, went 9.3 m/s (the input's fastest point 3.8), which only a sub-clip fixes.
    """
    sk = out.skeleton

    def speeds(m: Motion) -> np.ndarray:
        p = forward_kinematics(m, end_sites=True)
        return np.linalg.norm(np.diff(p, axis=0), axis=-1) * m.fps * _metres(m)

    if out.n_frames < 2:
        return None
    fast, base = speeds(out), speeds(motion)
    top = float(base.max(initial=0.0))
    if top <= 0 or fast.max() <= WHIP_RATIO * top:
        return None
    f, j = np.unravel_index(int(fast.argmax()), fast.shape)
    names = [*sk.names, *(f"{sk.names[p]} end site" for p in sk.end_site_parents)]
    note = (
        f"{WHIP_NOTE}: {names[j]} moves {fast.max():.3g} m/s at frames {f}-{f + 1} of the loop, "
        f"{fast.max() / top:.1f}x the input's fastest point ({top:.3g} m/s): the closing put its change there"
    )
    if whole:
        note += (
            f" (the clip ends {seam.seam_angle_max_deg:.0f} deg and {seam.seam_position_max_m:.2f} m from "
            "the pose it starts in; window='auto' / --window auto loops the sub-clip that closes with the "
            "least change)"
        )
    return note


def _joint_limits(motion: Motion, option: str | JointLimits) -> tuple[str, JointLimits | None]:
    """The mode and limits of ``loop_motion(joint_limits=...)`` for a prepared clip."""
    if isinstance(option, JointLimits):
        lim = option
        mode = "keep"
    elif option == "off":
        return "off", None
    else:
        from elastic_motion.motion.asfamc import read_joint_limits

        lim = read_joint_limits(motion)
        mode = option
    if lim is None:
        return mode, None
    lim = lim.restricted_to(motion.skeleton.names)
    return (mode, lim) if lim.joints else (mode, None)
