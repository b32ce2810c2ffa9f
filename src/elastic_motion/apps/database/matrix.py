"""The matrix run: all-pairs distances of a folder of motions, tile by tile, resumable.

:func:`compute_matrix` finds the files (:mod:`.files`), prepares them once into the SRV
cache (:mod:`.cache`), splits the upper triangle into tiles (:mod:`.tiles`), runs them on
an engine (:mod:`.engines`) and writes each finished tile, the matrices and the reports
into the output folder (:mod:`.storage`).

Resume: the identity of a run is its settings and its input files (``manifest.json``). A
folder holding a run with the same identity is resumed: every tile on disk that proves to be
the run's own (its record beside it, a regular file of the record's size, SHA-256, shape and
dtype, values of a tile: :mod:`.verified`, :func:`.tiles.tile_problem`) is kept, never
recomputed, and the matrices are rebuilt from them, so an interruption at any point loses at
most the tiles in flight and duplicates none. Nothing there is trusted: a tile of another
shape, dtype or content, NaN, negative, empty, a FIFO, a link or a folder in its place, or
without its record, is computed again, and the run's entry in the manifest and the report
says which and why (``tiles_rejected``); the SRV cache likewise (``cache_note``). A run of
format 1 (settings with ``"pair"``) is read as the same settings (:mod:`.settings`) and
resumed alike (tiles written before records existed are computed again).

Numerical code here prints nothing; progress goes to an optional ``progress(stage, done,
total)`` callback.
"""

from __future__ import annotations

import contextlib
import os
import platform
import stat
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from elastic_motion._options import with_overrides
from elastic_motion.apps.database import storage, verified
from elastic_motion.apps.database.cache import FilesNotSeenError, SRVCache, build_srv_cache
from elastic_motion.apps.database.engines import (
    ENGINES,
    Engine,
    EngineName,
    Task,
    local_start_method,
    open_engine,
    order_tiles,
)
from elastic_motion.apps.database.files import check_output_folder, find_motion_files
from elastic_motion.apps.database.settings import (
    FORMAT_VERSION,
    READABLE_FORMATS,
    DatabaseSettings,
    settings_differences,
)
from elastic_motion.apps.database.tiles import (
    LOCAL_CLUSTER_STARTUP,
    LOCAL_CLUSTER_STARTUP_FORKED,
    block,
    cluster_worth_it,
    tile_blocks,
    tile_problem,
)
from elastic_motion.apps.progress import Progress
from elastic_motion.apps.report import jsonable
from elastic_motion.errors import OptionError

__all__ = ["MatrixOptions", "MatrixResult", "compute_matrix", "remove_run"]


@dataclass(frozen=True)
class MatrixOptions:
    """How a matrix run computes (where its tiles run, which files it reads, what it may
    replace), not what: that is :class:`~elastic_motion.apps.database.DatabaseSettings`.

    Attributes
    ----------
    engine : {"serial", "local", "dask"}, default "serial"
        Where the tiles run (:mod:`~elastic_motion.apps.database.engines`). ``"local"`` starts a
        cluster of ``n_workers`` processes only when the estimated pair work pays for its start
        (:func:`elastic_motion.apps.database.tiles.cluster_worth_it`); otherwise the run is
        serial and the report's ``engine_note`` says why.
    scheduler : str, optional
        Address of the Dask scheduler for ``engine="dask"`` (``tcp://host:8786``).
    n_workers : int, default 2
        Worker processes of the ``"local"`` cluster (1 to 1024).
    connect_timeout : float, default 10
        Seconds to wait for the scheduler to answer (``"dask"``: connection and handshake; a
        server that is not Dask's is an error within this time) and, mid-run, for a worker when
        the cluster has none left. A worker lost mid-run costs nothing: its tiles run elsewhere.
    recursive : bool, default False
        Search input folders recursively.
    overwrite : bool, default False
        Replace a run with other settings or inputs found in the output folder (this module's
        files only); otherwise that is an error.
    force_cluster : bool, default False
        Start the local cluster whatever the estimate (tests, measurements).

    Raises
    ------
    OptionError
        An unknown engine (the number of workers and the timeout are checked when the engine
        starts, :func:`~elastic_motion.apps.database.engines.open_engine`).
    """

    engine: EngineName = "serial"
    scheduler: str | None = None
    n_workers: int = 2
    connect_timeout: float = 10.0
    recursive: bool = False
    overwrite: bool = False
    force_cluster: bool = False

    def __post_init__(self) -> None:
        if self.engine not in ENGINES:
            raise OptionError("engine", f"expected one of {list(ENGINES)}; got {self.engine!r}")


