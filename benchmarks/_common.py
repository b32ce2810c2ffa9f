"""Helpers shared by the benchmark scripts: timing, machine description, JSON output.

Each benchmark script runs on its own (``python benchmarks/NAME.py``), with this folder
on ``sys.path``, and imports what it needs from here.
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import tarfile
import time
from collections.abc import Callable
from io import BytesIO
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from elastic_motion._io import atomic_write_text

T = TypeVar("T")

RESULTS = Path(__file__).resolve().parent / "results"
#: This repository (the benchmarks' parent folder).
REPO = Path(__file__).resolve().parents[1]
#: The real data: ``$ELASTIC_MOTION_MOCAP`` or ``../shared/mocap`` beside the repository.
MOCAP = Path(os.environ.get("ELASTIC_MOTION_MOCAP", Path(__file__).resolve().parents[2] / "shared" / "mocap"))
#: CMU clips of one skeleton (the IsaacGymEnvs / una-dinosauria conversions share joint names;
#: the bvh11 conversions 131_* name their joints differently and form another group).
CMU_CLIPS = ["01_01", "07_01", "08_02", "09_11", "107_02_30hz", "108_01_30hz", "49_08", "55_01"]


def load_clip(rel: str, start: float | None = None, stop: float | None = None, tpose: bool = True):
    """A clip of the real data (path relative to :data:`MOCAP`), its T-pose frame dropped
    when ``tpose``, trimmed to ``[start, stop]`` seconds when given."""
    from elastic_motion.motion import drop_tpose, read_motion, trim

    m = read_motion(MOCAP / rel)
    if tpose:
        m = drop_tpose(m)
    if start is not None or stop is not None:
        m = trim(m, start, stop)
    return m


def timed_best(fn: Callable[[], T], repeat: int) -> tuple[float, T]:
    """Best wall time of ``repeat`` calls after one warm-up call (numba compilation or cache
    load, page faults), and the last call's result."""
    out = fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def best_time(fn: Callable[[], Any], repeat: int) -> float:
    """Best wall time of ``repeat`` calls after one warm-up call (see :func:`timed_best`)."""
    return timed_best(fn, repeat)[0]


def machine_info() -> dict[str, Any]:
    """What the numbers were measured on (and how busy the machine was)."""
    return {
        "python": platform.python_version(),
        "numpy": np.__version__,
        "machine": platform.machine(),
        "cpu_count": os.cpu_count(),
        "load_average": os.getloadavg() if hasattr(os, "getloadavg") else None,
        "date": time.strftime("%Y-%m-%d %H:%M"),
    }


def write_json(path: str | os.PathLike[str], obj: Any) -> Path:
    """Write ``obj`` as JSON to ``path`` atomically (numpy scalars and arrays as numbers)."""

    def default(o: Any) -> Any:
        if isinstance(o, np.ndarray):
            return o.tolist()
        if isinstance(o, np.generic):
            return o.item()
        if isinstance(o, Path):
            return str(o)
        raise TypeError(f"not JSON serialisable: {type(o).__name__}")

    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    return atomic_write_text(out, json.dumps(obj, indent=1, default=default) + "\n")


def baseline_src(rev: str, into: Path) -> Path:
    """``src/`` of revision ``rev`` of this repository, extracted into ``into`` (``git archive``):
    put it first on ``sys.path`` of a fresh process to time that revision in the same run."""
    blob = subprocess.run(
        ["git", "-C", str(REPO), "archive", "--format=tar", rev, "src"], capture_output=True, check=True
    ).stdout
    with tarfile.open(fileobj=BytesIO(blob)) as tar:
        tar.extractall(into, filter="data")
    return into / "src"
