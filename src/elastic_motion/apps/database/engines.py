"""Where tiles run: in this process (``"serial"``) or on Dask workers (``"local"``, ``"dask"``).

* ``"serial"``: an in-process loop.
* ``"local"``: a Dask ``LocalCluster`` of ``n_workers`` single-threaded processes started here.
* ``"dask"``: an existing Dask scheduler at ``scheduler``.

Tiles are Dask tasks that receive their SRV arrays with the task (scattered once; no shared
file system needed); the driver gathers them ``as_completed`` with a bounded number in
flight. Same function, same inputs: every engine gives bit-identical matrices.

A Dask engine also reads and prepares the files and computes their SRV arrays on its workers
(:meth:`DaskEngine.stages`, chunks of :data:`PREPARE_CHUNK` files per task; the prepared
motions stay on the workers, only summaries and the SRV arrays come back) when its workers see
the driver's files: always for ``"local"``; for ``"dask"`` when every worker finds each file
with the driver's size and modification time (else the driver reads them, and says so).
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import os
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from elastic_motion.apps.database.cache import Stages, file_fingerprint
from elastic_motion.apps.database.tiles import compute_tile, pair_distance
from elastic_motion.warp import WarpOptions

__all__ = ["ENGINES", "ClusterUnavailableError", "DaskStages", "Engine", "Task", "open_engine"]

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

    def stages(self, files: Sequence[str]) -> tuple[Stages | None, str | None]: ...

    def run(
        self, tasks: list[Task], args_of: Callable[[Task], tuple]
    ) -> Iterator[tuple[Task, np.ndarray, float]]: ...

    def close(self) -> None: ...


class SerialEngine:
    """Tiles one after another in this process."""

    name = "serial"
    n_workers = 1
    scheduler = None
    #: Why this engine runs (e.g. a local cluster that would not have paid for its start).
    note: str | None = None

    def share(self, arrays: list[np.ndarray]) -> list[Any]:
        """Handles of the SRV arrays that tasks receive (here: the arrays themselves)."""
        return arrays

    def stages(self, files: Sequence[str]) -> tuple[Stages | None, str | None]:
        """Where the files are prepared: here (``None``), and no note."""
        return None, None

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
    (arrays received from the scheduler are read-only: another numba specialisation), with one
    numba thread, as the tiles run on a worker (:func:`_timed_tile`)."""
    import numba

    numba.set_num_threads(1)
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
            import dask

            # Dask's nanny starts workers with MALLOC_TRIM_THRESHOLD_=65536, which turns off
            # glibc's adaptive mmap threshold: every array above 128 kB is then mmap'ed and
            # unmapped, and reading and preparing the files took 20-25 % more CPU on a worker
            # than here (measured). Our workers hold a few MB each: keep glibc's defaults.
            with dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}):
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
            self.client = _connect(Client, scheduler, timeout)
        self.timeout = float(timeout)
        info = _bounded(self.client.scheduler_info, self.timeout, scheduler or "the local cluster")
        if not info.get("workers"):  # a scheduler without workers: wait for one, within the timeout
            try:
                self.client.wait_for_workers(1, timeout=self.timeout)
            except Exception as exc:
                where = scheduler or "the local cluster"
                self.close()
                raise ClusterUnavailableError(
                    f"scheduler: the Dask scheduler at {where!r} has no worker "
                    f"(none joined within {self.timeout:g} s, --timeout); start `dask worker ADDRESS`"
                ) from exc
            info = self.client.scheduler_info()
        self.n_workers = max(1, len(info.get("workers", {})))
        self.scheduler = self.client.scheduler.address
        # load the compiled kernels on every worker once, before any tile is timed
        self.client.run(_warm_up)
        self._arrays: dict[str, np.ndarray] = {}

    def share(self, arrays: list[np.ndarray]) -> list[Any]:
        """Scatter the SRV arrays once, to every worker (``broadcast``): tasks get futures, so an
        array travels to each worker once instead of once per tile (no shared file system
        needed), and a worker lost mid-run loses no data the others need. The driver keeps the
        arrays too, so a task whose data is gone all the same is resubmitted with its arrays."""
        futures = self.client.scatter(arrays, hash=False, broadcast=True)
        for f, a in zip(futures, arrays, strict=True):
            self._arrays[f.key] = a
        return futures

    def stages(self, files: Sequence[str]) -> tuple[Stages | None, str | None]:
        """Where :func:`~elastic_motion.apps.database.cache.build_srv_cache` runs its stages: on
        the workers (:class:`DaskStages`) when they see the driver's files, else here (None).

        ``"local"``: its workers share the driver's file system. ``"dask"``: every worker stats
        each file (:func:`~elastic_motion.apps.database.cache.file_fingerprint`, one
        ``Client.run``); any file missing or different there means the driver reads them all.
        Returns the stages and a sentence saying where and why (for the report)."""
        if self.name == "local":
            where = f"read, prepared and SRV computed on the {self.n_workers} local workers"
            return DaskStages(self), where
        paths = [os.fspath(f) for f in files]
        mine = [file_fingerprint(f) for f in paths]
        try:
            theirs = _bounded(
                lambda: self.client.run(_fingerprints, paths), max(self.timeout, 30.0), self.scheduler
            )
        except Exception as exc:  # a worker that cannot answer: read here, as before
            return (
                None,
                f"read on the driver: the workers could not check the files ({type(exc).__name__}: {exc})",
            )
        for worker, prints in sorted(theirs.items()):
            for path, a, b in zip(paths, mine, prints, strict=True):
                if a != b:
                    return None, (
                        f"read on the driver: worker {worker} does not see {path} as the driver does "
                        "(no shared file system)"
                    )
        where = f"read, prepared and SRV computed on the {len(theirs)} workers (they see the driver's files)"
        return DaskStages(self), where

    def _with_arrays(self, args: tuple) -> tuple:
        """``args`` with every scattered future replaced by the driver's own array."""

        def own(x: Any) -> Any:
            key = getattr(x, "key", None)
            if isinstance(key, str) and key in self._arrays:
                return self._arrays[key]
            if isinstance(x, list):
                return [own(v) for v in x]
            return x

        return tuple(own(a) for a in args)

    def run(
        self, tasks: list[Task], args_of: Callable[[Task], tuple]
    ) -> Iterator[tuple[Task, np.ndarray, float]]:
        """Yield ``(task, tile, seconds)`` as tasks complete (at most ``4 * workers`` in flight).

        A lost worker does not end the run: Dask reruns its tasks elsewhere (the data is on
        every worker), and a task that fails because its data or its worker is gone is
        resubmitted with the arrays themselves (:data:`MAX_RESUBMITS` times). With no worker
        left for ``timeout`` seconds the run stops with :class:`ClusterUnavailableError`
        (finished tiles are kept; run again to resume).
        """
        from distributed import as_completed

        window = max(2, 4 * self.n_workers)  # tasks in flight: bounded memory on the driver
        pending = iter(tasks)
        task_of: dict[str, tuple[Task, int]] = {}

        def submit(t: Task, attempt: int = 0):
            args = args_of(t) if attempt == 0 else self._with_arrays(args_of(t))
            fut = self.client.submit(
                _timed_tile,
                *args,
                key=f"elastic-tile-{t.key}-{uuid.uuid4().hex}",
                pure=False,
                retries=2,
            )
            task_of[fut.key] = (t, attempt)
            return fut

        ac = as_completed([submit(t) for t in itertools.islice(pending, window)])
        idle_since: float | None = None
        while not ac.is_empty():
            batch = ac.next_batch(block=False)
            if not batch:
                idle_since = self._watchdog(idle_since)
                time.sleep(0.02)
                continue
            idle_since = None
            for fut in batch:
                task, attempt = task_of.pop(fut.key)
                try:
                    res, secs = fut.result()
                except Exception as exc:
                    if not _lost(exc) or attempt >= MAX_RESUBMITS:
                        raise
                    fut.release()
                    ac.add(submit(task, attempt + 1))
                    continue
                fut.release()
                nxt = next(pending, None)
                if nxt is not None:
                    ac.add(submit(nxt))
                yield task, res, secs

    def _watchdog(self, idle_since: float | None) -> float | None:
        """Raise when the cluster has had no worker for ``timeout`` seconds; else the idle start."""
        now = time.monotonic()
        if idle_since is None:
            return now
        if now - idle_since < max(self.timeout, 1.0):
            return idle_since
        try:
            workers = _bounded(self.client.scheduler_info, self.timeout, self.scheduler).get("workers", {})
        except Exception as exc:  # the scheduler itself is gone
            raise ClusterUnavailableError(
                f"scheduler: lost the Dask scheduler mid-run ({exc}); finished tiles are kept, "
                "run the same command again to resume"
            ) from exc
        if workers:
            return now  # working (long tiles): look again later
        raise ClusterUnavailableError(
            f"scheduler: the Dask cluster has had no worker for {self.timeout:g} s (--timeout); finished "
            "tiles are kept, run the same command again (with workers) to resume"
        )

    def close(self) -> None:
        """Close the client (and the cluster started here)."""
        with contextlib.suppress(Exception):
            self.client.close()
        if self.cluster is not None:
            with contextlib.suppress(Exception):
                self.cluster.close()


