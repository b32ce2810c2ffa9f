"""The Gram matrix of many extra constraint rows, solved through its structure.

The KKT projection (:mod:`elastic_motion.closing.kkt`) solves ``(J J^* + mu I) lambda = r`` at
every linearisation. For extra rows (a loop's kept contacts: thousands of rows, 3 per contact
frame) the dense Gram matrix ``G_xx = J_x J_x^*`` costs ``R^2`` memory and ``R^3`` to factor:
a whole CMU 55_01 with its contacts (3462 rows on a 30 fps grid of 452 cells) spent most of
its closing assembling and factoring it (1.7 s and 200 MB each time). Its structure is a
random walk's:

    G_xx = E P D P^T E^T

* ``D`` block diagonal: ``D_i`` (``c x c``) is cell ``i``'s Gram block on the ``c``
  coordinates the rows touch (:meth:`~elastic_motion.closing.kkt._ExtraLinear._cell_blocks`),
* ``P`` the prefix sum from cells to samples (sample ``f`` moves with the cells ``i < f``),
* ``E`` sparse: row ``r`` sums its atoms' derivatives ``D_a`` at their samples ``f_a``.

``P^{-1}`` is a difference, so with ``t = P^T E^T lambda`` (per cell) and ``u = P D t`` (per
sample), ``lambda = (G_xx + mu I)^{-1} r`` solves the sparse symmetric system

    -D t + P^{-1} u = 0,      P^{-T} t - E^T lambda = 0,      -E u - mu lambda = -r

of ``2 n c + R`` unknowns. In time order (each cell's ``t_i`` and ``u_{i+1}``, then the rows
of sample ``i + 1``) it is banded but for the rows measured from the last sample (a contact
across the seam): one sparse LU (SuperLU, partial pivoting: ``D_i`` is singular where the curve
stands still) with ``O((n c + R) c)`` fill replaces the dense factor, the same multipliers to
the conditioning of ``G`` (converged loops agree to 1e-10). The closing rows (at most twice the
group's dimension) join by a Schur complement (:class:`StructuredGram`).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg

__all__ = ["ExtraRowsSystem", "StructuredGram", "structured_pays"]


def structured_pays(n: int, c: int, r: int) -> bool:
    """Whether :class:`ExtraRowsSystem` beats the dense Gram matrix for ``r`` extra rows on
    ``c`` coordinates of a curve of ``n`` cells.

    By the factorisation's flops: dense ``r^3 / 3``, structured about ``(2 n c + r) b^2`` with
    the band ``b = 2 c + r / n`` of the time-ordered system, times 10 for a sparse LU's
    overhead against LAPACK (measured: CMU 55_01 whole, 3462 rows on 452 cells, 28
    coordinates: 0.14 s against 1.7 s dense; 49_08, 927 rows, 55 coordinates: dense 3x faster).
    """
    band = 2 * c + r / max(n, 1)
    return r**3 / 3.0 > 10.0 * (2 * n * c + r) * band**2


#: Right-hand sides solved together (bounds the work vectors).
_RHS_CHUNK = 8


class ExtraRowsSystem:
    """``(G_xx + mu I)^{-1}`` of the extra rows (module docstring), factored once.

    Parameters
    ----------
    cells : ndarray, shape (n, c, c)
        ``D_i``: each cell's Gram block on the ``c`` coordinates the rows touch (symmetric
        positive semi-definite: zero on a cell where the curve stands still).
    atoms : tuple of (ndarray (A, c), ndarray of int (A,), sparse matrix (R, A))
        Each atom's derivative on those coordinates, its sample (``1..n``), and which atoms
        each row sums.
    mu : float
        The diagonal shift.
    """

    def __init__(
        self, cells: np.ndarray, atoms: tuple[np.ndarray, np.ndarray, scipy.sparse.spmatrix], mu: float
    ) -> None:
        d_atoms, frames, rows = atoms
        n, c = cells.shape[0], cells.shape[1]
        r_count = rows.shape[0]
        nc = n * c
        # unknowns: t (n c: cell i at i c), u (n c: sample f at (f - 1) c), lambda (R)
        i_u, i_l = nc, 2 * nc
        size = i_l + r_count
        cell_of = np.repeat(np.arange(n), c)
        blocks: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []

        def add(r: np.ndarray, col: np.ndarray, v: np.ndarray, sym: bool = True) -> None:
            r, col = r.astype(np.int32), col.astype(np.int32)  # (the triplets are the peak memory)
            blocks.append((r, col, v))
            if sym:
                blocks.append((col, r, v))

        # -D_i t_i
        bi = (np.arange(n)[:, None, None] * c + np.arange(c)[None, :, None]).repeat(c, axis=2)
        add(bi.ravel(), np.swapaxes(bi, 1, 2).ravel(), -cells.ravel(), sym=False)
        # (P^{-1} u)_i = u_{i+1} - u_i on row t_i (u_0 = 0)
        t_idx = np.arange(nc)
        add(t_idx, i_u + t_idx, np.ones(nc))
        later = t_idx[c:]
        add(later, i_u + later - c, -np.ones(later.size))
        # -E^T lambda on row u_f: atom a of row r at sample f_a
        coo = rows.tocoo()
        row_of, atom_of = coo.row, coo.col
        e_u = i_u + ((frames[atom_of] - 1)[:, None] * c + np.arange(c)[None, :]).ravel()
        e_l = i_l + np.repeat(row_of, c)
        e_v = -d_atoms[atom_of].ravel()
        keep = e_v != 0.0
        add(e_u[keep], e_l[keep], e_v[keep])
        add(i_l + np.arange(r_count), i_l + np.arange(r_count), np.full(r_count, -mu), sym=False)
        # eliminate in time order: t_i, u_{i+1}, then the rows whose first sample is i + 1
        # (a banded matrix but for the rows relative to the last sample: the fill stays near
        # the diagonal; a general ordering, COLAMD or minimum degree, fills it 10-100x more)
        row_first = np.full(r_count, n, dtype=np.int64)
        np.minimum.at(row_first, row_of, frames[atom_of])
        key = np.concatenate([3 * cell_of, 3 * cell_of + 1, 3 * (row_first - 1) + 2])
        order = np.argsort(key, kind="stable")
        at = np.empty(size, dtype=np.int32)
        at[order] = np.arange(size, dtype=np.int32)  # each unknown's place in the elimination order
        kkt = scipy.sparse.csc_matrix(
            (
                np.concatenate([b[2] for b in blocks]),
                (at[np.concatenate([b[0] for b in blocks])], at[np.concatenate([b[1] for b in blocks])]),
            ),
            shape=(size, size),
        )
        blocks.clear()  # (the triplets: the matrix holds them now)
        self._lu = scipy.sparse.linalg.splu(kkt, permc_spec="NATURAL")
        self._size, self.n_rows = size, r_count
        self._lam = at[i_l:]  # lambda's places

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """``(G_xx + mu I)^{-1} rhs``, ``rhs`` of shape ``(R,)`` or ``(R, k)``."""
        if rhs.ndim == 1:
            return self.solve(rhs[:, None])[:, 0]
        out = np.empty_like(rhs, dtype=np.float64)
        # a few right-hand sides at a time: each needs a vector of every unknown (~10 n c)
        for j in range(0, rhs.shape[1], _RHS_CHUNK):
            b = np.zeros((self._size, min(_RHS_CHUNK, rhs.shape[1] - j)))
            b[self._lam] = -rhs[:, j : j + _RHS_CHUNK]
            out[:, j : j + _RHS_CHUNK] = self._lu.solve(b)[self._lam]
        return out


class StructuredGram:
    """``(J J^* + mu I)^{-1}`` of closing rows and many extra rows: the extra rows' block
    through :class:`ExtraRowsSystem`, the closing rows by a Schur complement.

    Parameters
    ----------
    g_cc : ndarray, shape (k, k)
        The closing rows' Gram block.
    g_cx : ndarray, shape (k, R)
        The closing rows against the extra rows.
    extra : ExtraRowsSystem
        Factored with the same ``mu``.
    mu : float
    """

    def __init__(self, g_cc: np.ndarray, g_cx: np.ndarray, extra: ExtraRowsSystem, mu: float) -> None:
        self.extra, self.mu = extra, mu
        self.k = g_cc.shape[0]
        self.g_cx = g_cx
        if self.k:
            self.y = extra.solve(g_cx.T)  # (R, k): G_xx^{-1} G_xc
            schur = g_cc + mu * np.eye(self.k) - g_cx @ self.y
            self._schur = scipy.linalg.lu_factor(schur, check_finite=False)

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """``(G + mu I)^{-1} rhs`` (closing rows first), ``rhs`` of shape ``(k + R,)`` or
        ``(k + R, j)``."""
        k = self.k
        rc, rx = rhs[:k], rhs[k:]
        yx = self.extra.solve(rx)
        if not k:
            return yx
        lc = scipy.linalg.lu_solve(self._schur, rc - self.g_cx @ yx, check_finite=False)
        lx = yx - (self.y @ lc)
        return np.concatenate([lc, lx])
