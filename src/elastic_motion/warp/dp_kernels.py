"""Numba kernels of the dynamic-programming warp solver (paper 001, sec. 3.2).

Conventions (see :mod:`elastic_motion.warp`):

- ``q0`` has ``n0`` cells on the break points ``t0`` (shape ``(n0+1,)``), ``q1`` has ``n1``
  cells on ``t1``; both piecewise constant, cell ``c`` holding on ``[t[c], t[c+1])``.
- The DP grid is a set of domain nodes ``u`` (shape ``(nu+1,)``) and range nodes ``v``
  (shape ``(nv+1,)``), both from 0 to 1.  A DP edge joins node ``(k, l)`` to ``(i, j)``
  with ``(i - k, j - l)`` one of the neighbourhood ``steps``; on it ``phi`` is the linear
  piece ``phi(x) = v[l] + s (x - u[k])``, ``s = (v[j] - v[l]) / (u[i] - u[k])``.
- Cost of an edge, exact for piecewise constant q's (paper 001 eq. 28; ``docs/warp.md``):

      E(k,l;i,j) = int_{u_k}^{u_i} |q0|^2 + int_{v_l}^{v_j} |q1|^2
                   - 2 sqrt(s) int_{u_k}^{u_i} <q0(x), q1(phi(x))> dx

  The first two terms are differences of prefix integrals ``P0``, ``P1`` (change of
  variables ``y = phi(x)`` in the second).  The cross term is a sum over the merged
  break points of ``G[a, b] * length`` with the Gram matrix ``G = q0 @ q1.T``, so one edge
  costs O(cells it crosses), independent of the dimension D.
- Landmark term of an edge (paper 001 eq. 27-28 with the erratum in ``docs/warp.md``,
  section "Landmarks"): a
  feature pair ``(theta0_m, theta1_m)`` is charged on the edge whose *domain* ``(u_k, u_i]``
  holds ``theta0_m``, at ``phi(theta0_m)`` of the linear piece; in the symmetric form
  (sec. 2.4, Remark 16) also on the edge whose *range* ``(v_l, v_j]`` holds ``theta1_m``,
  at ``phi^{-1}(theta1_m)`` of the same piece.

Penalty kinds (``pen_kind``): 0 = squared ``lam * r^2``, 1 = absolute ``lam * |r|``,
2 = none (only hard windows), 3 = tabulated (a user callable sampled on a uniform table of
``x`` in [0, 1], linear interpolation).  A hard window ``|r| > d_m`` gives ``+inf``.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

# ----------------------------------------------------------------------------- edge cost


@njit(cache=True, inline="always")
def cross_walk(u, v, t0, t1, c0, c1, G, k, l, i, j):  # pragma: no cover - numba
    """``int_{u_k}^{u_i} <q0(x), q1(phi(x))> dx`` for the linear piece (k,l)->(i,j).

    Walks the merged break points: the q0 breaks ``t0`` inside the domain and the
    pre-images ``u_k + (t1[b] - v_l) / s`` of the q1 breaks inside the range.
    """
    x = u[k]
    xe = u[i]
    ye = v[j]
    a = c0[k]
    b = c1[l]
    inv_s = (xe - x) / (ye - v[l])
    acc = 0.0
    while True:
        n0 = t0[a + 1]
        if n0 >= xe or a == t0.shape[0] - 2:
            n0 = xe
        yb = t1[b + 1]
        if yb >= ye or b == t1.shape[0] - 2:
            n1 = xe
        else:
            n1 = u[k] + (yb - v[l]) * inv_s
            if n1 > xe:
                n1 = xe
        nx = n0 if n0 < n1 else n1
        acc += G[a, b] * (nx - x)
        if nx >= xe:
            break
        x = nx
        if n0 <= nx:
            a += 1
        if n1 <= nx:
            b += 1
    return acc


@njit(cache=True, inline="always")
def _pen(r, lam, kind):  # pragma: no cover - numba
    if kind == 0:
        return lam * r * r
    if kind == 1:
        return lam * abs(r)
    return 0.0


@njit(cache=True, inline="always")
def table_value(tab, m, x):  # pragma: no cover - numba
    """Linear interpolation of row ``m`` of a penalty table sampled on [0, 1]."""
    nt = tab.shape[1] - 1
    p = x * nt
    if p <= 0.0:
        return tab[m, 0]
    if p >= nt:
        return tab[m, nt]
    c = int(p)
    f = p - c
    return (1.0 - f) * tab[m, c] + f * tab[m, c + 1]


@njit(cache=True, inline="always")
def _landmark_edge(u, v, k, l, i, j, lmk):  # pragma: no cover - numba
    """Landmark cost charged on the edge (k,l)->(i,j) (erratum of paper 001, eq. 27-28).

    ``lmk = (lam, kind, fx, fy, fd, cnt0, tab0, sx, sy, sd, cnt1, tab1, symmetric)``, see
    :func:`dp_solve`.
    """
    lam, kind, fx, fy, fd, cnt0, tab0, sx, sy, sd, cnt1, tab1, symmetric = lmk
    cost = 0.0
    m0 = cnt0[k]
    m1 = cnt0[i]
    if m1 > m0:
        s = (v[j] - v[l]) / (u[i] - u[k])
        for m in range(m0, m1):
            y = v[l] + s * (fx[m] - u[k])  # phi(theta0_m) on the linear piece
            r = y - fy[m]
            if abs(r) > fd[m]:
                return np.inf
            if kind == 3:
                cost += lam * table_value(tab0, m, y)
            else:
                cost += _pen(r, lam, kind)
    if symmetric:
        m0 = cnt1[l]
        m1 = cnt1[j]
        if m1 > m0:
            inv_s = (u[i] - u[k]) / (v[j] - v[l])
            for m in range(m0, m1):
                x = u[k] + inv_s * (sy[m] - v[l])  # phi^{-1}(theta1_m) on the piece
                r = x - sx[m]
                if abs(r) > sd[m]:
                    return np.inf
                if kind == 3:
                    cost += lam * table_value(tab1, m, x)
                else:
                    cost += _pen(r, lam, kind)
    return cost


# ----------------------------------------------------------------------------- the DP


@njit(cache=True)
def _dp_node(
    i, j, u, v, t0, t1, c0, c1, G, P0, P1, steps, taps, lo, hi, H, arg, lmk, has_lm
):  # pragma: no cover - numba
    """Best predecessor of node (i, j): recursion (29) of paper 001 over the neighbourhood.

    Candidates are pruned with the Cauchy-Schwarz lower bound of the edge cost,
    ``E >= (sqrt(A) - sqrt(B))^2`` (A, B the two prefix-sum terms), before the cross
    term is walked; the pruning is exact (it never discards the minimiser).
    """
    best = np.inf
    bestnb = -1
    K = steps.shape[0]
    tap_ptr, tap_dp, tap_dr, tap_w, sqrt_s = taps
    uniform = tap_ptr.shape[0] > 0
    # try first the step that was best at the diagonal neighbour (paths are coherent):
    # a good first bound lets the pruning discard most of the others
    first = -1
    if i > 0 and j > 0 and lo[i - 1] <= j - 1 <= hi[i - 1]:
        first = arg[i - 1, j - 1 - lo[i - 1]]
    for it in range(-1, K):
        if it < 0:
            if first < 0:
                continue
            nb = first
        else:
            nb = it
            if nb == first:
                continue
        k = i - steps[nb, 0]
        l = j - steps[nb, 1]
        if k < 0 or l < 0:
            continue
        if l < lo[k] or l > hi[k]:
            continue
        hkl = H[k, l - lo[k]]
        if hkl >= best:
            continue
        A = P0[i] - P0[k]
        B = P1[j] - P1[l]
        lm = 0.0
        if has_lm:
            lm = _landmark_edge(u, v, k, l, i, j, lmk)
        base = hkl + lm
        d = np.sqrt(A) - np.sqrt(B)
        if base + d * d >= best:
            continue
        if uniform:
            # uniform grids: the merged cells of a slope are a fixed pattern of taps
            cross = 0.0
            for m in range(tap_ptr[nb], tap_ptr[nb + 1]):
                cross += tap_w[m] * G[k + tap_dp[m], l + tap_dr[m]]
            rs = sqrt_s[nb]
        else:
            cross = cross_walk(u, v, t0, t1, c0, c1, G, k, l, i, j)
            rs = np.sqrt((v[j] - v[l]) / (u[i] - u[k]))
        e = A + B - 2.0 * rs * cross
        if e < 0.0:  # rounding only: the exact edge cost is an integral of a square
            e = 0.0
        cand = base + e
        if cand < best:
            best = cand
            bestnb = nb
    return best, bestnb


@njit(cache=True)
def _dp_row(
    i, j_from, j_to, u, v, t0, t1, c0, c1, G, P0, P1, steps, taps, lo, hi, H, arg, lmk, has_lm
):  # pragma: no cover - numba
    """Fill ``H[i, j]`` for ``j_from <= j < j_to`` (row i depends on rows < i only)."""
    for j in range(j_from, j_to):
        if j == 0:
            continue
        best, a = _dp_node(i, j, u, v, t0, t1, c0, c1, G, P0, P1, steps, taps, lo, hi, H, arg, lmk, has_lm)
        H[i, j - lo[i]] = best
        arg[i, j - lo[i]] = a


@njit(cache=True)
def _dp_alloc(lo, hi):  # pragma: no cover - numba
    nu = lo.shape[0] - 1
    W = 1
    for i in range(nu + 1):
        w = hi[i] - lo[i] + 1
        if w > W:
            W = w
    H = np.full((nu + 1, W), np.inf)
    arg = np.full((nu + 1, W), -1, dtype=np.int16)
    if lo[0] == 0:
        H[0, 0] = 0.0
    return H, arg


@njit(cache=True)
def _slope_cross(G, k, j0, b, width, tap_ptr, tap_dr, tap_dp, tap_w, nb, ac):  # pragma: no cover - numba
    """``ac[jj] = sum_taps w * G[k + dp, j0 + jj - b + dr]``: the cross terms of the edges of
    slope ``nb`` from row ``k`` into the nodes ``j0 .. j0 + width - 1`` (row kernel)."""
    # slices indexed from 0: no negative-index checks, so the loops vectorise
    for jj in range(width):
        ac[jj] = 0.0
    for m in range(tap_ptr[nb], tap_ptr[nb + 1]):
        w = tap_w[m]
        c0 = j0 - b + tap_dr[m]
        g = G[k + tap_dp[m], c0 : c0 + width]
        for jj in range(width):
            ac[jj] += w * g[jj]


@njit(cache=True)
def _slope_candidates(
    u, v, i, k, b, j0, width, edge, ac, hk, bj, aj, nb, lmk, with_lm
):  # pragma: no cover - numba
    """Relax the nodes ``(i, j0 + jj)`` by the edges of slope ``nb`` from row ``k``:
    ``edge = (P0[i] - P0[k], 2 sqrt(s), P1 at the nodes, P1 at the predecessors)``; with the
    landmark term per edge when ``with_lm``. Strict ``<``: the first slope of a tie wins."""
    Ak, rs2, p1j, p1l = edge
    if with_lm:
        for jj in range(width):
            # max(., 0): rounding only, the exact edge cost is an integral of a square
            c = hk[jj] + max(Ak + (p1j[jj] - p1l[jj]) - rs2 * ac[jj], 0.0)
            c += _landmark_edge(u, v, k, j0 + jj - b, i, j0 + jj, lmk)
            if c < bj[jj]:
                bj[jj] = c
                aj[jj] = nb
    else:
        for jj in range(width):
            c = hk[jj] + max(Ak + (p1j[jj] - p1l[jj]) - rs2 * ac[jj], 0.0)
            if c < bj[jj]:
                bj[jj] = c
                aj[jj] = nb


@njit(cache=True)
def _rows_row(
    i, u, v, P0, P1, G, steps, taps, lo, hi, lmk, has_lm, H, arg, acc, best, barg
):  # pragma: no cover - numba
    """Row ``i`` of :func:`dp_solve_rows`: every slope's predecessors on row ``i - a``."""
    tap_ptr, tap_dp, tap_dr, tap_w, sqrt_s = taps
    cnt0, symmetric = lmk[5], lmk[12]
    jl = max(lo[i], 1)
    jh = hi[i]
    if jh < jl:
        return
    for j in range(jl, jh + 1):
        best[j] = np.inf
        barg[j] = -1
    for nb in range(steps.shape[0]):
        a = steps[nb, 0]
        b = steps[nb, 1]
        k = i - a
        if k < 0:
            continue
        j0 = max(jl, lo[k] + b)
        j1 = min(jh, hi[k] + b)
        if j1 < j0:
            continue
        width = j1 - j0 + 1
        ac = acc[:width]
        _slope_cross(G, k, j0, b, width, tap_ptr, tap_dr, tap_dp, tap_w, nb, ac)
        edge = (P0[i] - P0[k], 2.0 * sqrt_s[nb], P1[j0 : j1 + 1], P1[j0 - b : j1 + 1 - b])
        with_lm = has_lm and (cnt0[i] > cnt0[k] or symmetric)
        hk = H[k, j0 - b : j1 + 1 - b]
        _slope_candidates(
            u, v, i, k, b, j0, width, edge, ac, hk, best[j0 : j1 + 1], barg[j0 : j1 + 1], nb, lmk, with_lm
        )
    for j in range(jl, jh + 1):
        H[i, j] = best[j]
        arg[i, j] = barg[j]


