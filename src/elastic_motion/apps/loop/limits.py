"""Joint limits kept by the loop: an active set of DOF angles pinned at their limits.

:func:`elastic_motion.apps.loop.loop_motion` with ``joint_limits="keep"`` (the default; it
applies when the clip was read from an ASF file with ``limits``, or a
:class:`~elastic_motion.motion.joint_limits.JointLimits` is given) closes the clip with
:func:`elastic_motion.closing.project_closed`, then, at most ``rounds`` times:

1. evaluates every limited DOF angle of the loop per frame
   (:func:`elastic_motion.motion.joint_limits.check_joint_limits`);
2. takes the frames/DOFs beyond their limit (by more than ``tol_deg``) where the *original*
   respected it and adds, of each run of such frames of a DOF, its worst frame and every
   ``step``-th frame to the active set: equality constraints pinning the DOF angle at the
   limit it crossed (:class:`LimitConstraints`, rows of the same projection, next to the
   contact rows if any). The loop between two pinned frames stays near the limit; what is
   still beyond it starts new runs in the next round;
3. probes (:attr:`PinSchedule.probe`): one iteration of the solve with these pins already
   shows where the loop will cross a limit next (frames beside a pin, a DOF the pins push
   over); those are pinned too and probed again, so that one round usually finds the whole
   active set (CMU backflip: one round and two probes instead of two rounds, 1.6 s
   instead of 2.1 s);
4. solves again.

Limits that the original itself violates are never enforced (at those frames), only
reported. Pinned rows are not released (a row whose multiplier has the wrong sign stays), so
the result is a KKT point of the projection with the active set as equalities, not of the
inequality problem; after ``rounds`` rounds any frame still beyond a limit is reported.
Frames 0 and ``F - 1`` are never pinned (the first frame does not change, closure ties the
last to it).

With kept contacts the active set is solved on the grid the contacts close on
(:mod:`elastic_motion.apps.loop.contact_grid`; every frame while their rows fit its budget),
with their rows in every solve: the limits are checked on every frame of the clip with the
grid's correction lifted, and a row pins a clip frame where the lifted loop has it (its
rotation the geodesic of the corrections of the grid frames around it,
:class:`~elastic_motion.apps.loop.contact_grid.GridLift`). Each solve starts from the loop
without limit rows (a warm start of :func:`~elastic_motion.closing.project_closed`), and
the loop is measured again on every frame of what is written (:func:`measured_on_frames`:
the contacts planted by IK after the solve). Before (issue 33), kept limits closed the
contacts on every frame: 2793 rows on CMU charleston1's best cycle, whose contacts and
closure are a hair apart, and every limits solve there failed (16.5 degrees past a limit,
in 23 times the time of the loop without limits).

Derivative of a row ``theta_i(C^T R_f C) - limit``: for ``delta R_f = hat(omega) R_f``,
``d theta / d omega = E^-1 C^T``
(:func:`elastic_motion.motion.joint_limits.dof_angles_jacobian`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from elastic_motion.apps.limit_stage import limits_of
from elastic_motion.apps.loop.contact_grid import GridLift
from elastic_motion.apps.loop.options import LoopOptions
from elastic_motion.closing import ClosingResult, ExtraConstraints
from elastic_motion.errors import OptionError
from elastic_motion.motion import Motion
from elastic_motion.motion.asfamc import read_joint_limits
from elastic_motion.motion.joint_limits import (
    JointLimitReport,
    JointLimits,
    check_joint_limits,
    dof_angles,
    dof_angles_with_jacobian,
    limit_excess,
)
from elastic_motion.notes import Note

__all__ = [
    "LIMIT_STEP",
    "LimitConstraints",
    "LimitsPlan",
    "LoopLimits",
    "StackedConstraints",
    "joint_limit_report",
    "lie_rotations",
    "limits_plan",
    "limits_report",
    "measured_on_frames",
    "solve_within_limits",
]

#: Seconds between the frames of a run beyond a limit that the loop pins (the worst frame and
#: every this many seconds from it): a DOF held still on every frame makes the SRV singular.
LIMIT_STEP = 0.1

#: Kinds of the notes on joint limits (:meth:`LoopLimits.notes`, :func:`limits_plan`).
REPORTED_ONLY_NOTE = "loop.limits_reported_only"
INPUT_VIOLATES_NOTE = "loop.limits_input_violates"
AT_LIMIT_NOTE = "loop.limits_at_limit"
NEWLY_CROSSED_NOTE = "loop.limits_newly_crossed"
LIMITS_MESSAGE_NOTE = "loop.limits_message"


class LimitConstraints(ExtraConstraints):
    """DOF angles pinned at given values (rows of :func:`~elastic_motion.closing.project_closed`).

    The curve must be a clip's Lie curve (root translation, then one ``SO(3)`` copy per
    joint in skeleton order), or the Lie curve of a grid of its frames (``lift``).

    Parameters
    ----------
    limits : JointLimits
    names : sequence of str
        The clip's joint names (skeleton order).
    frame, dof : ndarray of int, shape (R,)
        Per row: the clip's frame and the dof (column of ``limits.angles``).
    target : ndarray, shape (R,)
        The value the dof angle is pinned at, radians.
    lift : GridLift, optional
        The curve is a grid of the clip's frames: a row's rotation is the clip's at its frame
        with the grid's correction lifted (:class:`~elastic_motion.apps.loop.contact_grid.GridLift`),
        so a frame between two grid frames is held where the written loop has it. Its
        derivative is the correction's geodesic weights, ``1 - a`` on the grid frame before
        and ``a`` on the one after (exact on grid frames; between them first order in the
        correction's turn over a grid cell).
    """

    def __init__(
        self,
        limits: JointLimits,
        names: list[str] | tuple[str, ...],
        frame: np.ndarray,
        dof: np.ndarray,
        target: np.ndarray,
        lift: GridLift | None = None,
    ) -> None:
        self.limits = limits
        self.lift = lift
        index = {n: k for k, n in enumerate(names)}
        owner = [(k, i) for k, ax in enumerate(limits.axes) for i in range(len(ax))]
        self.frame = np.asarray(frame, dtype=np.int64)
        self.dof = np.asarray(dof, dtype=np.int64)
        self.target = np.asarray(target, dtype=np.float64)
        self.limit_joint = np.array([owner[d][0] for d in self.dof], dtype=np.int64)
        self.slot = np.array([owner[d][1] for d in self.dof], dtype=np.int64)
        self.joint = np.array([index[limits.joints[k]] for k in self.limit_joint], dtype=np.int64)
        self._group_rows: list[tuple[int, np.ndarray]] | None = None

    def __len__(self) -> int:
        return len(self.frame)

    def _groups(self) -> list[tuple[int, np.ndarray]]:
        """Per limited joint of the rows: its index in ``limits`` and its rows (fixed: cached,
        a solver evaluates the rows a hundred times)."""
        if self._group_rows is None:
            self._group_rows = [
                (int(k), np.flatnonzero(self.limit_joint == k)) for k in np.unique(self.limit_joint)
            ]
        return self._group_rows

    def _rotations(self, rot: np.ndarray) -> np.ndarray:
        """Each row's rotation ``(R, 3, 3)`` on the clip's frame."""
        if self.lift is None:
            return rot[self.frame, self.joint]
        return self.lift.at(rot, self.frame, self.joint)

    def _residual(self, values: np.ndarray) -> np.ndarray:
        """The rows' residuals for their dof angles ``values`` (R,): wrapped to ``[-pi, pi)``."""
        return (values - self.target + math.pi) % (2 * math.pi) - math.pi

    def residual(self, rot: np.ndarray, eu: np.ndarray) -> np.ndarray:
        r_all, lim = self._rotations(rot), self.limits
        values = np.zeros(len(self))
        for k, rows in self._groups():
            ang = dof_angles(r_all[rows], lim.frames[k], lim.axes[k], lim.lower[k], lim.upper[k])
            values[rows] = ang[np.arange(rows.size), self.slot[rows]]
        return self._residual(values)

    def evaluate(
        self, rot: np.ndarray, eu: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        r_count, m = len(self), rot.shape[1]
        lim, r_all = self.limits, self._rotations(rot)
        values, jac_rows = np.zeros(r_count), np.zeros((r_count, 3))
        for k, rows in self._groups():
            ang, jac = dof_angles_with_jacobian(
                r_all[rows], lim.frames[k], lim.axes[k], lim.lower[k], lim.upper[k]
            )
            values[rows] = ang[np.arange(rows.size), self.slot[rows]]
            jac_rows[rows] = jac[np.arange(rows.size), self.slot[rows]]
        if self.lift is None:
            frames, weights = self.frame[:, None].copy(), np.ones((r_count, 1))
        else:
            cell, a = self.lift.bracket(self.frame)
            frames = np.stack([cell, np.where(a > 0, cell + 1, -1)], axis=1)
            weights = np.stack([1.0 - a, a], axis=1)
        d_rot = np.zeros((r_count, frames.shape[1], m, 3))
        for s in range(frames.shape[1]):
            d_rot[np.arange(r_count), s, self.joint] = weights[:, s, None] * jac_rows
        return self._residual(values), frames, d_rot, np.zeros((r_count, frames.shape[1], eu.shape[1]))


class StackedConstraints(ExtraConstraints):
    """Several :class:`~elastic_motion.closing.ExtraConstraints` as one (rows concatenated)."""

    def __init__(self, *parts: ExtraConstraints) -> None:
        self.parts = [p for p in parts if p is not None and len(p) > 0]

    def __len__(self) -> int:
        return sum(len(p) for p in self.parts)

    def residual(self, rot: np.ndarray, eu: np.ndarray) -> np.ndarray:
        return np.concatenate([p.residual(rot, eu) for p in self.parts]) if self.parts else np.zeros(0)

    def evaluate(
        self, rot: np.ndarray, eu: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        out = [p.evaluate(rot, eu) for p in self.parts]
        width = max(o[1].shape[1] for o in out)
        g = np.concatenate([o[0] for o in out])
        frames, d_rot, d_eu = [], [], []
        for _, fr, dr, de in out:
            pad = width - fr.shape[1]
            frames.append(np.pad(fr, ((0, 0), (0, pad)), constant_values=-1))
            d_rot.append(np.pad(dr, ((0, 0), (0, pad), (0, 0), (0, 0))))
            d_eu.append(np.pad(de, ((0, 0), (0, pad), (0, 0))))
        return g, np.concatenate(frames), np.concatenate(d_rot), np.concatenate(d_eu)


@dataclass(frozen=True, eq=False)
class LoopLimits:
    """What the loop did with joint limits (:func:`solve_within_limits`, :class:`LoopResult`).

    Attributes
    ----------
    mode : {"keep", "report"}
    before : JointLimitReport
        The input (the looped frames): limits it violates are reported, not enforced.
    after : JointLimitReport
        The loop.
    rounds : int
        Active-set solves after the first.
    probes : int
        Probes before them (:attr:`PinSchedule.probe` iterations each).
    pinned : int
        Frame/DOF rows pinned at a limit in the final solve.
    pinned_joints : tuple of str
        Joints with a pinned DOF (they end at a limit).
    new_violations : tuple of str
        ``"joint.dof"`` beyond a limit in the loop at a frame where the input respected it
        (empty when the limits were kept, unless ``rounds`` ran out: ``message`` says so).
    message : str
    """

    mode: str
    before: JointLimitReport
    after: JointLimitReport
    rounds: int = 0
    pinned: int = 0
    pinned_joints: tuple[str, ...] = ()
    probes: int = 0
    new_violations: tuple[str, ...] = ()
    message: str = ""

    def summary(self) -> dict:
        """JSON-ready fields."""
        return {
            "mode": self.mode,
            "source": self.before.limits.source,
            "rounds": self.rounds,
            "probes": self.probes,
            "pinned_rows": self.pinned,
            "joints_at_limit": sorted({*self.pinned_joints, *(h.joint for h in self.after.at_limit)}),
            "new_violations": list(self.new_violations),
            "input_violations": self.before.summary()["violations"],
            "loop": self.after.summary(),
            "message": self.message,
        }

    def notes(self) -> list[Note]:
        """Report lines: limits the input violates, joints at a limit, limits the loop crossed."""
        out = []
        if self.before.violations:
            out.append(
                Note(
                    INPUT_VIOLATES_NOTE,
                    "joint limits the input violates (reported, not enforced): "
                    + ", ".join(
                        f"{h.joint}.{h.dof} by {h.worst_deg:.2f} deg" for h in self.before.violations
                    ),
                    {"dofs": [f"{h.joint}.{h.dof}" for h in self.before.violations]},
                )
            )
        joints = sorted({*self.pinned_joints, *(h.joint for h in self.after.at_limit)})
        if joints:
            out.append(
                Note(AT_LIMIT_NOTE, "joints at a limit in the loop: " + ", ".join(joints), {"joints": joints})
            )
        if self.new_violations:
            text = "loop beyond a limit the input respected: " + ", ".join(self.new_violations)
            out.append(Note(NEWLY_CROSSED_NOTE, text, {"dofs": list(self.new_violations)}))
        if self.message:
            out.append(Note(LIMITS_MESSAGE_NOTE, self.message))
        return out


def _new_beyond(after: JointLimitReport, ok_before: np.ndarray) -> np.ndarray:
    tol = math.radians(after.tol_deg)
    return (after.excess > tol) & ok_before


def joint_limit_report(
    motion: Motion, limits: JointLimits | None = None, *, tol_deg: float = 0.01
) -> JointLimitReport:
    """Which joints of a clip are beyond (or at) their limits (``em.joint_limits``).

    Parameters
    ----------
    motion : Motion
        A clip (read from an ASF/AMC pair when ``limits`` is not given).
    limits : JointLimits, optional
        Default: the ``limits`` of the ASF file the motion was read from
        (:func:`elastic_motion.motion.asfamc.read_joint_limits`).
    tol_deg : float, default 0.01
        Beyond a limit means by more than this, degrees.

    Returns
    -------
    JointLimitReport

    Raises
    ------
    OptionError
        No limits given and none in the motion's source.
    """
    if limits is None:
        limits = read_joint_limits(motion)
        if limits is None:
            raise OptionError(
                "limits",
                f"expected JointLimits or a motion read from an ASF file with limits; got {motion!r}",
            )
    return check_joint_limits(motion, limits, tol_deg=tol_deg)


def _respected(before: JointLimitReport, tol_deg: float, *, ends: bool = True) -> np.ndarray:
    """Where the clip respects its limits ``(F, D)``: what a loop must not newly cross. With
    ``ends=False`` never at frames 0 and ``F - 1`` (the seam's, never pinned: module
    docstring)."""
    ok = before.excess <= math.radians(tol_deg)
    if not ends:
        ok[[0, -1]] = False
    return ok


def _new_labels(limits: JointLimits, new_v: np.ndarray) -> tuple[str, ...]:
    labels = limits.dof_labels()
    return tuple(f"{labels[d][0]}.{labels[d][1]}" for d in np.flatnonzero(new_v.any(axis=0)))


def limits_report(
    original: np.ndarray,
    loop: np.ndarray,
    names: list[str] | tuple[str, ...],
    limits: JointLimits,
    *,
    tol_deg: float = 0.01,
) -> LoopLimits:
    """The limits of an input and its loop, measured only (``mode="report"``).

    Parameters
    ----------
    original, loop : ndarray, shape (F, J, 3, 3)
        Local rotations of the input and of the loop (same frames and joints).
    names : sequence of str
    limits : JointLimits
    tol_deg : float, default 0.01
    """
    limits = limits.restricted_to(list(names))
    before = check_joint_limits(original, limits, names=names, tol_deg=tol_deg)
    after = check_joint_limits(loop, limits, names=names, tol_deg=tol_deg)
    new_v = _new_beyond(after, _respected(before, tol_deg))
    return LoopLimits(mode="report", before=before, after=after, new_violations=_new_labels(limits, new_v))


def _pick(beyond: np.ndarray, excess: np.ndarray, step: int) -> np.ndarray:
    """Of each run of ``beyond`` frames (per column): its worst frame and every ``step``-th frame
    before and after it."""
    out = np.zeros_like(beyond)
    for d in np.flatnonzero(beyond.any(axis=0)):
        col = np.concatenate([[False], beyond[:, d], [False]]).astype(np.int8)
        edges = np.flatnonzero(np.diff(col))
        for a, b in zip(edges[::2], edges[1::2], strict=True):
            worst = a + int(np.argmax(excess[a:b, d]))
            out[worst % step : b : step, d][(np.arange(worst % step, b, step) >= a)] = True
    return out


@dataclass(frozen=True)
class PinSchedule:
    """How :func:`solve_within_limits` pins.

    Attributes
    ----------
    rounds : int, default 6
        Solves with limit rows at most. A solve that does not converge (pins too dense:
        a DOF held still makes the SRV singular) is retried with twice the ``step``.
    step : int, default 1
        Frames between the pinned frames of a run (1: every frame beyond the limit).
    tol_deg : float, default 0.01
        Beyond a limit means by more than this, degrees.
    probe : int, default 1
        Newton iterations of a round's probe (0: none). Before a round is solved, this many
        iterations from the loop without limit rows, with the round's pins, show where the
        loop will cross a limit next: those frames are pinned too, and probed again, before
        the round is solved once, from the loop without limit rows (CMU backflip: the
        crossings after one iteration were those of the converged round, and one frame more
        next to one of them; a second round cost 6 iterations, the probes 2 cheap ones).
    probe_margin_deg : float, default 2
        A probe's crossing is pinned only when beyond the limit by more than this, degrees.
        One iteration overshoots: on a synthetic knee its crossings of 0.5-1.6 degrees were
        not crossings of the converged round, and pinning them moved the loop 0.8 % farther
        from the clip (30 pins instead of 12); CMU backflip's were of 2.3-38 degrees. What a
        probe leaves is found by the round's own check, as without probes.
    """

    rounds: int = 6
    step: int = 1
    tol_deg: float = 0.01
    probe: int = 1
    probe_margin_deg: float = 2.0


def solve_within_limits(
    solve: Callable[[ExtraConstraints | None, ClosingResult], ClosingResult],
    clip: Motion,
    limits: JointLimits,
    *,
    base: ExtraConstraints | None = None,
    first: ClosingResult | None = None,
    schedule: PinSchedule | None = None,
    lift: GridLift | None = None,
) -> tuple[ClosingResult, LoopLimits]:
    """The active-set loop of the module docstring.

    Parameters
    ----------
    solve : callable
        ``solve(extra, start, probe) -> result``: :func:`~elastic_motion.closing.project_closed`
        of the clip's Lie curve with the rows ``extra``, from ``start``: the loop without limit
        rows (a warm start: it holds every row but the pins. From the last round's loop
        instead, CMU backflip's second round did not settle in 16 iterations) or a probe of the
        same rows; ``probe > 0``: only that many iterations (:attr:`PinSchedule.probe`).
    clip : Motion
        The input (its local rotations and joint names).
    limits : JointLimits
    base : ExtraConstraints, optional
        Rows solved with every round (the contacts).
    first : ClosingResult, optional
        The solve without limit rows, when already done (else ``solve(base, None)``).
    schedule : PinSchedule, optional
        Rounds, pin spacing and tolerance (default ``PinSchedule()``).
    lift : GridLift, optional
        The solves close a grid of the clip's frames (the contacts' grid): the limits are
        checked, and pinned, on every frame of the clip with the grid's correction lifted
        (:class:`LimitConstraints`); ``step`` is in the clip's frames.

    Returns
    -------
    ClosingResult, LoopLimits
        The last solve that converged (the first one when none with limit rows did); the
        report on the clip's frames.
    """
    original, names = clip.rotations, clip.skeleton.names
    n_joints = clip.n_joints
    sched = schedule if schedule is not None else PinSchedule()
    rounds, tol_deg = sched.rounds, sched.tol_deg

    def rotations_of(res: ClosingResult) -> np.ndarray:
        rot = lie_rotations(res, n_joints)
        return rot if lift is None else lift.rotations(rot)

    limits = limits.restricted_to(list(names))
    before = check_joint_limits(original, limits, names=names, tol_deg=tol_deg)
    ok_before = _respected(before, tol_deg, ends=False)
    res = first if first is not None else solve(base, None, 0)
    free = res
    after = check_joint_limits(rotations_of(res), limits, names=names, tol_deg=tol_deg)
    lo, hi = limits.bounds()
    pinned = np.zeros_like(ok_before)
    target = np.zeros(ok_before.shape)
    done, probes, message = 0, 0, ""
    stride = max(int(sched.step), 1)
    n_frames = ok_before.shape[0]

    def pins(new: np.ndarray, at: ClosingResult, old: np.ndarray) -> ExtraConstraints:
        """The rows of the pins ``old | new``, the ``new`` ones at the limit they cross on ``at``."""
        below, _above = limit_excess(limits.angles(rotations_of(at), list(names)), limits)
        target[new] = np.where(below > 0, lo[None, :], hi[None, :])[new]
        f_idx, d_idx = np.nonzero(old | new)
        rows = LimitConstraints(limits, names, f_idx, d_idx, target[f_idx, d_idx], lift)
        return StackedConstraints(base, rows) if base is not None and len(base) else rows

    while True:
        beyond = _new_beyond(after, ok_before) & ~pinned
        if not beyond.any():
            break
        if done >= rounds:
            message = f"joint limits: still beyond a limit after {rounds} solves"
            break
        new = _pick(beyond, after.excess, stride)
        trial, extra = pinned | new, pins(new, res, pinned)
        for _ in range(rounds if sched.probe > 0 else 0):  # probes: where the loop crosses next
            probe = solve(extra, free, sched.probe)
            probes += 1
            at = check_joint_limits(rotations_of(probe), limits, names=names, tol_deg=tol_deg)
            more = (at.excess > math.radians(sched.probe_margin_deg)) & ok_before & ~trial
            if not np.isfinite(probe.gap) or not more.any():
                break
            more = _pick(more, at.excess, stride)
            trial, extra = trial | more, pins(more, probe, trial)
        cand = solve(extra, free, 0)  # (from the probe instead: 4-5 iterations where 3 did, CMU 02_01)
        done += 1
        if not cand.converged:
            if stride < n_frames and _pick(beyond, after.excess, 2 * stride).sum() < new.sum():
                # pins too dense for the solver: sparser ones (not the same pins again)
                stride *= 2
                continue
            message = f"joint limits: solve {done} did not converge ({cand.message}); kept the previous loop"
            break
        res, pinned = cand, trial
        after = check_joint_limits(rotations_of(res), limits, names=names, tol_deg=tol_deg)
    return res, _kept_report(limits, before, after, ok_before, pinned, (done, probes), message)


def _kept_report(
    limits: JointLimits,
    before: JointLimitReport,
    after: JointLimitReport,
    ok_before: np.ndarray,
    pinned: np.ndarray,
    solves: tuple[int, int],
    message: str,
) -> LoopLimits:
    """The report of :func:`solve_within_limits`: ``pinned`` (frames, DOFs) the pins of the
    loop kept, ``ok_before`` where the clip respected its limits, ``solves`` the rounds and
    probes."""
    labels = limits.dof_labels()
    return LoopLimits(
        mode="keep",
        before=before,
        after=after,
        rounds=solves[0],
        probes=solves[1],
        pinned=int(pinned.sum()),
        pinned_joints=tuple(sorted({labels[d][0] for d in np.flatnonzero(pinned.any(axis=0))})),
        new_violations=_new_labels(limits, _new_beyond(after, ok_before)),
        message=message,
    )


def measured_on_frames(
    info: LoopLimits,
    loop: np.ndarray,
    names: list[str] | tuple[str, ...],
    limits: JointLimits,
    *,
    tol_deg: float,
) -> LoopLimits:
    """``info``, the active set solved on a grid of a clip's frames, measured on every frame.

    Parameters
    ----------
    info : LoopLimits
        :func:`solve_within_limits` on the grid's frames: its ``before`` is the clip it
        solved (every frame), the one the loop is measured against.
    loop : ndarray, shape (F, J, 3, 3)
        Local rotations of the loop on every frame (the grid's correction lifted, the
        contacts planted by IK: what is written).
    names : sequence of str
    limits : JointLimits
    tol_deg : float
        Beyond a limit means by more than this, degrees.

    Returns
    -------
    LoopLimits
        ``after`` and ``new_violations`` of every frame (frames 0 and ``F - 1`` excluded, as
        in :func:`solve_within_limits`); a limit crossed on a written frame that the grid's
        solve did not see (between the grid's frames, or by the IK) is in ``message`` too.
    """
    limits = limits.restricted_to(list(names))
    after = check_joint_limits(loop, limits, names=names, tol_deg=tol_deg)
    new_v = _new_beyond(after, _respected(info.before, tol_deg, ends=False))
    labels = _new_labels(limits, new_v)
    message = info.message
    if labels:
        worst = math.degrees(float(np.max(after.excess[new_v])))
        seen = (
            "joint limits: beyond a limit on the written frames (between the grid's frames or after "
            f"the IK) by up to {worst:.2f} deg: " + ", ".join(labels)
        )
        message = f"{message}; {seen}" if message else seen
    return dataclasses.replace(info, after=after, new_violations=labels, message=message)


def lie_rotations(result: ClosingResult, n_joints: int) -> np.ndarray:
    """The local rotations ``(F, J, 3, 3)`` of a closed Lie curve (root position first)."""
    return np.asarray(result.curve.values)[:, 3:].reshape(-1, n_joints, 3, 3)


@dataclass(frozen=True, eq=False)
class LimitsPlan:
    """What a loop does with the joint limits of a prepared clip (:func:`limits_plan`).

    Attributes
    ----------
    mode : {"keep", "report", "off"}
    limits : JointLimits or None
        The limits of the clip's joints (None: none to keep or report).
    notes : tuple of Note
        Why ``"keep"`` became ``"report"``, if it did.
    tol_deg : float
        Beyond a limit means by more than this, degrees (``limit_tol``).
    """

    mode: str
    limits: JointLimits | None
    notes: tuple[Note, ...] = ()
    tol_deg: float = 0.5

    @property
    def kept(self) -> JointLimits | None:
        """The limits the closing keeps (mode ``"keep"``), or None."""
        return self.limits if self.mode == "keep" else None

    def measured(self, clip: Motion, loop: Motion, solved: LoopLimits | None) -> LoopLimits | None:
        """What the loop did with the limits: ``solved`` (kept by the closing), else the
        limits of ``clip`` and its ``loop`` measured; None without limits."""
        if solved is not None or self.limits is None:
            return solved
        names = clip.skeleton.names
        return limits_report(clip.rotations, loop.rotations, names, self.limits, tol_deg=self.tol_deg)


def limits_plan(clip: Motion, options: LoopOptions) -> LimitsPlan:
    """The joint limits of a prepared clip and what the loop does with them
    (``options.joint_limits``: given limits are kept; ``"keep"`` and ``"report"`` read the
    clip's ASF file; keeping needs the Lie curve and the KKT solver, else they are reported,
    with a note)."""
    mode, lim = limits_of(options.joint_limits, clip)
    if mode == "off":
        return LimitsPlan("off", None, tol_deg=options.limit_tol)
    notes = ()
    if mode == "keep" and not options.solves_kkt_on_lie:
        mode = "report"
        notes = (
            Note(
                REPORTED_ONLY_NOTE,
                "joint limits: reported only (keeping them needs method='lie' and solver='kkt')",
            ),
        )
    return LimitsPlan(mode, lim, notes, options.limit_tol)
