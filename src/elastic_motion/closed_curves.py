"""Closed curves in ``R^d``: geodesics, distances and matching as paper 001 does them.

Conventions
-----------
* A closed curve is given by its SRV array ``q`` of shape ``(n, D)``, piecewise constant on
  the break points ``t`` of shape ``(n+1,)`` (``q[i]`` on ``[t[i], t[i+1])``, uniform when
  omitted), in orthonormal coordinates (:mod:`elastic_motion.curves`).  With
  ``h_i = t[i+1] - t[i]`` the curve closes when its *closure residual*
  ``F(q) = sum_i h_i |q_i| q_i = c(1) - c(0)`` is 0.
* The closed curves form the codimension-``D`` submanifold ``M = {q : F(q) = 0}`` of the flat
  space ``L^2`` (paper 001, Thm. 2), with the normal basis
  ``U_k(q) = (q_k q + |q|^2 e_k) / |q|`` (eq. 11).  It is the discrete ``M``: each element
  is exactly the SRV function of a closed polygon.  Translations are factored out by the
  SRVT; scale and rotations are *not* (as in paper 001).
* The **closed-curve distance** ``d_M(q0, q1)`` is the geodesic distance in ``M`` with the
  metric induced by ``L^2`` (the elastic metric ``G^{1, 1/2}``, eq. 4, on closed curves).
  It is at least the ``L^2`` (open-curve) distance ``||q0 - q1||``.
* The **matching energy** of closed curves (paper 001, eq. 22) is
  ``E_cl(tau, phi) = d_M(q0, q1_tau * phi)^2 + lam * sum_m FM(phi(theta0_m), theta1_m)``
  with ``q1_tau(s) = q1((s + tau) mod 1)`` the seed (start point) moved to ``tau``
  (:func:`elastic_motion.warp.shift_seed`) and ``phi`` a warp fixing 0 and 1.

Method
------
* :func:`project_closed` -- Newton's method with the basis ``U_k`` (Gram matrix
  ``<U_k, U_l> = sum_i h_i (|q_i|^2 delta_kl + 3 q_ik q_il)``), batched over leading axes.
* :func:`closed_geodesic` -- *discrete path straightening*: the path ``alpha_0 = q0, ...,
  alpha_K = q1`` with every ``alpha_k`` on ``M`` minimising the discrete path energy
  ``K sum_k ||alpha_{k+1} - alpha_k||^2``.  Its stationarity condition is that the discrete
  acceleration ``alpha_{k+1} - 2 alpha_k + alpha_{k-1}`` is normal to ``M`` at ``alpha_k``:
  the discrete geodesic equation (the same first-order condition as the path-straightening
  gradient of Srivastava, Klassen, Joshi & Jermyn 2011, "Shape analysis of elastic curves
  in Euclidean spaces", sec. 4, with the path discretised in time).  Solved by a
  projected Gauss-Newton method: the tangential gradient, a conjugate-gradient solve of
  the discrete Laplacian restricted to the tangent spaces, and Newton projection back
  onto ``M`` (the geodesic is closed at every time, to ``tol``).  Started coarse to fine
  (``K = 2, 4, ...``, new points the projected midpoints).  The distance is the length of
  the polygon ``sum_k ||alpha_{k+1} - alpha_k||``, which converges to ``d_M`` from below as
  ``O(K^-2)`` (chords of a curve; the tests check the convergence and an independent
  constrained optimiser).
* :func:`match_closed` -- eq. 22 in two steps, as paper 001 does: (1) seed and warp by
  the DP with the open-curve energy (the ``L^2`` distance to the ambient space), with
  the seed searched on the break points of *both* curves: the solve of q1 against q0
  (seeds on q1's breaks) and of q0 against q1 (seeds on q0's breaks, turned into a seed and
  warp of q1 exactly by :func:`swap_closed_match`), the better of the two by the same
  objective, so that ``d(a, b) = d(b, a)`` up to the grid; (2) ``E_cl`` itself is
  lowered by a descent on ``phi`` that uses the exact first variation of ``d_M^2``
  (Remarks 13-14): with ``alpha`` the closed geodesic from q0 to ``q1_tau * phi``,
  ``delta (d_M^2) = 2 <alpha'(1), delta (q1_tau * phi)>``, so ``d_M^2`` has the same
  gradient in ``phi`` as the open energy ``||q0_eff - q1_tau * phi||^2`` with the
  *effective target* ``q0_eff = q1_tau * phi - alpha'(1)`` (the open-curve gradient of
  Lemmas 12-14 projected onto ``M``, Remark 14).  Each step solves the open problem for
  ``q0_eff`` (DP then refinement) and keeps the new warp only if ``E_cl`` (a new closed
  geodesic) is lower. Without landmarks ``E_cl`` is symmetric but the descent is a local
  search whose path turns on rounding, so both steps also run with the curves the other way
  round and the lower match is kept (swapped back; a tie goes to a fixed order of the two
  curves): ``d(a, b) = d(b, a)`` to rounding. With landmarks and the symmetric term, the
  descent alone also runs from the swapped side.
* :func:`closed_geodesic_curves` -- the curves of the geodesic for drawing: each
  ``alpha_k`` integrated (closed, no display fix).

What it does not do: rotations and scale are not optimised (paper 001 neither); curves in
Lie groups other than ``R^d`` (the closed submanifold is then not ``F(q) = 0``: use
:mod:`elastic_motion.closing`); the seed is kept from step (1) during step (2).
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar

from elastic_motion._options import with_overrides
from elastic_motion._validation import as_float_array, check_finite
from elastic_motion.curves import (
    DiscreteCurve,
    SRVFunction,
    common_refinement,
    inverse_srv_transform,
    reparametrize_srv,
    srv_transform,
)
from elastic_motion.errors import OptionError
from elastic_motion.groups import Euclidean
from elastic_motion.warp import (
    Landmarks,
    WarpResult,
    landmark_cost,
    optimal_warp,
    shift_seed,
    swap_closed_match,
    warp_energy,
)
from elastic_motion.warp.energy import check_srv
from elastic_motion.warp.landmarks import Penalty, as_landmarks
from elastic_motion.warp.options import WarpOptions, WarpSolverOptions

__all__ = [
    "CLOSED_TOL",
    "ClosedGeodesic",
    "ClosedMatch",
    "ClosedMatchOptions",
    "closed_curve_srv",
    "closed_distance",
    "closed_geodesic",
    "closed_geodesic_curves",
    "closure_residual",
    "match_closed",
    "project_closed",
    "swap_closed_match",
]

#: An SRV array or a grid (checked by the caller).
Array = np.ndarray

#: Inputs count as closed when ``|F(q)| <= CLOSED_TOL * length`` (``length = ||q||^2``).
CLOSED_TOL = 1e-8


# ----------------------------------------------------------------------------- the manifold


def closure_residual(q: np.ndarray, h: np.ndarray) -> np.ndarray:
    """``F(q) = sum_i h_i |q_i| q_i = c(1) - c(0)``.

    Parameters
    ----------
    q : ndarray, shape (..., n, D)
    h : ndarray, shape (n,)
        Cell widths.

    Returns
    -------
    ndarray, shape (..., D)
    """
    qn = np.sqrt(np.einsum("...ij,...ij->...i", q, q))
    return np.einsum("i,...i,...ij->...j", h, qn, q)


def _normal_gram(q: np.ndarray, h: np.ndarray) -> np.ndarray:
    """``<U_k, U_l>_{L^2} = sum_i h_i (|q_i|^2 delta_kl + 3 q_ik q_il)``, shape (..., D, D)."""
    D = q.shape[-1]
    gram = 3.0 * np.einsum("i,...ik,...il->...kl", h, q, q)
    length = np.einsum("i,...ij,...ij->...", h, q, q)
    return gram + length[..., None, None] * np.eye(D)


def _normal_field(q: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``sum_k b_k U_k(q) = ((q . b) q + |q|^2 b) / |q|`` (0 on cells where q = 0).

    q of shape (..., n, D), b of shape (..., D); returns shape (..., n, D).
    """
    qn = np.sqrt(np.einsum("...ij,...ij->...i", q, q))
    safe = np.where(qn > 0, qn, 1.0)
    qb = np.einsum("...ij,...j->...i", q, b)
    out = (qb[..., None] * q + (qn**2)[..., None] * b[..., None, :]) / safe[..., None]
    return out


