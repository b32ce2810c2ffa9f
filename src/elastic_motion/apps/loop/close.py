"""Closing one prepared clip into a loop (:class:`ClipCloser`): its curve projected onto the
closed curves, with kept contacts and kept joint limits when asked.

What closes (the loop convention of :mod:`elastic_motion.motion.looping`):

* **Lie curve** ``R^3 x SO(3)^J`` (:func:`elastic_motion.motion.to_lie_curve`, with its
  default weights), ``root="travel"``: every closed joint's local rotation (free joints keep
  their samples); the root orientation *relative to heading*, i.e. up to a rotation about
  the up axis (the swing residual of :mod:`elastic_motion.closing`); the root height. The
  floor-plane root trajectory keeps its samples, so the displacement of one cycle is kept.
  ``root="inplace"``: all of it, floor position and heading too (paper 000's closing).
* **Euler baseline** (``method="euler-elastic"``): the same motion as continuous Euler angles
  in ``R^(3+3J)`` (:func:`elastic_motion.motion.to_euler_curve`, with the Lie curve's weights
  on the coordinates), closed by the Newton projection of paper 001, Thm. 2
  (:func:`elastic_motion.closing.project_closed_rd`; C1 by
  :func:`elastic_motion.closing.close_curve`). In ``"travel"`` it closes the root height,
  every joint's three angles and the root's three angles -- except the root's outermost
  angle when that is about the up axis (then it *is* the heading and stays free). Euler
  angles have no heading coordinate otherwise, so a turning clip is turned back.

The first frame never changes.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from elastic_motion._threads import single_threaded_blas
from elastic_motion.apps.loop.contact_grid import GridLift
from elastic_motion.apps.loop.kept_contacts import (
    POLISH_GAP,
    STALL_ITERATIONS,
    GridClip,
    GridSolve,
    KeptContacts,
    close_keeping_contacts,
)
from elastic_motion.apps.loop.limits import (
    LIMIT_STEP,
    LoopLimits,
    PinSchedule,
    measured_on_frames,
    solve_within_limits,
)
from elastic_motion.apps.loop.options import LoopOptions
from elastic_motion.apps.progress import Progress
from elastic_motion.closing import (
    ClosingResult,
    ExtraConstraints,
    close_curve,
    project_closed,
    project_closed_rd,
)
from elastic_motion.curves import DiscreteCurve, srv_distance, srv_transform
from elastic_motion.errors import OptionError
from elastic_motion.groups import Euclidean
from elastic_motion.motion import Motion, finger_joints, lie_group_for, to_lie_curve
from elastic_motion.motion.contacts import ContactPolicy, Contacts, detect_contacts
from elastic_motion.motion.joint_limits import JointLimits
from elastic_motion.motion.looping import treadmill
from elastic_motion.motion.representations import EULER, LIE, Representation, representation

#: A limits solve stops after this many times the iterations of the solve without limits (+4).
LIMIT_ITERATIONS = 4

__all__ = ["ClipCloser", "ClosedClip", "ClosedJoints", "Projection", "closed_joints", "closing_mask"]

_AXES = "xyz"


@dataclass(frozen=True, eq=False)
class ClosedJoints:
    """Which joints of a clip close (:func:`closed_joints`).

    Attributes
    ----------
    mask : ndarray of bool, shape (J,)
        Per joint, skeleton order: closed.
    closed, free : tuple of str
        The closed and the free joints' names, skeleton order.
    """

    mask: np.ndarray
    closed: tuple[str, ...]
    free: tuple[str, ...]


def closed_joints(motion: Motion, free_joints: str | tuple[str, ...] | None) -> ClosedJoints:
    """The joints of ``motion`` that close: all but ``free_joints`` (``"fingers"``: the finger
    and thumb joints, :func:`~elastic_motion.motion.finger_joints`; None: none; or names).

    Raises
    ------
    OptionError
        A name that is not a joint of the skeleton.
    """
    names = motion.skeleton.names
    if free_joints is None:
        free = set()
    elif isinstance(free_joints, str):
        free = set(finger_joints(motion.skeleton))
    else:
        unknown = [n for n in free_joints if n not in names]
        if unknown:
            raise OptionError(
                "free_joints",
                f"expected joint names of the skeleton {list(names)}; got unknown {unknown}",
            )
        free = set(free_joints)
    mask = np.array([n not in free for n in names])
    closed = tuple(n for n, c in zip(names, mask, strict=True) if c)
    return ClosedJoints(mask, closed, tuple(n for n, c in zip(names, mask, strict=True) if not c))


def closing_mask(motion: Motion, joints: ClosedJoints, root: str, rep: Representation) -> np.ndarray:
    """Which coordinates of the curve close, ``(3 + 3 J,)`` bool: the root position (in
    ``"travel"`` its height only), then 3 per joint, root first (module docstring).

    In ``"travel"`` the root's heading stays free: on the Lie curve the rotation about the
    up axis (the swing residual), on the Euler curve the root's outermost angle when that is
    about the up axis."""
    j, up = motion.n_joints, _AXES.index(motion.up_axis)
    rot_mask = np.repeat(joints.mask, 3).reshape(j, 3)
    pos_mask = np.ones(3, dtype=bool)
    if root == "travel":
        pos_mask[:] = False
        pos_mask[up] = True
        heading = _heading_coordinate(motion, rep)
        if joints.mask[0] and heading is not None:
            rot_mask[0, heading] = False
    return np.concatenate([pos_mask, rot_mask.ravel()])


def _heading_coordinate(motion: Motion, rep: Representation) -> int | None:
    """The root rotation's coordinate that is the heading: on the Lie curve the rotation about
    the up axis (the swing residual), on the Euler curve the outermost angle when it is about
    the up axis (else none: a turning clip is turned back)."""
    if rep.is_lie:
        return _AXES.index(motion.up_axis)
    return 0 if motion.skeleton.euler_orders[0][0].lower() == motion.up_axis else None


@dataclass(frozen=True, eq=False)
class Projection:
    """The closed curve nearest a clip's curve (:func:`elastic_motion.closing.project_closed`)
    with the loop's mask, seam, tolerance and iterations.

    Attributes
    ----------
    mask : ndarray of bool, shape (3 + 3 J,)
        :func:`closing_mask`.
    options : LoopOptions
    rotation_names : tuple of str or None
        The joints' names, for the cut-locus error (the Lie curve).
    progress : callable or None
        ``progress("closing", k, 0)`` after each iteration.
    """

    mask: np.ndarray
    options: LoopOptions
    rotation_names: tuple[str, ...] | None = None
    progress: Progress | None = None

    def __call__(
        self,
        curve: DiscreteCurve,
        extra: ExtraConstraints | None = None,
        stall: int | None = None,
        iterations: int | None = None,
        start: ClosingResult | None = None,
    ) -> ClosingResult:
        """Project ``curve`` with the rows ``extra``; stop after ``stall`` iterations without
        progress, and after ``iterations`` (at most the options' ``max_iter``); from ``start``'s
        SRV function when given (a loop of ``curve`` with fewer rows: a warm start)."""
        o = self.options
        return project_closed(
            curve,
            start=None if start is None else start.srv,
            factors=self.mask,
            c1=o.is_c1,
            tol=min(o.tol, 1e-9),
            max_iter=max(min(o.max_iter, iterations or o.max_iter), 1),
            rotation_names=None if self.rotation_names is None else list(self.rotation_names),
            extra=extra,
            stall_iterations=stall,
            progress=self.progress,
        )


@dataclass(frozen=True, eq=False)
class ClosedClip:
    """One clip closed (:class:`ClipCloser`).

    Attributes
    ----------
    motion : Motion
        The loop (the clip's name, no source).
    closing : ClosingResult
    kept : KeptContacts or None
        What became of the kept contacts (None when none were kept).
    limits : LoopLimits or None
        The joint limits kept (None when not kept).
    """

    motion: Motion
    closing: ClosingResult
    kept: KeptContacts | None = None
    limits: LoopLimits | None = None


@dataclass(frozen=True, eq=False)
class ClipCloser:
    """Closes clips with one loop's options (the close stage; the window stage calls it on
    each candidate).

    Attributes
    ----------
    options : LoopOptions
        With ``seam`` ``"c0"`` or ``"c1"``.
    joints : ClosedJoints
    limits : JointLimits or None
        Joint limits to keep (needs the Lie curve and the KKT solver).
    progress : callable or None
        ``progress("closing", k, 0)`` of the KKT solver.
    """

    options: LoopOptions
    joints: ClosedJoints
    limits: JointLimits | None = None
    progress: Progress | None = None

    def __call__(self, clip: Motion, contacts: ContactPolicy | None = None) -> ClosedClip:
        """Close ``clip`` (with ``contacts``, default the options' policy: ``"keep"`` plants the
        clip's contacts, anything else closes without them)."""
        rep = representation(self.options.method)
        mask = closing_mask(clip, self.joints, self.options.root, rep)
        if rep.is_lie:
            keep = (contacts or self.options.contact_mode) == "keep"
            found = detect_contacts(clip, self.options.detection) if keep else None
            # the window stage ranks candidates with contacts "report" and closes the chosen one
            # again with them: the limits too are kept then only (issue 33: 6 candidates each
            # solved with limit rows were most of the time of a loop with limits)
            ranking = contacts == "report" and self.options.contact_mode == "keep"
            closed = self._close_lie(clip, mask, found, ranking)
        else:
            closed = self._close_euler(clip, mask)
        return dataclasses.replace(closed, motion=closed.motion.replace(name=clip.name, source=()))

    def projection(self, mask: np.ndarray, clip: Motion) -> Projection:
        """The KKT projection of ``clip``'s Lie curve with ``mask`` and these options."""
        return Projection(mask, self.options, tuple(clip.skeleton.names), self.progress)

    def _lie_curve(self, clip: Motion) -> DiscreteCurve:
        return to_lie_curve(
            clip, self.options.joint_weights, translation_weight=self.options.translation_weight
        )

    def _close_lie(
        self, clip: Motion, mask: np.ndarray, found: Contacts | None, ranking: bool = False
    ) -> ClosedClip:
        """The Lie curve closed (with the contacts ``found`` kept when some are planted), within
        the kept joint limits (not when ``ranking``: a candidate window of a loop that keeps its
        contacts, closed again with them and the limits when chosen)."""
        o, project = self.options, self.projection(mask, clip)
        limits = self.limits if o.solver == "kkt" and not ranking else None
        kept = None
        if found is not None and found.any:
            out, res, kept, lie, lim_info = self._keep_contacts(clip, found, project, limits)
            if out is not None:
                if lim_info is not None:  # solved on the contacts' grid: measured on every frame
                    lim_info = measured_on_frames(
                        lim_info, out.rotations, clip.skeleton.names, limits, tol_deg=o.limit_tol
                    )
                return ClosedClip(out, res, kept, lim_info)
        elif o.solver == "kkt":
            lie = self._lie_curve(clip)
            res = project(lie)
        else:
            lie = self._lie_curve(clip)
            res = close_curve(
                lie, method=o.solver, tol=o.tol, max_iter=o.max_iter, factors=mask, c1=o.is_c1,
                rotation_names=list(clip.skeleton.names),
            )  # fmt: skip
        if limits is None:
            return ClosedClip(LIE.from_curve(res.curve, clip), res, kept)
        # without contacts (or with contacts dropped): on every frame, no rows but the pins
        res, lim_info = _within_limits(project, lie, clip, limits, res, o.limit_tol)
        return ClosedClip(LIE.from_curve(res.curve, clip), res, kept, lim_info)

    def _keep_contacts(
        self, clip: Motion, found: Contacts, project: Projection, limits: JointLimits | None
    ) -> tuple:
        """:func:`close_keeping_contacts`, within ``limits`` when given (on the contacts' grid);
        in place on the clip's treadmill.

        Returns the loop (None when the contacts were dropped), the closing, what became of
        the contacts, the curve closed (the clip's own when they were dropped) and what the
        grid's solve did with the limits (None without limits or when the contacts were
        dropped: the caller solves them without contacts).
        """
        base, travel = clip, None
        if self.options.root == "inplace":
            # planted feet cannot stay put while the clip comes back to its start: the body then
            # jumped back in the air (1.1 m between two frames of the DeepMimic run). They ride a
            # treadmill instead: the travel is removed at a constant rate, then the rest closed
            base, dist, turn = treadmill(clip)
            unit = clip.metres_per_unit if clip.metres_per_unit is not None else 1.0
            travel = {"travel_m": dist * unit, "turn_deg": float(np.degrees(turn))}
        within = None
        if limits is not None:

            def within(on_grid: GridClip, solved: GridSolve) -> tuple[ClosingResult, LoopLimits]:
                grid = on_grid.frames
                lift = (
                    None
                    if grid.size == base.n_frames
                    else GridLift(grid, on_grid.motion.rotations, base.rotations)
                )
                return _within_limits(
                    project, on_grid.curve, base, limits, solved.result, self.options.limit_tol,
                    grid=solved, lift=lift,
                )  # fmt: skip

        closing = close_keeping_contacts(
            base, found, project, self.options, step=self.options.contact_step, within=within
        )
        kept = closing.kept.replace(treadmill=travel)
        if closing.motion is not None:
            return closing.motion, closing.closing, kept, self._lie_curve(base), closing.limits
        # contacts and closure do not fit together: closed without them, and without the
        # treadmill they needed
        lie = self._lie_curve(clip)
        return None, project(lie), kept, lie, None

    def _close_euler(self, clip: Motion, mask: np.ndarray) -> ClosedClip:
        """The Euler curve, weighted like the Lie curve, closed (module docstring)."""
        o = self.options
        euler = EULER.to_curve(clip)
        weights = lie_group_for(clip.skeleton, o.joint_weights, o.translation_weight).weights
        curve = DiscreteCurve(euler.values, Euclidean(3 + 3 * clip.n_joints, weight=weights), euler.t)
        if o.solver == "kkt":
            res = Projection(mask, o, progress=self.progress)(curve)
        elif o.is_c1:
            res = close_curve(curve, method=o.solver, tol=o.tol, max_iter=o.max_iter, factors=mask, c1=True)
        else:
            res = project_closed_rd(curve, factors=mask, tol=o.tol, max_iter=o.max_iter)
        return ClosedClip(EULER.from_curve(res.curve, clip), res)


def _within_limits(
    project: Projection,
    lie: DiscreteCurve,
    clip: Motion,
    limits: JointLimits,
    first: ClosingResult,
    tol_deg: float,
    *,
    grid: GridSolve | None = None,
    lift: GridLift | None = None,
) -> tuple[ClosingResult, LoopLimits]:
    """:func:`solve_within_limits` of ``clip`` (its Lie curve ``lie``, or with ``lift`` the
    Lie curve of a grid of its frames; closed to ``first``, with ``grid`` the contacts' solve
    on that grid: its rows are rows of every round, and polish a stalled round unless that
    solve was itself closed exactly without them, the IK planting the contacts after), pins
    every :data:`LIMIT_STEP` seconds, each round's solve (:func:`_limits_solve`)
    warm-started from ``first``, the loop without limit rows. One BLAS thread: the Gram matrices
    of the rows are a few hundred to a few thousand (issue 33: a 1000-row Cholesky took 0.7 s
    with two threads on a busy machine, the contacts' own solve 0.3 s per iteration with one)."""
    cap = LIMIT_ITERATIONS * max(first.iterations, 1) + 4
    step = max(1, round(LIMIT_STEP * clip.fps))
    base = None if grid is None else grid.constraints
    polish_rows = None if grid is None or grid.polished else grid.constraints

    def solve(extra: ExtraConstraints | None, start: ClosingResult | None, probe: int) -> ClosingResult:
        if probe:  # a few iterations: where the loop goes with these pins
            return project(lie, extra, iterations=probe, start=start)
        return _limits_solve(project, lie, extra, polish_rows, cap, start)

    with single_threaded_blas():
        return solve_within_limits(
            solve,
            clip,
            limits,
            base=base,
            first=first,
            schedule=PinSchedule(step=step, tol_deg=tol_deg),
            lift=lift,
        )


def _limits_solve(
    project: Projection,
    lie: DiscreteCurve,
    extra: ExtraConstraints | None,
    polish_rows: ExtraConstraints | None,
    cap: int,
    start: ClosingResult | None = None,
) -> ClosingResult:
    """A solve of :func:`solve_within_limits`: ``lie`` projected with the rows ``extra``
    (pins and the contacts' rows, if any) from ``start`` (warm; from ``lie`` itself again when
    that runs out of iterations), stopping when the gap stops shrinking or after ``cap``
    iterations.

    A solve that stopped short of its tolerances (the optimality residual at the rounding
    floor, 1e-7, or the gap flat near 1e-7: issue 33, CMU backflip; or the contacts' rows
    and closure a hair apart, so that the gap stalls at 1e-4: CMU charleston1) is closed
    exactly from where it stopped with the rows ``polish_rows`` only: the pins then move by
    far less than ``limit_tol``, which the next round checks. Before, such a solve ran to
    ``max_iter`` and counted as failed, and its retries with sparser pins picked the same pins
    and failed the same way (five of them: 30x the time of the loop without limits).
    """
    res = project(lie, extra, stall=STALL_ITERATIONS, iterations=cap, start=start)
    if start is not None and not res.converged and res.iterations >= cap:
        # the warm start wandered without settling (CMU backflip's second round: 16 iterations
        # along the closed curves, the loop 5x farther from the clip): from the clip itself
        res = project(lie, extra, stall=STALL_ITERATIONS, iterations=cap)
    if res.converged or not np.isfinite(res.gap):
        return res
    polish = project(res.curve, polish_rows if polish_rows is not None and len(polish_rows) else None)
    if not (polish.converged or polish.gap <= POLISH_GAP):
        return res
    change = srv_distance(polish.srv, srv_transform(lie))  # from the input
    message = f"limits solve stopped ({res.message}); closed exactly from there ({polish.message})"
    return dataclasses.replace(polish, change=change, message=message, converged=True)
