"""Closing a clip with its contacts kept (``contacts="keep"``): the constrained projection on a
grid of the clip's frames, and what became of the contacts (:class:`KeptContacts`).

The stages of :func:`close_keeping_contacts`, each a function here:

1. **Solve, releasing what conflicts** (:func:`solve_with_contacts`): the contacts' rows
   (:mod:`elastic_motion.apps.loop.contact_rows`) on the grid
   (:mod:`elastic_motion.apps.loop.contact_grid`) are constraints of the KKT projection; a
   contact planted on the last frame by a joint in the air on the first is lifted early
   (:data:`LIFT_TIME`); when the projection fails, the contacts it missed most are released.
2. **The floor** (:func:`pin_above_floor`): points the loop takes under the floor are pinned
   at their deepest frame and the projection solved again (an active set, at most
   :data:`FLOOR_ROUNDS` rounds and :data:`MAX_FLOOR_PINS` rows).
3. **Polish** (:func:`polish_or_release`): a solve that stopped with its contacts within
   :data:`POLISH_MISS` is closed exactly from there; when that loses them, the worst are
   released and the projection solved again.
4. **Within the joint limits** (``within``, when the loop keeps them): the limits' active set
   (:func:`elastic_motion.apps.loop.limits.solve_within_limits`) solved on the same grid, its
   pins on the clip's frames through the lifted correction, the contacts' rows solved with
   every round.
5. **On every frame** (:func:`elastic_motion.apps.loop.planting.plant_and_lift`): the grid's
   correction lifted to every frame, the kept contacts planted by IK, the body raised out of
   the floor.

Frames in :class:`KeptContacts` are the clip's; metres; the first frame never changes.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from elastic_motion._threads import single_threaded_blas
from elastic_motion.apps.loop.contact_grid import contact_grid, fine_contacts, grid_step, lift_correction
from elastic_motion.apps.loop.contact_rows import FLOOR_ROW, ContactConstraints, Row, floor_rows
from elastic_motion.apps.loop.limits import LoopLimits
from elastic_motion.apps.loop.options import LoopOptions
from elastic_motion.apps.loop.planting import floor_per_frame, plant_and_lift
from elastic_motion.closing import ClosingResult
from elastic_motion.curves import DiscreteCurve, srv_distance, srv_transform
from elastic_motion.limits import check_option
from elastic_motion.motion import Motion, from_lie_curve, select_frames, to_lie_curve
from elastic_motion.motion.contacts import Contacts

__all__ = [
    "FLOOR_ROUNDS",
    "LIFT_TIME",
    "MAX_FLOOR_PINS",
    "MAX_RELEASE",
    "POLISH_MISS",
    "ContactsClosing",
    "GridClip",
    "GridSolve",
    "KeptContacts",
    "WithinLimits",
    "close_keeping_contacts",
    "pin_above_floor",
    "polish_or_release",
    "solve_with_contacts",
]

#: Seconds before the seam over which a contact planted on the last frame, of a joint in the
#: air on the first, is kept in the floor plane only: the joint rises there to the first
#: frame's pose without sliding (a foot lifts off in about this time: 0.1-0.2 s in walks).
LIFT_TIME = 0.15
#: Rounds of the floor's active set (joints the loop takes under the floor pinned at their
#: deepest frame, solved again) and the most rows it adds.
FLOOR_ROUNDS = 2
MAX_FLOOR_PINS = 40
#: Kept contacts missed by at most this (metres) where the constrained projection stopped
#: short are accepted: the loop is closed exactly from there (:attr:`KeptContacts.polished`),
#: if that closing keeps them within twice this, and leg IK plants the feet again (a third of
#: the contacts' detection height, 3 cm: a correction IK makes without a visible pose change).
POLISH_MISS = 0.01
#: A polishing closing (above) that stopped with the seam's gap at most this is closed,
#: whatever its optimality residual did (it may stall at the rounding floor).
POLISH_GAP = 1e-8
#: Contacts released at most when the projection with them fails (then they are dropped).
MAX_RELEASE = 8
#: Iterations without progress after which a constrained projection stops (``stall_iterations``).
STALL_ITERATIONS = 6

#: ``project(curve, extra=None, stall=None, iterations=None, start=None) -> ClosingResult``:
#: the KKT projection of a clip's Lie curve (:class:`elastic_motion.apps.loop.close.Projection`).
Project = Callable[..., ClosingResult]


@dataclass(frozen=True)
class KeptContacts:
    """What became of the contacts a loop kept (:func:`close_keeping_contacts`). Frames are
    the clip's (``[start, stop)``), lengths metres.

    Attributes
    ----------
    rows : int
        Constraint rows the projection was solved with (3 per contact frame of the grid).
    grid_frames : int
        Frames of the grid the clip was closed on.
    grid_fps : float
        The grid's mean frame rate (the clip's when closed on every frame).
    converged : bool
        Whether the constrained projection converged (else the contacts were dropped).
    polished : str or None
        How a projection that stopped short with its contacts within :data:`POLISH_MISS`
        was closed exactly.
    released : tuple of dict
        Contacts released because they conflict with closure: ``joint``, ``frames``
        ``[a, b)``, ``largest_miss_m`` (at release), ``why``.
    lifted_early : tuple of dict
        Contacts planted on the last frame by a joint in the air on the first: ``joint``,
        ``frames`` (from the first frame without a height row to the end).
    floor_pins : tuple of dict
        Points the loop took under the floor, pinned at their deepest frame: ``joint``,
        ``frame``.
    gave_way : tuple of dict
        Kept contacts the loop still misses by more than 1 mm: ``joint``, ``frames``,
        ``largest_miss_m``.
    dropped : str or None
        Why the contacts could not be kept (the clip was closed without them).
    planted_by_ik : dict or None
        Leg and arm IK after the solve: ``skating_before_m_s``, ``skating_after_m_s``,
        ``max_position_change_m`` (None when the IK changed nothing).
    lifted_max_m : float or None
        How far the body was raised out of the floor at most (None when dropped).
    treadmill : dict or None
        In place: the travel removed before closing, ``travel_m`` and ``turn_deg``.
    """

    rows: int
    grid_frames: int
    grid_fps: float
    converged: bool
    polished: str | None = None
    released: tuple[dict, ...] = ()
    lifted_early: tuple[dict, ...] = ()
    floor_pins: tuple[dict, ...] = ()
    gave_way: tuple[dict, ...] = ()
    dropped: str | None = None
    planted_by_ik: dict | None = None
    lifted_max_m: float | None = None
    treadmill: dict | None = None

    def summary(self) -> dict[str, Any]:
        """JSON-ready fields, in this order; ``dropped``, ``planted_by_ik``, ``lifted_max_m``
        and ``treadmill`` only when set (the report's ``"contacts_kept"``)."""
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if value is None and f.name in _WRITTEN_WHEN_SET:
                continue
            out[f.name] = [dict(v) for v in value] if isinstance(value, tuple) else value
        return out

    @classmethod
    def from_summary(cls, data: dict[str, Any]) -> KeptContacts:
        """Inverse of :meth:`summary`."""
        return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in data.items()})

    def replace(self, **changes: Any) -> KeptContacts:
        """A copy with some fields changed."""
        return dataclasses.replace(self, **changes)