def _normal_coeffs(q: np.ndarray, v: np.ndarray, h: np.ndarray) -> np.ndarray:
    """``<U_k(q), v>_{L^2} = sum_i h_i (q_ik (q_i . v_i) + |q_i|^2 v_ik) / |q_i|``, shape (..., D)."""
    qn = np.sqrt(np.einsum("...ij,...ij->...i", q, q))
    safe = np.where(qn > 0, qn, 1.0)
    qv = np.einsum("...ij,...ij->...i", q, v)
    w = h / safe
    return np.einsum("...i,...ij->...j", w * qv, q) + np.einsum("...i,...ij->...j", w * qn**2, v)


def tangent_part(q: np.ndarray, v: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Orthogonal projection of ``v`` onto the tangent space ``T_q M`` (batched)."""
    c = np.linalg.solve(_normal_gram(q, h), _normal_coeffs(q, v, h)[..., None])[..., 0]
    return v - _normal_field(q, c)


def project_closed(
    q: Any, h: Any, *, tol: float = 1e-13, max_iter: int = 50
) -> tuple[np.ndarray, np.ndarray]:
    """Project SRV arrays onto closed curves by Newton's method (paper 001, Thm. 2).

    Solves ``F(q + sum_k beta_k U_k(q)) = 0`` linearised, with backtracking, until
    ``|F| <= tol * ||q||^2``.  Batched over leading axes.

    Parameters
    ----------
    q : array_like, shape (..., n, D)
    h : array_like, shape (n,)
        Cell widths (positive, summing to 1).
    tol : float
        Relative tolerance on the closure residual.
    max_iter : int

    Returns
    -------
    q_closed : ndarray, shape (..., n, D)
    residual : ndarray, shape (...)
        ``|F(q_closed)| / ||q_closed||^2`` (relative gap).
    """
    q = np.array(q, dtype=np.float64)
    h = np.asarray(h, dtype=np.float64)
    length = np.maximum(np.einsum("i,...ij,...ij->...", h, q, q), 1e-300)
    f = closure_residual(q, h)
    res = np.linalg.norm(f, axis=-1) / length
    for _ in range(max_iter):
        todo = res > tol
        if not todo.any():
            break
        beta = np.linalg.solve(_normal_gram(q, h), -f[..., None])[..., 0]
        step = _normal_field(q, beta)
        alpha = np.ones(res.shape)
        for _ in range(30):  # backtracking, element by element
            cand = q + alpha[..., None, None] * step
            f_new = closure_residual(cand, h)
            res_new = np.linalg.norm(f_new, axis=-1) / np.maximum(
                np.einsum("i,...ij,...ij->...", h, cand, cand), 1e-300
            )
            bad = todo & (res_new >= res) & (res_new > tol)
            if not bad.any():
                break
            alpha = np.where(bad, 0.5 * alpha, alpha)
        upd = todo & (res_new < res)
        if not upd.any():
            break
        q = np.where(upd[..., None, None], cand, q)
        f = np.where(upd[..., None], f_new, f)
        res = np.where(upd, res_new, res)
        length = np.einsum("i,...ij,...ij->...", h, q, q)
    return q, res


def _check_closed_srv(q: np.ndarray, t: np.ndarray, name: str, close: bool, tol: float) -> np.ndarray:
    """Refuse (or project) SRV arrays of curves that do not close; refuse zero-length ones."""
    h = np.diff(t)
    length = float(np.einsum("i,ij,ij->", h, q, q))
    if not length > 0.0:
        raise ValueError(f"{name}: the curve has length 0 (all samples equal): it has no shape")
    gap = float(np.linalg.norm(closure_residual(q, h)))
    if gap <= tol * length:
        return q
    if not close:
        raise ValueError(
            f"{name}: the curve is not closed: its end is {gap:.3g} from its start "
            f"({100 * gap / length:.3g} % of its length {length:.4g}); close it first "
            f"(close=True projects it onto closed curves, paper 001 Thm. 2)"
        )
    out, res = project_closed(q, h)
    if res > tol:
        raise ValueError(f"{name}: could not close the curve (relative gap {float(res):.3g} after Newton)")
    return out


# ----------------------------------------------------------------------------- geodesic


@dataclass(frozen=True)
class ClosedGeodesic:
    """Discrete geodesic between closed curves in ``M`` (see the module docstring).

    Attributes
    ----------
    path : ndarray, shape (K+1, n, D)
        ``alpha_k`` at times ``s_k = k / K``, all closed; ``path[0] = q0``, ``path[-1] = q1``.
    t : ndarray, shape (n+1,)
        Common break points of the path.
    distance : float
        ``sum_k ||alpha_{k+1} - alpha_k||`` (the closed-curve distance, from below).
    energy : float
        ``K sum_k ||alpha_{k+1} - alpha_k||^2`` (``>= distance^2``, equal for equal steps).
    open_distance : float
        ``||q1 - q0||``, the ``L^2`` (open-curve) distance: a lower bound.
    max_gap : float
        Largest relative closure residual ``|F(alpha_k)| / ||alpha_k||^2`` along the path.
    iterations : int
        Gauss-Newton iterations over all levels.
    converged : bool
        Tangential gradient below ``tol`` on the finest level.
    time : float
        Seconds.
    """

    path: np.ndarray
    t: np.ndarray
    distance: float
    energy: float
    open_distance: float
    max_gap: float
    iterations: int
    converged: bool
    time: float = field(repr=False, default=0.0)

    @property
    def velocity_end(self) -> np.ndarray:
        """``alpha'(1)`` (per unit time), tangent to M at q1 (one-sided difference of the
        discrete geodesic projected onto ``T_{q1} M``), shape (n, D)."""
        h = np.diff(self.t)
        K = self.path.shape[0] - 1
        return tangent_part(self.path[-1], K * (self.path[-1] - self.path[-2]), h)


def _path_energy(path: np.ndarray, h: np.ndarray) -> float:
    d = np.diff(path, axis=0)
    return float((path.shape[0] - 1) * np.einsum("i,kij,kij->", h, d, d))


def _straighten(path: np.ndarray, h: np.ndarray, tol: float, max_iter: int) -> tuple[np.ndarray, int, bool]:
    """Projected Gauss-Newton on the discrete path energy; endpoints fixed."""
    K = path.shape[0] - 1
    if K < 2:
        return path, 0, True
    scale = float(np.einsum("i,kij,kij->", h, path, path)) / (K + 1)

    def inner(a: np.ndarray, b: np.ndarray) -> float:
        return float(np.einsum("i,kij,kij->", h, a, b))

    def lap(d: np.ndarray) -> np.ndarray:  # discrete Laplacian with zero ends, then P_T
        out = 2.0 * d
        out[1:] -= d[:-1]
        out[:-1] -= d[1:]
        return tangent_part(path[1:-1], out, h)

    it = 0
    for it in range(1, max_iter + 1):
        inner_pts = path[1:-1]
        g = tangent_part(inner_pts, 2.0 * inner_pts - path[:-2] - path[2:], h)
        gnorm = math.sqrt(inner(g, g))
        if gnorm <= tol * math.sqrt(scale):
            return path, it - 1, True
        # conjugate gradients on lap(delta) = -g in the tangent spaces
        x = np.zeros_like(g)
        r = -g
        p = r.copy()
        rr = inner(r, r)
        for _ in range(4 * K):
            ap = lap(p)
            a = rr / max(inner(p, ap), 1e-300)
            x += a * p
            r -= a * ap
            rr_new = inner(r, r)
            if math.sqrt(rr_new) <= 1e-3 * gnorm:
                break
            p = r + (rr_new / rr) * p
            rr = rr_new
        e0 = _path_energy(path, h)
        step = 1.0
        for _ in range(20):
            cand_inner, _ = project_closed(inner_pts + step * x, h)
            cand = np.concatenate([path[:1], cand_inner, path[-1:]])
            if _path_energy(cand, h) <= e0:
                break
            step *= 0.5
        else:
            return path, it, False
        path = cand
    return path, it, False


def closed_geodesic(
    q0: Any,
    q1: Any,
    t: Any = None,
    *,
    n_steps: int = 16,
    tol: float = 1e-9,
    max_iter: int = 100,
    close: bool = False,
    closed_tol: float = CLOSED_TOL,
) -> ClosedGeodesic:
    """Geodesic between two closed curves in the space of closed curves (see module docstring).

    Parameters
    ----------
    q0, q1 : array_like, shape (n, D)
        SRV arrays of closed curves on the same break points ``t`` (merge different grids
        first, e.g. :func:`closed_distance` does).
    t : array_like, shape (n+1,), optional
        Break points (uniform when omitted).
    n_steps : int
        ``K``, number of segments of the discrete path (a power of 2 is reached exactly by
        the coarse-to-fine start; others are fine too).
    tol : float
        Stop when the tangential gradient of the path energy is below ``tol`` (relative).
    max_iter : int
        Gauss-Newton iterations per level.
    close : bool
        Project inputs that are not closed onto closed curves first (default: refuse them,
        saying how far they are from closing).
    closed_tol : float
        Relative closure residual ``|F(q)| / ||q||^2`` below which an input counts as closed.

    Returns
    -------
    ClosedGeodesic

    Raises
    ------
    ValueError
        Shapes, NaN, a curve of length 0, a curve that is not closed (without ``close``).
    """
    t_begin = time.perf_counter()
    q0a, ta = check_srv(q0, t, "q0")
    q1a, tb = check_srv(q1, t, "q1")
    if q0a.shape != q1a.shape or not np.array_equal(ta, tb):
        raise ValueError(
            f"q1: expected the shape and grid of q0, {q0a.shape}; got {q1a.shape} "
            "(use closed_distance for curves on different grids)"
        )
    K = int(n_steps)
    if K < 1:
        raise ValueError(f"n_steps: expected at least 1 segment; got {n_steps!r}")
    q0a = _check_closed_srv(q0a, ta, "q0", close, closed_tol)
    q1a = _check_closed_srv(q1a, ta, "q1", close, closed_tol)
    h = np.diff(ta)
    path = np.stack([q0a, q1a])
    iters = 0
    converged = True
    levels = [K]
    while levels[-1] > 2 and levels[-1] % 2 == 0:
        levels.append(levels[-1] // 2)
    for k_level in reversed(levels):
        cur = path.shape[0] - 1
        if k_level != cur:
            if k_level == 2 * cur:
                mids, _ = project_closed(0.5 * (path[:-1] + path[1:]), h)
                new = np.empty((k_level + 1, *path.shape[1:]))
                new[0::2] = path
                new[1::2] = mids
            else:  # from the straight line, projected
                s = np.linspace(0.0, 1.0, k_level + 1)[:, None, None]
                lin, _ = project_closed((1 - s[1:-1]) * q0a + s[1:-1] * q1a, h)
                new = np.concatenate([q0a[None], lin, q1a[None]])
            path = new
        path, it, converged = _straighten(path, h, tol, max_iter)
        iters += it
    d = np.diff(path, axis=0)
    seg = np.sqrt(np.einsum("i,kij,kij->k", h, d, d))
    gaps = np.linalg.norm(closure_residual(path, h), axis=-1) / np.maximum(
        np.einsum("i,kij,kij->k", h, path, path), 1e-300
    )
    diff = q1a - q0a
    return ClosedGeodesic(
        path=path,
        t=ta,
        distance=float(seg.sum()),
        energy=_path_energy(path, h),
        open_distance=float(math.sqrt(np.einsum("i,ij,ij->", h, diff, diff))),
        max_gap=float(gaps.max()),
        iterations=iters,
        converged=bool(converged),
        time=time.perf_counter() - t_begin,
    )


def closed_distance(
    q0: Any, q1: Any, t0: Any = None, t1: Any = None, *, n_steps: int = 16, close: bool = False
) -> float:
    """Closed-curve distance ``d_M(q0, q1)`` of two parametrised closed curves (no warp).

    Grids may differ: both are read on their merged break points (exact for piecewise
    constant SRV arrays).  See :func:`closed_geodesic`; :func:`match_closed` minimises it
    over seeds and warps.
    """
    q0a, t0a = check_srv(q0, t0, "q0")
    q1a, t1a = check_srv(q1, t1, "q1")
    grid, (a, b) = common_refinement([(q0a, t0a), (q1a, t1a)])
    return closed_geodesic(a, b, grid, n_steps=n_steps, close=close).distance


# ----------------------------------------------------------------------------- matching


@dataclass(frozen=True)
class ClosedMatch:
    """Optimal seed and warp of closed curve q1 onto q0 for the closed energy (eq. 22).

    Attributes
    ----------
    seed_shift : float
        ``tau``: q1's start moved to ``tau`` (``shift_seed(q1, t1, tau)``), as in
        :class:`elastic_motion.warp.WarpResult`.
    vertices : ndarray, shape (K, 2)
        The warp ``phi`` of the shifted q1.
    distance : float
        ``d_M(q0, q1_tau * phi)``, the closed-curve distance of the match.
    open_distance : float
        ``||q0 - q1_tau * phi||`` (the open-curve energy's distance) of the same match.
    landmark_cost : float
        ``lam * sum_m FM(phi(theta0_m), theta1_m)`` (theta1 moved with the seed).
    energy : float
        ``distance^2 + landmark_cost`` (eq. 22).
    energy_open_step : float
        ``E_cl`` of the warp of step (1) (open energy), before the closed descent.
    geodesic : ClosedGeodesic
        The closed geodesic from q0 to ``q1_tau * phi`` (on the merged grid).
    seed_from : str
        ``"q1"`` (seeds on q1's breaks) or ``"q0"`` (seeds on q0's breaks, swapped);
        ``", solved the other way round"`` appended when the match of q0 onto q1 won.
    closed_steps : int
        Accepted steps of the closed descent (step 2).
    time : float
    """

    seed_shift: float
    vertices: np.ndarray
    distance: float
    open_distance: float
    landmark_cost: float
    energy: float
    energy_open_step: float
    geodesic: ClosedGeodesic = field(repr=False)
    seed_from: str = "q1"
    closed_steps: int = 0
    time: float = field(repr=False, default=0.0)


@dataclass(frozen=True, eq=False)
class ClosedMatchOptions:
    """How :func:`match_closed` matches two closed curves (compared by identity: ``windows``
    may be an array, ``penalty`` a callable).

    Attributes
    ----------
    warp : WarpOptions, default WarpOptions()
        Solver of the warps (``method``, ``neighbourhood``, ``coarse_to_fine``; default DP then
        refinement).
    lam, penalty, windows, symmetric
        The feature term, as in :class:`~elastic_motion.warp.WarpSolverOptions` (``theta1`` in
        q1's own parameter: it moves with the seed); defaults 1, ``"squared"``, None, False.
    closed_iter : int, default 4
        Maximal number of closed-descent steps (step 2); 0 keeps the open-energy match.
    n_steps : int, default 8
        Segments of the discrete closed geodesics evaluated during the match (>= 1).
    seed_refine : bool, default False
        Move the seed off the break points: minimise the open energy over seeds within one
        cell of q1 either side of the best break point (bounded Brent search, each
        evaluation a warp solve on the shifted q1).
    close : bool, default False
        Project curves that do not close onto closed curves first (default: refuse).
    """

    warp: WarpOptions = field(default_factory=WarpOptions)
    lam: float = 1.0
    penalty: Penalty = "squared"
    windows: Any = None
    symmetric: bool = False
    closed_iter: int = 4
    n_steps: int = 8
    seed_refine: bool = False
    close: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.warp, WarpOptions):
            raise OptionError("warp", f"expected a WarpOptions; got {type(self.warp).__name__}")
        if isinstance(self.n_steps, bool) or int(self.n_steps) != self.n_steps or self.n_steps < 1:
            raise OptionError("n_steps", f"expected an integer >= 1; got {self.n_steps!r}")
        if isinstance(self.closed_iter, bool) or int(self.closed_iter) != self.closed_iter:
            raise OptionError(
                "closed_iter", f"expected an integer (0: no closed descent); got {self.closed_iter!r}"
            )
        self.solver()  # the warp options, the landmark weight and penalty checked there

    def solver(self) -> WarpSolverOptions:
        """The options of the warps of the match (:func:`~elastic_motion.warp.optimal_warp`)."""
        return self.warp.solver_options().replace(
            lam=self.lam, penalty=self.penalty, windows=self.windows, symmetric=self.symmetric
        )

    def landmark_cost(self, vertices: np.ndarray, landmarks: Landmarks | None) -> float:
        """The feature term of a warp (0 without landmarks)."""
        if not landmarks:
            return 0.0
        return landmark_cost(
            vertices,
            landmarks,
            lam=self.lam,
            penalty=self.penalty,
            windows=self.windows,
            symmetric=self.symmetric,
        )


def _shift_landmarks(lm: Landmarks | None, tau: float) -> Landmarks | bool | None:
    if lm is None or len(lm) == 0 or tau == 0.0:
        return lm
    try:
        return Landmarks(lm.theta0.copy(), (lm.theta1 - tau) % 1.0)
    except ValueError:
        return False  # crossing pairs: this seed cannot meet them


def match_closed(
    q0: Any,
    q1: Any,
    t0: Any = None,
    t1: Any = None,
    options: ClosedMatchOptions | WarpOptions | None = None,
    *,
    landmarks: Landmarks | Any | None = None,
    **overrides: Any,
) -> ClosedMatch:
    """Seed and warp minimising the closed-curve energy (paper 001, eq. 22, Remark 12).

    Parameters
    ----------
    q0, q1 : array_like, shapes (n0, D), (n1, D)
        SRV arrays of closed curves in ``R^D`` on ``t0``, ``t1``.
    t0, t1 : array_like, optional
        Break points (uniform when omitted).
    options : ClosedMatchOptions or WarpOptions, optional
        :class:`ClosedMatchOptions` (the feature term, the closed descent, the seed, the
        solver of the warps); a :class:`~elastic_motion.warp.WarpOptions` is its ``warp``.
    landmarks : Landmarks or array_like of shape (M, 2), optional
        Feature pairs (``theta1`` in q1's own parameter: it moves with the seed).
    **overrides
        Fields of :class:`ClosedMatchOptions` (``match_closed(q0, q1, lam=2.0, closed_iter=1)``).

    Returns
    -------
    ClosedMatch

    Notes
    -----
    Cost: two closed-curve DP searches (each ``optimal_warp(closed=True)``), plus per closed
    step one DP on the merged grid and one closed geodesic (``O(K n D)`` per Gauss-Newton
    iteration); without landmarks both orders are solved (module docstring): 1.5-1.7 times
    the time of one.
    """
    t_begin = time.perf_counter()
    base = ClosedMatchOptions(warp=options) if isinstance(options, WarpOptions) else options
    opts = with_overrides(ClosedMatchOptions, base, overrides)
    q0a, t0a = check_srv(q0, t0, "q0")
    q1a, t1a = check_srv(q1, t1, "q1")
    if q0a.shape[1] != q1a.shape[1]:
        raise ValueError(f"q1: expected {q0a.shape[1]} dimensions like q0; got {q1a.shape[1]}")
    q0a = _check_closed_srv(q0a, t0a, "q0", opts.close, CLOSED_TOL)
    q1a = _check_closed_srv(q1a, t1a, "q1", opts.close, CLOSED_TOL)
    lm = as_landmarks(landmarks)
    matcher = _Matcher(opts)
    best = matcher.match(q0a, t0a, q1a, t1a, lm)
    if lm is None:
        # without landmarks the energy is symmetric, but the closed descent is a local search
        # whose path turns on rounding (from starts 1e-16 apart it found 0.863 and 0.873 on
        # two outlines): the pair is also solved the other way round and the lower match
        # kept (a tie goes to the canonical order), so that d(a, b) = d(b, a); this replaces
        # the descent from the swapped side within each order (same distances on paper 001's
        # Table 1 hands, 1.5-1.7x the time of one order instead of 2.0-2.1x)
        other = matcher.swap_back(q0a, t0a, q1a, t1a)
        if other is not None:
            tie = abs(other.energy - best.energy) <= 1e-12 * max(best.energy, 1e-300)
            canonical = (q0a.shape, q0a.tobytes(), t0a.tobytes()) <= (q1a.shape, q1a.tobytes(), t1a.tobytes())
            if (other.energy < best.energy and not tie) or (tie and not canonical):
                best = other
    return dataclasses.replace(best, time=time.perf_counter() - t_begin)


class _Matcher:
    """Steps (1) and (2) of :func:`match_closed` with one :class:`ClosedMatchOptions`."""

    def __init__(self, opts: ClosedMatchOptions) -> None:
        self.opts = opts
        self.solver = opts.solver()

    def warp(self, q0: Array, t0: Array, q1: Array, t1: Array, landmarks: Landmarks | None) -> WarpResult:
        """:func:`optimal_warp` of ``q1`` onto ``q0`` with the match's solver."""
        return optimal_warp(q0, q1, self.solver, t0=t0, t1=t1, landmarks=landmarks)

    def closed_energy(
        self, q0: Array, t0: Array, q1s: Array, t1s: Array, verts: Array, lm: Landmarks | None
    ) -> tuple[float, ClosedGeodesic, float, float]:
        """``(E_cl, ClosedGeodesic, landmark cost, open distance)`` of one (shifted q1, warp)."""
        srv1 = SRVFunction(q1s, t1s, np.zeros(q1s.shape[1]), Euclidean(q1s.shape[1]))
        moved = reparametrize_srv(srv1, verts)
        grid, (a, b) = common_refinement([(q0, t0), (moved.q, moved.t)])
        b, _ = project_closed(b, np.diff(grid))  # rounding of the action only
        geo = closed_geodesic(a, b, grid, n_steps=self.opts.n_steps, closed_tol=1e-6)
        lc = self.opts.landmark_cost(verts, lm)
        return geo.distance**2 + lc, geo, lc, geo.open_distance

    def refine_seed(
        self, q0: Array, t0: Array, q1: Array, t1: Array, start: tuple, lm: Landmarks | None
    ) -> tuple:
        """Bounded scalar search of the seed within the cells of q1 next to ``start = (tau,
        vertices, open energy)``."""
        tau, verts, e_open = start
        k = int(np.clip(np.searchsorted(t1, tau, side="right") - 1, 0, len(t1) - 2))
        left = t1[k] - t1[k - 1] if k > 0 else t1[-1] - t1[-2]
        right = t1[k + 1] - t1[k]
        cache: dict[float, tuple] = {}

        def f(x: float) -> float:
            seed = float(x) % 1.0
            lms = _shift_landmarks(lm, seed)
            if lms is False:
                cache[x] = (np.inf, None, None)
                return np.inf
            q1s, t1s = shift_seed(q1, t1, seed)
            try:
                r = self.warp(q0, t0, q1s, t1s, lms)
            except ValueError:
                cache[x] = (np.inf, None, None)
                return np.inf
            cache[x] = (r.energy, r.vertices, lms)
            return r.energy

        minimize_scalar(f, bounds=(tau - left, tau + right), method="bounded", options={"xatol": 1e-5})
        best = min(cache, key=lambda x: cache[x][0])
        if cache[best][0] < e_open:
            e, v, lms = cache[best]
            return float(best) % 1.0, v, e, lms
        return tau, verts, e_open, _shift_landmarks(lm, tau)

    def descent(
        self, q0: Array, t0: Array, q1: Array, t1: Array, start: tuple, lms: Landmarks | None
    ) -> tuple:
        """Step (2) for q1 warped onto q0 from ``start = (tau, vertices)``, the seed fixed.

        Returns ``(tau, vertices, E_cl, geodesic, landmark cost, open distance, accepted steps)``.
        """
        tau, verts = start
        q1s, t1s = shift_seed(q1, t1, tau)
        e_cl, geo, lc, d_open = self.closed_energy(q0, t0, q1s, t1s, verts, lms)
        steps = 0
        for _ in range(max(0, int(self.opts.closed_iter))):
            target = geo.path[-1] - geo.velocity_end  # q0_eff on the merged grid geo.t
            try:
                res = self.warp(target, geo.t, q1s, t1s, lms)
            except ValueError:
                break
            e_new, geo_new, lc_new, d_new = self.closed_energy(q0, t0, q1s, t1s, res.vertices, lms)
            if not e_new < e_cl * (1.0 - 1e-9):
                break
            verts, e_cl, geo, lc, d_open = res.vertices, e_new, geo_new, lc_new, d_new
            steps += 1
        return tau, verts, e_cl, geo, lc, d_open, steps

    def open_step(self, q0a: Array, t0a: Array, q1a: Array, t1a: Array, lm: Landmarks | None) -> tuple:
        """Step (1): seed and warp by the DP, seeds on the breaks of both curves, the better by
        the open objective. Returns ``((E_open, shifted landmarks), source, tau, vertices)``."""

        def open_score(tau: float, verts: np.ndarray) -> tuple[float, Landmarks | None]:
            lms = _shift_landmarks(lm, tau)
            if lms is False:
                return np.inf, None
            q1s, t1s = shift_seed(q1a, t1a, tau)
            e = warp_energy(q0a, q1s, verts, t0a, t1s)
            if lms:
                e += self.opts.landmark_cost(verts, lms)  # type: ignore[arg-type]
            return e, lms  # type: ignore[return-value]

        closed = self.solver.replace(closed=True, seeds="q1")
        cands = []
        a = optimal_warp(q0a, q1a, closed, t0=t0a, t1=t1a, landmarks=lm)
        cands.append(("q1", a.seed_shift, a.vertices))
        lm_sw = None if lm is None else lm.swapped()
        try:
            b = optimal_warp(q1a, q0a, closed, t0=t1a, t1=t0a, landmarks=lm_sw)
            tau_b, phi_b = swap_closed_match(b.vertices, b.seed_shift)
            cands.append(("q0", tau_b, phi_b))
        except ValueError:
            pass  # no swapped candidate (flat warp or landmarks that no seed of q0 meets)
        scored = [(open_score(tau, v), src, tau, v) for src, tau, v in cands]
        return min(scored, key=lambda s: s[0][0])

    def match(self, q0a: Array, t0a: Array, q1a: Array, t1a: Array, lm: Landmarks | None) -> ClosedMatch:
        """Steps (1) and (2) of :func:`match_closed` on checked arrays."""
        (e_open, lms), src, tau, verts = self.open_step(q0a, t0a, q1a, t1a, lm)
        if not np.isfinite(e_open):
            raise ValueError(
                "landmarks: no seed and warp meet the landmarks (hard windows or crossing pairs)"
            )
        if self.opts.seed_refine:
            tau, verts, e_open, lms = self.refine_seed(q0a, t0a, q1a, t1a, (tau, verts, e_open), lm)
        q1s, t1s = shift_seed(q1a, t1a, tau)
        e_start = self.closed_energy(q0a, t0a, q1s, t1s, verts, lms)[0]
        # (2) descent on E_cl with the exact first variation of d_M^2 (effective target); with
        # landmarks and the symmetric term the objective is symmetric in the two curves, so the
        # descent runs from both sides (warping q1, and warping q0 with the swapped match) and
        # the lower result is kept (without landmarks match_closed solves both orders whole)
        best = self.descent(q0a, t0a, q1a, t1a, (tau, verts), lms)
        if lm is not None and self.opts.symmetric and self.opts.closed_iter > 0:
            swapped = self.swapped_descent(q0a, t0a, q1a, t1a, (tau, verts, best), lm)
            if swapped is not None:
                best, src = swapped, f"{src}, swapped descent"
        tau, verts, e_cl, geo, lc, d_open, steps = best
        return ClosedMatch(
            seed_shift=float(tau),
            vertices=np.asarray(verts),
            distance=geo.distance,
            open_distance=d_open,
            landmark_cost=float(lc),
            energy=float(e_cl),
            energy_open_step=float(e_start),
            geodesic=geo,
            seed_from=src,
            closed_steps=steps,
        )

    def swapped_descent(
        self, q0a: Array, t0a: Array, q1a: Array, t1a: Array, start: tuple, lm: Landmarks
    ) -> tuple | None:
        """The descent run from the swapped side (q0 warped onto q1 with the swapped match of
        ``start = (tau, vertices, best)``), swapped back; None unless it beats ``best``."""
        tau, verts, best = start
        try:
            sigma, psi = swap_closed_match(verts, tau)
        except ValueError:
            return None
        lms_sw = _shift_landmarks(lm.swapped(), sigma)
        other = self.descent(q1a, t1a, q0a, t0a, (sigma, psi), lms_sw)
        if not (other[2] < best[2] * (1.0 - 1e-9) and other[-1] > 0):
            return None
        try:
            tau2, phi2 = swap_closed_match(other[1], other[0])
        except ValueError:
            return None
        lms2 = _shift_landmarks(lm, tau2)
        if lms2 is False:
            return None
        q1s2, t1s2 = shift_seed(q1a, t1a, tau2)
        e2, geo2, lc2, d2 = self.closed_energy(q0a, t0a, q1s2, t1s2, phi2, lms2)
        if not e2 < best[2]:
            return None
        return tau2, phi2, e2, geo2, lc2, d2, other[-1]

    def swap_back(self, q0: Array, t0: Array, q1: Array, t1: Array) -> ClosedMatch | None:
        """The match of q1 onto q0 (no landmarks) solved as q0 onto q1 and swapped back
        (:func:`swap_closed_match`), its energy measured again this way round; None when it
        cannot be swapped (a flat piece of the warp)."""
        m = self.match(q1, t1, q0, t0, None)
        try:
            tau, phi = swap_closed_match(m.vertices, m.seed_shift)
        except ValueError:
            return None
        q1s, t1s = shift_seed(q1, t1, tau)
        e_cl, geo, lc, d_open = self.closed_energy(q0, t0, q1s, t1s, phi, None)
        return ClosedMatch(
            seed_shift=float(tau),
            vertices=phi,
            distance=geo.distance,
            open_distance=d_open,
            landmark_cost=float(lc),
            energy=float(e_cl),
            energy_open_step=m.energy_open_step,
            geodesic=geo,
            seed_from=f"{m.seed_from}, solved the other way round",
            closed_steps=m.closed_steps,
        )


# ----------------------------------------------------------------------------- curves


def closed_curve_srv(
    curve: DiscreteCurve | Any, *, close: bool = False, closed_tol: float = CLOSED_TOL
) -> SRVFunction:
    """SRV function of a closed curve in ``R^d`` given by samples, checked to close.

    Parameters
    ----------
    curve : DiscreteCurve or array_like of shape (n+1, d)
        Samples with ``values[-1] == values[0]`` (uniform parameters for an array).
        Repeated consecutive samples are allowed (cells with ``q = 0``).
    close : bool
        Project a curve that does not close onto closed curves (its first sample kept).
    closed_tol : float
        Relative gap ``|c(1) - c(0)| / length`` accepted as closed.

    Raises
    ------
    ValueError
        Not ``R^d``; not closed (says by how much) without ``close``; length 0.
    """
    if not isinstance(curve, DiscreteCurve):
        arr = as_float_array(curve, "curve")
        check_finite(arr, "curve")
        if arr.ndim != 2 or arr.shape[0] < 3:
            raise ValueError(f"curve: expected samples of shape (n+1, d) with n+1 >= 3; got {arr.shape}")
        curve = DiscreteCurve(arr, Euclidean(arr.shape[1]))
    if not isinstance(curve.group, Euclidean):
        raise ValueError(f"curve: expected a curve in R^d; got group {curve.group!r}")
    srv = srv_transform(curve)
    q = _check_closed_srv(np.asarray(srv.q), srv.t, "curve", close, closed_tol)
    return SRVFunction(q, srv.t, srv.start, srv.group)


def closed_geodesic_curves(geodesic: ClosedGeodesic, *, centre: bool = True) -> list[np.ndarray]:
    """The curves ``R^{-1}(alpha_k)`` of a closed geodesic, for drawing.

    Returns
    -------
    list of ndarray, each of shape (n+1, D)
        Samples on ``geodesic.t`` (closed: last sample equals the first to the closure
        tolerance), centred at their mean vertex when ``centre`` (translations are not part
        of the SRV).
    """
    out = []
    g = Euclidean(geodesic.path.shape[2])
    for q in geodesic.path:
        c = inverse_srv_transform(SRVFunction(q, geodesic.t, np.zeros(q.shape[1]), g)).values
        if centre:
            c = c - c[:-1].mean(axis=0)
        out.append(np.asarray(c))
    return out