#: Times a tile whose worker or data was lost is resubmitted by the driver (with its arrays).
MAX_RESUBMITS = 3
#: Files per preparation task of :class:`DaskStages` (read and prepared: 20-50 ms each).
PREPARE_CHUNK = 8


def _fingerprints(paths: list[str]) -> list[tuple[int, int] | None]:
    return [file_fingerprint(p) for p in paths]


class DaskStages:
    """The stages of :func:`~elastic_motion.apps.database.cache.build_srv_cache` as Dask tasks
    (:class:`~elastic_motion.apps.database.cache.Stages`): handles are futures, a stage that
    follows another runs where its input is (Dask's data locality), so the prepared motions
    never leave the workers. A worker lost mid-way costs its tasks only (Dask reruns them from
    the files); no worker left for ``timeout`` seconds is :class:`ClusterUnavailableError`.

    Attributes
    ----------
    tasks_by_worker : dict of str -> int
        Tasks gathered, by the address of the worker that holds the result.
    """

    chunk_size = PREPARE_CHUNK

    def __init__(self, engine: DaskEngine) -> None:
        self.engine = engine
        self.tasks_by_worker: dict[str, int] = {}

    def _submit(self, fn: Callable[..., Any], *args: Any) -> Any:
        key = f"elastic-{fn.__name__.strip('_').replace('_', '-')}-{uuid.uuid4().hex}"
        return self.engine.client.submit(fn, *args, key=key, pure=False)

    def submit(self, fn: Callable[..., Any], args: Sequence[tuple]) -> list[Any]:
        return [self._submit(fn, *a) for a in args]

    def then(
        self, fn: Callable[..., Any], handles: Sequence[Any], args: Sequence[tuple] | None = None
    ) -> list[Any]:
        args = args if args is not None else [()] * len(handles)
        return [self._submit(fn, h, *a) for h, a in zip(handles, args, strict=True)]

    def gather(self, handles: Sequence[Any], on_done: Callable[[int], None] | None = None) -> list[Any]:
        from distributed import as_completed

        if not handles:
            return []
        index = {f.key: k for k, f in enumerate(handles)}
        out: list[Any] = [None] * len(handles)
        ac = as_completed(list(handles))
        idle_since: float | None = None
        while not ac.is_empty():
            batch = ac.next_batch(block=False)
            if not batch:
                idle_since = self.engine._watchdog(idle_since)
                time.sleep(0.01)
                continue
            idle_since = None
            for fut in batch:
                k = index[fut.key]
                out[k] = fut.result()  # a task's error is raised here, with its note naming the file
                if on_done is not None:
                    on_done(k)
        with contextlib.suppress(Exception):  # diagnostics only
            for keys in self.engine.client.who_has(list(handles)).values():
                for w in keys[:1]:
                    self.tasks_by_worker[w] = self.tasks_by_worker.get(w, 0) + 1
        return out

    def release(self, handles: Sequence[Any]) -> None:
        for f in handles:
            with contextlib.suppress(Exception):
                f.release()