@dataclass(frozen=True, eq=False)
class MatrixResult:
    """Outcome of :func:`compute_matrix`.

    Attributes
    ----------
    out_dir : Path
    names : list of str
        Motion names, in matrix order.
    distances : dict of str -> ndarray, shape (M, M)
        Read-only memory maps of ``distances_<key>.npy`` by representation key (``"lie"``,
        ``"euler"``; NaN where not computed yet).
    report : dict
        The content of ``report.json``.
    """

    out_dir: Path
    names: list[str]
    distances: dict[str, np.ndarray]
    report: dict[str, Any]

    @property
    def complete(self) -> bool:
        """Every tile of every representation is on disk."""
        return bool(self.report.get("complete"))

    def summary(self) -> dict[str, Any]:
        """JSON-ready: the content of ``report.json`` (what ``elastic-motion matrix --json`` reports)."""
        return jsonable(self.report)


def _identity(settings: DatabaseSettings, files: Sequence[Path]) -> dict[str, Any]:
    return {
        "format": FORMAT_VERSION,
        "settings": settings.to_json(),
        "inputs": [os.fspath(f) for f in files],
    }


def _upgraded_identity(old: Any) -> dict[str, Any] | None:
    """The identity of an earlier run in this release's form; None if unreadable."""
    if not isinstance(old, dict) or old.get("format") not in READABLE_FORMATS:
        return None
    try:
        settings = DatabaseSettings.from_json(old["settings"], old["format"]).to_json()
    except (KeyError, TypeError, ValueError):
        return None
    return {"format": FORMAT_VERSION, "settings": settings, "inputs": old.get("inputs")}


def _resume_hint(key: str, old: Any) -> str:
    """What to pass to resume a run whose low-pass differs: runs of releases before cache
    format 3 had none, and their users never set it."""
    if key == "warp.sample_smoothing":
        return f" (resume it with --sample-smoothing {old!r}; runs before format 3 had no low-pass)"
    return ""


def _identity_diff(old: dict[str, Any] | None, new: dict[str, Any]) -> str:
    if not old:
        return "its manifest.json is from an unknown format or unreadable"
    diffs = []
    if old.get("inputs") != new["inputs"]:
        o, n = set(old.get("inputs") or ()), set(new["inputs"])
        diffs.append(f"inputs differ ({len(n - o)} new, {len(o - n)} missing)")
    so, sn = old.get("settings", {}), new["settings"]
    diffs += [f"{k}: {o!r} -> {n!r}{_resume_hint(k, o)}" for k, o, n in settings_differences(so, sn)]
    if not diffs and so.get("joints") != sn.get("joints"):  # settings_differences: a list is a set
        diffs.append(
            f"joints: the same joints in another order, {so.get('joints')!r} -> {sn.get('joints')!r}"
        )
    return "; ".join(diffs) or "format differs"


