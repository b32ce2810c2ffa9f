"""Benchmark of the command line's start-up (issue 34): what a user waits for, end to end.

Rows, each a fresh process timed from its start to its exit (wall clock, ``subprocess.run``):

* **bare python**: ``python -c "import numpy, scipy.linalg, numba"``, the anchor: what any
  run of the package pays before it does anything;
* **--help**: ``elastic-motion --help``;
* **info**: ``elastic-motion info A.bvh``;
* **blend**: ``elastic-motion blend A.bvh B.bvh -o out.bvh`` of two CMU walks (07_01, 08_02:
  read, warp, blend, clean-up, metrics, write), the command line's defaults;
* **blend --no-metrics**: the same without the quality metrics.

The command line runs as its console script does (``from elastic_motion.cli import main``)
with the code of this tree (``--against REV`` adds the same rows on that revision's ``src/``,
``git archive`` into a temporary folder). **Warm** runs: one run of each row first, so that
the numba kernels are in their cache and the modules' bytecode is written (the benchmark
drops ``PYTHONDONTWRITEBYTECODE`` for its runs: an installed package has its ``.pyc``
files); then ``--repeat`` rounds, every row once per round, interleaved (a busy moment of a
shared machine hits all rows alike), and each row's **median**. The ratio is each row's
median over the bare Python's median, of the same run; the CPU columns give the same for the
processes' CPU time (user + system, ``getrusage`` of the children), which a busy machine
inflates less than the wall clock (on an idle one the two agree: a command runs on one core).
The load (``os.getloadavg``, as
``uptime`` prints it) before and after is printed and recorded: the ratios are meaningful on
a busy machine, the seconds only on an idle one.

Targets (issue 34): the warm blend under 0.6 s on an idle machine and at most 2x the bare
Python of the same run.

Usage: ``python benchmarks/cli_startup.py [--repeat N] [--against REV|none] [--out PATH]``
Real data from ``$ELASTIC_MOTION_MOCAP`` or ``../shared/mocap``.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import MOCAP, REPO, RESULTS, baseline_src, machine_info, write_json

#: Two CMU walks (the issue's pair).
PAIR = ("cmu/bvh/07_01.bvh", "cmu/bvh/08_02.bvh")
#: The console script's code (``pip install`` writes this into ``bin/elastic-motion``).
CONSOLE = "import sys; from elastic_motion.cli import main; sys.exit(main())"
BARE = "import numpy, scipy.linalg, numba"
#: The revision issue 34 was measured on (before its start-up work).
AGAINST = "2aaa80a"
#: Targets (issue 34).
TARGET_SECONDS = 0.6
TARGET_RATIO = 2.0


def rows_for(out_dir: Path) -> dict[str, list[str]]:
    """Row name -> arguments of ``python`` (the bare anchor) or of the command line."""
    a, b = (str(MOCAP / p) for p in PAIR)
    blend = ["blend", a, b, "-o", str(out_dir / "blend.bvh"), "--quiet"]
    return {
        "bare python": ["-c", BARE],
        "--help": ["-c", CONSOLE, "--help"],
        "info": ["-c", CONSOLE, "info", a],
        "blend": ["-c", CONSOLE, *blend],
        "blend --no-metrics": ["-c", CONSOLE, *blend, "--no-metrics"],
    }


def _children_cpu() -> float:
    use = resource.getrusage(resource.RUSAGE_CHILDREN)
    return use.ru_utime + use.ru_stime


def run_once(args: list[str], src: Path) -> tuple[float, float]:
    """Wall time and CPU time (user + system) of one ``python ARGS`` with ``src`` on
    ``sys.path``; raises if it fails."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPATH"] = str(src)
    cpu = _children_cpu()
    t = time.perf_counter()
    proc = subprocess.run([sys.executable, *args], env=env, capture_output=True, text=True, check=False)
    seconds = time.perf_counter() - t
    cpu = _children_cpu() - cpu
    if proc.returncode != 0:
        tail = (proc.stderr.strip().splitlines() or ["no message"])[-1]
        raise RuntimeError(f"{' '.join(args[2:4])}: exit code {proc.returncode}: {tail}")
    return seconds, cpu


