"""Benchmark of the scale targets of issue 15: all pairs of 1000 motions x 200 frames, exact-DP
quality, Dask speed-ups.

Sections (``--sections``, comma-separated; default all, in this order):

1. ``per_pair``: seconds per pair of the database's DP (neighbourhood 10, ``n_samples`` cells,
   Lie) on one core: one ``optimal_warp(method="dp")`` call per pair against the batched kernel
   (``warp.solver.dp_energies``, what the tiles run), on real SRV arrays of the windows.
2. ``scale``: ``M`` (default 1000) BVH files of exactly 200 frames, windows at random starts
   of the 120 Hz CMU clips of ``/work/shared/mocap`` (written once, seed 0), then the whole
   pipeline measured end to end: ``compute_matrix`` (read, prepare, SRV, all ``M (M - 1) / 2``
   pairs; Lie; the database defaults: ``n_samples = 64``, exact DP with neighbourhood 10,
   tiles of 32) with each engine of ``--engine`` (default ``serial,local``: the default
   engine, whose batched DP uses numba's threads, then a ``LocalCluster`` of 2 workers).
3. ``quality``: on a random sample of pairs of that matrix, the energy ``d^2`` of the matrix
   against the exact DP solved independently (``optimal_warp(q_i, q_j, method="dp")``, one
   call per pair, on the run's own SRV cache): the share of pairs more than 0.1 % above it
   (the target: none) and the largest excess; and whether the engines' matrices are equal
   bit for bit.
4. ``speedup``: all pairs of the first ``--speedup-motions`` (default 400) of those windows:
   serial (one numba thread), a ``LocalCluster`` of 2 workers, and a ``dask scheduler`` + 2
   ``dask worker`` processes started here on 127.0.0.1 (subprocesses); end-to-end seconds and
   seconds of the pair phase, the matrices compared bit for bit. Also serial with numba's
   default threads (the batched kernel shares a tile's pairs among them). With both Dask
   engines the files are read, prepared and their SRV computed on the workers too (the
   ``read on`` column). Each engine runs in a new Python process, as ``elastic-motion matrix``
   does (imports not timed; code and kernels load within the run; the ``LocalCluster``'s
   workers are forked from it); the separately started workers are started with ``--preload
   elastic_motion.apps.database.engines`` and the engine's Dask settings (a config file:
   ``engines.QUIET_DASK``, glibc's malloc defaults), as a running cluster would be, their
   start not timed. ``--repeat N`` runs the section N times (all kept in ``speedup_runs``);
   each run records the load average and the CPU seconds other jobs took meanwhile
   (``cpu_seconds_others``). Skipped with a message when ``distributed`` is not installed
   (extra ``cluster``).
5. ``small``: ``--engine local`` on a small input (40 windows) against serial, each in a new
   process: the cluster is not started when it would not pay for its start
   (``tiles.cluster_worth_it``); also what a cluster started anyway costs (``local_forced``).

Prints a table and writes ``benchmarks/results/database_scale.json``. The machine is shared:
the JSON records the load average before and after each section.

Usage::

    python benchmarks/database_scale.py                       # everything (~12 min idle machine)
    python benchmarks/database_scale.py --sections scale,quality
    python benchmarks/database_scale.py --quick               # smoke test (small sizes)
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from _common import CMU_CLIPS, RESULTS, machine_info, write_json
from elastic_motion import WarpOptions
from elastic_motion.apps.database import (
    DEFAULT_WARP,
    DatabaseSettings,
    SRVCache,
    build_srv_cache,
    compute_matrix,
    single_threaded_blas,
)
from elastic_motion.motion import drop_tpose, read_motion, select_frames, write_bvh
from elastic_motion.warp import optimal_warp
from elastic_motion.warp.solver import dp_energies

REPO = Path(__file__).resolve().parents[1]
FRAMES = 200
#: Energy above the exact DP allowed per pair (issue 15: 0.1 %).
TOLERANCE = 1e-3


def load(label: str) -> dict:
    return {"load_average": [round(x, 2) for x in os.getloadavg()], "at": label}


def write_windows(cmu: Path, out: Path, m: int, seed: int = 0) -> float:
    """``m`` BVH files of exactly ``FRAMES`` frames: windows at random starts of the 120 Hz CMU
    clips, in turn (``w0000.bvh`` ...). Returns the seconds spent."""
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    clips = [drop_tpose(read_motion(cmu / f"{c}.bvh")) for c in CMU_CLIPS]
    clips = [c for c in clips if c.fps == 120 and c.n_frames >= FRAMES]
    out.mkdir(parents=True, exist_ok=True)
    for k in range(m):
        clip = clips[k % len(clips)]
        s = int(rng.integers(0, clip.n_frames - FRAMES + 1))
        write_bvh(select_frames(clip, slice(s, s + FRAMES)), out / f"w{k:04d}.bvh")
    return time.perf_counter() - t0


#: The warp of issue 15's all-pairs target, "exact-DP quality": the DP alone (neighbourhood 10),
#: the database's default (``DEFAULT_WARP``), named here as the target states it.
EXACT_DP = DEFAULT_WARP.replace(method="dp")


def settings(tile_size: int = 32, warp: WarpOptions = EXACT_DP) -> DatabaseSettings:
    """n_samples 64, tiles of 32 x 32, Lie only, the database's low-pass; the exact DP with
    neighbourhood 10 unless ``warp`` is given (the search benchmark passes the default)."""
    return DatabaseSettings(tile_size=tile_size, representations=("lie",), warp=warp)


# --------------------------------------------------------------------------------------------
# 1. Per pair
# --------------------------------------------------------------------------------------------


def per_pair(inputs: list[Path], pairs: int) -> dict:
    """Seconds per pair on one core: one ``optimal_warp`` call per pair against the batch."""
    import numba

    cache = build_srv_cache(inputs[:100], settings())
    q = np.stack(cache.q["lie"])
    rng = np.random.default_rng(3)
    pr = np.column_stack([rng.integers(0, len(q), pairs), rng.integers(0, len(q), pairs)])
    numba.set_num_threads(1)
    out = {"n_samples": q.shape[1], "D": q.shape[2], "pairs": pairs}
    with single_threaded_blas():
        for nb in (6, 10):
            optimal_warp(q[0], q[1], method="dp", neighbourhood=nb)
            dp_energies(q, q, pr[:2], neighbourhood=nb)
            best_one, best_batch = np.inf, np.inf
            for _ in range(3):
                t0 = time.perf_counter()
                e1 = np.array([optimal_warp(q[a], q[b], method="dp", neighbourhood=nb).energy for a, b in pr])
                best_one = min(best_one, time.perf_counter() - t0)
                t0 = time.perf_counter()
                e2 = dp_energies(q, q, pr, neighbourhood=nb)
                best_batch = min(best_batch, time.perf_counter() - t0)
            out[f"neighbourhood {nb}"] = {
                "ms_optimal_warp": 1e3 * best_one / pairs,
                "ms_batched": 1e3 * best_batch / pairs,
                "max_relative_difference": float(np.max(np.abs(e2 - e1) / np.maximum(e1, 1e-300))),
            }
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    return out


# --------------------------------------------------------------------------------------------
# 2. Scale and 3. quality
# --------------------------------------------------------------------------------------------


def run_matrix(src: Path, out: Path, engine: str, workers: int, **kw) -> dict:
    """``compute_matrix`` of the folder, timed end to end (the load average before and after)."""
    shutil.rmtree(out, ignore_errors=True)
    before = load("before")["load_average"]
    t0 = time.perf_counter()
    res = compute_matrix([src], out, settings(), engine=engine, n_workers=workers, **kw)
    wall = time.perf_counter() - t0
    t = res.report["timings"]
    run = res.report["runs"][-1]
    import numba

    return {
        "engine": run["engine"],
        "numba_threads": numba.get_num_threads() if run["engine"] == "serial" else 1,
        "engine_note": run.get("engine_note"),
        "workers": run["workers"],
        "complete": res.complete,
        "motions": len(res.names),
        "pairs": t["pairs_computed"],
        "seconds_total": round(wall, 2),
        "seconds_read_and_srv": t["read_seconds"],
        "read_where": run.get("read_where"),
        "seconds_pairs": t["tiles_seconds"],
        "seconds_other": round(wall - t["read_seconds"] - t["tiles_seconds"], 2),
        "load_average_before_after": [before, load("after")["load_average"]],
    }


def run_fresh(
    src: Path,
    out: Path,
    engine: str,
    workers: int,
    numba_threads: int | None = None,
    helpers: list[subprocess.Popen] = (),
    **kw,
) -> dict:
    """:func:`run_matrix` in a new Python process (as a command-line run: nothing loaded or
    started before it; ``numba_threads``: ``numba.set_num_threads`` first). Also the CPU
    seconds of the machine during the run, of the run (with ``helpers``: the separately started
    scheduler and workers) and of the rest (``cpu_seconds_others``: other jobs)."""
    code = (
        "import json, sys\n"
        f"sys.path.insert(0, {str(Path(__file__).resolve().parent)!r})\n"
        "from pathlib import Path\n"
        "import numba\n"
        "from database_scale import run_matrix\n"
        f"if {numba_threads!r}:\n"
        f"    numba.set_num_threads({numba_threads!r})\n"
        f"r = run_matrix(Path({str(src)!r}), Path({str(out)!r}), {engine!r}, {workers!r}, **{kw!r})\n"
        "if r['engine'] == 'local':\n"
        "    from elastic_motion.apps.database.engines import local_start_method\n"
        "    r['worker_start'] = local_start_method()\n"
        "print('RESULT ' + json.dumps(r))\n"
    )
    cpu0 = _cpu_seconds(helpers)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    cpu1 = _cpu_seconds(helpers)
    lines = [x for x in proc.stdout.splitlines() if x.startswith("RESULT ")]
    if proc.returncode or not lines:
        raise RuntimeError(f"{engine} run failed:\n{proc.stderr[-3000:]}")
    r = json.loads(lines[-1][len("RESULT ") :])
    r["cpu_seconds_machine"] = round(cpu1[0] - cpu0[0], 2)
    r["cpu_seconds_ours"] = round(cpu1[1] - cpu0[1], 2)
    # CPU the machine spent on other work during the run (other jobs): the noise of its timings
    r["cpu_seconds_others"] = round(r["cpu_seconds_machine"] - r["cpu_seconds_ours"], 2)
    return r


def _cpu_seconds(helpers: list[subprocess.Popen]) -> tuple[float, float]:
    """(CPU seconds of the whole machine, of this process, its finished children and ``helpers``)."""
    import resource

    import psutil

    t = psutil.cpu_times()
    machine = (
        sum(t) - t.idle - getattr(t, "iowait", 0.0) - getattr(t, "guest", 0.0) - getattr(t, "guest_nice", 0.0)
    )
    own = sum(resource.getrusage(w).ru_utime + resource.getrusage(w).ru_stime
              for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))  # fmt: skip
    for h in helpers:  # a `dask worker` is a nanny process and its worker process
        with contextlib.suppress(psutil.Error):
            top = psutil.Process(h.pid)
            for q in [top, *top.children(recursive=True)]:
                with contextlib.suppress(psutil.Error):
                    c = q.cpu_times()
                    own += c.user + c.system
    return machine, own


def quality(out: Path, sample: int) -> dict:
    """Matrix energies against the exact DP, one ``optimal_warp`` call per sampled pair."""
    cache = SRVCache.load(out / "srv_cache.npz")
    d = np.load(out / "distances_lie.npy")
    q = cache.q["lie"]
    m = len(q)
    rng = np.random.default_rng(7)
    i = rng.integers(0, m, 3 * sample)
    j = rng.integers(0, m, 3 * sample)
    keep = i != j
    i, j = np.minimum(i, j)[keep][:sample], np.maximum(i, j)[keep][:sample]
    with single_threaded_blas():
        exact = np.array([optimal_warp(q[a], q[b], method="dp").energy for a, b in zip(i, j, strict=True)])
    got = d[i, j] ** 2
    excess = (got - exact) / np.maximum(exact, 1e-300)
    excess[(exact == 0) & (got == 0)] = 0.0
    return {
        "pairs": len(i),
        "reference": "optimal_warp(q_i, q_j, method='dp', neighbourhood=10): the exact DP, one call per pair",
        "tolerance": TOLERANCE,
        "share_over_tolerance": float(np.mean(excess > TOLERANCE)),
        "max_relative_excess": float(excess.max()),
        "max_relative_deficit": float(-excess.min()),
        "zero_energy_pairs": int(np.sum(exact == 0)),
    }


# --------------------------------------------------------------------------------------------
# 4. Dask speed-ups
# --------------------------------------------------------------------------------------------


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


#: What the separately started workers preload: the code and kernels of a database run
#: (``engines.dask_setup``), loaded when they start, as a long-running cluster's workers would be.
PRELOAD = "elastic_motion.apps.database.engines"


def start_dask(n_workers: int, config_dir: Path) -> tuple[str, list[subprocess.Popen], float]:
    """A ``dask scheduler`` and ``n_workers`` single-threaded ``dask worker`` processes on
    127.0.0.1 (subprocesses; their Dask config file written to ``config_dir``; ``--preload``
    :data:`PRELOAD`); returns the address, the processes and the start-up seconds (until the
    workers have joined, preloads done)."""
    from distributed import Client

    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1")
    # as engine "local" does (engines.DaskEngine): the workers' nannies keep glibc's malloc
    # defaults instead of Dask's MALLOC_TRIM_THRESHOLD_=65536 (20-25 % more CPU reading files)
    conf = config_dir
    conf.mkdir(parents=True, exist_ok=True)
    # and the quieter book-keeping of engine "local" (engines.QUIET_DASK)
    from elastic_motion.apps.database.engines import QUIET_DASK

    settings = {"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None, **QUIET_DASK}
    (conf / "elastic-motion.yaml").write_text(json.dumps(_nested(settings), indent=1))  # JSON is YAML
    env["DASK_CONFIG"] = str(conf)
    env.pop("MALLOC_TRIM_THRESHOLD_", None)
    port = _free_port()
    addr = f"tcp://127.0.0.1:{port}"
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "env": env}
    t0 = time.perf_counter()
    procs = [
        subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
             "--port", str(port), "--dashboard-address", ":0"],
            **quiet,
        )
    ]  # fmt: skip
    for _ in range(n_workers):
        procs.append(
            subprocess.Popen(
                [sys.executable, "-m", "distributed.cli.dask_worker", addr, "--nthreads", "1",
                 "--nworkers", "1", "--no-dashboard", "--preload", PRELOAD],
                **quiet,
            )
        )  # fmt: skip
    try:
        deadline = time.monotonic() + 120
        while True:
            try:
                with Client(addr, timeout=5) as c:
                    c.wait_for_workers(n_workers, timeout=max(1.0, deadline - time.monotonic()))
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.5)
    except BaseException:
        stop(procs)
        raise
    return addr, procs, time.perf_counter() - t0


def _nested(dotted: dict) -> dict:
    """``{"a.b.c": v}`` as ``{"a": {"b": {"c": v}}}`` (a Dask config file)."""
    out: dict = {}
    for key, value in dotted.items():
        *parents, last = key.split(".")
        node = out
        for part in parents:
            node = node.setdefault(part, {})
        node[last] = value
    return out


def stop(procs: list[subprocess.Popen]) -> None:
    for p in procs[::-1]:
        p.terminate()
    for p in procs:
        try:
            p.wait(timeout=30)
        except subprocess.TimeoutExpired:
            p.kill()


def speedup(src: Path, tmp: Path) -> dict:
    """Serial (one numba thread) against a LocalCluster and a separately started cluster."""
    try:
        import distributed  # noqa: F401
    except ImportError:
        return {"skipped": "distributed is not installed (pip install 'elastic-motion[cluster]')"}
    import numba

    rows: dict[str, dict] = {}
    # each engine in a fresh process, as `elastic-motion matrix` runs it (imports not timed; the
    # code and kernels load within the run: the serial run's and the forked workers' own)
    rows["serial, 1 thread"] = run_fresh(src, tmp / "sp_serial1", "serial", 1, numba_threads=1)
    rows[f"serial, {numba.config.NUMBA_NUM_THREADS} numba threads"] = run_fresh(
        src, tmp / "sp_serialN", "serial", 1
    )
    rows["LocalCluster, 2 workers"] = run_fresh(src, tmp / "sp_local", "local", 2, force_cluster=True)
    rows["LocalCluster, 2 workers"]["note"] = "start-up included in seconds_other"
    addr, procs, startup = start_dask(2, tmp / "dask-config")
    try:
        rows["dask scheduler + 2 dask workers (127.0.0.1)"] = run_fresh(
            src, tmp / "sp_dask", "dask", 2, helpers=procs, scheduler=addr, connect_timeout=30
        )
    finally:
        stop(procs)
    rows["dask scheduler + 2 dask workers (127.0.0.1)"]["seconds_cluster_start_not_included"] = round(
        startup, 2
    )
    rows["dask scheduler + 2 dask workers (127.0.0.1)"]["worker_preload"] = PRELOAD
    ref = np.load(tmp / "sp_serial1" / "distances_lie.npy")
    base = rows["serial, 1 thread"]
    dirs = dict(zip(rows, ["sp_serial1", "sp_serialN", "sp_local", "sp_dask"], strict=True))
    for name, r in rows.items():
        r["speedup_total"] = round(base["seconds_total"] / r["seconds_total"], 3)
        r["speedup_pairs"] = round(base["seconds_pairs"] / r["seconds_pairs"], 3)
        r["speedup_read"] = round(base["seconds_read_and_srv"] / r["seconds_read_and_srv"], 3)
        r["identical_to_serial"] = bool(
            np.load(tmp / dirs[name] / "distances_lie.npy").tobytes() == ref.tobytes()
        )
    return {"motions": base["motions"], "pairs": base["pairs"], "rows": rows}


# --------------------------------------------------------------------------------------------
# 5. Small input
# --------------------------------------------------------------------------------------------


def small(src: Path, tmp: Path, m: int) -> dict:
    """``--engine local`` on ``m`` windows against serial (the cluster is started only when worth
    it), each in a new process."""
    part = tmp / "small_inputs"
    part.mkdir(exist_ok=True)
    for f in sorted(src.glob("*.bvh"))[:m]:
        shutil.copy(f, part / f.name)
    out = {"serial": run_fresh(part, tmp / "small_serial", "serial", 1)}  # each in a new process
    try:
        import distributed  # noqa: F401
    except ImportError:
        out["local"] = {"skipped": "distributed is not installed"}
        return out
    out["local"] = run_fresh(part, tmp / "small_local", "local", 2)
    # what the cluster would have cost (for the threshold of tiles.cluster_worth_it)
    out["local_forced"] = run_fresh(part, tmp / "small_forced", "local", 2, force_cluster=True)
    return out


# --------------------------------------------------------------------------------------------
# Report
# --------------------------------------------------------------------------------------------


def markdown(r: dict) -> str:
    """The tables of a result (the sections it holds, in order), as Markdown."""
    sections = (
        ("per_pair", _markdown_per_pair),
        ("scale", _markdown_scale),
        ("quality", _markdown_quality),
        ("speedup", _markdown_speedup),
        ("small", _markdown_small),
    )
    lines = []
    for key, table in sections:
        if key in r:
            lines += table(r)
    meta = r.get("meta", {})
    if meta:
        lines += ["", "Load average (1, 5, 15 min) after each section: "]
        lines += [
            f"- {k}: {v['after']['load_average']} ({v['seconds']:.0f} s, {v['date']})"
            for k, v in meta.items()
            if isinstance(v, dict) and "after" in v
        ]
    return "\n".join(lines)


def _markdown_per_pair(r: dict) -> list[str]:
    p = r["per_pair"]
    lines = [
        f"### Seconds per pair, one core (N = {p['n_samples']}, D = {p['D']}, {p['pairs']} pairs)",
        "",
        "| DP neighbourhood | optimal_warp, ms | batched, ms | speed-up | max relative difference |",
        "|---|---|---|---|---|",
    ]
    for nb in (6, 10):
        x = p[f"neighbourhood {nb}"]
        lines.append(
            f"| {nb} | {x['ms_optimal_warp']:.3f} | {x['ms_batched']:.3f} | "
            f"{x['ms_optimal_warp'] / x['ms_batched']:.2f}x | {x['max_relative_difference']:.1e} |"
        )
    return lines


def _markdown_scale(r: dict) -> list[str]:
    runs = r["scale"]
    lines = [
        "",
        f"### All pairs of {next(iter(runs.values()))['motions']} motions x {FRAMES} frames (measured "
        "end to end; Lie, N = 64, exact DP neighbourhood 10, tiles of 32)",
        "",
        "| engine | read + SRV s | pairs s | other s | total s | pairs | load average | 10 min |",
        "|---|---|---|---|---|---|---|---|",
    ]

    def who(s: dict) -> str:
        if s["engine"] == "serial":
            return f"{s.get('numba_threads', '?')} numba threads"
        return f"{s['workers']} workers"

    for s in runs.values():
        lines.append(
            f"| {s['engine']} ({who(s)}) | {s['seconds_read_and_srv']:.1f} | "
            f"{s['seconds_pairs']:.1f} | {s['seconds_other']:.1f} | **{s['seconds_total']:.1f}** "
            f"({s['seconds_total'] / 60:.1f} min) | {s['pairs']} | {s.get('load_average')} | "
            f"{'met' if s['seconds_total'] <= 600 and s['complete'] else 'NOT met'} |"
        )
        if s.get("engine_note"):
            lines.append(f"\n{s['engine_note']}")
    return lines


def _markdown_quality(r: dict) -> list[str]:
    q = r["quality"]
    lines = [
        "",
        f"### Energy of the matrix above the exact DP ({q['pairs']} sampled pairs; reference: "
        f"{q['reference']})",
        "",
        "| pairs > 0.1 % above | max excess | max deficit | zero-energy pairs |",
        "|---|---|---|---|",
        f"| {100 * q['share_over_tolerance']:.2f} % | {q['max_relative_excess']:.1e} | "
        f"{q['max_relative_deficit']:.1e} | {q['zero_energy_pairs']} |",
    ]
    if "engines_bit_identical" in q:
        lines.append(f"\nMatrices of the engines equal bit for bit: {q['engines_bit_identical']}.")
    return lines


def _markdown_speedup(r: dict) -> list[str]:
    sp = r["speedup"]
    if "skipped" in sp:
        return ["", f"Dask speed-ups skipped: {sp['skipped']}"]
    lines = [
        "",
        f"### Dask speed-ups ({sp['motions']} motions, {sp['pairs']} pairs, against serial on one thread)",
        "",
        "| run | engine | total s | read + SRV s | read on | pairs s | speed-up total | "
        "speed-up read | speed-up pairs | identical | load before -> after (others' CPU) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for k, run in enumerate(r.get("speedup_runs") or [sp]):
        for name, x in run["rows"].items():
            la = x.get("load_average_before_after")
            la = f"{la[0][0]:.2f} -> {la[1][0]:.2f}" if la else "?"
            if "cpu_seconds_others" in x:
                la += f" ({x['cpu_seconds_others']:.1f} s)"
            lines.append(
                f"| {k + 1} | {name} | {x['seconds_total']:.1f} | {x['seconds_read_and_srv']:.1f} | "
                f"{x.get('read_where', '?')} | {x['seconds_pairs']:.1f} | {x['speedup_total']:.2f} | "
                f"{x.get('speedup_read', float('nan')):.2f} | {x['speedup_pairs']:.2f} | "
                f"{x['identical_to_serial']} | {la} |"
            )
    d = sp["rows"].get("dask scheduler + 2 dask workers (127.0.0.1)", {})
    if "seconds_cluster_start_not_included" in d:
        lines.append(
            f"\n(the separately started scheduler and workers took "
            f"{d['seconds_cluster_start_not_included']:.1f} s to start, not included)"
        )
    return lines


def _markdown_small(r: dict) -> list[str]:
    sm = r["small"]
    loc = sm["local"]
    lines = [
        "",
        f"### Small input ({sm['serial']['motions']} motions): serial "
        f"{sm['serial']['seconds_total']:.1f} s, "
        + (
            f"--engine local {loc['seconds_total']:.1f} s (ran as: {loc['engine']}; {loc.get('engine_note')})"
            if "skipped" not in loc
            else f"--engine local skipped: {loc['skipped']}"
        ),
    ]
    if "local_forced" in sm:
        lines.append(f"(a local cluster started anyway: {sm['local_forced']['seconds_total']:.1f} s)")
    return lines


def _arguments() -> argparse.Namespace:
    """The command line of this script."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--mocap",
        type=Path,
        default=Path(os.environ.get("ELASTIC_MOTION_MOCAP", REPO.parent / "shared" / "mocap")),
    )
    parser.add_argument("--sections", default="per_pair,scale,quality,speedup,small")
    parser.add_argument("--motions", type=int, default=1000, help="motions of the scale run (default 1000)")
    parser.add_argument(
        "--engine",
        default="serial,local",
        help="engines of the scale run, comma-separated (default serial,local: both, one after the other)",
    )
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--speedup-motions", type=int, default=400)
    parser.add_argument(
        "--repeat", type=int, default=1, help="runs of the speedup section (all kept in speedup_runs)"
    )
    parser.add_argument("--sample", type=int, default=300, help="pairs of the quality check")
    parser.add_argument("--inputs", type=Path, default=None, help="keep the generated windows here (reused)")
    parser.add_argument("--quick", action="store_true", help="small sizes (a smoke test of the script)")
    parser.add_argument("--out", type=Path, default=RESULTS / "database_scale.json")
    parser.add_argument("--markdown", action="store_true", help="only print the tables of the existing JSON")
    return parser.parse_args()


