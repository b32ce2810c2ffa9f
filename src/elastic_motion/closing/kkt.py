"""The closed curve nearest the original: the constrained projection (paper 000, sec. 4).

:func:`elastic_motion.closing.close_curve` drives the seam gap to zero by Gauss-Newton
steps, each the least change *of that step*: the closed curve it reaches is nearest the
original only to first order. This module solves the projection itself,

    minimise    1/2 ||q - q_orig||_L2^2 = 1/2 sum_i h_i |q_i - q_orig_i|^2
    subject to  F(q) = 0,

``q`` the SRV function (cell values, orthonormal coordinates, see
:mod:`elastic_motion.curves`), ``F`` the closing conditions of
:mod:`elastic_motion.closing.problem` (the selected rows of ``log r``, of the swing of the root
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
:mod:`elastic_motion.closing.problem` (``J_i = B_i M_i``, ``J J^*`` assembled from the same blocks).
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

import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg
import scipy.sparse

from elastic_motion.closing.options import ClosingOptions, solver_options
from elastic_motion.closing.problem import ClosingProblem, ClosingState, CutLocus, l2_norm
from elastic_motion.closing.result import ClosingResult, SolverLog
from elastic_motion.closing.structured import ExtraRowsSystem, StructuredGram, structured_pays
from elastic_motion.curves import DiscreteCurve, SRVFunction

__all__ = ["ExtraConstraints", "kkt_residual", "project_closed"]

#: Atoms per chunk of the cross block and the trace (bounds their per-atom prefixes to a few MB).
_ATOM_CHUNK = 512


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


def _eu_samples(prob: ClosingProblem, s: ClosingState) -> np.ndarray:
    """The Euclidean samples ``(n+1, e)`` (natural units) of a state's curve."""
    ne = prob.ne
    steps = s.x[:, :ne] * (prob.h[:, None] / prob.layout.s_eu)
    return prob.start_eu + np.concatenate([np.zeros((1, ne)), np.cumsum(steps, axis=0)])


def _solve(lin: _Linear | _ExtraLinear, rhs: np.ndarray) -> np.ndarray:
    """``(J J^* + mu I)^{-1} rhs`` at one linearisation (LU factors kept on ``lin``: the
    normal step, the projections of the CG loop and the multipliers share them)."""
    if lin._factor is None and isinstance(lin, _ExtraLinear) and lin.structured_pays():
        # thousands of extra rows (a loop's kept contacts): the sparse structure, not R x R
        try:
            lin._factor = ("structured", lin.structured())
        except RuntimeError:  # an exactly singular pivot (SuperLU): the dense fallbacks below
            pass
    if lin._factor is None:
        gmat = lin.gmat
        # (a relative 1e-12 shift: dependent rows, e.g. a foot and its toe planted together,
        # make J J^* singular; the multipliers are refined against the exact J in _kkt)
        mu = 1e-12 * max(float(np.trace(gmat)) / max(gmat.shape[0], 1), 1e-300)
        reg = gmat + mu * np.eye(gmat.shape[0])
        try:  # J J^* is symmetric positive (semi)definite: Cholesky, else LU
            lin._factor = ("cho", scipy.linalg.cho_factor(reg, check_finite=False))
        except np.linalg.LinAlgError:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", scipy.linalg.LinAlgWarning)
                lu = scipy.linalg.lu_factor(reg, check_finite=False)
            # an exactly singular Gram matrix (dependent rows): least squares instead
            lin._factor = ("lu", lu) if np.all(np.diag(lu[0]) != 0.0) else ("lstsq", None)
    kind, fac = lin._factor
    if kind == "structured":
        return fac.solve(rhs)
    if kind == "cho":
        return scipy.linalg.cho_solve(fac, rhs, check_finite=False)
    if kind == "lu":
        return scipy.linalg.lu_solve(fac, rhs, check_finite=False)
    return np.linalg.lstsq(lin.gmat, rhs, rcond=None)[0]


class _Linear:
    """The constraint linearisation at one point: ``J``, ``J^*`` and ``J J^*`` on the selected rows."""

    def __init__(self, prob: ClosingProblem, s: ClosingState) -> None:
        self.prob, self.s = prob, s
        self.bs, self.be = prob.blocks(s)
        self.sel = prob.sel
        self._gmat: np.ndarray | None = None
        self._factor: tuple | None = None
        self.f = prob.residual(s)
        self.fsel = self.f[self.sel]

    def release(self) -> None:
        """Drop the Gram matrix and its factors (rebuilt if asked for again)."""
        self._gmat, self._factor = None, None

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


