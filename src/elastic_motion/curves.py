"""Discrete curves in Lie groups and their square root velocity (SRV) transform.

Conventions
-----------
* A :class:`DiscreteCurve` has samples ``values[i] = c(t[i])``, shape
  ``(n+1, *group.point_shape)``, at strictly increasing parameters ``t`` with ``t[0] = 0``
  and ``t[-1] = 1`` (uniform by default). Between samples the curve is the group geodesic
  ``c(t) = exp(u log(c[i+1] c[i]^{-1})) c[i]``, ``u = (t - t[i]) / (t[i+1] - t[i])``
  (paper 000, eq. 19): the curve is piecewise geodesic and :meth:`DiscreteCurve.evaluate`
  is exact for it.
* An :class:`SRVFunction` is *cell-valued* and piecewise constant: ``q[i]`` holds on
  ``[t[i], t[i+1])``, shape ``(n, dim)``. It is stored in **orthonormal coordinates** of the
  Lie algebra (``sqrt(weights) * xi``, see :mod:`elastic_motion.groups`), so the pointwise
  inner product is the dot product and ``||q||^2_L2 = sum_i |q[i]|^2 (t[i+1] - t[i])``.
  Every solver downstream (``warp``, ``closing``) works on these arrays directly.
* Discrete SRVT (paper 000, sec. 5.1)::

      xi_i = log(c[i+1] c[i]^{-1}) / (t[i+1] - t[i]),   q_i = xi_i / sqrt(|xi_i|),

  with ``q_i = 0`` on intervals where the curve stands still. The inverse integrates
  ``c[i+1] = exp((t[i+1] - t[i]) |q_i| q_i) c[i]`` from the stored start point ``c[0]``.
  The transform is right-translation invariant (paper 000, Lemma 3.6), so the start point
  is kept beside ``q``.
* A *warp* ``phi`` is increasing with ``phi(0) = 0`` and ``phi(1) = 1``. It is given either
  as its samples on the curve's own grid (shape ``(n+1,)``) or as the vertices of a
  piecewise linear function (shape ``(K, 2)``: columns ``tau``, ``phi(tau)``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from elastic_motion._validation import as_float_array, check_finite, check_parameters
from elastic_motion.groups import LieGroup

__all__ = [
    "DiscreteCurve",
    "SRVFunction",
    "as_warp_vertices",
    "blend",
    "common_refinement",
    "curve_distance",
    "inverse_srv_transform",
    "reparametrize_curve",
    "reparametrize_srv",
    "srv_distance",
    "srv_transform",
    "weighted_blend",
]


def _uniform(n_points: int) -> np.ndarray:
    return np.linspace(0.0, 1.0, n_points)


@dataclass(frozen=True, eq=False)
class DiscreteCurve:
    """Samples of a curve in a Lie group.

    Parameters
    ----------
    values : array_like, shape (n+1, *group.point_shape)
        ``c(t[i])``; at least 2 samples. Checked by ``group.check_points`` (finite values;
        nearly orthogonal rotation matrices are projected to SO(3)).
    group : LieGroup
    t : array_like, shape (n+1,), optional
        Strictly increasing parameters from 0 to 1; uniform when omitted.
    """

    values: np.ndarray
    group: LieGroup
    t: np.ndarray = field(default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        if not isinstance(self.group, LieGroup):
            raise ValueError(f"group: expected a LieGroup; got {type(self.group).__name__}")
        values = self.group.check_points(self.values, "values")
        if values.ndim != 1 + len(self.group.point_shape):
            raise ValueError(
                f"values: expected shape (n+1, {', '.join(map(str, self.group.point_shape))}) "
                f"for {self.group!r}; got {values.shape}"
            )
        if values.shape[0] < 2:
            raise ValueError(f"values: expected at least 2 samples; got {values.shape[0]}")
        t = _uniform(values.shape[0]) if self.t is None else check_parameters(self.t, "t", values.shape[0])
        values.setflags(write=False)
        t.setflags(write=False)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "t", t)

    @property
    def n_points(self) -> int:
        """Number of samples ``n+1``."""
        return int(self.values.shape[0])

    def evaluate(self, s: np.ndarray | float) -> np.ndarray:
        """The piecewise geodesic curve at parameters ``s`` in [0, 1].

        Parameters
        ----------
        s : array_like, shape (m,) or scalar

        Returns
        -------
        ndarray, shape (m, *point_shape) (or ``point_shape`` for a scalar)
        """
        s_arr = as_float_array(s, "s")
        check_finite(s_arr, "s")
        if (s_arr < 0).any() or (s_arr > 1).any():
            raise ValueError(f"s: expected parameters in [0, 1]; got range [{s_arr.min()}, {s_arr.max()}]")
        flat = np.atleast_1d(s_arr)
        j = np.clip(np.searchsorted(self.t, flat, side="right") - 1, 0, self.n_points - 2)
        u = (flat - self.t[j]) / (self.t[j + 1] - self.t[j])
        out = self.group.interpolate(self.values[j], self.values[j + 1], u)
        return out[0] if s_arr.ndim == 0 else out


@dataclass(frozen=True, eq=False)
class SRVFunction:
    """Piecewise constant SRV function of a discrete curve, with the curve's start point.

    Parameters
    ----------
    q : ndarray, shape (n, group.dim)
        Cell values in orthonormal Lie algebra coordinates; ``q[i]`` holds on ``[t[i], t[i+1])``.
    t : ndarray, shape (n+1,)
        Break points, strictly increasing from 0 to 1.
    start : ndarray, shape group.point_shape
        ``c(0)``, needed by the inverse transform.
    group : LieGroup
    """

    q: np.ndarray
    t: np.ndarray
    start: np.ndarray
    group: LieGroup

    def __post_init__(self) -> None:
        if not isinstance(self.group, LieGroup):
            raise ValueError(f"group: expected a LieGroup; got {type(self.group).__name__}")
        q = as_float_array(self.q, "q")
        if q.ndim != 2 or q.shape[1] != self.group.dim:
            raise ValueError(f"q: expected shape (n, {self.group.dim}) for {self.group!r}; got {q.shape}")
        check_finite(q, "q")
        t = check_parameters(self.t, "t", q.shape[0] + 1)
        start = self.group.check_points(self.start, "start")
        if start.shape != tuple(self.group.point_shape):
            raise ValueError(f"start: expected shape {self.group.point_shape}; got {start.shape}")
        for a in (q, t, start):
            a.setflags(write=False)
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "start", start)

    @property
    def dt(self) -> np.ndarray:
        """Cell lengths ``t[i+1] - t[i]``, shape (n,)."""
        return np.diff(self.t)

    def norm(self) -> float:
        """L2 norm ``(sum_i |q_i|^2 dt_i)^(1/2)``; equals the square root of the curve's length
        in the group metric (``|q|^2 = |xi|``)."""
        return float(np.sqrt(np.dot(np.einsum("ij,ij->i", self.q, self.q), self.dt)))

    def on_grid(self, t: np.ndarray) -> SRVFunction:
        """The L2-orthogonal projection onto piecewise constants on the grid ``t``
        (cell averages; exact when ``t`` refines ``self.t``)."""
        t = check_parameters(t, "t")
        merged = np.union1d(self.t, t)
        qa = _values_on(self.q, self.t, merged)
        cell = np.searchsorted(t, merged[:-1], side="right") - 1
        dt = np.diff(merged)
        sums = np.zeros((t.shape[0] - 1, self.q.shape[1]))
        np.add.at(sums, cell, qa * dt[:, None])
        return SRVFunction(sums / np.diff(t)[:, None], t, self.start, self.group)


# ---------------------------------------------------------------------------------------------
# Transform and inverse
# ---------------------------------------------------------------------------------------------


def srv_transform(curve: DiscreteCurve) -> SRVFunction:
    """Discrete SRVT of a curve (paper 000, sec. 5.1).

    Parameters
    ----------
    curve : DiscreteCurve
        ``n+1`` samples in ``curve.group``.

    Returns
    -------
    SRVFunction
        ``q`` of shape ``(n, dim)`` in orthonormal coordinates, on ``curve.t``, with
        ``start = curve.values[0]``. Cells where the curve stands still get ``q = 0``.

    Notes
    -----
    For rotation steps of angle ``pi`` between consecutive samples the direction of
    ``log`` is ambiguous; motion data sampled at animation rates is far from that.
    """
    if not isinstance(curve, DiscreteCurve):
        raise ValueError(f"curve: expected a DiscreteCurve; got {type(curve).__name__}")
    g = curve.group
    dt = np.diff(curve.t)
    steps = g.difference(curve.values[:-1], curve.values[1:])  # log(c[i+1] c[i]^{-1})
    xi = g.to_orthonormal(steps) / dt[:, None]
    speed = np.sqrt(np.einsum("ij,ij->i", xi, xi))
    scale = np.zeros_like(speed)
    moving = speed > 0
    scale[moving] = 1.0 / np.sqrt(speed[moving])
    return SRVFunction(xi * scale[:, None], curve.t, curve.values[0], g)


def inverse_srv_transform(srv: SRVFunction) -> DiscreteCurve:
    """Reconstruct the piecewise geodesic curve of an SRV function (paper 000, sec. 5.1).

    ``c[0] = srv.start``, ``c[i+1] = exp((t[i+1] - t[i]) |q_i| q_i) c[i]`` (coordinates
    converted back from orthonormal ones).

    Returns
    -------
    DiscreteCurve
        ``n+1`` samples on ``srv.t``.
    """
    if not isinstance(srv, SRVFunction):
        raise ValueError(f"srv: expected an SRVFunction; got {type(srv).__name__}")
    g = srv.group
    qn = np.sqrt(np.einsum("ij,ij->i", srv.q, srv.q))
    steps = g.from_orthonormal(srv.q * (qn * srv.dt)[:, None])
    values = g.accumulate(g.exp(steps), srv.start)
    return DiscreteCurve(values, g, srv.t)


# ---------------------------------------------------------------------------------------------
# Piecewise constant functions on different grids
# ---------------------------------------------------------------------------------------------


#: Break points closer than this (parameters in [0, 1]) are one break point of a merged grid:
#: break points computed two ways (a warp's vertex and the pre-image of a break point) agree
#: only up to rounding, and a cell of width 1e-16 would carry a meaningless sample.
MERGE_TOL = 1e-12


def _merge_breaks(grid: np.ndarray, tol: float = MERGE_TOL) -> np.ndarray:
    """Sorted break points without those within ``tol`` of their predecessor.

    ``grid`` is sorted, from 0 to 1; the end points are kept (a point within ``tol`` of the
    last one gives way to it).  Returns ``grid`` itself when no two points are that close.
    """
    if grid.shape[0] <= 2:
        return grid
    keep = np.concatenate([[True], np.diff(grid) > tol])
    if keep.all():
        return grid
    out = grid[keep]
    if not keep[-1]:
        out[-1] = grid[-1]  # the end point replaces the point it is close to
    return out


def _values_on(q: np.ndarray, t: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """Values of the piecewise constant ``(q, t)`` on the cells of ``grid`` (which refines t,
    up to break points merged within :data:`MERGE_TOL`): the value at each cell's midpoint."""
    mid = 0.5 * (grid[:-1] + grid[1:])
    cell = np.clip(np.searchsorted(t, mid, side="right") - 1, 0, q.shape[0] - 1)
    return q[cell]


