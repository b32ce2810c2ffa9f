"""Where tiles run: in this process (``"serial"``) or on Dask workers (``"local"``, ``"dask"``).

* ``"serial"``: an in-process loop.
* ``"local"``: a Dask ``LocalCluster`` of ``n_workers`` single-threaded processes started here.
* ``"dask"``: an existing Dask scheduler at ``scheduler``.

Tiles are Dask tasks that receive the SRV arrays of a representation as one object scattered
once to every worker (no shared file system needed; one dependency per task, not one per
motion); the driver gathers them ``as_completed`` with a bounded number in flight, the
costliest tiles first (:func:`order_tiles`: the last ones are the small diagonal tiles, so
the workers finish together). Same function, same inputs: every engine gives bit-identical
matrices.

``"local"`` forks its workers from this process on Linux (:func:`local_start_method`): they start
in about 0.1 s with the code and the compiled kernels this process has loaded, instead of 1-2 s
for spawned interpreters that import everything again. Workers started with ``dask worker``
load the code and kernels at start with ``--preload elastic_motion.apps.database.engines``
(:func:`dask_setup`), else on their first tasks.

A Dask engine also reads and prepares the files and computes their SRV arrays on its workers
(:meth:`DaskEngine.stages`, chunks of :data:`PREPARE_CHUNK` files per task; the prepared
motions stay on the workers, only summaries and the SRV arrays come back) when its workers see
the driver's files: always for ``"local"``; for ``"dask"`` when every worker finds each file
with the driver's size and modification time (else the driver reads them, and says so).
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import itertools
import logging
import math
import os
import sys
import tempfile
import threading
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numba
import numpy as np

from elastic_motion.apps.database.cache import (
    Stages,
    file_fingerprint,
    prepare_chunk,
    srv_chunk,
    summarise_chunk,
)
from elastic_motion.apps.database.settings import DatabaseSettings
from elastic_motion.apps.database.tiles import compute_tile, pair_distance
from elastic_motion.errors import OptionError
from elastic_motion.motion import Motion, Skeleton, write_bvh
from elastic_motion.motion.rotations import euler_to_matrix
from elastic_motion.vocabulary import ENGINES, EngineName
from elastic_motion.warp import WarpOptions

__all__ = [
    "ENGINES",
    "ClusterUnavailableError",
    "DaskStages",
    "Engine",
    "EngineName",
    "Task",
    "dask_setup",
    "local_start_method",
    "open_engine",
]

# Where a matrix run computes its tiles (module docstring), EngineName ("serial": this process,
# "local": a Dask LocalCluster started here, "dask": a running Dask scheduler), and the names
# open_engine accepts, ENGINES: from elastic_motion.vocabulary.


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

    def share(self, arrays: list[np.ndarray]) -> Any: ...

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

    def share(self, arrays: list[np.ndarray]) -> Any:
        """The handle of the SRV arrays that tasks receive (here: the list itself)."""
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
            res = tile_of(*args_of(t))
            yield t, res, time.perf_counter() - t0

    def close(self) -> None:
        """Nothing to release."""


def _single_threaded_worker() -> None:
    """One BLAS thread in this worker process (as Dask's nanny sets for spawned workers with
    ``OMP_NUM_THREADS=1`` ...; a forked worker inherits the driver's pools), so two workers
    share two cores without oversubscribing them. numba's thread count is per calling thread:
    set here for this one (warm-up), and by each tile's task itself (``compute_tile(...,
    numba_threads=1)``)."""
    numba.set_num_threads(1)
    with contextlib.suppress(ImportError):  # threadpoolctl is optional (the "cluster" extra)
        from threadpoolctl import threadpool_limits

        threadpool_limits(1, user_api="blas")  # process-wide, until changed again


def _warm_up() -> None:
    """Load (or compile) the DP kernels in this process, for writable and for read-only arrays
    (arrays received from the scheduler are read-only: another numba specialisation), with one
    numba thread, as the tiles run on a worker (:func:`_timed_tile`)."""
    _single_threaded_worker()
    q = np.zeros((4, 2))
    q[:, 0] = 1.0
    r = q[::-1].copy()
    warp = WarpOptions(method="dp", neighbourhood=2)
    pair_distance(q, r, warp)
    q.setflags(write=False)
    r.setflags(write=False)
    pair_distance(q, r, warp)


def _warm_up_preparation() -> None:
    """Load the code and compiled kernels of reading, preparing and the SRV (a small BVH file
    written to a temporary folder, prepared as a database does)."""
    rot = ("Zrotation", "Yrotation", "Xrotation")
    sk = Skeleton(
        ["Hips", "Spine", "LeftLeg", "RightLeg"],
        [-1, 0, 0, 0],
        [[0, 0, 0], [0, 0.3, 0], [0.1, -0.1, 0], [-0.1, -0.1, 0]],
        [("Xposition", "Yposition", "Zposition", *rot)] + [rot] * 3,
        end_site_parents=[2, 3],
        end_site_offsets=[[0, -0.5, 0]] * 2,
    )
    s = np.linspace(0.0, 1.0, 24)
    ang = np.zeros((24, 4, 3))
    ang[:, :, 2] = 0.3 * np.sin(2 * np.pi * s)[:, None]
    root = np.stack([0 * s, 0.9 + 0 * s, s], axis=1)
    settings = DatabaseSettings(n_samples=8)
    with tempfile.TemporaryDirectory(prefix="elastic-motion-warm-") as d:
        path = os.path.join(d, "warm.bvh")
        write_bvh(Motion(sk, 30.0, root, euler_to_matrix(ang, "ZYX"), metres_per_unit=1.0), path)
        prepared = prepare_chunk([(path, None, None)], settings)
        summary = summarise_chunk(prepared)
        if "names" in summary[0]:
            w = (np.asarray(summary[0]["jw"]), float(summary[0]["tw"]))
            srv_chunk(prepared, [w], tuple(settings.representations))


def dask_setup(worker: Any = None) -> None:
    """Dask's preload hook: ``dask worker ADDRESS --preload elastic_motion.apps.database.engines``
    loads the code and compiled kernels of a database run when the worker starts (reading,
    preparing, SRV, the DP of the tiles, one numba thread), so its first tasks do not."""
    with contextlib.suppress(Exception):  # a warm-up only: the tasks load what they need anyway
        _warm_up_preparation()
    _warm_up()


def tile_of(
    rows: np.ndarray,
    cols: np.ndarray,
    q: Sequence[np.ndarray],
    g_rows: np.ndarray,
    g_cols: np.ndarray,
    warp: WarpOptions,
    cyclic: bool = False,
    *,
    numba_threads: int | None = None,
) -> np.ndarray:
    """:func:`~elastic_motion.apps.database.tiles.compute_tile` of motions ``rows`` against
    ``cols``, their SRV arrays taken from ``q`` (all the motions of the representation: what a
    task receives, :meth:`DaskEngine.share`); ``cyclic``: phase-free matching."""
    return compute_tile(rows, cols, q, g_rows, g_cols, warp, cyclic=cyclic, numba_threads=numba_threads)


def _timed_tile(*args: Any) -> tuple[np.ndarray, float]:
    t0 = time.perf_counter()
    res = tile_of(*args, numba_threads=1)
    return res, time.perf_counter() - t0


def order_tiles(tasks: Sequence[Task], cost: Callable[[Task], float]) -> list[Task]:
    """``tasks`` by decreasing ``cost`` (ties in the given order): the longest first, so with
    several workers the last tasks are the shortest and no worker waits long for another at
    the end (longest processing time first)."""
    return [t for _, _, t in sorted(((-cost(t), k, t) for k, t in enumerate(tasks)), key=lambda x: x[:2])]


class DaskEngine:
    """Tiles as Dask tasks on a ``LocalCluster`` started here or on a running scheduler."""

    def __init__(self, name: str, scheduler: str | None, n_workers: int, timeout: float) -> None:
        try:  # Dask is optional (the "cluster" extra), and slow to import
            from distributed import Client, LocalCluster
        except ImportError as exc:  # pragma: no cover - depends on the environment
            raise ClusterUnavailableError(
                f"engine: {name!r} needs Dask distributed; got it not installed "
                "(pip install 'elastic-motion[cluster]' or pip install 'dask[distributed]')"
            ) from exc
        self.name = name
        self.cluster = None
        self.start_method: str | None = None
        if name == "local":
            import dask  # installed with distributed (above)

            # Dask's nanny starts workers with MALLOC_TRIM_THRESHOLD_=65536, which turns off
            # glibc's adaptive mmap threshold: every array above 128 kB is then mmap'ed and
            # unmapped, and reading and preparing the files took 20-25 % more CPU on a worker
            # than here (measured). Our workers hold a few MB each: keep glibc's defaults.
            self.start_method = local_start_method()
            with dask.config.set(
                {
                    **QUIET_DASK,
                    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
                    "distributed.worker.multiprocessing-method": self.start_method,
                }
            ):
                self.cluster = LocalCluster(
                    n_workers=n_workers,
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=None,
                    # no dashboard, but the scheduler still serves its health routes over HTTP,
                    # on 8787 unless told otherwise: two runs at once (or a user's own cluster)
                    # then collide and Dask warns; any free port will do
                    scheduler_kwargs={"dashboard_address": ":0"},
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
        # one numba and one BLAS thread per worker; the kernels load with the first tasks (a
        # forked worker has those this process had loaded, a preloaded one has them all)
        self.client.run(_single_threaded_worker)
        self._arrays: dict[str, np.ndarray] = {}

    def share(self, arrays: list[np.ndarray]) -> Any:
        """Scatter the SRV arrays of a representation once, to every worker (``broadcast``), as
        one object: tasks get its future, so the arrays travel to each worker once instead of
        once per tile (no shared file system needed), each tile depends on one key instead of
        one per motion (400 motions: 0.23 s to scatter them one by one, measured), and a
        worker lost mid-run loses no data the others need. The driver keeps the list too, so a
        task whose data is gone all the same is resubmitted with the arrays themselves."""
        arrays = list(arrays)
        [future] = self.client.scatter([arrays], hash=False, broadcast=True)
        self._arrays[future.key] = arrays
        return future

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

    def _with_arrays(self, args: tuple, keep: Sequence[int] | None = None) -> tuple:
        """``args`` with every scattered future replaced by the driver's own arrays; with
        ``keep``, only those motions' arrays (None for the others: a resubmitted tile carries
        its rows and columns, not the whole database)."""

        def own(x: Any) -> Any:
            key = getattr(x, "key", None)
            if not (isinstance(key, str) and key in self._arrays):
                return x
            arrays = self._arrays[key]
            if keep is None:
                return arrays
            wanted = set(int(i) for i in keep)
            return [a if i in wanted else None for i, a in enumerate(arrays)]

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
        window = max(2, 4 * self.n_workers)  # tasks in flight: bounded memory on the driver
        pending = iter(tasks)
        task_of: dict[str, tuple[Task, int]] = {}

        def submit(t: Task, attempt: int = 0):
            args = args_of(t) if attempt == 0 else self._with_arrays(args_of(t), [*t.rows, *t.cols])
            fut = self.client.submit(
                _timed_tile,
                *args,
                key=f"elastic-tile-{t.key}-{uuid.uuid4().hex}",
                pure=False,
                retries=2,
            )
            task_of[fut.key] = (t, attempt)
            return fut

        ac = _Completed([submit(t) for t in itertools.islice(pending, window)])
        idle_since: float | None = None
        while not ac.is_empty():
            batch = ac.next_batch(WAIT_SECONDS)
            if not batch:
                idle_since = self._watchdog(idle_since)
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


#: Seconds the driver blocks waiting for a task to finish before it checks that the cluster still
#: has workers (it used to poll every 10-20 ms: CPU taken from the workers on a small machine).
WAIT_SECONDS = 0.5
#: Futures the driver waits on at a time (the oldest pending ones).
WAIT_AT_MOST = 64


class _Completed:
    """Futures handed back as they finish, waiting without polling (``distributed.wait`` with a
    timeout, so the caller can check the cluster between waits): ``as_completed`` with a
    blocking ``next_batch(timeout)``."""

    def __init__(self, futures: Sequence[Any]) -> None:
        self._pending: dict[str, Any] = {f.key: f for f in futures}

    def add(self, future: Any) -> None:
        self._pending[future.key] = future

    def is_empty(self) -> bool:
        return not self._pending

    def next_batch(self, timeout: float) -> list[Any]:
        """The futures finished (done, failed or cancelled) within ``timeout`` s; [] if none."""
        from distributed import wait  # optional: only a Dask engine makes these

        futures = list(self._pending.values())
        if not any(f.done() for f in futures):
            # the oldest ones only: waiting on every pending future costs the driver time
            # growing with their number, each call (quadratic over a run of many chunks); a
            # later one that finishes first is picked up within `timeout`
            try:
                wait(futures[:WAIT_AT_MOST], timeout=timeout, return_when="FIRST_COMPLETED")
            except TimeoutError:
                return []
            except Exception:  # e.g. a future cancelled meanwhile: handed back below, as done
                pass
        done = [f for f in futures if f.done()]
        for f in done:
            del self._pending[f.key]
        return done


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
        if not handles:
            return []
        index = {f.key: k for k, f in enumerate(handles)}
        out: list[Any] = [None] * len(handles)
        ac = _Completed(list(handles))
        idle_since: float | None = None
        try:
            while not ac.is_empty():
                batch = ac.next_batch(WAIT_SECONDS)
                if not batch:
                    idle_since = self.engine._watchdog(idle_since)
                    continue
                idle_since = None
                for fut in batch:
                    k = index[fut.key]
                    out[k] = fut.result()  # a task's error is raised here, with its note naming the file
                    if on_done is not None:
                        on_done(k)
        except BaseException:
            # the stage is abandoned (e.g. FilesNotSeenError: the driver reads the files itself):
            # its other tasks must not go on using the workers, whatever still refers to them
            with contextlib.suppress(Exception):
                self.engine.client.cancel([f for f in handles if not f.done()])
            raise
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
    names = {"KilledWorker", "FutureCancelledError", "CancelledError", "CommClosedError"}
    if isinstance(exc, asyncio.CancelledError | concurrent.futures.CancelledError):
        return True
    text = str(exc).lower()
    return type(exc).__name__ in names or "forgotten" in text or "lost" in text


def _bounded(fn: Callable[[], Any], timeout: float, where: str | None) -> Any:
    """``fn()`` in a helper thread; ``ClusterUnavailableError`` if it has not returned in ``timeout`` s."""
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


#: Dask settings of the ``"local"`` cluster (its scheduler, nannies and workers): its periodic
#: book-keeping less often (no statistical profiler sampling each worker's thread every 10 ms,
#: event-loop ticks every second instead of 20 ms, system and memory monitors every 1-2 s). On
#: 2 cores shared by the driver, the scheduler and both workers, that book-keeping took CPU from
#: the tiles: the driver's event loop used 1.3 s of CPU during the 20 s pair phase of 400 motions
#: and the workers' tiles took 9 % longer than serially; with these, 0.8 s and 4 % (measured).
#: Give separately started workers the same in a Dask config file (``docs/database.md``).
QUIET_DASK = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "2s",
    "distributed.worker.memory.monitor-interval": "1s",
    "distributed.scheduler.work-stealing-interval": "500ms",
}

#: How :func:`local_start_method` starts the local cluster's workers on Linux when Dask's
#: ``distributed.worker.multiprocessing-method`` is left at its default (``"spawn"``).
LOCAL_START_METHOD = "fork"


def local_start_method() -> str:
    """How the ``"local"`` engine starts its worker processes: ``"fork"`` on Linux, else Dask's
    configured ``distributed.worker.multiprocessing-method`` (default ``"spawn"``).

    A forked worker starts in about 0.1 s with what this process has imported and compiled;
    a spawned one starts a new interpreter that imports Dask, NumPy, numba and this package
    and loads the kernels again: 1-2 s of both cores on the 2-core reference machine, a tenth
    of the read phase of 400 motions (measured: start 1.0 s, kernels 1.0-1.4 s, close 0.3-0.7
    s, against 0.1, 0.01 and 0.02 s forked). Spawn is kept where forking is unsafe: outside
    Linux, when Dask's setting is not the default, and once numba's thread pool runs in this
    process with a layer other than its workqueue (the nannies fork from a thread that is not
    the main one: GNU OpenMP does not survive it, and TBB may be left broken in the child; seen
    hanging a second cluster after a serial run here). A matrix run starts its engine before
    any DP runs in this process, so ``--engine local`` forks; a program that ran serial DPs
    first gets spawned workers.
    """
    try:  # Dask is optional (the "cluster" extra)
        import dask
    except ImportError:  # pragma: no cover - no Dask: open_engine says so
        return "spawn"

    configured = dask.config.get("distributed.worker.multiprocessing-method", "spawn")
    if configured != "spawn" or not sys.platform.startswith("linux"):
        return configured
    if _numba_threading_layer() not in (None, "workqueue"):
        return "spawn"
    return LOCAL_START_METHOD


def _numba_threading_layer() -> str | None:
    """numba's threading layer if it was started in this process, else None."""
    try:
        return str(numba.threading_layer())
    except ValueError:  # not started yet: a forked child starts its own
        return None


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
