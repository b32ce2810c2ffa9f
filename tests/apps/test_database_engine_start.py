"""How the Dask engines start and feed their workers (issue 15, "Scale").

* ``--engine local`` forks its workers from the driver on Linux (they start with its code and
  compiled kernels instead of importing and loading them again), single-threaded;
* ``dask worker --preload elastic_motion.apps.database.engines`` loads the code and kernels of
  a database run at the worker's start (``dask_setup``);
* the SRV arrays of a representation go to the workers as one scattered object (one
  dependency per tile);
* with several workers the costliest tiles run first (``order_tiles``), so the run does not
  end waiting on one worker.
"""

from __future__ import annotations

import socket
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from database_testlib import (
    assert_local_cluster_is_serial,
    needs_dask,
    synthetic_motion,
)

from elastic_motion.apps.database import DatabaseSettings, compute_matrix, engines, matrix
from elastic_motion.apps.database.engines import SerialEngine, Task, order_tiles
from elastic_motion.motion import write_bvh
from elastic_motion.warp import WarpOptions

SETTINGS = DatabaseSettings(n_samples=10, tile_size=3, warp=WarpOptions(method="dp", neighbourhood=3))

#: Set in the driver after import: a forked worker has it, a spawned one does not.
PROBE = "elastic-motion-fork-probe"


