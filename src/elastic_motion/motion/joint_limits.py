"""Joint limits: per-joint Euler DOF angles of local rotations and the ranges they may take.

Acclaim ASF files give, per bone, ``dof`` channels (a subset of ``rx ry rz`` in listed
order), an ``axis`` frame ``C`` and ``limits`` (one ``(min max)`` pair per dof). The
AMC reader (:mod:`elastic_motion.motion.asfamc`) builds the local rotation of a bone as
``R = C M C^T`` with ``M = R_c(gamma) R_b(beta) R_a(alpha)``, the rotations about the fixed
axes ``a, b, c`` applied in listed order (the dof axes, then the missing ones with angle 0).
The *DOF angles* of any rotation ``R`` are read back the same way: ``M = C^T R C``
decomposed in that fixed-axis order, the first ``len(dof)`` angles kept. Of the two
Tait-Bryan solutions (``(alpha, beta, gamma)`` and ``(alpha + pi, pi - beta, gamma + pi)``)
the one whose angles about the missing axes are smallest is taken (for 3 dofs: the one with
the middle angle in ``[-pi/2, pi/2]``). For a rotation the
AMC reader produced they equal the AMC values (modulo 2 pi); for a rotation with a
component about a missing axis (after closing a loop, say) they are the angles of the same
decomposition.

Derivative (left perturbation ``delta R = hat(omega) R``, ``omega`` in the joint's local
frame): ``delta M = hat(C^T omega) M`` and ``C^T omega = E (alpha', beta', gamma')`` with
``E = [R_c R_b e_a, R_c e_b, e_c]``, so ``d angles / d omega = E^-1 C^T``
(:func:`dof_angles_jacobian`; singular only at gimbal lock, middle angle +-90 degrees).

This module does no I/O: :func:`elastic_motion.motion.asfamc.read_joint_limits` builds a
:class:`JointLimits` from an ASF file.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from elastic_motion.motion.rotations import axis_rotation, matrix_to_euler
from elastic_motion.motion.skeleton import Motion

__all__ = [
    "JointLimitReport",
    "JointLimits",
    "LimitHit",
    "check_joint_limits",
    "dof_angles",
    "dof_angles_jacobian",
    "dof_angles_with_jacobian",
    "dof_rotation",
    "project_to_limits",
]

_TWO_PI = 2.0 * math.pi
#: Radians: an angle beyond its range by at most this is within it (rounding of the decomposition).
_ROUNDING = 1e-9


def _full_axes(axes: str) -> str:
    axes = axes.upper()
    if len(set(axes)) != len(axes) or any(a not in "XYZ" for a in axes) or not 1 <= len(axes) <= 3:
        raise ValueError(f"axes: expected 1 to 3 distinct letters of XYZ; got {axes!r}")
    return axes + "".join(a for a in "XYZ" if a not in axes)


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + math.pi) % _TWO_PI - math.pi


def _decompose(
    m: np.ndarray, full: str, n: int, lower: np.ndarray | None = None, upper: np.ndarray | None = None
) -> np.ndarray:
    """All three fixed-axis angles ``(alpha, beta, gamma)`` of ``M`` (module docstring); with
    bounds and 3 dofs, the solution (each angle in its turn nearest the range) least beyond them."""
    ang = matrix_to_euler(m, full[::-1])[..., ::-1]
    alt = _wrap(np.stack([ang[..., 0] + math.pi, math.pi - ang[..., 1], ang[..., 2] + math.pi], axis=-1))
    if n == 3:
        if lower is None or upper is None:
            return ang
        ang = _nearest_turn(ang, lower, upper)
        alt = _nearest_turn(alt, lower, upper)
        swap = _excess_sum(alt, lower, upper) < _excess_sum(ang, lower, upper) - 1e-12
    else:
        swap = np.abs(alt[..., n:]).sum(axis=-1) < np.abs(ang[..., n:]).sum(axis=-1) - 1e-12
    return np.where(swap[..., None], alt, ang)


def _excess_sum(ang: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    return (np.maximum(lo - ang, 0.0) + np.maximum(ang - hi, 0.0)).sum(axis=-1)


def dof_angles(
    rotations: np.ndarray,
    frame: np.ndarray,
    axes: str,
    lower: np.ndarray | None = None,
    upper: np.ndarray | None = None,
) -> np.ndarray:
    """The DOF angles of local rotations (module docstring), radians.

    Parameters
    ----------
    rotations : ndarray, shape (..., 3, 3)
        Local joint rotations ``R``.
    frame : ndarray, shape (3, 3)
        The bone's axis frame ``C`` (ASF ``axis``).
    axes : str
        The dof axes in listed (fixed-axis) order, e.g. ``"XZ"`` for ``dof rx rz``.
    lower, upper : ndarray, shape (3,), optional
        With 3 dofs: the range, to choose the decomposition least beyond it (module docstring).

    Returns
    -------
    ndarray, shape (..., len(axes))
        ``a0, a2`` of the full decomposition in ``[-pi, pi]``, the middle one in
        ``[-pi/2, pi/2]``.
    """
    full = _full_axes(axes)
    c = np.asarray(frame, dtype=np.float64)
    m = c.T @ np.asarray(rotations, dtype=np.float64) @ c
    return _decompose(m, full, len(axes), lower, upper)[..., : len(axes)]


def dof_angles_jacobian(
    rotations: np.ndarray,
    frame: np.ndarray,
    axes: str,
    lower: np.ndarray | None = None,
    upper: np.ndarray | None = None,
) -> np.ndarray:
    """``d angles / d omega`` for ``delta R = hat(omega) R`` (module docstring).

    Parameters
    ----------
    rotations, frame, axes, lower, upper
        As in :func:`dof_angles`.

    Returns
    -------
    ndarray, shape (..., len(axes), 3)
        Radians per radian of ``omega`` (local frame of the joint's parent).
    """
    return dof_angles_with_jacobian(rotations, frame, axes, lower, upper)[1]


def dof_angles_with_jacobian(
    rotations: np.ndarray,
    frame: np.ndarray,
    axes: str,
    lower: np.ndarray | None = None,
    upper: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`dof_angles` and :func:`dof_angles_jacobian` of the same rotations from one
    decomposition (a solver's linearisation needs both).

    Returns
    -------
    angles : ndarray, shape (..., len(axes))
    jacobian : ndarray, shape (..., len(axes), 3)
    """
    full = _full_axes(axes)
    c = np.asarray(frame, dtype=np.float64)
    r = np.asarray(rotations, dtype=np.float64)
    m = c.T @ r @ c
    ang = _decompose(m, full, len(axes), lower, upper)
    idx = ["XYZ".index(a) for a in full]
    eye = np.eye(3)
    rb = axis_rotation(ang[..., 1], full[1])
    rc = axis_rotation(ang[..., 2], full[2])
    col_a = np.einsum("...ij,...jk,k->...i", rc, rb, eye[idx[0]])
    col_b = np.einsum("...ij,j->...i", rc, eye[idx[1]])
    col_c = np.broadcast_to(eye[idx[2]], col_a.shape)
    e = np.stack([col_a, col_b, col_c], axis=-1)
    jac = np.linalg.solve(e, np.broadcast_to(c.T, e.shape))  # E^-1 C^T
    return ang[..., : len(axes)], jac[..., : len(axes), :]


def dof_rotation(angles: np.ndarray, frame: np.ndarray, axes: str) -> np.ndarray:
    """The local rotation of fixed-axis angles, ``R = C M C^T`` (inverse of the full
    decomposition of :func:`dof_angles`; module docstring).

    Parameters
    ----------
    angles : ndarray, shape (..., 3)
        ``(alpha, beta, gamma)``: the dof axes' angles, then the missing axes', radians.
    frame : ndarray, shape (3, 3)
        The bone's axis frame ``C``.
    axes : str
        The dof axes in listed order.

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    full = _full_axes(axes)
    a = np.asarray(angles, dtype=np.float64)
    m = axis_rotation(a[..., 2], full[2]) @ axis_rotation(a[..., 1], full[1])
    m = m @ axis_rotation(a[..., 0], full[0])
    c = np.asarray(frame, dtype=np.float64)
    return c @ m @ c.T


@dataclass(frozen=True, eq=False)
class JointLimits:
    """Ranges of the DOF angles of some joints (module docstring).

    Attributes
    ----------
    joints : tuple of str
        Joints with at least one limited dof.
    axes : tuple of str
        Per joint, its dof axes in listed order (``"XYZ"``, ``"XZ"``, ``"X"``, ...).
    frames : ndarray, shape (K, 3, 3)
        Per joint, the axis frame ``C``.
    lower, upper : tuple of ndarray
        Per joint, one bound per dof, radians (``-inf`` / ``inf``: unlimited).
    source : str
        Where they were read (``""``: built in code).
    """

    joints: tuple[str, ...]
    axes: tuple[str, ...]
    frames: np.ndarray
    lower: tuple[np.ndarray, ...]
    upper: tuple[np.ndarray, ...]
    source: str = ""

    def __post_init__(self) -> None:
        k = len(self.joints)
        frames = np.asarray(self.frames, dtype=np.float64).reshape(k, 3, 3)
        object.__setattr__(self, "frames", frames)
        lo = tuple(np.asarray(v, dtype=np.float64).reshape(-1) for v in self.lower)
        hi = tuple(np.asarray(v, dtype=np.float64).reshape(-1) for v in self.upper)
        if not (len(self.axes) == len(lo) == len(hi) == k):
            raise ValueError("joints, axes, lower and upper: expected one entry per joint")
        for name, ax, a, b in zip(self.joints, self.axes, lo, hi, strict=True):
            _full_axes(ax)
            if a.shape != (len(ax),) or b.shape != (len(ax),):
                raise ValueError(f"limits of {name!r}: expected {len(ax)} bounds per side (dof {ax})")
        object.__setattr__(self, "lower", lo)
        object.__setattr__(self, "upper", hi)

    def to_json(self) -> dict:
        """JSON-ready fields: per joint its axes, frame and range in degrees (None: unlimited)."""
        parts = zip(self.joints, self.axes, self.frames, self.lower, self.upper, strict=True)
        return {
            "source": self.source,
            "joints": [
                {
                    "name": n,
                    "axes": ax,
                    "frame": c.tolist(),
                    "lower_deg": [_finite_or_none(math.degrees(v)) for v in lo],
                    "upper_deg": [_finite_or_none(math.degrees(v)) for v in hi],
                }
                for n, ax, c, lo, hi in parts
            ],
        }

    @classmethod
    def from_json(cls, data: dict) -> JointLimits:
        """Inverse of :meth:`to_json`."""
        rows = data["joints"]

        def rad(vals: list, inf: float) -> np.ndarray:
            return np.array([inf if v is None else math.radians(v) for v in vals], dtype=np.float64)

        return cls(
            tuple(r["name"] for r in rows),
            tuple(r["axes"] for r in rows),
            np.array([r["frame"] for r in rows], dtype=np.float64).reshape(len(rows), 3, 3),
            tuple(rad(r["lower_deg"], -math.inf) for r in rows),
            tuple(rad(r["upper_deg"], math.inf) for r in rows),
            str(data.get("source", "")),
        )

    @classmethod
    def range_of(cls, motions: Sequence[Motion], joints: Sequence[str]) -> JointLimits:
        """Limits that are the motions' own range: each of ``joints`` gets three DOFs (``XYZ``
        angles in its parent frame, identity reference frame) bounded by the least and greatest
        angle any of ``motions`` takes (radians). A motion within its own range never
        violates them; a blend of several can (the knee of one with the hip of another)."""
        n = len(joints)
        whole = cls(
            tuple(joints),
            ("XYZ",) * n,
            np.stack([np.eye(3)] * n) if n else np.zeros((0, 3, 3)),
            (np.full(3, -np.pi),) * n,
            (np.full(3, np.pi),) * n,
        )
        ang = np.concatenate([whole.angles(m.rotations, m.skeleton.names) for m in motions])
        lo, hi = ang.min(axis=0).reshape(n, 3), ang.max(axis=0).reshape(n, 3)
        return cls(whole.joints, whole.axes, whole.frames, tuple(lo), tuple(hi), "the motions' own range")

    @property
    def n_dofs(self) -> int:
        """Number of limited dofs (all joints)."""
        return sum(len(a) for a in self.axes)

    def dof_labels(self) -> list[tuple[str, str]]:
        """``(joint, "rx")`` per dof, in the column order of :meth:`angles`."""
        return [(n, "r" + a.lower()) for n, ax in zip(self.joints, self.axes, strict=True) for a in ax]

    def restricted_to(self, names: list[str] | tuple[str, ...]) -> JointLimits:
        """The limits of the joints present in ``names`` (a skeleton's joints)."""
        keep = [k for k, n in enumerate(self.joints) if n in set(names)]
        return JointLimits(
            tuple(self.joints[k] for k in keep),
            tuple(self.axes[k] for k in keep),
            self.frames[keep],
            tuple(self.lower[k] for k in keep),
            tuple(self.upper[k] for k in keep),
            self.source,
        )

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``lower, upper`` of every dof, shape (D,), radians."""
        if not self.joints:
            return np.zeros(0), np.zeros(0)
        return np.concatenate(self.lower), np.concatenate(self.upper)

    def angles(self, rotations: np.ndarray, names: list[str] | tuple[str, ...]) -> np.ndarray:
        """DOF angles of every limited dof, shape (F, D), radians, each put in the turn
        nearest its range (``theta + 2 pi k`` inside ``[lower, upper]`` when one is).

        Parameters
        ----------
        rotations : ndarray, shape (F, J, 3, 3)
            Local rotations of a clip whose joints are ``names``.
        names : sequence of str
        """
        index = {n: k for k, n in enumerate(names)}
        cols = []
        parts = zip(self.joints, self.axes, self.frames, self.lower, self.upper, strict=True)
        for name, ax, c, lo, hi in parts:
            cols.append(_nearest_turn(dof_angles(rotations[:, index[name]], c, ax, lo, hi), lo, hi))
        if not cols:
            return np.zeros((rotations.shape[0], 0))
        return np.concatenate(cols, axis=1)


def _eased_envelope(c: np.ndarray, half: int) -> np.ndarray:
    """Per column, the largest ``c[g] w(f - g)`` over ``g``, ``c >= 0``, shape (F, n); ``w`` a
    raised cosine of half-width ``half`` frames with ``w(0) = 1`` (so the envelope is >= ``c``)."""
    if half <= 0 or not c.any():
        return c
    d = np.arange(-half, half + 1)
    w = 0.5 * (1.0 + np.cos(np.pi * d / (half + 1)))
    pad = np.pad(c, ((half, half), (0, 0)))
    win = np.lib.stride_tricks.sliding_window_view(pad, 2 * half + 1, axis=0)  # (F, n, 2h+1)
    return (win * w).max(axis=-1)


def project_to_limits(
    rotations: np.ndarray,
    names: list[str] | tuple[str, ...],
    limits: JointLimits,
    *,
    exempt: np.ndarray | None = None,
    ease_frames: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Local rotations moved into the limit box, each dof eased into its limit.

    Per limited joint and frame, the full decomposition of :func:`dof_angles` (the turn of each
    dof angle nearest its range) gives ``theta``; the correction ``c = clip(theta, lo, hi) -
    theta`` is spread to the neighbouring frames by the envelope ``max_g |c(g)| w(f - g)``
    (``w``: raised cosine of half-width ``ease_frames``, ``w(0) = 1``; the pushes down and up
    separately), added to ``theta``, and the sum clipped to the range again. The angles about
    the missing axes are kept and the rotation rebuilt (:func:`dof_rotation`); frames with no
    change keep their matrices bit for bit. Exact: every dof not ``exempt`` is within its range
    at every frame (up to rounding); the clip is the nearest point of the box in the DOF
    angles (not in the rotation's geodesic distance), the easing makes the change continuous
    in time with slopes of at most ``pi / 2`` times the largest correction per ``ease_frames``.

    Parameters
    ----------
    rotations : ndarray, shape (F, J, 3, 3)
        Local rotations of a clip whose joints are ``names``.
    names : sequence of str
    limits : JointLimits
        Joints not in ``names`` are ignored.
    exempt : ndarray of bool, shape (F, D), optional
        Frames and dofs (columns of ``limits.restricted_to(names).angles``) left beyond their
        range (limits an input violates there: reported, not enforced).
    ease_frames : int, default 0
        Half-width of the easing, frames (0: the plain clip, frame by frame).

    Returns
    -------
    rotations : ndarray, shape (F, J, 3, 3)
    change : ndarray, shape (F, D)
        The change of each dof angle, radians (0 where unchanged).
    """
    lim = limits.restricted_to(list(names))
    rot = np.array(rotations, dtype=np.float64, copy=True)
    index = {n: k for k, n in enumerate(names)}
    changes = []
    col = 0
    for name, ax, c, lo, hi in zip(lim.joints, lim.axes, lim.frames, lim.lower, lim.upper, strict=True):
        n = len(ax)
        j = index[name]
        m = c.T @ rot[:, j] @ c
        full = _decompose(m, _full_axes(ax), n, lo, hi)
        theta = _nearest_turn(full[:, :n], lo, hi)
        free = np.ones_like(theta, dtype=bool) if exempt is None else ~exempt[:, col : col + n]
        need = np.where(free, np.clip(theta, lo, hi) - theta, 0.0)
        need[np.abs(need) <= _ROUNDING] = 0.0  # a bound met to rounding is met
        ease = _eased_envelope(np.maximum(need, 0.0), ease_frames) - _eased_envelope(
            np.maximum(-need, 0.0), ease_frames
        )
        moved = theta + ease
        moved = np.where(free, np.clip(moved, lo, hi), moved)
        delta = moved - theta
        delta[np.abs(delta) <= _ROUNDING] = 0.0
        moved = theta + delta
        rows = np.flatnonzero(np.abs(delta).max(axis=1) > 0.0)
        if rows.size:
            full[rows, :n] = moved[rows]
            rot[rows, j] = dof_rotation(full[rows], c, ax)
        changes.append(delta)
        col += n
    change = np.concatenate(changes, axis=1) if changes else np.zeros((rot.shape[0], 0))
    return rot, change


def _nearest_turn(theta: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """``theta + 2 pi k`` with the least distance to ``[lo, hi]`` (``k`` in -1, 0, 1)."""
    cands = theta[..., None] + _TWO_PI * np.array([0.0, -1.0, 1.0])
    dist = np.maximum(lo[..., None] - cands, 0.0) + np.maximum(cands - hi[..., None], 0.0)
    best = np.argmin(dist, axis=-1)  # ties: k = 0 first
    return np.take_along_axis(cands, best[..., None], axis=-1)[..., 0]


@dataclass(frozen=True)
class LimitHit:
    """One dof's frames beyond (or at) a limit.

    Attributes
    ----------
    joint : str
    dof : str
        ``"rx"``, ``"ry"`` or ``"rz"``.
    lower_deg, upper_deg : float
        Its range, degrees.
    frames : int
        How many frames.
    first_frame, last_frame : int
    worst_deg : float
        Largest excess beyond the range over those frames, degrees (<= the tolerance for
        a dof at its limit).
    """

    joint: str
    dof: str
    lower_deg: float
    upper_deg: float
    frames: int
    first_frame: int
    last_frame: int
    worst_deg: float

    def summary(self) -> dict:
        """JSON-ready fields."""
        return {
            "joint": self.joint,
            "dof": self.dof,
            "range_deg": [_finite_or_none(self.lower_deg), _finite_or_none(self.upper_deg)],
            "frames": self.frames,
            "first_frame": self.first_frame,
            "last_frame": self.last_frame,
            "worst_deg": self.worst_deg,
        }


def _finite_or_none(v: float) -> float | None:
    return float(v) if math.isfinite(v) else None


@dataclass(frozen=True, eq=False)
class JointLimitReport:
    """Which dofs of a clip are beyond their limits, and which sit at one (:func:`check_joint_limits`).

    Attributes
    ----------
    limits : JointLimits
    n_frames : int
    tol_deg : float
        Tolerance: beyond a limit means by more than this; at a limit means within it.
    excess : ndarray, shape (F, D)
        Per frame and dof, how far beyond its range the angle is, radians (0 inside).
    violations : tuple of LimitHit
        Dofs beyond their range at some frame.
    at_limit : tuple of LimitHit
        Dofs within ``tol_deg`` of a bound at some frame (and not beyond it there).
    """

    limits: JointLimits
    n_frames: int
    tol_deg: float
    excess: np.ndarray
    violations: tuple[LimitHit, ...]
    at_limit: tuple[LimitHit, ...]

    @property
    def ok(self) -> bool:
        """No dof beyond its range."""
        return not self.violations

    def summary(self) -> dict:
        """JSON-ready fields."""
        return {
            "source": self.limits.source,
            "limited_joints": len(self.limits.joints),
            "limited_dofs": self.limits.n_dofs,
            "tol_deg": self.tol_deg,
            "joints_beyond_limit": sorted({h.joint for h in self.violations}),
            "joints_at_limit": sorted({h.joint for h in self.at_limit}),
            "violations": [h.summary() for h in self.violations],
            "at_limit": [h.summary() for h in self.at_limit],
        }


def _hits(mask: np.ndarray, excess: np.ndarray, limits: JointLimits) -> tuple[LimitHit, ...]:
    lo, hi = limits.bounds()
    out = []
    for d, (joint, dof) in enumerate(limits.dof_labels()):
        frames = np.flatnonzero(mask[:, d])
        if frames.size == 0:
            continue
        out.append(
            LimitHit(
                joint=joint,
                dof=dof,
                lower_deg=math.degrees(lo[d]),
                upper_deg=math.degrees(hi[d]),
                frames=int(frames.size),
                first_frame=int(frames[0]),
                last_frame=int(frames[-1]),
                worst_deg=math.degrees(float(excess[frames, d].max())),
            )
        )
    return tuple(out)


def limit_excess(angles: np.ndarray, limits: JointLimits) -> tuple[np.ndarray, np.ndarray]:
    """Signed distances beyond the range: ``(below, above)``, each shape (F, D), radians.

    ``below = lower - theta`` and ``above = theta - upper`` (positive: beyond).
    """
    lo, hi = limits.bounds()
    with np.errstate(invalid="ignore"):
        return lo[None, :] - angles, angles - hi[None, :]


def check_joint_limits(
    motion: Motion | np.ndarray,
    limits: JointLimits,
    *,
    names: list[str] | tuple[str, ...] | None = None,
    tol_deg: float = 0.01,
) -> JointLimitReport:
    """Evaluate each limited joint's DOF angles per frame and report violations.

    Parameters
    ----------
    motion : Motion or ndarray, shape (F, J, 3, 3)
        The clip (or its local rotations, with ``names``).
    limits : JointLimits
        Joints not in the clip are ignored.
    names : sequence of str, optional
        Joint names of ``rotations`` (default: the motion's skeleton).
    tol_deg : float, default 0.01
        Beyond a limit means by more than this (degrees); at a limit means within it.

    Returns
    -------
    JointLimitReport
    """
    if isinstance(motion, Motion):
        rot = motion.rotations
        names = motion.skeleton.names if names is None else names
    else:
        rot = np.asarray(motion, dtype=np.float64)
        if names is None:
            raise ValueError("names: expected the joint names of the rotations")
    limits = limits.restricted_to(list(names))
    tol = math.radians(float(tol_deg))
    ang = limits.angles(rot, list(names))
    below, above = limit_excess(ang, limits)
    excess = np.maximum(np.maximum(below, above), 0.0)
    beyond = excess > tol
    near = ~beyond & ((np.abs(below) <= tol) | (np.abs(above) <= tol))
    signed = np.maximum(below, above)
    return JointLimitReport(
        limits=limits,
        n_frames=int(rot.shape[0]),
        tol_deg=float(tol_deg),
        excess=excess,
        violations=_hits(beyond, excess, limits),
        at_limit=_hits(near, signed, limits),
    )
