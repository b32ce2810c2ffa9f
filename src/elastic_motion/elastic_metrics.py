"""General elastic metrics ``G^{a,b}`` on open plane curves, flattened by the ``F_{a,b}`` transform.

The elastic metric of paper 001, eq. 4,

    G^{a,b}_c(h, k) = int a^2 <D_s h, n> <D_s k, n> + b^2 <D_s h, v> <D_s k, v> ds

(``v`` the unit tangent, ``n`` the unit normal, ``D_s = d/ds`` arc length, ``a, b > 0``) is the
pull-back of the flat ``L^2`` metric by the transform of Bauer, Bruveris, Marsland & Michor,
"Constructing reparameterization invariant metrics on spaces of plane curves", Differential
Geom. Appl. 34 (2014), and Kurtek & Needham, "Simplifying transforms for general elastic
metrics on the space of plane curves", SIAM J. Imaging Sci. 11 (2018):

    F_{a,b}(c) = 2 b |c'|^{1/2} exp(i lambda theta),    lambda = a / (2 b),

with plane vectors read as complex numbers and ``theta`` the tangent angle of ``c``, lifted
continuously along the curve.  For ``a = 1, b = 1/2`` it is the SRVT ``c' / sqrt|c'|``.

Conventions
-----------
* Curves are open and planar: samples ``(n+1, 2)`` on break points ``t`` (uniform when
  omitted); piecewise linear, so ``F`` is piecewise constant, ``q[i]`` on
  ``[t[i], t[i+1])``, shape ``(n, 2)`` (real, imaginary).  It is a
  :mod:`elastic_motion.warp` SRV array: the warp solver applies unchanged, because
  ``F(c o phi) = sqrt(phi') F(c) o phi`` (the same action as the SRVT, exact for piecewise
  linear curves and warps).
* ``theta``: the angle of the first segment in ``(-pi, pi]``, then unwrapped (each step in
  ``(-pi, pi]``).  Cells where the curve stands still (repeated samples) have ``q = 0`` and
  keep the angle of the previous moving cell.
* Distance: ``d_{a,b}(c0, c1) = min_phi ||F(c0) - F(c1 o phi)||_{L^2}`` (translations factored
  out).  As for the SRVT (paper 001, Thm. 1) the straight segment between the transforms is
  the geodesic when it avoids 0; for ``lambda != 1`` the transform depends on the lift of
  ``theta`` (rotating a curve by ``2 pi`` is the identity on curves, not on ``F``), so this
  is the distance between the two *lifted* curves (BBMM 2014, sec. 4; Kurtek-Needham
  2018, sec. 3).  Rotations are not optimised.

Curves in ``R^d``, any ``d >= 2`` (:func:`elastic_ab_distance_rd`; :func:`elastic_ab_distance`
routes ``d >= 3`` there and keeps the planar path above, unchanged, for ``d = 2``)
-----------------------------------------------------------------------------------
The construction of Bauer, Charon, Klassen, Kurtek, Needham & Pierron, "Elastic metrics on
spaces of Euclidean curves: theory and algorithms", J. Nonlinear Sci. 34 (2024), arXiv
2209.09862 (the ``F_{a,b}`` transform for ``R^d``).  With ``u = c' / |c'|``,
``R = 2 b |c'|^{1/2}`` and ``lambda = a / (2 b)``, ``c -> (R, u)`` maps curves modulo
translation one to one onto maps into the *metric cone* ``C_lambda`` over the round sphere
``S^{d-1}`` of radius ``lambda``, and pulls its ``L^2`` metric back to ``G^{a,b}`` exactly
(for every ``a, b > 0``).  For ``a <= 2 b`` (``lambda <= 1``) the cone sits isometrically in
``R^{d+1}``: :func:`ab_cone_transform`,

    F_{a,b}(c) = |c'|^{1/2} (a u, sqrt(4 b^2 - a^2))      (shape (n, d+1)),

the SRVT (with a zero last column) at ``a = 2 b``.  The distance of two points of ``C_lambda``
is ``R0^2 + R1^2 - 2 R0 R1 cos(min(lambda alpha, pi))``, ``alpha`` the angle between ``u0`` and
``u1``, and geodesics of ``L^2(I, C_lambda)`` are pointwise geodesics of the cone (straight
segments of the developed cone; through the apex when ``lambda alpha >= pi``, possible only for
``a >= 2 b``, where the path leaves the immersions: the distance is then an infimum).  So:

* exact: the transform, its pull-back metric (``G^{a,b}``), the distance between *parametrised*
  curves ``||F(c0) - F(c1)||_{C}`` (the closed form above, cell by cell), the geodesic between
  ``c0`` and ``c1 o phi`` (:func:`elastic_ab_geodesic`: its ``G^{a,b}`` length is the
  reported distance), all invariant under rotations of ``R^d`` and translations;
* the warp: the transform has the SRV action ``q(c o phi) = sqrt(phi') q(c) o phi`` (exact
  for piecewise linear curves and warps), and the cone energy at a warp is
  ``||F(c0)||^2 + ||F(c1)||^2 - 2 int sqrt(phi') K(F(c0), F(c1) o phi)`` with the cone's
  cross term ``K(p0, p1) = R0 R1 cos(min(lambda alpha, pi))``: the squared norms do not depend
  on ``phi``.  On piecewise constant arrays ``K`` is a matrix over pairs of cells; factored
  ``K = x0 x1^T`` (thin SVD), :func:`elastic_motion.warp.optimal_warp` on ``x0, x1`` (an SRV
  problem whose energy differs from the cone's by a constant) minimises the *exact* cone
  energy, with the solver's guarantees and limits (DP on its grid, local refinement,
  landmarks and options passed through).  ``result.distance`` is the cone distance at the
  warp found; ``result.warp.distance`` is the solver's objective (offset by that constant).
  Cost: the SVD, ``O(n0 n1 min(n0, n1))``, on top of the SRV solve.
* In ``d = 2`` the cone uses the unlifted angle: at a given warp it agrees with the planar
  ``F_{a,b}`` distance wherever the lifted tangent angles of the matched cells differ by less
  than ``min(pi, pi / lambda)`` (the planar distance is that of the *lifted* curves).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from elastic_motion._validation import as_float_array, check_finite, check_parameters
from elastic_motion.curves import SRVFunction, common_refinement, reparametrize_srv
from elastic_motion.groups import Euclidean
from elastic_motion.warp import WarpOptions, WarpResult, WarpSolverOptions, optimal_warp

__all__ = [
    "ElasticABResult",
    "ab_cone_inverse",
    "ab_cone_transform",
    "ab_inverse",
    "ab_transform",
    "cone_distance2",
    "cone_warp_distance",
    "elastic_ab_distance",
    "elastic_ab_distance_rd",
    "elastic_ab_geodesic",
]


def _check_ab(a: float, b: float) -> tuple[float, float]:
    for v, name in ((a, "a"), (b, "b")):
        if not (isinstance(v, int | float | np.floating) and math.isfinite(v) and v > 0):
            raise ValueError(
                f"{name}: expected a positive finite weight of the elastic metric G^(a,b); got {v!r}"
            )
    return float(a), float(b)


def _check_curve(c: Any, name: str, t: Any, planar: bool = True) -> tuple[np.ndarray, np.ndarray]:
    arr = as_float_array(c, name)
    check_finite(arr, name)
    if planar and (arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] < 2):
        raise ValueError(
            f"{name}: expected plane curve samples of shape (n+1, 2), n+1 >= 2 (curves in R^d, d >= 3: "
            f"ab_cone_transform / elastic_ab_distance); got {arr.shape}"
        )
    if not planar and (arr.ndim != 2 or arr.shape[1] < 2 or arr.shape[0] < 2):
        raise ValueError(
            f"{name}: expected curve samples of shape (n+1, d), d >= 2, n+1 >= 2; got {arr.shape}"
        )
    if t is None:
        ta = np.linspace(0.0, 1.0, arr.shape[0])
    else:
        ta = check_parameters(t, f"{name}: t", arr.shape[0])
    if not np.any(np.diff(arr, axis=0)):
        raise ValueError(f"{name}: all samples are equal (a curve of length 0 has no shape)")
    return arr, ta


def ab_transform(c: Any, a: float = 1.0, b: float = 0.5, t: Any = None) -> tuple[np.ndarray, np.ndarray]:
    """``F_{a,b}`` of a piecewise linear plane curve (module docstring).

    Parameters
    ----------
    c : array_like, shape (n+1, 2)
        Samples ``c(t[i])``.
    a, b : float
        Positive weights of the normal and tangential parts of ``G^{a,b}``.
    t : array_like, shape (n+1,), optional
        Parameters (uniform when omitted).

    Returns
    -------
    q : ndarray, shape (n, 2)
        ``2 b |v_i|^{1/2} (cos(lambda theta_i), sin(lambda theta_i))`` with ``v_i`` the
        velocity of cell i; 0 on cells where the curve stands still.
    t : ndarray, shape (n+1,)

    Raises
    ------
    ValueError
        ``a`` or ``b`` not positive, bad shapes, NaN, a curve of length 0.
    """
    a, b = _check_ab(a, b)
    arr, ta = _check_curve(c, "c", t)
    v = np.diff(arr, axis=0) / np.diff(ta)[:, None]
    speed = np.hypot(v[:, 0], v[:, 1])
    moving = speed > 0
    ang = np.arctan2(v[:, 1], v[:, 0])
    idx = np.where(moving, np.arange(len(ang)), -1)
    idx = np.maximum.accumulate(idx)
    idx[idx < 0] = int(np.argmax(moving))  # leading still cells take the first moving angle
    theta = np.unwrap(ang[idx])
    lam = a / (2.0 * b)
    mag = 2.0 * b * np.sqrt(speed)
    q = np.column_stack([mag * np.cos(lam * theta), mag * np.sin(lam * theta)])
    return q, ta


def ab_inverse(
    q: Any,
    a: float = 1.0,
    b: float = 0.5,
    t: Any = None,
    start: Any = (0.0, 0.0),
    theta0: float | None = None,
) -> np.ndarray:
    """Inverse of :func:`ab_transform`: the piecewise linear curve with ``F_{a,b}(c) = q``.

    ``|v| = (|q| / 2b)^2``, ``theta = arg(q) / lambda`` with ``arg`` unwrapped along the
    curve (the lift of ``F`` is taken continuous), ``c[i+1] = c[i] + h_i v_i``.

    The lift is found by unwrapping ``arg(q)``: it is the curve's when its tangent turns by
    less than ``pi / lambda`` between consecutive cells (refine the sampling otherwise).
    ``q`` gives the first tangent angle only up to multiples of ``2 pi / lambda``:
    ``theta0`` (the tangent angle of the curve's first moving cell, or a guess of it)
    picks the lift nearest to it; by default the lift of smallest ``|theta|`` (right for
    ``a = 2b``, the SRVT, and for curves starting within ``pi / lambda`` of the x axis).

    Returns
    -------
    ndarray, shape (n+1, 2)
    """
    a, b = _check_ab(a, b)
    qa = as_float_array(q, "q")
    check_finite(qa, "q")
    if qa.ndim != 2 or qa.shape[1] != 2:
        raise ValueError(f"q: expected an F_(a,b) array of shape (n, 2); got {qa.shape}")
    n = qa.shape[0]
    ta = np.linspace(0.0, 1.0, n + 1) if t is None else check_parameters(t, "t", n + 1)
    mag = np.hypot(qa[:, 0], qa[:, 1])
    moving = mag > 0
    ang = np.arctan2(qa[:, 1], qa[:, 0])
    idx = np.maximum.accumulate(np.where(moving, np.arange(n), -1))
    idx[idx < 0] = int(np.argmax(moving)) if moving.any() else 0
    lam = a / (2.0 * b)
    lifted = np.unwrap(ang[idx])
    first = lifted[0] / lam
    period = 2.0 * np.pi / lam
    guess = 0.0 if theta0 is None else float(theta0)
    theta = lifted / lam + period * np.round((guess - first) / period)
    speed = (mag / (2.0 * b)) ** 2
    v = speed[:, None] * np.column_stack([np.cos(theta), np.sin(theta)])
    steps = v * np.diff(ta)[:, None]
    return np.vstack([np.zeros((1, 2)), np.cumsum(steps, axis=0)]) + np.asarray(start, dtype=np.float64)


@dataclass(frozen=True)
class ElasticABResult:
    """Elastic ``G^{a,b}`` distance of two open curves.

    Attributes
    ----------
    distance : float
        ``||F(c0) - F(c1) * phi||`` at the optimal warp (for ``dim >= 3`` or the cone
        construction: the exact cone distance at the warp, module docstring).
    a, b : float
    warp : WarpResult
        The optimal warp of c1 (``vertices``, ``phi``, diagnostics; for the cone construction
        ``warp.distance`` is the solver's objective, the cone energy offset by a constant).
    q0, q1 : ndarray, shapes (n0, D), (n1, D)
        The transforms: planar ``F_{a,b}`` (``D = 2``), or the cone's
        ``R (lambda u, sqrt(1 - lambda^2))`` (``D = d + 1``, ``lambda <= 1``) / ``R u``
        (``D = d``, ``lambda > 1``); ``t0``, ``t1`` their break points.
    theta0 : float
        Planar only: the tangent angle of c0's first moving cell.
    dim : int
        ``d``, the dimension of the curves.
    construction : str
        ``"planar"`` (the lifted plane ``F_{a,b}``) or ``"cone"`` (the ``R^d`` construction).
    """

    distance: float
    a: float
    b: float
    warp: WarpResult
    q0: np.ndarray
    t0: np.ndarray
    q1: np.ndarray
    t1: np.ndarray
    theta0: float = 0.0
    dim: int = 2
    construction: str = "planar"


def _first_angle(c: np.ndarray) -> float:
    d = np.diff(c, axis=0)
    k = int(np.argmax(np.any(d != 0, axis=1)))
    return float(np.arctan2(d[k, 1], d[k, 0]))


def elastic_ab_distance(
    c0: Any,
    c1: Any,
    a: float = 1.0,
    b: float = 0.5,
    *,
    t0: Any = None,
    t1: Any = None,
    options: WarpSolverOptions | WarpOptions | None = None,
    **warp_kw: Any,
) -> ElasticABResult:
    """Elastic distance of open curves for the metric ``G^{a,b}`` (paper 001, eq. 4).

    Plane curves ``(n+1, 2)``: ``min_phi ||F_{a,b}(c0) - sqrt(phi') F_{a,b}(c1) o phi||``, the
    warp found by :func:`elastic_motion.warp.optimal_warp` (``options``, landmarks etc. passed
    through ``warp_kw``).  Curves in ``R^d``, ``d >= 3``: :func:`elastic_ab_distance_rd` (the
    cone construction, module docstring).  At ``a = 1, b = 1/2`` this is the SRV elastic
    distance.
    """
    if np.ndim(c0) == 2 and np.shape(c0)[1] != 2:
        return elastic_ab_distance_rd(c0, c1, a, b, t0=t0, t1=t1, options=options, **warp_kw)
    q0, ta = ab_transform(c0, a, b, t0)
    q1, tb = ab_transform(c1, a, b, t1)
    res = optimal_warp(q0, q1, t0=ta, t1=tb, options=options, **warp_kw)
    return ElasticABResult(
        res.distance, float(a), float(b), res, q0, ta, q1, tb, _first_angle(np.asarray(c0))
    )


def elastic_ab_geodesic(result: ElasticABResult, s: float, t_out: Any = None) -> np.ndarray:
    """Point ``s`` of the straight segment ``(1-s) F(c0) + s F(c1) * phi``, mapped back to a
    curve (start at the origin).

    For the cone construction (``result.construction == "cone"``, curves in ``R^d``): the
    pointwise geodesic of the cone between ``F(c0)`` and ``F(c1) * phi``, mapped back
    (module docstring); its ``G^{a,b}`` length
    is ``result.distance``.

    Returns
    -------
    ndarray, shape (m+1, d)
        On the merged break points (or sampled at ``t_out``).
    """
    if result.construction == "cone":
        return _cone_geodesic(result, s, t_out)
    moved = reparametrize_srv(
        SRVFunction(result.q1, result.t1, np.zeros(2), Euclidean(2)), result.warp.vertices
    )
    grid, (qa, qb) = common_refinement([(result.q0, result.t0), (moved.q, moved.t)])
    qs = (1.0 - s) * qa + s * qb
    # the lift of the first angle moves continuously along the segment (which avoids 0)
    moving = np.flatnonzero(np.hypot(qa[:, 0], qa[:, 1]) > 0)
    k = int(moving[0]) if moving.size else 0
    z0, zs = complex(*qa[k]), complex(*qs[k])
    lam = result.a / (2.0 * result.b)
    theta0 = result.theta0 + (np.angle(zs / z0) if zs != 0 and z0 != 0 else 0.0) / lam
    c = ab_inverse(qs, result.a, result.b, grid, theta0=theta0)
    if t_out is None:
        return c
    tt = np.asarray(t_out, dtype=np.float64)
    return np.column_stack([np.interp(tt, grid, c[:, 0]), np.interp(tt, grid, c[:, 1])])


# ---------------------------------------------------------------- curves in R^d: the cone


def _velocities(arr: np.ndarray, ta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Speeds ``|c'|`` ``(n,)`` and unit tangents ``u`` ``(n, d)`` (0 on still cells)."""
    v = np.diff(arr, axis=0) / np.diff(ta)[:, None]
    speed = np.linalg.norm(v, axis=1)
    u = np.divide(v, speed[:, None], out=np.zeros_like(v), where=speed[:, None] > 0)
    return speed, u


def ab_cone_transform(c: Any, a: float = 1.0, b: float = 0.5, t: Any = None) -> tuple[np.ndarray, np.ndarray]:
    """``F_{a,b}(c) = |c'|^{1/2} (a u, sqrt(4 b^2 - a^2))`` of a piecewise linear curve in ``R^d``.

    The transform of Bauer, Charon, Klassen, Kurtek, Needham & Pierron (2024) for ``a <= 2 b``
    (module docstring): its values lie on a cone of ``R^{d+1}`` whose ``L^2`` metric pulls back
    to ``G^{a,b}``; ``F(c o phi) = sqrt(phi') F(c) o phi``.

    Parameters
    ----------
    c : array_like, shape (n+1, d), d >= 2
    a, b : float
        Positive weights, ``a <= 2 b``.
    t : array_like, shape (n+1,), optional
        Parameters (uniform when omitted).

    Returns
    -------
    q : ndarray, shape (n, d+1)
        0 on cells where the curve stands still.
    t : ndarray, shape (n+1,)

    Raises
    ------
    ValueError
        ``a``, ``b`` not positive, ``a > 2 b`` (no cone of ``R^{d+1}``: use
        :func:`elastic_ab_distance_rd`, which handles every ``a, b`` with the abstract cone),
        bad shapes, NaN, a curve of length 0.
    """
    a, b = _check_ab(a, b)
    if a > 2.0 * b:
        raise ValueError(
            f"a, b: the cone transform into R^(d+1) needs a <= 2b (got a = {a!r}, b = {b!r}); "
            "elastic_ab_distance_rd handles a > 2b through the abstract metric cone"
        )
    arr, ta = _check_curve(c, "c", t, planar=False)
    speed, u = _velocities(arr, ta)
    beta = math.sqrt(max(4.0 * b * b - a * a, 0.0))
    q = np.sqrt(speed)[:, None] * np.column_stack([a * u, np.full(len(speed), beta)])
    return q, ta


def ab_cone_inverse(q: Any, a: float = 1.0, b: float = 0.5, t: Any = None, start: Any = None) -> np.ndarray:
    """Inverse of :func:`ab_cone_transform`: the piecewise linear curve, shape ``(n+1, d)``.

    ``|c'| = (|q| / 2b)^2`` and ``u = q[:, :d] / |q[:, :d]|`` (no lift: the cone transform
    keeps the direction itself); ``start`` ``(d,)`` is ``c(0)`` (origin by default).
    """
    a, b = _check_ab(a, b)
    qa = as_float_array(q, "q")
    check_finite(qa, "q")
    if qa.ndim != 2 or qa.shape[1] < 3:
        raise ValueError(f"q: expected a cone F_(a,b) array of shape (n, d+1), d >= 2; got {qa.shape}")
    n, d = qa.shape[0], qa.shape[1] - 1
    ta = np.linspace(0.0, 1.0, n + 1) if t is None else check_parameters(t, "t", n + 1)
    radius, u = _unembed(qa, d)
    steps = ((radius / (2.0 * b)) ** 2 * np.diff(ta))[:, None] * u
    origin = np.zeros(d) if start is None else np.asarray(start, dtype=np.float64)
    return np.vstack([np.zeros((1, d)), np.cumsum(steps, axis=0)]) + origin


def _embed(speed: np.ndarray, u: np.ndarray, lam: float, b: float) -> np.ndarray:
    """The cone point ``(R, u)`` as an array: ``R (lambda u, sqrt(1 - lambda^2))`` (``lambda <= 1``,
    ``= F_{a,b}``) or ``R u`` (``lambda > 1``), ``R = 2 b |c'|^{1/2}``."""
    radius = 2.0 * b * np.sqrt(speed)
    if lam <= 1.0:
        return radius[:, None] * np.column_stack([lam * u, np.full(len(u), math.sqrt(1.0 - lam * lam))])
    return radius[:, None] * u


def _unembed(q: np.ndarray, d: int) -> tuple[np.ndarray, np.ndarray]:
    """``(R, u)`` of :func:`_embed`'s array: ``R = |q|``, ``u`` the direction of ``q[:, :d]``."""
    radius = np.linalg.norm(q, axis=1)
    head = q[:, :d]
    nh = np.linalg.norm(head, axis=1)
    u = np.divide(head, nh[:, None], out=np.zeros_like(head), where=nh[:, None] > 0)
    return radius, u


def _angles(u0: np.ndarray, u1: np.ndarray) -> np.ndarray:
    """Angles in ``[0, pi]`` between unit rows (accurate near 0 and pi)."""
    return 2.0 * np.arctan2(np.linalg.norm(u0 - u1, axis=1), np.linalg.norm(u0 + u1, axis=1))


def _cone_cross(r0: np.ndarray, r1: np.ndarray, alpha: np.ndarray, lam: float) -> np.ndarray:
    """The cone's cross term ``r0 r1 cos(min(lam alpha, pi))`` (broadcast): the one home of the
    cone's geometry, used by the distance and by the warp's factors."""
    return r0 * r1 * np.cos(np.minimum(lam * alpha, np.pi))


def cone_distance2(r0: Any, u0: Any, r1: Any, u1: Any, lam: float) -> np.ndarray:
    """Squared distance of points ``(r, u)`` of the metric cone over ``S^{d-1}`` of radius ``lam``.

    ``r0^2 + r1^2 - 2 r0 r1 cos(min(lam alpha, pi))``, ``alpha`` the angle of ``u0``, ``u1``
    (rows of shape ``(n, d)``; a point with ``r = 0`` is the apex, its ``u`` unused).

    Returns
    -------
    ndarray, shape (n,)
    """
    r0a, r1a = np.asarray(r0, dtype=np.float64), np.asarray(r1, dtype=np.float64)
    alpha = _angles(np.asarray(u0, dtype=np.float64), np.asarray(u1, dtype=np.float64))
    return np.maximum(r0a**2 + r1a**2 - 2.0 * _cone_cross(r0a, r1a, alpha, lam), 0.0)


def _moved_pair_arrays(
    q0: np.ndarray, t0: np.ndarray, q1: np.ndarray, t1: np.ndarray, vertices: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``F(c0)`` and ``F(c1) * phi`` (embedded arrays) on their merged break points."""
    dd = q1.shape[1]
    moved = reparametrize_srv(SRVFunction(q1, t1, np.zeros(dd), Euclidean(dd)), vertices)
    grid, (qa, qb) = common_refinement([(q0, t0), (moved.q, moved.t)])
    return grid, qa, qb


def _moved_pair(result: ElasticABResult) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return _moved_pair_arrays(result.q0, result.t0, result.q1, result.t1, result.warp.vertices)


def elastic_ab_distance_rd(
    c0: Any,
    c1: Any,
    a: float = 1.0,
    b: float = 0.5,
    *,
    t0: Any = None,
    t1: Any = None,
    options: WarpSolverOptions | WarpOptions | None = None,
    **warp_kw: Any,
) -> ElasticABResult:
    """Elastic ``G^{a,b}`` distance of open curves in ``R^d``, any ``d >= 2``, any ``a, b > 0``.

    The cone construction of Bauer et al. (2024) (module docstring): the warp of c1 by
    :func:`elastic_motion.warp.optimal_warp` on the factors of the cone's cross term
    (``options``, landmarks etc. through ``warp_kw``), then the exact cone distance at that
    warp.  Translations factored out, rotations not optimised.

    Parameters
    ----------
    c0, c1 : array_like, shapes (n0+1, d), (n1+1, d)
    a, b : float
    t0, t1 : array_like, optional
        Parameters of the samples (uniform when omitted).

    Returns
    -------
    ElasticABResult
        ``construction = "cone"``, ``dim = d``.

    Raises
    ------
    ValueError
        Bad weights, shapes (or c0, c1 of different ``d``), NaN, curves of length 0.
    """
    a, b = _check_ab(a, b)
    arr0, ta = _check_curve(c0, "c0", t0, planar=False)
    arr1, tb = _check_curve(c1, "c1", t1, planar=False)
    if arr0.shape[1] != arr1.shape[1]:
        raise ValueError(
            f"c0, c1: expected curves in the same R^d; got d = {arr0.shape[1]} and {arr1.shape[1]}"
        )
    lam = a / (2.0 * b)
    q0 = _embed(*_velocities(arr0, ta), lam, b)
    q1 = _embed(*_velocities(arr1, tb), lam, b)
    x0, x1 = _cone_gram_factors(q0, q1, arr0.shape[1], lam)
    res = optimal_warp(x0, x1, t0=ta, t1=tb, options=options, **warp_kw)
    dist = _cone_distance_at(q0, ta, q1, tb, res.vertices, (arr0.shape[1], lam))
    return ElasticABResult(dist, a, b, res, q0, ta, q1, tb, 0.0, arr0.shape[1], "cone")


def _cone_gram_factors(q0: np.ndarray, q1: np.ndarray, d: int, lam: float) -> tuple[np.ndarray, np.ndarray]:
    """Arrays ``x0`` ``(n0, r)``, ``x1`` ``(n1, r)`` with ``x0 x1^T = K``, the cone's cross term
    ``K_ij = R0_i R1_j cos(min(lambda alpha_ij, pi))`` (a thin SVD, ``r`` its numerical rank).

    ``int d_C(F(c0), sqrt(phi') F(c1) o phi)^2 = ||q0||^2 + ||q1||^2 - 2 int sqrt(phi') K``
    cell by cell, and ``||x0 - sqrt(phi') x1 o phi||^2`` differs from it by a constant (both
    squared norms are invariant under the warp action): the SRV warp solver on ``x0, x1``
    minimises the exact cone energy.
    """
    r0, u0 = _unembed(q0, d)
    r1, u1 = _unembed(q1, d)
    # the angles from the dot products: a matrix product, n0 x n1 (the rows' difference form of
    # _angles would take n0 x n1 x d memory)
    gram = _cone_cross(r0[:, None], r1[None, :], np.arccos(np.clip(u0 @ u1.T, -1.0, 1.0)), lam)
    left, sing, right = np.linalg.svd(gram, full_matrices=False)
    keep = sing > sing[0] * 1e-13 if sing.size and sing[0] > 0 else np.zeros(sing.shape, dtype=bool)
    keep[0] = True  # a zero cross term (curves at right angles...) still needs one column
    root = np.sqrt(sing[keep])
    return np.ascontiguousarray(left[:, keep] * root), np.ascontiguousarray(right[keep].T * root)


def _cone_distance_at(
    q0: np.ndarray,
    t0: np.ndarray,
    q1: np.ndarray,
    t1: np.ndarray,
    vertices: np.ndarray,
    dl: tuple[int, float],
) -> float:
    d, lam = dl
    grid, qa, qb = _moved_pair_arrays(q0, t0, q1, t1, vertices)
    ra, ua = _unembed(qa, d)
    rb, ub = _unembed(qb, d)
    return math.sqrt(float(np.sum(cone_distance2(ra, ua, rb, ub, lam) * np.diff(grid))))


def cone_warp_distance(
    c0: Any, c1: Any, a: float, b: float, vertices: Any, *, t0: Any = None, t1: Any = None
) -> float:
    """Exact ``G^{a,b}`` distance of the *parametrised* curves ``c0`` and ``c1 o phi`` in ``R^d``.

    ``(int d_C(F(c0), sqrt(phi') F(c1) o phi)^2 dt)^{1/2}`` with the cone distance of
    :func:`cone_distance2` (module docstring), for the piecewise linear warp ``phi`` with
    ``vertices`` ``(K, 2)`` (``(t, phi(t))`` from ``(0, 0)`` to ``(1, 1)``, increasing).
    """
    a, b = _check_ab(a, b)
    arr0, ta = _check_curve(c0, "c0", t0, planar=False)
    arr1, tb = _check_curve(c1, "c1", t1, planar=False)
    lam = a / (2.0 * b)
    q0 = _embed(*_velocities(arr0, ta), lam, b)
    q1 = _embed(*_velocities(arr1, tb), lam, b)
    return _cone_distance_at(q0, ta, q1, tb, np.asarray(vertices, dtype=np.float64), (arr0.shape[1], lam))


def _toward(u0: np.ndarray, u1: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Unit rows ``w`` orthogonal to ``u0`` with ``u1 = cos(alpha) u0 + sin(alpha) w`` (any
    orthogonal unit row where ``u1 = +-u0``)."""
    w = u1 - np.cos(alpha)[:, None] * u0
    nw = np.linalg.norm(w, axis=1)
    bad = nw < 1e-12
    if np.any(bad):
        e = np.zeros_like(u0[bad])
        e[np.arange(len(e)), np.argmin(np.abs(u0[bad]), axis=1)] = 1.0
        e -= np.sum(e * u0[bad], axis=1)[:, None] * u0[bad]
        w[bad] = e
        nw[bad] = np.linalg.norm(e, axis=1)
    return w / np.where(nw > 0, nw, 1.0)[:, None]


def _cone_geodesic(result: ElasticABResult, s: float, t_out: Any) -> np.ndarray:
    """Point ``s`` of the cone geodesic from ``F(c0)`` to ``F(c1) * phi``, as a curve."""
    grid, qa, qb = _moved_pair(result)
    d, b = result.dim, result.b
    lam = result.a / (2.0 * b)
    r0, u0 = _unembed(qa, d)
    r1, u1 = _unembed(qb, d)
    u0 = np.where(r0[:, None] > 0, u0, u1)  # the apex takes the other end's direction
    u1 = np.where(r1[:, None] > 0, u1, u0)
    alpha = _angles(u0, u1)
    psi = np.minimum(lam * alpha, np.pi)
    # the straight segment of the developed cone, from angle 0 (u0) to angle psi (u1)
    x = (1.0 - s) * r0 + s * r1 * np.cos(psi)
    y = s * r1 * np.sin(psi)
    radius = np.hypot(x, y)
    frac = np.divide(np.arctan2(y, x), psi, out=np.zeros_like(psi), where=psi > 0)
    sigma = alpha * np.clip(frac, 0.0, 1.0)  # the angle on S^{d-1}, along the great circle
    u = np.cos(sigma)[:, None] * u0 + np.sin(sigma)[:, None] * _toward(u0, u1, alpha)
    steps = ((radius / (2.0 * b)) ** 2 * np.diff(grid))[:, None] * u
    c = np.vstack([np.zeros((1, d)), np.cumsum(steps, axis=0)])
    if t_out is None:
        return c
    tt = np.asarray(t_out, dtype=np.float64)
    return np.column_stack([np.interp(tt, grid, c[:, k]) for k in range(d)])