@pytest.fixture(scope="module")
def db(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("enginedb")
    for k in range(8):
        write_bvh(synthetic_motion(k % 3, k, frames=18 + k), d / f"m{k}.bvh")
    return d


def test_local_start_method_forks_on_linux_unless_unsafe_or_configured(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    dask = pytest.importorskip("dask")
    monkeypatch.setattr(engines.sys, "platform", "linux")
    monkeypatch.setattr(engines, "_numba_threading_layer", lambda: None)  # a child starts its own
    assert engines.local_start_method() == "fork"
    monkeypatch.setattr(engines, "_numba_threading_layer", lambda: "workqueue")  # fork-safe
    assert engines.local_start_method() == "fork"
    for layer in ("omp", "tbb"):  # running here: a fork from the nanny's thread may break them
        monkeypatch.setattr(engines, "_numba_threading_layer", lambda layer=layer: layer)
        assert engines.local_start_method() == "spawn"
    monkeypatch.setattr(engines, "_numba_threading_layer", lambda: None)
    with dask.config.set({"distributed.worker.multiprocessing-method": "forkserver"}):  # the user's choice
        assert engines.local_start_method() == "forkserver"
    monkeypatch.setattr(engines.sys, "platform", "darwin")
    assert engines.local_start_method() == "spawn"


_ENGINE_CHECK = """
import sys
import dask, numba, numpy as np
from elastic_motion.apps.database import engines
from elastic_motion.apps.database.tiles import pair_distance
from elastic_motion.warp import WarpOptions

if sys.argv[1] == "after-threads":  # numba's thread pool started here first (a serial DP)
    numba.set_num_threads(2)
    pair_distance(np.eye(4, 2), np.eye(4, 2)[::-1].copy(), WarpOptions(method="dp", neighbourhood=2))
engines._test_probe = "{probe}"  # set after import: only a forked worker has it
eng = engines.open_engine("local", None, 2, 30.0)
try:
    probe = set(eng.client.run(lambda: getattr(sys.modules[engines.__name__], "_test_probe", None)).values())
    threads = set(eng.client.run(lambda: numba.get_num_threads()).values())
    quiet = set(eng.client.run(lambda: dask.config.get("distributed.worker.profile.enabled")).values())
    layer = engines._numba_threading_layer()
    print(layer, eng.start_method, sorted(map(str, probe)), sorted(threads), sorted(quiet))
finally:
    eng.close()
"""


@needs_dask
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="workers are forked on Linux only")
@pytest.mark.parametrize("case", ["fresh", "after-threads"])
def test_local_workers_are_forked_from_a_fresh_driver_single_threaded_and_quiet(case: str) -> None:
    """``fresh``: as `elastic-motion matrix --engine local`, forked. ``after-threads``: numba's
    pool already running here; TBB or OpenMP (fork-unsafe) -> spawned, and it works; numba's
    own workqueue (where neither is installed) -> forked."""
    code = _ENGINE_CHECK.format(probe=PROBE)
    out = subprocess.run([sys.executable, "-c", code, case], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-3000:]
    layer, result = out.stdout.strip().splitlines()[-1].split(" ", 1)
    assert (layer == "None") == (case == "fresh")
    forked = layer in ("None", "workqueue")
    expected = f"fork ['{PROBE}'] [1] [False]" if forked else "spawn ['None'] [1] [False]"
    assert result == expected


@needs_dask
def test_local_engine_equals_serial_bit_for_bit(db: Path, tmp_path: Path) -> None:
    """A local cluster computes the serial matrix and leaves Dask's default port alone: with
    8787 taken (a user's cluster, another run, another test worker) the cluster starts
    without Dask's "port in use" warning."""
    with socket.socket() as taken, warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            taken.bind(("", 8787))
            taken.listen()
        except OSError:  # already in use: the case under test all the same
            pass
        assert_local_cluster_is_serial(db, tmp_path, SETTINGS)
    assert not [w for w in caught if "8787" in str(w.message)], [str(w.message) for w in caught]


def test_dask_setup_loads_the_kernels_of_a_run_in_a_fresh_process() -> None:
    code = (
        "from elastic_motion.apps.database.engines import dask_setup\n"
        "from elastic_motion.warp import dp_kernels\n"
        "from elastic_motion.motion import bvh\n"
        "import numba\n"
        "assert not dp_kernels.dp_energies_uniform_serial.signatures\n"
        "assert not bvh._parse_frames_fast.signatures\n"
        "dask_setup(None)\n"
        "assert dp_kernels.dp_energies_uniform_serial.signatures, 'DP kernel not loaded'\n"
        "assert bvh._parse_frames_fast.signatures, 'BVH reader kernel not loaded'\n"
        "assert numba.get_num_threads() == 1\n"
        "print('ok')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr[-2000:]


@needs_dask
def test_each_representation_is_scattered_once_as_one_object() -> None:
    eng = engines.open_engine("local", None, 1, 30.0)
    try:
        arrays = [np.full((3, 2), float(k)) for k in range(5)]
        handle = eng.share(arrays)
        assert hasattr(handle, "key") and len(eng.client.who_has([handle])[handle.key]) == 1
        args = (
            np.arange(2),
            np.arange(1, 4),
            handle,
            np.zeros(2, int),
            np.zeros(3, int),
            WarpOptions(method="none"),
        )
        tile, _ = eng.client.submit(engines._timed_tile, *args, pure=False).result()
        here = engines.tile_of(*args[:2], arrays, *args[3:])
        assert (
            tile.tobytes() == here.tobytes()
            and tile[0, 0] == pytest.approx(np.sqrt(2.0))
            and tile[1, 0] == 0.0
        )
        # resubmitted after a loss: the driver's own arrays replace the future
        args = eng._with_arrays((np.arange(2), handle))
        assert args[1] is eng._arrays[handle.key] and args[1] == arrays
        # ... only its rows' and columns' arrays (not the whole database)
        only = eng._with_arrays((np.arange(2), handle), keep=[1])[1]
        assert only[0] is None and only[1] is arrays[1] and len(only) == len(arrays)
        sparse = eng._with_arrays((handle,), keep=[0, 1, 1, 2, 3])[0]
        tile_args = (np.arange(2), np.arange(1, 4), sparse, np.zeros(2, int), np.zeros(3, int))
        assert engines.tile_of(*tile_args, WarpOptions(method="none")).tobytes() == here.tobytes()
    finally:
        eng.close()


def test_order_tiles_puts_the_costliest_first_ties_in_order() -> None:
    t = [Task(f"k{k}", "lie", 0, k, np.arange(1), np.arange(1)) for k in range(5)]
    cost = {"k0": 2.0, "k1": 5.0, "k2": 2.0, "k3": 9.0, "k4": 1.0}
    assert [x.key for x in order_tiles(t, lambda x: cost[x.key])] == ["k3", "k1", "k0", "k2", "k4"]


def test_a_run_on_several_workers_starts_with_the_costliest_tiles(
    db: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    seen: list[list[str]] = []

    class TwoWorkers(SerialEngine):
        n_workers = 2

        def run(self, tasks, args_of):
            seen.append([t.key for t in tasks])
            return super().run(tasks, args_of)

    monkeypatch.setattr(matrix, "open_engine", lambda *a, **k: TwoWorkers())
    res = compute_matrix([db], tmp_path / "two", SETTINGS)
    keys = seen[0]
    assert res.complete and len(keys) == len(set(keys)) == 6 * len(SETTINGS.representations)  # 3 blocks
    pairs = []
    for k in keys:  # lie_0_1 ...: blocks of 3, 8 motions (blocks 0, 1 full, block 2 of 2 motions)
        _, bi, bj = k.rsplit("_", 2)
        n = [3, 3, 2]
        a, b = n[int(bi)], n[int(bj)]
        pairs.append(a * (a - 1) // 2 if bi == bj else a * b)
    assert pairs == sorted(pairs, reverse=True) and pairs[0] == 9 and pairs[-1] == 1
    serial = compute_matrix([db], tmp_path / "serial", SETTINGS)
    for r in SETTINGS.representations:
        assert np.asarray(res.distances[r]).tobytes() == np.asarray(serial.distances[r]).tobytes()


def test_forked_workers_make_a_local_cluster_worth_it_on_smaller_inputs(
    db: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Measured (new processes, 2 cores): 120 windows of 64 cells 3.6-3.8 s on a forked local
    cluster against 4.2-4.3 s serially, 40 windows 1.5-1.6 s against 1.3 s."""
    from elastic_motion.apps.database import tiles

    w = WarpOptions(method="dp", neighbourhood=10)
    assert tiles.cluster_worth_it(120 * 119 // 2, 64, w, startup=tiles.LOCAL_CLUSTER_STARTUP_FORKED)[0]
    small, why = tiles.cluster_worth_it(40 * 39 // 2, 64, w, startup=tiles.LOCAL_CLUSTER_STARTUP_FORKED)
    assert not small and f"the {tiles.LOCAL_CLUSTER_STARTUP_FORKED:g} s a cluster needs" in why
    assert not tiles.cluster_worth_it(120 * 119 // 2, 64, w)[0]  # spawned workers: 6 s to start
    seen: list[float] = []

    def spy(*args, startup=None, **kw):
        seen.append(startup)
        return tiles.cluster_worth_it(*args, startup=startup, **kw)

    monkeypatch.setattr(matrix, "cluster_worth_it", spy)
    for method, expected in (
        ("fork", tiles.LOCAL_CLUSTER_STARTUP_FORKED),
        ("spawn", tiles.LOCAL_CLUSTER_STARTUP),
    ):
        monkeypatch.setattr(matrix, "local_start_method", lambda method=method: method)
        res = compute_matrix([db], tmp_path / method, SETTINGS, engine="local")
        assert seen[-1] == expected and res.report["engine"] == "serial"  # 8 clips: never worth it


def test_a_cyclic_run_is_costed_as_two_n_samples_plain_pairs_per_pair(
    db: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Whether a local cluster pays off: a cyclic pair is the exact DP of every shift of
    either motion, 2 n_samples plain pairs (``tiles.pair_distances(cyclic=True)``)."""
    import dataclasses

    from elastic_motion.apps.database import tiles

    pairs: list[int] = []

    def spy(n_pairs, *args, **kw):
        pairs.append(n_pairs)
        return tiles.cluster_worth_it(n_pairs, *args, **kw)

    monkeypatch.setattr(matrix, "cluster_worth_it", spy)
    n, reps = 8, len(SETTINGS.representations)
    for cyclic in (False, True):
        s = dataclasses.replace(SETTINGS, cyclic=cyclic)
        compute_matrix([db], tmp_path / f"c{cyclic}", s, engine="local")
    assert pairs == [n * (n - 1) // 2 * reps, n * (n - 1) // 2 * reps * 2 * SETTINGS.n_samples]


@needs_dask
def test_a_future_cancelled_while_the_driver_waits_is_handed_back() -> None:
    """``_Completed.next_batch``: ``distributed.wait`` raises when a future it waits on is
    cancelled; the batch hands the future back (``run`` then resubmits or reports it)."""
    import threading
    import time

    eng = engines.open_engine("local", None, 1, 30.0)
    try:
        fut = eng.client.submit(time.sleep, 5.0, pure=False)
        done = engines._Completed([fut])
        timer = threading.Timer(0.3, fut.cancel)
        timer.start()
        batch = []
        for _ in range(20):
            batch = done.next_batch(1.0)
            if batch:
                break
        timer.join()
        assert batch == [fut] and fut.cancelled() and done.is_empty()
    finally:
        eng.close()


def _fail_fast(_: int) -> None:
    raise ValueError("file m3.bvh: unreadable")


def _sleep_long(_: int) -> int:
    import time

    time.sleep(60)
    return 1


@needs_dask
def test_an_abandoned_stage_cancels_its_other_tasks() -> None:
    """A stage whose gather raises (a task's error, or FilesNotSeenError before the driver
    reads the files itself) cancels its unfinished tasks: they do not keep the workers busy."""
    eng = engines.open_engine("local", None, 1, 30.0)
    try:
        import time

        stages = engines.DaskStages(eng)
        fail = stages.submit(_fail_fast, [(0,)])  # first on the one worker thread
        slow = stages.submit(_sleep_long, [(1,), (2,)])
        t0 = time.perf_counter()
        with pytest.raises(ValueError, match=r"m3\.bvh"):
            stages.gather([*slow, *fail])
        assert time.perf_counter() - t0 < 30.0
        assert [f.status for f in slow] == ["cancelled", "cancelled"]
    finally:
        eng.close()