def common_refinement(
    functions: Sequence[tuple[np.ndarray, np.ndarray]],
) -> tuple[np.ndarray, list[np.ndarray]]:
    """Merge the break points of piecewise constant functions ``(q_k, t_k)``.

    Break points closer than :data:`MERGE_TOL` are merged (:func:`_merge_breaks`), so the
    merged grid has no cells of rounding width; each function is read at the midpoints of
    the merged cells (exact up to the merged slivers, of total width ``< MERGE_TOL`` each).

    Returns the merged grid and each function's values on its cells.
    """
    grid = functions[0][1]
    for _, t in functions[1:]:
        grid = np.union1d(grid, t)
    grid = _merge_breaks(grid)
    return grid, [_values_on(q, t, grid) for q, t in functions]


def _check_same_group(a: LieGroup, b: LieGroup, name_a: str, name_b: str) -> None:
    if a != b:
        raise ValueError(f"{name_b}: expected a curve in the same group as {name_a} ({a!r}); got {b!r}")


def srv_distance(srv0: SRVFunction, srv1: SRVFunction) -> float:
    """L2 distance ``||q0 - q1||`` of two SRV functions, exact on their merged grid."""
    _check_same_group(srv0.group, srv1.group, "srv0", "srv1")
    grid, (a, b) = common_refinement([(srv0.q, srv0.t), (srv1.q, srv1.t)])
    d = a - b
    return float(np.sqrt(np.dot(np.einsum("ij,ij->i", d, d), np.diff(grid))))