#: Fields of :class:`KeptContacts` that its summary has only when they are set.
_WRITTEN_WHEN_SET = ("dropped", "planted_by_ik", "lifted_max_m", "treadmill")


@dataclass(frozen=True, eq=False)
class GridClip:
    """A clip on the frames it is closed on.

    Attributes
    ----------
    motion : Motion
        The grid's frames (:func:`~elastic_motion.motion.select_frames`; ``fps`` the clip's).
    curve : DiscreteCurve or None
        Their Lie curve (what the projection closes).
    frames : ndarray of int, shape (K,)
        The grid's frame numbers in the clip.
    c1 : bool
        A C1 seam.
    """

    motion: Motion
    curve: DiscreteCurve | None
    frames: np.ndarray
    c1: bool = False

    def on_clip(self, item: dict) -> dict:
        """``item`` with its ``frames`` ``[a, b)`` of grid frames as the clip's frames."""
        a, b = item["frames"]
        return {**item, "frames": [int(self.frames[a]), int(self.frames[b - 1]) + 1]}


@dataclass(frozen=True, eq=False)
class GridSolve:
    """A constrained projection on the grid (:func:`solve_with_contacts`) and what was done
    on the way.

    Attributes
    ----------
    result : ClosingResult
    constraints : ContactConstraints
        The rows it was solved with (on the grid's frames).
    released : tuple of dict
        Contacts released (``joint``, ``frames`` on the grid's frames, ``largest_miss_m``,
        ``why``).
    lifting : tuple of dict
        Contacts lifted early (``joint``, ``frames``: from the first grid frame without a
        height row to the end).
    pins : tuple of Row
        Floor rows added (:func:`pin_above_floor`).
    near : float
        How far (metres) the contacts were from holding where the solver stopped.
    polished : str or None
        What the polish did (:func:`polish_or_release`), None when nothing.
    polish_failed : str
        Why closing exactly lost the contacts (the end of the ``dropped`` note), or "".
    """

    result: ClosingResult
    constraints: ContactConstraints
    released: tuple[dict, ...] = ()
    lifting: tuple[dict, ...] = ()
    pins: tuple[Row, ...] = ()
    near: float = 0.0
    polished: str | None = None
    polish_failed: str = ""

    def replace(self, **changes: Any) -> GridSolve:
        """A copy with some fields changed."""
        return dataclasses.replace(self, **changes)