def measure(codes: dict[str, Path], rows: dict[str, list[str]], repeat: int) -> list[dict]:
    """Warm-up, then ``repeat`` interleaved rounds; one record per (code, row)."""
    cells = [(code, name) for code in codes for name in rows if code == "this" or name != "bare python"]
    for code, name in cells:  # warm: numba cache, bytecode
        run_once(rows[name], codes[code])
    times: dict[tuple[str, str], list[float]] = {cell: [] for cell in cells}
    cpus: dict[tuple[str, str], list[float]] = {cell: [] for cell in cells}
    for _ in range(repeat):
        for code, name in cells:
            wall, cpu = run_once(rows[name], codes[code])
            times[code, name].append(wall)
            cpus[code, name].append(cpu)
    bare = statistics.median(times["this", "bare python"])
    bare_cpu = statistics.median(cpus["this", "bare python"])
    return [
        {
            "code": code,
            "row": name,
            "median_s": statistics.median(times[code, name]),
            "min_s": min(times[code, name]),
            "max_s": max(times[code, name]),
            "ratio_to_bare": statistics.median(times[code, name]) / bare,
            "cpu_median_s": statistics.median(cpus[code, name]),
            "cpu_ratio_to_bare": statistics.median(cpus[code, name]) / bare_cpu,
            "times_s": times[code, name],
            "cpu_s": cpus[code, name],
        }
        for code, name in cells
    ]


def targets(records: list[dict]) -> dict:
    """Issue 34's start-up targets on this tree's blend."""
    blend = next(r for r in records if r["code"] == "this" and r["row"] == "blend")
    return {
        "blend_s": blend["median_s"],
        "blend_ratio_to_bare": blend["ratio_to_bare"],
        "under_0.6_s": blend["median_s"] < TARGET_SECONDS,
        "at_most_2x_bare": blend["ratio_to_bare"] <= TARGET_RATIO,
    }


def load() -> str:
    return "load average: " + ", ".join(f"{x:.2f}" for x in os.getloadavg())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=7, help="interleaved rounds after the warm-up")
    ap.add_argument("--against", default=AGAINST, help="git revision to compare with, or 'none'")
    ap.add_argument("--out", default=str(RESULTS / "cli_startup.json"))
    args = ap.parse_args()
    missing = [p for p in PAIR if not (MOCAP / p).exists()]
    if missing:
        sys.exit(f"cli_startup: expected the CMU walks {missing} under {MOCAP}; got none")
    load_before = os.getloadavg()
    print(f"before: {load()}")
    with tempfile.TemporaryDirectory() as tmp:
        codes = {"this": REPO / "src"}
        if args.against != "none":
            codes[args.against] = baseline_src(args.against, Path(tmp) / "baseline")
        records = measure(codes, rows_for(Path(tmp)), args.repeat)
    load_after = os.getloadavg()
    print(f"after:  {load()}")
    print(f"\nwarm runs, median of {args.repeat} interleaved rounds (wall clock, s)\n")
    print("| code | row | median s | min s | max s | x bare python | CPU s | CPU x bare |")
    print("|---|---|---|---|---|---|---|---|")
    for r in records:
        print(
            f"| {r['code']} | {r['row']} | {r['median_s']:.3f} | {r['min_s']:.3f} | {r['max_s']:.3f} "
            f"| {r['ratio_to_bare']:.2f} | {r['cpu_median_s']:.3f} | {r['cpu_ratio_to_bare']:.2f} |"
        )
    goal = targets(records)
    print(f"\nissue 34 targets (blend under {TARGET_SECONDS} s idle, at most {TARGET_RATIO}x bare): {goal}")
    write_json(
        args.out,
        {
            "machine": machine_info(),
            "load_average_before": load_before,
            "load_average_after": load_after,
            "repeat": args.repeat,
            "against": args.against,
            "pair": PAIR,
            "records": records,
            "targets": goal,
        },
    )
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