@njit(cache=True)
def dp_solve_rows(u, v, P0, P1, G, steps, taps, lo, hi, lmk):  # pragma: no cover - numba
    """Row-vectorised DP for uniform grids (the DP grid is the break points of q0 and q1).

    Same recursion and edge cost as :func:`dp_solve`, reorganised for speed: for a row i
    and a slope (a, b) the predecessors of all nodes (i, j) lie on row k = i - a, and the
    cross terms of all these edges are the same taps applied to shifted slices of rows of
    the Gram matrix: ``acc[j] += w * G[k + dp, j - b + dr]``, a contiguous loop that the
    compiler vectorises (no pruning, no branches).  The landmark term is added per edge
    only on the few (row, slope) pairs whose domain ``(u_k, u_i]`` holds a theta0 (or,
    symmetric form, per node where the range holds a theta1).

    Returns dense tables ``H``, ``arg`` of shape ``(nu+1, nv+1)`` (``+inf`` / -1 off the band).
    """
    fx, sx, symmetric = lmk[2], lmk[7], lmk[12]
    nu = lo.shape[0] - 1
    nv = P1.shape[0] - 1
    H = np.full((nu + 1, nv + 1), np.inf)
    arg = np.full((nu + 1, nv + 1), -1, dtype=np.int16)
    H[0, 0] = 0.0
    acc = np.zeros(nv + 1)
    best = np.empty(nv + 1)
    barg = np.empty(nv + 1, dtype=np.int16)
    has_lm = fx.shape[0] > 0 or (symmetric and sx.shape[0] > 0)
    for i in range(1, nu + 1):
        _rows_row(i, u, v, P0, P1, G, steps, taps, lo, hi, lmk, has_lm, H, arg, acc, best, barg)
    return H, arg


