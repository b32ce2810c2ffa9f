"""Long-run fuzzing of the motion readers (issue 14): N mutated files, time and memory per case.

    python benchmarks/fuzz_readers.py --cases 100000 [--workers 2] [--seed 1]

Seeds, mutation strategies and the contract are those of ``tests/fuzz/mutations.py`` (the
pytest module runs a few hundred of the same cases): a reader returns a finite Motion or
raises ``ParseError``. Each worker process runs its share of the cases and measures each one's
peak memory as the growth of the peak resident set size (Linux: ``VmHWM``, reset before every
case through ``/proc/self/clear_refs``; elsewhere ``tracemalloc``, which slows the cases) and
its time as CPU time (wall time is recorded too: on a shared machine it includes waiting), and
an alarm after 30 s is a hang guard (a case that trips it counts as an escape). Prints a
markdown table (cases per outcome and strategy, slowest and largest cases, every escape) and writes
``benchmarks/results/fuzz_readers.json``.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import signal
import sys
import tempfile
import time
import tracemalloc
from collections import Counter
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "tests" / "fuzz"))

from mutations import load_seeds, mutate, run_case  # noqa: E402

from _common import RESULTS, machine_info, write_json  # noqa: E402

MOCAP = Path(os.environ.get("ELASTIC_MOTION_MOCAP", HERE.parents[1] / "shared" / "mocap"))
TIME_BUDGET_S = 2.0
MEMORY_BUDGET_MB = 500.0
HANG_GUARD_S = 30


def _status_kb(field: str) -> int:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(field + ":"):
                return int(line.split()[1])
    raise OSError(f"no {field} in /proc/self/status")


def _can_reset_peak() -> bool:
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
        _status_kb("VmHWM")
        return True
    except OSError:
        return False


class _CaseTimeout(Exception):
    """A case ran past the hang guard (an escape)."""


def _alarm(signum, frame):
    raise _CaseTimeout(f"case ran longer than {HANG_GUARD_S} s")


def _worker(args: tuple[int, int, int, int]) -> dict:
    worker, n_workers, n_cases, seed = args
    seeds = load_seeds(MOCAP if MOCAP.is_dir() else None)
    # warm up (numba caches, imports) before limits and measurements
    with tempfile.TemporaryDirectory(prefix="em-fuzz-") as tmp:
        for s in seeds:
            run_case(Path(tmp), s, s.data, "warm")
        if hasattr(signal, "SIGALRM"):
            signal.signal(signal.SIGALRM, _alarm)
        rng = np.random.default_rng([seed, worker])
        outcomes: Counter = Counter()
        by_strategy: Counter = Counter()
        escapes, slowest, largest = [], [], []
        rss = _can_reset_peak()
        if not rss:
            tracemalloc.start()
        for k in range(worker, n_cases, n_workers):
            s = seeds[k % len(seeds)]
            data, used = mutate(s.data, rng)
            if rss:
                with open("/proc/self/clear_refs", "w") as fh:
                    fh.write("5")  # peak RSS := current RSS
                base_kb = _status_kb("VmRSS")
            else:
                tracemalloc.reset_peak()
            t0 = time.perf_counter()
            c0 = time.process_time()
            if hasattr(signal, "SIGALRM"):
                signal.alarm(HANG_GUARD_S)
            try:
                out = run_case(Path(tmp), s, data, f"w{worker}")
            finally:
                if hasattr(signal, "SIGALRM"):
                    signal.alarm(0)
            dt = time.perf_counter() - t0
            cpu = time.process_time() - c0
            if rss:
                peak_mb = (_status_kb("VmHWM") - base_kb) * 1024 / 1e6
            else:
                peak_mb = tracemalloc.get_traced_memory()[1] / 1e6
            outcomes[out.status] += 1
            for u in used:
                by_strategy[(u, out.status)] += 1
            case = {
                "case": k,
                "seed": s.name,
                "strategies": used,
                "seconds": round(dt, 4),
                "cpu_seconds": round(cpu, 4),
                "peak_mb": round(peak_mb, 2),
            }
            if out.status == "escaped":
                escapes.append({**case, "error": out.detail})
            slowest = sorted([*slowest, case], key=lambda c: -c["cpu_seconds"])[:5]
            largest = sorted([*largest, case], key=lambda c: -c["peak_mb"])[:5]
        if not rss:
            tracemalloc.stop()
    return {
        "outcomes": dict(outcomes),
        "by_strategy": {f"{a}:{b}": n for (a, b), n in by_strategy.items()},
        "escapes": escapes,
        "slowest": slowest,
        "largest": largest,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=100_000, help="number of mutated files (default: 100000)")
    ap.add_argument("--workers", type=int, default=2, help="worker processes (default: 2)")
    ap.add_argument("--seed", type=int, default=1, help="random seed (default: 1)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    jobs = [(w, args.workers, args.cases, args.seed) for w in range(args.workers)]
    with mp.get_context("spawn").Pool(args.workers) as pool:
        parts = pool.map(_worker, jobs)
    wall = time.perf_counter() - t0
    outcomes: Counter = Counter()
    strat: Counter = Counter()
    escapes, slowest, largest = [], [], []
    for p in parts:
        outcomes.update(p["outcomes"])
        strat.update(p["by_strategy"])
        escapes += p["escapes"]
        slowest = sorted([*slowest, *p["slowest"]], key=lambda c: -c["cpu_seconds"])[:5]
        largest = sorted([*largest, *p["largest"]], key=lambda c: -c["peak_mb"])[:5]
    over_time = [c for c in slowest if c["cpu_seconds"] > TIME_BUDGET_S]
    over_mem = [c for c in largest if c["peak_mb"] > MEMORY_BUDGET_MB]
    print(f"# Reader fuzzing: {args.cases} cases, seed {args.seed}, {args.workers} workers, {wall:.0f} s\n")
    print("| outcome | cases |\n|---|---|")
    for k in ("ok", "parse_error", "escaped"):
        print(f"| {k} | {outcomes.get(k, 0)} |")
    print("\n| strategy | ok | parse_error | escaped |\n|---|---|---|---|")
    for name in sorted({k.split(":")[0] for k in strat}):
        ok, pe, esc = (strat.get(f"{name}:{k}", 0) for k in ("ok", "parse_error", "escaped"))
        print(f"| {name} | {ok} | {pe} | {esc} |")
    print(
        f"\nslowest case: {slowest[0]['cpu_seconds'] if slowest else 0:.3f} s of CPU "
        f"({slowest[0]['seconds'] if slowest else 0:.3f} s wall; budget {TIME_BUDGET_S} s); "
        f"largest peak: {largest[0]['peak_mb'] if largest else 0:.1f} MB (budget {MEMORY_BUDGET_MB:g} MB)"
    )
    for e in escapes[:20]:
        print(f"ESCAPED case {e['case']} ({e['seed']}, {'+'.join(e['strategies'])}): {e['error']}")
    RESULTS.mkdir(exist_ok=True)
    write_json(
        RESULTS / "fuzz_readers.json",
        {
            "machine": machine_info(),
            "cases": args.cases,
            "seed": args.seed,
            "workers": args.workers,
            "wall_seconds": round(wall, 1),
            "outcomes": dict(outcomes),
            "by_strategy": dict(strat),
            "escapes": escapes,
            "slowest": slowest,
            "largest": largest,
            "time_budget_s": TIME_BUDGET_S,
            "memory_budget_mb": MEMORY_BUDGET_MB,
            "within_budget": not escapes and not over_time and not over_mem,
        },
    )
    return 0 if not escapes and not over_time and not over_mem else 1


if __name__ == "__main__":
    sys.exit(main())
