"""What a loop gives back: :class:`LoopResult`.

Units: angles in degrees in the reports (radians in ``heading_change``), positions in metres
when the motion's ``metres_per_unit`` is known (else in its length unit), times in seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from elastic_motion.apps.loop.kept_contacts import KeptContacts
from elastic_motion.apps.loop.limits import LoopLimits
from elastic_motion.apps.loop.window import CycleWindow
from elastic_motion.apps.metrics import ContactSkating, SeamMetrics
from elastic_motion.apps.metrics.floor import FootQuality
from elastic_motion.apps.prepare import PreparedMotions
from elastic_motion.closing import ClosingResult
from elastic_motion.motion import Motion
from elastic_motion.motion.contacts import Contacts
from elastic_motion.notes import Note

__all__ = ["LoopResult"]


@dataclass(frozen=True, eq=False)
class LoopResult:
    """A looped motion (:func:`elastic_motion.apps.loop.loop_motion`).

    Attributes
    ----------
    motion : Motion
        The closed cycle: same frames, skeleton and first frame as the prepared input
        (metres when the unit is known, Y-up).
    original : Motion
        The prepared input (the window's frames).
    closing : ClosingResult
        The curve-level result (gap history, iterations, timing; see
        :mod:`elastic_motion.closing`).
    method : {"lie", "euler-elastic"}
    root : {"travel", "inplace"}
    seam : {"c0", "c1"}
        The seam closed (with ``seam="auto"``: the one taken).
    closed_joints, free_joints : tuple of str
        Joints whose rotations were closed / left free.
    heading_change : float
        ``delta`` of the result's cycle transform, radians (0 for ``"inplace"``).
    displacement : ndarray, shape (3,)
        Floor-plane root displacement per cycle, motion length units (0 for ``"inplace"``).
    seam_before, seam_after : SeamMetrics
        :func:`~elastic_motion.apps.metrics.seam_metrics` of the input and of the loop
        (closed joints; ``seam_after`` with the deviation from the input).
    prepared : PreparedMotions
        The preparation step's result (its ``inputs[0]`` says what was done).
    notes : tuple of Note
        What the loop did (kinds in :mod:`elastic_motion.apps.loop.notes`; the preparation's
        notes first, kind ``"prepare"``).
    window : CycleWindow or None
        The window looped, and how it was chosen (None: the whole clip).
    contacts : Contacts or None
        The input's contacts (None with ``contacts="off"``).
    skating_before, skating_after : ContactSkating or None
        Skating and depth below the floor during the input's contacts, input and loop.
    contacts_kept : KeptContacts or None
        What became of the kept contacts (``contacts="keep"`` and some found).
    joint_limits : LoopLimits or None
        What the loop did with joint limits (None without limits).
    change_m : float
        The most the loop moves a closed joint or end site relative to the root, metres (what
        ``change_bound`` bounds; :attr:`LoopMeasures.change_m`).
    feet_before, feet_after : FootQuality or None
        The clip and the loop, each measured on itself the same way (own contacts, skating,
        skids: :func:`~elastic_motion.apps.metrics.floor.foot_quality`).
    skating_on_treadmill : ContactSkating or None
        In place with contacts kept (a treadmill,
        :func:`~elastic_motion.motion.looping.treadmill`): the loop's skating with the belt's
        motion taken out, how much the feet slip on it; ``skating_after`` is in the world,
        where planted feet move back with the belt.
    """

    motion: Motion
    original: Motion
    closing: ClosingResult
    method: str
    root: str
    seam: str
    closed_joints: tuple[str, ...]
    free_joints: tuple[str, ...]
    heading_change: float
    displacement: np.ndarray
    seam_before: SeamMetrics
    seam_after: SeamMetrics
    prepared: PreparedMotions
    notes: tuple[Note, ...] = ()
    window: CycleWindow | None = None
    contacts: Contacts | None = None
    skating_before: ContactSkating | None = None
    skating_after: ContactSkating | None = None
    contacts_kept: KeptContacts | None = None
    joint_limits: LoopLimits | None = None
    skating_on_treadmill: ContactSkating | None = None
    change_m: float = 0.0
    feet_before: FootQuality | None = None
    feet_after: FootQuality | None = None

    @property
    def c1(self) -> bool:
        """Whether the seam is C1 (the report's ``"c1"``)."""
        return self.seam == "c1"

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
            "change_m": self.change_m,
            "seam_before": self.seam_before.summary(),
            "seam_after": self.seam_after.summary(),
            "free_joints_seam_deg": {
                n: float(self.seam_after.seam_angle_deg[self.motion.skeleton.index(n)])
                for n in self.free_joints
            },
            "feet_before": _feet(self.feet_before),
            "feet_after": _feet(self.feet_after),
            "window": _summary(self.window),
            "contacts": _summary(self.contacts),
            "skating_before": _summary(self.skating_before),
            "skating_after": _summary(self.skating_after),
            "skating_on_treadmill": _summary(self.skating_on_treadmill),
            "contacts_kept": _summary(self.contacts_kept),
            "joint_limits": _summary(self.joint_limits),
            "preparation": [r.summary() for r in self.prepared.inputs],
            "notes": [str(n) for n in self.notes],
        }


def _feet(q: FootQuality | None) -> dict | None:
    """A FootQuality's report without its contact intervals (``contacts`` has the input's)."""
    return None if q is None else {k: v for k, v in q.summary().items() if k != "contacts"}


def _summary(record: Any) -> Any:
    """``record.summary()``, or None."""
    return None if record is None else record.summary()