def compute_matrix(
    inputs: Sequence[str | os.PathLike[str]],
    out_dir: str | os.PathLike[str],
    settings: DatabaseSettings | None = None,
    options: MatrixOptions | None = None,
    *,
    progress: Progress | None = None,
    **overrides: Any,
) -> MatrixResult:
    """All-pairs distances of the motions in ``inputs``, written tile by tile to ``out_dir``.

    The Python face of ``elastic-motion matrix``: the same settings give the same files.

    Parameters
    ----------
    inputs : sequence of paths
        Motion files and/or folders (see :func:`find_motion_files`).
    out_dir : path
        Output folder (created). If it holds a run with the same settings and inputs, that
        run is resumed: finished tiles are kept, the rest computed. A different run there is
        an error unless ``overwrite=True`` (which deletes this module's files only).
    settings : DatabaseSettings, optional
        What determines the numbers; default ``DatabaseSettings()``.
    options : MatrixOptions, optional
        How the run computes: engine, scheduler, workers, timeout, recursive, overwrite.
    progress : callable, optional
        ``progress(stage, done, total)`` with stages ``"read"`` and ``"tiles"``; called after
        each tile is safely on disk.
    **overrides
        Fields of :class:`MatrixOptions` (``engine="local"``, ``n_workers=4``, ...).

    Returns
    -------
    MatrixResult

    Raises
    ------
    ClusterUnavailableError
        The scheduler cannot be reached (checked before anything is written).
    OptionError
        ``out_dir`` holding another run (the message says how to resume or restart it) or
        an input, or inside an input folder (or holding one); no readable motion; ``n_workers``
        below 1 or a non-positive ``connect_timeout``; an unknown field of ``overrides``. A file
        that cannot be read (malformed, beyond a resource limit, not a regular file) is never an
        error: it is skipped and listed in the report.
    ValueError
        Bad settings.
    """
    opts = with_overrides(MatrixOptions, options, overrides)
    settings = settings or DatabaseSettings()
    out = Path(out_dir)
    files, ignored = find_motion_files(inputs, recursive=opts.recursive)
    check_output_folder(out, inputs, files, storage.our_names(), "out_dir")
    ident = _identity(settings, files)
    _check_resumable(out, ident, opts.overwrite)
    # connect before writing anything: an unreachable scheduler leaves no output behind
    worth = None
    if opts.engine == "local" and not opts.force_cluster:
        worth = _cluster_pays(len(files), settings, opts.n_workers)
    eng = open_engine(opts.engine, opts.scheduler, opts.n_workers, opts.connect_timeout, worth_it=worth)
    try:
        return _run(out, files, ignored, settings, ident, eng, progress)
    finally:
        eng.close()


def _check_resumable(out: Path, ident: dict[str, Any], overwrite: bool) -> None:
    """Refuse (or with ``overwrite`` clean) a folder holding a run of another identity; with
    ``overwrite`` clean any run there."""
    manifest_path = out / storage.MANIFEST
    if manifest_path.exists():
        try:
            old = _upgraded_identity(storage.read_json(manifest_path).get("identity"))
        except (OSError, ValueError, AttributeError):
            old = None
        if old != ident:
            if not overwrite:
                raise OptionError(
                    "out_dir",
                    f"{os.fspath(out)!r} holds a run with other settings or inputs "
                    f"({_identity_diff(old, ident)}); expected the same settings and inputs to resume it. "
                    "Run again with the settings it was started with to resume it, choose another folder, "
                    "or pass overwrite=True (--overwrite) to start it again",
                )
            storage.clean_outputs(out)
    elif overwrite and out.exists():
        storage.clean_outputs(out)


def _cluster_pays(n: int, settings: DatabaseSettings, n_workers: int) -> tuple[bool, str]:
    """Whether a local cluster pays for its start on ``n`` motions, and the sentence saying so
    (:func:`~elastic_motion.apps.database.tiles.cluster_worth_it`)."""
    n_pairs = n * (n - 1) // 2 * len(settings.representations)
    if settings.cyclic:  # every cyclic shift of either motion: 2 n_samples plain pairs each
        n_pairs *= 2 * settings.n_samples
    forked = local_start_method() == "fork"  # forked workers start in a fraction of a second
    return cluster_worth_it(
        n_pairs,
        settings.n_samples,
        settings.warp,
        n_workers=max(2, n_workers),
        startup=LOCAL_CLUSTER_STARTUP_FORKED if forked else LOCAL_CLUSTER_STARTUP,
    )


