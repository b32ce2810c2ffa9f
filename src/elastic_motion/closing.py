"""Closing curves: seamless loops (paper 000, sec. 4; paper 001, Thm. 2).

A curve ``c`` on the grid ``t`` (``n+1`` samples, ``n`` cells of width ``h_i``) is *closed*
when its last sample equals its first. The closing problem moves the curve's SRV function
``q`` (cell-valued, orthonormal coordinates, see :mod:`elastic_motion.curves`) so that the
discrete inverse SRVT started at the *original* first sample ``c_0`` ends at ``c_0``.

Conventions (stated once, used by every function here)
------------------------------------------------------
* **Discrete inverse SRVT** (paper 000, sec. 5.1): ``c_{i+1} = E_i c_i``, ``E_i = exp(u_i)``,
  ``u_i = from_orthonormal(h_i |q_i| q_i)``. The **seam gap** is
  ``r = c_n c_0^{-1} = E_{n-1} ... E_0`` and the objective is paper 000 eq. (11) on the
  discrete curve, ``Phi(q) = 1/2 |log r|_w^2`` (the group's weighted norm).
* **Which coordinates close** (argument ``factors``): a boolean mask over the Lie algebra
  coordinates, built per factor / per copy / per coordinate. A closed Euclidean coordinate
  enters ``Phi`` with its component of ``r``. An ``SO(3)`` copy is closed fully (all three
  coordinates, residual ``log r``), not at all, or *up to rotations about one coordinate
  axis* (two coordinates closed): then the residual is the **swing** of ``r`` about that
  axis ``a``, the rotation vector ``theta (a x r a) / |a x r a|`` with
  ``theta = angle(a, r a)``; it is zero exactly when ``r`` is a rotation about ``a``, and
  ``|swing|`` is the distance from ``r`` to that subgroup. This is how an animation keeps
  the change of heading of one cycle (``a`` = up axis) while closing the root's tilt.
  One closed coordinate of an ``SO(3)`` copy has no meaning and is refused.
* **Free coordinates**: every entry of ``q`` may move (the SRV norm ``|q_i|`` couples all
  coordinates of a cell). Free Euclidean coordinates and entirely free ``SO(3)`` copies are
  curves of their own in the product group, independent of the gap, so by default
  (``keep_free=True``) their original samples are put back after closing. A copy closed up
  to an axis cannot be split and moves as a whole.
* **C1 closing** (beyond the paper, ``c1=True``): the repeated curve continues as
  ``r c(t)`` (left translation by the gap, so a free heading change carries over), whose
  first cell has velocity ``Ad_r xi_0``. We also ask the last cell's velocity to match it:
  ``xi_{n-1} = Ad_r xi_0`` on every closed block (all three coordinates of a closed or
  swing-closed ``SO(3)`` copy, the closed Euclidean coordinates), with
  ``xi_i = u_i / h_i`` the right-trivialised velocity. The residual is measured per frame:
  ``F_1 = (xi_{n-1} - Ad_r xi_0) / n`` in orthonormal coordinates (radians per frame on a
  uniform grid). With both conditions the discrete second difference across the seam is 0.
* **Gap values** reported: ``gap = |F_0|`` (weighted norm of the closing residual,
  ``sqrt(2 Phi)``; with unit weights an upper bound of every joint's seam angle in
  radians) and ``velocity_gap = |F_1|``.

The gradient (paper 000, Thm. 4.5 and its exact discrete form)
--------------------------------------------------------------
Perturbing ``q`` gives ``delta r r^{-1} = sum_i Ad_{P_i} dexp_{u_i}(delta u_i)`` with
``P_i = c_n c_{i+1}^{-1}``, and ``delta log r = dexp^{-1}_{log r}(delta r r^{-1})``
(eq. 16). So the weighted-inner-product gradient of ``Phi`` with respect to ``u_i`` is
``dexp_{u_i}^† Ad_{P_i}^† (dexp^{-1}_{log r})^† log r``; the chain rule through
``u_i = h_i |q_i| q_i`` (eq. 13) gives the L2 gradient
``grad_i = M_i S g_i``, ``M_i = |q_i| I + q_i q_i^T / |q_i|`` (eq. 17), ``S = sqrt(weights)``.
Since ``Ad_{P_i} dexp_{u_i} = int_0^1 Ad_{c_n c(x)^{-1}} ds`` over the cell, the exact
discrete gradient is the cell average of the continuous ``theta`` of eq. (17); the paper's
formula evaluates it at one end (``gradient="paper"``: ``P_i`` without ``dexp_{u_i}^†``), an
``O(h)`` approximation. For bi-invariant inner products (all groups of this package)
``(dexp^{-1}_l)^† l = l`` (Cor. 4.8; it also holds for the swing residual);
``log_term="bi-invariant"`` uses it, ``"general"`` applies ``dexp_inv_dual``.

Methods
-------
* ``method="gradient"``: the gradient flow of paper 000 sec. 4.2 discretised by steepest
  descent with the exact gradient, the step of the linearised model (Cauchy step) and an
  Armijo backtracking line search: every accepted step decreases ``Phi``.
* ``method="gauss-newton"`` (default): the minimal-L2-norm change of ``q`` that solves the
  linearised closing conditions ``J dq = -F`` (``J`` is ``k x (n dim)`` with ``k`` closing
  conditions; ``J J^*`` is ``k x k`` and is assembled from the same adjoint), with the same
  line search. Each step is the least change *of that step* that solves the linearised
  conditions, so the result is closed but only closest to the original to first order (it
  is not the minimiser of ``||q - q_orig||``); it converges quadratically. The closed curve
  nearest the original in SRV L2 is :func:`elastic_motion.closing_kkt.project_closed`. In
  ``R^d`` Gauss-Newton is exactly the Newton projection with the basis of paper 001,
  Thm. 2 (:func:`project_closed_rd`).

Cut locus: ``log`` is two-valued at angle ``pi``. A closed ``SO(3)`` block whose seam
rotation (or swing) is within ``cut_locus_tol`` of ``pi`` raises ``ValueError`` naming the
copy; the line search never accepts a step that takes a block there. A single step
``|u_i|`` of a closed copy may grow past ``pi`` (data glitches such as a foot flipping by
179 degrees in one frame get pushed over): ``exp`` and the objective stay smooth up to
``2 pi`` (where ``dexp`` is singular; the line search stops short of it), the returned
samples are exact, and :attr:`ClosingResult.srv` is the solver's own SRV function (not the
SRVT of the returned curve, which would read such a step the short way round). Free copies
may hold any steps (e.g. the 180-degree finger flips of the CMU data): they are integrated
as they are and, with ``keep_free``, restored.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numba import njit

from elastic_motion.curves import DiscreteCurve, SRVFunction, inverse_srv_transform, srv_transform
from elastic_motion.groups import SO3, Euclidean, LieGroup, PowerGroup, ProductGroup, hat

__all__ = [
    "ClosingGradient",
    "ClosingResult",
    "SeamGap",
    "close_curve",
    "closing_gap",
    "closing_gradient",
    "closing_mask",
    "project_closed_rd",
]

_SO3 = SO3()
_EYE3 = np.eye(3)
_METHODS = ("gauss-newton", "gradient")
_GRADIENTS = ("exact", "paper")
_LOG_TERMS = ("general", "bi-invariant")


# --------------------------------------------------------------------------------------------
# Results
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class ClosingResult:
    """Outcome of :func:`close_curve` / :func:`project_closed_rd`.

    Attributes
    ----------
    curve : DiscreteCurve
        The closed curve, same grid and first sample as the input.
    srv : SRVFunction
        The SRV function the solver computed (``q`` of shape ``(n, dim)``, orthonormal
        coordinates): every number measured through it equals the solver's. It is not
        re-read from ``curve``: a step of a closed copy that ends past ``pi`` stays as the
        solver took it, and with ``keep_free`` the free coordinates of ``curve`` are the
        original samples while ``srv`` holds the solver's values for them.
    gap, gap_initial : float
        Weighted norm of the closing residual after / before (``sqrt(2 Phi_0)``).
    velocity_gap, velocity_gap_initial : float
        Norm of the seam velocity mismatch ``(xi_{n-1} - Ad_r xi_0) / n`` on the closed
        blocks (computed whether or not ``c1`` was asked for).
    history : ndarray, shape (iterations+1,)
        ``gap`` after each iteration (non-increasing when ``c1=False``).
    velocity_history : ndarray, shape (iterations+1,)
    objective_history : ndarray, shape (iterations+1,)
        The minimised ``Phi`` (strictly decreasing: every accepted step decreases it).
    steps : ndarray, shape (iterations,)
        Accepted line-search step sizes.
    iterations : int
    converged : bool
        Whether the tolerance was reached.
    message : str
    time : float
        Wall-clock seconds spent in the solver.
    method, gradient : str
        The options used.
    rotation_gaps : ndarray, shape (m,)
        Final residual angle (radians, unweighted) of each ``SO(3)`` copy in algebra order
        (0 for free copies; the swing angle for copies closed up to an axis).
    translation_gaps : ndarray, shape (e,)
        Final absolute residual of each Euclidean coordinate (0 for free ones).
    change : float or None
        ``||q - q_orig||_L2`` (``sqrt(sum_i h_i |q_i - q_orig_i|^2)``, orthonormal
        coordinates) between ``srv`` and the input's SRV function.
    kkt_residual : float or None
        For the constrained projection (:func:`elastic_motion.closing_kkt.project_closed`):
        the relative first-order optimality residual at the result, else ``None``.
    multipliers : ndarray or None
        Lagrange multipliers of the closing conditions (constrained projection only).
    """

    curve: DiscreteCurve
    srv: SRVFunction
    gap: float
    gap_initial: float
    velocity_gap: float
    velocity_gap_initial: float
    history: np.ndarray
    velocity_history: np.ndarray
    objective_history: np.ndarray
    steps: np.ndarray
    iterations: int
    converged: bool
    message: str
    time: float
    method: str
    gradient: str
    rotation_gaps: np.ndarray
    translation_gaps: np.ndarray
    change: float | None = None
    kkt_residual: float | None = None
    multipliers: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class SeamGap:
    """The seam of a curve, as :func:`closing_gap` measures it.

    Attributes
    ----------
    gap : float
        Weighted norm of the closing residual ``|F_0|`` (``sqrt(2 Phi)``).
    velocity_gap : float
        ``|(xi_{n-1} - Ad_r xi_0) / n|`` on the closed blocks (orthonormal coordinates).
    rotation_gaps : ndarray, shape (m,)
        Residual angle of each ``SO(3)`` copy, radians (0 for free copies).
    rotation_angles : ndarray, shape (m,)
        Full angle ``|log(R_n R_0^T)|`` of each copy, whatever the mask.
    translation_gaps : ndarray, shape (e,)
        ``|c_n - c_0|`` per Euclidean coordinate (0 for free ones).
    """

    gap: float
    velocity_gap: float
    rotation_gaps: np.ndarray
    rotation_angles: np.ndarray
    translation_gaps: np.ndarray


@dataclass(frozen=True, eq=False)
class ClosingGradient:
    """Value and L2 gradient of the closing objective (:func:`closing_gradient`).

    Attributes
    ----------
    phi : float
        ``Phi = 1/2 |F_0|^2 (+ c1_weight/2 |F_1|^2 with c1)``.
    gradient : ndarray, shape (n, dim)
        L2 gradient in orthonormal coordinates (group coordinate order): for a change
        ``dq``, ``dPhi = sum_i dt_i gradient[i] . dq[i]``. The partial derivatives
        ``dPhi / dq[i, k]`` are ``gradient * dt[:, None]``.
    """

    phi: float
    gradient: np.ndarray


# --------------------------------------------------------------------------------------------
# Layout: a group of the product family as Euclidean coordinates + SO(3) copies
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class _Layout:
    """Where the leaves of a group sit in its algebra vectors and raveled points."""

    dim: int
    eu_alg: np.ndarray  # (e,) algebra indices of Euclidean coordinates
    eu_pt: np.ndarray  # (e,) raveled point indices of them
    so3_alg: np.ndarray  # (m, 3)
    so3_pt: np.ndarray  # (m, 9)
    s_eu: np.ndarray  # (e,) sqrt(weights)
    s_so3: np.ndarray  # (m,)
    labels: list[str]  # (m,) description of each SO(3) copy for error messages
    perm: np.ndarray  # (dim,) internal order (Euclidean coords, then SO(3) copies) -> group order


def _layout(group: LieGroup) -> _Layout:
    factors = group.factors if isinstance(group, ProductGroup) else [group]
    eu_alg: list[int] = []
    eu_pt: list[int] = []
    so3_alg: list[list[int]] = []
    so3_pt: list[list[int]] = []
    labels: list[str] = []
    a = p = 0
    for k, f in enumerate(factors):
        if isinstance(f, PowerGroup):
            base, copies = f.base, f.n
        else:
            base, copies = f, 1
        where = f"factor {k} ({f!r})" if isinstance(group, ProductGroup) else f"{f!r}"
        for c in range(copies):
            if isinstance(base, Euclidean):
                eu_alg.extend(range(a, a + base.dim))
                eu_pt.extend(range(p, p + base.dim))
                a += base.dim
                p += base.dim
            elif isinstance(base, SO3):
                so3_alg.append([a, a + 1, a + 2])
                so3_pt.append(list(range(p, p + 9)))
                labels.append(f"{where}, copy {c}" if copies > 1 else where)
                a += 3
                p += 9
            else:
                raise ValueError(
                    f"curve.group: expected a group built from Euclidean and SO3 "
                    f"(Euclidean, SO3, PowerGroup, ProductGroup); got factor {f!r}"
                )
    w = np.asarray(group.weights, dtype=np.float64)
    eu_alg_a = np.asarray(eu_alg, dtype=np.int64)
    so3_alg_a = np.asarray(so3_alg, dtype=np.int64).reshape(-1, 3)
    return _Layout(
        dim=int(group.dim),
        eu_alg=eu_alg_a,
        eu_pt=np.asarray(eu_pt, dtype=np.int64),
        so3_alg=so3_alg_a,
        so3_pt=np.asarray(so3_pt, dtype=np.int64).reshape(-1, 9),
        s_eu=np.sqrt(w[eu_alg_a]),
        s_so3=np.sqrt(w[so3_alg_a[:, 0]]) if so3_alg_a.size else np.zeros(0),
        labels=labels,
        perm=np.concatenate([eu_alg_a, so3_alg_a.ravel()]),
    )


def closing_mask(group: LieGroup, factors: object = None) -> np.ndarray:
    """The boolean mask over algebra coordinates that ``factors`` selects for closing.

    Parameters
    ----------
    group : LieGroup
    factors : None, array_like or sequence, optional
        ``None``: close everything. A boolean array of shape ``(group.dim,)``: one flag per
        algebra coordinate. For a :class:`ProductGroup`, a sequence with one entry per factor,
        each ``True``/``False``, a boolean array ``(factor.dim,)``, or for a
        :class:`PowerGroup` factor a boolean array ``(factor.n,)`` (one flag per copy). For a
        :class:`PowerGroup` itself, ``(n,)`` flags per copy are accepted too.

    Returns
    -------
    ndarray of bool, shape (group.dim,)
    """
    dim = int(group.dim)
    if factors is None:
        return np.ones(dim, dtype=bool)

    def one(f: LieGroup, entry: object, name: str) -> np.ndarray:
        arr = np.asarray(entry)
        if arr.dtype != bool:
            if arr.dtype.kind in "iuf" and np.isin(arr, (0, 1)).all():
                arr = arr.astype(bool)
            else:
                raise ValueError(f"{name}: expected True/False flags; got {entry!r}")
        if arr.ndim == 0:
            return np.full(f.dim, bool(arr))
        if arr.shape == (f.dim,):
            return arr.copy()
        if isinstance(f, PowerGroup) and arr.shape == (f.n,):
            return np.repeat(arr, f.base.dim)
        expect = f"a flag, or flags of shape ({f.dim},)" + (
            f" or ({f.n},) (one per copy)" if isinstance(f, PowerGroup) else ""
        )
        raise ValueError(f"{name}: expected {expect} for {f!r}; got shape {arr.shape}")

    if isinstance(group, ProductGroup):
        try:
            flat = np.asarray(factors)
        except ValueError:  # ragged per-factor entries
            flat = None
        if flat is not None and flat.shape == (dim,) and dim != len(group.factors):
            return one(group, flat, "factors")
        if not isinstance(factors, Sequence | np.ndarray) or len(factors) != len(group.factors):
            raise ValueError(
                f"factors: expected one entry per factor ({len(group.factors)}) or a mask of "
                f"shape ({dim},); got {factors!r}"
            )
        return np.concatenate(
            [one(f, e, f"factors[{k}]") for k, (f, e) in enumerate(zip(group.factors, factors, strict=True))]
        )
    return one(group, factors, "factors")


@dataclass(frozen=True, eq=False)
class _Spec:
    """Which residual each block contributes (from the mask)."""

    eu_closed: np.ndarray  # (e,) bool
    mode: np.ndarray  # (m,) 0 free, 1 log (fully closed), 2 swing about a coordinate axis
    axis: np.ndarray  # (m,) the free axis of swing blocks, -1 otherwise
    rows0: np.ndarray  # (dim,) bool, internal order: closing conditions
    rows1: np.ndarray  # (dim,) bool, internal order: velocity conditions (C1)


def _spec(layout: _Layout, mask: np.ndarray) -> _Spec:
    eu_closed = mask[layout.eu_alg]
    so3m = mask[layout.so3_alg] if layout.so3_alg.size else np.zeros((0, 3), dtype=bool)
    count = so3m.sum(axis=1)
    bad = np.flatnonzero(count == 1)
    if bad.size:
        b = int(bad[0])
        raise ValueError(
            f"factors: an SO(3) copy closes all 3 coordinates, 2 (rotations about the third axis "
            f"are free) or none; {layout.labels[b]} has only coordinate "
            f"{int(np.flatnonzero(so3m[b])[0])} closed"
        )
    mode = np.where(count == 3, 1, np.where(count == 2, 2, 0))
    axis = np.where(count == 2, np.argmin(so3m, axis=1), -1)
    rows0 = np.concatenate([eu_closed, so3m.ravel()])
    rows1 = np.concatenate([eu_closed, np.repeat(mode > 0, 3)])
    return _Spec(eu_closed, mode, axis, rows0, rows1)


# --------------------------------------------------------------------------------------------
# Small SO(3) helpers (vectorised)
# --------------------------------------------------------------------------------------------


def _as_matrix(op, u: np.ndarray) -> np.ndarray:
    """The matrix of the linear map ``v -> op(u, v)`` for a stack of ``u`` (..., 3)."""
    cols = op(
        np.broadcast_to(u[..., None, :], u.shape[:-1] + (3, 3)), np.broadcast_to(_EYE3, u.shape[:-1] + (3, 3))
    )
    return np.swapaxes(cols, -1, -2)


def _swing(r: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Swing of rotations ``r`` (k, 3, 3) about coordinate axes ``axis`` (k,).

    Returns the swing rotation vectors ``l = theta (a x b)/|a x b|`` (k, 3), ``b = r a``,
    the angles ``theta`` (k,) and the Jacobians ``dl = Js eta`` for ``delta r = hat(eta) r``:
    ``Js = f cos(theta) I - f b a^T + g v v^T``, ``v = a x b``, ``f = theta / sin(theta)``,
    ``g = (sin theta - theta cos theta) / sin^3 theta`` (series near 0).
    """
    k = r.shape[0]
    a = np.zeros((k, 3))
    a[np.arange(k), axis] = 1.0
    b = r[np.arange(k), :, axis]
    v = np.cross(a, b)
    sn = np.linalg.norm(v, axis=-1)
    cs = np.einsum("ki,ki->k", a, b)
    theta = np.arctan2(sn, cs)
    small = theta < 1e-2
    t2 = theta**2
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.where(small, 1.0 + t2 / 6.0 + 7.0 * t2**2 / 360.0 + 31.0 * t2**3 / 15120.0, theta / sn)
        g = np.where(
            small,
            1.0 / 3.0 + 2.0 * t2 / 15.0 + 2.0 * t2**2 / 63.0 + 4.0 * t2**3 / 675.0,
            (sn - theta * cs) / sn**3,
        )
    ell = f[:, None] * v
    js = (
        (f * cs)[:, None, None] * _EYE3
        - f[:, None, None] * np.einsum("ki,kj->kij", b, a)
        + g[:, None, None] * np.einsum("ki,kj->kij", v, v)
    )
    return ell, theta, js