def _run_section(
    section: str,
    result: dict,
    args: argparse.Namespace,
    src: Path,
    inputs: list[Path],
    sub: Path,
    tmp: Path,
    engines: list[str],
) -> None:
    """Run one section into ``result`` (``src``: the windows, ``inputs`` their files, ``sub`` the
    speed-up's subset, ``tmp`` the scratch folder)."""
    if section == "per_pair":
        result["per_pair"] = per_pair(inputs, pairs=200 if args.quick else 1000)
    elif section == "scale":
        result["scale"] = {}
        for engine in engines:
            before_run = load("before")
            out = tmp / f"scale_{engine}"
            result["scale"][engine] = run_matrix(src, out, engine, args.workers)
            result["scale"][engine]["load_average"] = [
                before_run["load_average"],
                load("after")["load_average"],
            ]
            print(f"  {engine}: {result['scale'][engine]['seconds_total']:.1f} s", flush=True)
    elif section == "quality":
        outs = [tmp / f"scale_{e}" for e in engines if (tmp / f"scale_{e}" / "distances_lie.npy").exists()]
        if not outs:
            raise SystemExit("--sections: 'quality' checks the matrix of 'scale'; run them together")
        result["quality"] = quality(outs[0], args.sample)
        ref = np.load(outs[0] / "distances_lie.npy").tobytes()
        result["quality"]["engines_bit_identical"] = all(
            np.load(o / "distances_lie.npy").tobytes() == ref for o in outs
        )
    elif section == "speedup":
        result["speedup_runs"] = []
        for k in range(max(1, args.repeat)):
            result["speedup"] = speedup(sub, tmp)
            result["speedup"]["date"] = time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime())
            result["speedup_runs"].append(result["speedup"])
            if len(result["speedup_runs"]) > 1:
                print(f"  run {k + 1}:\n" + markdown({"speedup": result["speedup"]}), flush=True)
    elif section == "small":
        result["small"] = small(src, tmp, 40)