@njit(cache=True)
def dp_solve(u, v, t0, t1, c0, c1, G, P0, P1, steps, taps, lo, hi, lmk):  # pragma: no cover - numba
    """Fill the value table ``H`` on a band of the grid and return it with the arg-min table.

    Parameters
    ----------
    u, v : (nu+1,), (nv+1,) float64
        Domain and range nodes of the DP grid.
    t0, t1 : (n0+1,), (n1+1,) float64
        Break points of q0 and q1.
    c0, c1 : (nu+1,), (nv+1,) int64
        Cell of q0 (q1) that starts at node ``u[k]`` (``v[l]``).
    G : (n0, n1) float64
        Gram matrix ``q0 @ q1.T``.
    P0, P1 : (nu+1,), (nv+1,) float64
        Prefix integrals of ``|q0|^2`` at the domain nodes and of ``|q1|^2`` at the range nodes.
    steps : (K, 2) int64
        Neighbourhood: allowed ``(i - k, j - l)``.
    taps : tuple (tap_ptr (K+1,), tap_dp (T,), tap_dr (T,) int64, tap_w (T,), sqrt_s (K,))
        Uniform grids (``u = t0``, ``v = t1``, both uniform): the cells ``(k + dp, l + dr)``
        crossed by an edge of slope ``nb`` and their lengths ``w`` are the same for every
        edge, entries ``tap_ptr[nb]:tap_ptr[nb+1]``; ``sqrt_s[nb]`` its ``sqrt(slope)``.
        Empty ``tap_ptr``: walk the break points instead (any grids).
    lo, hi : (nu+1,) int64
        Band: row ``i`` holds the range nodes ``lo[i] <= j <= hi[i]`` (full DP: 0 and nv).
    lmk : tuple (lam, kind, fx, fy, fd, cnt0, tab0, sx, sy, sd, cnt1, tab1, symmetric)
        Landmark data: weight, penalty kind; ``fx, fy, fd`` the pairs ``(theta0, theta1)`` and
        windows sorted by theta0, ``cnt0[k]`` the number with ``theta0 <= u[k]``, ``tab0``
        the penalty table (kind 3); ``sx, sy, sd, cnt1, tab1`` the same sorted by theta1
        against the range nodes ``v`` (symmetric form).

    Returns
    -------
    H : (nu+1, W) float64
        ``H[i, j - lo[i]]`` = minimal energy of a path from (0, 0) to (i, j).
    arg : (nu+1, W) int16
        Index into ``steps`` of the best last edge (-1: unreachable).
    """
    H, arg = _dp_alloc(lo, hi)
    has_lm = lmk[2].shape[0] > 0 or (lmk[12] and lmk[7].shape[0] > 0)
    nu = u.shape[0] - 1
    for i in range(1, nu + 1):
        _dp_row(
            i, lo[i], hi[i] + 1, u, v, t0, t1, c0, c1, G, P0, P1, steps, taps, lo, hi, H, arg, lmk, has_lm
        )
    return H, arg