@njit(cache=True)
def _cell_blocks_kernel(rot, dmat, h, lmat, out):  # pragma: no cover - numba
    # out[i, b] = h_i L_b Ad_{P_i} dexp_{u_i}, P_i = c_n c_{i+1}^T (paper 000, Thm. 4.5 on the
    # discrete curve); dmat[i, b] is the matrix of dexp_{u_i} (groups.SO3.dexp), or the
    # identity for the paper's one-sided formula.
    n = dmat.shape[0]
    m = dmat.shape[1]
    nr = lmat.shape[1]
    pm = np.empty((3, 3))
    am = np.empty((3, 3))
    for i in range(n):
        for b in range(m):
            for r in range(3):
                for c in range(3):
                    pm[r, c] = (
                        rot[n, b, r, 0] * rot[i + 1, b, c, 0]
                        + rot[n, b, r, 1] * rot[i + 1, b, c, 1]
                        + rot[n, b, r, 2] * rot[i + 1, b, c, 2]
                    )
            for r in range(3):
                for c in range(3):
                    am[r, c] = (
                        pm[r, 0] * dmat[i, b, 0, c]
                        + pm[r, 1] * dmat[i, b, 1, c]
                        + pm[r, 2] * dmat[i, b, 2, c]
                    )
            for r in range(nr):
                for c in range(3):
                    out[i, b, r, c] = h[i] * (
                        lmat[b, r, 0] * am[0, c] + lmat[b, r, 1] * am[1, c] + lmat[b, r, 2] * am[2, c]
                    )