def curve_distance(c0: DiscreteCurve, c1: DiscreteCurve) -> float:
    """Distance of parametrised curves ``d_P(c0, c1) = ||R(c0) - R(c1)||_L2`` (paper 000, eq. 4).

    Invariant under right translation of either curve (Lemma 3.6) and under a common
    reparametrisation of both (Prop. 3.8; for discrete curves up to discretisation error).
    """
    return srv_distance(srv_transform(c0), srv_transform(c1))


# ---------------------------------------------------------------------------------------------
# Reparametrisation
# ---------------------------------------------------------------------------------------------


def as_warp_vertices(phi: object, t: np.ndarray | None = None, name: str = "phi") -> np.ndarray:
    """Normalise a warp to the vertices ``(K, 2)`` of a piecewise linear increasing function.

    Parameters
    ----------
    phi : array_like, shape (K, 2) or (n+1,)
        Vertices ``(tau_k, phi(tau_k))``, or samples ``phi(t[i])`` on the grid ``t``.
    t : ndarray, shape (n+1,), optional
        Grid of the samples (uniform if omitted); ignored for vertices.

    Returns
    -------
    ndarray, shape (K, 2)
        Validated: ``tau`` strictly increasing from 0 to 1, ``phi`` non-decreasing from 0 to 1.
    """
    arr = as_float_array(phi, name)
    check_finite(arr, name)
    if arr.ndim == 1:
        grid = _uniform(arr.shape[0]) if t is None else check_parameters(t, "t", arr.shape[0])
        arr = np.column_stack([grid, arr])
    elif arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(
            f"{name}: expected warp samples of shape (n+1,) or vertices of shape (K, 2); got {arr.shape}"
        )
    check_parameters(arr[:, 0], f"{name} (vertex parameters)")
    vals = arr[:, 1]
    if vals[0] != 0.0 or vals[-1] != 1.0:
        raise ValueError(
            f"{name}: expected a warp fixing the ends (phi(0) = 0, phi(1) = 1); "
            f"got phi(0) = {vals[0]!r}, phi(1) = {vals[-1]!r}"
        )
    steps = np.diff(vals)
    if (steps < 0).any():
        i = int(np.argmax(steps < 0)) + 1
        raise ValueError(
            f"{name}: expected an increasing warp; phi decreases between vertices {i - 1} and {i}"
        )
    return arr