@njit(cache=True)
def dp_backtrack(arg, lo, steps, nu, nv):  # pragma: no cover - numba
    """Node indices ``(K, 2)`` of the optimal path from (0, 0) to (nu, nv) (eq. 30)."""
    out = np.empty((nu + nv + 2, 2), dtype=np.int64)
    n = 0
    i = nu
    j = nv
    out[0, 0] = i
    out[0, 1] = j
    n = 1
    while i > 0 or j > 0:
        a = arg[i, j - lo[i]]
        if a < 0:
            return out[:0]
        i -= steps[a, 0]
        j -= steps[a, 1]
        out[n, 0] = i
        out[n, 1] = j
        n += 1
    return out[:n][::-1].copy()


# ----------------------------------------------------------------------------- many pairs
#
# The batched DP (:func:`dp_energies_uniform`): the recursion and edge costs of
# :func:`dp_solve_rows` on uniform grids without landmarks, laid out for throughput.
# Value and arg-min tables live in one flat, padded layout: node (i, j) is entry
# ``(i + P) * S + j + P`` with ``P`` the largest step and row stride ``S = n1 + 1 + P``; the
# ``P`` rows above and the ``P`` columns left of the grid hold ``H = +inf``, so a predecessor
# ``(i - a, j - b)`` is a constant offset from the node, with no bounds tests.  The Gram
# matrix is flat too, with row stride ``SG = n1 + 1`` (one zero column) and ``PT = 2 P`` zero
# rows above: every cell an edge into node (i, j) crosses is a constant offset from entry
# ``(i + PT) * SG + j``, so the cross term of slope ``nb`` on a block of rows is
# ``C[p] = sum_taps w * G[p + off]`` over one contiguous run of ``p``: one long vectorised
# loop per tap instead of one short one per (row, tap).  (Nodes with ``j < b`` read cells of
# the row above instead of zeros: finite values on edges whose predecessor is ``+inf``.)
# Work per pair: ``O(n0 n1 sum_(a,b) (a + b - 1))``, the edge work of the row kernel.