@dataclass(frozen=True, eq=False)
class ContactsClosing:
    """A clip closed with its contacts kept (:func:`close_keeping_contacts`).

    Attributes
    ----------
    motion : Motion or None
        The loop; None when the contacts could not be kept (the caller closes without them:
        ``kept.dropped`` says why).
    closing : ClosingResult
        The constrained projection (on the grid), ``time`` covering every attempt.
    constraints : ContactConstraints
        The rows it was solved with (on the grid's frames).
    kept : KeptContacts
    limits : LoopLimits or None
        What ``within`` did with the joint limits, before the IK (None without it, or when
        the contacts were dropped).
    """

    motion: Motion | None
    closing: ClosingResult
    constraints: ContactConstraints
    kept: KeptContacts
    limits: LoopLimits | None = None


#: ``within(on_grid, solved) -> (result, limits)``: the grid's solve with its contacts kept
#: taken on within the joint limits (:func:`close_keeping_contacts`, step 4).
WithinLimits = Callable[[GridClip, GridSolve], tuple[ClosingResult, LoopLimits]]


def close_keeping_contacts(
    clip: Motion,
    found: Contacts,
    project: Project,
    options: LoopOptions,
    *,
    step: float,
    within: WithinLimits | None = None,
) -> ContactsClosing:
    """Close a prepared clip with its contacts kept (module docstring).

    Parameters
    ----------
    clip : Motion
        The prepared clip (on its treadmill in place).
    found : Contacts
        Its contacts (some planted).
    project : callable
        The KKT projection with the loop's mask and options (:data:`Project`).
    options : LoopOptions
        The weights and the seam.
    step : float
        Seconds between grid frames at most (:func:`~elastic_motion.apps.loop.contact_grid.grid_step`;
        0: every frame).
    within : callable, optional
        The joint limits' stage (:data:`WithinLimits`), run on the grid when the contacts held.
    """
    on_grid, found_c = _grid_clip(clip, found, options, step)
    t_keep = time.perf_counter()
    limits = None
    with single_threaded_blas():  # rows' Gram matrices of ~1000: one BLAS thread is faster
        solved = solve_with_contacts(on_grid, found_c, _stalling(project), max_release=MAX_RELEASE)
        solved = pin_above_floor(on_grid, found_c, solved, project)
        solved = polish_or_release(on_grid, found_c, solved, project)
        if within is not None and solved.result.converged:
            within_res, limits = within(on_grid, solved)
            solved = solved.replace(result=within_res)
    # the time of every constrained solve (released attempts, polish, limits) is the solve's
    res = dataclasses.replace(solved.result, time=time.perf_counter() - t_keep)
    kept = _kept_record(clip, on_grid, solved.replace(result=res))
    if not res.converged:
        return ContactsClosing(None, res, solved.constraints, kept)
    grid = on_grid.frames
    out = lift_correction(clip, grid, on_grid.motion, from_lie_curve(res.curve, on_grid.motion))
    lift_fine = {g["joint"]: int(grid[g["frames"][0]]) for g in solved.lifting}
    spacing = (clip.n_frames - 1) / max(grid.size - 1, 1) / clip.fps if grid.size < clip.n_frames else 0.0
    kept_fine = fine_contacts(found, grid, solved.released)
    out, planted, lifted = plant_and_lift(clip, out, found, kept_fine, lift_fine, on_grid.c1, smooth=spacing)
    return ContactsClosing(
        out, res, solved.constraints, kept.replace(planted_by_ik=planted, lifted_max_m=lifted), limits
    )


