"""The closing flows: Gauss-Newton and gradient descent on the seam gap (paper 000, sec. 4).

Both minimise the discrete ``Phi(q) = 1/2 |F_0(q)|^2`` (plus ``c1_weight/2 |F_1|^2`` with
``c1``) of :mod:`elastic_motion.closing.problem` over ``q`` from the curve's own SRV
function, the first sample fixed, with an Armijo backtracking line search: every accepted
step decreases ``Phi``.

* ``method="gradient"``: the gradient flow of paper 000 sec. 4.2 discretised by steepest
  descent with the exact gradient, the step of the linearised model (Cauchy step) and the
  line search.
* ``method="gauss-newton"`` (default): the minimal-L2-norm change of ``q`` that solves the
  linearised closing conditions ``J dq = -F`` (``J`` is ``k x (n dim)`` with ``k`` closing
  conditions; ``J J^*`` is ``k x k`` and is assembled from the same adjoint), with the same
  line search. Each step is the least change *of that step* that solves the linearised
  conditions, so the result is closed but only closest to the original to first order (it
  is not the minimiser of ``||q - q_orig||``); it converges quadratically. The closed curve
  nearest the original in SRV L2 is :func:`elastic_motion.closing.project_closed`. In
  ``R^d`` Gauss-Newton is exactly the Newton projection with the basis of paper 001,
  Thm. 2 (:func:`elastic_motion.closing.project_closed_rd`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from elastic_motion.closing.options import ClosingOptions, solver_options
from elastic_motion.closing.problem import ClosingProblem, ClosingState, CutLocus, l2_norm
from elastic_motion.closing.result import ClosingResult, SolverLog
from elastic_motion.curves import DiscreteCurve, SRVFunction

__all__ = ["ClosingGradient", "close_curve", "closing_gradient"]


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
        Coordinates to close (:func:`~elastic_motion.closing.closing_mask`).
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
    options = ClosingOptions(
        method="gradient",
        factors=factors,
        c1=c1,
        c1_weight=c1_weight,
        gradient=gradient,  # type: ignore[arg-type]
        log_term=log_term,  # type: ignore[arg-type]
        cut_locus_tol=1e-9,
    )
    prob = ClosingProblem.from_curve(curve, options)
    s = prob.evaluate_checked(prob.to_internal(prob.srv.q))
    bs, be = prob.blocks(s, exact_dexp=gradient == "exact", log_term=log_term)
    g = prob.adjoint(s, bs, be, prob.residual(s))
    return ClosingGradient(phi=prob.objective(s), gradient=prob.to_group(g))


def close_curve(
    curve: DiscreteCurve | SRVFunction, options: ClosingOptions | None = None, **overrides: Any
) -> ClosingResult:
    """Close a curve (make its last sample equal its first) by changing its SRV function.

    Minimises the discrete ``Phi(q) = 1/2 |F_0(q)|^2`` (paper 000, eq. 11; plus
    ``c1_weight/2 |F_1|^2`` with ``c1``) over ``q`` from the curve's own SRV function, the
    first sample fixed, by one of the two flows (module docstring; the residuals and the
    gradient: :mod:`elastic_motion.closing.problem`).

    Parameters
    ----------
    curve : DiscreteCurve or SRVFunction
        ``n+1 >= 3`` samples in a group built from ``Euclidean`` and ``SO3``.
    options : ClosingOptions, optional
        Default ``ClosingOptions(method="gauss-newton")``: tolerance 1e-6 (``gap <= tol``, and
        ``velocity_gap <= tol`` with ``c1``; with unit weights radians for rotations), at most
        100 iterations. Read here: ``method`` (``"gauss-newton"`` or ``"gradient"``),
        ``factors``, ``c1``, ``c1_weight``, ``tol``, ``max_iter``, ``gradient`` and
        ``log_term`` (the gradient flow's direction; Gauss-Newton always uses the exact
        Jacobian), ``step`` (the gradient flow's first trial step; Gauss-Newton tries 1),
        ``armijo``, ``max_backtracks``, ``keep_free``, ``cut_locus_tol``, ``rotation_names``.
    **overrides
        Fields of ``options`` (``close_curve(curve, method="gradient", tol=1e-9)``).

    Returns
    -------
    ClosingResult

    Raises
    ------
    ValueError
        Fewer than 3 samples; a group outside the family; a seam rotation at angle pi on a
        closed copy (``rotation_names`` name it); bad option values (``OptionError``).

    Notes
    -----
    Cost per iteration: ``O(n m)`` 3x3 products for ``m`` rotations and, for Gauss-Newton,
    a ``k x k`` solve with ``k`` closing conditions and ``O(n k^2)`` to assemble ``J J^*``.
    A curve that is already closed (within ``tol``) is returned unchanged (0 iterations).
    """
    t_begin = time.perf_counter()
    opts = solver_options("flows", "gauss-newton", options, overrides)
    prob = ClosingProblem.from_curve(curve, opts)
    state = prob.evaluate_checked(prob.to_internal(prob.srv.q))
    log = SolverLog(
        gaps=[float(np.linalg.norm(state.f0))],
        velocity_gaps=[float(np.linalg.norm(state.f1))],
        objective=[prob.objective(state)],
        started=t_begin,
    )
    state = _descend(prob, state, opts, log)
    out_curve, closed = prob.closed_output(
        curve, prob.to_group(state.q), moved=log.iterations > 0, keep_free=opts.keep_free
    )
    return ClosingResult(
        curve=out_curve,
        srv=closed,
        method=opts.method,
        gradient=opts.gradient,
        rotation_gaps=state.rot_gaps,
        translation_gaps=state.eu_gaps,
        change=l2_norm(closed.q - prob.srv.q, prob.srv.dt),
        **log.summary(),
    )


def _descend(prob: ClosingProblem, state: ClosingState, opts: ClosingOptions, log: SolverLog) -> ClosingState:
    """The flow's iterations from ``state`` (``log`` holds its start); returns the last state."""
    tol, max_iter = opts.tolerance, opts.iterations

    def done(s: ClosingState) -> bool:
        return bool(np.linalg.norm(s.f0) <= tol and (not opts.c1 or np.linalg.norm(s.f1) <= tol))

    phi = log.objective[-1]
    log.converged = done(state)
    log.message = "already closed" if log.converged else f"reached max_iter = {max_iter}"
    while not log.converged and log.iterations < max_iter:
        f = prob.residual(state)
        blocks = prob.blocks(state)
        g_exact = prob.adjoint(state, *blocks, f)
        if opts.method == "gauss-newton":
            d, alpha = _gauss_newton_step(prob, state, blocks, f), 1.0
        else:
            d, alpha = _gradient_step(prob, state, blocks, f, g_exact, opts)
        slope = float(np.einsum("i,ij,ij->", prob.h, g_exact, d))
        if not slope < 0:
            log.message = "the search direction does not decrease the gap (stationary point?)"
            break
        accepted, alpha = _line_search(prob, state.q, d, (alpha, phi, slope), opts)
        if accepted is None:
            log.message = f"line search failed after {opts.max_backtracks} halvings (gap {log.gaps[-1]:.3g})"
            break
        state, phi = accepted, prob.objective(accepted)
        log.record(
            step=alpha,
            gap=float(np.linalg.norm(state.f0)),
            velocity_gap=float(np.linalg.norm(state.f1)),
            objective=phi,
        )
        if done(state):
            log.converged = True
            log.message = f"converged in {log.iterations} iterations"
    return state


def _gauss_newton_step(
    prob: ClosingProblem, state: ClosingState, blocks: tuple[np.ndarray, np.ndarray], f: np.ndarray
) -> np.ndarray:
    """The minimal-norm ``d = J^* z`` with ``(J J^* + mu I) z = -F`` on the closed rows
    (``mu`` a relative 1e-13 shift; least squares when the solve fails)."""
    sel = prob.sel
    gmat = prob.gram(state, *blocks)[np.ix_(sel, sel)]
    mu = 1e-13 * max(float(np.trace(gmat)) / max(gmat.shape[0], 1), 1e-300)
    rhs = -f[sel]
    try:
        zsel = np.linalg.solve(gmat + mu * np.eye(gmat.shape[0]), rhs)
    except np.linalg.LinAlgError:
        zsel = np.linalg.lstsq(gmat, rhs, rcond=None)[0]
    z = np.zeros_like(f)
    z[sel] = zsel
    return prob.adjoint(state, *blocks, z)


def _gradient_step(
    prob: ClosingProblem,
    state: ClosingState,
    blocks: tuple[np.ndarray, np.ndarray],
    f: np.ndarray,
    g_exact: np.ndarray,
    opts: ClosingOptions,
) -> tuple[np.ndarray, float]:
    """Steepest descent along the chosen gradient and its first trial step (``opts.step``, or
    the minimiser of the linearised objective along it: the Cauchy step)."""
    if opts.gradient == "exact" and opts.log_term == "general":
        gd = g_exact
    else:
        bsd, bed = prob.blocks(state, exact_dexp=opts.gradient == "exact", log_term=opts.log_term)
        gd = prob.adjoint(state, bsd, bed, f)
    d = -gd
    if opts.step is not None:
        return d, opts.step
    jd = prob.forward(state, *blocks, d)[prob.sel]
    denom = float(jd @ jd)
    alpha = -float(f[prob.sel] @ jd) / denom if denom > 0 else 1.0
    if not alpha > 0:
        alpha = 1.0
    return d, alpha


def _line_search(
    prob: ClosingProblem,
    q: np.ndarray,
    d: np.ndarray,
    start: tuple[float, float, float],
    opts: ClosingOptions,
) -> tuple[ClosingState | None, float]:
    """Armijo backtracking from ``q`` along ``d``; ``start = (first step, Phi(q), slope)``.
    Returns the accepted state (None after ``max_backtracks`` halvings) and its step; a step
    that reaches the cut locus is halved."""
    alpha, phi, slope = start
    for _ in range(opts.max_backtracks + 1):
        try:
            trial = prob.evaluate(q + alpha * d)
        except CutLocus:
            alpha *= 0.5
            continue
        phi_t = prob.objective(trial)
        if np.isfinite(phi_t) and phi_t <= phi + opts.armijo * alpha * slope:
            return trial, alpha
        alpha *= 0.5
    return None, alpha