@njit(cache=True)
def _gram_padded(q0, q1t, Gp, PT, SG):  # pragma: no cover - numba
    """``Gp[(x + PT) * SG + y] = <q0[x], q1[y]>`` (``q1t`` = ``q1.T``), zero elsewhere.

    Summed over the dimension in a fixed order (four terms at a time, then added), whatever
    the batch: the same pair gives the same bits in every tiling and engine.
    """
    n0, D = q0.shape
    n1 = q1t.shape[1]
    Gp[:] = 0.0
    for x in range(n0):
        base = (x + PT) * SG
        row = Gp[base : base + n1]
        d = 0
        while d + 4 <= D:
            c0, c1, c2, c3 = q0[x, d], q0[x, d + 1], q0[x, d + 2], q0[x, d + 3]
            r0, r1, r2, r3 = q1t[d], q1t[d + 1], q1t[d + 2], q1t[d + 3]
            for y in range(n1):
                row[y] += (c0 * r0[y] + c1 * r1[y]) + (c2 * r2[y] + c3 * r3[y])
            d += 4
        while d < D:
            c0 = q0[x, d]
            r0 = q1t[d]
            for y in range(n1):
                row[y] += c0 * r0[y]
            d += 1


@njit(cache=True)
def _cross_block(Gp, C, lo, L, tap_ptr, tap_off, tap_w):  # pragma: no cover - numba
    """``C[nb, m] = sum_t tap_w[t] * Gp[lo + m + tap_off[t]]`` for ``m < L``, every slope.

    Taps are taken four (then two, one) at a time so the running sum is loaded and stored
    once per group.
    """
    for nb in range(tap_ptr.shape[0] - 1):
        c = C[nb, :L]
        t = tap_ptr[nb]
        te = tap_ptr[nb + 1]
        for m in range(L):
            c[m] = 0.0
        while t + 4 <= te:
            w0, w1, w2, w3 = tap_w[t], tap_w[t + 1], tap_w[t + 2], tap_w[t + 3]
            g0 = Gp[lo + tap_off[t] : lo + tap_off[t] + L]
            g1 = Gp[lo + tap_off[t + 1] : lo + tap_off[t + 1] + L]
            g2 = Gp[lo + tap_off[t + 2] : lo + tap_off[t + 2] + L]
            g3 = Gp[lo + tap_off[t + 3] : lo + tap_off[t + 3] + L]
            for m in range(L):
                c[m] += (w0 * g0[m] + w1 * g1[m]) + (w2 * g2[m] + w3 * g3[m])
            t += 4
        while t + 2 <= te:
            w0, w1 = tap_w[t], tap_w[t + 1]
            g0 = Gp[lo + tap_off[t] : lo + tap_off[t] + L]
            g1 = Gp[lo + tap_off[t + 1] : lo + tap_off[t + 1] + L]
            for m in range(L):
                c[m] += w0 * g0[m] + w1 * g1[m]
            t += 2
        if t < te:
            w0 = tap_w[t]
            g0 = Gp[lo + tap_off[t] : lo + tap_off[t] + L]
            for m in range(L):
                c[m] += w0 * g0[m]