def _grid_clip(clip: Motion, found: Contacts, options: LoopOptions, step: float) -> tuple[GridClip, Contacts]:
    """The clip on the frames it is closed on (every frame while the rows fit in the budget)
    with their Lie curve, and the contacts on those frames; the rows bounded before their
    Gram matrix is made (3 rows per contact frame at most)."""
    grid = contact_grid(
        clip.n_frames, clip.fps, grid_step(found, step) if step > 0 else 0.0, seam_cells=options.is_c1
    )
    coarse = select_frames(clip, grid) if grid.size < clip.n_frames else clip
    found_c = found.select_frames(grid) if coarse is not clip else found
    rows = 3 * int(found_c.mask.sum())
    check_option("contacts", "rows of the kept contacts (3 per contact frame):", rows, "max_constraint_rows")
    curve = to_lie_curve(coarse, options.joint_weights, translation_weight=options.translation_weight)
    return GridClip(coarse, curve, grid, options.is_c1), found_c


def _stalling(project: Project, iterations: int | None = None) -> Callable:
    """``solve(curve, extra)`` of :func:`solve_with_contacts`: ``project`` stopping after
    :data:`STALL_ITERATIONS` without progress (and after ``iterations``)."""

    def solve(curve: DiscreteCurve, extra: ContactConstraints) -> ClosingResult:
        if iterations is None:
            return project(curve, extra, stall=STALL_ITERATIONS)
        return project(curve, extra, stall=STALL_ITERATIONS, iterations=iterations)

    return solve


def _kept_record(clip: Motion, on_grid: GridClip, solved: GridSolve) -> KeptContacts:
    """What became of the contacts (:class:`KeptContacts`), on the clip's frames."""
    res, extra, grid = solved.result, solved.constraints, on_grid.frames
    vals = np.asarray(res.curve.values)
    gave_way = extra.gave_way(vals[:, 3:].reshape(vals.shape[0], -1, 3, 3), vals[:, :3])
    dropped = None
    if not res.converged:
        # the gap in the solver's message is the closure's and the contacts' together: say
        # how far the contacts were from holding, the part a user can judge
        dropped = (
            f"contacts dropped ({res.message}; the contacts missed by up to {1000 * solved.near:.1f} mm"
            f"{solved.polish_failed}); closed without them"
        )
    return KeptContacts(
        rows=len(extra),
        grid_frames=int(grid.size),
        grid_fps=float(clip.fps * (grid.size - 1) / max(clip.n_frames - 1, 1)),
        converged=res.converged,
        polished=solved.polished,
        released=tuple(on_grid.on_clip(r) for r in solved.released),
        lifted_early=tuple(on_grid.on_clip(r) for r in solved.lifting),
        floor_pins=tuple(
            {"joint": r.name.removesuffix(FLOOR_ROW), "frame": int(grid[r.frame])} for r in solved.pins
        ),
        gave_way=tuple(on_grid.on_clip(g) for g in gave_way),
        dropped=dropped,
    )


