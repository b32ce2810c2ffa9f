"""Thread pools of the numerical libraries: limiting BLAS while small matrices are worked on."""

from __future__ import annotations

import contextlib

__all__ = ["single_threaded_blas"]


def single_threaded_blas() -> contextlib.AbstractContextManager:
    """Limit BLAS to one thread inside the ``with`` block, when ``threadpoolctl`` is installed.

    Small products and factorisations (a few hundred to a few thousand rows) gain nothing
    from a second BLAS thread and lose much when the machine is busy: a multi-threaded
    OpenBLAS spins its threads after each call and starves numba's threads and other
    processes (measured: DP pairs 4-5x slower at N = 200 on 2 cores; a 430-row Cholesky
    0.78 s instead of 2 ms on a loaded machine; the 1164-row kept-contacts loop of
    ``benchmarks/loop_quality.py`` 1.07 s with two threads, 0.87 s with one, idle). One
    thread also fixes the summation order of the products, so serial and cluster database
    runs are bit-identical. Without ``threadpoolctl`` (an optional extra) nothing changes.
    """
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - optional dependency
        return contextlib.nullcontext()
    return threadpool_limits(1, user_api="blas")
