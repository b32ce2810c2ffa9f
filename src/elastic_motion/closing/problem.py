"""The closing problem: a curve's integration, its seam residuals, their Jacobian, the state.

A curve ``c`` on the grid ``t`` (``n+1`` samples, ``n`` cells of width ``h_i``) is *closed*
when its last sample equals its first. The closing problem moves the curve's SRV function
``q`` (cell-valued, orthonormal coordinates, see :mod:`elastic_motion.curves`) so that the
discrete inverse SRVT started at the *original* first sample ``c_0`` ends at ``c_0``.

Conventions (stated once, used by every solver of the package)
--------------------------------------------------------------
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

Cut locus: ``log`` is two-valued at angle ``pi``. A closed ``SO(3)`` block whose seam
rotation (or swing) is within ``cut_locus_tol`` of ``pi`` raises ``ValueError`` naming the
copy; the line search never accepts a step that takes a block there. A single step
``|u_i|`` of a closed copy may grow past ``pi`` (data glitches such as a foot flipping by
179 degrees in one frame get pushed over): ``exp`` and the objective stay smooth up to
``2 pi`` (where ``dexp`` is singular; the line search stops short of it), the returned
samples are exact, and :attr:`~elastic_motion.closing.ClosingResult.srv` is the solver's
own SRV function (not the SRVT of the returned curve, which would read such a step the short
way round). Free copies may hold any steps (e.g. the 180-degree finger flips of the CMU
data): they are integrated as they are and, with ``keep_free``, restored.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numba import njit

from elastic_motion.closing.options import ClosingOptions
from elastic_motion.curves import DiscreteCurve, SRVFunction, inverse_srv_transform, srv_transform
from elastic_motion.groups import SO3, Euclidean, LieGroup, PowerGroup, ProductGroup, hat

__all__ = [
    "ClosingProblem",
    "ClosingState",
    "CutLocus",
    "GroupLayout",
    "SeamGap",
    "as_srv",
    "closing_gap",
    "closing_mask",
    "group_layout",
    "l2_norm",
]

_SO3 = SO3()
_EYE3 = np.eye(3)


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


# --------------------------------------------------------------------------------------------
# Layout: a group of the product family as Euclidean coordinates + SO(3) copies
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class GroupLayout:
    """Where the leaves of a group of the product family sit in its algebra vectors and
    raveled points (:func:`group_layout`).

    The solvers work in an *internal order*: the Euclidean coordinates first, then the
    ``SO(3)`` copies, each in algebra order; ``perm`` maps it to the group's order.
    """

    dim: int
    eu_alg: np.ndarray  # (e,) algebra indices of Euclidean coordinates
    eu_pt: np.ndarray  # (e,) raveled point indices of them
    so3_alg: np.ndarray  # (m, 3)
    so3_pt: np.ndarray  # (m, 9)
    s_eu: np.ndarray  # (e,) sqrt(weights)
    s_so3: np.ndarray  # (m,)
    labels: list[str]  # (m,) description of each SO(3) copy for error messages
    perm: np.ndarray  # (dim,) internal order (Euclidean coords, then SO(3) copies) -> group order


def group_layout(group: LieGroup) -> GroupLayout:
    """The :class:`GroupLayout` of a group built from ``Euclidean`` and ``SO3`` (``PowerGroup``,
    ``ProductGroup``); ``ValueError`` naming the factor for any other group."""
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
    return GroupLayout(
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


def _spec(layout: GroupLayout, mask: np.ndarray) -> _Spec:
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


class CutLocus(Exception):
    """A closed block reached log's cut locus (angle pi), or a step reached angle 2 pi.

    Raised by :meth:`ClosingProblem.evaluate`; the line searches take it as a step too long,
    :meth:`ClosingProblem.evaluate_checked` turns it into a ``ValueError`` naming the copy.
    """


@dataclass(eq=False)
class ClosingState:
    """The curve of one SRV function ``q`` and its closing residuals (:meth:`ClosingProblem.evaluate`).

    Arrays in the internal order (:class:`GroupLayout`); ``n`` cells, ``m`` ``SO(3)`` copies,
    ``e`` Euclidean coordinates, ``dim = e + 3 m``.
    """

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


class ClosingProblem:
    """The closing objective of one curve; every array in internal coordinate order.

    Built by :meth:`from_curve`. :meth:`evaluate` integrates the curve of a ``q`` and its
    residuals (a :class:`ClosingState`); :meth:`residual`, :meth:`blocks`, :meth:`forward`,
    :meth:`adjoint` and :meth:`gram` give the residual ``F``, the Jacobian ``J`` (per-cell
    blocks ``J_i = B_i M_i``), ``J d``, ``J^* z`` and ``J J^*`` that every solver of
    :mod:`elastic_motion.closing` uses (module docstring).

    Attributes
    ----------
    srv : SRVFunction
        The curve's SRV function (group order).
    layout : GroupLayout
    h : ndarray, shape (n,)
        Cell widths.
    n, m, ne : int
        Cells, ``SO(3)`` copies, Euclidean coordinates.
    sel : ndarray of bool
        The closing conditions (rows of ``F``) that are closed; with ``c1`` also the
        velocity rows.
    """

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
        self.srv = srv
        self.layout = lay = group_layout(srv.group)
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

    @classmethod
    def from_curve(cls, curve: DiscreteCurve | SRVFunction, options: ClosingOptions) -> ClosingProblem:
        """The problem of closing ``curve`` (at least 3 samples) as ``options`` says (its
        ``factors``, ``c1``, ``c1_weight``, ``cut_locus_tol`` and ``rotation_names``)."""
        srv = as_srv(curve)
        n_points = srv.q.shape[0] + 1
        if n_points < 3:
            raise ValueError(
                f"curve: expected at least 3 samples to close (a closed curve with fewer has no "
                f"shape left); got {n_points}"
            )
        mask = closing_mask(srv.group, options.factors)
        return cls(
            srv,
            mask,
            c1=options.c1,
            c1_weight=options.c1_weight,
            cut_locus_tol=options.cut_locus_tol,
            rotation_names=options.rotation_names,
        )

    # -- conversions ------------------------------------------------------------------------
    def to_internal(self, q: np.ndarray) -> np.ndarray:
        """``q`` (n, dim) in the group's coordinate order -> internal order."""
        return np.ascontiguousarray(q[:, self.layout.perm])

    def to_group(self, qi: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`to_internal`."""
        out = np.empty_like(qi)
        out[:, self.layout.perm] = qi
        return out

    # -- evaluation ---------------------------------------------------------------------------
    def evaluate(self, q: np.ndarray) -> ClosingState:
        """Integrate the curve of ``q`` and its residuals; ``CutLocus`` at log's cut locus."""
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
            raise CutLocus(
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
                raise CutLocus(
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
                raise CutLocus(
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
        return ClosingState(q, qn, x, u_so3, rot, r, ell, lres, f0, f1, y, gaps, angles, eu_gaps)

    def evaluate_checked(self, q: np.ndarray) -> ClosingState:
        """:meth:`evaluate`, a seam at the cut locus a ``ValueError`` naming the copy."""
        try:
            return self.evaluate(q)
        except CutLocus as exc:
            raise ValueError(f"curve: cannot close: {exc}") from None

    def objective(self, s: ClosingState) -> float:
        """``Phi = 1/2 |F_0|^2`` (``+ c1_weight/2 |F_1|^2`` with ``c1``)."""
        phi = 0.5 * float(s.f0 @ s.f0)
        if self.c1:
            phi += 0.5 * self.sqrt_c1w**2 * float(s.f1 @ s.f1)
        return phi

    def residual(self, s: ClosingState) -> np.ndarray:
        """Stacked residual on the full row space (zeros on free rows)."""
        return np.concatenate([s.f0, self.sqrt_c1w * s.f1]) if self.c1 else s.f0

    # -- Jacobian blocks ----------------------------------------------------------------------
    def blocks(
        self, s: ClosingState, *, exact_dexp: bool = True, log_term: str = "general"
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
    def apply_m(s: ClosingState, w: np.ndarray) -> np.ndarray:
        """``M_i w_i = |q_i| w_i + (q_i . w_i / |q_i|) q_i`` (eq. 13); 0 where ``q_i = 0``."""
        qn = s.qn
        safe = np.where(qn > 0, qn, 1.0)
        coef = np.where(qn > 0, np.einsum("ij,ij->i", s.q, w) / safe, 0.0)
        return qn[:, None] * w + coef[:, None] * s.q

    def adjoint(self, s: ClosingState, bs: np.ndarray, be: np.ndarray, z: np.ndarray) -> np.ndarray:
        """L2 adjoint ``(J^* z)_i = M_i B_i^T z / h_i``, shape (n, dim)."""
        zs, ze = self._split_rows(z)
        w = np.empty((self.n, self.layout.dim))
        w[:, : self.ne] = np.einsum("ner,er->ne", be, ze)
        w[:, self.ne :] = np.einsum("nbrk,br->nbk", bs, zs).reshape(self.n, 3 * self.m)
        return self.apply_m(s, w) / self.h[:, None]

    def forward(self, s: ClosingState, bs: np.ndarray, be: np.ndarray, d: np.ndarray) -> np.ndarray:
        """``J d = sum_i B_i M_i d_i`` on the full row space."""
        md = self.apply_m(s, d)
        zs = np.einsum("nbrk,nbk->br", bs, md[:, self.ne :].reshape(self.n, self.m, 3))
        ze = np.einsum("ner,ne->er", be, md[:, : self.ne])
        return self._join_rows(zs, ze)

    def gram(self, s: ClosingState, bs: np.ndarray, be: np.ndarray) -> np.ndarray:
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

    # -- the result ---------------------------------------------------------------------------
    def closed_output(
        self, curve: DiscreteCurve | SRVFunction, q_final: np.ndarray, *, moved: bool, keep_free: bool
    ) -> tuple[DiscreteCurve, SRVFunction]:
        """The closed curve and the solver's own SRV function (module docstring, "Free
        coordinates") for the final ``q_final`` (group order; ``curve`` the input): with
        ``keep_free`` the free Euclidean coordinates and free SO(3) copies of the curve get their
        original samples back; the SRV function is not re-read from the curve."""
        srv = self.srv
        if not moved:
            return (curve if isinstance(curve, DiscreteCurve) else inverse_srv_transform(srv)), srv
        closed = SRVFunction(q_final, srv.t, srv.start, srv.group)
        out_curve = inverse_srv_transform(closed)
        lay = self.layout
        free = np.concatenate([lay.eu_pt[~self.spec.eu_closed], lay.so3_pt[self.spec.mode == 0].ravel()])
        if keep_free and free.size:
            original = curve if isinstance(curve, DiscreteCurve) else inverse_srv_transform(srv)
            vals = np.array(out_curve.values).reshape(out_curve.n_points, -1)
            vals[:, free] = np.asarray(original.values).reshape(original.n_points, -1)[:, free]
            out_curve = DiscreteCurve(vals.reshape(out_curve.values.shape), srv.group, srv.t)
        return out_curve, closed


def l2_norm(dq: np.ndarray, h: np.ndarray) -> float:
    """``sqrt(sum_i h_i |dq_i|^2)``: the L2 norm of a cell-valued function."""
    return float(np.sqrt(np.einsum("i,ij,ij->", h, dq, dq)))


def as_srv(curve: object, name: str = "curve") -> SRVFunction:
    """The SRV function of a ``DiscreteCurve`` (an ``SRVFunction`` as it is); ``ValueError``
    naming ``name`` for anything else."""
    if isinstance(curve, SRVFunction):
        return curve
    if isinstance(curve, DiscreteCurve):
        return srv_transform(curve)
    raise ValueError(f"{name}: expected a DiscreteCurve or an SRVFunction; got {type(curve).__name__}")


# --------------------------------------------------------------------------------------------
# Measuring the seam
# --------------------------------------------------------------------------------------------


def closing_gap(
    curve: DiscreteCurve | SRVFunction,
    *,
    factors: object = None,
    rotation_names: Sequence[str] | None = None,
) -> SeamGap:
    """Measure the seam of a curve: the residuals :func:`~elastic_motion.closing.close_curve` drives to zero.

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
    options = ClosingOptions(factors=factors, cut_locus_tol=1e-9, rotation_names=rotation_names)
    prob = ClosingProblem.from_curve(curve, options)
    s = prob.evaluate_checked(prob.to_internal(prob.srv.q))
    return SeamGap(
        gap=float(np.linalg.norm(s.f0)),
        velocity_gap=float(np.linalg.norm(s.f1)),
        rotation_gaps=s.rot_gaps,
        rotation_angles=s.rot_angles,
        translation_gaps=s.eu_gaps,
    )
