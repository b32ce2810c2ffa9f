"""Numba kernels of the gradient refinement (:mod:`elastic_motion.warp.refine`): the whole
L-BFGS descent runs compiled, one call per refinement.

Conventions (see :mod:`elastic_motion.warp.refine`): the warp is piecewise linear on fixed
domain nodes ``u`` ``(K+1,)`` with vertex values ``y = phi(u)`` ``(K+1,)``, parametrised by
``z`` ``(K,)`` on the unit sphere: ``y_k = sum_{r<k} z_r^2 / sum_r z_r^2``. The pair is in
Gram form: break points ``t0`` ``(n0+1,)``, ``t1`` ``(n1+1,)``, ``G = q0 q1^T`` ``(n0, n1)``,
``A_tot = ||q0||^2``, ``B_tot = ||q1||^2``; ``prob = (t0, t1, G, A_tot, B_tot, u)``.

Landmark term ``lmk = (lam, kind, theta0, theta1, windows, piece, tab0, tab1, symmetric)``:
``kind`` as in :mod:`elastic_motion.warp.dp_kernels` (0 squared, 1 absolute, 2 none: windows
only, 3 a callable tabulated on ``[0, 1]``: ``tab0`` row ``m`` is ``f(x, theta1_m)``, ``tab1``
row ``m`` is ``f(x, theta0_m)``); ``theta0``, ``theta1``, ``windows`` ``(M,)`` (windows with
the rounding slack added, ``+inf`` where none); ``piece[m]`` the linear piece of ``u`` that
holds ``theta0_m``. ``M = 0``: no landmark term.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from elastic_motion.warp.dp_kernels import table_value

#: Why the descent stopped (:data:`STOP_REASONS` names them).
STOP_MAX_ITER, STOP_TOL, STOP_STATIONARY, STOP_LINE_SEARCH, STOP_INFEASIBLE = 0, 1, 2, 3, 4
STOP_REASONS = ("max_iter", "tol", "stationary", "line search", "infeasible start")

#: Armijo constant and the halvings of the backtracking line search.
ARMIJO = 1e-4
HALVINGS = 40
#: The first step of a descent (no curvature pair yet) moves at most this far on the sphere.
FIRST_STEP = 0.1


@njit(cache=True)
def energy_and_grad(t0, t1, G, A_tot, B_tot, x, y, grad):  # pragma: no cover - numba
    """Exact elastic energy of a piecewise linear ``phi`` and its gradient in the vertex values.

    ``x`` ``(K+1,)`` must hold every break point of ``t0`` (each piece of ``phi`` lies in one
    cell ``a`` of q0; the refinement's nodes do), ``y`` ``(K+1,)`` the values ``phi(x)``.
    ``E = A_tot + B_tot - 2 sum_p sqrt(s_p) C_p`` with ``C_p`` the cross integral of piece p
    (Gram form).  Differentiating ``F_p = sqrt(s) int_0^L <q0(x_p + t), q1(y_p + s t)> dt``
    in the end values (``L`` the piece length, ``s = (y_{p+1} - y_p) / L``):

        dF/dy_{p+1} =  C/(2 sqrt(s) L) + sum_b <q0(x_b), J_b> (t_b / L) / sqrt(s)
        dF/dy_p     = -C/(2 sqrt(s) L) + sum_b <q0(x_b), J_b> (1 - t_b / L) / sqrt(s)

    where ``J_b = q1[b] - q1[b-1]`` is the jump of q1 at the break ``t1[b]`` inside the
    range and ``t_b`` its pre-image offset (q1' is a sum of Dirac masses: this is the
    discrete form of the ``q1' * phi`` term in Lemma 12 / 14 of paper 001),
    ``<q0[a], J_b> = G[a, b] - G[a, b-1]``.

    Returns ``E`` and writes ``d E / d y_p`` into ``grad`` ``(K+1,)``.
    """
    n0 = t0.shape[0] - 1
    n1 = t1.shape[0] - 1
    K = x.shape[0] - 1
    grad[:] = 0.0
    total = 0.0
    a = 0
    b = 0
    for p in range(K):
        xs = x[p]
        xe = x[p + 1]
        ys = y[p]
        ye = y[p + 1]
        while a < n0 - 1 and t0[a + 1] <= xs:
            a += 1
        if a < n0 - 1 and t0[a + 1] < xe:
            raise ValueError("energy_and_grad: x must hold every break point of t0")
        while b < n1 - 1 and t1[b + 1] <= ys:
            b += 1
        dy = ye - ys
        if dy <= 0.0:
            continue  # flat piece: no cross term (its gradient is infinite; psi-form avoids it)
        inv_L = 1.0 / (xe - xs)
        rs = np.sqrt(dy * inv_L)
        inv_rs = 1.0 / rs
        inv_s = inv_rs * inv_rs  # pre-image of a q1 break t: xs + (t - ys) inv_s
        inv_dy = inv_s * inv_L
        C = 0.0
        J = 0.0  # sum_b <q0, J_b> t_b / L
        Jc = 0.0  # sum_b <q0, J_b> (1 - t_b / L)
        xc = xs  # start of the current q1 cell's stretch of the piece
        while b < n1 - 1 and t1[b + 1] < ye:  # the q1 breaks inside the piece's range
            nb = min(xs + (t1[b + 1] - ys) * inv_s, xe)
            C += G[a, b] * (nb - xc)
            xc = nb
            b += 1
            w = (t1[b] - ys) * inv_dy  # t_b / L
            g = G[a, b] - G[a, b - 1]
            J += g * w
            Jc += g * (1.0 - w)
        C += G[a, b] * (xe - xc)
        total += rs * C
        c2 = 0.5 * C * inv_L
        grad[p + 1] += -2.0 * inv_rs * (c2 + J)
        grad[p] += -2.0 * inv_rs * (Jc - c2)
    return A_tot + B_tot - 2.0 * total


@njit(cache=True)
def warp_values(z, y):  # pragma: no cover - numba
    """``y_k = sum_{r<k} z_r^2 / sum_r z_r^2`` into ``y`` ``(K+1,)``: from 0 to exactly 1."""
    K = z.shape[0]
    S = 0.0
    for r in range(K):
        S += z[r] * z[r]
    inv_S = 1.0 / S
    c = 0.0
    y[0] = 0.0
    for r in range(K):
        c += z[r] * z[r]
        v = c * inv_S
        y[r + 1] = v if v < 1.0 else 1.0  # rounding can put the sum a hair above 1
    y[K] = 1.0


@njit(cache=True, inline="always")
def _penalty(kind, tab, m, r, x):  # pragma: no cover - numba
    """``FM(x, target)`` (``r = x - target``) and ``d FM / d x`` (without ``lam``)."""
    if kind == 0:
        return r * r, 2.0 * r
    if kind == 1:
        return abs(r), (1.0 if r > 0.0 else (-1.0 if r < 0.0 else 0.0))
    if kind == 3:
        h = 1e-6
        return table_value(tab, m, x), (table_value(tab, m, x + h) - table_value(tab, m, x - h)) / (2.0 * h)
    return 0.0, 0.0


@njit(cache=True, inline="always")
def _search_left(y: np.ndarray, v: float) -> int:
    """``np.searchsorted(y, v)`` (side "left": the first ``i`` with ``y[i] >= v``) for an
    increasing ``y``, as a plain loop: numba's ``searchsorted`` makes loading this module's
    cached kernels import its array-math module and scipy.linalg (0.15-0.2 s per process)."""
    lo, hi = 0, y.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if y[mid] < v:
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(cache=True)
def landmark_term(y, u, lmk, grad):  # pragma: no cover - numba
    """Landmark term of the warp with vertex values ``y`` on ``u``; adds its gradient in
    ``y`` to ``grad``. ``+inf`` (``grad`` untouched) when a hard window is violated."""
    lam, kind, theta0, theta1, windows, piece, tab0, tab1, symmetric = lmk
    M = theta0.shape[0]
    if M == 0:
        return 0.0
    K = u.shape[0] - 1
    x = np.empty(M)
    xi = np.empty(M)
    p = np.empty(M, dtype=np.int64)
    for m in range(M):  # phi(theta0_m) on its linear piece
        r = piece[m]
        f = (theta0[m] - u[r]) / (u[r + 1] - u[r])
        x[m] = y[r] + f * (y[r + 1] - y[r])
        if abs(x[m] - theta1[m]) > windows[m]:
            return np.inf
    if symmetric:  # phi^{-1}(theta1_m): the first piece whose range reaches it
        for m in range(M):
            k = min(max(_search_left(y, theta1[m]) - 1, 0), K - 1)
            p[m] = k
            dy = y[k + 1] - y[k]
            xi[m] = u[k] + ((theta1[m] - y[k]) / dy if dy > 0.0 else 0.0) * (u[k + 1] - u[k])
            if abs(xi[m] - theta0[m]) > windows[m]:
                return np.inf
    total = 0.0
    for m in range(M):
        r = piece[m]
        f = (theta0[m] - u[r]) / (u[r + 1] - u[r])
        v, d = _penalty(kind, tab0, m, x[m] - theta1[m], x[m])
        total += v
        grad[r] += lam * d * (1.0 - f)
        grad[r + 1] += lam * d * f
    if symmetric:
        for m in range(M):
            k = p[m]
            v, d = _penalty(kind, tab1, m, xi[m] - theta0[m], xi[m])
            total += v
            dy = y[k + 1] - y[k]
            if dy > 0.0:
                du = u[k + 1] - u[k]
                grad[k] += lam * d * du * (theta1[m] - y[k + 1]) / (dy * dy)
                grad[k + 1] -= lam * d * du * (theta1[m] - y[k]) / (dy * dy)
    return lam * total


@njit(cache=True)
def objective(z, prob, lmk, y, gy, gz):  # pragma: no cover - numba
    """Energy (elastic + landmark) at ``z`` and its gradient in ``z`` (into ``gz``); ``y`` and
    ``gy`` ``(K+1,)`` are scratch (on return: the vertex values and the gradient in them).
    ``+inf`` (``gz = 0``) when a hard window is violated."""
    t0, t1, G, A_tot, B_tot, u = prob
    K = z.shape[0]
    warp_values(z, y)
    e = energy_and_grad(t0, t1, G, A_tot, B_tot, u, y, gy)
    le = landmark_term(y, u, lmk, gy)
    if not np.isfinite(le):
        gz[:] = 0.0
        return np.inf
    # chain rule y_k = sum_{r<k} w_r / S, w_r = z_r^2:
    # dE/dw_r = (sum_{k>r} g_k - sum_k g_k y_k) / S
    S = 0.0
    gdy = 0.0
    for r in range(K):
        S += z[r] * z[r]
    for k in range(K + 1):
        gdy += gy[k] * y[k]
    two_inv_S = 2.0 / S
    suffix = 0.0
    for r in range(K - 1, -1, -1):
        suffix += gy[r + 1]
        gz[r] = two_inv_S * z[r] * (suffix - gdy)
    return e + le


@njit(cache=True, fastmath={"reassoc"})
def _dot(a, b):  # pragma: no cover - numba
    """``<a, b>``, summed in any order (vectorised; deterministic on one machine)."""
    acc = 0.0
    for i in range(a.shape[0]):
        acc += a[i] * b[i]
    return acc


@njit(cache=True)
def _direction(g, z, S, Y, count, newest, d, work):  # pragma: no cover - numba
    """The L-BFGS direction into ``d``: the two-loop recursion over the ``count`` newest pairs
    of the ring buffers ``S``, ``Y`` (``newest`` the row of the last one), made tangent to the
    sphere at ``z``. Returns ``(slope <g, d>, restarted)``; a direction that does not descend
    is replaced by steepest descent ``-g`` (``restarted``: the caller clears the memory).
    ``work`` ``(2, memory)`` is scratch."""
    memory = S.shape[0]
    K = g.shape[0]
    alpha, rho = work[0], work[1]
    for k in range(K):
        d[k] = -g[k]
    for i in range(count):  # newest first
        j = (newest - i) % memory
        rho[i] = 1.0 / _dot(Y[j], S[j])
        alpha[i] = rho[i] * _dot(S[j], d)
        for k in range(K):
            d[k] -= alpha[i] * Y[j, k]
    if count > 0:
        gamma = _dot(S[newest], Y[newest]) / _dot(Y[newest], Y[newest])
        for k in range(K):
            d[k] *= gamma
    for i in range(count - 1, -1, -1):  # oldest first
        j = (newest - i) % memory
        c = alpha[i] - rho[i] * _dot(Y[j], d)
        for k in range(K):
            d[k] += c * S[j, k]
    dz = _dot(d, z)
    for k in range(K):  # keep the direction tangent to the sphere
        d[k] -= dz * z[k]
    slope = _dot(g, d)
    if slope >= 0.0:  # not a descent direction: restart from steepest descent
        for k in range(K):
            d[k] = -g[k]
        return _dot(g, d), True
    return slope, False


@njit(cache=True)
def _line_search(z, d, e, slope, step, prob, lmk, buf):  # pragma: no cover - numba
    """Backtracking on the sphere from ``z`` along ``d``: the first of ``HALVINGS`` halvings of
    ``step`` that meets Armijo with a strict decrease; its point and gradient are left in
    ``buf = (zn, gn, y, gy)``. Returns ``(energy, evaluations)``, the energy ``nan`` when none."""
    zn, gn, y, gy = buf
    for it in range(HALVINGS):
        for k in range(z.shape[0]):
            zn[k] = z[k] + step * d[k]
        norm = np.sqrt(_dot(zn, zn))
        for k in range(z.shape[0]):
            zn[k] /= norm
        en = objective(zn, prob, lmk, y, gy, gn)
        if en <= e + ARMIJO * step * slope and en < e:
            return en, it + 1
        # the minimiser of the quadratic through e, slope and en, within [0.1, 0.5] step
        curv = en - e - slope * step
        if np.isfinite(en) and curv > 0.0:
            step = min(max(-0.5 * slope * step * step / curv, 0.1 * step), 0.5 * step)
        else:
            step *= 0.5
    return np.nan, HALVINGS


@njit(cache=True)
def lbfgs(z, prob, lmk, tol, max_iter, memory, window):  # pragma: no cover - numba
    """L-BFGS on the unit sphere from ``z`` ``(K,)``, with a backtracking (Armijo) line search
    whose steps strictly decrease the energy.

    Stops (:data:`STOP_REASONS`) when the relative decrease over the last ``window``
    iterations is below ``window * tol``, after ``max_iter`` iterations, when the direction
    does not descend (a zero gradient) or when no step of the line search decreases.

    Returns ``(z, energy at the start, energy, iterations, stop code, evaluations)``.
    """
    K = z.shape[0]
    z = z.copy()
    g = np.empty(K)
    y = np.empty(K + 1)
    gy = np.empty(K + 1)
    e = objective(z, prob, lmk, y, gy, g)
    e_start = e
    if not np.isfinite(e):
        return z, e_start, e, 0, STOP_INFEASIBLE, 1
    n_eval = 1
    S = np.empty((memory, K))
    Y = np.empty((memory, K))
    d = np.empty(K)
    work = np.empty((2, memory))
    sk = np.empty(K)
    yk = np.empty(K)
    buf = (np.empty(K), np.empty(K), y, gy)
    history = np.empty(max_iter + 1)
    history[0] = e
    count = 0
    newest = memory - 1
    stop = STOP_MAX_ITER
    it = 0
    for it in range(1, max_iter + 1):
        slope, restarted = _direction(g, z, S, Y, count, newest, d, work)
        if restarted:
            count = 0
        if not slope < 0.0:  # zero or nan gradient
            stop = STOP_STATIONARY
            break
        step = 1.0 if count > 0 else min(1.0, FIRST_STEP / (np.sqrt(_dot(d, d)) + 1e-300))
        en, evals = _line_search(z, d, e, slope, step, prob, lmk, buf)
        n_eval += evals
        if np.isnan(en):
            stop = STOP_LINE_SEARCH
            break
        zn, gn = buf[0], buf[1]
        for k in range(K):
            sk[k] = zn[k] - z[k]
            yk[k] = gn[k] - g[k]
        if _dot(sk, yk) > 1e-12 * _dot(sk, sk):  # keep curvature pairs only
            newest = (newest + 1) % memory
            S[newest] = sk
            Y[newest] = yk
            count = min(count + 1, memory)
        z[:] = zn
        g[:] = gn
        e = en
        history[it] = e
        # relative decrease over the last `window` iterations (single L-BFGS steps on a
        # piecewise smooth energy are erratic: one short step must not stop the descent)
        if it >= window and (history[it - window] - e) / max(abs(e), 1e-300) < window * tol:
            stop = STOP_TOL
            break
    return z, e_start, e, it, stop, n_eval