@njit(cache=True)
def _prefix_norms(q, out):  # pragma: no cover - numba
    """``out[x + 1] = out[x] + |q[x]|^2 / n``: prefix integrals of ``|q|^2`` at the nodes of the
    uniform grid of ``n`` cells (``out[0] = 0``)."""
    n, D = q.shape
    out[0] = 0.0
    for x in range(n):
        s = 0.0
        for d in range(D):
            s += q[x, d] * q[x, d]
        out[x + 1] = out[x] + s / n


@njit(cache=True)
def _uniform_row(i, co, hb, P0, Hp, arg, C, Bp, steps, sqrt_s, S, n1):  # pragma: no cover - numba
    """Relax the nodes of row ``i`` (padded layout, ``hb`` its first node) by every slope; ``co``
    the row's offset in the block of cross terms ``C``."""
    best = Hp[hb : hb + n1 + 1]
    ab = arg[hb : hb + n1 + 1]
    for nb in range(steps.shape[0]):
        a = steps[nb, 0]
        b = steps[nb, 1]
        if a > i:
            continue
        # edge cost (paper 001 eq. 28): A + B - 2 sqrt(s) cross, clamped at 0 (rounding)
        A = P0[i] - P0[i - a]
        rs2 = 2.0 * sqrt_s[nb]
        hk = Hp[hb - a * S - b : hb - a * S - b + n1 + 1]
        bb = Bp[b, : n1 + 1]
        cc = C[nb, co : co + n1 + 1]
        for j in range(1, n1 + 1):
            e = A + bb[j] - rs2 * cc[j]
            if e < 0.0:
                e = 0.0
            v = hk[j] + e
            if v < best[j]:
                best[j] = v
                ab[j] = nb


@njit(cache=True)
def _uniform_path(arg, steps, P, S, t0, t1):  # pragma: no cover - numba
    """Backtrack (eq. 30) from ``(n0, n1)`` in the padded layout: the vertices ``(x, y)`` of
    the DP warp, from ``(0, 0)``."""
    n0 = t0.shape[0] - 1
    n1 = t1.shape[0] - 1
    x = np.empty(n0 + n1 + 1)
    y = np.empty(n0 + n1 + 1)
    i = n0
    j = n1
    cnt = 0
    while True:
        x[cnt] = t0[i]
        y[cnt] = t1[j]
        cnt += 1
        if i == 0 and j == 0:
            break
        nb = arg[(i + P) * S + j + P]
        i -= steps[nb, 0]
        j -= steps[nb, 1]
    return x[:cnt][::-1].copy(), y[:cnt][::-1].copy()