def solve_with_contacts(
    on_grid: GridClip,
    contacts: Contacts,
    solve: Callable[[Any, ContactConstraints], ClosingResult],
    *,
    max_release: int,
    more_rows: Sequence[Row] = (),
    release_near: bool = False,
) -> GridSolve:
    """Close ``on_grid.curve`` with the contacts kept; release contacts that conflict with closure.

    ``on_grid.frames`` are the grid's frame numbers in the clip (``on_grid.motion``'s fps
    the clip's), so :data:`LIFT_TIME` is measured in the clip's time.

    A contact on the last frame of a joint that is in the air on the first is kept in the
    floor plane only over its last :data:`LIFT_TIME` (closing puts the first pose, that
    joint in the air, on the last frame: it must rise there; with a C1 seam it is free
    there, to take the first frame's velocity too). When the projection fails (closure and
    contacts do not fit together), the contact that missed most at the failed solve is
    released (with any that missed at least a quarter as much). At most ``max_release``
    contacts and three re-solves. A failed solve whose contacts all hold within
    :data:`POLISH_MISS` is returned as it is (the caller closes exactly from it), unless
    ``release_near`` (the caller's exact closing from there failed): then it releases too.

    Parameters
    ----------
    on_grid : GridClip
    contacts : Contacts
        On the grid's frames.
    solve : callable
        ``solve(curve, extra) -> ClosingResult``.
    max_release : int
    more_rows : sequence of Row
        Rows solved with the contacts' (floor pins).
    release_near : bool

    Returns
    -------
    GridSolve
        The result, the constraints it was solved with, the released contacts and the
        contacts lifted early (those with rows to lift: a heel whose last contact was left
        to its toe has none).
    """
    mask = np.array(contacts.mask)
    lift_from, lifting = _lift_plan(mask, contacts.joints, on_grid)
    motion, f_count = on_grid.motion, mask.shape[0]
    released: list[dict] = []
    attempts = 0
    while True:
        kept = dataclasses.replace(contacts, mask=mask)
        extra = ContactConstraints(motion, kept, more_rows=more_rows, lift_from=lift_from, c1=on_grid.c1)
        res = solve(on_grid.curve, extra)
        attempts += 1
        if res.converged or len(released) >= max_release or attempts > 3 or not len(extra):
            break
        misses = _misses(res, extra, contacts.joints, release_near)
        if not misses:
            break
        for g in _worst(misses, max_release - len(released)):
            a, b = g["frames"]
            mask[a:b, contacts.joints.index(g["joint"])] = False
            if b == f_count and g["joint"] in lift_from:  # its lift goes with it
                del lift_from[g["joint"]]
                lifting = [x for x in lifting if x["joint"] != g["joint"]]
            released.append({**g, "why": "missed most when the projection with it failed"})
    # (a heel whose last contact was left to its toe has no rows to lift)
    with_rows = {r.name for r in extra.rows if r.interval[1] == f_count}
    return GridSolve(res, extra, tuple(released), tuple(x for x in lifting if x["joint"] in with_rows))


def _lift_plan(
    mask: np.ndarray, joints: Sequence[str], on_grid: GridClip
) -> tuple[dict[str, int], list[dict]]:
    """The contacts lifted early (:func:`solve_with_contacts`): per joint planted on the last
    frame and in the air on the first, the grid frame its height rows stop at, and the
    report items (``joint``, ``frames``).

    A contact that reaches the last frame of a joint in the air on the first cannot hold to
    the end: closing puts the first frame's pose, that joint in the air, on the last frame.
    It is kept in the floor plane only over its last :data:`LIFT_TIME`: the joint rises
    there to meet the first pose without sliding (height rows to the end would make it pop
    up between the last two frames, or fail).
    """
    frames, f_count = on_grid.frames, mask.shape[0]
    # the first grid frame of the clip's last round(LIFT_TIME fps) frames (at least one)
    start = int(np.searchsorted(frames, frames[-1] + 1 - max(1, round(LIFT_TIME * on_grid.motion.fps))))
    lift_from: dict[str, int] = {}
    lifting: list[dict] = []
    for k, name in enumerate(joints):
        if mask[-1, k] and not mask[0, k]:
            a = int(np.flatnonzero(~mask[:, k])[-1]) + 1
            lift_from[name] = max(a + 1, start)
            lifting.append({"joint": name, "frames": [lift_from[name], f_count]})
    return lift_from, lifting


def _misses(
    res: ClosingResult, extra: ContactConstraints, joints: Sequence[str], release_near: bool
) -> list[dict]:
    """The contacts a failed solve missed (``extra.gave_way``; not floor pins), or none when
    they all nearly held (within :data:`POLISH_MISS`: the caller closes exactly from there)
    unless ``release_near``."""
    vals = np.asarray(res.curve.values)
    rot, eu = vals[:, 3:].reshape(vals.shape[0], -1, 3, 3), vals[:, :3]
    if not release_near and np.abs(extra.residual(rot, eu)).max() <= POLISH_MISS:
        return []  # nearly held: the caller closes exactly from here, releasing nothing
    return [g for g in extra.gave_way(rot, eu) if g["joint"] in joints]


def _worst(misses: list[dict], budget: int) -> list[dict]:
    """The contacts to release: the one missed most and any missed at least a quarter as
    much, worst first, at most ``budget``."""
    worst = max(g["largest_miss_m"] for g in misses)
    ranked = [
        g for g in sorted(misses, key=lambda g: -g["largest_miss_m"]) if g["largest_miss_m"] >= 0.25 * worst
    ]
    return ranked[: max(budget, 0)]