def _load_or_build_cache(
    out: Path,
    files: list[Path],
    ignored: list[Path],
    settings: DatabaseSettings,
    resuming: bool,
    progress: Progress | None,
    eng: Engine,
) -> tuple[SRVCache, dict[str, Any]]:
    """The run's SRV cache (reused when resuming) and where it came from (for the report:
    ``cache_reused``, ``read_where``, ``read_note``, ``read_tasks_by_worker``)."""
    cache_path = out / storage.CACHE
    cache, cache_note = None, None
    if resuming and os.path.lexists(cache_path):
        cache, cache_note = _reused_cache(cache_path, settings, files)
    if cache is not None:
        return cache, {"cache_reused": True, "read_where": None}
    # a Dask engine whose workers see the files reads, prepares and computes the SRV there
    stages, note = eng.stages([os.fspath(f) for f in files])
    where = "driver" if stages is None else "workers"
    try:
        cache = build_srv_cache(files, settings, ignored=ignored, progress=progress, stages=stages)
    except FilesNotSeenError as exc:  # a worker joined that does not see them: read them here
        where, note = "driver", f"read on the driver: {exc}"
        cache = build_srv_cache(files, settings, ignored=ignored, progress=progress)
    if len(cache) == 0:  # before anything is written
        raise OptionError(
            "inputs",
            "expected at least one readable motion; got none (skipped: "
            + "; ".join(f"{s['path']}: {s['reason']}" for s in cache.skipped[:5])
            + ")",
        )
    out.mkdir(parents=True, exist_ok=True)
    verified.write_verified(cache_path, cache.to_bytes())
    info: dict[str, Any] = {"cache_reused": False, "read_where": where, "read_note": note}
    if cache_note is not None:
        info["cache_note"] = cache_note
    if where == "workers":
        info["read_tasks_by_worker"] = dict(getattr(stages, "tasks_by_worker", {}))
    return cache, info


def _reused_cache(
    cache_path: Path, settings: DatabaseSettings, files: list[Path]
) -> tuple[SRVCache | None, str | None]:
    """The SRV cache a resumed run left, if it proves to be its own (its record, a regular file
    of the record's size and SHA-256, arrays :meth:`SRVCache.load` accepts, this run's settings
    and inputs); else None and the note saying why it is built again (same inputs, same numbers)."""
    try:
        with verified.open_verified(cache_path) as fh:
            cache = SRVCache.load(fh)
    except Exception as exc:  # whatever it holds: built again, never trusted
        return None, f"{exc} (built again)"
    read = sorted([*cache.paths, *(s.get("path") for s in cache.skipped)])
    if cache.settings.to_json() != settings.to_json() or read != sorted(os.fspath(f) for f in files):
        return None, f"{storage.CACHE}: the SRV cache of other settings or inputs (built again)"
    return cache, None


