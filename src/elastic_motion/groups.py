"""Lie groups for motion curves: ``R^d``, ``SO(3)``, powers and products of them.

Conventions (used by every layer of the package)
-------------------------------------------------
* **Points** of a group are float64 arrays of shape ``(..., *group.point_shape)``; every
  operation is batched over the leading ``...`` axes with numpy broadcasting.

  - ``Euclidean(d)``: vectors, ``point_shape = (d,)``; the group operation is ``+``.
  - ``SO3()``: rotation matrices acting on column vectors, ``point_shape = (3, 3)``.
  - ``PowerGroup(base, n)``: ``n`` independent copies, ``point_shape = (n, *base.point_shape)``
    (e.g. ``SO(3)^J`` is ``(J, 3, 3)``: one rotation per joint).
  - ``ProductGroup(factors)``: a point is the *flat* concatenation of the factors' raveled
    points, ``point_shape = (P,)``; use :meth:`ProductGroup.split_points` /
    :meth:`ProductGroup.join_points` to get the factors' arrays.

* **Lie algebra elements** are coordinate vectors of shape ``(..., group.dim)``. For
  ``so(3)`` the coordinates are those of the hat map (paper 000, sec. 5.1)::

      hat(x) = [[0, -x3, x2], [x3, 0, -x1], [-x2, x1, 0]],   hat(x) @ y = x × y,

  so ``exp(x)`` is the rotation by the angle ``|x|`` (radians) about ``x / |x|`` and the
  bracket is ``[x, y] = x × y``.

* **Inner product** on the Lie algebra: diagonal, ``<u, v> = sum_k w_k u_k v_k`` with the
  group's ``weights`` (shape ``(dim,)``). For ``SO(3)`` the unweighted inner product is
  ``<x, y> = x · y = 1/2 tr(hat(x) hat(y)^T)``: one half of the Frobenius product, i.e.
  ``-1/2`` of the Cartan-Killing form ``B(x, y) = tr(ad_x ad_y) = -2 x · y`` (``ad_x = hat(x)``
  since ``[x, y] = x × y``). It is bi-invariant
  (``ad`` is skew), so paper 000 Cor. 4.8 applies, and with weight 1 the norm of
  ``log(R)`` is the rotation angle in radians. A weight ``w`` per copy scales this.
  Coordinates in an orthonormal basis are ``sqrt(w) * u`` (:meth:`LieGroup.to_orthonormal`):
  the curves layer stores SRV functions in those so that L2 products are plain dot products.

* **Trivialisation**: right. The SRVT uses ``xi = c' c^{-1}``; the derivative of ``exp`` is
  ``d/de exp(u + e v) = dexp_u(v) exp(u)`` with ``dexp_u = sum_k ad_u^k / (k+1)!``
  (paper 000, eq. 14-15).

Numerical kernels for ``SO(3)`` are numba-compiled (``cache=True``) loops; they are written
so that ``log`` is accurate near the identity and at rotation angles up to and including
``pi`` (where ``log`` is two-valued: either answer is returned).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numba import njit

from elastic_motion._numba_cache import load_kernels_lightly
from elastic_motion._validation import as_float_array, check_finite, check_trailing_shape

__all__ = [
    "SO3",
    "Euclidean",
    "LieGroup",
    "PowerGroup",
    "ProductGroup",
    "animation_group",
    "hat",
    "vee",
]

# Before any kernel of the package runs (every module with a kernel imports this one): load the
# kernels from numba's cache without its compiler's registries (elastic_motion._numba_cache).
load_kernels_lightly()

# Thresholds below which series expansions replace closed forms (chosen so the truncation
# error of the series is below 1e-17 relative, see the kernels' comments).
_SMALL_ANGLE_EXP = 1e-4
_SMALL_ANGLE_SERIES = 1e-2
# Above this angle (cos < -0.8, about 2.5 rad) log reads the axis from the symmetric part of
# R, because sin(angle) -> 0 at pi makes the skew part lose the axis.
_LOG_SYMMETRIC_BRANCH_COS = -0.8


# --------------------------------------------------------------------------------------------
# SO(3) kernels
# --------------------------------------------------------------------------------------------


def hat(x: np.ndarray) -> np.ndarray:
    """Skew matrix of a vector: ``hat(x) @ y = cross(x, y)``.

    Parameters
    ----------
    x : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    x = as_float_array(x, "x")
    check_trailing_shape(x, (3,), "x", "so(3) coordinates")
    out = np.zeros(x.shape[:-1] + (3, 3))
    out[..., 0, 1] = -x[..., 2]
    out[..., 0, 2] = x[..., 1]
    out[..., 1, 0] = x[..., 2]
    out[..., 1, 2] = -x[..., 0]
    out[..., 2, 0] = -x[..., 1]
    out[..., 2, 1] = x[..., 0]
    return out


def vee(m: np.ndarray) -> np.ndarray:
    """Inverse of :func:`hat` applied to the skew part ``(m - m^T) / 2`` of ``m``.

    Parameters
    ----------
    m : array_like, shape (..., 3, 3)

    Returns
    -------
    ndarray, shape (..., 3)
    """
    m = as_float_array(m, "m")
    check_trailing_shape(m, (3, 3), "m", "3x3 matrices")
    return 0.5 * np.stack(
        [m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1]],
        axis=-1,
    )


