"""Where tiles run: in this process (``"serial"``) or on Dask workers (``"local"``, ``"dask"``).

* ``"serial"``: an in-process loop.
* ``"local"``: a Dask ``LocalCluster`` of ``n_workers`` single-threaded processes started here.
* ``"dask"``: an existing Dask scheduler at ``scheduler``.

Tiles are Dask tasks that receive their SRV arrays with the task (scattered once; no shared
file system needed); the driver gathers them ``as_completed`` with a bounded number in
flight. Same function, same inputs: every engine gives bit-identical matrices.
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import time
import uuid
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from elastic_motion.apps.database.tiles import compute_tile, pair_distance
from elastic_motion.warp import WarpOptions

__all__ = ["ENGINES", "ClusterUnavailableError", "Engine", "Task", "open_engine"]

#: Engine names accepted by :func:`open_engine`.
ENGINES = ("serial", "local", "dask")


class ClusterUnavailableError(RuntimeError):
    """The Dask scheduler could not be reached (or Dask is not installed)."""


@dataclass
class Task:
    """One tile to compute: block ``(bi, bj)`` of representation ``rep``."""

    key: str
    rep: str
    bi: int
    bj: int
    rows: np.ndarray
    cols: np.ndarray


class Engine(Protocol):
    """What the matrix run needs from an engine."""

    name: str
    n_workers: int

    def share(self, arrays: list[np.ndarray]) -> list[Any]: ...

    def run(
        self, tasks: list[Task], args_of: Callable[[Task], tuple]
    ) -> Iterator[tuple[Task, np.ndarray, float]]: ...

    def close(self) -> None: ...


class SerialEngine:
    """Tiles one after another in this process."""

    name = "serial"
    n_workers = 1
    scheduler = None

    def share(self, arrays: list[np.ndarray]) -> list[Any]:
        """Handles of the SRV arrays that tasks receive (here: the arrays themselves)."""
        return arrays

    def run(
        self, tasks: list[Task], args_of: Callable[[Task], tuple]
    ) -> Iterator[tuple[Task, np.ndarray, float]]:
        """Yield ``(task, tile, seconds)`` for each task, in order."""
        for t in tasks:
            t0 = time.perf_counter()
            res = compute_tile(*args_of(t))
            yield t, res, time.perf_counter() - t0

    def close(self) -> None:
        """Nothing to release."""


def _warm_up() -> None:
    """Load (or compile) the DP kernels in this process, for writable and for read-only arrays
    (arrays received from the scheduler are read-only: another numba specialisation)."""
    q = np.zeros((4, 2))
    q[:, 0] = 1.0
    r = q[::-1].copy()
    warp = WarpOptions(method="dp", neighbourhood=2)
    pair_distance(q, r, warp)
    q.setflags(write=False)
    r.setflags(write=False)
    pair_distance(q, r, warp)


def _timed_tile(*args: Any) -> tuple[np.ndarray, float]:
    t0 = time.perf_counter()
    res = compute_tile(*args, numba_threads=1)
    return res, time.perf_counter() - t0


class DaskEngine:
    """Tiles as Dask tasks on a ``LocalCluster`` started here or on a running scheduler."""

    def __init__(self, name: str, scheduler: str | None, n_workers: int, timeout: float) -> None:
        try:
            from distributed import Client, LocalCluster
        except ImportError as exc:  # pragma: no cover - depends on the environment
            raise ClusterUnavailableError(
                f"engine: {name!r} needs Dask distributed; got it not installed "
                "(pip install 'elastic-motion[cluster]' or pip install 'dask[distributed]')"
            ) from exc
        self.name = name
        self.cluster = None
        if name == "local":
            self.cluster = LocalCluster(
                n_workers=n_workers,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=logging.CRITICAL,  # task errors still reach the driver as exceptions
            )
            self.client = Client(self.cluster)
        else:
            if not scheduler:
                raise ValueError(
                    "scheduler: expected a Dask scheduler address for engine 'dask' (tcp://host:8786)"
                )
            try:
                self.client = Client(scheduler, timeout=timeout)
            except (OSError, TimeoutError) as exc:
                raise ClusterUnavailableError(
                    f"scheduler: could not reach the Dask scheduler at {scheduler!r} within {timeout:g} s "
                    f"({exc}). Check the address and that `dask scheduler` is running there, or use "
                    "--engine local"
                ) from exc
        info = self.client.scheduler_info()
        self.n_workers = max(1, len(info.get("workers", {})))
        self.scheduler = self.client.scheduler.address
        # load the compiled kernels on every worker once, before any tile is timed
        self.client.run(_warm_up)

    def share(self, arrays: list[np.ndarray]) -> list[Any]:
        """Scatter the SRV arrays once; tasks get futures, so each array travels to a worker at
        most once instead of once per tile (no shared file system needed)."""
        return self.client.scatter(arrays, hash=False)

    def run(
        self, tasks: list[Task], args_of: Callable[[Task], tuple]
    ) -> Iterator[tuple[Task, np.ndarray, float]]:
        """Yield ``(task, tile, seconds)`` as tasks complete (at most ``4 * workers`` in flight)."""
        from distributed import as_completed

        window = max(2, 4 * self.n_workers)  # tasks in flight: bounded memory on the driver
        pending = iter(tasks)
        task_of: dict[str, Task] = {}

        def submit(t: Task):
            fut = self.client.submit(
                _timed_tile, *args_of(t), key=f"elastic-tile-{t.key}-{uuid.uuid4().hex}", pure=False
            )
            task_of[fut.key] = t
            return fut

        ac = as_completed([submit(t) for t in itertools.islice(pending, window)])
        for fut in ac:
            res, secs = fut.result()
            task = task_of.pop(fut.key)
            fut.release()
            nxt = next(pending, None)
            if nxt is not None:
                ac.add(submit(nxt))
            yield task, res, secs

    def close(self) -> None:
        """Close the client (and the cluster started here)."""
        with contextlib.suppress(Exception):
            self.client.close()
        if self.cluster is not None:
            with contextlib.suppress(Exception):
                self.cluster.close()


def open_engine(engine: str, scheduler: str | None, n_workers: int, timeout: float) -> Engine:
    """Start or connect an engine.

    Parameters
    ----------
    engine : {"serial", "local", "dask"}
    scheduler : str or None
        Scheduler address for ``"dask"`` (``tcp://host:8786``).
    n_workers : int
        Worker processes of ``"local"``.
    timeout : float
        Seconds to wait for the scheduler.

    Raises
    ------
    ClusterUnavailableError
        Dask missing or the scheduler unreachable.
    ValueError
        An unknown engine name.
    """
    if engine == "serial":
        return SerialEngine()
    if engine in ("local", "dask"):
        return DaskEngine(engine, scheduler, n_workers, timeout)
    raise ValueError(f"engine: expected one of {list(ENGINES)}; got {engine!r}")
