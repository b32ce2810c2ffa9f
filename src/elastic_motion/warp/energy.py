"""The discrete objective and the algebra of piecewise linear warps.

Conventions (fixed project-wide, see :mod:`elastic_motion.warp`): an SRV array ``q`` of
shape ``(n, D)`` is piecewise constant, ``q[i]`` holding on ``[t[i], t[i+1])`` of the
strictly increasing grid ``t`` of shape ``(n+1,)`` from 0 to 1 (``linspace(0, 1, n+1)`` when
not given).  A warp is a piecewise linear ``phi`` given by its vertices, an array of shape
``(K, 2)`` of ``(x_k, phi(x_k))`` with ``x`` strictly increasing from 0 to 1 and ``phi``
non-decreasing from 0 to 1.  It acts on q1 by ``(q1 * phi)(t) = sqrt(phi'(t)) q1(phi(t))``.

:func:`warp_energy` is the one scoring function of the discrete objective used by the
solvers, the tests and the benchmark: for piecewise constant q's and piecewise linear
``phi`` the integral ``int_0^1 |q0 - sqrt(phi') q1(phi)|^2 dt`` is a finite sum over the
merged break points (the q0 breaks, the vertices of phi and the pre-images of the q1
breaks), computed exactly (up to rounding), not by resampling.

The action itself, ``q * phi`` as a new piecewise constant SRV, lives in the curves layer:
:func:`elastic_motion.curves.reparametrize_srv`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from elastic_motion._validation import as_float_array, check_finite, check_parameters
from elastic_motion.curves import as_warp_vertices
from elastic_motion.warp import dp_kernels

# break points closer than this (in parameter units) are merged by the exact action
MERGE_TOL = 1e-13


def kernel_array(x: Any, dtype: Any = np.float64) -> np.ndarray:
    """Writable C-contiguous array: one numba specialisation per kernel (readonly or strided
    arrays would each compile another one)."""
    return np.require(x, dtype=dtype, requirements=["C", "W"])


def check_srv(q: Any, t: Any, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Validate an SRV array and its grid; returns float64 ``(q (n, D), t (n+1,))``.

    ``q`` may also be an object with ``.q`` and ``.t`` (an
    :class:`elastic_motion.curves.SRVFunction`); then ``t`` must be None.
    """
    if hasattr(q, "q") and hasattr(q, "t"):
        if t is not None:
            raise ValueError(f"{name}: an SRVFunction carries its own grid; do not pass t as well")
        q, t = q.q, q.t
    arr = as_float_array(q, name)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2 or arr.shape[0] < 1 or arr.shape[1] < 1:
        raise ValueError(
            f"{name}: expected an SRV array of shape (n, D) (n cells, D dimensions); got shape {arr.shape}"
        )
    check_finite(arr, name)
    n = arr.shape[0]
    tname = "t" + name[1:] if name.startswith("q") else f"{name}_t"
    if t is None:
        grid = np.linspace(0.0, 1.0, n + 1)
    else:
        grid = check_parameters(t, tname, n_points=n + 1)
    return kernel_array(arr), kernel_array(grid)


