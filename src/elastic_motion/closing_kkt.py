"""The closed curve nearest the original: the constrained projection (paper 000, sec. 4).

:func:`elastic_motion.closing.close_curve` drives the seam gap to zero by Gauss-Newton
steps, each the least change *of that step*: the closed curve it reaches is nearest the
original only to first order. This module solves the projection itself,

    minimise    1/2 ||q - q_orig||_L2^2 = 1/2 sum_i h_i |q_i - q_orig_i|^2
    subject to  F(q) = 0,

``q`` the SRV function (cell values, orthonormal coordinates, see
:mod:`elastic_motion.curves`), ``F`` the closing conditions of
:mod:`elastic_motion.closing` (the selected rows of ``log r``, of the swing of the root
about the up axis, of the closed Euclidean coordinates of ``c_n - c_0``; with ``c1`` also
the seam velocity rows), the first sample fixed. It holds for every group of the product
family, ``R^d`` included (there ``F(q) = sum_i h_i |q_i| q_i`` on the closed coordinates,
paper 001, Thm. 2, and the result is the nearest closed curve, not the Newton projection
:func:`elastic_motion.closing.project_closed_rd` that stops at the first closed curve).

Method: SQP with the identity as the Hessian model of the Lagrangian (the objective's own
Hessian). At ``q`` with ``e = q - q_orig`` the quadratic subproblem
``min 1/2 ||e + d||^2  s.t.  F + J d = 0`` has the solution
``d = -e + J^* lambda``, ``(J J^*) lambda = -F + J e``, i.e. the next iterate is
``q_orig + J(q)^* lambda``; ``J`` is the exact discrete Jacobian of
:mod:`elastic_motion.closing` (``J_i = B_i M_i``, ``J J^*`` assembled from the same blocks).
A fixed point satisfies the first-order (KKT) conditions exactly: ``F(q) = 0`` and
``q - q_orig = J^* lambda``. Steps are globalised by a backtracking line search on the
exact penalty ``1/2 ||e||^2 + rho |F|`` (``rho`` above ``|lambda|``), so the iteration
converges to a KKT point from the original curve (its first step is the Gauss-Newton step).
Convergence is linear with a rate set by the curvature of the constraints times
``|lambda|``: small for real closings (a few to a few dozen iterations).

Stopping: ``|F| <= tol`` and the **KKT residual**
``|e - J^* lambda_ls|_L2 / |e|_L2 <= kkt_tol``, ``lambda_ls`` the least-squares multipliers
``(J J^*)^{-1} J e`` at the point (the part of the change not normal to the constraint
set; 0 exactly at a KKT point). When the residual stops decreasing on a closed curve (its
rounding floor, about ``1e-9`` relative on 600-frame clips) the solver stops and says so.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

import numpy as np

from elastic_motion.closing import (
    ClosingResult,
    _closed_output,
    _CutLocus,
    _evaluate_or_raise,
    _l2,
    _Problem,
    _problem,
    _State,
)
from elastic_motion.curves import DiscreteCurve, SRVFunction
from elastic_motion.groups import SO3

__all__ = ["ExtraConstraints", "kkt_residual", "project_closed"]

_SO3 = SO3()


class ExtraConstraints:
    """Equality constraints ``g(c) = 0`` on the integrated curve, besides closure (interface).

    :func:`project_closed` calls :meth:`evaluate` with the curve the solver integrated and
    treats the rows like the closing conditions (same projection, same KKT conditions). The
    curve is given by its ``SO(3)`` part and its Euclidean part, in the layout of the group
    (Euclidean coordinates in algebra order, then the ``SO(3)`` copies in algebra order), the
    Euclidean coordinates that are not closed replaced by the original samples (what
    ``keep_free`` returns).
    """

    def evaluate(
        self, rot: np.ndarray, eu: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Residuals and their derivative (each row depends on the samples of a few frames).

        Parameters
        ----------
        rot : ndarray, shape (n+1, m, 3, 3)
            The rotations of every sample.
        eu : ndarray, shape (n+1, e)
            The Euclidean coordinates of every sample (natural units).

        Returns
        -------
        g : ndarray, shape (R,)
        frames : ndarray of int, shape (R, S)
            The samples row ``r`` depends on (``-1``: unused slot).
        d_rot : ndarray, shape (R, S, m, 3)
            ``dg / d omega`` for a left perturbation ``delta R = hat(omega) R`` of sample
            ``frames[r, s]``'s rotation of copy ``b`` (the solver chains it through the
            ``exp`` steps).
        d_eu : ndarray, shape (R, S, e)
            ``dg / d c`` of the Euclidean coordinates of that sample.
        """
        raise NotImplementedError

    def residual(self, rot: np.ndarray, eu: np.ndarray) -> np.ndarray:
        """``g`` alone (default: from :meth:`evaluate`)."""
        return self.evaluate(rot, eu)[0]