@njit(cache=True)
def _dp_uniform_pair(q0, q1, steps, taps, layout, t0, t1, scratch):  # pragma: no cover - numba
    """DP of one pair in the padded layout; returns ``(exact energy of the DP path, H value)``.

    ``taps = (tap_ptr, tap_off, tap_w, sqrt_s)``, ``layout = (P, S, PT, SG, R)`` (module
    comment above; ``R`` rows per block of cross terms); the scratch arrays
    ``(q1t, Gp, Hp, arg, C, Bp)`` come from the caller.
    The recursion is that of :func:`dp_solve_rows` (same slope order, same strict ``<``, so
    the same ties win); the returned energy is :func:`energy_direct` of the backtracked path,
    as :func:`elastic_motion.warp.optimal_warp` reports it.  ``(+inf, +inf)``: no path.
    """
    tap_ptr, tap_off, tap_w, sqrt_s = taps
    P, S, PT, SG, R = layout
    q1t, Gp, Hp, arg, C, Bp = scratch
    n0, D = q0.shape
    n1 = q1.shape[0]
    for y in range(n1):
        for d in range(D):
            q1t[d, y] = q1[y, d]
    _gram_padded(q0, q1t, Gp, PT, SG)
    # prefix integrals of |q|^2 at the nodes (uniform cells: h = 1 / n)
    P0 = np.zeros(n0 + 1)
    _prefix_norms(q0, P0)
    P1 = np.zeros(n1 + 1)
    _prefix_norms(q1, P1)
    # Bp[b, j] = int_{v_(j-b)}^{v_j} |q1|^2 (0 where j < b: H is +inf there anyway)
    for b in range(1, Bp.shape[0]):
        for j in range(n1 + 1):
            Bp[b, j] = P1[j] - P1[j - b] if j >= b else 0.0
    Hp[:] = np.inf
    arg[:] = -1
    Hp[P * S + P] = 0.0
    for i0 in range(1, n0 + 1, R):
        i1 = min(i0 + R, n0 + 1)
        _cross_block(Gp, C, (i0 + PT) * SG, (i1 - i0) * SG, tap_ptr, tap_off, tap_w)
        for i in range(i0, i1):
            _uniform_row(i, (i - i0) * SG, (i + P) * S + P, P0, Hp, arg, C, Bp, steps, sqrt_s, S, n1)
    value = Hp[(n0 + P) * S + n1 + P]
    if not np.isfinite(value):
        return np.inf, np.inf
    # backtrack into the vertices of phi, then the exact energy of that warp
    x, y = _uniform_path(arg, steps, P, S, t0, t1)
    return energy_direct(q0, t0, q1, t1, x, y), value


@njit(cache=True)
def _batch_setup(n0, n1, steps, taps, block_rows):  # pragma: no cover - numba
    """Layout ``(P, S, PT, SG, R)``, kernel taps ``(tap_ptr, tap_off, tap_w, sqrt_s)`` (offsets
    in the Gram layout) and the grids ``t0``, ``t1`` of a batch (module comment above)."""
    tap_ptr, tap_dp, tap_dr, tap_w, sqrt_s = taps
    K = steps.shape[0]
    P = 1
    for nb in range(K):
        P = max(P, steps[nb, 0], steps[nb, 1])
    SG = n1 + 1
    tap_off = np.empty(tap_w.shape[0], dtype=np.int64)
    for nb in range(K):
        for t in range(tap_ptr[nb], tap_ptr[nb + 1]):
            tap_off[t] = (tap_dp[t] - steps[nb, 0]) * SG + (tap_dr[t] - steps[nb, 1])
    layout = (P, n1 + 1 + P, 2 * P, SG, max(1, min(block_rows, n0)))
    return (
        layout,
        (tap_ptr, tap_off, tap_w, sqrt_s),
        np.linspace(0.0, 1.0, n0 + 1),
        np.linspace(0.0, 1.0, n1 + 1),
    )


@njit(cache=True)
def _batch_scratch(n0, n1, D, K, layout):  # pragma: no cover - numba
    """Scratch arrays ``(q1t, Gp, Hp, arg, C, Bp)`` of :func:`_dp_uniform_pair` (one per thread)."""
    P, S, PT, SG, R = layout
    size = (n0 + P + 1) * S
    return (
        np.empty((D, n1)),
        np.empty((n0 + PT + 1) * SG),
        np.empty(size),
        np.empty(size, dtype=np.int16),
        np.empty((K, R * SG)),
        np.zeros((P + 1, n1 + 1)),
    )