def check_pair(
    q0: Any, q1: Any, t0: Any = None, t1: Any = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Validate two SRV arrays of the same dimension D (numbers of cells may differ)."""
    q0a, t0a = check_srv(q0, t0, "q0")
    q1a, t1a = check_srv(q1, t1, "q1")
    if q0a.shape[1] != q1a.shape[1]:
        raise ValueError(
            f"q0, q1: expected SRV arrays of the same dimension D; got q0 of shape {q0a.shape} "
            f"(D = {q0a.shape[1]}) and q1 of shape {q1a.shape} (D = {q1a.shape[1]})"
        )
    return q0a, t0a, q1a, t1a


def check_vertices(vertices: Any, name: str = "vertices") -> np.ndarray:
    """Validate the vertices ``(K, 2)`` of a piecewise linear warp (returns a float64 copy).

    End values within 1e-9 of 0 and 1 are snapped (warps read from other tools, e.g.
    fdasrsf's normalised gamma, end at ``1 - 1e-16``); the rest is
    :func:`elastic_motion.curves.as_warp_vertices`: ``x`` strictly increasing from 0 to 1,
    ``phi`` non-decreasing from 0 to 1.
    """
    v = np.array(as_float_array(vertices, name), dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != 2 or v.shape[0] < 2:
        raise ValueError(
            f"{name}: expected warp vertices (x_k, phi(x_k)) of shape (K, 2), K >= 2; got shape {v.shape}"
        )
    check_finite(v, name)
    for c in (0, 1):
        if abs(v[0, c]) <= 1e-9:
            v[0, c] = 0.0
        if abs(v[-1, c] - 1.0) <= 1e-9:
            v[-1, c] = 1.0
    return np.ascontiguousarray(as_warp_vertices(v, name=name))


def warp_energy(q0: Any, q1: Any, phi_vertices: Any, t0: Any = None, t1: Any = None) -> float:
    """Exact elastic energy ``int_0^1 |q0(t) - sqrt(phi'(t)) q1(phi(t))|^2 dt``.

    The one common scoring function of the discrete objective: exact for piecewise
    constant ``q0``, ``q1`` and piecewise linear ``phi`` (a sum over the merged break
    points; each term ``|q0[a] - sqrt(s) q1[b]|^2 * length`` is computed in D dimensions,
    so there is no cancellation).  Cost O((n0 + n1 + K) D).

    Parameters
    ----------
    q0 : array_like, shape (n0, D)
        SRV of curve 0, cell-valued on ``t0``.
    q1 : array_like, shape (n1, D)
        SRV of curve 1, cell-valued on ``t1``.
    phi_vertices : array_like, shape (K, 2)
        Vertices ``(x_k, phi(x_k))`` of the warp (see :func:`check_vertices`).
    t0, t1 : array_like, shape (n0+1,) and (n1+1,), optional
        Break points; uniform when omitted.

    Returns
    -------
    float
        The energy (without landmark term; see :func:`landmark_cost`).  For the identity
        warp on equal grids it is ``||q0 - q1||^2_{L^2}``.
    """
    q0a, t0a, q1a, t1a = check_pair(q0, q1, t0, t1)
    v = check_vertices(phi_vertices, "phi_vertices")
    return float(dp_kernels.energy_direct(q0a, t0a, q1a, t1a, kernel_array(v[:, 0]), kernel_array(v[:, 1])))


def warp_at(vertices: Any, t: Any) -> np.ndarray:
    """Evaluate the piecewise linear warp at parameters ``t`` (any shape)."""
    v = check_vertices(vertices)
    return np.interp(np.asarray(t, dtype=np.float64), v[:, 0], v[:, 1])


def invert_warp(vertices: Any) -> np.ndarray:
    """Vertices of ``phi^{-1}``, shape ``(K, 2)``.

    Raises ``ValueError`` when ``phi`` has a flat piece (slope 0): its inverse jumps and is
    not a piecewise linear function.
    """
    v = check_vertices(vertices)
    if (np.diff(v[:, 1]) <= 0).any():
        k = int(np.argmax(np.diff(v[:, 1]) <= 0))
        raise ValueError(
            f"vertices: phi is flat on [{v[k, 0]!r}, {v[k + 1, 0]!r}], so phi^-1 jumps there "
            "and has no piecewise linear inverse"
        )
    return np.ascontiguousarray(v[:, ::-1])


def compose_warps(phi_a: Any, phi_b: Any) -> np.ndarray:
    """Vertices of ``phi_a o phi_b`` (first ``phi_b``, then ``phi_a``), shape ``(K, 2)``.

    With the right action this is the warp of two successive actions:
    ``(q * phi_a) * phi_b = q * (phi_a o phi_b)``.
    """
    a = check_vertices(phi_a, "phi_a")
    b = check_vertices(phi_b, "phi_b")
    # break points of the composition: vertices of phi_b and pre-images of phi_a's vertices
    pre = preimages(b, a[:, 0])
    x = np.union1d(b[:, 0], pre)
    x = _merge_close(x)
    y = np.interp(np.interp(x, b[:, 0], b[:, 1]), a[:, 0], a[:, 1])
    y = np.maximum.accumulate(y)
    y[0], y[-1] = 0.0, 1.0
    return np.column_stack([x, y])


def preimages(v: np.ndarray, levels: np.ndarray) -> np.ndarray:
    """Parameters ``x`` with ``phi(x) = level`` (first one on flat pieces)."""
    x, y = v[:, 0], v[:, 1]
    idx = np.clip(np.searchsorted(y, levels, side="left"), 1, len(y) - 1)
    y0, y1 = y[idx - 1], y[idx]
    dy = y1 - y0
    frac = np.where(dy > 0, (levels - y0) / np.where(dy > 0, dy, 1.0), 0.0)
    return np.clip(x[idx - 1] + frac * (x[idx] - x[idx - 1]), 0.0, 1.0)


def _merge_close(x: np.ndarray) -> np.ndarray:
    """Sorted unique break points, dropping those within ``MERGE_TOL`` of the previous."""
    x = np.unique(np.clip(x, 0.0, 1.0))
    keep = np.ones(x.shape[0], dtype=bool)
    keep[1:] = np.diff(x) > MERGE_TOL
    x = x[keep]
    x[0] = 0.0
    if x[-1] < 1.0 - MERGE_TOL:
        x = np.append(x, 1.0)
    x[-1] = 1.0
    return x


def shift_seed(q: Any, t: Any, shift: float) -> tuple[np.ndarray, np.ndarray]:
    """Move the start of a closed curve's SRV: ``q_new(s) = q((s + shift) mod 1)``.

    Exact; a cell is split when ``shift`` is not a break point.

    Returns
    -------
    q_new : ndarray, shape (m, D)
    t_new : ndarray, shape (m+1,)
    """
    qa, ta = check_srv(q, t, "q")
    tau = float(shift) % 1.0
    if tau == 0.0:
        return qa.copy(), ta.copy()
    x = _merge_close(np.concatenate([(ta - tau) % 1.0, [0.0, 1.0]]))
    mid = 0.5 * (x[1:] + x[:-1])
    cell = np.clip(np.searchsorted(ta, (mid + tau) % 1.0, side="right") - 1, 0, qa.shape[0] - 1)
    return qa[cell].copy(), x


def srv_norm2(q: np.ndarray, t: np.ndarray) -> float:
    """``||q||^2_{L^2} = sum_i |q_i|^2 (t[i+1] - t[i])``."""
    return float(np.einsum("ij,ij,i->", q, q, np.diff(t)))


def check_finite_scalar(value: float, name: str) -> None:
    """Raise ``ValueError`` if ``value`` is not a finite number."""
    check_finite(np.asarray([value], dtype=np.float64), name)


def swap_closed_match(vertices: Any, seed: float) -> tuple[float, np.ndarray]:
    """Turn a match of q0 onto q1 into the same match of q1 onto q0.

    A closed match ``(sigma, psi)`` of ``q_b`` onto ``q_a`` compares ``q_a`` with
    ``shift_seed(q_b, sigma) * psi``.  The same correspondence seen from ``q_b`` is the
    circle map ``x -> psi^{-1}((x - sigma) mod 1)``: the seed ``tau = psi^{-1}(1 - sigma)`` of
    ``q_a`` and the warp ``phi(x) = (psi^{-1}((x - sigma) mod 1) - tau) mod 1``, with
    ``||q_a - shift_seed(q_b, sigma) * psi|| = ||q_b - shift_seed(q_a, tau) * phi||`` exactly
    (the action is an isometry).

    Parameters
    ----------
    vertices : array_like, shape (K, 2)
        ``psi``, strictly increasing (its inverse must be a function).
    seed : float
        ``sigma`` in [0, 1).

    Returns
    -------
    tau : float
    phi : ndarray, shape (K', 2)
    """
    v = check_vertices(vertices)
    if (np.diff(v[:, 1]) <= 0).any():
        raise ValueError("vertices: the warp has a flat piece; its inverse jumps (no swapped match)")
    inv = v[:, ::-1]  # psi^{-1}: vertices (psi(x_k), x_k)
    sigma = float(seed) % 1.0
    if sigma == 0.0:
        return 0.0, np.ascontiguousarray(inv)
    cut = 1.0 - sigma
    tau = float(np.interp(cut, inv[:, 0], inv[:, 1]))
    s = np.union1d(inv[:, 0], [cut])
    y = np.interp(s, inv[:, 0], inv[:, 1])
    hi = s >= cut
    lo = s <= cut
    x = np.concatenate([s[hi] - cut, s[lo][1:] + sigma])
    phi = np.concatenate([y[hi] - tau, y[lo][1:] + 1.0 - tau])
    keep = np.concatenate([[True], np.diff(x) > 1e-15])
    x, phi = x[keep], phi[keep]
    x[0], x[-1] = 0.0, 1.0
    phi = np.clip(np.maximum.accumulate(phi), 0.0, 1.0)
    phi[0], phi[-1] = 0.0, 1.0
    return tau, np.column_stack([x, phi])