@njit(cache=True)
def _so3_exp_kernel(v: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover - numba
    # Rodrigues (paper 000, sec. 5.1) in the form R = cos(a) I + A hat(v) + B v v^T with
    # A = sin(a)/a, B = (1 - cos a)/a^2 = 2 sin^2(a/2)/a^2 (no cancellation), a = |v|.
    for n in range(v.shape[0]):
        x = v[n, 0]
        y = v[n, 1]
        z = v[n, 2]
        a2 = x * x + y * y + z * z
        a = math.sqrt(a2)
        if a < 1e-4:
            # Taylor series; the first omitted terms are a^6/5040 and a^6/40320 < 1e-27.
            A = 1.0 - a2 / 6.0 * (1.0 - a2 / 20.0)
            B = 0.5 - a2 / 24.0 * (1.0 - a2 / 30.0)
            c = 1.0 - a2 * B
        else:
            # half-angle forms: two transcendental calls instead of three
            h = math.sin(0.5 * a)
            k = math.cos(0.5 * a)
            A = 2.0 * h * k / a
            B = 2.0 * h * h / a2
            c = 1.0 - 2.0 * h * h
        out[n, 0, 0] = c + B * x * x
        out[n, 0, 1] = -A * z + B * x * y
        out[n, 0, 2] = A * y + B * x * z
        out[n, 1, 0] = A * z + B * x * y
        out[n, 1, 1] = c + B * y * y
        out[n, 1, 2] = -A * x + B * y * z
        out[n, 2, 0] = -A * y + B * x * z
        out[n, 2, 1] = A * x + B * y * z
        out[n, 2, 2] = c + B * z * z


@njit(cache=True)
def _so3_log_kernel(r: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover - numba
    # angle = atan2(|y|, (tr R - 1)/2) with y = vee of the skew part = sin(angle) * axis;
    # accurate over [0, pi] (atan2 never loses precision, unlike arccos near 0 and pi).
    for n in range(r.shape[0]):
        yx = 0.5 * (r[n, 2, 1] - r[n, 1, 2])
        yy = 0.5 * (r[n, 0, 2] - r[n, 2, 0])
        yz = 0.5 * (r[n, 1, 0] - r[n, 0, 1])
        s = math.sqrt(yx * yx + yy * yy + yz * yz)
        c = 0.5 * (r[n, 0, 0] + r[n, 1, 1] + r[n, 2, 2] - 1.0)
        if c > 1.0:
            c = 1.0
        elif c < -1.0:
            c = -1.0
        a = math.atan2(s, c)
        if c > -0.8:
            # a / sin(a) = 1 + a^2/6 + 7 a^4/360 + ...; the series avoids 0/0 at a = 0.
            if a < 1e-4:
                f = 1.0 + a * a / 6.0
            else:
                f = a / s
            out[n, 0] = f * yx
            out[n, 1] = f * yy
            out[n, 2] = f * yz
        else:
            # Near pi: (R + R^T)/2 - cos(a) I = (1 - cos a) n n^T. Read n from the column of
            # the largest diagonal entry, then fix its sign with y = sin(a) n.
            omc = 1.0 - c
            d0 = r[n, 0, 0] - c
            d1 = r[n, 1, 1] - c
            d2 = r[n, 2, 2] - c
            if d0 >= d1 and d0 >= d2:
                n0 = math.sqrt(max(d0, 0.0) / omc)
                n1 = 0.5 * (r[n, 0, 1] + r[n, 1, 0]) / (omc * n0)
                n2 = 0.5 * (r[n, 0, 2] + r[n, 2, 0]) / (omc * n0)
            elif d1 >= d2:
                n1 = math.sqrt(max(d1, 0.0) / omc)
                n0 = 0.5 * (r[n, 0, 1] + r[n, 1, 0]) / (omc * n1)
                n2 = 0.5 * (r[n, 1, 2] + r[n, 2, 1]) / (omc * n1)
            else:
                n2 = math.sqrt(max(d2, 0.0) / omc)
                n0 = 0.5 * (r[n, 0, 2] + r[n, 2, 0]) / (omc * n2)
                n1 = 0.5 * (r[n, 1, 2] + r[n, 2, 1]) / (omc * n2)
            norm = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
            sign = 1.0
            if n0 * yx + n1 * yy + n2 * yz < 0.0:
                sign = -1.0
            g = sign * a / norm
            out[n, 0] = g * n0
            out[n, 1] = g * n1
            out[n, 2] = g * n2


@njit(cache=True)
def _matmul33_kernel(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover
    for n in range(a.shape[0]):
        for i in range(3):
            a0 = a[n, i, 0]
            a1 = a[n, i, 1]
            a2 = a[n, i, 2]
            for j in range(3):
                out[n, i, j] = a0 * b[n, 0, j] + a1 * b[n, 1, j] + a2 * b[n, 2, j]


@njit(cache=True)
def _matmul33t_kernel(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover
    # out = a @ b^T (for b a rotation: a b^{-1} without forming the transpose)
    for n in range(a.shape[0]):
        for i in range(3):
            for j in range(3):
                out[n, i, j] = a[n, i, 0] * b[n, j, 0] + a[n, i, 1] * b[n, j, 1] + a[n, i, 2] * b[n, j, 2]


@njit(cache=True)
def _so3_defect_kernel(r: np.ndarray, err: np.ndarray, det: np.ndarray) -> None:  # pragma: no cover
    # err = max_ij |(R^T R - I)_ij|, det = det R
    for n in range(r.shape[0]):
        e = 0.0
        for i in range(3):
            for j in range(3):
                d = r[n, 0, i] * r[n, 0, j] + r[n, 1, i] * r[n, 1, j] + r[n, 2, i] * r[n, 2, j]
                if i == j:
                    d -= 1.0
                e = max(e, abs(d))
        err[n] = e
        det[n] = (
            r[n, 0, 0] * (r[n, 1, 1] * r[n, 2, 2] - r[n, 1, 2] * r[n, 2, 1])
            - r[n, 0, 1] * (r[n, 1, 0] * r[n, 2, 2] - r[n, 1, 2] * r[n, 2, 0])
            + r[n, 0, 2] * (r[n, 1, 0] * r[n, 2, 1] - r[n, 1, 1] * r[n, 2, 0])
        )


@njit(cache=True)
def _accumulate33_kernel(steps: np.ndarray, start: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover
    # out[0] = start; out[i+1, m] = steps[i, m] @ out[i, m]  (right-trivialised integration,
    # paper 000 sec. 5.1: c_{i+1} = exp(...) c_i).
    n_steps = steps.shape[0]
    for m in range(start.shape[0]):
        for i in range(3):
            for j in range(3):
                out[0, m, i, j] = start[m, i, j]
    for k in range(n_steps):
        for m in range(start.shape[0]):
            for i in range(3):
                s0 = steps[k, m, i, 0]
                s1 = steps[k, m, i, 1]
                s2 = steps[k, m, i, 2]
                for j in range(3):
                    out[k + 1, m, i, j] = s0 * out[k, m, 0, j] + s1 * out[k, m, 1, j] + s2 * out[k, m, 2, j]


def _flat(arr: np.ndarray, trailing: int) -> tuple[np.ndarray, tuple[int, ...]]:
    """C-contiguous ``(N, *trailing_shape)`` view/copy of ``arr`` and its leading shape.

    Always read-only (a view of a copy): numba types a read-only array apart from a writable
    one, so each kernel is compiled, cached and loaded once, not once per flag (a motion's
    arrays are read-only, their copies not; issue 34: every load costs start-up time).
    """
    lead = arr.shape[: arr.ndim - trailing]
    return _read_only(np.ascontiguousarray(arr.reshape((-1,) + arr.shape[arr.ndim - trailing :]))), lead


def _read_only(arr: np.ndarray) -> np.ndarray:
    """``arr`` itself when read-only, else a read-only view of it (a kernel's input: see :func:`_flat`)."""
    if not arr.flags.writeable:
        return arr
    view = arr.view()
    view.flags.writeable = False
    return view


def _series_or(a: np.ndarray, small: np.ndarray, series, closed) -> np.ndarray:
    """Evaluate ``closed(a)`` where ``a`` is large and ``series(a)`` where ``small``."""
    out = np.empty_like(a)
    if small.any():
        out[small] = series(a[small])
    big = ~small
    if big.any():
        out[big] = closed(a[big])
    return out


# --------------------------------------------------------------------------------------------
# Groups
# --------------------------------------------------------------------------------------------


class LieGroup:
    """Base class: a matrix Lie group or vector space with a diagonal inner product.

    Subclasses implement the batched operations below; see the module docstring for the
    array conventions. Attributes: ``dim`` (Lie algebra dimension), ``point_shape``
    (shape of one point), ``weights`` (shape ``(dim,)``, the diagonal of the inner product).
    """

    dim: int
    point_shape: tuple[int, ...]
    weights: np.ndarray

    # -- to be implemented -------------------------------------------------------------------
    def identity(self, shape: tuple[int, ...] = ()) -> np.ndarray:
        """Identity element(s), shape ``(*shape, *point_shape)``."""
        raise NotImplementedError

    def exp(self, v: np.ndarray) -> np.ndarray:
        """Group exponential: ``(..., dim) -> (..., *point_shape)``."""
        raise NotImplementedError

    def log(self, g: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`exp` (principal branch): ``(..., *point_shape) -> (..., dim)``."""
        raise NotImplementedError

    def compose(self, g: np.ndarray, h: np.ndarray) -> np.ndarray:
        """Group product ``g h`` (broadcast over leading axes)."""
        raise NotImplementedError

    def inverse(self, g: np.ndarray) -> np.ndarray:
        """Group inverse ``g^{-1}``."""
        raise NotImplementedError

    def adjoint(self, g: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``Ad_g v = g v g^{-1}``: points ``(..., *point_shape)``, vectors ``(..., dim)``."""
        raise NotImplementedError

    def adjoint_dual(self, g: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``Ad_g^† v``, the adjoint of ``Ad_g`` for the group's inner product."""
        raise NotImplementedError

    def bracket(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Lie bracket ``ad_u v = [u, v]``, shapes ``(..., dim)``."""
        raise NotImplementedError

    def dexp(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Right-trivialised derivative of exp: ``d/de exp(u + e v) = dexp_u(v) exp(u)``."""
        raise NotImplementedError

    def dexp_inv(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`dexp` in its second argument (valid for ``|u| < 2 pi``)."""
        raise NotImplementedError

    def dexp_dual(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``dexp_u^† v``, the adjoint of ``dexp_u`` for the group's inner product."""
        raise NotImplementedError

    def dexp_inv_dual(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``(dexp_u^{-1})^† v`` for the group's inner product (paper 000, Thm. 4.5)."""
        raise NotImplementedError

    def project(self, g: np.ndarray) -> np.ndarray:
        """Nearest point of the group (for points read from files, slightly off it)."""
        raise NotImplementedError

    def accumulate(self, steps: np.ndarray, start: np.ndarray) -> np.ndarray:
        """Right-trivialised integration ``c_0 = start``, ``c_{i+1} = steps_i c_i``.

        Parameters
        ----------
        steps : ndarray, shape (n, *point_shape)
        start : ndarray, shape (*point_shape,)

        Returns
        -------
        ndarray, shape (n+1, *point_shape)
        """
        raise NotImplementedError

    def check_points(self, g: object, name: str) -> np.ndarray:
        """Validate points: float array, trailing shape, finite; returns float64 array."""
        arr = as_float_array(g, name)
        check_trailing_shape(arr, self.point_shape, name, f"points of {self!r}")
        check_finite(arr, name)
        return arr

    # -- shared, derived from the above --------------------------------------------------------
    def inner(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Inner product ``<u, v> = sum_k w_k u_k v_k``: shapes ``(..., dim) -> (...)``."""
        return np.einsum("...k,...k->...", u * self.weights, v)

    def norm(self, u: np.ndarray) -> np.ndarray:
        """Norm induced by :meth:`inner`: ``(..., dim) -> (...)``."""
        return np.sqrt(np.maximum(self.inner(u, u), 0.0))

    def to_orthonormal(self, v: np.ndarray) -> np.ndarray:
        """Coordinates in an orthonormal basis: ``sqrt(w) * v`` (Euclidean dot = inner)."""
        return v * np.sqrt(self.weights)

    def from_orthonormal(self, v: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`to_orthonormal`."""
        return v / np.sqrt(self.weights)

    def difference(self, g: np.ndarray, h: np.ndarray) -> np.ndarray:
        """``log(h g^{-1})``: the algebra element taking ``g`` to ``h`` by right translation."""
        return self.log(self.compose(h, self.inverse(g)))

    def interpolate(self, g: np.ndarray, h: np.ndarray, s: np.ndarray | float) -> np.ndarray:
        """Geodesic ``exp(s log(h g^{-1})) g`` (paper 000, eq. 19); ``s`` broadcasts over ``...``."""
        s = np.asarray(s, dtype=np.float64)
        d = self.difference(g, h)
        return self.compose(self.exp(s[..., None] * d), g)

    def weighted_mean(
        self, points: np.ndarray, weights: np.ndarray, *, max_iter: int = 50, tol: float = 1e-13
    ) -> np.ndarray:
        """Weighted (Karcher-type) mean of ``K`` points by the fixed-point iteration
        ``m <- exp(sum_k w_k log(p_k m^{-1})) m``, started at the point of largest weight.

        Parameters
        ----------
        points : ndarray, shape (K, *point_shape)
        weights : ndarray, shape (K,)
            Non-negative, normalised here to sum 1.

        Returns
        -------
        ndarray, shape point_shape
            For two points with weights ``(1-s, s)`` this is the geodesic point
            ``exp(s log(p_1 p_0^{-1})) p_0``. Exact in one step for vector spaces.
        """
        points = self.check_points(points, "points")
        w = as_float_array(weights, "weights")
        if w.shape != (points.shape[0],):
            raise ValueError(f"weights: expected shape ({points.shape[0]},); got {w.shape}")
        if (w < 0).any() or w.sum() <= 0:
            raise ValueError(f"weights: expected non-negative weights with a positive sum; got {w}")
        w = w / w.sum()
        m = points[int(np.argmax(w))]
        for _ in range(max_iter):
            step = np.einsum("k,k...->...", w, self.difference(m, points))
            m = self.compose(self.exp(step), m)
            if np.sqrt(np.sum(step**2)) < tol:
                break
        return m

    def __eq__(self, other: object) -> bool:
        return type(self) is type(other) and repr(self) == repr(other)

    def __hash__(self) -> int:
        return hash(repr(self))


class Euclidean(LieGroup):
    """The vector space ``R^d`` as an abelian Lie group (operation ``+``).

    Parameters
    ----------
    d : int
        Dimension.
    weight : float or array_like of shape (d,), default 1
        Diagonal of the inner product (e.g. to put metres and radians on one scale).
    """

    def __init__(self, d: int, weight: float | Sequence[float] | np.ndarray = 1.0) -> None:
        if int(d) != d or d < 1:
            raise ValueError(f"d: expected a positive integer dimension; got {d!r}")
        self.dim = int(d)
        self.point_shape = (self.dim,)
        w = np.broadcast_to(as_float_array(weight, "weight"), (self.dim,)).copy()
        if not (np.isfinite(w).all() and (w > 0).all()):
            raise ValueError(f"weight: expected positive finite weights; got {w}")
        self.weights = w

    def __repr__(self) -> str:
        w = self.weights
        wtxt = (
            ""
            if np.all(w == 1.0)
            else f", weight={w[0]!r}"
            if np.all(w == w[0])
            else f", weight={w.tolist()!r}"
        )
        return f"Euclidean({self.dim}{wtxt})"

    def identity(self, shape: tuple[int, ...] = ()) -> np.ndarray:
        return np.zeros(tuple(shape) + self.point_shape)

    def exp(self, v: np.ndarray) -> np.ndarray:
        return np.array(v, dtype=np.float64, copy=True)

    def log(self, g: np.ndarray) -> np.ndarray:
        return np.array(g, dtype=np.float64, copy=True)

    def compose(self, g: np.ndarray, h: np.ndarray) -> np.ndarray:
        return np.add(g, h, dtype=np.float64)

    def inverse(self, g: np.ndarray) -> np.ndarray:
        return -np.asarray(g, dtype=np.float64)

    def difference(self, g: np.ndarray, h: np.ndarray) -> np.ndarray:
        return np.subtract(h, g, dtype=np.float64)

    def adjoint(self, g: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.broadcast_to(v, np.broadcast_shapes(np.shape(g), np.shape(v))).astype(np.float64)

    adjoint_dual = adjoint

    def bracket(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.zeros(np.broadcast_shapes(np.shape(u), np.shape(v)))

    def dexp(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.broadcast_to(v, np.broadcast_shapes(np.shape(u), np.shape(v))).astype(np.float64)

    dexp_inv = dexp
    dexp_dual = dexp
    dexp_inv_dual = dexp

    def project(self, g: np.ndarray) -> np.ndarray:
        return np.asarray(g, dtype=np.float64)

    def accumulate(self, steps: np.ndarray, start: np.ndarray) -> np.ndarray:
        steps = np.asarray(steps, dtype=np.float64)
        out = np.empty((steps.shape[0] + 1,) + steps.shape[1:])
        out[0] = start
        np.cumsum(steps, axis=0, out=out[1:])
        out[1:] += start
        return out


class SO3(LieGroup):
    """The rotation group ``SO(3)``; points are ``(..., 3, 3)`` rotation matrices.

    Parameters
    ----------
    weight : float, default 1
        Scales the bi-invariant inner product ``<x, y> = weight * x · y`` (module docstring).
    """

    dim = 3
    point_shape = (3, 3)

    #: Largest deviation ``max |R^T R - I|`` accepted by :meth:`check_points` before a matrix
    #: is rejected as "not a rotation" (rather than projected). Files store rotations with a
    #: few significant digits, so small deviations are normal.
    orthogonality_tolerance = 1e-2

    def __init__(self, weight: float = 1.0) -> None:
        w = float(weight)
        if not (math.isfinite(w) and w > 0):
            raise ValueError(f"weight: expected a positive finite number; got {weight!r}")
        self.weight = w
        self.weights = np.full(3, w)

    def __repr__(self) -> str:
        return "SO3()" if self.weight == 1.0 else f"SO3(weight={self.weight!r})"

    def identity(self, shape: tuple[int, ...] = ()) -> np.ndarray:
        return np.broadcast_to(np.eye(3), tuple(shape) + (3, 3)).copy()

    def exp(self, v: np.ndarray) -> np.ndarray:
        v = np.asarray(v, dtype=np.float64)
        flat, lead = _flat(v, 1)
        out = np.empty((flat.shape[0], 3, 3))
        _so3_exp_kernel(flat, out)
        return out.reshape(lead + (3, 3))

    def log(self, g: np.ndarray) -> np.ndarray:
        g = np.asarray(g, dtype=np.float64)
        flat, lead = _flat(g, 2)
        out = np.empty((flat.shape[0], 3))
        _so3_log_kernel(flat, out)
        return out.reshape(lead + (3,))

    def compose(self, g: np.ndarray, h: np.ndarray) -> np.ndarray:
        g = np.asarray(g, dtype=np.float64)
        h = np.asarray(h, dtype=np.float64)
        shape = np.broadcast_shapes(g.shape, h.shape)
        if int(np.prod(shape[:-2], dtype=np.int64)) < 8:
            return np.matmul(g, h)
        a, lead = _flat(np.broadcast_to(g, shape), 2)
        b, _ = _flat(np.broadcast_to(h, shape), 2)
        out = np.empty_like(a)
        _matmul33_kernel(a, b, out)
        return out.reshape(lead + (3, 3))

    def inverse(self, g: np.ndarray) -> np.ndarray:
        return np.swapaxes(np.asarray(g, dtype=np.float64), -1, -2).copy()

    def difference(self, g: np.ndarray, h: np.ndarray) -> np.ndarray:
        # log(h g^T), fused: this is the SRVT's inner loop
        g = np.asarray(g, dtype=np.float64)
        h = np.asarray(h, dtype=np.float64)
        shape = np.broadcast_shapes(g.shape, h.shape)
        a, lead = _flat(np.broadcast_to(h, shape), 2)
        b, _ = _flat(np.broadcast_to(g, shape), 2)
        prod = np.empty_like(a)
        _matmul33t_kernel(a, b, prod)
        out = np.empty((a.shape[0], 3))
        _so3_log_kernel(_read_only(prod), out)
        return out.reshape(lead + (3,))

    def adjoint(self, g: np.ndarray, v: np.ndarray) -> np.ndarray:
        # hat(R x) = R hat(x) R^T, so Ad_R is the matrix R acting on coordinates.
        return np.einsum("...ij,...j->...i", g, v)

    def adjoint_dual(self, g: np.ndarray, v: np.ndarray) -> np.ndarray:
        # The inner product is a multiple of the dot product, so Ad_R^† = R^T.
        return np.einsum("...ji,...j->...i", g, v)

    def bracket(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.cross(u, v)

    @staticmethod
    def _dexp_coefficients(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # dexp_u = I + a hat(u) + b hat(u)^2, a = (1 - cos t)/t^2, b = (t - sin t)/t^3, t = |u|
        # (the series sum_k ad_u^k/(k+1)! of paper 000 eq. 15 in closed form).
        t = np.linalg.norm(u, axis=-1)
        small = t < _SMALL_ANGLE_SERIES
        a = _series_or(
            t,
            small,
            lambda x: 0.5 - x**2 / 24.0 + x**4 / 720.0,
            lambda x: 2.0 * np.sin(0.5 * x) ** 2 / x**2,
        )
        b = _series_or(
            t,
            small,
            lambda x: 1.0 / 6.0 - x**2 / 120.0 + x**4 / 5040.0,
            lambda x: (x - np.sin(x)) / x**3,
        )
        return a, b

    def dexp(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        u = np.asarray(u, dtype=np.float64)
        v = np.asarray(v, dtype=np.float64)
        a, b = self._dexp_coefficients(u)
        uv = np.cross(u, v)
        return v + a[..., None] * uv + b[..., None] * np.cross(u, uv)

    def dexp_matrix(self, u: np.ndarray) -> np.ndarray:
        """The matrix of ``v -> dexp_u(v)``, ``I + a hat(u) + b hat(u)^2``, shape ``(..., 3, 3)``.

        The same closed form as :meth:`dexp` (one home for it), for callers that apply
        ``dexp_u`` to many vectors or compose it with other matrices (the closing Jacobian).
        """
        u = np.asarray(u, dtype=np.float64)
        a, b = self._dexp_coefficients(u)
        # hat(u)^2 = u u^T - |u|^2 I
        t2 = np.einsum("...i,...i->...", u, u)
        out = (b[..., None, None] * u[..., :, None]) * u[..., None, :] + a[..., None, None] * hat(u)
        out += (1.0 - b * t2)[..., None, None] * np.eye(3)
        return out

    def dexp_inv(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        # dexp_u^{-1} = I - hat(u)/2 + e hat(u)^2, e = (1 - (t/2) cot(t/2)) / t^2.
        u = np.asarray(u, dtype=np.float64)
        v = np.asarray(v, dtype=np.float64)
        t = np.linalg.norm(u, axis=-1)
        small = t < _SMALL_ANGLE_SERIES
        e = _series_or(
            t,
            small,
            lambda x: 1.0 / 12.0 + x**2 / 720.0 + x**4 / 30240.0,
            lambda x: (1.0 - 0.5 * x / np.tan(0.5 * x)) / x**2,
        )
        uv = np.cross(u, v)
        return v - 0.5 * uv + e[..., None] * np.cross(u, uv)

    def dexp_dual(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        # hat(u) is skew for the (scaled) dot product: dexp_u^† = dexp_{-u}.
        return self.dexp(-np.asarray(u, dtype=np.float64), v)

    def dexp_inv_dual(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        # hat(u) is skew for the (scaled) dot product: (dexp_u^{-1})^† = dexp_{-u}^{-1}.
        return self.dexp_inv(-np.asarray(u, dtype=np.float64), v)

    def project(self, g: np.ndarray) -> np.ndarray:
        """Nearest rotation in the Frobenius norm (polar decomposition by SVD, ``det = +1``).

        Parameters
        ----------
        g : array_like, shape (..., 3, 3)

        Returns
        -------
        ndarray, shape (..., 3, 3)
        """
        g = np.asarray(g, dtype=np.float64)
        u, _, vt = np.linalg.svd(g)
        d = np.sign(np.linalg.det(u @ vt))
        d = np.where(d == 0, 1.0, d)  # (an array also for a single matrix)
        u[..., :, 2] *= d[..., None]
        return u @ vt

    def check_points(self, g: object, name: str) -> np.ndarray:
        """Validate rotation matrices; nearly orthogonal ones are projected to SO(3).

        Matrices with ``max |R^T R - I| <= 1e-12`` and ``det > 0`` are returned as they are;
        up to :attr:`orthogonality_tolerance` they are projected (:meth:`project`); beyond it,
        or with a negative determinant, ``ValueError`` names the first offending index.
        """
        arr = super().check_points(g, name)
        flat, lead = _flat(arr, 2)
        err = np.empty(flat.shape[0])
        det = np.empty(flat.shape[0])
        _so3_defect_kernel(flat, err, det)
        err = err.reshape(lead)
        det = det.reshape(lead)
        bad = (err > self.orthogonality_tolerance) | (det <= 0)
        if bad.any():
            idx = tuple(int(i) for i in np.argwhere(bad)[0]) if bad.ndim else ()
            raise ValueError(
                f"{name}: expected rotation matrices (R^T R = I, det R = +1); the matrix at "
                f"index {idx} has max|R^T R - I| = {np.asarray(err)[idx]:.3g} and "
                f"det = {np.asarray(det)[idx]:.3g}"
            )
        if (err > 1e-12).any():
            arr = self.project(arr)
        return arr

    def accumulate(self, steps: np.ndarray, start: np.ndarray) -> np.ndarray:
        steps = np.asarray(steps, dtype=np.float64)
        n = steps.shape[0]
        batch = steps.shape[1:-2]
        s = np.ascontiguousarray(steps.reshape((n, -1, 3, 3)))
        st = np.ascontiguousarray(np.broadcast_to(start, batch + (3, 3)).reshape((-1, 3, 3)))
        out = np.empty((n + 1,) + st.shape)
        _accumulate33_kernel(s, st, out)
        return out.reshape((n + 1,) + batch + (3, 3))


class PowerGroup(LieGroup):
    """``n`` independent copies of ``base`` (e.g. ``SO(3)^J``, one rotation per joint).

    Parameters
    ----------
    base : LieGroup
        The group of one copy (``SO3()`` or ``Euclidean(d)``).
    n : int
        Number of copies.
    weights : array_like, shape (n,), optional
        Weight of each copy; copy ``k`` has inner product ``weights[k] * <., .>_base``.

    Points have shape ``(..., n, *base.point_shape)``; algebra vectors ``(..., n * base.dim)``
    with copy ``k`` at ``[k*base.dim:(k+1)*base.dim]``.
    """

    def __init__(self, base: LieGroup, n: int, weights: Sequence[float] | np.ndarray | None = None) -> None:
        if not isinstance(base, LieGroup) or isinstance(base, ProductGroup):
            raise ValueError(f"base: expected a simple LieGroup (SO3 or Euclidean); got {base!r}")
        if int(n) != n or n < 1:
            raise ValueError(f"n: expected a positive integer number of copies; got {n!r}")
        self.base = base
        self.n = int(n)
        cw = np.ones(self.n) if weights is None else as_float_array(weights, "weights")
        if cw.shape != (self.n,):
            raise ValueError(f"weights: expected one weight per copy, shape ({self.n},); got {cw.shape}")
        if not (np.isfinite(cw).all() and (cw > 0).all()):
            raise ValueError(f"weights: expected positive finite weights; got {cw}")
        self.copy_weights = cw
        self.dim = self.n * base.dim
        self.point_shape = (self.n,) + tuple(base.point_shape)
        self.weights = (cw[:, None] * base.weights[None, :]).ravel()

    def __repr__(self) -> str:
        w = "" if np.all(self.copy_weights == 1.0) else f", weights={self.copy_weights.tolist()!r}"
        return f"PowerGroup({self.base!r}, {self.n}{w})"

    def _split(self, v: np.ndarray) -> np.ndarray:
        v = np.asarray(v, dtype=np.float64)
        return v.reshape(v.shape[:-1] + (self.n, self.base.dim))

    def _join(self, v: np.ndarray) -> np.ndarray:
        return v.reshape(v.shape[:-2] + (self.dim,))

    def identity(self, shape: tuple[int, ...] = ()) -> np.ndarray:
        return self.base.identity(tuple(shape) + (self.n,))

    def exp(self, v: np.ndarray) -> np.ndarray:
        return self.base.exp(self._split(v))

    def log(self, g: np.ndarray) -> np.ndarray:
        return self._join(self.base.log(g))

    def compose(self, g: np.ndarray, h: np.ndarray) -> np.ndarray:
        return self.base.compose(g, h)

    def inverse(self, g: np.ndarray) -> np.ndarray:
        return self.base.inverse(g)

    def difference(self, g: np.ndarray, h: np.ndarray) -> np.ndarray:
        return self._join(self.base.difference(g, h))

    def adjoint(self, g: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._join(self.base.adjoint(g, self._split(v)))

    def adjoint_dual(self, g: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._join(self.base.adjoint_dual(g, self._split(v)))

    def bracket(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._join(self.base.bracket(self._split(u), self._split(v)))

    def dexp(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._join(self.base.dexp(self._split(u), self._split(v)))

    def dexp_inv(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._join(self.base.dexp_inv(self._split(u), self._split(v)))

    def dexp_dual(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._join(self.base.dexp_dual(self._split(u), self._split(v)))

    def dexp_inv_dual(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._join(self.base.dexp_inv_dual(self._split(u), self._split(v)))

    def project(self, g: np.ndarray) -> np.ndarray:
        return self.base.project(g)

    def check_points(self, g: object, name: str) -> np.ndarray:
        arr = as_float_array(g, name)
        check_trailing_shape(arr, self.point_shape, name, f"points of {self!r}")
        return self.base.check_points(arr, name)

    def accumulate(self, steps: np.ndarray, start: np.ndarray) -> np.ndarray:
        return self.base.accumulate(steps, start)


class ProductGroup(LieGroup):
    """Direct product ``G_1 x ... x G_K`` (e.g. ``R^3 x SO(3)^J`` for an animation).

    A point is the flat concatenation of the factors' raveled points, shape ``(..., P)``
    with ``P = sum_k prod(G_k.point_shape)``; an algebra vector the concatenation of the
    factors' coordinates, ``(..., sum_k G_k.dim)``. The inner product is the sum of the
    factors' (already weighted) inner products.

    Parameters
    ----------
    factors : sequence of LieGroup
        ``Euclidean``, ``SO3`` or ``PowerGroup`` instances (not nested products).
    """

    def __init__(self, factors: Sequence[LieGroup]) -> None:
        factors = list(factors)
        if not factors or not all(
            isinstance(f, LieGroup) and not isinstance(f, ProductGroup) for f in factors
        ):
            raise ValueError(f"factors: expected a non-empty list of non-product LieGroups; got {factors!r}")
        self.factors = factors
        sizes = [int(np.prod(f.point_shape)) for f in factors]
        self._point_bounds = np.concatenate([[0], np.cumsum(sizes)]).astype(int)
        self._alg_bounds = np.concatenate([[0], np.cumsum([f.dim for f in factors])]).astype(int)
        self.dim = int(self._alg_bounds[-1])
        self.point_shape = (int(self._point_bounds[-1]),)
        self.weights = np.concatenate([f.weights for f in factors])

    def __repr__(self) -> str:
        return f"ProductGroup([{', '.join(repr(f) for f in self.factors)}])"

    # -- splitting ----------------------------------------------------------------------------
    def split_points(self, g: np.ndarray) -> list[np.ndarray]:
        """Factor arrays ``[(..., *G_1.point_shape), ...]`` (views) of flat points ``(..., P)``."""
        g = np.asarray(g, dtype=np.float64)
        lead = g.shape[:-1]
        return [
            g[..., a:b].reshape(lead + tuple(f.point_shape))
            for f, a, b in zip(self.factors, self._point_bounds[:-1], self._point_bounds[1:], strict=True)
        ]

    def join_points(self, parts: Sequence[np.ndarray]) -> np.ndarray:
        """Inverse of :meth:`split_points`: factor arrays with common leading shape -> ``(..., P)``."""
        if len(parts) != len(self.factors):
            raise ValueError(f"parts: expected {len(self.factors)} factor arrays; got {len(parts)}")
        flat = []
        lead = None
        for k, (f, p) in enumerate(zip(self.factors, parts, strict=True)):
            p = as_float_array(p, f"parts[{k}]")
            check_trailing_shape(p, f.point_shape, f"parts[{k}]", f"points of {f!r}")
            this_lead = p.shape[: p.ndim - len(f.point_shape)]
            if lead is not None and this_lead != lead:
                raise ValueError(f"parts[{k}]: expected leading shape {lead} like parts[0]; got {this_lead}")
            lead = this_lead
            flat.append(p.reshape(this_lead + (-1,)))
        return np.concatenate(flat, axis=-1)

    def split_algebra(self, v: np.ndarray) -> list[np.ndarray]:
        """Factor coordinate arrays ``[(..., G_1.dim), ...]`` (views) of ``(..., dim)``."""
        v = np.asarray(v, dtype=np.float64)
        return [v[..., a:b] for a, b in zip(self._alg_bounds[:-1], self._alg_bounds[1:], strict=True)]

    def _map_points(self, fn_name: str, *pts: np.ndarray) -> np.ndarray:
        split = [self.split_points(p) for p in pts]
        return self.join_points_broadcast(
            [getattr(f, fn_name)(*(s[k] for s in split)) for k, f in enumerate(self.factors)]
        )

    def join_points_broadcast(self, parts: Sequence[np.ndarray]) -> np.ndarray:
        """Like :meth:`join_points` but broadcasting the factors' leading shapes."""
        leads = [p.shape[: p.ndim - len(f.point_shape)] for f, p in zip(self.factors, parts, strict=True)]
        lead = np.broadcast_shapes(*leads)
        return self.join_points(
            [
                np.broadcast_to(p, lead + tuple(f.point_shape))
                for f, p in zip(self.factors, parts, strict=True)
            ]
        )

    # -- group operations -----------------------------------------------------------------------
    def identity(self, shape: tuple[int, ...] = ()) -> np.ndarray:
        return self.join_points([f.identity(shape) for f in self.factors])

    def exp(self, v: np.ndarray) -> np.ndarray:
        return self.join_points([f.exp(x) for f, x in zip(self.factors, self.split_algebra(v), strict=True)])

    def log(self, g: np.ndarray) -> np.ndarray:
        return np.concatenate(
            [f.log(x) for f, x in zip(self.factors, self.split_points(g), strict=True)], axis=-1
        )

    def compose(self, g: np.ndarray, h: np.ndarray) -> np.ndarray:
        return self._map_points("compose", g, h)

    def inverse(self, g: np.ndarray) -> np.ndarray:
        return self._map_points("inverse", g)

    def difference(self, g: np.ndarray, h: np.ndarray) -> np.ndarray:
        gs, hs = self.split_points(g), self.split_points(h)
        return np.concatenate(
            [f.difference(a, b) for f, a, b in zip(self.factors, gs, hs, strict=True)], axis=-1
        )

    def _map_algebra(
        self, fn_name: str, g_or_u: np.ndarray, v: np.ndarray, first_is_point: bool
    ) -> np.ndarray:
        firsts = self.split_points(g_or_u) if first_is_point else self.split_algebra(g_or_u)
        vs = self.split_algebra(v)
        return np.concatenate(
            [getattr(f, fn_name)(a, b) for f, a, b in zip(self.factors, firsts, vs, strict=True)], axis=-1
        )

    def adjoint(self, g: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._map_algebra("adjoint", g, v, True)

    def adjoint_dual(self, g: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._map_algebra("adjoint_dual", g, v, True)

    def bracket(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._map_algebra("bracket", u, v, False)

    def dexp(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._map_algebra("dexp", u, v, False)

    def dexp_inv(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._map_algebra("dexp_inv", u, v, False)

    def dexp_dual(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._map_algebra("dexp_dual", u, v, False)

    def dexp_inv_dual(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._map_algebra("dexp_inv_dual", u, v, False)

    def project(self, g: np.ndarray) -> np.ndarray:
        return self._map_points("project", g)

    def check_points(self, g: object, name: str) -> np.ndarray:
        arr = super().check_points(g, name)
        return self.join_points(
            [
                f.check_points(p, f"{name} (factor {k}: {f!r})")
                for k, (f, p) in enumerate(zip(self.factors, self.split_points(arr), strict=True))
            ]
        )

    def accumulate(self, steps: np.ndarray, start: np.ndarray) -> np.ndarray:
        return self.join_points(
            [
                f.accumulate(s, s0)
                for f, s, s0 in zip(
                    self.factors, self.split_points(steps), self.split_points(start), strict=True
                )
            ]
        )


def animation_group(
    n_joints: int,
    joint_weights: Sequence[float] | np.ndarray | None = None,
    translation_weight: float = 1.0,
) -> ProductGroup:
    """The group ``R^3 x SO(3)^J`` of an animation frame: root position, then one rotation
    per joint (joint 0 is the root's orientation).

    Parameters
    ----------
    n_joints : int
        ``J``, the number of joints with a rotation.
    joint_weights : array_like, shape (J,), optional
        Inner-product weight of each joint's rotation (default 1 each).
    translation_weight : float, default 1
        Inner-product weight of the root position (units of the motion: a weight of
        ``1/L^2`` makes a root displacement of ``L`` count like one radian).

    Returns
    -------
    ProductGroup
        ``ProductGroup([Euclidean(3, translation_weight), PowerGroup(SO3(), J, joint_weights)])``;
        points have shape ``(..., 3 + 9 J)``, algebra vectors ``(..., 3 + 3 J)``.
    """
    return ProductGroup([Euclidean(3, weight=translation_weight), PowerGroup(SO3(), n_joints, joint_weights)])
