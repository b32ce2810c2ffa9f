"""The record a blend returns (:class:`BlendResult`) and its notes' kinds.

Every stage of :func:`elastic_motion.apps.blend.blend_motions` returns its notes as
:class:`~elastic_motion.notes.Note` objects of a stable kind (``"blend.warp"``,
``"blend.cleanup"``, ...; the constants ``NOTE_*`` beside the code that writes them); the
result lists them in the order the stages ran, and its JSON summary their texts.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from elastic_motion.apps.blend_options import BlendOptions
from elastic_motion.apps.cleanup import CleanupResult
from elastic_motion.apps.limit_stage import LimitStage
from elastic_motion.apps.metrics import BlendMetrics
from elastic_motion.apps.prepare import PreparedMotions
from elastic_motion.motion import Motion
from elastic_motion.notes import Note, note_texts
from elastic_motion.warp import WarpOptions

if TYPE_CHECKING:  # the loop and cycles apps are imported only by a blend that needs them
    from elastic_motion.apps.cycles import CycleMatch
    from elastic_motion.apps.loop import LoopResult

__all__ = ["BlendResult"]


#: The preparation's notes (units, T-pose, joints, frame rates, placement), as the inputs came.
@dataclass(frozen=True, eq=False)
class BlendResult:
    """The outcome of :func:`~elastic_motion.apps.blend.blend_motions`.

    Attributes
    ----------
    motion : Motion
        The blend: A's joints (or the common ones), A's frame rate, metres when known.
    method, warp : str
        The curve method and the warp method used.
    weights : ndarray, shape (K,)
        Weight of each input (sum 1); with a weight curve, its mean over the normalised time.
    warps : tuple of ndarray
        Vertices ``(V, 2)`` of ``phi_k``: the result's curve parameter -> input ``k``'s
        (identity for A in a two-motion blend, and for every input without warp).
    landmarks : tuple of (float, float)
        Landmark pairs used, seconds in A and B.
    timing : ndarray, shape (F_out,)
        Curve parameter ``u`` of each output frame (step 4 of the package docstring).
    prepared : PreparedMotions
        The inputs after preparation (units, joints, frame rate, placement).
    warp_options : WarpOptions
        How the warp was found.
    metrics : BlendMetrics or None
        Quality metrics (package docstring); None unless asked for.
    notes : tuple of Note
        What was done, in words (``str(note)``) and by kind (``note.kind``: ``NOTE_*``).
    cleanup : CleanupResult or None
        The foot-skate clean-up (step 7): carried contacts, skating before and after, the
        largest pose change; with ``contacts="report"`` the skating measured and nothing
        changed (``applied`` False); None when skipped (``contacts="off"``, a weight of 1, no
        contacts in the inputs).
    before_cleanup : Motion or None
        The blend before the clean-up (None when no clean-up was applied).
    cycles : CycleMatch or None
        How the gait cycles were matched (``cycles=True``); ``n == 0`` when they could not be.
    loop : LoopResult or None
        The closing of the blended cycle (``loop=True``): seam before and after.
    landmark_pairing : dict or None
        ``landmarks="auto"``: how the events were paired
        (:meth:`elastic_motion.apps.landmarks.PhasePairing.summary`): each pinned pair with
        its offset from the warp without landmarks, its timing window and why; each dropped
        pair and skipped event with the reason. None otherwise.
    pose_anchor_deg : float or None
        The largest correction of the pose anchoring (step 4, degrees: of a joint's rotation
        for ``"lie"``, of one Euler angle for ``"euler-elastic"``); None when not anchored.
    height_anchor_m : float or None
        The largest correction of the root height by the same anchoring (metres; length
        units when the motion's are unknown); None when not anchored.
    weight_curve : ndarray, shape (M, 2) or (M, K + 1), or None
        The knots of a weight curve as given (``weight_curve=``): ``(u, s)`` or
        ``(u, w_1, ..., w_K)``; None for constant weights.
    options : BlendOptions
        The options of the blend.
    trimmed : tuple of (int, int)
        Output frames cut at the start and the end where the warp held an input still
        (``trim_ends``; :func:`elastic_motion.apps.blend.timing.held_ends`).
    joint_limits : LimitStage or None
        What the limits stage did (``joint_limits`` option): the result's limits before and
        after, the inputs' own violations, which dofs and frames changed and by how much;
        None without limits (``"off"``, inputs not read from an ASF file).
    contact_warp : dict or None
        What ``contact_warp="auto"`` decided
        (:meth:`~elastic_motion.apps.blend.contact_warp.ContactWarpChoice.summary`): which
        warp was kept, the skid counts and slid distances of the blend on each and of the
        inputs, the distances under each warp; None when the rule did not run.
    """

    motion: Motion
    method: str
    warp: str
    weights: np.ndarray
    warps: tuple[np.ndarray, ...]
    landmarks: tuple[tuple[float, float], ...]
    timing: np.ndarray
    prepared: PreparedMotions
    warp_options: WarpOptions = field(default_factory=WarpOptions)
    metrics: BlendMetrics | None = None
    notes: tuple[Note, ...] = ()
    cleanup: CleanupResult | None = None
    before_cleanup: Motion | None = None
    cycles: CycleMatch | None = None
    loop: LoopResult | None = None
    landmark_pairing: dict | None = None
    pose_anchor_deg: float | None = None
    height_anchor_m: float | None = None
    weight_curve: np.ndarray | None = None
    options: BlendOptions = field(default_factory=BlendOptions)
    trimmed: tuple[int, int] = (0, 0)
    joint_limits: LimitStage | None = None
    contact_warp: dict | None = None

    def summary(self) -> dict[str, Any]:
        """JSON-ready fields of a report (``docs/cli.md``)."""
        m = self.motion
        return {
            "method": self.method,
            "warp": self.warp,
            "weights": self.weights.tolist(),
            "weight_curve": None if self.weight_curve is None else self.weight_curve.tolist(),
            "landmarks_s": [list(p) for p in self.landmarks],
            "landmark_pairing": self.landmark_pairing,
            "frames": m.n_frames,
            "fps": m.fps,
            "duration_s": m.duration,
            "joints": m.n_joints,
            "warp_options": self.warp_options.to_json(),
            "warp_vertices": [w.tolist() for w in self.warps],
            "preparation": [r.summary() for r in self.prepared.inputs],
            "metrics": None if self.metrics is None else self.metrics.summary(),
            "notes": note_texts(self.notes),
            "cleanup": None if self.cleanup is None else self.cleanup.summary(),
            "cycles": None if self.cycles is None else self.cycles.summary(),
            "loop": None if self.loop is None else self.loop.summary(),
            "pose_anchor_deg": self.pose_anchor_deg,
            "height_anchor_m": self.height_anchor_m,
            "trimmed_frames": list(self.trimmed),
            "joint_limits": None if self.joint_limits is None else self.joint_limits.summary(),
            "contact_warp": self.contact_warp,
        }
