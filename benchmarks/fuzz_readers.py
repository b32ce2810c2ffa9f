"""Long-run fuzzing of the motion readers (issues 14, 32): both generators, time and memory per case.

    python benchmarks/fuzz_readers.py --cases 100000 [--workers 2] [--seed 1] [--generators mutation,grammar]

Two generators share the cases (alternately): the **mutation** one (``tests/fuzz/mutations.py``:
seed files, real clips when ``../shared/mocap`` is there, with their bytes changed) and the
**grammar** one (``tests/fuzz/grammar.py``: BVH, ASF/AMC and DeepMimic files generated valid
by construction or with one grammar rule broken). The contract is ``tests/fuzz/contract.py``'s
(the pytest modules run a few thousand of the same cases): a reader returns a finite Motion
or raises ``ParseError``; every accepted file is written back with ``write_bvh`` and read
back as the same motion; a grammar-valid file is accepted and a grammar-invalid one refused.

Each worker process runs its share of the cases and measures each one (reading, writing back,
reading back) for its peak memory, the growth of the peak resident set size (Linux:
``VmHWM``, reset before every case through ``/proc/self/clear_refs``; elsewhere not measured)
and its CPU time (wall time is recorded too: on a shared machine it includes waiting); an
alarm after 30 s is a hang guard (a case that trips it is an escape). Prints a markdown table
per generator and format (cases, ok, parse errors, escapes, write-backs failed, valid files refused,
invalid ones accepted, cases that raised a warning, slowest case, largest peak) with examples
of each failure, and writes ``benchmarks/results/fuzz_readers.json``.
Targets (issue 32): 0 escapes, every accepted file written back equal, slowest case under
1 s of CPU, peak under 300 MB.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import signal
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "tests" / "fuzz"))

import contract  # noqa: E402
import grammar  # noqa: E402
from mutations import load_seeds, mutate  # noqa: E402

from _common import MOCAP, RESULTS, machine_info, write_json  # noqa: E402

TIME_BUDGET_S = 1.0
MEMORY_BUDGET_MB = 300.0
HANG_GUARD_S = 30
GENERATORS = ("mutation", "grammar")
_FORMAT_OF = {".bvh": "bvh", ".amc": "asfamc", ".asf": "asf", ".txt": "deepmimic"}


class _CaseTimeout(BaseException):
    """A case ran past the hang guard (an escape); not an Exception, so no reader catches it."""


def _alarm(signum, frame):
    raise _CaseTimeout(f"case ran longer than {HANG_GUARD_S} s")


class _Cases:
    """The cases of one worker: case ``k`` comes from generator ``k % len(generators)``; the
    mutation generator cycles through the seed files, the grammar one through the formats."""

    def __init__(self, worker: int, seed: int, generators: tuple[str, ...]) -> None:
        self.generators = generators
        self.seeds = load_seeds(MOCAP if MOCAP.is_dir() else None)
        self.rng = {g: np.random.default_rng([seed, worker, i]) for i, g in enumerate(GENERATORS)}
        self.formats = list(grammar.GENERATORS)

    def case(self, k: int) -> tuple[str, str, dict, tuple[str, bytes, bytes | None, str]]:
        """``(generator, format, description, (name, data, asf, expect))`` of case ``k``."""
        gen = self.generators[k % len(self.generators)]
        i = k // len(self.generators)
        if gen == "mutation":
            s = self.seeds[i % len(self.seeds)]
            data, used = mutate(s.data, self.rng[gen])
            fmt = _FORMAT_OF.get(Path(s.name).suffix.lower(), "deepmimic")
            return gen, fmt, {"seed": s.name, "rule": "+".join(used)}, (s.name, data, s.asf, "any")
        fmt = self.formats[i % len(self.formats)]
        c = grammar.GENERATORS[fmt](self.rng[gen])
        return gen, fmt, {"rule": c.rule, "expect": c.expect}, (c.name, c.data, c.asf, c.expect)


def _run_one(folder: Path, k: int, case: tuple[str, bytes, bytes | None, str]) -> contract.Outcome:
    name, data, asf, _ = case
    if hasattr(signal, "SIGALRM"):
        signal.alarm(HANG_GUARD_S)
    try:
        return contract.run_checked(folder, name, data, asf, f"c{k}")
    except _CaseTimeout as exc:
        return contract.Outcome("escaped", f"hang: {exc}")
    finally:
        if hasattr(signal, "SIGALRM"):
            signal.alarm(0)


def _worker(args: tuple[int, int, int, int, tuple[str, ...]]) -> dict[str, contract.Tally]:
    worker, n_workers, n_cases, seed, generators = args
    cases = _Cases(worker, seed, generators)
    tallies: dict[str, contract.Tally] = {}
    with contract.scratch_dir() as folder:
        for s in cases.seeds:  # warm up (numba caches, imports) before measuring
            contract.run_checked(folder, s.name, s.data, s.asf, "warm")
        for fmt, gen in grammar.GENERATORS.items():
            c = gen(np.random.default_rng(0), perturb=0.0)
            contract.run_checked(folder, c.name, c.data, c.asf, f"warm_{fmt}")
        if hasattr(signal, "SIGALRM"):
            signal.signal(signal.SIGALRM, _alarm)
        rss = contract.can_measure_rss()
        for k in range(worker, n_cases, n_workers):
            gen, fmt, info, case = cases.case(k)
            out, m = contract.measured(rss, _run_one, folder, k, case)
            key = f"{gen}/{fmt}"
            tallies.setdefault(key, contract.Tally(n_examples=5))
            detail = {"case": k, **info, "detail": out.detail, "warning": out.warning, **m}
            tallies[key].add(contract.verdict(out, case[3]), detail)
    return tallies


_COLUMNS = (
    ("cases", None),
    ("ok", "ok"),
    ("parse errors", "parse_error"),
    ("escapes", "escaped"),
    ("write-back failed", "writeback_failed"),
    ("valid refused", "valid_refused"),
    ("invalid accepted", "invalid_accepted"),
)


def _table(tallies: dict[str, contract.Tally]) -> str:
    head = (
        "| generator | format | "
        + " | ".join(c for c, _ in _COLUMNS)
        + " | warned | slowest (s CPU) | peak (MB) |"
    )
    rows = [head, "|" + "---|" * (len(_COLUMNS) + 5)]
    for key in sorted(tallies):
        t = tallies[key]
        cells = [str(t.cases if v is None else t.counts.get(v, 0)) for _, v in _COLUMNS]
        slow = t.slowest["cpu_seconds"] if t.slowest else 0.0
        peak = t.largest["peak_mb"] if t.largest else 0.0
        rows.append(
            f"| {key.replace('/', ' | ')} | "
            + " | ".join(cells)
            + f" | {t.warned} | {slow:.3f} | {peak:.1f} |"
        )
    return "\n".join(rows)


def _examples(tallies: dict[str, contract.Tally]) -> list[str]:
    out = []
    for kind in (*contract.FAILURES, "warning"):
        for key in sorted(tallies):
            for e in tallies[key].examples.get(kind, [])[:3]:
                what = e["warning"] if kind == "warning" else e["detail"]
                rule = f"{e['seed']}: {e['rule']}" if "seed" in e else e["rule"]
                out.append(f"{kind.upper()} {key} case {e['case']} ({rule}): {what[:300]}")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--cases", type=int, default=100_000, help="number of files, all generators (default: 100000)"
    )
    ap.add_argument("--workers", type=int, default=2, help="worker processes (default: 2)")
    ap.add_argument("--seed", type=int, default=1, help="random seed (default: 1)")
    ap.add_argument(
        "--generators",
        default=",".join(GENERATORS),
        help=f"comma-separated, from {', '.join(GENERATORS)} (default: both)",
    )
    args = ap.parse_args(argv)
    generators = tuple(g.strip() for g in args.generators.split(",") if g.strip())
    if not generators or any(g not in GENERATORS for g in generators):
        ap.error(f"--generators: expected names from {', '.join(GENERATORS)}; got {args.generators!r}")
    t0 = time.perf_counter()
    jobs = [(w, args.workers, args.cases, args.seed, generators) for w in range(args.workers)]
    with mp.get_context("spawn").Pool(args.workers) as pool:
        parts = pool.map(_worker, jobs)
    wall = time.perf_counter() - t0
    tallies: dict[str, contract.Tally] = {}
    for part in parts:
        for key, t in part.items():
            tallies.setdefault(key, contract.Tally(n_examples=5)).merge(t)
    total = contract.Tally(n_examples=5)
    for t in tallies.values():
        total.merge(t)
    slow = total.slowest["cpu_seconds"] if total.slowest else 0.0
    peak = total.largest["peak_mb"] if total.largest else 0.0
    failures = {k: total.counts.get(k, 0) for k in contract.FAILURES}
    within = not any(failures.values()) and slow < TIME_BUDGET_S and peak < MEMORY_BUDGET_MB
    print(
        f"# Reader fuzzing: {args.cases} cases ({'+'.join(generators)}), seed {args.seed}, "
        f"{args.workers} workers, {wall:.0f} s\n"
    )
    print(_table(tallies))
    wall_slow = total.slowest["seconds"] if total.slowest else 0.0
    print(
        f"\nslowest case: {slow:.3f} s of CPU ({wall_slow:.3f} s wall; "
        f"budget {TIME_BUDGET_S} s); largest peak: {peak:.1f} MB (budget {MEMORY_BUDGET_MB:g} MB); "
        f"failures {failures}; "
        f"{'within' if within else 'NOT within'} the targets"
    )
    for line in _examples(tallies):
        print(line)
    RESULTS.mkdir(exist_ok=True)
    write_json(
        RESULTS / "fuzz_readers.json",
        {
            "machine": machine_info(),
            "cases": args.cases,
            "generators": list(generators),
            "seed": args.seed,
            "workers": args.workers,
            "wall_seconds": round(wall, 1),
            "by_generator_format": {k: _as_dict(t) for k, t in sorted(tallies.items())},
            "total": _as_dict(total),
            "time_budget_s": TIME_BUDGET_S,
            "memory_budget_mb": MEMORY_BUDGET_MB,
            "within_budget": within,
        },
    )
    return 0 if within else 1


def _as_dict(t: contract.Tally) -> dict:
    return {
        "cases": t.cases,
        "counts": dict(t.counts),
        "warned": t.warned,
        "slowest": t.slowest,
        "largest": t.largest,
        "examples": t.examples,
    }


if __name__ == "__main__":
    sys.exit(main())
