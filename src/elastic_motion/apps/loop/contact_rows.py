"""Contacts kept by the loop: planted joints as constraints of the closing projection.

:func:`elastic_motion.apps.loop.loop_motion` with ``contacts="keep"``
(:mod:`elastic_motion.apps.loop.kept_contacts`) solves, in one
projection (:func:`elastic_motion.closing.project_closed`), ``min ||q - q_orig||^2``
subject to closure *and* the input's contacts
(:func:`elastic_motion.motion.contacts.detect_contacts` on the prepared clip):

* **Rows.** For each contact interval ``[a, b)`` of joint ``k`` every frame is constrained:
  the joint's forward-kinematics position (metres, world) equals the input's at that frame
  (3 rows: the input's planted foot, with its own small roll, stays where it was). A
  contact that reaches the clip's last frame (``b = F``) is the first part of a contact
  across the seam: there the floor-plane position is constrained *relative to the last
  frame* (``p(f) - p(F-1) = p_in(f) - p_in(F-1)``, 2 rows) and the height absolutely
  (except at ``F - 1``, which the seam fixes), so closing moves that contact as one piece
  with the next cycle's start; when the joint is planted on the first frame too, its height
  rows are relative to the last frame as well (the seam sets the last frame's height to the
  first's; held absolutely, a CMU 07_01 toe at 6.7 cm over a first frame's 4.5 cm dropped
  2.1 cm in the last step). That holds only when the joint is planted on the first frame
  (else closing it may fail and the contact is released,
  :func:`elastic_motion.apps.loop.kept_contacts.solve_with_contacts`). A foot whose
  toe crosses the seam while its heel (ankle) is planted on the last frame but lifted on
  the first leaves that last heel contact to the toe: rows on both (the heel's absolute,
  the toe's relative to the seam) fight over the rigid foot by a few mm and the solver
  stalls (CMU 55_01 frames 391-991). A heel contact that ends before the last frame and lies
  mostly (over half) within its toe's seam contact moves with the toe: its floor-plane rows are relative to
  the toe's position on the last frame (``anchor_joint``), so the foot keeps the input's
  direction (held absolutely, the heel stayed where it was while the toe went with the seam:
  a Bandai walk's foot turned 22 deg about its heel through the whole stance).
* **Derivatives.** For a left perturbation ``delta R_j = hat(omega) R_j`` of joint ``j``'s
  local rotation at frame ``f``, ``delta p_k = (G_parent(j) omega) x (p_k - p_j)`` for every
  proper ancestor ``j`` of ``k`` (root included, ``G_parent(root) = I``); a change of the
  root translation moves ``p_k`` by the same amount. The projection chains these through
  the ``exp`` steps of the curve (exact discrete Jacobian, tested by finite differences).
* **Every frame of the grid.** Rows only at every ``s``-th frame do not work: the
  projection's correction of the SRV is piecewise constant between the rows' frames, so a
  planted joint drifts between two constrained frames and snaps back at each (a sawtooth:
  measured on CMU 09_11, 120 fps, rows every 4th frame, the right foot skated 2.6 m/s
  against the input's 0.36). With rows on every frame the correction cannot drift, but a
  120 fps clip has four times the rows of a 30 fps one (and the solve grows as their
  cube). So a long clip is closed on a grid of its frames, every grid frame of a contact
  constrained, and the grid's correction is interpolated to all frames
  (:mod:`elastic_motion.apps.loop.contact_grid`); between grid frames a planted joint moves
  by the curvature of the correction only.
* **Planted on every frame.** Between grid frames (and after a solve polished from
  within ``POLISH_MISS``) :func:`row_plants` gives every kept contact's target on every
  frame, and :func:`elastic_motion.apps.loop.planting.plant_and_lift` puts the joints there.
* **Lifted early.** A contact on the last frame of a joint in the air on the first
  (``lift_from`` of :func:`contact_rows`) keeps its floor-plane rows to the end but no
  height rows over its last frames: closing puts the first pose, that joint in the air,
  on the last frame, and the joint rises there without sliding.
* **The floor.** :func:`floor_rows`: rows on the joints and end sites a solved loop takes
  under the floor, at the deepest frame of each dip (an active set; end site ``J + e`` of a
  row is ``p_parent + G_parent offset``, its ancestors the parent's chain and the parent).
* **Gave way.** When contacts and closure cannot all hold, the projection's least-squares
  multipliers spread the conflict; :meth:`ContactConstraints.gave_way` reports, per contact, the
  largest distance (m) between the loop's joint and its constrained position.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from elastic_motion.closing import ExtraConstraints
from elastic_motion.motion import Motion, Skeleton
from elastic_motion.motion.contacts import Contacts, mask_runs
from elastic_motion.motion.kinematics import joint_positions_and_rotations

__all__ = ["FLOOR_ROW", "ContactConstraints", "Row", "contact_rows", "floor_rows", "row_plants"]

_AXES = "xyz"


#: The end of a floor row's name: ``"<joint> above the floor"`` (:func:`floor_rows`).
FLOOR_ROW = " above the floor"


@dataclass(frozen=True)
class Row:
    """One constraint row: the coordinate ``axis`` of point ``joint``'s position (metres,
    world) at ``frame``, minus that of ``anchor_point`` at frame ``anchor`` when relative,
    equals ``target``.

    Attributes
    ----------
    joint : int
        Skeleton index of a joint, or ``J + e`` for end site ``e``.
    name : str
        The contact's joint (or ``"<point> above the floor"``, :func:`floor_rows`).
    interval : tuple of int
        The contact's frames ``[a, b)``.
    frame, axis : int
    anchor : int
        -1: an absolute row; else the frame it is relative to.
    target : float
        Metres.
    anchor_joint : int
        A relative row's point at ``anchor``: -1 its own joint.
    """

    joint: int
    name: str
    interval: tuple[int, int]
    frame: int
    axis: int
    anchor: int
    target: float
    anchor_joint: int = -1

    @property
    def anchor_point(self) -> int:
        """The point a relative row is measured from at its ``anchor`` frame."""
        return self.joint if self.anchor_joint < 0 else self.anchor_joint


def contact_rows(
    motion: Motion,
    contacts: Contacts,
    lift_from: Mapping[str, int] | None = None,
    *,
    c1: bool = False,
) -> list[Row]:
    """The constraint rows of a clip's contacts on every contact frame (module docstring), metres.

    ``lift_from`` maps a joint whose last contact reaches the last frame to the frame from
    which that contact is kept in the floor plane only (no height rows): the joint may rise
    there to meet the first frame's pose across the seam without sliding.

    ``c1``: the seam is C1 (the last step's velocities are the first step's): a lifted
    contact has no rows at all from its ``lift_from`` frame, and a contact across the seam
    none on the frame before the last (rows there would give the last step the input's own
    end velocity, which need not be its first).
    """
    lift_from = dict(lift_from or {})
    f_count = motion.n_frames
    scale = motion.metres_per_unit if motion.metres_per_unit is not None else 1.0
    pos = _fk(motion, motion.rotations, motion.root_translation)[0] * scale
    rows: list[Row] = []
    plan = _SeamPlan.of(motion.skeleton, contacts.all_intervals(), f_count)
    up = _AXES.index(motion.up_axis)
    for name, runs in plan.intervals.items():
        j = motion.skeleton.index(name)
        for a, b in runs:
            block = _Block(j, name, (a, b), up, c1)
            if b == f_count and a > 0:  # a contact across the seam
                if not plan.left_to_toe(name):
                    rows += _seam_rows(block, pos, lift_from.get(name, f_count), name in plan.start)
                continue
            anchor = plan.anchor_of(name, j, a, b)
            rows += _rows_with_the_toe(block, pos, anchor) if anchor >= 0 else _absolute_rows(block, pos)
    return rows


@dataclass(frozen=True)
class _SeamPlan:
    """Which contacts cross the seam, and which move with another's (:func:`contact_rows`).

    A foot planted on the last frame with its toe but lifting its heel on the first: the
    heel's last contact is left to the toe (rows on both, the heel's absolute and the toe's
    relative to the seam, fight over the rigid foot by a few mm and stall the solver).
    """

    skeleton: Skeleton
    intervals: dict[str, list[tuple[int, int]]]
    start: set[str]  # joints planted on the first frame
    crossing_bodies: set[str]  # bodies with a joint planted on the first and the last frame
    seam_runs: dict[str, list[tuple[int, int]]]  # per body: (joint, first frame) kept relative

    @classmethod
    def of(cls, sk: Skeleton, intervals: dict[str, list[tuple[int, int]]], f_count: int) -> _SeamPlan:
        start = {n for n, runs in intervals.items() if runs and runs[0][0] == 0}
        end = {n for n, runs in intervals.items() if runs and runs[-1][1] == f_count}
        plan = cls(sk, intervals, start, set(), {})
        plan.crossing_bodies.update(plan.body(n) for n in end & start)
        # the seam contacts kept relative to the last frame, per body: (joint, first frame), in
        # skeleton order (a set's order follows the string hash, which changes from run to run)
        for name in sorted(end, key=sk.index):
            a = intervals[name][-1][0]
            if a > 0 and not plan.left_to_toe(name):
                plan.seam_runs.setdefault(plan.body(name), []).append((sk.index(name), a))
        return plan

    def body(self, name: str) -> str:
        """The top-most contact joint above ``name`` (a toe's foot), or ``name``."""
        sk = self.skeleton
        top, p = name, sk.parents[sk.index(name)]
        while p >= 0:
            if sk.names[p] in self.intervals:
                top = sk.names[p]
            p = sk.parents[p]
        return top

    def left_to_toe(self, name: str) -> bool:
        """Whether ``name``'s contact across the seam is left to its toe (class docstring)."""
        return name not in self.start and self.body(name) in self.crossing_bodies

    def anchor_of(self, name: str, joint: int, a: int, b: int) -> int:
        """The joint whose seam contact the contact ``[a, b)`` of ``name`` moves with, or -1.

        A heel planted mostly within its toe's seam contact moves with the toe as one piece
        (absolute, it held the heel where it was while the toe went with the seam, and the
        foot turned about the heel: 22 deg through a Bandai walk's stance); a heel contact of
        an earlier step that the toe's last one only overlaps stays absolute.
        """
        runs = self.seam_runs.get(self.body(name), [])
        return next((k for k, s in runs if k != joint and 2 * (b - max(a, s)) > b - a), -1)


@dataclass(frozen=True)
class _Block:
    """One contact interval of one joint, and the frame's conventions (:func:`contact_rows`)."""

    joint: int
    name: str
    interval: tuple[int, int]
    up: int  # index of the up axis
    c1: bool

    @property
    def horizontal(self) -> list[int]:
        return [a for a in range(3) if a != self.up]

    def row(self, frame: int, axis: int, anchor: int, target: float, anchor_joint: int = -1) -> Row:
        return Row(self.joint, self.name, self.interval, frame, axis, anchor, target, anchor_joint)


def _seam_rows(block: _Block, pos: np.ndarray, lift: int, planted_first: bool) -> list[Row]:
    """Rows of a contact across the seam: floor plane relative to the last frame; heights
    absolute, or relative too when the joint is planted on the first frame; none from ``lift``
    on (the floor plane kept there, but with a C1 seam)."""
    (a, b), j, up, last = block.interval, block.joint, block.up, pos.shape[0] - 1
    rows = []
    for f in range(a, b):
        if f == last or (block.c1 and f == last - 1):
            continue
        lifting = f >= lift
        for ax in block.horizontal if not (block.c1 and lifting) else ():
            rows.append(block.row(f, ax, last, pos[f, j, ax] - pos[-1, j, ax]))
        if not lifting and planted_first:
            # planted on the first frame too: the seam sets the last frame's height to the
            # first's, so the block keeps its heights relative to the last frame (held
            # absolutely, a toe at 6.7 cm over a first frame's 4.5 cm dropped 2.1 cm in the
            # last step of a CMU walk's loop)
            rows.append(block.row(f, up, last, pos[f, j, up] - pos[-1, j, up]))
        elif not lifting:
            rows.append(block.row(f, up, -1, pos[f, j, up]))
    return rows


def _rows_with_the_toe(block: _Block, pos: np.ndarray, anchor: int) -> list[Row]:
    """Rows of a contact that moves with joint ``anchor``'s seam contact: floor plane relative
    to ``anchor`` on the last frame, heights absolute."""
    (a, b), j, up, last = block.interval, block.joint, block.up, pos.shape[0] - 1
    rows = []
    for f in range(a, b):
        if f == 0 or (block.c1 and f >= last - 1):
            continue
        for ax in block.horizontal:
            rows.append(block.row(f, ax, last, pos[f, j, ax] - pos[-1, anchor, ax], anchor))
        rows.append(block.row(f, up, -1, pos[f, j, up]))
    return rows


def _absolute_rows(block: _Block, pos: np.ndarray) -> list[Row]:
    """Rows of an interior contact: the joint where the input had it (the first frame never
    changes: no rows there)."""
    (a, b), j = block.interval, block.joint
    return [block.row(f, ax, -1, pos[f, j, ax]) for f in range(max(a, 1), b) for ax in range(3)]


def _fk(
    motion: Motion, rot: np.ndarray, root: np.ndarray, end_sites: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """Positions ``(F, J + E, 3)`` of the joints, then the end sites (motion's unit; ``(F, J,
    3)`` without them), and the joints' global rotations ``(F, J, 3, 3)``. A row's point
    ``J + e`` is end site ``e``."""
    trans = motion.local_translations().copy()
    trans[:, 0] = root
    pos, glob = joint_positions_and_rotations(motion.skeleton.parents, trans, rot)
    sk = motion.skeleton
    if end_sites and sk.end_site_parents.size:
        ep = sk.end_site_parents
        sites = pos[:, ep] + np.einsum("fejk,ek->fej", glob[:, ep], sk.end_site_offsets)
        pos = np.concatenate([pos, sites], axis=1)
    return pos, glob


class ContactConstraints(ExtraConstraints):
    """The contact rows of a prepared clip for :func:`~elastic_motion.closing.project_closed`.

    The curve must be the clip's Lie curve (:func:`elastic_motion.motion.to_lie_curve`: root
    translation, then one ``SO(3)`` copy per joint in skeleton order), in metres.

    Parameters
    ----------
    motion : Motion
        The prepared clip (metres).
    contacts : Contacts
        Its contacts (every contact frame is constrained).
    more_rows : sequence of rows, optional
        Rows from elsewhere, after the contacts' rows.
    lift_from, c1
        Contacts lifted early, a C1 seam (:func:`contact_rows`).
    """

    def __init__(
        self,
        motion: Motion,
        contacts: Contacts,
        more_rows: Sequence[Row] = (),
        lift_from: Mapping[str, int] | None = None,
        c1: bool = False,
    ) -> None:
        self.motion = motion
        self.rows = contact_rows(motion, contacts, lift_from, c1=c1) + list(more_rows)
        self.scale = motion.metres_per_unit if motion.metres_per_unit is not None else 1.0
        self.joint = np.array([r.joint for r in self.rows], dtype=np.int64)
        self.frame = np.array([r.frame for r in self.rows], dtype=np.int64)
        self.axis = np.array([r.axis for r in self.rows], dtype=np.int64)
        self.anchor = np.array([r.anchor for r in self.rows], dtype=np.int64)
        # the point a relative row is measured from: its own joint unless another is named
        self.anchor_point = np.array([r.anchor_point for r in self.rows], dtype=np.int64)
        self.target = np.array([r.target for r in self.rows], dtype=np.float64)
        self._sites = bool((self.joint >= motion.n_joints).any())  # FK of end sites: only if used
        # proper ancestors of each row's point and of its anchor point, padded with -1
        self._anc = self._chains(self.joint)
        self._anc_anchor = self._chains(self.anchor_point)

    def _chains(self, points: np.ndarray) -> np.ndarray:
        """Proper ancestors ``(R, depth)`` of each point, padded with -1; an end site ``J + e``:
        its parent joint and that joint's ancestors."""
        sk, n_joints = self.motion.skeleton, self.motion.n_joints
        chains = []
        for k in points:
            chain, p = [], (sk.parents[k] if k < n_joints else sk.end_site_parents[k - n_joints])
            while p >= 0:
                chain.append(int(p))
                p = sk.parents[p]
            chains.append(chain)
        out = np.full((len(chains), max((len(c) for c in chains), default=0)), -1, dtype=np.int64)
        for r, chain in enumerate(chains):
            out[r, : len(chain)] = chain
        return out

    def __len__(self) -> int:
        return len(self.rows)

    def residual(self, rot: np.ndarray, eu: np.ndarray) -> np.ndarray:
        pos = _fk(self.motion, rot, eu, self._sites)[0] * self.scale
        val = pos[self.frame, self.joint, self.axis]
        rel = self.anchor >= 0
        val[rel] -= pos[self.anchor[rel], self.anchor_point[rel], self.axis[rel]]
        return val - self.target

    def evaluate(
        self, rot: np.ndarray, eu: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        pos, glob = _fk(self.motion, rot, eu, self._sites)
        pos = pos * self.scale
        r_count, m = len(self.rows), rot.shape[1]
        parents = self.motion.skeleton.parents
        frames = np.stack([self.frame, self.anchor], axis=1)
        d_rot = np.zeros((r_count, 2, m, 3))
        d_eu = np.zeros((r_count, 2, eu.shape[1]))
        rows = np.arange(r_count)
        e_ax = np.eye(3)[self.axis]  # (R, 3)
        for slot, sign, point, chains in (
            (0, 1.0, self.joint, self._anc),
            (1, -1.0, self.anchor_point, self._anc_anchor),
        ):
            anc = np.maximum(chains, 0)  # (R, D); padding masked below
            used = (chains >= 0)[:, :, None]
            f = frames[:, slot]
            on = f >= 0
            fs = np.maximum(f, 0)
            lever = pos[fs, point][:, None, :] - pos[fs[:, None], anc]  # (R, D, 3), metres
            par = parents[anc]
            gpar = np.where((par >= 0)[:, :, None, None], glob[fs[:, None], np.maximum(par, 0)], np.eye(3))
            # row ax of -hat(lever) G_parent: e . ((G_par omega) x lever) = (lever x e) . G_par omega
            w = np.cross(lever, e_ax[:, None, :])
            contrib = np.einsum("rai,raij->raj", w, gpar) * (sign * self.scale) * on[:, None, None]
            # the ancestors of a row are distinct: a plain scatter (padding goes to column m)
            wide = np.zeros((r_count, m + 1, 3))
            wide[rows[:, None], np.where(used[:, :, 0], anc, m)] = contrib
            d_rot[:, slot] = wide[:, :m]
            d_eu[rows[on], slot, self.axis[on]] = sign * self.scale
        val = pos[self.frame, self.joint, self.axis]
        rel = self.anchor >= 0
        val[rel] -= pos[self.anchor[rel], self.anchor_point[rel], self.axis[rel]]
        return val - self.target, frames, d_rot, d_eu

    def gave_way(self, rot: np.ndarray, eu: np.ndarray, threshold: float = 1e-3) -> list[dict]:
        """Contacts whose rows are not met within ``threshold`` metres: joint, interval, largest miss."""
        res = np.abs(self.residual(rot, eu))
        out: dict[tuple[str, tuple[int, int]], float] = {}
        for r, row in enumerate(self.rows):
            key = (row.name, row.interval)
            out[key] = max(out.get(key, 0.0), float(res[r]))
        return [
            {"joint": name, "frames": list(iv), "largest_miss_m": miss}
            for (name, iv), miss in out.items()
            if miss > threshold
        ]


def row_plants(
    motion: Motion,
    contacts: Contacts,
    loop: Motion,
    lift_from: Mapping[str, int] | None = None,
    *,
    c1: bool = False,
) -> dict[str, np.ndarray]:
    """Where the kept contacts' rows put each contact joint on every frame of the loop.

    Parameters
    ----------
    motion : Motion
        The prepared clip (the rows' targets are its positions).
    contacts : Contacts
        The kept contacts on its frames (:func:`fine_contacts`).
    loop : Motion
        The loop on the same frames (a seam row's target is relative to its last frame).
    lift_from, c1
        As :func:`contact_rows`, on these frames.

    Returns
    -------
    dict of str to ndarray, shape (F, 3)
        Per contact joint, its planted position in the motion's unit on the frames its rows
        constrain; NaN on other frames and for coordinates without a row (the foot's height
        while it lifts off early, a heel held by its toe).
    """
    rows = contact_rows(motion, contacts, lift_from, c1=c1)
    scale = motion.metres_per_unit if motion.metres_per_unit is not None else 1.0
    pos = _fk(loop, loop.rotations, loop.root_translation)[0] * scale
    out: dict[str, np.ndarray] = {}
    for r in rows:
        plant = out.setdefault(r.name, np.full((motion.n_frames, 3), np.nan))
        base = pos[r.anchor, r.anchor_point, r.axis] if r.anchor >= 0 else 0.0
        plant[r.frame, r.axis] = (r.target + base) / scale
    return out


def floor_rows(
    motion: Motion, closed: Motion, floor: np.ndarray, rows: Sequence[Row], *, tol: float = 0.005
) -> list[Row]:
    """Rows that put back above the floor the joints a closed loop takes under it.

    Per joint or end site and run of frames where ``closed`` has it more than ``tol`` under
    ``floor`` (and ``motion`` does not), one row at the run's deepest frame: the joint's
    height is the input's there (an active set, like the joint limits': the projection is
    solved again with these rows). Not on the first and last frames (the seam fixes them),
    nor on a frame whose height ``rows`` already constrain for that joint.

    Parameters
    ----------
    motion, closed : Motion
        The prepared clip and its loop on the same frames.
    floor : ndarray, shape (F,)
        Per frame, the height no joint may go under (metres).
    rows : sequence of rows
        The rows the loop was solved with.

    Returns
    -------
    list of rows
        Named ``"<joint> above the floor"``, interval ``(f, f + 1)``, metres.
    """
    up = _AXES.index(motion.up_axis)
    scale = motion.metres_per_unit if motion.metres_per_unit is not None else 1.0
    h_in = _fk(motion, motion.rotations, motion.root_translation)[0][..., up] * scale
    h_out = _fk(closed, closed.rotations, closed.root_translation)[0][..., up] * scale
    under = (h_out < floor[:, None] - tol) & (h_in >= floor[:, None] - tol)
    under[[0, -1]] = False
    for r in rows:
        if r.axis == up and r.anchor < 0:
            under[r.frame, r.joint] = False
    sk = motion.skeleton
    names = list(sk.names) + [f"{sk.names[p]} end site" for p in sk.end_site_parents]
    out = []
    for j in np.flatnonzero(under.any(axis=0)):
        name = names[j]
        for a, b in mask_runs(under[:, j]):
            f = a + int(np.argmin(h_out[a:b, j]))
            out.append(Row(int(j), f"{name}{FLOOR_ROW}", (f, f + 1), f, up, -1, float(h_in[f, j])))
    return out