def reparametrize_curve(curve: DiscreteCurve, phi: object) -> DiscreteCurve:
    """``c o phi`` sampled on the curve's own grid by geodesic interpolation (paper 000, sec. 5.1).

    Parameters
    ----------
    curve : DiscreteCurve
    phi : array_like, shape (n+1,) or (K, 2)
        Warp samples on ``curve.t`` or vertices (see :func:`as_warp_vertices`).

    Returns
    -------
    DiscreteCurve
        ``values[i] = c(phi(t[i]))`` on ``curve.t``.
    """
    verts = as_warp_vertices(phi, curve.t)
    s = np.clip(np.interp(curve.t, verts[:, 0], verts[:, 1]), 0.0, 1.0)
    return DiscreteCurve(curve.evaluate(s), curve.group, curve.t)


def reparametrize_srv(srv: SRVFunction, phi: object) -> SRVFunction:
    """The exact action ``(q * phi)(t) = sqrt(phi'(t)) q(phi(t))`` for piecewise linear ``phi``.

    Parameters
    ----------
    srv : SRVFunction
    phi : array_like, shape (n+1,) or (K, 2)
        Warp samples on ``srv.t`` or vertices.

    Returns
    -------
    SRVFunction
        Piecewise constant on the merged break points: the vertices of ``phi`` and the
        preimages ``phi^{-1}(srv.t)``. It is the SRV function of ``c o phi`` for the
        piecewise geodesic curve ``c`` of ``srv`` (paper 000, Lemma 3.6), so
        ``inverse_srv_transform`` of it samples ``c o phi`` exactly (break points closer
        than :data:`MERGE_TOL` are merged: an error below ``MERGE_TOL |q|^2``). Where ``phi``
        is flat the result is 0.
    """
    verts = as_warp_vertices(phi, srv.t)
    tau, ph = verts[:, 0], verts[:, 1]
    # Preimages of srv's break points under phi: t_j in the open range of a strictly
    # increasing piece k maps back to one point of it; a t_j equal to some phi(tau_k) has
    # the vertex tau_k among its preimages already (phi is non-decreasing).
    k = np.clip(np.searchsorted(ph, srv.t, side="right") - 1, 0, tau.shape[0] - 2)
    inside = (ph[k] < srv.t) & (srv.t < ph[k + 1])
    kk = k[inside]
    pre = tau[kk] + (srv.t[inside] - ph[kk]) * (tau[kk + 1] - tau[kk]) / (ph[kk + 1] - ph[kk])
    grid = _merge_breaks(np.union1d(tau, pre))  # no cells of rounding width
    mid = 0.5 * (grid[:-1] + grid[1:])
    k = np.clip(np.searchsorted(tau, mid, side="right") - 1, 0, tau.shape[0] - 2)
    slope = (ph[k + 1] - ph[k]) / (tau[k + 1] - tau[k])
    phi_mid = ph[k] + slope * (mid - tau[k])
    cell = np.clip(np.searchsorted(srv.t, phi_mid, side="right") - 1, 0, srv.q.shape[0] - 1)
    q = np.sqrt(slope)[:, None] * srv.q[cell]
    return SRVFunction(q, grid, srv.start, srv.group)


