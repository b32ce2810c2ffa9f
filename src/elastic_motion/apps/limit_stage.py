"""Joint limits kept by a blend or a mean: the result's DOF angles moved into their ranges.

One home for the ``joint_limits`` option of the loop, the blend and the mean
(:func:`check_limits_option`, :func:`limits_of`): ``"keep"``, ``"report"``, ``"off"``, a
:class:`~elastic_motion.motion.joint_limits.JointLimits`, or the path of an ASF file whose
``limits`` are kept (a *limits file*: e.g. the skeleton file of CMU clips converted to BVH,
which keep its bone names). ``"keep"`` and ``"report"`` read the limits of the ASF file the
first input was read from (none: nothing happens).

The blend and the mean keep them by :func:`keep_within_limits`, their last stage (after the
contacts' clean-up, whose leg IK bends knees): per limited joint and frame, the DOF angles
(:func:`~elastic_motion.motion.joint_limits.dof_angles`, the turn nearest the range) are
clipped to their range and the correction eased in and out over :data:`LIMIT_EASE` seconds
(:func:`~elastic_motion.motion.joint_limits.project_to_limits`), so that a joint slows into
its limit instead of stopping dead. What is exact: every enforced DOF angle of the result is
within its range (to rounding; read back from a written BVH, to its decimals); the angles
about a joint's other axes and the root are kept. What is not: the change is the nearest point
of the box in DOF angles per frame, eased, not the nearest motion in the SRV metric (the loop
solves that constrained projection, at 10x its time), and it moves the feet the knees carry
(contacts planted before are not planted again; a note gives the largest angle change).

Limits the inputs violate are reported, not enforced: a DOF is enforced at an output frame
only when every input respects it at its matched time (the blend's clock, the mean's warps:
each input's excess beyond the range interpolated between its two frames there).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from elastic_motion.errors import OptionError
from elastic_motion.motion import Motion
from elastic_motion.motion.asfamc import read_joint_limits
from elastic_motion.motion.joint_limits import (
    JointLimitReport,
    JointLimits,
    check_joint_limits,
    project_to_limits,
)
from elastic_motion.notes import Note
from elastic_motion.vocabulary import LIMIT_POLICIES

__all__ = [
    "LIMITS_CHANGED_NOTE",
    "LIMITS_INPUT_VIOLATES_NOTE",
    "LIMITS_NEWLY_CROSSED_NOTE",
    "LIMIT_EASE",
    "LimitStage",
    "check_limits_option",
    "keep_within_limits",
    "limits_of",
]

#: Seconds: half-width of the raised cosine that eases a limit's correction in and out.
LIMIT_EASE = 0.15
#: Kinds of the notes of :meth:`LimitStage.notes`.
LIMITS_CHANGED_NOTE = "limits.changed"
LIMITS_INPUT_VIOLATES_NOTE = "limits.input_violates"
LIMITS_NEWLY_CROSSED_NOTE = "limits.newly_crossed"


def check_limits_option(value: object, name: str = "joint_limits") -> str | JointLimits:
    """The ``joint_limits`` option checked: a policy of
    :data:`~elastic_motion.vocabulary.LimitPolicy`, a JointLimits, or the path of an ASF file
    (read here: its limits, kept).

    Raises
    ------
    OptionError
        Anything else, or an ASF file without limits, naming ``name``.
    """
    if isinstance(value, JointLimits) or (isinstance(value, str) and value in LIMIT_POLICIES):
        return value
    if isinstance(value, str | os.PathLike) and os.fspath(value).lower().endswith(".asf"):
        lim = read_joint_limits(value)
        if lim is None:
            raise OptionError(name, f"expected an ASF file with joint limits; {os.fspath(value)!r} has none")
        return lim
    raise OptionError(
        name, f"expected one of {list(LIMIT_POLICIES)}, a JointLimits or an .asf file; got {value!r}"
    )


def limits_of(option: str | JointLimits, motion: Motion) -> tuple[str, JointLimits | None]:
    """The mode (``"keep"``, ``"report"``, ``"off"``) and the limits of ``motion``'s joints that
    a checked ``joint_limits`` option means (given limits: kept; ``"keep"`` and ``"report"``:
    those of the ASF file ``motion`` was read from, if any). None: no limit to act on."""
    if option == "off":
        return "off", None
    if isinstance(option, JointLimits):
        mode, lim = "keep", option
    else:
        mode, lim = str(option), read_joint_limits(motion)
    if lim is not None:
        lim = lim.restricted_to(motion.skeleton.names)
        lim = lim if lim.joints else None
    return mode, lim


@dataclass(frozen=True, eq=False)
class LimitStage:
    """What a blend or a mean did with joint limits (:func:`keep_within_limits`).

    Attributes
    ----------
    mode : {"keep", "report"}
    before : JointLimitReport
        The result before the stage.
    after : JointLimitReport
        The result (the same as ``before`` with ``"report"``).
    inputs : tuple of JointLimitReport
        Each input over its own frames: the limits it violates are reported, not enforced.
    exempt_dofs : tuple of str
        ``"joint.dof"`` left unenforced at some frame because an input violates it there.
    change : ndarray, shape (F, D)
        Radians by which each DOF angle of the result was changed (0: unchanged).
    exempt : ndarray of bool, shape (F, D)
        Frames and dofs not enforced: an input violates the limit there.
    """

    mode: str
    before: JointLimitReport
    after: JointLimitReport
    inputs: tuple[JointLimitReport, ...]
    exempt_dofs: tuple[str, ...]
    change: np.ndarray
    exempt: np.ndarray

    @property
    def changed_frames(self) -> int:
        """Frames with at least one DOF angle changed."""
        return int((np.abs(self.change) > 0).any(axis=1).sum())

    @property
    def max_change_deg(self) -> float:
        """The largest change of one DOF angle, degrees."""
        return math.degrees(float(np.abs(self.change).max(initial=0.0)))

    def changed(self) -> list[dict]:
        """Per changed dof: joint, dof, how many frames, the first and last, the largest change (deg)."""
        out = []
        for d, (joint, dof) in enumerate(self.after.limits.dof_labels()):
            frames = np.flatnonzero(np.abs(self.change[:, d]) > 0)
            if frames.size:
                out.append(
                    {
                        "joint": joint,
                        "dof": dof,
                        "frames": int(frames.size),
                        "first_frame": int(frames[0]),
                        "last_frame": int(frames[-1]),
                        "max_change_deg": math.degrees(float(np.abs(self.change[frames, d]).max())),
                    }
                )
        return out

    def summary(self) -> dict:
        """JSON-ready fields."""
        return {
            "mode": self.mode,
            "source": self.after.limits.source,
            "ease_s": LIMIT_EASE,
            "changed_frames": self.changed_frames,
            "max_change_deg": self.max_change_deg,
            "changed": self.changed(),
            "exempt_dofs": list(self.exempt_dofs),
            "input_violations": [r.summary()["violations"] for r in self.inputs],
            "before": self.before.summary(),
            "after": self.after.summary(),
        }

    def notes(self) -> list[Note]:
        """Report lines: limits the inputs violate, what was changed, limits still crossed."""
        out = []
        hits = sorted({f"{h.joint}.{h.dof}" for r in self.inputs for h in r.violations})
        if hits:
            text = "joint limits an input violates (reported, not enforced where it does): " + ", ".join(hits)
            out.append(Note(LIMITS_INPUT_VIOLATES_NOTE, text, {"dofs": hits}))
        if self.mode == "keep" and self.changed_frames:
            rows = self.changed()
            text = (
                f"joint limits kept: {self.changed_frames} frames changed, "
                f"up to {self.max_change_deg:.3g} deg ("
                + ", ".join(f"{r['joint']}.{r['dof']} {r['max_change_deg']:.3g}" for r in rows)
                + f"; eased over {LIMIT_EASE:g} s)"
            )
            data = {"frames": self.changed_frames, "max_change_deg": self.max_change_deg}
            out.append(Note(LIMITS_CHANGED_NOTE, text, data))
        beyond = [f"{h.joint}.{h.dof}" for h in self.after.violations if f"{h.joint}.{h.dof}" not in hits]
        if beyond:
            text = "result beyond a joint limit the inputs respect: " + ", ".join(beyond)
            out.append(Note(LIMITS_NEWLY_CROSSED_NOTE, text, {"dofs": beyond}))
        return out


def _excess_at(excess: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """``excess`` ``(F_k, D)`` linearly interpolated at fractional ``frames`` ``(F,)``."""
    f = np.clip(frames, 0.0, excess.shape[0] - 1)
    i = np.clip(np.floor(f).astype(np.int64), 0, max(excess.shape[0] - 2, 0))
    j = np.minimum(i + 1, excess.shape[0] - 1)
    u = (f - i)[:, None]
    return (1.0 - u) * excess[i] + u * excess[j]


def keep_within_limits(
    motion: Motion,
    option: str | JointLimits,
    inputs: Sequence[Motion],
    matched: Sequence[np.ndarray] | None = None,
    *,
    tol_deg: float = 0.01,
) -> tuple[Motion, LimitStage | None]:
    """The result ``motion`` of a blend or a mean within its joint limits (module docstring).

    Parameters
    ----------
    motion : Motion
        The result.
    option : str or JointLimits
        A checked ``joint_limits`` option (:func:`check_limits_option`); ``"keep"`` and
        ``"report"`` read the limits of the first input's ASF file.
    inputs : sequence of Motion
        The inputs (their limits are measured over their own frames).
    matched : sequence of ndarray, shape (F,), optional
        Each input's (fractional) frame at each of the result's frames: a DOF is enforced at a
        frame only where every input respects it there (its excess beyond the range linearly
        interpolated between its two frames: an input respecting it at both is not exempt,
        though its rotation interpolated between them may stray a fraction of a degree past
        the range). Default: only where every input respects it at all its frames.
    tol_deg : float, default 0.01
        Degrees: beyond a limit means by more than this.

    Returns
    -------
    motion : Motion
        ``motion`` within the limits (``"keep"``), else ``motion`` itself.
    stage : LimitStage or None
        None with ``"off"`` or no limits.
    """
    mode, lim = limits_of(option, inputs[0])
    if lim is None:
        return motion, None
    names = motion.skeleton.names
    lim = lim.restricted_to(names)
    reports = tuple(check_joint_limits(m, lim, tol_deg=tol_deg) for m in inputs)
    before = check_joint_limits(motion, lim, tol_deg=tol_deg)
    tol = math.radians(tol_deg)
    if matched is not None:
        exempt = np.zeros(before.excess.shape, dtype=bool)
        for rep, frames in zip(reports, matched, strict=True):
            exempt |= _excess_at(rep.excess, np.asarray(frames, dtype=np.float64)) > tol
    else:
        bad = {(h.joint, h.dof) for r in reports for h in r.violations}
        cols = np.array([lab in bad for lab in lim.dof_labels()], dtype=bool)
        exempt = np.broadcast_to(cols, before.excess.shape)
    labels = [f"{j}.{d}" for (j, d), e in zip(lim.dof_labels(), exempt.any(axis=0), strict=True) if e]
    change = np.zeros(before.excess.shape)
    out = motion
    if mode == "keep" and (before.excess > 0).any():
        ease = round(LIMIT_EASE * motion.fps)
        rot, change = project_to_limits(motion.rotations, names, lim, exempt=exempt, ease_frames=ease)
        out = motion.replace(rotations=rot)
    after = check_joint_limits(out, lim, tol_deg=tol_deg) if out is not motion else before
    return out, LimitStage(mode, before, after, reports, tuple(labels), change, np.asarray(exempt))
