"""The grid a clip with kept contacts is closed on, and the correction lifted to every frame.

Rows of kept contacts on every frame of a 120 fps clip are four times those of a 30 fps one
(and the constrained solve grows as their cube): a clip whose contacts need more than
:data:`ROW_BUDGET` rows is closed on a grid of its frames (:func:`grid_step`, at most
``step`` seconds apart, default 1/30 s; :func:`contact_grid`: nearly uniform, first and last
frame included), every grid frame of a contact constrained
(:mod:`elastic_motion.apps.loop.contact_rows`, module docstring, "Every frame of the grid");
the grid's correction (per joint ``R' R^T``, root offset) is then interpolated to all frames
(:func:`lift_correction`, geodesic in time). The seam frames are grid frames, so the loop
closes exactly (with a C1 seam frames 1 and ``F - 2`` too: the velocities it matches are the
clip's own first and last frame steps).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from elastic_motion.groups import SO3
from elastic_motion.motion import Motion
from elastic_motion.motion.contacts import Contacts

__all__ = ["ROW_BUDGET", "GridLift", "contact_grid", "fine_contacts", "grid_step", "lift_correction"]

_SO3 = SO3()

#: Rows of kept contacts solved on the clip's own frames; above it the grid gets coarser
#: (each solve factors an ``R x R`` matrix: about 0.1 s per iteration at 1200 rows).
ROW_BUDGET = 1200


def grid_step(contacts: Contacts, step: float, budget: int = ROW_BUDGET) -> float:
    """Seconds between the frames a clip with kept contacts is closed on.

    Every frame while the contacts' rows (3 per contact frame) fit in ``budget``; else the
    spacing that brings them under it, at most ``step`` seconds (:func:`contact_grid`).
    """
    rows = 3 * int(np.count_nonzero(contacts.mask))
    if rows <= budget or step <= 0:
        return 0.0
    return min(step, math.ceil(rows / budget) / contacts.fps)


def contact_grid(n_frames: int, fps: float, step: float, *, seam_cells: bool = False) -> np.ndarray:
    """The frames a clip with kept contacts is closed on (module docstring, "every frame").

    Parameters
    ----------
    n_frames : int
    fps : float
        The clip's frame rate.
    step : float
        Seconds between grid frames (at most; 0 or a step below 1.5 frames: every frame).
    seam_cells : bool, default False
        Also frames ``1`` and ``n_frames - 2``: the first and last steps of the grid are the
        clip's own first and last frame steps, whose velocities a C1 seam matches (the
        correction lifted to the clip is exact on grid frames, so the clip's seam is C1 too).

    Returns
    -------
    ndarray of int
        Increasing frame indices, ``0`` and ``n_frames - 1`` included, spacing
        ``floor(step fps)`` or one more (one frame for the seam cells).
    """
    if step <= 0 or step * fps < 1.5 or n_frames < 3:
        return np.arange(n_frames)
    k = max(3, math.ceil((n_frames - 1) / (step * fps)) + 1)
    grid = np.round(np.linspace(0, n_frames - 1, k)).astype(np.int64)
    if seam_cells:
        grid = np.concatenate([grid, [1, n_frames - 2]])
    return np.unique(grid)


def lift_correction(fine: Motion, grid: np.ndarray, before: Motion, after: Motion) -> Motion:
    """``fine`` with the change ``before -> after`` of its grid frames interpolated to all frames.

    Parameters
    ----------
    fine : Motion
        The clip (``F`` frames).
    grid : ndarray of int, shape (K,)
        Increasing frames of ``fine``, ``0`` and ``F - 1`` included.
    before, after : Motion
        ``fine`` on the grid frames, and the same frames changed (e.g. closed).

    Returns
    -------
    Motion
        On the grid frames exactly ``after``; in between, each joint's left correction
        ``D = R_after R_before^T`` follows the geodesic between the neighbouring grid frames'
        (``exp(a log(D_1 D_0^T)) D_0``) and the root offset the straight line.
    """
    f = fine.n_frames
    if grid.size == f:
        return after
    k, a = _bracket(grid, np.arange(f))
    d = after.rotations @ np.swapaxes(before.rotations, -1, -2)  # (K, J, 3, 3)
    step = _SO3.log(d[1:] @ np.swapaxes(d[:-1], -1, -2))  # (K-1, J, 3)
    corr = _SO3.exp(a[:, None, None] * step[k]) @ d[k]
    off = after.root_translation - before.root_translation
    root = fine.root_translation + (1.0 - a)[:, None] * off[k] + a[:, None] * off[k + 1]
    rot = corr @ fine.rotations
    rot[grid] = after.rotations  # exactly (no rounding of the seam frames)
    root[grid] = after.root_translation
    same = np.all(after.rotations == before.rotations, axis=(0, 2, 3))
    rot[:, same] = fine.rotations[:, same]  # unchanged joints (e.g. free ones) stay bit for bit
    return fine.replace(rotations=rot, root_translation=root)


def _bracket(grid: np.ndarray, frames: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per frame of the clip, the grid cell ``k`` it lies in (``grid[k] <= f <= grid[k + 1]``)
    and its fraction ``a`` of the cell."""
    k = np.clip(np.searchsorted(grid, frames, side="right") - 1, 0, grid.size - 2)
    return k, (frames - grid[k]) / (grid[k + 1] - grid[k])