# ---------------------------------------------------------------------------------------------
# Geodesics and blends
# ---------------------------------------------------------------------------------------------


def weighted_blend(
    curves: Sequence[DiscreteCurve],
    weights: Sequence[float] | np.ndarray,
    warps: Sequence[object | None] | None = None,
    *,
    t_out: np.ndarray | None = None,
) -> DiscreteCurve:
    """Weighted combination of ``K`` curves in SRV space: ``R^{-1}(sum_k w_k (q_k * phi_k))``.

    Parameters
    ----------
    curves : sequence of DiscreteCurve
        ``K >= 1`` curves in one group (grids may differ).
    weights : array_like, shape (K,) or (M, K + 1)
        Affine weights (they must sum to 1; negative ones extrapolate); or time-varying
        weights: knots ``(t, w_1, ..., w_K)`` of ``w_k(t)`` piecewise linear in the curves'
        common parameter (``t`` from 0 to 1, increasing; each row non-negative, summing to 1).
        Then ``q(t) = sum_k w_k(t) (q_k * phi_k)(t)`` (the weights read at the midpoint of each
        cell of the merged grid refined by the knots and 1024 uniform cells), integrated from
        the weighted mean of the start points at ``w(0)``.
    warps : sequence of (warp or None), optional
        ``phi_k`` applied to curve ``k`` before blending (samples on its grid or vertices).
    t_out : ndarray, optional
        Parameters at which to sample the result (default: the merged break points of
        all the warped SRV functions, on which the result is exact).

    Returns
    -------
    DiscreteCurve
        Its start point is the weighted mean of the start points in the group
        (:meth:`LieGroup.weighted_mean`; for two curves the geodesic point
        ``exp(s log(c1(0) c0(0)^{-1})) c0(0)``).
    """
    curves = list(curves)
    if not curves:
        raise ValueError("curves: expected at least one curve")
    for k, c in enumerate(curves):
        if not isinstance(c, DiscreteCurve):
            raise ValueError(f"curves[{k}]: expected a DiscreteCurve; got {type(c).__name__}")
        _check_same_group(curves[0].group, c.group, "curves[0]", f"curves[{k}]")
    w = as_float_array(weights, "weights")
    check_finite(w, "weights")
    knots = _check_weight_knots(w, len(curves)) if w.ndim == 2 else None
    if knots is None and w.shape != (len(curves),):
        raise ValueError(f"weights: expected one weight per curve, shape ({len(curves)},); got {w.shape}")
    if knots is None and abs(w.sum() - 1.0) > 1e-9:
        raise ValueError(f"weights: expected weights summing to 1; got sum {w.sum()!r}")
    if warps is None:
        warps = [None] * len(curves)
    if len(warps) != len(curves):
        raise ValueError(f"warps: expected {len(curves)} entries (None for no warp); got {len(warps)}")
    g = curves[0].group
    srvs = []
    for c, phi in zip(curves, warps, strict=True):
        srv = srv_transform(c)
        srvs.append(srv if phi is None else reparametrize_srv(srv, phi))
    functions = [(s.q, s.t) for s in srvs]
    if knots is not None:  # refine by the knots and a uniform grid: the weights vary in a cell
        extra = np.union1d(knots[:, 0], np.linspace(0.0, 1.0, 1025))
        functions.append((np.zeros((extra.shape[0] - 1, 1)), extra))
    grid, vals = common_refinement(functions)
    if knots is None:
        q = np.einsum("k,kij->ij", w, np.stack(vals))
    else:
        mid = 0.5 * (grid[:-1] + grid[1:])
        wt = np.column_stack([np.interp(mid, knots[:, 0], knots[:, k + 1]) for k in range(len(curves))])
        q = np.einsum("ik,kij->ij", wt, np.stack(vals[: len(curves)]))
        w = knots[0, 1:]
    starts = np.stack([c.values[0] for c in curves])
    if (w >= 0).all():
        start = g.weighted_mean(starts, w)
    else:
        # affine extrapolation: exp(sum_k w_k log(p_k p_0^{-1})) p_0
        start = g.compose(g.exp(np.einsum("k,k...->...", w, g.difference(starts[0], starts))), starts[0])
    result = inverse_srv_transform(SRVFunction(q, grid, start, g))
    if t_out is None:
        return result
    t_out = check_parameters(t_out, "t_out")
    return DiscreteCurve(result.evaluate(t_out), g, t_out)