@njit(cache=True)
def _gram_blocks_kernel(bs, wq, q, ks, ys):  # pragma: no cover - numba
    # ks[b] = sum_i wq_i B_ib B_ib^T (block-diagonal part of J J^*), ys[i, b] = B_ib q_ib
    n = bs.shape[0]
    m = bs.shape[1]
    nr = bs.shape[2]
    for b in range(m):
        for r in range(nr):
            for s in range(nr):
                ks[b, r, s] = 0.0
    for i in range(n):
        for b in range(m):
            for r in range(nr):
                ys[i, b, r] = (
                    bs[i, b, r, 0] * q[i, b, 0] + bs[i, b, r, 1] * q[i, b, 1] + bs[i, b, r, 2] * q[i, b, 2]
                )
                for s in range(r + 1):
                    v = wq[i] * (
                        bs[i, b, r, 0] * bs[i, b, s, 0]
                        + bs[i, b, r, 1] * bs[i, b, s, 1]
                        + bs[i, b, r, 2] * bs[i, b, s, 2]
                    )
                    ks[b, r, s] += v
    for b in range(m):
        for r in range(nr):
            for s in range(r):
                ks[b, s, r] = ks[b, r, s]


# --------------------------------------------------------------------------------------------
# The discrete closing problem
# --------------------------------------------------------------------------------------------