@dataclass(frozen=True, eq=False)
class GridLift:
    """A clip closed on a grid of its frames: its rotations on any frame as
    :func:`lift_correction` lifts the grid's (for rows on the clip's frames solved on the grid:
    the joint limits, :class:`elastic_motion.apps.loop.limits.LimitConstraints`).

    Attributes
    ----------
    frames : ndarray of int, shape (K,)
        The grid (increasing, ``0`` and ``F - 1`` included).
    before : ndarray, shape (K, J, 3, 3)
        The grid's local rotations before closing.
    fine : ndarray, shape (F, J, 3, 3)
        The clip's.
    """

    frames: np.ndarray
    before: np.ndarray
    fine: np.ndarray

    def bracket(self, frames: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per clip frame, its grid cell ``k`` and fraction ``a`` (the frame ``grid[k]`` is
        ``a = 0``)."""
        return _bracket(self.frames, np.asarray(frames))

    def rotations(self, after: np.ndarray) -> np.ndarray:
        """Every frame's rotations ``(F, J, 3, 3)`` for the grid's rotations ``after``."""
        f = self.fine.shape[0]
        if self.frames.size == f:
            return after
        k, a = self.bracket(np.arange(f))
        d = after @ np.swapaxes(self.before, -1, -2)
        step = _SO3.log(d[1:] @ np.swapaxes(d[:-1], -1, -2))
        rot = _SO3.exp(a[:, None, None] * step[k]) @ d[k] @ self.fine
        rot[self.frames] = after
        return rot

    def at(self, after: np.ndarray, frames: np.ndarray, joints: np.ndarray) -> np.ndarray:
        """The rotations ``(R, 3, 3)`` of ``joints`` at the clip's ``frames`` (one pair per
        row) for the grid's rotations ``after``: the correction's geodesic between the
        neighbouring grid frames' (:func:`lift_correction`)."""
        k, a = self.bracket(frames)
        before_t = np.swapaxes(self.before, -1, -2)
        d0 = after[k, joints] @ before_t[k, joints]
        d1 = after[k + 1, joints] @ before_t[k + 1, joints]
        step = _SO3.log(d1 @ np.swapaxes(d0, -1, -2))
        return _SO3.exp(a[:, None] * step) @ d0 @ self.fine[frames, joints]


def fine_contacts(contacts: Contacts, grid: np.ndarray, released: Sequence[dict]) -> Contacts:
    """A clip's contacts without those released on its grid (whole contacts of the clip's frames;
    ``grid = arange(F)``: released on the clip's own frames).

    ``released`` items carry ``joint`` and ``frames`` ``[a, b)`` on the grid's frames
    (:func:`elastic_motion.apps.loop.kept_contacts.solve_with_contacts`); every contact of the clip that
    overlaps grid frames ``grid[a] .. grid[b - 1]`` is dropped.
    """
    mask = np.array(contacts.mask)
    for g in released:
        k = contacts.joints.index(g["joint"])
        lo, hi = int(grid[g["frames"][0]]), int(grid[g["frames"][1] - 1])
        for a, b in contacts.intervals(g["joint"]):
            if a <= hi and b > lo:
                mask[a:b, k] = False
    return dataclasses.replace(contacts, mask=mask)