def _eu_samples(prob: _Problem, s: _State) -> np.ndarray:
    """The Euclidean samples ``(n+1, e)`` (natural units) of a state's curve."""
    ne = prob.ne
    steps = s.x[:, :ne] * (prob.h[:, None] / prob.layout.s_eu)
    return prob.start_eu + np.concatenate([np.zeros((1, ne)), np.cumsum(steps, axis=0)])


def _solve(gmat: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    mu = 1e-14 * max(float(np.trace(gmat)) / max(gmat.shape[0], 1), 1e-300)
    try:
        return np.linalg.solve(gmat + mu * np.eye(gmat.shape[0]), rhs)
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(gmat, rhs, rcond=None)[0]


class _Linear:
    """The constraint linearisation at one point: ``J``, ``J^*`` and ``J J^*`` on the selected rows."""

    def __init__(self, prob: _Problem, s: _State) -> None:
        self.prob, self.s = prob, s
        self.bs, self.be = prob.blocks(s)
        self.sel = prob.sel
        self._gmat: np.ndarray | None = None
        self.f = prob.residual(s)
        self.fsel = self.f[self.sel]

    @property
    def gmat(self) -> np.ndarray:
        """``J J^*`` on the selected rows (assembled on first use: Hessian products need only ``J^*``)."""
        if self._gmat is None:
            self._gmat = self.prob.gram(self.s, self.bs, self.be)[np.ix_(self.sel, self.sel)]
        return self._gmat

    def forward(self, d: np.ndarray) -> np.ndarray:
        return self.prob.forward(self.s, self.bs, self.be, d)[self.sel]

    def adjoint(self, lam: np.ndarray) -> np.ndarray:
        z = np.zeros_like(self.f)
        z[self.sel] = lam
        return self.prob.adjoint(self.s, self.bs, self.be, z)


class _DenseLinear:
    """Closing rows plus extra constraint rows, as a dense Jacobian ``(R, n, dim)`` (internal order)."""

    def __init__(self, prob: _Problem, s: _State, extra: ExtraConstraints, eu_orig: np.ndarray) -> None:
        self.prob, self.s = prob, s
        n, m, ne, dim = prob.n, prob.m, prob.ne, prob.layout.dim
        lay, sp = prob.layout, prob.spec
        bs, be = prob.blocks(s)
        full = prob.residual(s)
        sel = prob.sel
        k = be.shape[-1]
        # closing rows: row (g, internal coordinate) of the full residual; w.r.t. M_i dq_i
        jf = np.zeros((k * dim, n, dim))
        for g in range(k):
            if ne:
                idx = g * dim + np.arange(ne)
                jf[idx, :, np.arange(ne)] = be[:, :, g].T
            for b in range(m):
                r0 = g * dim + ne + 3 * b
                jf[r0 : r0 + 3, :, ne + 3 * b : ne + 3 * b + 3] = np.transpose(
                    bs[:, b, 3 * g : 3 * g + 3, :], (1, 0, 2)
                )
        jf = jf[sel]
        # extra rows through the exp steps: the natural steps u_i = h_i x_i / s
        eu = np.where(sp.eu_closed, _eu_samples(prob, s), eu_orig)
        g_x, frames, d_rot, d_eu = extra.evaluate(s.rot, eu)
        r = g_x.shape[0]
        je = np.zeros((r, n, dim))
        # a sample f depends on the cells i < f: "before[r, s, i]" = i < frames[r, s]
        before = (np.arange(n)[None, None, :] < frames[:, :, None]).astype(np.float64)  # (R, S, n)
        # delta eu_f = sum_{i<f} delta u_i (closed coordinates only)
        tail_eu = np.einsum("rsi,rse->rie", before, d_eu)
        je[:, :, :ne] = np.where(sp.eu_closed, tail_eu, 0.0) / lay.s_eu
        if m:
            # delta R_f R_f^T = sum_{i<f} R_f R_{i+1}^T dexp_{u_i} delta u_i
            fr = np.maximum(frames, 0)
            d_back = np.einsum("rsbj,rsbjk->rsbk", d_rot, s.rot[fr])  # (dg/domega_f) R_f
            tail = np.einsum("rsi,rsbk->ribk", before, d_back)  # (R, n, m, 3): sum over f > i
            dmat = _SO3.dexp_matrix(s.u_so3)  # (n, m, 3, 3)
            a = np.einsum("fbji,fbjk->fbik", s.rot[1:], dmat)  # R_{i+1}^T dexp_{u_i}
            ju = np.einsum("ribj,ibjk->ribk", tail, a)
            je[:, :, ne:] = (ju / lay.s_so3[:, None]).reshape(r, n, 3 * m)
        je *= prob.h[None, :, None]
        jm = np.concatenate([jf, je], axis=0)
        # J_i = (rows w.r.t. M_i dq_i) M_i, M_i symmetric
        qn = np.where(s.qn > 0, s.qn, 1.0)
        coef = np.einsum("rij,ij->ri", jm, s.q) / qn
        self.jac = jm * s.qn[None, :, None] + coef[:, :, None] * s.q[None] * (s.qn > 0)[None, :, None]
        self.h = prob.h
        self.fsel = np.concatenate([full[sel], g_x])
        self.n_extra = r
        self._gmat: np.ndarray | None = None

    @property
    def gmat(self) -> np.ndarray:
        """``J J^*`` (assembled on first use: the Hessian products need only ``J^*``)."""
        if self._gmat is None:
            flat = self.jac.reshape(self.jac.shape[0], -1)
            w = np.repeat(1.0 / self.h, self.jac.shape[2])
            self._gmat = (flat * w) @ flat.T
        return self._gmat

    def forward(self, d: np.ndarray) -> np.ndarray:
        return np.einsum("ria,ia->r", self.jac, d)

    def adjoint(self, lam: np.ndarray) -> np.ndarray:
        return np.einsum("r,ria->ia", lam, self.jac) / self.h[:, None]


def _dot(h: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    return float(np.einsum("i,ij,ij->", h, a, b))


def _newton_step(
    prob: _Problem, lin: _Linear | _DenseLinear, e: np.ndarray, lam: np.ndarray, linearise, max_cg: int = 20
) -> np.ndarray:
    """SQP step with the Hessian of the Lagrangian ``W = I - sum_k lam_k Hess F_k``.

    ``W v`` by central differences of ``J(q)^* lam`` (the exact adjoint at ``q +- eps v``);
    the step is the normal step ``-J^* (J J^*)^{-1} F`` plus the minimiser of the quadratic
    model on the null space of ``J`` by projected conjugate gradients (stopped at negative
    curvature).
    """
    h, q = prob.h, lin.s.q
    scale = max(_l2(q, h), 1.0)

    def jt_lam(qq: np.ndarray) -> np.ndarray:
        return linearise(prob.evaluate(qq)).adjoint(lam)

    def wv(v: np.ndarray) -> np.ndarray:
        nv = _l2(v, h)
        if nv == 0.0:
            return np.zeros_like(v)
        eps = 1e-5 * scale / nv
        return v - (jt_lam(q + eps * v) - jt_lam(q - eps * v)) / (2.0 * eps)

    def proj(v: np.ndarray) -> np.ndarray:
        return v - lin.adjoint(_solve(lin.gmat, lin.forward(v)))

    dn = -lin.adjoint(_solve(lin.gmat, lin.fsel))
    # only the null-space part of the model gradient matters: project it once and after each
    # update (the range part of e is large, and projecting it anew each time loses accuracy)
    r = proj(e + wv(dn))
    t = np.zeros_like(e)
    zr = r
    p = -zr
    rz = _dot(h, r, zr)
    rz0 = rz
    for _ in range(max_cg):
        if rz <= 1e-6 * rz0 or rz <= 0.0:  # inexact Newton: |r| down by 1e-3
            break
        wp = wv(p)
        curv = _dot(h, p, wp)
        if curv <= 1e-12 * _dot(h, p, p):
            break
        a = rz / curv
        t = t + a * p
        r = proj(r + a * wp)
        zr = r
        rz_new = _dot(h, r, zr)
        p = -zr + (rz_new / rz) * p
        rz = rz_new
    return dn + t


def _kkt(lin: _Linear, e: np.ndarray, h: np.ndarray) -> tuple[float, np.ndarray]:
    """Relative KKT residual and least-squares multipliers at ``q = q_orig + e``."""
    lam = _solve(lin.gmat, lin.forward(e))
    ne = _l2(e, h)
    if ne == 0.0:
        return 0.0, lam
    res = e - lin.adjoint(lam)
    for _ in range(2):  # iterative refinement of the normal equations (J J^* is ill-conditioned)
        lam = lam + _solve(lin.gmat, lin.forward(res))
        res = e - lin.adjoint(lam)
    return _l2(res, h) / ne, lam


def kkt_residual(
    curve: DiscreteCurve | SRVFunction,
    original: DiscreteCurve | SRVFunction,
    *,
    factors: object = None,
    c1: bool = False,
    c1_weight: float = 1.0,
) -> tuple[float, float]:
    """First-order optimality of ``curve`` as the closed curve nearest ``original``.

    Parameters
    ----------
    curve, original : DiscreteCurve or SRVFunction
        Same group and grid; the SRV functions ``q`` and ``q_orig`` are compared (pass
        :attr:`ClosingResult.srv`: the curve's own SRVT reads steps past ``pi`` the short way).
    factors, c1, c1_weight
        The closing conditions (:func:`elastic_motion.closing.close_curve`).

    Returns
    -------
    kkt : float
        ``|e - J^* lambda_ls|_L2 / |e|_L2`` with ``e = q - q_orig`` and the least-squares
        multipliers (0 at a KKT point; 0 when ``e = 0``).
    gap : float
        ``|F(q)|``, the closing residual (0 on the constraint set).
    """
    srv, prob = _problem(curve, factors, c1, c1_weight, 0.0, None)
    srv0, _ = _problem(original, factors, c1, c1_weight, 0.0, None)
    if srv0.q.shape != srv.q.shape or not np.allclose(srv0.t, srv.t):
        raise ValueError(f"original: expected the grid of curve ({srv.q.shape}); got {srv0.q.shape}")
    s = _evaluate_or_raise(prob, prob.to_internal(srv.q))
    lin = _Linear(prob, s)
    e = prob.to_internal(srv.q) - prob.to_internal(srv0.q)
    k, _ = _kkt(lin, e, prob.h)
    return k, float(np.linalg.norm(lin.fsel))


def project_closed(
    curve: DiscreteCurve | SRVFunction,
    *,
    factors: object = None,
    c1: bool = False,
    c1_weight: float = 1.0,
    tol: float = 1e-9,
    kkt_tol: float = 1e-8,
    max_iter: int = 200,
    keep_free: bool = True,
    cut_locus_tol: float = 1e-6,
    rotation_names: Sequence[str] | None = None,
    extra: ExtraConstraints | None = None,
) -> ClosingResult:
    """The closed curve nearest ``curve`` in SRV L2 (a KKT point of the projection).

    Solves ``min 1/2 ||q - q_orig||_L2^2`` subject to the closing conditions, the first
    sample fixed (module docstring), for any group of the product family (``R^d``,
    ``SO(3)^J``, ``R^3 x SO(3)^J``).

    Parameters
    ----------
    curve : DiscreteCurve or SRVFunction
        ``n+1 >= 3`` samples.
    factors : optional
        What to close (:func:`elastic_motion.closing.closing_mask`): default everything.
    c1 : bool
        Also match the seam velocities (the C1 rows of :func:`~elastic_motion.closing.close_curve`).
    c1_weight : float
        Scale of the velocity rows (constraints: the solution does not depend on it, only
        the conditioning does).
    tol : float
        Feasibility: stop when the closing residual's norm is ``<= tol``.
    kkt_tol : float
        Optimality: and the relative KKT residual is ``<= kkt_tol``.
    max_iter : int
    keep_free : bool
        Put back the original samples of free coordinates in the returned ``curve`` (they
        do not affect the gap); ``srv`` keeps the solver's values.
    cut_locus_tol : float
        Distance to ``pi`` at which a closed seam rotation is on log's cut locus.
    rotation_names : sequence of str, optional
        One name per ``SO(3)`` copy, for error messages.
    extra : ExtraConstraints, optional
        More equality constraints on the integrated curve (e.g. contacts of a motion), solved
        in the same projection; their rows follow the closing rows in ``multipliers``. The
        Jacobian is then assembled densely (``R x n x dim`` numbers for ``R`` rows).

    Returns
    -------
    ClosingResult
        ``method = "kkt"``; ``change`` is ``||q - q_orig||_L2``, ``kkt_residual`` the
        relative KKT residual at the result, ``multipliers`` the Lagrange multipliers of
        the selected closing rows; ``objective_history`` holds ``1/2 ||q - q_orig||^2``.

    Raises
    ------
    ValueError
        As :func:`~elastic_motion.closing.close_curve` (fewer than 3 samples, a seam at the
        cut locus, bad options).
    """
    t_begin = time.perf_counter()
    if int(max_iter) != max_iter or max_iter < 0:
        raise ValueError(f"max_iter: expected a non-negative integer; got {max_iter!r}")
    for name, v in (("tol", tol), ("kkt_tol", kkt_tol)):
        if not (math.isfinite(v) and v >= 0):
            raise ValueError(f"{name}: expected a non-negative number; got {v!r}")
    srv, prob = _problem(curve, factors, c1, c1_weight, cut_locus_tol, rotation_names)
    h = prob.h
    q0 = prob.to_internal(srv.q)
    q = q0.copy()
    state = _evaluate_or_raise(prob, q)
    eu_orig = _eu_samples(prob, state)

    def linearise(st: _State) -> _Linear | _DenseLinear:
        return _DenseLinear(prob, st, extra, eu_orig) if extra is not None else _Linear(prob, st)

    def feasibility(st: _State) -> float:
        f = prob.residual(st)[prob.sel]
        if extra is not None:
            eu = np.where(prob.spec.eu_closed, _eu_samples(prob, st), eu_orig)
            f = np.concatenate([f, extra.residual(st.rot, eu)])
        return float(np.linalg.norm(f))

    lin = linearise(state)
    e = q - q0
    kkt, lam = _kkt(lin, e, h)
    feas = float(np.linalg.norm(lin.fsel))
    gaps = [float(np.linalg.norm(state.f0))]
    vgaps = [float(np.linalg.norm(state.f1))]
    objs = [0.0]
    steps: list[float] = []
    kkts = [kkt]
    rho = 0.0
    it = 0
    converged = feas <= tol and kkt <= kkt_tol
    message = "already closed" if converged else f"reached max_iter = {max_iter}"
    newton = False
    while not converged and it < max_iter:
        lam_step = _solve(lin.gmat, -lin.fsel + lin.forward(e))
        rho = max(rho, 2.0 * float(np.linalg.norm(lam_step)) + 1e-12)
        merit = 0.5 * _l2(e, h) ** 2 + rho * feas
        accepted = None
        directions = []
        if newton:
            try:  # fewer CG steps with extra rows (each Hessian product rebuilds their Jacobian)
                directions.append(
                    _newton_step(prob, lin, e, lam, linearise, max_cg=12 if extra is None else 6)
                )
            except _CutLocus:
                pass
        directions.append(-e + lin.adjoint(lam_step))  # identity Hessian model (fallback)
        for d in directions:
            slope = _dot(h, e, d) - rho * feas
            alpha = 1.0
            # near the solution the merit function cannot resolve the step (its decrease is
            # below rounding): take the full step while it keeps the curve closed
            tiny = _l2(d, h) <= 1e-6 * max(_l2(e, h), 1e-300)
            for _ in range(40):
                try:
                    trial = prob.evaluate(q + alpha * d)
                except _CutLocus:
                    alpha *= 0.5
                    continue
                et = trial.q - q0
                ft = feasibility(trial)
                mt = 0.5 * _l2(et, h) ** 2 + rho * ft
                if np.isfinite(mt) and (
                    mt <= merit + 1e-4 * alpha * min(slope, 0.0) or (tiny and ft <= max(feas, tol))
                ):
                    accepted = trial
                    break
                alpha *= 0.5
            if accepted is not None:
                break
        if accepted is None:
            message = f"line search failed (gap {feas:.3g}, KKT residual {kkt:.3g})"
            break
        state, q = accepted, accepted.q
        e = q - q0
        lin = linearise(state)
        kkt, lam = _kkt(lin, e, h)
        feas = float(np.linalg.norm(lin.fsel))
        it += 1
        steps.append(alpha)
        gaps.append(float(np.linalg.norm(state.f0)))
        vgaps.append(float(np.linalg.norm(state.f1)))
        objs.append(0.5 * _l2(e, h) ** 2)
        kkts.append(kkt)
        if feas <= tol and kkt <= kkt_tol:
            converged = True
            message = f"converged in {it} iterations (KKT residual {kkt:.2g})"
        elif newton and feas <= tol and len(kkts) > 4 and kkt > 0.5 * min(kkts[-4:-1]):
            message = f"stalled at KKT residual {kkt:.2g} after {it} iterations (rounding floor)"
            break
        elif not newton and kkt > 0.2 * kkts[-2]:
            newton = True  # the identity model converges slowly here: use the Lagrangian's Hessian

    q_final = prob.to_group(q)
    out_curve, closed = _closed_output(prob, curve, srv, q_final, moved=it > 0, keep_free=keep_free)
    return ClosingResult(
        curve=out_curve,
        srv=closed,
        gap=gaps[-1],
        gap_initial=gaps[0],
        velocity_gap=vgaps[-1],
        velocity_gap_initial=vgaps[0],
        history=np.asarray(gaps),
        velocity_history=np.asarray(vgaps),
        objective_history=np.asarray(objs),
        steps=np.asarray(steps),
        iterations=it,
        converged=converged,
        message=message,
        time=time.perf_counter() - t_begin,
        method="kkt",
        gradient="exact",
        rotation_gaps=state.rot_gaps,
        translation_gaps=state.eu_gaps,
        change=_l2(q_final - srv.q, h),
        kkt_residual=kkt,
        multipliers=lam,
    )