class _CutLocus(Exception):
    """A closed block reached log's cut locus (angle pi), or a step reached angle 2 pi."""


@dataclass(eq=False)
class _State:
    q: np.ndarray  # (n, dim) internal order, orthonormal
    qn: np.ndarray  # (n,)
    x: np.ndarray  # (n, dim) |q| q
    u_so3: np.ndarray  # (n, m, 3) natural coordinates
    rot: np.ndarray  # (n+1, m, 3, 3) the SO(3) part of the curve
    r: np.ndarray  # (m, 3, 3) seam rotation per copy
    ell: np.ndarray  # (m, 3) residual (natural): log r, swing, or 0
    lres: np.ndarray  # (m, 3, 3) Jacobian of the residual: dexp^{-1}_{log r}, Js, or 0
    f0: np.ndarray  # (dim,) closing residual, orthonormal, zero on free rows
    f1: np.ndarray  # (dim,) velocity residual (C1), orthonormal, zero on free rows
    y: np.ndarray  # (m, 3) Ad_r x_0 (orthonormal)
    rot_gaps: np.ndarray  # (m,)
    rot_angles: np.ndarray  # (m,)
    eu_gaps: np.ndarray  # (e,)
    _dexp: np.ndarray | None = None  # (n, m, 3, 3) matrices of dexp_{u_i}, on first use

    @property
    def dexp(self) -> np.ndarray:
        """The matrices of ``dexp_{u_i}`` of every step (``groups.SO3.dexp_matrix``), cached."""
        if self._dexp is None:
            self._dexp = np.ascontiguousarray(_SO3.dexp_matrix(self.u_so3))
        return self._dexp


