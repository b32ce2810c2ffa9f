"""Paper 001's Newton projection onto closed curves in ``R^d`` (Thm. 2).

The closed curves are ``{q : integral |q| q dt = 0}`` (discretely
``sum_i h_i |q_i| q_i = 0`` on the closed coordinates). Paper 001, Thm. 2 gives the normal
basis ``U_k(q) = (q_k q + |q|^2 e_k) / |q|``; Newton's method solves
``sum_l <U_k, U_l>_L2 beta_l = -F_k`` (Gram matrix ``delta_kl int |q|^2 + 3 int q_k q_l``) and
moves ``q <- q + sum_k beta_k U_k``, backtracking when the residual would grow. It stops at
the first closed curve it reaches, not at the nearest one
(:func:`elastic_motion.closing.project_closed`).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from elastic_motion.closing.options import ClosingOptions, solver_options
from elastic_motion.closing.problem import GroupLayout, as_srv, closing_mask, group_layout, l2_norm
from elastic_motion.closing.result import ClosingResult, SolverLog
from elastic_motion.curves import DiscreteCurve, SRVFunction, inverse_srv_transform

__all__ = ["project_closed_rd"]


def project_closed_rd(
    curve: DiscreteCurve | SRVFunction, options: ClosingOptions | None = None, **overrides: Any
) -> ClosingResult:
    """Project a curve in ``R^d`` onto closed curves (paper 001, Thm. 2; Newton).

    Parameters
    ----------
    curve : DiscreteCurve or SRVFunction
        At least 3 samples in a group made only of Euclidean factors (weights allowed:
        everything is done in orthonormal coordinates).
    options : ClosingOptions, optional
        Default ``ClosingOptions(method="newton")``: stop when the weighted norm of
        ``c_n - c_0`` (closed coordinates) is ``<= tol`` (default 1e-10), at most
        ``max_iter`` (50) iterations. Read here: ``factors``, ``tol``, ``max_iter`` and
        ``keep_free`` (put back the original samples of the coordinates that are not closed).
    **overrides
        Fields of ``options`` (``project_closed_rd(curve, factors=mask, tol=1e-12)``).

    Returns
    -------
    ClosingResult
        With ``method = "newton"``.
    """
    t_begin = time.perf_counter()
    opts = solver_options("newton", "newton", options, overrides)
    srv = as_srv(curve)
    lay = group_layout(srv.group)
    if lay.so3_alg.size:
        raise ValueError(f"curve: expected a curve in R^d (Euclidean factors only); got group {srv.group!r}")
    if srv.q.shape[0] + 1 < 3:
        raise ValueError(f"curve: expected at least 3 samples to close; got {srv.q.shape[0] + 1}")
    mask = closing_mask(srv.group, opts.factors)
    newton = _Newton(srv.dt, np.flatnonzero(mask))
    q = np.array(srv.q)
    f = newton.residual(q)
    log = SolverLog(
        gaps=[float(np.linalg.norm(f))], velocity_gaps=[newton.velocity_gap(q)], objective=[], started=t_begin
    )
    q, f = newton.iterate(q, f, log, opts)
    log.objective = 0.5 * np.asarray(log.gaps) ** 2
    out = _output(
        curve, srv, q, moved=log.iterations > 0, free=lay.eu_pt[~mask[lay.eu_alg]] if opts.keep_free else None
    )
    return ClosingResult(
        curve=out,
        srv=srv if log.iterations == 0 else SRVFunction(q, srv.t, srv.start, srv.group),
        method="newton",
        gradient="exact",
        rotation_gaps=np.zeros(0),
        translation_gaps=_translation_gaps(lay, newton.idx, f),
        change=l2_norm(q - srv.q, srv.dt),
        **log.summary(),
    )


class _Newton:
    """The closure residual of the closed coordinates ``idx`` on cells of widths ``h``, and
    Newton's steps with paper 001's normal basis."""

    def __init__(self, h: np.ndarray, idx: np.ndarray) -> None:
        self.h, self.idx = h, idx

    def residual(self, qq: np.ndarray) -> np.ndarray:
        """``sum_i h_i |q_i| q_i`` on the closed coordinates."""
        qn = np.sqrt(np.einsum("ij,ij->i", qq, qq))
        return (self.h * qn) @ qq[:, self.idx]

    def velocity_gap(self, qq: np.ndarray) -> float:
        """The seam velocity mismatch ``|(x_{n-1} - x_0) / n|``, ``x = |q| q``, closed coordinates."""
        qn = np.sqrt(np.einsum("ij,ij->i", qq, qq))
        x = qn[:, None] * qq
        return float(np.linalg.norm((x[-1, self.idx] - x[0, self.idx]) / qq.shape[0]))

    def direction(self, q: np.ndarray, f: np.ndarray) -> np.ndarray:
        """The Newton step ``sum_k beta_k U_k(q)``."""
        h, idx = self.h, self.idx
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
        return ((q @ b)[:, None] * q + np.outer(qn**2, b)) / safe[:, None]

    def iterate(
        self, q: np.ndarray, f: np.ndarray, log: SolverLog, opts: ClosingOptions
    ) -> tuple[np.ndarray, np.ndarray]:
        """Newton steps from ``q`` (residual ``f``), halving a step until it reduces the gap;
        returns the last ``q`` and its residual."""
        tol, max_iter = opts.tolerance, opts.iterations
        log.converged = log.gaps[0] <= tol
        log.message = "already closed" if log.converged else f"reached max_iter = {max_iter}"
        while not log.converged and log.iterations < max_iter:
            d = self.direction(q, f)
            alpha = 1.0
            for _ in range(40):
                f_new = self.residual(q + alpha * d)
                if np.linalg.norm(f_new) < np.linalg.norm(f):
                    break
                alpha *= 0.5
            else:
                log.message = "Newton step does not reduce the gap"
                break
            q = q + alpha * d
            f = f_new
            log.record(
                step=alpha, gap=float(np.linalg.norm(f)), velocity_gap=self.velocity_gap(q), objective=None
            )
            if log.gaps[-1] <= tol:
                log.converged = True
                log.message = f"converged in {log.iterations} iterations"
        return q, f


def _output(
    curve: DiscreteCurve | SRVFunction,
    srv: SRVFunction,
    q: np.ndarray,
    *,
    moved: bool,
    free: np.ndarray | None,
) -> DiscreteCurve:
    """The closed curve of ``q``; the raveled coordinates ``free`` get the original samples back."""
    if not moved:
        return curve if isinstance(curve, DiscreteCurve) else inverse_srv_transform(srv)
    out = inverse_srv_transform(SRVFunction(q, srv.t, srv.start, srv.group))
    if free is not None and free.size:
        original = curve if isinstance(curve, DiscreteCurve) else inverse_srv_transform(srv)
        vals = np.array(out.values).reshape(out.n_points, -1)
        vals[:, free] = np.asarray(original.values).reshape(original.n_points, -1)[:, free]
        out = DiscreteCurve(vals.reshape(out.values.shape), srv.group, srv.t)
    return out


def _translation_gaps(lay: GroupLayout, idx: np.ndarray, f: np.ndarray) -> np.ndarray:
    """``|c_n - c_0|`` per coordinate (natural units; 0 on free ones)."""
    eu_gaps = np.zeros(lay.dim)
    eu_gaps[idx] = np.abs(f) / lay.s_eu[idx]  # pure R^d: Euclidean order is algebra order
    return eu_gaps