def _check_weight_knots(knots: np.ndarray, k: int) -> np.ndarray:
    """Knots ``(M, K + 1)`` of time-varying weights (:func:`weighted_blend`), checked."""
    if knots.shape[0] < 2 or knots.shape[1] != k + 1:
        raise ValueError(
            f"weights: expected constant weights ({k},) or at least two knots (t, w_1, ..., w_{k}) of shape "
            f"(M, {k + 1}); got shape {knots.shape}"
        )
    t, w = knots[:, 0], knots[:, 1:]
    if abs(t[0]) > 1e-12 or abs(t[-1] - 1.0) > 1e-12 or not (np.diff(t) > 0).all():
        raise ValueError(f"weights: expected knot times t from 0 to 1, increasing; got {t.tolist()}")
    if (w < 0).any() or np.abs(w.sum(axis=1) - 1.0).max() > 1e-9:
        raise ValueError(f"weights: expected knot weights >= 0 summing to 1 in each row; got {w.tolist()}")
    return knots


def blend(
    c0: DiscreteCurve,
    c1: DiscreteCurve,
    s: float,
    phi: object | None = None,
    *,
    t_out: np.ndarray | None = None,
) -> DiscreteCurve:
    """Point ``s`` of the SRV geodesic from ``c0`` to ``c1 o phi`` (paper 000, eq. 20).

    ``R^{-1}((1 - s) q0 + s (q1 * phi))`` started at ``exp(s log(c1(0) c0(0)^{-1})) c0(0)``.
    ``s = 0`` returns ``c0`` and ``s = 1`` returns ``c1 o phi`` (on the merged grid, or on
    ``t_out``). ``s`` outside [0, 1] extrapolates.

    Parameters
    ----------
    c0, c1 : DiscreteCurve
        Curves in the same group.
    s : float
    phi : warp of ``c1``, optional
        Samples on ``c1.t`` or vertices ``(K, 2)``.
    t_out : ndarray, optional
        Parameters of the output samples (default: merged break points).
    """
    s = float(s)
    if not np.isfinite(s):
        raise ValueError(f"s: expected a finite blend weight; got {s!r}")
    return weighted_blend([c0, c1], [1.0 - s, s], [None, phi], t_out=t_out)