def pin_above_floor(on_grid: GridClip, found: Contacts, solved: GridSolve, project: Project) -> GridSolve:
    """The floor's active set: joints the loop takes under the floor get a row at their
    deepest frame (the input's height there) and the projection is solved again, the
    contacts kept so far kept and none released; pins that do not fit are dropped
    (at most :data:`FLOOR_ROUNDS` rounds and :data:`MAX_FLOOR_PINS` rows).

    ``found``: the contacts on the grid's frames (before any release)."""
    coarse = on_grid.motion
    kept = fine_contacts(found, np.arange(coarse.n_frames), solved.released)  # on its own frames
    floor = floor_per_frame(coarse, found)
    for _ in range(FLOOR_ROUNDS):
        res = solved.result
        new = floor_rows(coarse, from_lie_curve(res.curve, coarse), floor, solved.constraints.rows)
        if not res.converged or not new or len(solved.pins) + len(new) > MAX_FLOOR_PINS:
            break
        # (a few rows more than a solve that converged: at most twice its iterations)
        solve = _stalling(project, 2 * res.iterations + 4)
        pins = (*solved.pins, *new)
        again = solve_with_contacts(on_grid, kept, solve, max_release=0, more_rows=pins)
        if not again.result.converged:
            break
        solved = solved.replace(
            result=again.result, constraints=again.constraints, lifting=again.lifting, pins=pins
        )
    return solved


def _worst_miss(res: ClosingResult, extra: ContactConstraints) -> float:
    """How far (metres) the contacts of ``extra`` are from holding on ``res``'s curve."""
    v = np.asarray(res.curve.values)
    return float(np.abs(extra.residual(v[:, 3:].reshape(v.shape[0], -1, 3, 3), v[:, :3])).max(initial=0))


def _polish(solved: GridSolve, project: Project, curve: DiscreteCurve | None) -> GridSolve:
    """A constrained projection that stopped short with its contacts within
    :data:`POLISH_MISS` closed exactly from there, if that keeps them within twice it.

    Returns ``solved`` with ``near`` set and, when polished, the result (converged,
    ``change`` measured from ``curve``, the input) and what was done in ``polished``; when
    the exact closing lost the contacts, why in ``polish_failed`` (the end of the
    ``dropped`` note)."""
    res, extra = solved.result, solved.constraints
    near = _worst_miss(res, extra)
    solved = solved.replace(near=near, polished=None, polish_failed="")
    if res.converged or near > POLISH_MISS:
        return solved
    polish = project(res.curve)
    after = _worst_miss(polish, extra)
    # closed is what counts: a polish whose optimality residual stalled at the rounding
    # floor with the seam shut (the Bandai old walk: contacts within 0.0 mm) is kept
    closed_enough = polish.converged or polish.gap <= POLISH_GAP
    if closed_enough and after <= 2 * POLISH_MISS:
        polished = (
            f"the contacts held within {1000 * near:.1f} mm where the solver stopped "
            f"({res.message}); closed exactly from there (within {1000 * after:.1f} mm)"
        )
        change = srv_distance(polish.srv, srv_transform(curve))  # from the input
        result = dataclasses.replace(polish, change=change, message=polished, converged=True)
        return solved.replace(result=result, polished=polished)
    failed = (
        f"; closing exactly from there missed them by {1000 * after:.1f} mm"
        if closed_enough
        else f"; closing exactly from there failed ({polish.message})"
    )
    return solved.replace(polish_failed=failed)


def polish_or_release(on_grid: GridClip, found: Contacts, solved: GridSolve, project: Project) -> GridSolve:
    """:func:`_polish` ``solved``; when the exact closing lost the contacts and fewer than
    :data:`MAX_RELEASE` were released, release the worst as a failed solve would and solve
    again (without the floor pins), kept when that polishes to a closed loop.

    CMU 131_03 "start, hop, stop" closed whole nearly held its contacts where the solver
    stopped, but closing exactly from there lost them: its final stance cannot stay planted
    on a seam 106 degrees and 0.67 m away; all its contacts were dropped and the loop skated
    0.34 m/s against the input's 0.16.

    ``found``: the contacts on the grid's frames (before any release)."""
    polished = _polish(solved, project, on_grid.curve)
    if not (polished.polish_failed and MAX_RELEASE > len(solved.released)):
        return polished
    again = solve_with_contacts(
        on_grid, found, _stalling(project), max_release=MAX_RELEASE, release_near=True
    )
    again = _polish(again, project, on_grid.curve)
    return again if again.result.converged else polished
