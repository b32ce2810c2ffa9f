"""The read / prepare / SRV phase of a matrix run on Dask workers (issue 15).

With a Dask engine the files are read, prepared and their SRV arrays computed on the workers
(``cache.build_srv_cache`` with ``DaskEngine.stages``), with the numbers of a serial run bit for
bit. The driver's own preparation functions are wrapped with counters here: a spawned worker
imports the unwrapped module, and a forked one counts in its own copy of the counters, so a
count above zero means that work ran in the driver. Real CMU windows (``mocap_dir``, skipped when
absent) and one malformed file.
"""

from __future__ import annotations

import pickle
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from database_testlib import assert_same_as_serial, needs_dask

from elastic_motion.apps.database import DatabaseSettings, SRVCache, build_srv_cache, cache, compute_matrix
from elastic_motion.motion import drop_tpose, group_weights, read_motion, select_frames, write_bvh
from elastic_motion.warp import WarpOptions

SETTINGS = DatabaseSettings(n_samples=12, tile_size=4, warp=WarpOptions(method="dp", neighbourhood=4))
CLIPS = ("07_01", "49_08", "131_01")  # two skeleton groups: 131_01 has other joints
BAD = "broken.bvh"


@pytest.fixture(scope="module")
def db(mocap_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """11 windows of 40 frames of three CMU clips, and one malformed file."""
    d = tmp_path_factory.mktemp("db")
    for c in CLIPS:
        m = drop_tpose(read_motion(mocap_dir / "cmu" / "bvh" / f"{c}.bvh"))
        for k, s in enumerate(range(0, min(m.n_frames - 40, 4 * 97), 97)):
            write_bvh(select_frames(m, slice(s, s + 40)), d / f"{c}_w{k}.bvh")
    (d / BAD).write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0\n")
    return d


@pytest.fixture()
def driver_calls(monkeypatch: pytest.MonkeyPatch) -> Counter:
    """Counts of the preparation steps that ran in this process (not on a spawned worker)."""
    calls: Counter = Counter()

    def wrap(name: str) -> None:
        original = getattr(cache, name)

        def counted(*args, **kw):
            calls[name] += 1
            return original(*args, **kw)

        monkeypatch.setattr(cache, name, counted)

    for name in ("prepare_motion", "srv_arrays"):
        wrap(name)
    return calls


@pytest.fixture(scope="module")
def serial_run(db: Path, tmp_path_factory: pytest.TempPathFactory):
    return compute_matrix([db], tmp_path_factory.mktemp("serial") / "out", SETTINGS)


def _same_as_serial(res, serial) -> None:
    assert_same_as_serial(res, serial, min_motions=10)


def test_serial_preparation_runs_here_and_names_the_bad_file(
    serial_run, db: Path, driver_calls: Counter, tmp_path
):
    """The reference: the counters see a serial run's preparation (so a zero below means
    something), the malformed file is skipped and named, and the group weights are those of
    ``motion.group_weights`` (the stages recompute its means from per-motion defaults)."""
    res = compute_matrix([db], tmp_path / "again", SETTINGS)
    n = len(res.names)
    assert driver_calls["prepare_motion"] == n + 1 and driver_calls["srv_arrays"] == n
    assert res.report["runs"][-1]["read_where"] == "driver"
    assert [Path(s["path"]).name for s in res.report["skipped"]] == [BAD]
    assert "broken.bvh" in res.report["skipped"][0]["path"]
    c = SRVCache.load(Path(serial_run.out_dir) / "srv_cache.npz")
    assert len(c.group_joints) == 2
    from elastic_motion.apps.database.preparation import prepare_motion

    for g in range(len(c.group_joints)):
        members = [p for p, gg in zip(c.paths, c.groups, strict=True) if gg == g]
        jw, tw = group_weights([prepare_motion(p, SETTINGS.n_samples).motion for p in members])
        assert np.asarray(c.group_weights[g][0]).tobytes() == jw.tobytes() and c.group_weights[g][1] == tw


@needs_dask
def test_local_cluster_reads_prepares_and_computes_srv_on_its_workers(
    serial_run, db: Path, driver_calls: Counter, tmp_path: Path
) -> None:
    seen: list[tuple[int, int]] = []

    def progress(stage: str, done: int, total: int) -> None:
        if stage == "read":
            seen.append((done, total))

    res = compute_matrix(
        [db], tmp_path / "local", SETTINGS, engine="local", n_workers=2, force_cluster=True, progress=progress
    )
    n_files = len(res.names) + 1
    assert seen[-1] == (n_files, n_files) and [d for d, _ in seen] == sorted(d for d, _ in seen)
    run = res.report["runs"][-1]
    assert run["engine"] == "local" and run["read_where"] == "workers"
    assert driver_calls["prepare_motion"] == 0 and driver_calls["srv_arrays"] == 0  # none in the driver
    tasks = run["read_tasks_by_worker"]
    assert all(w.startswith("tcp://") for w in tasks) and sum(tasks.values()) >= 3  # prepare, summary, SRV
    _same_as_serial(res, serial_run)  # the bad file skipped and named as in the serial run


@needs_dask
def test_scheduler_address_reads_on_workers_that_see_the_files_else_on_the_driver(
    serial_run, db: Path, driver_calls: Counter, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import logging

    import dask
    from distributed import LocalCluster

    from elastic_motion.apps.database import engines

    # (without Dask's MALLOC_TRIM_THRESHOLD_, which its nanny would also leave in this
    # process's environment for the clusters started after it)
    no_trim = {"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}
    with (
        dask.config.set(no_trim),
        LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=logging.CRITICAL,
        ) as cluster,
    ):
        address = cluster.scheduler_address
        res = compute_matrix([db], tmp_path / "dask", SETTINGS, engine="dask", scheduler=address)
        assert res.report["runs"][-1]["read_where"] == "workers"
        assert driver_calls["prepare_motion"] == 0 and driver_calls["srv_arrays"] == 0
        _same_as_serial(res, serial_run)

        # workers whose files differ from the driver's (as on another machine): read on the driver
        monkeypatch.setattr(engines, "file_fingerprint", lambda p: (-1, -1))
        res = compute_matrix([db], tmp_path / "elsewhere", SETTINGS, engine="dask", scheduler=address)
        run = res.report["runs"][-1]
        assert run["read_where"] == "driver" and "does not see" in run["read_note"]
        assert driver_calls["prepare_motion"] == len(res.names) + 1
        _same_as_serial(res, serial_run)
        monkeypatch.undo()

        # a worker that finds a file changed when its task runs: the driver reads them all again
        monkeypatch.setattr(cache, "file_fingerprint", lambda p: (-2, -2))
        res = compute_matrix([db], tmp_path / "changed", SETTINGS, engine="dask", scheduler=address)
        run = res.report["runs"][-1]
        assert run["read_where"] == "driver" and "expected the file the driver sees" in run["read_note"]
        _same_as_serial(res, serial_run)


def test_an_unexpected_error_names_the_file_and_keeps_its_note_through_pickling(
    db: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An error that is not a bad file's (a bug) ends the run, naming the file, also when it
    comes back from a worker (pickled)."""

    def boom(path, *args, **kw):
        raise RuntimeError("unexpected")

    monkeypatch.setattr(cache, "prepare_motion", boom)
    victim = str(sorted(db.glob("*.bvh"))[0])
    with pytest.raises(RuntimeError, match="unexpected") as info:
        build_srv_cache([victim], SETTINGS)
    assert any(victim in n for n in info.value.__notes__)
    again = pickle.loads(pickle.dumps(info.value))
    assert any(victim in n for n in again.__notes__)


@needs_dask
def test_local_workers_keep_glibc_malloc_defaults() -> None:
    """Dask's MALLOC_TRIM_THRESHOLD_=65536 made the workers' reading 20-40 % slower (measured):
    the local cluster's workers start without it."""
    import os

    from elastic_motion.apps.database.engines import open_engine

    eng = open_engine("local", None, 2, 30.0)
    try:
        assert eng.name == "local"
        env = eng.client.run(os.environ.get, "MALLOC_TRIM_THRESHOLD_")
        assert len(env) == 2 and set(env.values()) == {None}
        assert set(eng.client.run(os.environ.get, "OMP_NUM_THREADS").values()) == {"1"}  # Dask's others kept
    finally:
        eng.close()