@njit(cache=True, parallel=True, nogil=True)
def dp_energies_uniform(Q0, Q1, i0s, i1s, steps, taps, block_rows):  # pragma: no cover - numba
    """DP energies of many pairs ``(Q0[i0s[p]], Q1[i1s[p]])`` on uniform grids, no landmarks.

    Parameters
    ----------
    Q0, Q1 : (M0, n0, D), (M1, n1, D) float64
        SRV arrays on ``linspace(0, 1, n + 1)``.
    i0s, i1s : (npairs,) int64
        The pairs.
    steps : (K, 2) int64
        Neighbourhood.
    taps : tuple (tap_ptr, tap_dp, tap_dr, tap_w, sqrt_s)
        Its uniform-grid taps, as for :func:`dp_solve` (the taps of the grids ``(n0, n1)``).
    block_rows : int
        Rows of the grid whose cross terms are computed together (a few: they stay in cache).

    Returns
    -------
    energy : (npairs,) float64
        Exact energy of each pair's DP warp (``+inf``: no path reaches (1, 1)).
    value : (npairs,) float64
        The DP's own value ``H[n0, n1]`` (equal to ``energy`` up to rounding).

    Pairs are split among numba's threads (``numba.set_num_threads``); each pair is solved
    by one thread, so the results do not depend on the number of threads (and equal those
    of :func:`dp_energies_uniform_serial`).  The GIL is released.
    """
    n0, n1, D, K = Q0.shape[1], Q1.shape[1], Q0.shape[2], steps.shape[0]
    layout, ktaps, t0, t1 = _batch_setup(n0, n1, steps, taps, block_rows)
    npairs = i0s.shape[0]
    energy = np.empty(npairs)
    value = np.empty(npairs)
    nchunk = min(npairs, 256)
    for ch in prange(nchunk):
        scratch = _batch_scratch(n0, n1, D, K, layout)
        for p in range(ch, npairs, nchunk):
            e, v = _dp_uniform_pair(Q0[i0s[p]], Q1[i1s[p]], steps, ktaps, layout, t0, t1, scratch)
            energy[p] = e
            value[p] = v
    return energy, value


@njit(cache=True, nogil=True)
def dp_energies_uniform_serial(Q0, Q1, i0s, i1s, steps, taps, block_rows):  # pragma: no cover - numba
    """:func:`dp_energies_uniform` on the calling thread only (for one numba thread, e.g. a
    single-threaded Dask worker: the parallel version would still go through numba's
    threading layer, whose idle threads spin beside the other workers)."""
    n0, n1, D, K = Q0.shape[1], Q1.shape[1], Q0.shape[2], steps.shape[0]
    layout, ktaps, t0, t1 = _batch_setup(n0, n1, steps, taps, block_rows)
    npairs = i0s.shape[0]
    energy = np.empty(npairs)
    value = np.empty(npairs)
    scratch = _batch_scratch(n0, n1, D, K, layout)
    for p in range(npairs):
        energy[p], value[p] = _dp_uniform_pair(Q0[i0s[p]], Q1[i1s[p]], steps, ktaps, layout, t0, t1, scratch)
    return energy, value


# ----------------------------------------------------------------------------- energies


@njit(cache=True)
def energy_direct(q0, t0, q1, t1, x, y):  # pragma: no cover - numba
    """Exact ``int_0^1 |q0 - sqrt(phi') q1(phi)|^2`` for piecewise linear ``phi``.

    Walks the merged break points (the q0 breaks, the phi vertices ``x``, and the
    pre-images of the q1 breaks) and sums ``|q0[a] - sqrt(s) q1[b]|^2 * length`` over the
    pieces, D-dimensional and term by term non-negative (no cancellation).  On pieces of
    slope 0 (``phi`` flat) the q1 term vanishes.
    """
    n0 = q0.shape[0]
    n1 = q1.shape[0]
    D = q0.shape[1]
    K = x.shape[0] - 1
    total = 0.0
    a = 0
    b = 0
    for p in range(K):
        xs = x[p]
        xe = x[p + 1]
        if xe <= xs:
            continue
        ys = y[p]
        ye = y[p + 1]
        s = (ye - ys) / (xe - xs)
        rs = np.sqrt(s) if s > 0.0 else 0.0
        # cells that hold the start of the piece
        while a < n0 - 1 and t0[a + 1] <= xs:
            a += 1
        while b < n1 - 1 and t1[b + 1] <= ys:
            b += 1
        xc = xs
        while True:
            # the last cell has no further break (guards rounding of end values past 1)
            na = t0[a + 1] if (t0[a + 1] < xe and a < n0 - 1) else xe
            if s > 0.0 and t1[b + 1] < ye and b < n1 - 1:
                nb = xs + (t1[b + 1] - ys) / s
                if nb > xe:
                    nb = xe
            else:
                nb = xe
            nx = na if na < nb else nb
            if nx > xc:
                e = 0.0
                for d in range(D):
                    r = q0[a, d] - rs * q1[b, d]
                    e += r * r
                total += e * (nx - xc)
            if nx >= xe:
                break
            xc = nx
            if na <= nx and a < n0 - 1:
                a += 1
            if nb <= nx and b < n1 - 1:
                b += 1
    return total
