"""Gradient refinement of a warp off the DP grid (paper 001, sec. 3.1, Lemma 14).

The warp is piecewise linear on fixed domain nodes ``u_0 = 0 < ... < u_K = 1`` (the q0
break points plus the vertices of the starting warp) with free values ``phi(u_k)``.  It
is parametrised by ``psi = sqrt(phi')`` (Lemma 14), piecewise constant: with
``z_r = psi_r sqrt(u_{r+1} - u_r)`` (so the L2 norm of ``psi`` is the Euclidean norm of
``z``),

    phi(u_k) = sum_{r<k} z_r^2 / sum_r z_r^2,

which is non-decreasing and runs from 0 to 1 for every ``z != 0``: the optimisation is
unconstrained and scale invariant (``z`` lives on the unit sphere, as ``psi`` does on the
Hilbert sphere of Lemma 14).

Energy: the exact discrete objective (Gram form of
:func:`elastic_motion.warp.dp_kernels.energy_and_grad`) plus the
landmark term; gradient: the exact derivative of the discrete energy in the vertex values
(the discrete counterpart of eq. 24 / 26) chained through ``z``.  Optimiser: L-BFGS
directions with a backtracking (Armijo) line search on the sphere; a step is accepted
only if it decreases the energy, so the returned energy is never above the starting one.
Stops when the relative decrease per iteration (averaged over 5 iterations) falls below
``tol``, after ``max_iter`` iterations, or when no decreasing step is found.

The energy is only piecewise smooth (it has kinks where a vertex value crosses a q1 break
point): the method is a local descent, meant to polish a DP warp, not to replace it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from elastic_motion._options import with_overrides
from elastic_motion.errors import OptionError
from elastic_motion.warp import dp_kernels
from elastic_motion.warp.dp import DPProblem, LandmarkTables
from elastic_motion.warp.energy import kernel_array

__all__ = ["RefineOptions", "RefineResult", "refine_warp"]


@dataclass(frozen=True)
class RefineOptions:
    """How :func:`refine_warp` descends.

    Attributes
    ----------
    tol : float, default 1e-7
        Stop when the last ``window`` iterations decreased the energy by less than
        ``window * tol`` times its value (relative tolerance per iteration). Non-negative.
    max_iter : int, default 500
        Maximal number of iterations.
    memory : int, default 10
        Number of L-BFGS pairs kept (>= 1).
    window : int, default 5
        Iterations over which the relative decrease is measured (>= 1).
    jitter : float, default 1e-3
        Relative perturbation of ``psi`` at the start (moves the vertices off the kinks of
        the energy, where the gradient is one-sided). Non-negative.
    """

    tol: float = 1e-7
    max_iter: int = 500
    memory: int = 10
    window: int = 5
    jitter: float = 1e-3

    def __post_init__(self) -> None:
        for name in ("tol", "jitter"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise OptionError(name, f"expected a finite number >= 0; got {v!r}")
        for name, least in (("max_iter", 0), ("memory", 1), ("window", 1)):
            v = getattr(self, name)
            if isinstance(v, bool) or int(v) != v or v < least:
                raise OptionError(name, f"expected an integer >= {least}; got {v!r}")


@dataclass(frozen=True)
class RefineResult:
    """Outcome of :func:`refine_warp`."""

    vertices: np.ndarray  # (K+1, 2)
    energy: float  # objective (elastic + landmark), Gram form
    energy_start: float
    iterations: int
    evaluations: int
    stop: str


class _Objective:
    """Energy and gradient in ``z`` for fixed domain nodes ``u`` (the pair in Gram form:
    ``t0``, ``t1``, ``G``, ``A_tot``, ``B_tot`` of ``pb``)."""

    def __init__(self, pb: DPProblem, u: np.ndarray, lmd: LandmarkTables) -> None:
        G = pb.G
        self.t0, self.t1, self.G = kernel_array(pb.t0), kernel_array(pb.t1), kernel_array(G)
        dG = np.zeros_like(G)
        dG[:, 1:] = G[:, 1:] - G[:, :-1]  # <q0[a], q1[b] - q1[b-1]>: jumps of q1
        self.dG = dG
        self.A, self.B = pb.A_tot, pb.B_tot
        self.u = kernel_array(u)
        self.du = np.diff(u)
        lm = lmd.lm
        self.lm, self.spec, self.sym = lm, lmd.spec, lmd.symmetric
        self.n_eval = 0
        if lm is not None and len(lm) > 0:
            self.lm_piece = np.clip(np.searchsorted(u, lm.theta0, side="right") - 1, 0, len(u) - 2)

    def phi(self, z: np.ndarray) -> np.ndarray:
        w = z * z
        y = np.concatenate([[0.0], np.cumsum(w)]) / w.sum()
        y = np.minimum(y, 1.0)  # rounding can put the cumulative sum a hair above 1
        y[-1] = 1.0
        return y

    def landmark(self, y: np.ndarray) -> tuple[float, np.ndarray]:
        """Landmark term and its gradient in the vertex values ``y``."""
        g = np.zeros_like(y)
        lm, spec = self.lm, self.spec
        if (
            lm is None
            or spec is None
            or len(lm) == 0
            or (spec.lam == 0.0 and not np.isfinite(spec.windows).any())
        ):
            return 0.0, g
        u, du = self.u, self.du
        r = self.lm_piece
        f = (lm.theta0 - u[r]) / du[r]
        x = y[r] + f * (y[r + 1] - y[r])  # phi(theta0_m) on its linear piece
        if (np.abs(x - lm.theta1) > spec.windows + 1e-12).any():
            return np.inf, g
        val = spec.lam * float(spec.values(x, lm.theta1).sum())
        d = spec.lam * spec.derivative(x, lm.theta1)
        np.add.at(g, r, d * (1.0 - f))
        np.add.at(g, r + 1, d * f)
        if self.sym:
            p = np.clip(np.searchsorted(y, lm.theta1, side="left") - 1, 0, len(y) - 2)
            dy = y[p + 1] - y[p]
            ok = dy > 0
            dys = np.where(ok, dy, 1.0)
            xi = u[p] + np.where(ok, (lm.theta1 - y[p]) / dys, 0.0) * du[p]  # phi^{-1}(theta1)
            if (np.abs(xi - lm.theta0) > spec.windows + 1e-12).any():
                return np.inf, g
            val += spec.lam * float(spec.values(xi, lm.theta0).sum())
            d = np.where(ok, spec.lam * spec.derivative(xi, lm.theta0), 0.0)
            np.add.at(g, p, d * du[p] * (lm.theta1 - y[p + 1]) / dys**2)
            np.add.at(g, p + 1, -d * du[p] * (lm.theta1 - y[p]) / dys**2)
        return val, g

    def __call__(self, z: np.ndarray) -> tuple[float, np.ndarray]:
        self.n_eval += 1
        y = self.phi(z)
        e, gy = dp_kernels.energy_and_grad(self.t0, self.t1, self.G, self.dG, self.A, self.B, self.u, y)
        le, lg = self.landmark(y)
        if not np.isfinite(le):
            return np.inf, np.zeros_like(z)
        gy = gy + lg
        e = float(e) + le
        # chain rule y_k = sum_{r<k} w_r / S, w_r = z_r^2:
        # dE/dw_r = (sum_{k>r} g_k - sum_k g_k y_k) / S
        w = z * z
        S = w.sum()
        suffix = np.cumsum(gy[::-1])[::-1]  # suffix[k] = sum_{k' >= k} g_k'
        dw = (suffix[1:] - float(gy @ y)) / S
        return e, 2.0 * z * dw


def refine_warp(
    pb: DPProblem,
    start: np.ndarray,
    lmd: LandmarkTables | None = None,
    options: RefineOptions | None = None,
    **overrides: Any,
) -> RefineResult:
    """Refine a warp by L-BFGS on ``psi = sqrt(phi')`` with a backtracking line search.

    Parameters
    ----------
    pb : DPProblem
        The pair in Gram form: break points ``t0`` ``(n0+1,)``, ``t1`` ``(n1+1,)``, the Gram
        matrix ``G = q0 @ q1.T`` ``(n0, n1)``, ``A_tot = ||q0||^2``, ``B_tot = ||q1||^2``.
    start : ndarray, shape (K, 2)
        Starting warp (e.g. the DP warp, or the identity ``[[0, 0], [1, 1]]``).
    lmd : LandmarkTables, optional
        Landmark term (see :mod:`elastic_motion.warp.landmarks`); default none.
    options : RefineOptions, optional
    **overrides
        Fields of ``options`` (``refine_warp(pb, start, tol=1e-9)``).

    Returns
    -------
    RefineResult
    """
    opts = with_overrides(RefineOptions, options, overrides)
    u, z = _start(pb.t0, start, opts.jitter)
    obj = _Objective(pb, u, LandmarkTables(None, None, False) if lmd is None else lmd)
    e, g = obj(z)
    if not np.isfinite(e):
        return RefineResult(start, e, e, 0, obj.n_eval, "infeasible start")
    e_start = e
    z, e, it, stop = _lbfgs(obj, z, (e, g), opts)
    vertices = np.column_stack([u, obj.phi(z)])
    return RefineResult(vertices, e, e_start, it, obj.n_eval, stop)


def _start(t0: np.ndarray, start: np.ndarray, jitter: float) -> tuple[np.ndarray, np.ndarray]:
    """The domain nodes ``u`` (q0's break points and the start's vertices) and the start's
    ``z`` on the unit sphere, lifted off flat pieces and jittered off the kinks."""
    u = np.union1d(t0, start[:, 0])
    keep = np.ones(u.shape[0], dtype=bool)
    keep[1:] = np.diff(u) > 1e-13
    u = u[keep]
    u[-1] = 1.0
    y0 = np.interp(u, start[:, 0], start[:, 1])
    du = np.diff(u)
    z = np.sqrt(np.maximum(np.diff(y0), 0.0) / du) * np.sqrt(du)
    # a flat piece (psi = 0) is a fixed point of the psi-form gradient: lift it slightly
    floor = 1e-6 * np.sqrt(du)
    z = np.maximum(z, floor)
    # DP warps (and the identity on equal grids) put every vertex exactly on a q1 break
    # point, where the energy has a kink and the gradient is one-sided: move the start off
    # the kinks by a tiny relative perturbation (fixed seed: results are reproducible)
    z = z * (1.0 + jitter * np.random.default_rng(0).standard_normal(z.shape[0]))
    z /= np.linalg.norm(z)
    return u, z


def _lbfgs(
    obj: _Objective, z: np.ndarray, eg: tuple[float, np.ndarray], opts: RefineOptions
) -> tuple[np.ndarray, float, int, str]:
    """L-BFGS on the sphere from ``z`` (energy and gradient ``eg``); returns the last ``z``, its
    energy, the iterations and why it stopped."""
    e, g = eg
    s_hist: list[np.ndarray] = []
    y_hist: list[np.ndarray] = []
    stop = "max_iter"
    it = 0
    history = [e]
    window = opts.window
    for it in range(1, opts.max_iter + 1):  # noqa: B007
        d, slope = _direction(g, z, s_hist, y_hist)
        if slope >= 0.0 or not np.isfinite(slope):
            stop = "stationary"
            break
        # first step: move at most 0.1 on the unit sphere; then the quasi-Newton step
        step = 1.0 if s_hist else min(1.0, 0.1 / (np.linalg.norm(d) + 1e-300))
        found = _line_search(obj, z, d, (e, slope, step))
        if found is None:
            stop = "line search"
            break
        zn, en, gn = found
        s_k, y_k = zn - z, gn - g
        if float(s_k @ y_k) > 1e-12 * float(s_k @ s_k):
            s_hist.append(s_k)
            y_hist.append(y_k)
            if len(s_hist) > opts.memory:
                s_hist.pop(0)
                y_hist.pop(0)
        z, e, g = zn, en, gn
        history.append(e)
        # relative decrease over the last `window` iterations (single L-BFGS steps on a
        # piecewise smooth energy are erratic: one short step must not stop the descent)
        if len(history) > window:
            rel = (history[-1 - window] - e) / max(abs(e), 1e-300)
            if rel < window * opts.tol:
                stop = "tol"
                break
    return z, e, it, stop


def _direction(
    g: np.ndarray, z: np.ndarray, s_hist: list[np.ndarray], y_hist: list[np.ndarray]
) -> tuple[np.ndarray, float]:
    """The L-BFGS direction (two-loop recursion, tangent to the sphere at ``z``) and its slope
    ``<g, d>``; steepest descent, the memory cleared, when it does not descend."""
    d = -g
    alphas = []
    for s_k, y_k in zip(reversed(s_hist), reversed(y_hist), strict=True):
        rho = 1.0 / float(y_k @ s_k)
        a = rho * float(s_k @ d)
        alphas.append((rho, a))
        d = d - a * y_k
    if s_hist:
        d = d * float(s_hist[-1] @ y_hist[-1]) / float(y_hist[-1] @ y_hist[-1])
    for (rho, a), s_k, y_k in zip(reversed(alphas), s_hist, y_hist, strict=True):
        b = rho * float(y_k @ d)
        d = d + (a - b) * s_k
    d = d - float(d @ z) * z  # keep the direction tangent to the sphere
    slope = float(g @ d)
    if slope >= 0.0:  # not a descent direction: restart from steepest descent
        s_hist.clear()
        y_hist.clear()
        d = -g
        slope = float(g @ d)
    return d, slope


def _line_search(
    obj: _Objective, z: np.ndarray, d: np.ndarray, start: tuple[float, float, float]
) -> tuple[np.ndarray, float, np.ndarray] | None:
    """Backtracking on the sphere from ``z`` along ``d``; ``start = (energy, slope, first
    step)``. The accepted point (Armijo and a strict decrease), or None after 40 halvings."""
    e, slope, step = start
    for _ in range(40):
        zn = z + step * d
        zn /= np.linalg.norm(zn)
        en, gn = obj(zn)
        if en <= e + 1e-4 * step * slope and en < e:
            return zn, en, gn
        step *= 0.5
    return None