def _run(
    out: Path,
    files: list[Path],
    ignored: list[Path],
    settings: DatabaseSettings,
    ident: dict[str, Any],
    eng: Engine,
    progress: Progress | None,
) -> MatrixResult:
    """The run in ``out`` once its checks passed: read (or reuse) the SRV cache, adopt the
    tiles on disk, compute the others on ``eng``, write the matrices and the reports."""
    started = time.time()
    manifest_path = out / storage.MANIFEST
    manifest = storage.read_json(manifest_path) if manifest_path.exists() else None
    t_read = time.perf_counter()
    cache, read_info = _load_or_build_cache(
        out, files, ignored, settings, manifest is not None, progress, eng
    )
    t_read = time.perf_counter() - t_read
    (out / storage.TILES).mkdir(parents=True, exist_ok=True)
    storage.write_names(out, cache)
    run = _TileRun.start(out, manifest, ident, cache.groups, settings, eng, started)
    report = _report(cache, settings, eng, files, complete=False)
    report["runs"] = run.manifest["runs"]
    storage.write_json(out / storage.REPORT, report)

    mats = run.mats  # rebuilt from the tiles on disk that proved to be the run's
    todo = run.todo()
    if progress is not None:
        progress("tiles", run.total - len(todo), run.total)
    if eng.n_workers > 1:  # the longest tiles first: the workers finish together
        todo = order_tiles(todo, lambda t: _pairs_in(t.rows, t.cols, cache.groups))
    t_tiles = time.perf_counter()
    tile_seconds = run.compute(todo, cache, eng, mats, progress)
    wall = time.perf_counter() - t_tiles
    for mm in mats.values():
        mm.flush()
    complete = run.complete()
    if complete:
        for r, mm in mats.items():
            if np.isnan(mm).any():  # every tile present, so this is a bug, not an interruption
                raise RuntimeError(f"{storage.matrix_name(r)}: NaN left after all tiles were written")
    run.info["seconds_tiles"] = round(wall, 3)
    run.info["seconds_tile_work"] = round(tile_seconds, 3)
    run.info["seconds_read"] = round(t_read, 3)
    run.info.update(read_info)
    run.info["pairs_per_second"] = (
        round(run.info["pairs_computed"] / wall, 3) if wall > 0 and run.info["pairs_computed"] else None
    )
    storage.write_json(manifest_path, run.manifest)
    report = _report(cache, settings, eng, files, complete=complete)
    report["runs"] = run.manifest["runs"]
    report["timings"] = {
        "read_seconds": round(t_read, 3),
        "tiles_seconds": round(wall, 3),
        "pairs_computed": run.info["pairs_computed"],
        "pairs_per_second": run.info["pairs_per_second"],
    }
    storage.write_json(out / storage.REPORT, report)
    del mats
    run.mats = {}
    dists = {r: np.load(out / storage.matrix_name(r), mmap_mode="r") for r in settings.representations}
    return MatrixResult(out, cache.names, dists, report)