def main() -> None:
    args = _arguments()
    if args.markdown:
        print(markdown(json.loads(args.out.read_text())))
        return
    if args.quick:
        args.motions, args.speedup_motions, args.sample = 120, 80, 40
    sections = [s.strip() for s in args.sections.split(",") if s.strip()]
    known = {"per_pair", "scale", "quality", "speedup", "small"}
    if set(sections) - known:
        raise SystemExit(f"--sections: expected some of {sorted(known)}; got {sorted(set(sections) - known)}")
    # a subset of the sections updates the existing JSON; all of them start it afresh
    keep = args.out.exists() and not args.quick and set(sections) != known
    result = json.loads(args.out.read_text()) if keep else {}
    result["machine"] = machine_info()
    result.setdefault("meta", {})
    tmp = Path(tempfile.mkdtemp(prefix="em-db-scale-"))
    src = args.inputs or tmp / "windows"
    existing = sorted(src.glob("w*.bvh")) if src.exists() else []
    if len(existing) != args.motions:
        shutil.rmtree(src, ignore_errors=True)
        secs = write_windows(args.mocap / "cmu" / "bvh", src, args.motions)
        print(f"wrote {args.motions} windows of {FRAMES} frames to {src} in {secs:.0f} s", flush=True)
    inputs = sorted(src.glob("w*.bvh"))
    sub = tmp / "speedup_inputs"
    sub.mkdir()
    for f in inputs[: args.speedup_motions]:
        shutil.copy(f, sub / f.name)
    engines = [e.strip() for e in args.engine.split(",") if e.strip()]
    if not engines or set(engines) - {"serial", "local"}:
        raise SystemExit(
            f"--engine: expected 'serial', 'local' or both (comma-separated); got {args.engine!r}"
        )
    try:
        for section in sections:
            print(f"[{time.strftime('%H:%M:%S')}] {section} ...", flush=True)
            before = load("before")
            t0 = time.perf_counter()
            _run_section(section, result, args, src, inputs, sub, tmp, engines)
            result["meta"][section] = {
                "seconds": round(time.perf_counter() - t0, 1),
                "before": before,
                "after": load("after"),
                "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
                "quick": args.quick,
            }
            if not args.quick:
                write_json(args.out, result)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(markdown(result))
    if not args.quick:
        print(f"\nwritten {args.out}")


if __name__ == "__main__":
    main()