def _lost(exc: BaseException) -> bool:
    """Whether ``exc`` says a task's worker or input data went away (not an error of the task)."""
    import asyncio
    import concurrent.futures

    names = {"KilledWorker", "FutureCancelledError", "CancelledError", "CommClosedError"}
    if isinstance(exc, asyncio.CancelledError | concurrent.futures.CancelledError):
        return True
    text = str(exc).lower()
    return type(exc).__name__ in names or "forgotten" in text or "lost" in text


def _bounded(fn: Callable[[], Any], timeout: float, where: str | None) -> Any:
    """``fn()`` in a helper thread; ``ClusterUnavailableError`` if it has not returned in ``timeout`` s."""
    import threading

    box: dict[str, Any] = {}

    def target() -> None:
        try:
            box["value"] = fn()
        except BaseException as exc:  # handed to the caller
            box["error"] = exc

    th = threading.Thread(target=target, name="elastic-motion-connect", daemon=True)
    th.start()
    th.join(max(timeout, 0.1) + 0.25)
    if th.is_alive():
        raise ClusterUnavailableError(
            f"scheduler: could not reach the Dask scheduler at {where!r} within {timeout:g} s (--timeout): "
            "nothing answered as Dask does; check the address (is something else listening there?) "
            "and that `dask scheduler` is running there, or use --engine local"
        )
    if "error" in box:
        raise box["error"]
    return box["value"]