@dataclass(eq=False)
class _TileRun:
    """The tiles of one run in ``out``: its ``manifest`` (the tiles done, by key, and the runs;
    written back as tiles finish), this run's entry ``info`` in it, and the matrices ``mats``.

    Nothing on disk is trusted (module docstring): :meth:`start` places every tile that proves
    to be the run's own -- its record there, the file a regular one of the record's size and
    SHA-256, shape and dtype, and values :func:`~elastic_motion.apps.database.tiles.tile_problem`
    accepts (:mod:`~elastic_motion.apps.database.verified`) -- also those finished after the last
    manifest write, and computes the others again, noting why in ``info["tiles_rejected"]``.
    """

    out: Path
    manifest: dict[str, Any]
    info: dict[str, Any]
    settings: DatabaseSettings
    groups: np.ndarray
    blocks: list[tuple[int, int]]
    mats: dict[str, np.ndarray]

    @classmethod
    def start(
        cls,
        out: Path,
        manifest: dict[str, Any] | None,
        ident: dict[str, Any],
        groups: np.ndarray,
        settings: DatabaseSettings,
        eng: Engine,
        started: float,
    ) -> _TileRun:
        """This run's entry in the manifest (new or resumed) and the matrices with the tiles on
        disk verified and placed; the manifest written."""
        ts, m = settings.tile_size, len(groups)
        if manifest is None:
            manifest = {"n_motions": m, "tile_size": ts, "n_blocks": -(-m // ts), "tiles": {}, "runs": []}
        for k, kind in (("tiles", dict), ("runs", list)):  # bookkeeping only: the tiles prove themselves
            if not isinstance(manifest.get(k), kind):
                manifest[k] = kind()
        manifest["identity"] = ident  # a format-1 run resumed is written in this release's form
        info: dict[str, Any] = {
            "run": len(manifest["runs"]) + 1,
            "engine": eng.name,
            "engine_note": getattr(eng, "note", None),
            "workers": eng.n_workers,
            "scheduler": getattr(eng, "scheduler", None),
            "started": time.strftime("%Y-%m-%dT%H:%M:%S%z", time.localtime(started)),
        }
        run = cls(out, manifest, info, settings, groups, tile_blocks(m, ts), {})
        run.mats = run._open_matrices()
        recovered, rejected = run._adopt()
        info["tiles_before"] = len(manifest["tiles"])
        info["tiles_recovered"] = recovered
        info["tiles_rejected"] = rejected
        info["tiles_computed"] = 0
        info["pairs_computed"] = 0
        manifest["runs"].append(info)
        storage.write_json(out / storage.MANIFEST, manifest)
        return run

    @property
    def total(self) -> int:
        """Tiles of the run: blocks times representations."""
        return len(self.blocks) * len(self.settings.representations)

    def block(self, i: int) -> np.ndarray:
        """Motion indices of block ``i``."""
        return block(i, self.settings.tile_size, len(self.groups))

    def tile_path(self, key: str) -> Path:
        """``tiles/<key>.npy``."""
        return self.out / storage.TILES / (key + ".npy")

    def _open_matrices(self) -> dict[str, np.ndarray]:
        """The matrix files, new and memory-mapped, all NaN (a link, FIFO or hard link found at
        their name is replaced, never written through)."""
        mats = {}
        m = len(self.groups)
        for r in self.settings.representations:
            path = self.out / storage.matrix_name(r)
            with contextlib.suppress(FileNotFoundError):
                if not stat.S_ISDIR(os.lstat(path).st_mode):
                    path.unlink()
            mm = np.lib.format.open_memmap(path, mode="w+", dtype=np.float64, shape=(m, m))
            mm[:] = np.nan
            mats[r] = mm
        return mats

    def _adopt(self) -> tuple[int, list[str]]:
        """Place every tile that proves to be the run's own, list it in the manifest (those not
        listed yet as recovered) and forget the others; (tiles recovered, notes on the others)."""
        listed = self.manifest["tiles"]
        kept: dict[str, Any] = {}
        recovered, rejected = 0, []
        for r in self.settings.representations:
            for bi, bj in self.blocks:
                key = storage.tile_key(r, bi, bj)
                rows, cols = self.block(bi), self.block(bj)
                try:
                    tile = verified.load_array(self.tile_path(key), (len(rows), len(cols)), tile=key)
                    problem = tile_problem(tile, rows, cols, self.groups[rows], self.groups[cols])
                    if problem is not None:
                        raise verified.NotVerified(f"{key}.npy: {problem}")
                except verified.NotVerified as exc:
                    if not exc.missing:
                        rejected.append(f"{storage.TILES}/{exc}: computed again")
                    rejected += [f"{storage.TILES}/{n}" for n in verified.make_room(self.tile_path(key))]
                    continue
                _place(self.mats[r], tile, rows, cols)
                recovered += key not in listed
                kept[key] = listed.get(key) or {"run": self.info["run"], "recovered": True}
        self.manifest["tiles"] = kept
        return recovered, rejected

    def todo(self) -> list[Task]:
        """The tiles not on disk, by representation then block."""
        return [
            Task(storage.tile_key(r, bi, bj), r, bi, bj, self.block(bi), self.block(bj))
            for r in self.settings.representations
            for bi, bj in self.blocks
            if storage.tile_key(r, bi, bj) not in self.manifest["tiles"]
        ]

    def complete(self) -> bool:
        """Every tile of every representation is on disk."""
        tiles = self.manifest["tiles"]
        return all(
            storage.tile_key(r, bi, bj) in tiles
            for r in self.settings.representations
            for bi, bj in self.blocks
        )

    def compute(
        self,
        todo: list[Task],
        cache: SRVCache,
        eng: Engine,
        mats: dict[str, np.ndarray],
        progress: Progress | None,
    ) -> float:
        """Run the tiles ``todo`` on ``eng``: each finished tile written, placed in ``mats`` and
        listed in the manifest (written at most every 2 s, and after the last); the seconds the
        tiles took (summed over workers)."""
        settings, groups = self.settings, cache.groups
        handles: dict[str, Any] = {}

        def args_of(t: Task) -> tuple:
            if t.rep not in handles:
                handles[t.rep] = eng.share(cache.q[t.rep])
            return (
                t.rows,
                t.cols,
                handles[t.rep],
                groups[t.rows],
                groups[t.cols],
                settings.warp,
                settings.cyclic,
            )

        done = self.total - len(todo)
        tile_seconds = 0.0
        last_manifest = time.monotonic()
        manifest_path = self.out / storage.MANIFEST
        for task, res, secs in eng.run(todo, args_of):
            verified.save_array(self.tile_path(task.key), res, tile=task.key)
            _place(mats[task.rep], res, task.rows, task.cols)
            n_pairs = _pairs_in(task.rows, task.cols, groups)
            self.manifest["tiles"][task.key] = {
                "run": self.info["run"],
                "seconds": round(secs, 4),
                "pairs": n_pairs,
            }
            self.info["tiles_computed"] += 1
            self.info["pairs_computed"] += n_pairs
            tile_seconds += secs
            done += 1
            if time.monotonic() - last_manifest > 2.0 or done == self.total:
                storage.write_json(manifest_path, self.manifest)
                last_manifest = time.monotonic()
            if progress is not None:
                progress("tiles", done, self.total)
        return tile_seconds


def _pairs_in(rows: np.ndarray, cols: np.ndarray, groups: np.ndarray) -> int:
    i = rows[:, None]
    j = cols[None, :]
    return int(((i < j) & (groups[i] == groups[j])).sum())


def _place(mat: np.ndarray, tile: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> None:
    """Write a tile's upper-triangle entries and their mirror into ``mat``."""
    a, b = np.nonzero(rows[:, None] <= cols[None, :])
    i, j = rows[a], cols[b]
    mat[i, j] = tile[a, b]
    mat[j, i] = tile[a, b]


def _comparison_note(settings: DatabaseSettings, groups: list[dict[str, Any]]) -> str:
    if settings.joints == "common" and groups:
        joints = groups[0]["joints"]
        note = f"joints='common': all motions compared on the {len(joints)} joints they share"
        if len(joints) < 5:
            note += f" (only {joints}: the skeletons have little in common, distances mean little)"
        return note
    if len(groups) <= 1:
        return "one skeleton group"
    return (
        f"{len(groups)} skeleton groups: distances between groups are +inf "
        "(use joints='common' to compare them on their shared joints)"
    )


def _report(
    cache: SRVCache, settings: DatabaseSettings, eng: Engine, files: Sequence[Path], *, complete: bool
) -> dict[str, Any]:
    groups = []
    for g, joints in enumerate(cache.group_joints):
        members = [n for n, gg in zip(cache.names, cache.groups, strict=True) if gg == g]
        groups.append({"group": g, "joints": joints, "n_joints": len(joints), "motions": members})
    return {
        "complete": complete,
        "format": FORMAT_VERSION,
        "n_inputs": len(files),
        "n_motions": len(cache),
        "settings": settings.to_json(),
        "skipped": cache.skipped,
        "ignored": cache.ignored,
        "groups": groups,
        "comparison": _comparison_note(settings, groups),
        "joints_mode": settings.joints if isinstance(settings.joints, str) else "list",
        "engine": eng.name,
        "engine_note": getattr(eng, "note", None),
        "workers": eng.n_workers,
        "scheduler": getattr(eng, "scheduler", None),
        "host": platform.node(),
        "files": {
            "names": storage.NAMES,
            "distances": {r: storage.matrix_name(r) for r in settings.representations},
            "srv_cache": storage.CACHE,
            "tiles": storage.TILES + "/",
        },
    }


def remove_run(out_dir: str | os.PathLike[str]) -> None:
    """Delete the files a run wrote in ``out_dir`` (never anything else), then the folder if empty."""
    storage.clean_outputs(Path(out_dir))
    with contextlib.suppress(OSError):
        Path(out_dir).rmdir()