class _ExtraLinear:
    """Closing rows plus extra constraint rows, without forming their Jacobian (internal order).

    An extra row depends on the curve's samples at a few frames (``ExtraConstraints``), and
    sample ``f`` on the cells ``i < f``: with the per-cell maps ``A_i = R_{i+1}^T dexp_{u_i}``
    (``SO(3)`` copies) the perturbation of sample ``f`` is a prefix sum over cells,
    ``delta R_f R_f^T = R_f sum_{i<f} (h_i / s) A_i (M_i dq_i)`` and
    ``delta c_f = sum_{i<f} (h_i / s) (M_i dq_i)`` (closed Euclidean coordinates). So

    * ``J d`` is one prefix sum over the cells and a gather at the rows' frames, and
      ``J^* lambda`` one scatter at the frames and a suffix sum: ``O(n dim + R)``;
    * ``J J^*`` of the extra rows is, with ``D_a`` the row's derivative at its frame ``f_a``
      (pulled back by ``R_f``) and ``K(k) = sum_{i<k} C_i`` the prefix of the cells' Gram
      blocks, ``D_a^T K(min(f_a, f_b)) D_b`` plus the rank-one part of ``M_i^2``: two
      ``R x dim x R`` products (no ``R x n x dim`` Jacobian).

    The dense Jacobian this replaces is kept in the tests as the reference implementation.
    """

    def __init__(
        self, prob: ClosingProblem, s: ClosingState, extra: ExtraConstraints, eu_orig: np.ndarray
    ) -> None:
        self.prob, self.s = prob, s
        n, m, ne = prob.n, prob.m, prob.ne
        lay, sp, h = prob.layout, prob.spec, prob.h
        self.bs, self.be = prob.blocks(s)
        self.sel = prob.sel
        self.f = prob.residual(s)
        eu = np.where(sp.eu_closed, _eu_samples(prob, s), eu_orig)
        g_x, frames, d_rot, d_eu = extra.evaluate(s.rot, eu)
        r_count, slots = frames.shape
        self.n_extra = r_count
        self.fsel = np.concatenate([self.f[self.sel], g_x])
        self.n_closing = self.fsel.size - r_count
        # the atoms (row, slot) with a frame > 0 (sample 0 is fixed; -1 marks an unused slot)
        # and the row's derivative there, pulled back by R_f
        valid = (frames > 0).reshape(-1)
        self.fr = frames.reshape(-1)[valid]
        atom_row = np.repeat(np.arange(r_count), slots)[valid]
        a_count = self.fr.size
        d_flat = np.zeros((a_count, lay.dim))
        d_flat[:, :ne] = np.where(sp.eu_closed, d_eu, 0.0).reshape(-1, ne)[valid]
        if m:
            d_atoms = d_rot.reshape(-1, m, 3)[valid]
            d_flat[:, ne:] = np.einsum("abj,abjk->abk", d_atoms, s.rot[self.fr]).reshape(a_count, 3 * m)
        self.d_flat = d_flat
        # rows = sum of their atoms: a sparse (R, A); sample f collects the atoms at f: (n+1, A)
        self._rows = scipy.sparse.csr_matrix(
            (np.ones(a_count), (atom_row, np.arange(a_count))), shape=(r_count, a_count)
        )
        self._one_atom_per_row = a_count == r_count and bool(np.all(atom_row == np.arange(r_count)))
        row_atoms = np.full(r_count * slots, -1, dtype=np.int64)
        row_atoms[valid] = np.arange(a_count)
        self._row_atoms = row_atoms.reshape(r_count, slots)  # each row's atoms, -1: none
        self._scatter = scipy.sparse.csr_matrix(
            (np.ones(a_count), (self.fr, np.arange(a_count))), shape=(n + 1, a_count)
        )
        # per-cell maps, natural units: t_i = scale_i * A_i (M_i dq_i) on the SO(3) copies
        self.scale_rot = h[:, None] / lay.s_so3[None, :]  # (n, m)
        self.scale_eu = h[:, None] / lay.s_eu[None, :]  # (n, e)
        self.a = np.matmul(np.swapaxes(s.rot[1:], -1, -2), s.dexp) if m else np.zeros((n, 0, 3, 3))
        self._gmat: np.ndarray | None = None
        self._factor: tuple | None = None

    # -- the extra rows -----------------------------------------------------------------------
    def _cell_tangents(self, md: np.ndarray) -> np.ndarray:
        """``(n, dim)``: each cell's contribution to the samples after it (``md = M d``)."""
        ne, m = self.prob.ne, self.prob.m
        t = np.empty_like(md)
        t[:, :ne] = self.scale_eu * md[:, :ne]
        if m:
            rot = np.einsum("ibjk,ibk->ibj", self.a, md[:, ne:].reshape(-1, m, 3))
            t[:, ne:] = (self.scale_rot[:, :, None] * rot).reshape(-1, 3 * m)
        return t

    def _extra_forward(self, md: np.ndarray) -> np.ndarray:
        t = self._cell_tangents(md)
        prefix = np.concatenate([np.zeros((1, t.shape[1])), np.cumsum(t, axis=0)])  # (n+1, dim)
        return self._rows @ np.einsum("ad,ad->a", self.d_flat, prefix[self.fr])

    def _extra_adjoint_w(self, lam: np.ndarray) -> np.ndarray:
        """``B^T`` part of the adjoint (before ``M`` and ``1/h``): ``(n, dim)``."""
        ne, m, n = self.prob.ne, self.prob.m, self.prob.n
        cov = self._scatter @ ((self._rows.T @ lam)[:, None] * self.d_flat)
        suffix = np.cumsum(cov[::-1], axis=0)[::-1]  # suffix[f] = sum_{g >= f} cov[g]
        after = suffix[1:]  # cell i feeds the samples i+1, ..., n
        w = np.empty((n, after.shape[1]))
        w[:, :ne] = self.scale_eu * after[:, :ne]
        if m:
            rot = np.einsum("ibjk,ibj->ibk", self.a, after[:, ne:].reshape(n, m, 3))
            w[:, ne:] = (self.scale_rot[:, :, None] * rot).reshape(n, 3 * m)
        return w

    # -- the interface of _Linear ---------------------------------------------------------------
    def forward(self, d: np.ndarray) -> np.ndarray:
        prob = self.prob
        md = prob.apply_m(self.s, d)
        closing = prob.forward(self.s, self.bs, self.be, d)[self.sel]
        return np.concatenate([closing, self._extra_forward(md)])

    def adjoint(self, lam: np.ndarray) -> np.ndarray:
        prob = self.prob
        k = self.n_closing
        z = np.zeros_like(self.f)
        z[self.sel] = lam[:k]
        out = prob.adjoint(self.s, self.bs, self.be, z)
        if self.n_extra:
            out += prob.apply_m(self.s, self._extra_adjoint_w(lam[k:])) / prob.h[:, None]
        return out

    def release(self) -> None:
        """Drop the Gram matrix and its factors (rebuilt if asked for again)."""
        self._gmat, self._factor = None, None

    @property
    def gmat(self) -> np.ndarray:
        """``J J^*`` of all rows (assembled on first use: Hessian products need only ``J^*``)."""
        if self._gmat is None:
            self._gmat = self._assemble_gram()
        return self._gmat

    def _assemble_gram(self) -> np.ndarray:
        """``J J^*`` of all rows, dense: the closing block, the extra rows' and the cross block."""
        g_cc = self._closing_block()
        if not self.n_extra:
            return g_cc
        g_cx = self._cross_block()
        g_xx = self._extra_block(self._rank_one_rows())
        return np.block([[g_cc, g_cx], [g_cx.T, g_xx]])

    def _closing_block(self) -> np.ndarray:
        return self.prob.gram(self.s, self.bs, self.be)[np.ix_(self.sel, self.sel)]

    def _rank_one_y(self) -> np.ndarray:
        """``y_i = sqrt(3 / h_i) T_i q_i`` ``(n, dim)``: the rank-one part ``y_i y_i^T`` of each
        cell's Gram block (``M_i^2 = |q_i|^2 I + 3 q_i q_i^T``)."""
        return self._cell_tangents(self.s.q) * np.sqrt(3.0 / self.prob.h)[:, None]

    def _rank_one_rows(self) -> np.ndarray:
        """``z`` of the rank-one part per row ``(R, n)``: ``z[r, i] = D_r . y_i`` for the cells
        ``i`` before the row's frames."""
        n, fr, cols = self.prob.n, self.fr, self._cols
        y = self._rank_one_y()
        z = (np.ascontiguousarray(self.d_flat[:, cols]) @ y[:, cols].T) * (
            np.arange(n)[None, :] < fr[:, None]
        )  # (A, n)
        return z if self._one_atom_per_row else self._rows @ z

    @property
    def _cols(self) -> np.ndarray:
        """The coordinates the extra rows touch (a foot's chain: products on those only)."""
        return np.flatnonzero(np.any(self.d_flat != 0.0, axis=0))

    def _prefix_products(self) -> np.ndarray:
        """``e_flat[a] = K(f_a) D_a`` ``(A, dim)``: the |q|^2 part of ``M_i^2``, block diagonal
        per cell, its prefix ``K(f) = sum_{i<f} |q_i|^2 h_i / s^2 A_i A_i^T`` at each atom."""
        prob, s = self.prob, self.s
        m, ne, h, lay = prob.m, prob.ne, prob.h, prob.layout
        qn2, d, fr = s.qn**2, self.d_flat, self.fr
        c_eu = (qn2 * h)[:, None] / lay.s_eu[None, :] ** 2  # (n, e)
        c_rot = (
            (qn2 * h)[:, None, None, None]
            / (lay.s_so3**2)[None, :, None, None]
            * np.einsum("ibjk,iblk->ibjl", self.a, self.a)
        )
        k_eu = np.concatenate([np.zeros((1, ne)), np.cumsum(c_eu, axis=0)])[fr]  # (A, e)
        k_rot = np.concatenate([np.zeros((1, m, 3, 3)), np.cumsum(c_rot, axis=0)])[fr]  # (A, m, 3, 3)
        e_flat = np.empty_like(d)
        e_flat[:, :ne] = k_eu * d[:, :ne]
        if m:
            e_flat[:, ne:] = np.einsum("abjk,abk->abj", k_rot, d[:, ne:].reshape(-1, m, 3)).reshape(-1, 3 * m)
        return e_flat

    def _extra_block(self, z_rows: np.ndarray) -> np.ndarray:
        """``J_x J_x^*`` dense ``(R, R)``: ``D_a^T K(min(f_a, f_b)) D_b`` summed over the rows'
        atoms, plus ``z z^T``."""
        cols, fr = self._cols, self.fr
        d_c = np.ascontiguousarray(self.d_flat[:, cols])
        prod = np.ascontiguousarray(self._prefix_products()[:, cols]) @ d_c.T  # D_a^T K(f_a) D_b
        g_atoms = np.where(fr[:, None] <= fr[None, :], prod, prod.T)
        if self._one_atom_per_row:
            return g_atoms + z_rows @ z_rows.T
        rows = self._rows
        return rows @ (rows @ g_atoms).T + z_rows @ z_rows.T

    def _extra_trace(self, cells: np.ndarray, cols: np.ndarray) -> float:
        """The trace of :meth:`_extra_block` without forming it, from the cell blocks ``D_i``
        on ``cols`` (:meth:`_cell_blocks`): per row, its atoms' pairs ``D_a^T S(min(f_a, f_b))
        D_b`` with ``S(f) = sum_{i<f} D_i``."""
        prefix = np.concatenate([np.zeros((1,) + cells.shape[1:]), np.cumsum(cells, axis=0)])
        d_c, fr, slots = self.d_flat[:, cols], self.fr, self._row_atoms
        diag = 0.0
        for s_a in range(slots.shape[1]):
            for s_b in range(slots.shape[1]):
                a, b = slots[:, s_a], slots[:, s_b]
                ok = (a >= 0) & (b >= 0)
                a, b = a[ok], b[ok]
                f = fr[np.where(fr[a] <= fr[b], a, b)]  # S at the earlier frame
                for c0 in range(0, a.size, _ATOM_CHUNK):
                    at = slice(c0, c0 + _ATOM_CHUNK)
                    diag += float(np.einsum("aj,ajk,ak->", d_c[a[at]], prefix[f[at]], d_c[b[at]]))
        return diag

    def _cross_block(self) -> np.ndarray:
        """The closing rows against the extra rows ``(k, R)`` (selected closing rows): per atom,
        ``B_c^T`` of the cells before its frame against ``D_a``, in chunks of atoms (the
        per-atom prefixes are ``A x m x 3k x 3``)."""
        prob, s = self.prob, self.s
        n, m, ne, dim, h, lay = prob.n, prob.m, prob.ne, prob.layout.dim, prob.h, prob.layout
        qn2, d, fr = s.qn**2, self.d_flat, self.fr
        k = self.be.shape[-1]
        bs, be = self.bs, self.be
        # prefixes over the cells of each closing row's weighted block (|q|^2 part)
        p_eu = np.concatenate(
            [np.zeros((1, ne, k)), np.cumsum((qn2[:, None, None] / lay.s_eu[None, :, None]) * be, axis=0)]
        )  # (n+1, e, k)
        if m:
            v_rot = (qn2[:, None] / lay.s_so3[None, :])[:, :, None, None] * np.einsum(
                "ibjk,ibrk->ibrj", self.a, bs
            )  # (n, m, 3k, 3): (|q|^2 / s) A_i b_row
            p_rot = np.concatenate([np.zeros((1,) + v_rot.shape[1:]), np.cumsum(v_rot, axis=0)])
        # the rank-one part: (b_c . q) sqrt(3 / h) against y_i . D_a over the cells before f_a
        yc = np.empty((n, k * dim))
        for g in range(k):
            yc[:, g * dim : g * dim + ne] = be[:, :, g] * s.q[:, :ne]
            if m:
                yc[:, g * dim + ne : (g + 1) * dim] = np.einsum(
                    "ibrk,ibk->ibr", bs[:, :, 3 * g : 3 * g + 3], s.q[:, ne:].reshape(n, m, 3)
                ).reshape(n, 3 * m)
        yc *= np.sqrt(3.0 / h)[:, None]
        cols = self._cols
        y_c = self._rank_one_y()[:, cols]
        g_cx = np.zeros((k * dim, fr.size))
        for lo in range(0, fr.size, _ATOM_CHUNK):
            at = slice(lo, lo + _ATOM_CHUNK)
            f_at, d_at = fr[at], d[at]
            for g in range(k):
                g_cx[g * dim : g * dim + ne, at] = (p_eu[f_at][:, :, g] * d_at[:, :ne]).T
            if m:
                blk = np.einsum("abrj,abj->abr", p_rot[f_at], d_at[:, ne:].reshape(-1, m, 3))  # (a, m, 3k)
                for g in range(k):
                    idx = g * dim + ne + 3 * np.arange(m)[:, None] + np.arange(3)[None, :]  # (m, 3)
                    g_cx[idx.ravel(), at] = blk[:, :, 3 * g : 3 * g + 3].reshape(-1, 3 * m).T
            z = (np.ascontiguousarray(d_at[:, cols]) @ y_c.T) * (np.arange(n)[None, :] < f_at[:, None])
            g_cx[:, at] += yc.T @ z.T
        if not self._one_atom_per_row:
            g_cx = (self._rows @ g_cx.T).T
        return g_cx[self.sel]

    def _cell_blocks(self, cols: np.ndarray) -> np.ndarray:
        """``D_i`` on the coordinates ``cols`` ``(n, c, c)``: cell ``i``'s contribution to the
        Gram matrix of the samples after it, ``(1 / h_i) T_i M_i^2 T_i^T`` (``T_i`` the cell's
        map to the samples, :meth:`_cell_tangents`): the block-diagonal ``|q|^2`` part plus the
        rank-one ``y_i y_i^T`` (:meth:`_rank_one_rows`)."""
        prob, s = self.prob, self.s
        n, m, ne, h, lay = prob.n, prob.m, prob.ne, prob.h, prob.layout
        qn2 = s.qn**2
        # each coordinate's block: a Euclidean coordinate its own, an SO(3) copy's three theirs
        block = np.where(cols < ne, -1 - cols, (cols - ne) // 3)
        within = np.where(cols < ne, 0, (cols - ne) % 3)
        same = block[:, None] == block[None, :]
        out = np.zeros((n, cols.size, cols.size))
        eu = cols < ne
        if eu.any():
            k = np.flatnonzero(eu)
            out[:, k, k] = (qn2 * h)[:, None] / lay.s_eu[cols[k]][None, :] ** 2
        rot = ~eu
        if m and rot.any():
            c_rot = (
                (qn2 * h)[:, None, None, None]
                / (lay.s_so3**2)[None, :, None, None]
                * np.einsum("ibjk,iblk->ibjl", self.a, self.a)
            )  # (n, m, 3, 3)
            i, j = np.nonzero(same & rot[:, None] & rot[None, :])
            out[:, i, j] = c_rot[:, block[i], within[i], within[j]]
        y = self._cell_tangents(s.q)[:, cols] * np.sqrt(3.0 / h)[:, None]
        return out + y[:, :, None] * y[:, None, :]

    def structured_pays(self) -> bool:
        """Whether :meth:`structured` is cheaper than the dense :attr:`gmat`."""
        return self.n_extra > 0 and structured_pays(self.prob.n, int(self._cols.size), self.n_extra)

    def structured(self) -> StructuredGram:
        """``(J J^* + mu I)^{-1}`` through the structure of the extra rows
        (:mod:`elastic_motion.closing.structured`), ``mu`` as :func:`_solve` shifts the dense one."""
        g_cc = self._closing_block()
        cols = self._cols
        cells = self._cell_blocks(cols)
        size = g_cc.shape[0] + self.n_extra
        mu = 1e-12 * max((float(np.trace(g_cc)) + self._extra_trace(cells, cols)) / max(size, 1), 1e-300)
        atoms = (np.ascontiguousarray(self.d_flat[:, cols]), self.fr, self._rows)
        extra = ExtraRowsSystem(cells, atoms, mu)
        return StructuredGram(g_cc, self._cross_block(), extra, mu)


def _dot(h: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    return float(np.einsum("i,ij,ij->", h, a, b))


def _newton_step(
    prob: ClosingProblem,
    lin: _Linear | _ExtraLinear,
    e: np.ndarray,
    lam: np.ndarray,
    linearise,
    max_cg: int = 20,
) -> np.ndarray:
    """SQP step with the Hessian of the Lagrangian ``W = I - sum_k lam_k Hess F_k``.

    ``W v`` by central differences of ``J(q)^* lam`` (the exact adjoint at ``q +- eps v``);
    the step is the normal step ``-J^* (J J^*)^{-1} F`` plus the minimiser of the quadratic
    model on the null space of ``J`` by projected conjugate gradients (stopped at negative
    curvature).
    """
    h, q = prob.h, lin.s.q
    scale = max(l2_norm(q, h), 1.0)

    def jt_lam(qq: np.ndarray) -> np.ndarray:
        return linearise(prob.evaluate(qq)).adjoint(lam)

    def wv(v: np.ndarray) -> np.ndarray:
        nv = l2_norm(v, h)
        if nv == 0.0:
            return np.zeros_like(v)
        eps = 1e-5 * scale / nv
        return v - (jt_lam(q + eps * v) - jt_lam(q - eps * v)) / (2.0 * eps)

    def proj(v: np.ndarray) -> np.ndarray:
        return v - lin.adjoint(_solve(lin, lin.forward(v)))

    dn = -lin.adjoint(_solve(lin, lin.fsel))
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
    lam = _solve(lin, lin.forward(e))
    ne = l2_norm(e, h)
    if ne == 0.0:
        return 0.0, lam
    res = e - lin.adjoint(lam)
    for _ in range(2):  # iterative refinement of the normal equations (J J^* is ill-conditioned)
        lam = lam + _solve(lin, lin.forward(res))
        res = e - lin.adjoint(lam)
    return l2_norm(res, h) / ne, lam


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
        The closing conditions (:class:`~elastic_motion.closing.ClosingOptions`).

    Returns
    -------
    kkt : float
        ``|e - J^* lambda_ls|_L2 / |e|_L2`` with ``e = q - q_orig`` and the least-squares
        multipliers (0 at a KKT point; 0 when ``e = 0``).
    gap : float
        ``|F(q)|``, the closing residual (0 on the constraint set).
    """
    options = ClosingOptions(factors=factors, c1=c1, c1_weight=c1_weight, cut_locus_tol=0.0)
    prob = ClosingProblem.from_curve(curve, options)
    srv, srv0 = prob.srv, ClosingProblem.from_curve(original, options).srv
    if srv0.q.shape != srv.q.shape or not np.allclose(srv0.t, srv.t):
        raise ValueError(f"original: expected the grid of curve ({srv.q.shape}); got {srv0.q.shape}")
    s = prob.evaluate_checked(prob.to_internal(srv.q))
    lin = _Linear(prob, s)
    e = prob.to_internal(srv.q) - prob.to_internal(srv0.q)
    k, _ = _kkt(lin, e, prob.h)
    return k, float(np.linalg.norm(lin.fsel))


def project_closed(
    curve: DiscreteCurve | SRVFunction,
    options: ClosingOptions | None = None,
    *,
    extra: ExtraConstraints | None = None,
    start: SRVFunction | None = None,
    progress: Callable[[str, int, int], None] | None = None,
    **overrides: Any,
) -> ClosingResult:
    """The closed curve nearest ``curve`` in SRV L2 (a KKT point of the projection).

    Solves ``min 1/2 ||q - q_orig||_L2^2`` subject to the closing conditions, the first
    sample fixed (module docstring), for any group of the product family (``R^d``,
    ``SO(3)^J``, ``R^3 x SO(3)^J``).

    Parameters
    ----------
    curve : DiscreteCurve or SRVFunction
        ``n+1 >= 3`` samples.
    options : ClosingOptions, optional
        Default ``ClosingOptions()`` (``method="kkt"``): feasibility ``tol`` 1e-9 (the closing
        residual's norm), optimality ``kkt_tol`` 1e-8 (the relative KKT residual), at most
        200 iterations. Read here: ``factors``, ``c1`` (also match the seam velocities, the
        C1 rows of :func:`~elastic_motion.closing.close_curve`), ``c1_weight`` (the scale of
        the velocity rows: the solution does not depend on it, only the conditioning does),
        ``tol``, ``kkt_tol``, ``max_iter``, ``keep_free`` (the returned ``curve`` gets the
        original samples of free coordinates back; ``srv`` keeps the solver's values),
        ``cut_locus_tol``, ``rotation_names`` and ``stall_iterations`` (give up,
        ``converged=False`` and a message saying the constraints look inconsistent, when
        the gap has not dropped by 20 % over this many iterations after the first few: a
        caller that can relax its constraints learns early that it must).
    extra : ExtraConstraints, optional
        More equality constraints on the integrated curve (e.g. contacts of a motion), solved
        in the same projection; their rows follow the closing rows in ``multipliers``. Their
        Jacobian is applied by prefix sums over the cells and ``J J^*`` assembled from
        per-frame blocks (``_ExtraLinear``): ``O(n dim + R^2 dim)`` per linearisation.
    start : SRVFunction, optional
        The first iterate instead of ``curve``'s own SRV function: the solver's SRV function
        (:attr:`ClosingResult.srv`) of a nearby problem on the same grid and group, e.g. the
        same projection with fewer ``extra`` rows. The objective is still the distance to
        ``curve``; a start near the solution saves the iterations that bring the gap down.
    progress : callable, optional
        ``progress("closing", iterations, 0)`` after each iteration (total unknown: 0).
    **overrides
        Fields of ``options`` (``project_closed(curve, factors=mask, c1=True)``).

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
    opts = solver_options("kkt", "kkt", options, overrides)
    prob = ClosingProblem.from_curve(curve, opts)
    origin = prob.evaluate_checked(prob.to_internal(prob.srv.q).copy())
    run = _Projection(prob, opts, extra, origin)
    state = origin if start is None else prob.evaluate_checked(prob.to_internal(_start_q(prob, start)))
    log = SolverLog(
        gaps=[float(np.linalg.norm(state.f0))],
        velocity_gaps=[float(np.linalg.norm(state.f1))],
        objective=[0.5 * l2_norm(state.q - origin.q, prob.h) ** 2],
        started=t_begin,
    )
    # (the first point is not kept here: each iterate's factors go when the next is built)
    point = run.iterate(run.point(state), log, progress)
    q_final = prob.to_group(point.state.q)
    moved = log.iterations > 0 or start is not None
    out_curve, closed = prob.closed_output(curve, q_final, moved=moved, keep_free=opts.keep_free)
    return ClosingResult(
        curve=out_curve,
        srv=closed,
        method="kkt",
        gradient="exact",
        rotation_gaps=point.state.rot_gaps,
        translation_gaps=point.state.eu_gaps,
        change=l2_norm(q_final - prob.srv.q, prob.h),
        kkt_residual=point.kkt,
        multipliers=point.lam,
        **log.summary(),
    )


def _start_q(prob: ClosingProblem, start: SRVFunction) -> np.ndarray:
    """The SRV values of a warm ``start`` (group order), checked against the problem's grid."""
    srv = prob.srv
    q = np.asarray(start.q, dtype=np.float64)
    if q.shape != srv.q.shape or not np.allclose(start.t, srv.t):
        raise ValueError(
            f"start: expected the SRV function of the curve's grid ({srv.q.shape}); got {q.shape}"
        )
    return q


@dataclass(eq=False)
class _Point:
    """An iterate of the projection and its linearisation: ``e = q - q_orig``, the KKT residual
    and least-squares multipliers there, and the feasibility ``|F|`` (closing and extra rows)."""

    state: ClosingState
    e: np.ndarray
    lin: _Linear | _ExtraLinear
    kkt: float
    lam: np.ndarray
    feas: float


class _Projection:
    """One run of the SQP projection (module docstring): the fixed data of the problem and the
    memory of the iteration (penalty ``rho``, Newton mode, KKT and feasibility histories)."""

    def __init__(
        self, prob: ClosingProblem, opts: ClosingOptions, extra: ExtraConstraints | None, start: ClosingState
    ) -> None:
        self.prob, self.opts, self.extra, self.h = prob, opts, extra, prob.h
        self.q0 = start.q.copy()
        self.eu_orig = _eu_samples(prob, start)
        self.rho = 0.0
        self.newton = False
        self.kkts: list[float] = []
        self.feas_hist: list[float] = []

    def linearise(self, st: ClosingState) -> _Linear | _ExtraLinear:
        """The constraint linearisation at ``st`` (with the extra rows when there are any)."""
        if self.extra is not None:
            return _ExtraLinear(self.prob, st, self.extra, self.eu_orig)
        return _Linear(self.prob, st)

    def feasibility(self, st: ClosingState) -> float:
        """``|F|`` of the closed rows (and the extra rows) at ``st``."""
        prob = self.prob
        f = prob.residual(st)[prob.sel]
        if self.extra is not None:
            eu = np.where(prob.spec.eu_closed, _eu_samples(prob, st), self.eu_orig)
            f = np.concatenate([f, self.extra.residual(st.rot, eu)])
        return float(np.linalg.norm(f))

    def point(self, st: ClosingState) -> _Point:
        """The iterate at ``st``, linearised."""
        lin = self.linearise(st)
        e = st.q - self.q0
        kkt, lam = _kkt(lin, e, self.h)
        return _Point(st, e, lin, kkt, lam, float(np.linalg.norm(lin.fsel)))

    def iterate(self, p: _Point, log: SolverLog, progress: Callable[[str, int, int], None] | None) -> _Point:
        """Steps from ``p`` until converged, stopped or ``max_iter``; returns the last iterate."""
        tol, max_iter = self.opts.tolerance, self.opts.iterations
        self.kkts.append(p.kkt)
        self.feas_hist.append(p.feas)
        log.converged = p.feas <= tol and p.kkt <= self.opts.kkt_tol
        log.message = "already closed" if log.converged else f"reached max_iter = {max_iter}"
        while not log.converged and log.iterations < max_iter:
            accepted, alpha = self.step(p)
            if accepted is None:
                log.message = self.no_step_message(p, log)
                break
            p.lin.release()  # its Gram matrix and factors are done with: free them first
            p = self.point(accepted)
            log.record(
                step=alpha,
                gap=float(np.linalg.norm(p.state.f0)),
                velocity_gap=float(np.linalg.norm(p.state.f1)),
                objective=0.5 * l2_norm(p.e, self.h) ** 2,
            )
            if progress is not None:
                progress("closing", log.iterations, 0)
            if self.stop(p, log):
                break
        return p

    def step(self, p: _Point) -> tuple[ClosingState | None, float]:
        """One accepted step from ``p``: the Newton step of the Lagrangian's Hessian (once the
        identity model is slow) and the identity model's step, each with its line search on the
        exact penalty; ``(None, 0)`` when neither is accepted."""
        lin, e = p.lin, p.e
        lam_step = _solve(lin, -lin.fsel + lin.forward(e))
        self.rho = max(self.rho, 2.0 * float(np.linalg.norm(lam_step)) + 1e-12)
        merit = 0.5 * l2_norm(e, self.h) ** 2 + self.rho * p.feas
        directions = []
        if self.newton:
            try:  # fewer CG steps with extra rows (each Hessian product rebuilds their Jacobian)
                max_cg = 12 if self.extra is None else 6
                directions.append(_newton_step(self.prob, lin, e, p.lam, self.linearise, max_cg=max_cg))
            except CutLocus:
                pass
        directions.append(-e + lin.adjoint(lam_step))  # identity Hessian model (fallback)
        for d in directions:
            trial, alpha = self.search(p, d, merit)
            if trial is not None:
                return trial, alpha
        return None, 0.0

    def search(self, p: _Point, d: np.ndarray, merit: float) -> tuple[ClosingState | None, float]:
        """Backtracking along ``d`` on the merit ``1/2 ||e||^2 + rho |F|``."""
        h, e, feas = self.h, p.e, p.feas
        slope = _dot(h, e, d) - self.rho * feas
        alpha = 1.0
        # near the solution the merit function cannot resolve the step (its decrease is
        # below rounding): take the full step while it keeps the curve closed
        tiny = l2_norm(d, h) <= 1e-6 * max(l2_norm(e, h), 1e-300)
        for _ in range(24):  # down to alpha = 6e-8: a shorter step is no step
            try:
                trial = self.prob.evaluate(p.state.q + alpha * d)
            except CutLocus:
                alpha *= 0.5
                continue
            ft = self.feasibility(trial)
            mt = 0.5 * l2_norm(trial.q - self.q0, h) ** 2 + self.rho * ft
            if np.isfinite(mt) and (
                mt <= merit + 1e-4 * alpha * min(slope, 0.0)
                or (tiny and ft <= max(feas, self.opts.tolerance))
            ):
                return trial, alpha
            alpha *= 0.5
        return None, alpha

    def no_step_message(self, p: _Point, log: SolverLog) -> str:
        """Why no step was accepted. With ``stall_iterations``, a gap above the tolerance that
        the last step barely decreased (by under a fifth) is the constraints not fitting
        together: the penalty cannot go down either, and whether the line search fails before
        the stall test has seen ``stall_iterations`` flat steps depends on the rounding of the
        platform's linear algebra. Otherwise the line search failed."""
        stall, hist = self.opts.stall_iterations, self.feas_hist  # hist[-1] is p's gap
        if stall and p.feas > self.opts.tolerance and len(hist) >= 2 and p.feas > 0.8 * hist[-2]:
            return (
                f"the constraints look inconsistent: gap {p.feas:.3g} after {log.iterations} iterations "
                "(no step decreases it)"
            )
        return f"line search failed (gap {p.feas:.3g}, KKT residual {p.kkt:.3g})"

    def stop(self, p: _Point, log: SolverLog) -> bool:
        """After an accepted step: converged, stalled at the rounding floor, or the constraints
        inconsistent (``log`` says which); else switch to Newton steps when the identity model
        converges slowly."""
        opts, feas, kkt = self.opts, p.feas, p.kkt
        tol, stall = opts.tolerance, opts.stall_iterations
        self.kkts.append(kkt)
        if feas <= tol and kkt <= opts.kkt_tol:
            log.converged = True
            log.message = f"converged in {log.iterations} iterations (KKT residual {kkt:.2g})"
            return True
        kkts = self.kkts
        if self.newton and feas <= tol and kkt < 1e-6 and len(kkts) > 4 and kkt > 0.5 * min(kkts[-4:-1]):
            log.message = (
                f"stalled at KKT residual {kkt:.2g} after {log.iterations} iterations (rounding floor)"
            )
            return True
        hist = self.feas_hist
        if stall and feas > tol and len(hist) > stall + 4 and feas > 0.8 * hist[-stall]:
            # the constraints do not fit together: the gap stops decreasing
            log.message = (
                f"the constraints look inconsistent: gap {feas:.3g} after {log.iterations} iterations"
            )
            return True
        if not self.newton and kkt > 0.2 * kkts[-2]:
            self.newton = True  # the identity model converges slowly here: use the Lagrangian's Hessian
        hist.append(feas)
        return False