def _connect(client_cls: Any, scheduler: str, timeout: float) -> Any:
    """A ``Client`` of ``scheduler``, connected (and handshaken) within ``timeout`` seconds."""
    try:
        return _bounded(lambda: client_cls(scheduler, timeout=timeout), timeout, scheduler)
    except ClusterUnavailableError:
        raise
    except (OSError, TimeoutError) as exc:
        raise ClusterUnavailableError(
            f"scheduler: could not reach the Dask scheduler at {scheduler!r} within {timeout:g} s "
            f"({exc}). Check the address and that `dask scheduler` is running there, or use "
            "--engine local"
        ) from exc
    except ValueError:  # a malformed address: the user's option
        raise
    except Exception as exc:  # a server that is not Dask: garbled handshake
        raise ClusterUnavailableError(
            f"scheduler: expected a Dask scheduler at {scheduler!r}; got an answer that is not Dask's "
            f"({type(exc).__name__}: {exc})"
        ) from exc


def open_engine(
    engine: str,
    scheduler: str | None,
    n_workers: int,
    timeout: float,
    *,
    worth_it: tuple[bool, str] | None = None,
) -> Engine:
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
    worth_it : (bool, str), optional
        For ``"local"``: whether starting a cluster pays for itself
        (:func:`elastic_motion.apps.database.tiles.cluster_worth_it`) and the sentence saying
        so. When it does not, a serial engine is returned with that sentence as its ``note``,
        so ``--engine local`` never loses to serial on small inputs. None: always start it.

    Raises
    ------
    ClusterUnavailableError
        Dask missing or the scheduler unreachable.
    ValueError
        An unknown engine name.
    """
    import math

    from elastic_motion.errors import OptionError

    if not (isinstance(timeout, int | float) and math.isfinite(timeout) and timeout > 0):
        raise OptionError("timeout", f"expected a positive number of seconds; got {timeout!r}")
    if engine == "local" and not (isinstance(n_workers, int) and 1 <= n_workers <= 1024):
        raise OptionError("workers", f"expected 1 to 1024 worker processes; got {n_workers!r}")
    if engine == "serial":
        return SerialEngine()
    if engine == "local" and worth_it is not None and not worth_it[0]:
        serial = SerialEngine()
        serial.note = worth_it[1]
        return serial
    if engine in ("local", "dask"):
        return DaskEngine(engine, scheduler, n_workers, timeout)
    raise ValueError(f"engine: expected one of {list(ENGINES)}; got {engine!r}")
