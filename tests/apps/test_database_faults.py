"""The matrix run under faults: a Dask worker SIGKILLed mid-run, a server that is not Dask,
bad files among good ones, output folders that overlap their inputs (issue 14).

The Dask test starts its own ``dask scheduler`` and two ``dask worker`` processes on
127.0.0.1 (no nanny, so a killed worker stays dead), kills one after the second tile, and
checks that the matrix equals the serial one bit for bit.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import numpy as np
import pytest
from database_testlib import needs_dask

from elastic_motion.apps.database import ClusterUnavailableError, DatabaseSettings, compute_matrix
from elastic_motion.errors import OptionError
from elastic_motion.motion import Motion, Skeleton, write_bvh
from elastic_motion.motion.deepmimic import DEEPMIMIC_JOINTS
from elastic_motion.motion.rotations import euler_to_matrix
from elastic_motion.warp import WarpOptions

SETTINGS = DatabaseSettings(n_samples=12, tile_size=2, warp=WarpOptions(method="dp", neighbourhood=4))


def _motion(k: int, frames: int = 24) -> Motion:
    names = ["Hips", "Spine", "LeftLeg", "RightLeg"]
    rot = ("Zrotation", "Yrotation", "Xrotation")
    sk = Skeleton(
        names,
        [-1, 0, 0, 0],
        [[0, 0, 0], [0, 0.3, 0], [0.1, -0.1, 0], [-0.1, -0.1, 0]],
        [("Xposition", "Yposition", "Zposition", *rot)] + [rot] * 3,
        end_site_parents=[2, 3],
        end_site_offsets=[[0, -0.5, 0]] * 2,
    )
    s = np.linspace(0.0, 1.0, frames)
    ang = np.zeros((frames, 4, 3))
    for j in range(4):
        ang[:, j, 2] = (0.3 + 0.05 * k) * np.sin(2 * np.pi * (1 + 0.1 * k) * s + j + 0.2 * k)
        ang[:, j, 1] = 0.1 * np.cos(2 * np.pi * s + j)
    root = np.stack([0.02 * np.sin(4 * np.pi * s), 0.9 + 0 * s, (1.0 + 0.1 * k) * s], axis=1)
    return Motion(sk, 30.0, root, euler_to_matrix(ang, "ZYX"), metres_per_unit=1.0)


@pytest.fixture(scope="module")
def db(tmp_path_factory) -> Path:
    """12 readable clips and the hostile files of issue 14 (each must be skipped and listed)."""
    d = tmp_path_factory.mktemp("faultdb")
    for k in range(12):
        write_bvh(_motion(k, 20 + k), d / f"m{k:02d}.bvh")
    good = (d / "m00.bvh").read_text()
    head = good[: good.index("Frames:")]
    (d / "huge_frames.bvh").write_text(head + "Frames: 1000000000000000\nFrame Time: 0.0333333\n0 0 0\n")
    (d / "fast.bvh").write_text(re.sub(r"Frame Time:.*", "Frame Time: 1e-9", good))
    joints = [[0.5] if revolute else [1.0, 0.0, 0.0, 0.0] for _, _, revolute in DEEPMIMIC_JOINTS[1:]]
    flat = [v for j in joints for v in j]
    frames = [[0.0333, 0.0, 0.9, 0.0, 1.0, 0.0, 0.0, 0.0, *flat] for _ in range(5)]
    frames[2][0] = 1.797e308
    (d / "overflow.txt").write_text(json.dumps({"Loop": "none", "Frames": frames}))
    frames[2][0] = 1e4
    (d / "long_hold.txt").write_text(json.dumps({"Loop": "none", "Frames": frames}))
    return d


BAD = {"huge_frames.bvh", "fast.bvh", "overflow.txt", "long_hold.txt"}


def test_bad_files_are_skipped_and_listed_never_fatal(db: Path, tmp_path: Path) -> None:
    res = compute_matrix([db], tmp_path / "out", SETTINGS)
    assert res.complete and len(res.names) == 12
    skipped = {Path(s["path"]).name: s["reason"] for s in res.report["skipped"]}
    assert set(skipped) == BAD
    assert "max_frames" in skipped["huge_frames.bvh"] and "max_fps" in skipped["fast.bvh"]
    assert "max_duration" in skipped["overflow.txt"] and "max_resample_growth" in skipped["long_hold.txt"]


def test_output_folder_never_overlaps_an_input_folder(db: Path, tmp_path: Path) -> None:
    with pytest.raises(OptionError, match="inside an input folder"):
        compute_matrix([db], db / "M", SETTINGS)
    assert not (db / "M").exists()
    with pytest.raises(OptionError, match="inside an input folder"):
        compute_matrix([db], db.parent, SETTINGS)


def test_zero_workers_and_bad_timeout_are_option_errors(db: Path, tmp_path: Path) -> None:
    with pytest.raises(OptionError, match="workers"):
        compute_matrix([db], tmp_path / "o", SETTINGS, engine="local", n_workers=0)
    with pytest.raises(OptionError, match="timeout"):
        compute_matrix([db], tmp_path / "o", SETTINGS, engine="local", connect_timeout=float("nan"))
    assert not (tmp_path / "o").exists()


class _Hello(BaseHTTPRequestHandler):
    def do_GET(self) -> None:  # pragma: no cover - Dask never sends HTTP
        self.send_response(200)
        self.end_headers()

    def log_message(self, *args) -> None:
        pass


@needs_dask
def test_timeout_holds_against_a_server_that_is_not_dask(db: Path, tmp_path: Path) -> None:
    server = ThreadingHTTPServer(("127.0.0.1", 0), _Hello)
    server.daemon_threads = True
    th = threading.Thread(target=server.serve_forever, daemon=True)
    th.start()
    try:
        address = f"tcp://127.0.0.1:{server.server_address[1]}"
        t0 = time.monotonic()
        with pytest.raises(ClusterUnavailableError, match="could not reach the Dask scheduler"):
            compute_matrix(
                [db], tmp_path / "o", SETTINGS, engine="dask", scheduler=address, connect_timeout=2.0
            )
        assert time.monotonic() - t0 < 4.0
        assert not (tmp_path / "o").exists()
    finally:
        server.shutdown()
        server.server_close()


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _dask(*args: str, log: Path) -> subprocess.Popen:
    cmd = [sys.executable, "-m", "distributed.cli.dask_" + args[0], *args[1:]]
    with open(log, "wb") as fh:  # the child keeps its own copy of the descriptor
        return subprocess.Popen(cmd, stdout=fh, stderr=subprocess.STDOUT, start_new_session=True)


def _stop(procs: list[subprocess.Popen]) -> None:
    for p in procs:
        if p.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(p.pid, signal.SIGKILL)
    for p in procs:
        with contextlib.suppress(subprocess.TimeoutExpired):
            p.wait(timeout=5)


def _wait_for_workers(address: str, n: int, deadline: float) -> None:
    from distributed import Client

    with Client(address, timeout=10) as c:
        while len(c.scheduler_info().get("workers", {})) < n:
            if time.monotonic() > deadline:
                raise TimeoutError(f"{n} workers did not join {address}")
            time.sleep(0.1)


@needs_dask
def test_matrix_survives_a_worker_sigkilled_mid_run(db: Path, tmp_path: Path) -> None:
    serial = compute_matrix([db], tmp_path / "serial", SETTINGS)
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    env_logs = tmp_path / "logs"
    env_logs.mkdir()
    procs: list[subprocess.Popen] = []
    try:
        procs.append(
            _dask(
                "scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                str(port),
                "--no-dashboard",
                log=env_logs / "s.log",
            )
        )
        for k in range(2):
            procs.append(
                _dask(
                    "worker",
                    address,
                    "--host",
                    "127.0.0.1",
                    "--nthreads",
                    "1",
                    "--no-nanny",
                    "--no-dashboard",
                    "--name",
                    f"w{k}",
                    log=env_logs / f"w{k}.log",
                )
            )
        _wait_for_workers(address, 2, time.monotonic() + 15)
        victim = procs[1]
        killed = []

        def progress(stage: str, done: int, total: int) -> None:
            if stage == "tiles" and done >= 2 and not killed:
                os.killpg(victim.pid, signal.SIGKILL)  # mid-run, tiles in flight on both workers
                victim.wait(timeout=5)
                killed.append(done)

        res = compute_matrix(
            [db],
            tmp_path / "dask",
            SETTINGS,
            engine="dask",
            scheduler=address,
            connect_timeout=5,
            progress=progress,
        )
        assert killed and killed[0] < 42  # killed mid-run (21 blocks x 2 representations)
        assert res.complete
        for r in ("lie", "euler"):
            assert np.asarray(res.distances[r]).tobytes() == np.asarray(serial.distances[r]).tobytes()
    finally:
        _stop(procs)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_special_entries_of_a_folder_are_listed_as_skipped(tmp_path: Path) -> None:
    """FIFOs, folders named *.bvh, dangling links and link loops: listed, never opened or fatal."""
    d = tmp_path / "db"
    d.mkdir()
    for k in range(3):
        write_bvh(_motion(k), d / f"m{k}.bvh")
    os.mkfifo(d / "fifo.bvh")
    os.mkfifo(d / "fifo.txt")  # a .txt is peeked at to tell DeepMimic clips: never a FIFO
    (d / "folder.bvh").mkdir()
    (d / "dangling.bvh").symlink_to(d / "missing.bvh")
    (d / "loop_a.bvh").symlink_to(d / "loop_b.bvh")
    (d / "loop_b.bvh").symlink_to(d / "loop_a.bvh")
    t0 = time.monotonic()
    res = compute_matrix([d], tmp_path / "out", SETTINGS)
    assert time.monotonic() - t0 < 20
    assert res.complete and len(res.names) == 3
    skipped = {Path(s["path"]).name for s in res.report["skipped"]}
    assert skipped == {"fifo.bvh", "fifo.txt", "folder.bvh", "dangling.bvh", "loop_a.bvh", "loop_b.bvh"}


@needs_dask
def test_losing_every_worker_ends_the_run_within_the_timeout_and_it_resumes(db: Path, tmp_path: Path) -> None:
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    procs: list[subprocess.Popen] = []
    try:
        procs.append(
            _dask(
                "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard", log=tmp_path / "s"
            )
        )
        procs.append(
            _dask(
                "worker",
                address,
                "--host",
                "127.0.0.1",
                "--nthreads",
                "1",
                "--no-nanny",
                "--no-dashboard",
                log=tmp_path / "w",
            )
        )
        _wait_for_workers(address, 1, time.monotonic() + 15)
        killed: list[float] = []

        def progress(stage: str, done: int, total: int) -> None:
            if stage == "tiles" and done >= 2 and not killed:
                os.killpg(procs[1].pid, signal.SIGKILL)
                procs[1].wait(timeout=5)
                killed.append(time.monotonic())

        out = tmp_path / "dask"
        with pytest.raises(ClusterUnavailableError, match="no worker for 2 s"):
            compute_matrix(
                [db], out, SETTINGS, engine="dask", scheduler=address, connect_timeout=2, progress=progress
            )
        assert killed and time.monotonic() - killed[0] < 8.0
    finally:
        _stop(procs)
    res = compute_matrix([db], out, SETTINGS)  # the tiles already on disk are kept: resume serially
    assert res.complete and res.report["runs"][-1]["tiles_before"] >= 2


@needs_dask
def test_a_scheduler_without_workers_is_an_error_within_the_timeout(db: Path, tmp_path: Path) -> None:
    port = _free_port()
    procs = [
        _dask("scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard", log=tmp_path / "s")
    ]
    try:
        from distributed import Client

        with Client(f"tcp://127.0.0.1:{port}", timeout=15):
            pass  # the scheduler is up
        t0 = time.monotonic()
        with pytest.raises(ClusterUnavailableError, match="has no worker"):
            compute_matrix(
                [db],
                tmp_path / "o",
                SETTINGS,
                engine="dask",
                scheduler=f"tcp://127.0.0.1:{port}",
                connect_timeout=1,
            )
        assert time.monotonic() - t0 < 5.0 and not (tmp_path / "o").exists()
    finally:
        _stop(procs)
