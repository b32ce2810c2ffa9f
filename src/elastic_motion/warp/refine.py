"""Gradient refinement of a warp off the DP grid (paper 001, sec. 3.1, Lemma 14).

The warp is piecewise linear on fixed domain nodes ``u_0 = 0 < ... < u_K = 1`` (the q0
break points, the vertices of the starting warp and the pre-images of the q1 break points
under it) with free values ``phi(u_k)``.  It
is parametrised by ``psi = sqrt(phi')`` (Lemma 14), piecewise constant: with
``z_r = psi_r sqrt(u_{r+1} - u_r)`` (so the L2 norm of ``psi`` is the Euclidean norm of
``z``),

    phi(u_k) = sum_{r<k} z_r^2 / sum_r z_r^2,

which is non-decreasing and runs from 0 to 1 for every ``z != 0``: the optimisation is
unconstrained and scale invariant (``z`` lives on the unit sphere, as ``psi`` does on the
Hilbert sphere of Lemma 14).

Nodes: by default (``nodes="both"``) the pre-images of q1's break points under the start
are nodes too, so that the warp is free on both curves' grids (the DP's warp has its
vertices on the grid ``t0 x t1``; the refinement's extra freedom lowers the energy by 0.1 to
10 % more, ``docs/warp.md``); ``nodes="q0"``: q0's break points and the start's vertices.

Energy: the exact discrete objective (Gram form,
:func:`elastic_motion.warp.refine_kernels.energy_and_grad`) plus the landmark term;
gradient: the exact derivative of the discrete energy in the vertex values (the discrete
counterpart of eq. 24 / 26) chained through ``z``.  Optimiser: L-BFGS directions with a
backtracking (Armijo) line search on the sphere, compiled as one loop
(:func:`elastic_motion.warp.refine_kernels.lbfgs`); a step is accepted only if it decreases
the energy, so the returned energy is never above the starting one.

Stopping rule: the descent stops when the energy decreased by less than ``tol`` (relative,
default 1e-7) per iteration on average over the last ``window`` iterations (default 20),
i.e. ``E[k - window] - E[k] < window * tol * |E[k]|``; or after ``max_iter`` iterations
(default 1000); or when no step decreases the energy.  The window is long because single
L-BFGS steps on a piecewise smooth energy are erratic: a few short steps at a kink must not
stop the descent (measured on the CMU pairs of ``benchmarks/warp.py`` at N = 100 to 800,
six jitter seeds each: with 5 iterations 3 of 48 descents ended on the DP's energy, with 20
one).

The energy is only piecewise smooth (it has kinks where a vertex value crosses a q1 break
point): the method is a local descent, meant to polish a DP warp, not to replace it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from elastic_motion._options import with_overrides
from elastic_motion.defaults import DEFAULT_REFINE_MAX_ITER, DEFAULT_REFINE_TOL, DEFAULT_REFINE_WINDOW
from elastic_motion.errors import OptionError
from elastic_motion.warp import refine_kernels
from elastic_motion.warp.dp import DPProblem, LandmarkTables
from elastic_motion.warp.energy import MERGE_TOL, kernel_array, preimages
from elastic_motion.warp.landmarks import WINDOW_SLACK

__all__ = ["RefineOptions", "RefineResult", "refine_warp"]


@dataclass(frozen=True)
class RefineOptions:
    """How :func:`refine_warp` descends.

    Attributes
    ----------
    tol : float, default 1e-7
        Stop when the last ``window`` iterations decreased the energy by less than
        ``window * tol`` times its value (relative tolerance per iteration). Non-negative.
    max_iter : int, default 1000
        Maximal number of iterations.
    memory : int, default 20
        Number of L-BFGS pairs kept (>= 1).
    window : int, default 20
        Iterations over which the relative decrease is measured (>= 1).
    jitter : float, default 1e-3
        Relative perturbation of ``psi`` at the start (moves the vertices off the kinks of
        the energy, where the gradient is one-sided). Non-negative.
    nodes : {"both", "q0"}, default "both"
        The domain nodes of the warp: q0's break points, the start's vertices and the
        pre-images of q1's break points under the start (``"both"``), or without those
        (``"q0"``, the refinement before issue 34).
    """

    tol: float = DEFAULT_REFINE_TOL
    max_iter: int = DEFAULT_REFINE_MAX_ITER
    memory: int = 20
    window: int = DEFAULT_REFINE_WINDOW
    jitter: float = 1e-3
    nodes: Literal["both", "q0"] = "both"

    def __post_init__(self) -> None:
        for name in ("tol", "jitter"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise OptionError(name, f"expected a finite number >= 0; got {v!r}")
        for name, least in (("max_iter", 0), ("memory", 1), ("window", 1)):
            v = getattr(self, name)
            if isinstance(v, bool) or int(v) != v or v < least:
                raise OptionError(name, f"expected an integer >= {least}; got {v!r}")
        if self.nodes not in ("both", "q0"):
            raise OptionError("nodes", f"expected 'both' or 'q0'; got {self.nodes!r}")


@dataclass(frozen=True)
class RefineResult:
    """Outcome of :func:`refine_warp`: the refined warp's vertices ``(K+1, 2)``, its objective
    (elastic + landmark, Gram form), the objective of the start, the iterations and energy
    evaluations of the descent and why it stopped (``"tol"``, ``"max_iter"``,
    ``"stationary"``, ``"line search"``, ``"infeasible start"``)."""

    vertices: np.ndarray
    energy: float
    energy_start: float
    iterations: int
    evaluations: int
    stop: str


class _Objective:
    """Energy and gradient in ``z`` for fixed domain nodes ``u``: the pair in Gram form
    (``t0``, ``t1``, ``G``, ``A_tot``, ``B_tot`` of ``pb``) and the landmark term, packed for
    the compiled kernels (:mod:`elastic_motion.warp.refine_kernels`)."""

    def __init__(self, pb: DPProblem, u: np.ndarray, lmd: LandmarkTables) -> None:
        u = kernel_array(u)
        self.prob = (
            kernel_array(pb.t0),
            kernel_array(pb.t1),
            kernel_array(pb.G),
            float(pb.A_tot),
            float(pb.B_tot),
            u,
        )
        self.lmk = _landmark_args(lmd, u)

    def phi(self, z: np.ndarray) -> np.ndarray:
        """The vertex values ``phi(u)`` of ``z``, shape ``(K+1,)``."""
        y = np.empty(z.shape[0] + 1)
        refine_kernels.warp_values(kernel_array(z), y)
        return y

    def __call__(self, z: np.ndarray) -> tuple[float, np.ndarray]:
        z = kernel_array(z)
        y, gy, gz = np.empty(z.shape[0] + 1), np.empty(z.shape[0] + 1), np.empty(z.shape[0])
        return float(refine_kernels.objective(z, self.prob, self.lmk, y, gy, gz)), gz


def _landmark_args(lmd: LandmarkTables, u: np.ndarray) -> tuple:
    """``lmk`` of :mod:`elastic_motion.warp.refine_kernels` (module docstring there); empty
    arrays when there is no landmark term."""
    lm, spec = lmd.lm, lmd.spec
    empty_f, empty_t = np.zeros(0), np.zeros((0, 2))
    if lm is None or spec is None or len(lm) == 0:
        return (0.0, 0, empty_f, empty_f, empty_f, np.zeros(0, dtype=np.int64), empty_t, empty_t, False)
    piece = np.clip(np.searchsorted(u, lm.theta0, side="right") - 1, 0, len(u) - 2)
    k = kernel_array
    return (
        float(spec.lam),
        int(spec.kind),
        k(lm.theta0),
        k(lm.theta1),
        k(spec.windows + WINDOW_SLACK),
        k(piece, np.int64),
        k(spec.table(lm.theta1)) if spec.kind == 3 else empty_t,
        k(spec.table(lm.theta0)) if spec.kind == 3 and lmd.symmetric else empty_t,
        bool(lmd.symmetric),
    )


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
    u, z = _start(pb.t0, pb.t1 if opts.nodes == "both" else None, start, opts.jitter)
    obj = _Objective(pb, u, LandmarkTables(None, None, False) if lmd is None else lmd)
    z, e_start, e, it, code, n_eval = refine_kernels.lbfgs(
        z, obj.prob, obj.lmk, float(opts.tol), int(opts.max_iter), int(opts.memory), int(opts.window)
    )
    stop = refine_kernels.STOP_REASONS[code]
    if code == refine_kernels.STOP_INFEASIBLE:
        return RefineResult(start, e, e, 0, n_eval, stop)
    vertices = np.column_stack([u, obj.phi(z)])
    return RefineResult(vertices, float(e), float(e_start), int(it), int(n_eval), stop)


def _start(
    t0: np.ndarray, t1: np.ndarray | None, start: np.ndarray, jitter: float
) -> tuple[np.ndarray, np.ndarray]:
    """The domain nodes ``u`` (q0's break points, the start's vertices and, with ``t1``, the
    pre-images of q1's break points under the start) and the start's ``z`` on the unit
    sphere, lifted off flat pieces and jittered off the kinks."""
    extra = start[:, 0] if t1 is None else np.union1d(start[:, 0], preimages(start, t1))
    # every break of q0 is a node (a piece lies in one cell of q0); other nodes within
    # MERGE_TOL of a break or of each other are dropped
    i = np.clip(np.searchsorted(t0, extra), 1, len(t0) - 1)
    extra = extra[np.minimum(extra - t0[i - 1], t0[i] - extra) > MERGE_TOL]
    if extra.size:
        extra = extra[np.concatenate([[True], np.diff(extra) > MERGE_TOL])]
    u = np.union1d(t0, extra)
    y0 = np.interp(u, start[:, 0], start[:, 1])
    du = np.diff(u)
    z = np.sqrt(np.maximum(np.diff(y0), 0.0) / du) * np.sqrt(du)
    # a flat piece (psi = 0) is a fixed point of the psi-form gradient: lift it slightly
    z = np.maximum(z, 1e-6 * np.sqrt(du))
    # DP warps (and the identity on equal grids) put every vertex exactly on a q1 break
    # point, where the energy has a kink and the gradient is one-sided: move the start off
    # the kinks by a tiny relative perturbation (fixed seed: results are reproducible)
    z = z * (1.0 + jitter * np.random.default_rng(0).standard_normal(z.shape[0]))
    return u, kernel_array(z / np.linalg.norm(z))
