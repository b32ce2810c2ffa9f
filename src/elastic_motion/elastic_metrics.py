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

__all__ = ["ElasticABResult", "ab_inverse", "ab_transform", "elastic_ab_distance", "elastic_ab_geodesic"]


def _check_ab(a: float, b: float) -> tuple[float, float]:
    for v, name in ((a, "a"), (b, "b")):
        if not (isinstance(v, int | float | np.floating) and math.isfinite(v) and v > 0):
            raise ValueError(
                f"{name}: expected a positive finite weight of the elastic metric G^(a,b); got {v!r}"
            )
    return float(a), float(b)


def _check_curve(c: Any, name: str, t: Any) -> tuple[np.ndarray, np.ndarray]:
    arr = as_float_array(c, name)
    check_finite(arr, name)
    if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] < 2:
        raise ValueError(f"{name}: expected plane curve samples of shape (n+1, 2), n+1 >= 2; got {arr.shape}")
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
    """Elastic ``G^{a,b}`` distance of two open plane curves.

    Attributes
    ----------
    distance : float
        ``||F(c0) - F(c1) * phi||`` at the optimal warp.
    a, b : float
    warp : WarpResult
        The optimal warp of c1 (``vertices``, ``phi``, diagnostics).
    q0, q1 : ndarray, shapes (n0, 2), (n1, 2)
        The transforms; ``t0``, ``t1`` their break points.
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
    """Elastic distance of open plane curves for the metric ``G^{a,b}`` (paper 001, eq. 4).

    ``min_phi ||F_{a,b}(c0) - sqrt(phi') F_{a,b}(c1) o phi||``, the warp found by
    :func:`elastic_motion.warp.optimal_warp` (``options``, landmarks etc. passed through
    ``warp_kw``).  At ``a = 1, b = 1/2`` this is the SRV elastic distance.
    """
    q0, ta = ab_transform(c0, a, b, t0)
    q1, tb = ab_transform(c1, a, b, t1)
    res = optimal_warp(q0, q1, t0=ta, t1=tb, options=options, **warp_kw)
    return ElasticABResult(
        res.distance, float(a), float(b), res, q0, ta, q1, tb, _first_angle(np.asarray(c0))
    )


def elastic_ab_geodesic(result: ElasticABResult, s: float, t_out: Any = None) -> np.ndarray:
    """Point ``s`` of the straight segment ``(1-s) F(c0) + s F(c1) * phi``, mapped back to a
    curve (start at the origin).

    Returns
    -------
    ndarray, shape (m+1, 2)
        On the merged break points (or sampled at ``t_out``).
    """
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