class _Problem:
    """The closing objective of one curve; every array in internal coordinate order."""

    def __init__(
        self,
        srv: SRVFunction,
        mask: np.ndarray,
        *,
        c1: bool,
        c1_weight: float,
        cut_locus_tol: float,
        rotation_names: Sequence[str] | None,
    ) -> None:
        self.layout = lay = _layout(srv.group)
        self.spec = _spec(lay, mask)
        if rotation_names is not None:
            names = list(rotation_names)
            if len(names) != lay.so3_alg.shape[0]:
                raise ValueError(
                    f"rotation_names: expected one name per SO(3) copy ({lay.so3_alg.shape[0]}); "
                    f"got {len(names)}"
                )
            lay.labels[:] = [f"{nm} ({lab})" for nm, lab in zip(names, lay.labels, strict=True)]
        self.h = srv.dt
        self.n = int(srv.q.shape[0])
        self.ne = int(lay.eu_alg.size)
        self.m = int(lay.so3_alg.shape[0])
        start = np.asarray(srv.start, dtype=np.float64).ravel()
        self.start_eu = start[lay.eu_pt]
        self.start_rot = start[lay.so3_pt].reshape(self.m, 3, 3)
        self.c1 = bool(c1)
        self.c = 1.0 / self.n  # velocity residual per frame
        self.sqrt_c1w = math.sqrt(c1_weight)
        self.cut = float(cut_locus_tol)
        sp = self.spec
        self.sel = np.concatenate([sp.rows0, sp.rows1]) if self.c1 else sp.rows0.copy()

    # -- conversions ------------------------------------------------------------------------
    def to_internal(self, q: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(q[:, self.layout.perm])

    def to_group(self, qi: np.ndarray) -> np.ndarray:
        out = np.empty_like(qi)
        out[:, self.layout.perm] = qi
        return out

    # -- evaluation ---------------------------------------------------------------------------
    def evaluate(self, q: np.ndarray) -> _State:
        """Integrate the curve of ``q`` and its residuals; ``_CutLocus`` at log's cut locus."""
        lay, sp, ne, m = self.layout, self.spec, self.ne, self.m
        qn = np.sqrt(np.einsum("ij,ij->i", q, q))
        x = qn[:, None] * q
        v = self.h[:, None] * x  # orthonormal steps h |q| q
        u_so3 = v[:, ne:].reshape(self.n, m, 3) / lay.s_so3[:, None]
        rot = _SO3.accumulate(_SO3.exp(u_so3), self.start_rot) if m else np.zeros((self.n + 1, 0, 3, 3))
        # dexp_u is singular at |u| = 2 pi: there the exp steps stop depending smoothly on q
        step2 = np.where(sp.mode > 0, np.einsum("nbk,nbk->nb", u_so3, u_so3), 0.0)  # closed copies
        if m and step2.max(initial=0.0) >= (2.0 * math.pi - self.cut) ** 2:
            idx = np.unravel_index(int(np.argmax(step2)), (self.n, m))
            raise _CutLocus(
                f"cell {idx[0]} of {lay.labels[idx[1]]} rotates by 2 pi in one step (dexp is singular)"
            )
        r = np.matmul(rot[-1], np.swapaxes(rot[0], -1, -2))
        logs = _SO3.log(r) if m else np.zeros((0, 3))
        angles = np.linalg.norm(logs, axis=-1)
        ell = np.zeros((m, 3))
        lres = np.zeros((m, 3, 3))
        gaps = np.zeros(m)
        full = sp.mode == 1
        if full.any():
            near = full & (angles > math.pi - self.cut)
            if near.any():
                b = int(np.flatnonzero(near)[0])
                raise _CutLocus(
                    f"{lay.labels[b]}: the seam rotation is {angles[b]:.9f} rad, at the cut locus of "
                    f"log (pi): closing it by either direction is equally short"
                )
            ell[full] = logs[full]
            lres[full] = _as_matrix(_SO3.dexp_inv, logs[full])
            gaps[full] = angles[full]
        sw = sp.mode == 2
        if sw.any():
            s_ell, s_theta, s_js = _swing(r[sw], sp.axis[sw])
            if (s_theta > math.pi - self.cut).any():
                b = int(np.flatnonzero(sw)[int(np.argmax(s_theta))])
                raise _CutLocus(
                    f"{lay.labels[b]}: the seam rotation tilts axis {int(sp.axis[b])} by "
                    f"{s_theta.max():.9f} rad, at the cut locus (pi): the swing back is ambiguous"
                )
            ell[sw] = s_ell
            lres[sw] = s_js
            gaps[sw] = s_theta
        eu_res = v[:, :ne].sum(axis=0)  # orthonormal c_n - c_0 of the Euclidean coordinates
        f0 = np.zeros(lay.dim)
        f0[:ne] = np.where(sp.eu_closed, eu_res, 0.0)
        f0[ne:] = (lay.s_so3[:, None] * ell).ravel()
        x0 = x[0, ne:].reshape(m, 3)
        y = np.einsum("bij,bj->bi", r, x0)  # Ad_r x_0 (orthonormal; weights are scalar per copy)
        f1 = np.zeros(lay.dim)
        f1[:ne] = np.where(sp.eu_closed, self.c * (x[-1, :ne] - x[0, :ne]), 0.0)
        f1[ne:] = (np.where((sp.mode > 0)[:, None], self.c * (x[-1, ne:].reshape(m, 3) - y), 0.0)).ravel()
        eu_gaps = np.where(sp.eu_closed, np.abs(eu_res) / lay.s_eu, 0.0)
        return _State(q, qn, x, u_so3, rot, r, ell, lres, f0, f1, y, gaps, angles, eu_gaps)

    def objective(self, s: _State) -> float:
        phi = 0.5 * float(s.f0 @ s.f0)
        if self.c1:
            phi += 0.5 * self.sqrt_c1w**2 * float(s.f1 @ s.f1)
        return phi

    def residual(self, s: _State) -> np.ndarray:
        """Stacked residual on the full row space (zeros on free rows)."""
        return np.concatenate([s.f0, self.sqrt_c1w * s.f1]) if self.c1 else s.f0

    # -- Jacobian blocks ----------------------------------------------------------------------
    def blocks(
        self, s: _State, *, exact_dexp: bool = True, log_term: str = "general"
    ) -> tuple[np.ndarray, np.ndarray]:
        """Per-cell block matrices ``B_i`` of the Jacobian ``J_i = B_i M_i``.

        Returns ``Bs`` (n, m, R, 3) for the SO(3) copies and ``Be`` (n, e, R/3) for the
        Euclidean coordinates, ``R = 3`` (closing rows) or ``6`` (with the C1 rows).
        ``B0_i = h_i L0 Ad_{P_i} dexp_{u_i}`` (Thm. 4.5 discretised), ``L0`` the residual's
        Jacobian (``dexp^{-1}_{log r}`` or the swing's, or ``I`` under Cor. 4.8).
        """
        n, m, ne, h = self.n, self.m, self.ne, self.h
        if log_term == "bi-invariant":
            l0 = np.broadcast_to(_EYE3, (m, 3, 3))
        else:
            l0 = s.lres
        if self.c1:
            w = self.sqrt_c1w
            # d(Ad_r x_0) = Ad_r dx_0 + eta x y  ->  L1 = (c / s) hat(y) on eta (orthonormal)
            l1 = (w * self.c / self.layout.s_so3)[:, None, None] * hat(s.y)
            lmat = np.ascontiguousarray(np.concatenate([l0, l1], axis=1))
        else:
            lmat = np.ascontiguousarray(l0)
        bs = np.empty((n, m, lmat.shape[1], 3))
        if m:
            u = s.u_so3
            eye = np.ascontiguousarray(np.broadcast_to(_EYE3, u.shape[:-1] + (3, 3)))
            dmat = s.dexp if exact_dexp else eye
            _cell_blocks_kernel(s.rot, dmat, h, lmat, bs)
        be0 = np.broadcast_to(h[:, None], (n, ne))
        if not self.c1:
            return bs, be0[..., None]
        bs[-1, :, 3:] += w * self.c * _EYE3
        bs[0, :, 3:] -= w * self.c * s.r
        be1 = np.zeros((n, ne))
        be1[-1] += w * self.c
        be1[0] -= w * self.c
        return bs, np.stack([be0, be1], axis=-1)

    def _split_rows(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Full row vector (R/3 * dim,) -> (m, R) SO(3) part and (e, R/3) Euclidean part."""
        ne, m, dim = self.ne, self.m, self.layout.dim
        groups = z.reshape(-1, dim)
        zs = np.concatenate([g[ne:].reshape(m, 3) for g in groups], axis=1)
        ze = np.stack([g[:ne] for g in groups], axis=-1)
        return zs, ze

    def _join_rows(self, zs: np.ndarray, ze: np.ndarray) -> np.ndarray:
        m = self.m
        k = ze.shape[-1]
        return np.concatenate(
            [np.concatenate([ze[:, g], zs[:, 3 * g : 3 * g + 3].reshape(3 * m)]) for g in range(k)]
        )

    @staticmethod
    def _apply_m(s: _State, w: np.ndarray) -> np.ndarray:
        """``M_i w_i = |q_i| w_i + (q_i . w_i / |q_i|) q_i`` (eq. 13); 0 where ``q_i = 0``."""
        qn = s.qn
        safe = np.where(qn > 0, qn, 1.0)
        coef = np.where(qn > 0, np.einsum("ij,ij->i", s.q, w) / safe, 0.0)
        return qn[:, None] * w + coef[:, None] * s.q

    def adjoint(self, s: _State, bs: np.ndarray, be: np.ndarray, z: np.ndarray) -> np.ndarray:
        """L2 adjoint ``(J^* z)_i = M_i B_i^T z / h_i``, shape (n, dim)."""
        zs, ze = self._split_rows(z)
        w = np.empty((self.n, self.layout.dim))
        w[:, : self.ne] = np.einsum("ner,er->ne", be, ze)
        w[:, self.ne :] = np.einsum("nbrk,br->nbk", bs, zs).reshape(self.n, 3 * self.m)
        return self._apply_m(s, w) / self.h[:, None]

    def forward(self, s: _State, bs: np.ndarray, be: np.ndarray, d: np.ndarray) -> np.ndarray:
        """``J d = sum_i B_i M_i d_i`` on the full row space."""
        md = self._apply_m(s, d)
        zs = np.einsum("nbrk,nbk->br", bs, md[:, self.ne :].reshape(self.n, self.m, 3))
        ze = np.einsum("ner,ne->er", be, md[:, : self.ne])
        return self._join_rows(zs, ze)

    def gram(self, s: _State, bs: np.ndarray, be: np.ndarray) -> np.ndarray:
        """``J J^* = sum_i B_i M_i^2 B_i^T / h_i`` with ``M_i^2 = |q_i|^2 I + 3 q_i q_i^T``."""
        n, m, ne, dim = self.n, self.m, self.ne, self.layout.dim
        k = be.shape[-1]
        wq = s.qn**2 / self.h
        # block-diagonal part |q|^2 B B^T
        ks = np.empty((m, bs.shape[2], bs.shape[2]))
        ys = np.empty((n, m, bs.shape[2]))
        if m:
            _gram_blocks_kernel(bs, wq, np.ascontiguousarray(s.q[:, ne:].reshape(n, m, 3)), ks, ys)
        ke = np.einsum("ner,nes->ers", be * wq[:, None, None], be)
        # rank-one part 3 (B q)(B q)^T, dense
        ye = be * s.q[:, :ne, None]
        yfull = np.empty((n, k * dim))
        for g in range(k):
            yfull[:, g * dim : g * dim + ne] = ye[:, :, g]
            yfull[:, g * dim + ne : (g + 1) * dim] = ys[:, :, 3 * g : 3 * g + 3].reshape(n, 3 * m)
        gmat = 3.0 * (yfull.T * (1.0 / self.h)) @ yfull
        # scatter the blocks
        for g1 in range(k):
            for g2 in range(k):
                e_idx1 = g1 * dim + np.arange(ne)
                e_idx2 = g2 * dim + np.arange(ne)
                gmat[e_idx1, e_idx2] += ke[:, g1, g2]
                base1 = g1 * dim + ne + 3 * np.arange(m)
                base2 = g2 * dim + ne + 3 * np.arange(m)
                for i in range(3):
                    for j in range(3):
                        gmat[base1 + i, base2 + j] += ks[:, 3 * g1 + i, 3 * g2 + j]
        return gmat


def _l2(dq: np.ndarray, h: np.ndarray) -> float:
    """``sqrt(sum_i h_i |dq_i|^2)``: the L2 norm of a cell-valued function."""
    return float(np.sqrt(np.einsum("i,ij,ij->", h, dq, dq)))


def _as_srv(curve: object, name: str = "curve") -> SRVFunction:
    if isinstance(curve, SRVFunction):
        return curve
    if isinstance(curve, DiscreteCurve):
        return srv_transform(curve)
    raise ValueError(f"{name}: expected a DiscreteCurve or an SRVFunction; got {type(curve).__name__}")


def _check_choice(value: str, choices: tuple[str, ...], name: str) -> str:
    if value not in choices:
        raise ValueError(f"{name}: expected one of {', '.join(map(repr, choices))}; got {value!r}")
    return value


def _check_positive(value: float, name: str, *, allow_zero: bool = False) -> float:
    v = float(value)
    if not math.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        raise ValueError(
            f"{name}: expected a {'non-negative' if allow_zero else 'positive'} number; got {value!r}"
        )
    return v


def _problem(curve, factors, c1, c1_weight, cut_locus_tol, rotation_names, min_points=3):
    srv = _as_srv(curve)
    n_points = srv.q.shape[0] + 1
    if n_points < min_points:
        raise ValueError(
            f"curve: expected at least {min_points} samples to close (a closed curve with fewer has no "
            f"shape left); got {n_points}"
        )
    mask = closing_mask(srv.group, factors)
    prob = _Problem(
        srv,
        mask,
        c1=c1,
        c1_weight=_check_positive(c1_weight, "c1_weight"),
        cut_locus_tol=_check_positive(cut_locus_tol, "cut_locus_tol", allow_zero=True),
        rotation_names=rotation_names,
    )
    return srv, prob


def _closed_output(
    prob: _Problem,
    curve: DiscreteCurve | SRVFunction,
    srv: SRVFunction,
    q_final: np.ndarray,
    *,
    moved: bool,
    keep_free: bool,
) -> tuple[DiscreteCurve, SRVFunction]:
    """The closed curve and the solver's own SRV function (module docstring, "Free
    coordinates"): with ``keep_free`` the free Euclidean coordinates and free SO(3) copies of
    the curve get their original samples back; ``srv`` is not re-read from the curve."""
    if not moved:
        return (curve if isinstance(curve, DiscreteCurve) else inverse_srv_transform(srv)), srv
    closed = SRVFunction(q_final, srv.t, srv.start, srv.group)
    out_curve = inverse_srv_transform(closed)
    lay = prob.layout
    free = np.concatenate([lay.eu_pt[~prob.spec.eu_closed], lay.so3_pt[prob.spec.mode == 0].ravel()])
    if keep_free and free.size:
        original = curve if isinstance(curve, DiscreteCurve) else inverse_srv_transform(srv)
        vals = np.array(out_curve.values).reshape(out_curve.n_points, -1)
        vals[:, free] = np.asarray(original.values).reshape(original.n_points, -1)[:, free]
        out_curve = DiscreteCurve(vals.reshape(out_curve.values.shape), srv.group, srv.t)
    return out_curve, closed


def _evaluate_or_raise(prob: _Problem, q: np.ndarray) -> _State:
    try:
        return prob.evaluate(q)
    except _CutLocus as exc:
        raise ValueError(f"curve: cannot close: {exc}") from None


# --------------------------------------------------------------------------------------------
# Public functions
# --------------------------------------------------------------------------------------------


def closing_gap(
    curve: DiscreteCurve | SRVFunction,
    *,
    factors: object = None,
    rotation_names: Sequence[str] | None = None,
) -> SeamGap:
    """Measure the seam of a curve: the residuals :func:`close_curve` drives to zero.

    Parameters
    ----------
    curve : DiscreteCurve or SRVFunction
        At least 3 samples, in a group of the product family.
    factors : optional
        Which coordinates count (see :func:`closing_mask`).
    rotation_names : sequence of str, optional
        One name per ``SO(3)`` copy, used in error messages.

    Returns
    -------
    SeamGap

    Raises
    ------
    ValueError
        When a closed ``SO(3)`` copy's seam rotation is at log's cut locus (angle pi).
    """
    _, prob = _problem(curve, factors, False, 1.0, 1e-9, rotation_names)
    s = _evaluate_or_raise(prob, prob.to_internal(_as_srv(curve).q))
    return SeamGap(
        gap=float(np.linalg.norm(s.f0)),
        velocity_gap=float(np.linalg.norm(s.f1)),
        rotation_gaps=s.rot_gaps,
        rotation_angles=s.rot_angles,
        translation_gaps=s.eu_gaps,
    )


def closing_gradient(
    curve: DiscreteCurve | SRVFunction,
    *,
    factors: object = None,
    c1: bool = False,
    c1_weight: float = 1.0,
    gradient: str = "exact",
    log_term: str = "general",
) -> ClosingGradient:
    """Value and L2 gradient of the discrete closing objective ``Phi`` at ``q``.

    Parameters
    ----------
    curve : DiscreteCurve or SRVFunction
        ``q`` of shape ``(n, dim)``; at least 3 samples.
    factors : optional
        Coordinates to close (:func:`closing_mask`).
    c1 : bool
        Add the seam velocity mismatch ``c1_weight/2 |F_1|^2`` to ``Phi``.
    gradient : {"exact", "paper"}
        ``"exact"``: the gradient of the discrete objective (adjoint through every
        ``exp`` step, with ``dexp_{u_i}^†``). ``"paper"``: paper 000 eq. (17)/(18) evaluated
        on the discrete curve (``Ad_{P_i}^†`` without ``dexp_{u_i}^†``), ``O(h)`` off.
    log_term : {"general", "bi-invariant"}
        ``(dexp^{-1}_{log r})^† log r`` by the group's ``dexp_inv_dual`` (Thm. 4.5) or
        replaced by ``log r`` (Cor. 4.8).

    Returns
    -------
    ClosingGradient
    """
    _check_choice(gradient, _GRADIENTS, "gradient")
    _check_choice(log_term, _LOG_TERMS, "log_term")
    srv, prob = _problem(curve, factors, c1, c1_weight, 1e-9, None)
    s = _evaluate_or_raise(prob, prob.to_internal(srv.q))
    bs, be = prob.blocks(s, exact_dexp=gradient == "exact", log_term=log_term)
    g = prob.adjoint(s, bs, be, prob.residual(s))
    return ClosingGradient(phi=prob.objective(s), gradient=prob.to_group(g))


def close_curve(
    curve: DiscreteCurve | SRVFunction,
    *,
    method: str = "gauss-newton",
    tol: float = 1e-6,
    max_iter: int = 100,
    factors: object = None,
    c1: bool = False,
    c1_weight: float = 1.0,
    gradient: str = "exact",
    log_term: str = "general",
    step: float | None = None,
    armijo: float = 1e-4,
    max_backtracks: int = 40,
    keep_free: bool = True,
    cut_locus_tol: float = 1e-6,
    rotation_names: Sequence[str] | None = None,
) -> ClosingResult:
    """Close a curve (make its last sample equal its first) by changing its SRV function.

    Minimises the discrete ``Phi(q) = 1/2 |F_0(q)|^2`` (paper 000, eq. 11; plus
    ``c1_weight/2 |F_1|^2`` with ``c1``) over ``q`` from the curve's own SRV function, the
    first sample fixed. See the module docstring for the residuals, the gradient and the
    two methods.

    Parameters
    ----------
    curve : DiscreteCurve or SRVFunction
        ``n+1 >= 3`` samples in a group built from ``Euclidean`` and ``SO3``.
    method : {"gauss-newton", "gradient"}
        Minimal-norm Gauss-Newton projection (default), or the gradient flow of paper 000
        sec. 4.2 (steepest descent, Cauchy step, Armijo line search).
    tol : float
        Stop when ``gap <= tol`` (and ``velocity_gap <= tol`` with ``c1``). ``gap`` is the
        weighted norm of the residual: with unit weights, radians for rotations.
    max_iter : int
        Iteration limit (each iteration is one accepted step).
    factors : optional
        What to close (:func:`closing_mask`): default everything.
    c1 : bool
        Also match the seam velocities ``xi_{n-1} = Ad_r xi_0`` (beyond the paper).
    c1_weight : float
        Weight of the velocity residual in ``Phi``.
    gradient : {"exact", "paper"}
        Gradient used by ``method="gradient"`` (Gauss-Newton always uses the exact Jacobian).
    log_term : {"general", "bi-invariant"}
        Thm. 4.5's ``(dexp^{-1})^†`` or Cor. 4.8's simplification, for ``method="gradient"``.
    step : float, optional
        First trial step of each line search for ``method="gradient"`` (default: the
        minimiser of the linearised objective along the gradient). Gauss-Newton tries 1.
    armijo : float
        Sufficient-decrease constant ``c`` in ``Phi(q + a d) <= Phi(q) + c a <grad, d>``.
    max_backtracks : int
        Halvings of the step before the line search gives up (the result then says so).
    keep_free : bool
        Put the original samples back on free Euclidean coordinates and free ``SO(3)``
        copies (they do not affect the gap).
    cut_locus_tol : float
        Distance (radians) to ``pi`` at which a seam rotation counts as on the cut locus.
    rotation_names : sequence of str, optional
        One name per ``SO(3)`` copy (e.g. joint names) for error messages.

    Returns
    -------
    ClosingResult

    Raises
    ------
    ValueError
        Fewer than 3 samples; a group outside the family; a seam rotation at angle pi on a
        closed copy (``rotation_names`` name it); bad option values.

    Notes
    -----
    Cost per iteration: ``O(n m)`` 3x3 products for ``m`` rotations and, for Gauss-Newton,
    a ``k x k`` solve with ``k`` closing conditions and ``O(n k^2)`` to assemble ``J J^*``.
    A curve that is already closed (within ``tol``) is returned unchanged (0 iterations).
    """
    t_begin = time.perf_counter()
    _check_choice(method, _METHODS, "method")
    _check_choice(gradient, _GRADIENTS, "gradient")
    _check_choice(log_term, _LOG_TERMS, "log_term")
    tol = _check_positive(tol, "tol", allow_zero=True)
    if int(max_iter) != max_iter or max_iter < 0:
        raise ValueError(f"max_iter: expected a non-negative integer; got {max_iter!r}")
    if step is not None:
        step = _check_positive(step, "step")
    if not 0 < armijo < 1:
        raise ValueError(f"armijo: expected a constant in (0, 1); got {armijo!r}")
    srv, prob = _problem(curve, factors, c1, c1_weight, cut_locus_tol, rotation_names)
    state = _evaluate_or_raise(prob, prob.to_internal(srv.q))
    phi = prob.objective(state)
    gaps = [float(np.linalg.norm(state.f0))]
    vgaps = [float(np.linalg.norm(state.f1))]
    phis = [phi]
    steps: list[float] = []
    sel = prob.sel

    def done(s: _State) -> bool:
        return bool(np.linalg.norm(s.f0) <= tol and (not c1 or np.linalg.norm(s.f1) <= tol))

    converged = done(state)
    message = "already closed" if converged else f"reached max_iter = {max_iter}"
    it = 0
    while not converged and it < max_iter:
        f = prob.residual(state)
        bs, be = prob.blocks(state)
        g_exact = prob.adjoint(state, bs, be, f)
        if method == "gauss-newton":
            gmat = prob.gram(state, bs, be)[np.ix_(sel, sel)]
            mu = 1e-13 * max(float(np.trace(gmat)) / max(gmat.shape[0], 1), 1e-300)
            rhs = -f[sel]
            try:
                zsel = np.linalg.solve(gmat + mu * np.eye(gmat.shape[0]), rhs)
            except np.linalg.LinAlgError:
                zsel = np.linalg.lstsq(gmat, rhs, rcond=None)[0]
            z = np.zeros_like(f)
            z[sel] = zsel
            d = prob.adjoint(state, bs, be, z)
            alpha = 1.0
        else:
            if gradient == "exact" and log_term == "general":
                gd = g_exact
            else:
                bsd, bed = prob.blocks(state, exact_dexp=gradient == "exact", log_term=log_term)
                gd = prob.adjoint(state, bsd, bed, f)
            d = -gd
            if step is None:
                jd = prob.forward(state, bs, be, d)[sel]
                denom = float(jd @ jd)
                alpha = -float(f[sel] @ jd) / denom if denom > 0 else 1.0
                if not alpha > 0:
                    alpha = 1.0
            else:
                alpha = step
        slope = float(np.einsum("i,ij,ij->", prob.h, g_exact, d))
        if not slope < 0:
            message = "the search direction does not decrease the gap (stationary point?)"
            break
        accepted = None
        for _ in range(max_backtracks + 1):
            try:
                trial = prob.evaluate(state.q + alpha * d)
            except _CutLocus:
                alpha *= 0.5
                continue
            phi_t = prob.objective(trial)
            if np.isfinite(phi_t) and phi_t <= phi + armijo * alpha * slope:
                accepted = trial
                break
            alpha *= 0.5
        if accepted is None:
            message = f"line search failed after {max_backtracks} halvings (gap {gaps[-1]:.3g})"
            break
        state, phi = accepted, prob.objective(accepted)
        it += 1
        steps.append(alpha)
        phis.append(phi)
        gaps.append(float(np.linalg.norm(state.f0)))
        vgaps.append(float(np.linalg.norm(state.f1)))
        if done(state):
            converged = True
            message = f"converged in {it} iterations"

    out_curve, closed = _closed_output(
        prob, curve, srv, prob.to_group(state.q), moved=it > 0, keep_free=keep_free
    )
    return ClosingResult(
        curve=out_curve,
        srv=closed,
        gap=gaps[-1],
        gap_initial=gaps[0],
        velocity_gap=vgaps[-1],
        velocity_gap_initial=vgaps[0],
        history=np.asarray(gaps),
        velocity_history=np.asarray(vgaps),
        objective_history=np.asarray(phis),
        steps=np.asarray(steps),
        iterations=it,
        converged=converged,
        message=message,
        time=time.perf_counter() - t_begin,
        method=method,
        gradient=gradient,
        rotation_gaps=state.rot_gaps,
        translation_gaps=state.eu_gaps,
        change=_l2(closed.q - srv.q, srv.dt),
    )


def project_closed_rd(
    curve: DiscreteCurve | SRVFunction,
    *,
    factors: object = None,
    tol: float = 1e-10,
    max_iter: int = 50,
    keep_free: bool = True,
) -> ClosingResult:
    """Project a curve in ``R^d`` onto closed curves (paper 001, Thm. 2; Newton).

    The closed curves are ``{q : integral |q| q dt = 0}`` (discretely
    ``sum_i h_i |q_i| q_i = 0`` on the closed coordinates). Paper 001, Thm. 2 gives the
    normal basis ``U_k(q) = (q_k q + |q|^2 e_k) / |q|``; Newton's method solves
    ``sum_l <U_k, U_l>_L2 beta_l = -F_k`` (Gram matrix
    ``delta_kl int |q|^2 + 3 int q_k q_l``) and moves ``q <- q + sum_k beta_k U_k``,
    backtracking when the residual would grow.

    Parameters
    ----------
    curve : DiscreteCurve or SRVFunction
        At least 3 samples in a group made only of Euclidean factors (weights allowed:
        everything is done in orthonormal coordinates).
    factors : optional
        Coordinates to close (:func:`closing_mask`).
    tol : float
        Stop when the weighted norm of ``c_n - c_0`` (closed coordinates) is ``<= tol``.
    max_iter : int
    keep_free : bool
        Put back the original samples of the coordinates that are not closed.

    Returns
    -------
    ClosingResult
        With ``method = "newton"``.
    """
    t_begin = time.perf_counter()
    srv = _as_srv(curve)
    lay = _layout(srv.group)
    if lay.so3_alg.size:
        raise ValueError(f"curve: expected a curve in R^d (Euclidean factors only); got group {srv.group!r}")
    if srv.q.shape[0] + 1 < 3:
        raise ValueError(f"curve: expected at least 3 samples to close; got {srv.q.shape[0] + 1}")
    tol = _check_positive(tol, "tol", allow_zero=True)
    mask = closing_mask(srv.group, factors)
    h = srv.dt
    q = np.array(srv.q)
    idx = np.flatnonzero(mask)

    def resid(qq: np.ndarray) -> np.ndarray:
        qn = np.sqrt(np.einsum("ij,ij->i", qq, qq))
        return (h * qn) @ qq[:, idx]  # sum_i h_i |q_i| q_i, closed coordinates

    def velocity_gap(qq: np.ndarray) -> float:
        qn = np.sqrt(np.einsum("ij,ij->i", qq, qq))
        x = qn[:, None] * qq
        return float(np.linalg.norm((x[-1, idx] - x[0, idx]) / qq.shape[0]))

    f = resid(q)
    gaps = [float(np.linalg.norm(f))]
    vg = [velocity_gap(q)]
    steps: list[float] = []
    it = 0
    converged = gaps[0] <= tol
    message = "already closed" if converged else f"reached max_iter = {max_iter}"
    while not converged and it < max_iter:
        qn = np.sqrt(np.einsum("ij,ij->i", q, q))
        safe = np.where(qn > 0, qn, 1.0)
        # U_k(q_i) = (q_ik q_i + |q_i|^2 e_k) / |q_i|   (paper 001, eq. 11);
        # <U_k, U_l>_L2 = sum_i h_i (|q_i|^2 delta_kl + 3 q_ik q_il)
        qs = q[:, idx]
        gram = 3.0 * (qs.T * h) @ qs
        gram[np.diag_indices_from(gram)] += float(h @ qn**2)
        try:
            beta = np.linalg.solve(gram, -f)
        except np.linalg.LinAlgError:
            beta = np.linalg.lstsq(gram, -f, rcond=None)[0]
        b = np.zeros(q.shape[1])
        b[idx] = beta
        # sum_k beta_k U_k(q_i) = ((q_i . b) q_i + |q_i|^2 b) / |q_i|
        d = ((q @ b)[:, None] * q + np.outer(qn**2, b)) / safe[:, None]
        alpha = 1.0
        for _ in range(40):
            f_new = resid(q + alpha * d)
            if np.linalg.norm(f_new) < np.linalg.norm(f):
                break
            alpha *= 0.5
        else:
            message = "Newton step does not reduce the gap"
            break
        q = q + alpha * d
        f = f_new
        it += 1
        steps.append(alpha)
        gaps.append(float(np.linalg.norm(f)))
        vg.append(velocity_gap(q))
        if gaps[-1] <= tol:
            converged = True
            message = f"converged in {it} iterations"
    if it == 0:
        out = curve if isinstance(curve, DiscreteCurve) else inverse_srv_transform(srv)
    else:
        out = inverse_srv_transform(SRVFunction(q, srv.t, srv.start, srv.group))
    free = lay.eu_pt[~mask[lay.eu_alg]]
    if keep_free and free.size and it > 0:
        original = curve if isinstance(curve, DiscreteCurve) else inverse_srv_transform(srv)
        vals = np.array(out.values).reshape(out.n_points, -1)
        vals[:, free] = np.asarray(original.values).reshape(original.n_points, -1)[:, free]
        out = DiscreteCurve(vals.reshape(out.values.shape), srv.group, srv.t)
    eu_gaps = np.zeros(lay.dim)
    eu_gaps[idx] = np.abs(f) / lay.s_eu[idx]  # pure R^d: Euclidean order is algebra order
    phis = 0.5 * np.asarray(gaps) ** 2
    return ClosingResult(
        curve=out,
        srv=srv if it == 0 else SRVFunction(q, srv.t, srv.start, srv.group),
        gap=gaps[-1],
        gap_initial=gaps[0],
        velocity_gap=vg[-1],
        velocity_gap_initial=vg[0],
        history=np.asarray(gaps),
        velocity_history=np.asarray(vg),
        objective_history=phis,
        steps=np.asarray(steps),
        iterations=it,
        converged=converged,
        message=message,
        time=time.perf_counter() - t_begin,
        method="newton",
        gradient="exact",
        rotation_gaps=np.zeros(0),
        translation_gaps=eu_gaps,
        change=_l2(q - srv.q, srv.dt),
    )
