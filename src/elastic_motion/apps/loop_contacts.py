"""Contacts kept by the loop: planted joints as constraints of the closing projection.

:func:`elastic_motion.apps.loop.loop_motion` with ``contacts="keep"`` solves, in one
projection (:func:`elastic_motion.closing_kkt.project_closed`), ``min ||q - q_orig||^2``
subject to closure *and* the input's contacts
(:func:`elastic_motion.motion.contacts.detect_contacts` on the prepared clip):

* **Rows.** For each contact interval ``[a, b)`` of joint ``k`` the frames
  ``a, a + s, a + 2 s, ..., b - 1`` (``s`` = ``step`` seconds in frames) are constrained:
  the joint's forward-kinematics position (metres, world) equals the input's at that frame
  (3 rows: the input's planted foot, with its own small roll, stays where it was). A
  contact that reaches the clip's last frame (``b = F``) is the first part of a contact
  across the seam: there the floor-plane position is constrained *relative to the last
  frame* (``p(f) - p(F-1) = p_in(f) - p_in(F-1)``, 2 rows) and the height absolutely
  (except at ``F - 1``, which the seam fixes), so closing moves that contact as one piece
  with the next cycle's start.
* **Derivatives.** For a left perturbation ``delta R_j = hat(omega) R_j`` of joint ``j``'s
  local rotation at frame ``f``, ``delta p_k = (G_parent(j) omega) x (p_k - p_j)`` for every
  proper ancestor ``j`` of ``k`` (root included, ``G_parent(root) = I``); a change of the
  root translation moves ``p_k`` by the same amount. The projection chains these through
  the ``exp`` steps of the curve (exact discrete Jacobian, tested by finite differences).
* **Gave way.** When contacts and closure cannot all hold, the projection's least-squares
  multipliers spread the conflict; :func:`contact_residuals` reports, per contact, the
  largest distance (m) between the loop's joint and its constrained position.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from elastic_motion.closing_kkt import ExtraConstraints
from elastic_motion.motion import Motion
from elastic_motion.motion.contacts import Contacts
from elastic_motion.motion.kinematics import joint_positions_and_rotations

__all__ = ["ContactConstraints", "contact_rows"]

_AXES = "xyz"


@dataclass(frozen=True)
class _Row:
    joint: int  # skeleton index
    name: str
    interval: tuple[int, int]
    frame: int
    axis: int
    anchor: int  # -1: absolute row; else the frame it is relative to
    target: float


def contact_rows(motion: Motion, contacts: Contacts, step: float = 0.1) -> list[_Row]:
    """The constraint rows of a clip's contacts (module docstring), metres."""
    f_count = motion.n_frames
    up = _AXES.index(motion.up_axis)
    horiz = [a for a in range(3) if a != up]
    scale = motion.metres_per_unit if motion.metres_per_unit is not None else 1.0
    pos = _fk(motion, motion.rotations, motion.root_translation)[0] * scale
    stride = max(1, round(step * motion.fps))
    rows: list[_Row] = []
    for name, runs in contacts.all_intervals().items():
        j = motion.skeleton.index(name)
        for a, b in runs:
            frames = sorted({*range(a, b, stride), b - 1})
            seam = b == f_count and a > 0
            for f in frames:
                if seam:
                    if f == f_count - 1:
                        continue
                    for ax in horiz:
                        rows.append(_Row(j, name, (a, b), f, ax, f_count - 1, pos[f, j, ax] - pos[-1, j, ax]))
                    rows.append(_Row(j, name, (a, b), f, up, -1, pos[f, j, up]))
                else:
                    if f == 0:
                        continue  # the first frame never changes
                    for ax in range(3):
                        rows.append(_Row(j, name, (a, b), f, ax, -1, pos[f, j, ax]))
    return rows


def _fk(motion: Motion, rot: np.ndarray, root: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    trans = motion.local_translations().copy()
    trans[:, 0] = root
    return joint_positions_and_rotations(motion.skeleton.parents, trans, rot)


class ContactConstraints(ExtraConstraints):
    """The contact rows of a prepared clip for :func:`~elastic_motion.closing_kkt.project_closed`.

    The curve must be the clip's Lie curve (:func:`elastic_motion.motion.to_lie_curve`: root
    translation, then one ``SO(3)`` copy per joint in skeleton order), in metres.

    Parameters
    ----------
    motion : Motion
        The prepared clip (metres).
    contacts : Contacts
        Its contacts.
    step : float
        Seconds between constrained frames of a contact.
    """

    def __init__(self, motion: Motion, contacts: Contacts, step: float = 0.1) -> None:
        self.motion = motion
        self.rows = contact_rows(motion, contacts, step)
        self.scale = motion.metres_per_unit if motion.metres_per_unit is not None else 1.0
        sk = motion.skeleton
        parents = sk.parents
        self._ancestors = {}
        for r in self.rows:
            if r.joint not in self._ancestors:
                chain, p = [], parents[r.joint]
                while p >= 0:
                    chain.append(int(p))
                    p = parents[p]
                self._ancestors[r.joint] = np.array(chain, dtype=np.int64)
        self.joint = np.array([r.joint for r in self.rows], dtype=np.int64)
        self.frame = np.array([r.frame for r in self.rows], dtype=np.int64)
        self.axis = np.array([r.axis for r in self.rows], dtype=np.int64)
        self.anchor = np.array([r.anchor for r in self.rows], dtype=np.int64)
        self.target = np.array([r.target for r in self.rows], dtype=np.float64)

    def __len__(self) -> int:
        return len(self.rows)

    def residual(self, rot: np.ndarray, eu: np.ndarray) -> np.ndarray:
        pos = _fk(self.motion, rot, eu)[0] * self.scale
        val = pos[self.frame, self.joint, self.axis]
        rel = self.anchor >= 0
        val[rel] -= pos[self.anchor[rel], self.joint[rel], self.axis[rel]]
        return val - self.target

    def evaluate(
        self, rot: np.ndarray, eu: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        pos, glob = _fk(self.motion, rot, eu)
        pos = pos * self.scale
        r_count = len(self.rows)
        m = rot.shape[1]
        frames = np.stack([self.frame, self.anchor], axis=1)
        d_rot = np.zeros((r_count, 2, m, 3))
        d_eu = np.zeros((r_count, 2, eu.shape[1]))
        parents = self.motion.skeleton.parents
        val = pos[self.frame, self.joint, self.axis].copy()
        for r in range(r_count):
            k, ax = self.joint[r], self.axis[r]
            for slot, (f, sign) in enumerate(((self.frame[r], 1.0), (self.anchor[r], -1.0))):
                if f < 0:
                    continue
                anc = self._ancestors[k]
                lever = pos[f, k] - pos[f, anc]  # (A, 3), metres
                gpar = np.where(
                    (parents[anc] >= 0)[:, None, None], glob[f, np.maximum(parents[anc], 0)], np.eye(3)
                )
                # row ax of -hat(lever) G_parent: (G_par omega) x lever, component ax
                e = np.zeros(3)
                e[ax] = 1.0
                w = np.cross(lever, e)  # e . (v x lever) = v . (lever x e)
                d_rot[r, slot, anc] += sign * np.einsum("ai,aij->aj", w, gpar) * self.scale
                d_eu[r, slot, ax] += sign * self.scale
            if self.anchor[r] >= 0:
                val[r] -= pos[self.anchor[r], k, ax]
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
