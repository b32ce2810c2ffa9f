"""Benchmark of the optimal-warp solver against fdasrsf (same run, same scoring).

Cases
-----
- ``synth3``, ``synth93``: smooth random curves in R^3 and R^93 (a sum of Fourier modes) and
  a known smooth warp ``gamma``: ``c0 = c1 o gamma``, both sampled on N+1 uniform points,
  SRV by finite differences (``q_i = v_i / sqrt|v_i|``).  The truth is ``phi = gamma``.
- ``cmu07-08``, ``cmu131``: real pairs, CMU 07_01 vs 08_02 and 131_01 vs 131_02, read with
  :mod:`elastic_motion.motion` (T-pose dropped, lengths in metres), resampled to N+1 frames
  over their duration (geodesic interpolation), as SO(3)^31 x R^3 curves
  (:func:`elastic_motion.motion.to_lie_curve`, default joint weights) and SRV arrays of
  shape (N, 96) (:func:`elastic_motion.curves.srv_transform`).  No known truth.

Methods
-------
- ``ours-dp``: :func:`elastic_motion.warp.optimal_warp` (exact DP on the N x N grid, 63 slopes).
- ``ours-dp+refine``: the same, then gradient refinement off the grid.
- ``ours-c2f``: coarse-to-fine banded DP (not exact; its energy loss against ``ours-dp``).
- ``fdasrsf-DP``, ``fdasrsf-RBFGS``: ``fdasrsf.curve_functions.optimum_reparam_curve`` with
  method ``"DP"`` and ``"RBFGS"`` (fdasrsf 2.7.3, the benchmark extra).

How the inputs are mapped (keep the comparison honest): fdasrsf takes SRVF *samples* of shape
``(D, T)`` on ``T`` uniform points.  Our ``q`` is cell-valued on ``t = linspace(0, 1, N+1)``;
fdasrsf gets ``T = N + 1`` samples ``q_fd[:, i] = q[i]`` (``q[N-1]`` repeated at the last
node), i.e. the same node grid as our DP and its left-endpoint rule for our cell values.
Its gamma (samples on the same ``t``) is normalised to ``gamma[0] = 0``, ``gamma[-1] = 1``
(RBFGS ends a hair below 1), made non-decreasing (``maximum.accumulate``: RBFGS can wiggle
by rounding), and read as the piecewise linear warp with vertices ``(t_i, gamma_i)``.
Every warp of every method is scored by the same exact function
:func:`elastic_motion.warp.warp_energy`.  Times are wall clock: ours the minimum of
``--repeat`` runs after a warm-up (numba compilation excluded and reported apart), fdasrsf
one run (it is slow) unless ``--fd-repeat``.

Issue 13 extras (``--steep``, ``--closed``; written to the same JSON under ``"steep"`` and
``"closed"``):

- ``--steep``: the default method (``dp+refine``) against the DP alone on warps whose slopes
  leave ``[1/10, 10]``: paper 001's open pair (three vs two extrema; reference: ``dp+refine``
  at N = 3200) and ``c0 = c1 o gamma`` with ``gamma(t) = t^4`` (slope 0 at 0; the distance is
  0 up to discretisation), on real motion pairs the cost of the default against ``dp``.
- ``--closed``: :func:`elastic_motion.closed_curves.match_closed` (seed, warp, closed
  descent, closed geodesic) on the hand outlines of ``examples/warp_2d.py`` at 100 / 200 /
  400 points, three rows as paper 001's Table 1, timed beside the paper's seconds.

Issue 34 (the cost of the default): every row also times ``ours-dp`` and ``ours-dp+refine``
interleaved (``--repeat`` rounds, the median; wall clock and the process's CPU time, which the
other jobs of a shared machine disturb less) and prints a second table, dp+refine against dp
(the targets: at most 3x at N = 100, at most 1.5x from N = 400) and against fdasrsf, with the
energies, the refinement's gain over the DP, and with ``--baseline OLD.json`` (this script's
JSON from an earlier version of the solver) the energy of dp+refine over the old one per
pair. The load average (``uptime``) at the start and the end is printed and written.

Usage::

    python benchmarks/warp.py --steep --closed --cases    # only the issue-13 tables
    python benchmarks/warp.py                      # full: N = 100 ... 1600, all cases
    python benchmarks/warp.py --n 100 200 --cases synth3 cmu131 --fd-max-n 200   # quick
    python benchmarks/warp.py --fd-max-n 800 --baseline old.json   # issue 34: against today

Writes ``benchmarks/results/warp.json`` and prints a markdown table.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from _common import MOCAP, write_json
from elastic_motion.warp import optimal_warp, warp_energy

ROOT = Path(__file__).resolve().parents[1]
CASES = ("synth3", "synth93", "cmu07-08", "cmu131")
REAL = {
    "cmu07-08": ("cmu/bvh/07_01.bvh", "cmu/bvh/08_02.bvh"),
    "cmu131": ("cmu/bvh/131_01.bvh", "cmu/bvh/131_02.bvh"),
}


# ----------------------------------------------------------------------------- inputs


def synthetic(n: int, d: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Smooth curve pair in R^d with a known warp: returns ``(q0, q1, gamma on t)``."""
    rng = np.random.default_rng(seed)
    modes = 5
    phases = rng.uniform(0, 2 * np.pi, (modes, d))
    amp = rng.normal(size=(modes, d)) / np.arange(1, modes + 1)[:, None]

    def curve(x: np.ndarray) -> np.ndarray:
        k = np.arange(1, modes + 1)[None, :, None]
        return np.sum(amp[None] * np.sin(np.pi * k * x[:, None, None] + phases[None]), axis=1)

    t = np.linspace(0.0, 1.0, n + 1)
    gamma = t + 0.35 * np.sin(np.pi * t) ** 2 * (t - 0.3)  # smooth, increasing, fixes 0 and 1
    return srv(curve(gamma), t), srv(curve(t), t), gamma


def srv(c: np.ndarray, t: np.ndarray) -> np.ndarray:
    v = np.diff(c, axis=0) / np.diff(t)[:, None]
    speed = np.linalg.norm(v, axis=1)
    return v / np.sqrt(np.where(speed > 0, speed, 1.0))[:, None]


def real_pair(case: str, n: int) -> tuple[np.ndarray, np.ndarray, None]:
    """Two CMU walks as SO(3)^31 x R^3 SRV arrays of shape (n, 96)."""
    from elastic_motion import motion
    from elastic_motion.curves import srv_transform

    out = []
    for rel in REAL[case]:
        mo = motion.drop_tpose(motion.read_motion(MOCAP / rel))
        mo = motion.to_metres(mo)
        times = np.asarray(mo.times)
        target = np.linspace(times[0], times[-1], n + 1)
        mo = motion.resample_at_times(mo, times, target, fps=mo.fps)
        out.append(srv_transform(motion.to_lie_curve(mo)).q)
    return out[0], out[1], None


# ----------------------------------------------------------------------------- runners


def run_ours(q0, q1, repeat: int, **kw) -> tuple[float, np.ndarray, dict]:
    best, res = np.inf, None
    for _ in range(repeat):
        t = time.perf_counter()
        res = optimal_warp(q0, q1, **kw)
        best = min(best, time.perf_counter() - t)
    d = res.diagnostics
    info = {
        "nodes_evaluated": d.nodes_evaluated,
        "levels": d.levels,
        "iterations": d.iterations,
        "time_dp": d.time_dp,
        "time_refine": d.time_refine,
    }
    return best, res.vertices, info


#: Our methods of a row, timed interleaved: name, keywords of optimal_warp.
OURS = (
    ("ours-dp", {"method": "dp"}),
    ("ours-dp+refine", {"method": "dp+refine"}),
    ("ours-c2f", {"coarse_to_fine": True, "method": "dp"}),
)


def run_ours_interleaved(q0, q1, repeat: int) -> dict[str, dict]:
    """Our methods in turn, ``repeat`` rounds (after one warm-up round): the median wall and
    CPU seconds of each, its last warp's vertices and diagnostics."""
    wall: dict[str, list[float]] = {name: [] for name, _ in OURS}
    cpu: dict[str, list[float]] = {name: [] for name, _ in OURS}
    last = {}
    for rnd in range(repeat + 1):
        for name, kw in OURS:
            t, c = time.perf_counter(), time.process_time()
            last[name] = optimal_warp(q0, q1, **kw)
            if rnd:
                wall[name].append(time.perf_counter() - t)
                cpu[name].append(time.process_time() - c)
    out = {}
    for name, _ in OURS:
        d = last[name].diagnostics
        out[name] = {
            "time": float(np.median(wall[name])),
            "cpu": float(np.median(cpu[name])),
            "time_min": min(wall[name]),
            "vertices": last[name].vertices,
            "nodes_evaluated": d.nodes_evaluated,
            "levels": d.levels,
            "iterations": d.iterations,
            "refine_stop": d.refine_stop,
            "time_dp": d.time_dp,
            "time_refine": d.time_refine,
        }
    return out


def run_fdasrsf(q0, q1, method: str, repeat: int) -> tuple[float, np.ndarray]:
    import fdasrsf.curve_functions as cf

    n = q0.shape[0]
    t = np.linspace(0.0, 1.0, n + 1)
    f0 = np.ascontiguousarray(np.vstack([q0, q0[-1:]]).T)
    f1 = np.ascontiguousarray(np.vstack([q1, q1[-1:]]).T)
    best, gam = np.inf, None
    for _ in range(repeat):
        a, b = f0.copy(), f1.copy()  # fdasrsf may modify its inputs
        tt = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            gam = cf.optimum_reparam_curve(a, b, 0.0, method)
        best = min(best, time.perf_counter() - tt)
    g = np.asarray(gam, dtype=float).ravel()
    g = (g - g[0]) / (g[-1] - g[0])
    g = np.maximum.accumulate(np.clip(g, 0.0, 1.0))
    g[0], g[-1] = 0.0, 1.0
    return best, np.column_stack([t, g])


def warp_error(vertices: np.ndarray, gamma: np.ndarray | None) -> tuple[float | None, float | None]:
    if gamma is None:
        return None, None
    t = np.linspace(0.0, 1.0, len(gamma))
    diff = np.interp(t, vertices[:, 0], vertices[:, 1]) - gamma
    return float(np.abs(diff).max()), float(np.sqrt(np.mean(diff**2)))


# ----------------------------------------------------------------------------- issue 13


def open_pair(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Paper 001's open pair as in ``examples/warp_2d.py`` before issue 13 (SRV arrays)."""
    t = np.linspace(0.0, 1.0, n + 1)
    c0 = np.column_stack([t, 0.25 * np.sin(3 * np.pi * t)])
    c1 = np.column_stack([t, 0.25 * np.sin(2 * np.pi * t) * (1 + 0.3 * t)])
    return srv(c0, t), srv(c1, t)


def power_pair(n: int) -> tuple[np.ndarray, np.ndarray]:
    """``c0 = c1 o gamma``, ``gamma(t) = t^4``: the best warp has slope 0 at 0 (distance 0)."""
    t = np.linspace(0.0, 1.0, n + 1)

    def c(x):
        return np.column_stack([np.cos(3 * x), np.sin(5 * x) + x])

    return srv(c(t**4), t), srv(c(t), t)


def steep_rows(ns: list[int], repeat: int) -> list[dict]:
    rows = []
    ref_open = optimal_warp(*open_pair(3200), method="dp+refine").distance
    for case, make, ref in (("paper001-open", open_pair, ref_open), ("power4", power_pair, 0.0)):
        for n in ns:
            q0, q1 = make(n)
            row = {"case": case, "N": n, "reference": ref}
            for method in ("dp", "dp+refine"):
                sec, verts, _ = run_ours(q0, q1, repeat, method=method)
                d = float(np.sqrt(warp_energy(q0, q1, verts)))
                row[method] = {"time": sec, "distance": d, "error": d - ref}
            rows.append(row)
            print(
                f"{case} N={n}: dp {row['dp']['distance']:.5f} ({row['dp']['time']:.3f}s), default "
                f"{row['dp+refine']['distance']:.5f} ({row['dp+refine']['time']:.3f}s), ref {ref:.5f}",
                file=sys.stderr,
                flush=True,
            )
    return rows


def steep_markdown(rows: list[dict]) -> str:
    lines = [
        "| case | N | reference | dp distance | dp error | dp s "
        "| default distance | default error | default s |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        dp, de = r["dp"], r["dp+refine"]
        lines.append(
            f"| {r['case']} | {r['N']} | {r['reference']:.5f} | {dp['distance']:.5f} | {dp['error']:+.5f} | "
            f"{dp['time']:.3f} | {de['distance']:.5f} | {de['error']:+.5f} | {de['time']:.3f} |"
        )
    return "\n".join(lines)


def closed_rows(repeat: int) -> list[dict]:
    sys.path.insert(0, str(ROOT / "examples"))
    import warp_2d as ex
    from elastic_motion.closed_curves import match_closed
    from elastic_motion.curves import srv_transform

    cases, _, _ = ex.closed_cases()
    rows = []
    for n, paper in ex.PAPER_TABLE_1.items():
        q0 = srv_transform(ex.hand(n, ex.FINGERS_A)).q
        q1 = srv_transform(ex.hand(n, ex.FINGERS_B, rot=ex.SEED_B)).q
        for (title, lm), paper_s in zip(cases, paper, strict=True):
            best, m = np.inf, None
            for _ in range(repeat):
                t = time.perf_counter()
                m = match_closed(q0, q1, landmarks=lm, lam=ex.LAM_CLOSED)
                best = min(best, time.perf_counter() - t)
            rows.append(
                {
                    "N": n,
                    "case": title,
                    "paper_s": paper_s,
                    "time": best,
                    "closed_distance": m.distance,
                    "open_distance": m.open_distance,
                    "closed_steps": m.closed_steps,
                }
            )
            print(
                f"closed N={n} {title}: {best:.2f}s (paper {paper_s} s), d = {m.distance:.4f}",
                file=sys.stderr,
            )
    return rows


def closed_markdown(rows: list[dict]) -> str:
    lines = [
        "| points | case | paper s | ours s | closed distance | open distance | closed steps |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['N']} | {r['case']} | {r['paper_s']} | {r['time']:.2f} | {r['closed_distance']:.4f} | "
            f"{r['open_distance']:.4f} | {r['closed_steps']} |"
        )
    return "\n".join(lines)


# ----------------------------------------------------------------------------- main


def _parse(argv: list[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, nargs="+", default=[100, 200, 400, 800, 1600])
    ap.add_argument("--cases", nargs="*", default=list(CASES), choices=CASES)
    ap.add_argument(
        "--fd-max-n",
        type=int,
        default=1600,
        help="skip fdasrsf DP above this N (it is O(N^2) edges of O(N D) each)",
    )
    ap.add_argument("--rbfgs-max-n", type=int, default=1600, help="skip fdasrsf RBFGS above this N")
    ap.add_argument("--no-fdasrsf", action="store_true")
    ap.add_argument("--repeat", type=int, default=5, help="interleaved rounds of our solvers (median time)")
    ap.add_argument(
        "--baseline",
        type=Path,
        default=None,
        help="JSON of an earlier run: dp+refine's energy against it, pair by pair",
    )
    ap.add_argument("--fd-repeat", type=int, default=1)
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "warp.json")
    ap.add_argument("--steep", action="store_true", help="default method vs dp on steep warps (issue 13)")
    ap.add_argument("--closed", action="store_true", help="closed matching vs paper 001 Table 1 (issue 13)")
    return ap.parse_args(argv)


def _fdasrsf_version() -> str | None:
    """fdasrsf's version, or None when it is not installed (the competitor is then skipped)."""
    try:
        import fdasrsf
    except ImportError:
        return None
    return getattr(fdasrsf, "__version__", "unknown")


def _warm_up() -> float:
    """Seconds of numba compilation (cached on disk after the first run)."""
    t = time.perf_counter()
    q0, q1, _ = synthetic(64, 3)
    for method in ("dp", "dp+refine"):
        optimal_warp(q0, q1, method=method)
    optimal_warp(q0, q1, coarse_to_fine=True)
    return time.perf_counter() - t


def _measure(case: str, n: int, args: argparse.Namespace, have_fd: bool) -> dict | None:
    """One row: our solvers and fdasrsf's on one pair of SRV functions."""
    if case.startswith("synth"):
        q0, q1, gamma = synthetic(n, int(case[5:]))
    elif not MOCAP.is_dir():
        print(f"skip {case}: {MOCAP} not found", file=sys.stderr)
        return None
    else:
        q0, q1, gamma = real_pair(case, n)
    res = run_ours_interleaved(q0, q1, args.repeat)
    if have_fd and n <= args.fd_max_n:
        sec, verts = run_fdasrsf(q0, q1, "DP", args.fd_repeat)
        res["fdasrsf-DP"] = {"time": sec, "vertices": verts}
    if have_fd and n <= args.rbfgs_max_n:
        sec, verts = run_fdasrsf(q0, q1, "RBFGS", args.fd_repeat)
        res["fdasrsf-RBFGS"] = {"time": sec, "vertices": verts}
    for r in res.values():
        verts = r.pop("vertices")
        r["energy"] = warp_energy(q0, q1, verts)
        r["err_max"], r["err_rms"] = warp_error(verts, gamma)
        r["n_vertices"] = len(verts)
    identity = warp_energy(q0, q1, [[0, 0], [1, 1]])
    return {"case": case, "N": n, "D": q0.shape[1], "identity_energy": identity, "methods": res}


def main(argv: list[str] | None = None) -> int:
    args = _parse(argv)
    fd_version = None if args.no_fdasrsf else _fdasrsf_version()
    if not args.no_fdasrsf and fd_version is None:
        print("fdasrsf not installed (pip install -e '.[benchmark]'): comparing nothing", file=sys.stderr)
    load_start = os.getloadavg()
    compile_s = _warm_up()
    extra: dict[str, list] = {}
    if args.steep:
        extra["steep"] = steep_rows(args.n, args.repeat)
    if args.closed:
        extra["closed"] = closed_rows(args.repeat)
    rows = []
    for case in args.cases:
        for n in args.n:
            row = _measure(case, n, args, fd_version is not None)
            if row is not None:
                rows.append(row)
                print(format_row(row), file=sys.stderr, flush=True)
    meta = {
        "python": platform.python_version(),
        "machine": platform.machine(),
        "processor": platform.processor(),
        "cpu_count": __import__("os").cpu_count(),
        "numba_compile_warmup_s": compile_s,
        "repeat": args.repeat,
        "fd_max_n": args.fd_max_n,
        "rbfgs_max_n": args.rbfgs_max_n,
        "load_average_start": load_start,
        "load_average_end": os.getloadavg(),
        "baseline": args.baseline,
    }
    if fd_version is not None:
        meta["fdasrsf"] = fd_version
    baseline = _baseline_energies(args.baseline)
    write_json(args.out, {"meta": meta, "rows": rows, "refine": refine_rows(rows, baseline), **extra})
    if rows:
        print(markdown(rows))
        print()
        print(refine_markdown(refine_rows(rows, baseline)))
        print(refine_summary(refine_rows(rows, baseline)))
    print(f"load average (1, 5, 15 min): start {_load(load_start)}, end {_load(meta['load_average_end'])}")
    if "steep" in extra:
        print(steep_markdown(extra["steep"]))
    if "closed" in extra:
        print(closed_markdown(extra["closed"]))
    print(f"\nnumba warm-up (compile or cache load): {compile_s:.1f} s; JSON: {args.out}")
    return 0


def format_row(row: dict) -> str:
    parts = [f"{row['case']} N={row['N']} D={row['D']}"]
    for name, r in row["methods"].items():
        parts.append(f"{name}: {r['time']:.3f}s E={r['energy']:.5g}")
    return " | ".join(parts)


def _fmt(x: float | None, spec: str = ".4g") -> str:
    return "-" if x is None else format(x, spec)


def markdown(rows: list[dict]) -> str:
    head = (
        "| case | N | D | ours DP s | ours E | fd DP s | fd DP E | speed-up | E ours/fd | "
        "ours DP+ref s | DP+ref E | RBFGS s | RBFGS E | E ref/RBFGS | c2f s | c2f loss | "
        "err DP | err DP+ref | err fd DP | err RBFGS |"
    )
    sep = "|" + "---|" * (head.count("|") - 1)
    lines = [head, sep]
    for row in rows:
        m = row["methods"]
        dp, ref, c2f = m["ours-dp"], m["ours-dp+refine"], m["ours-c2f"]
        fd, rb = m.get("fdasrsf-DP"), m.get("fdasrsf-RBFGS")
        lines.append(
            "| "
            + " | ".join(
                [
                    row["case"],
                    str(row["N"]),
                    str(row["D"]),
                    _fmt(dp["time"], ".3f"),
                    _fmt(dp["energy"]),
                    _fmt(fd and fd["time"], ".2f"),
                    _fmt(fd and fd["energy"]),
                    _fmt(fd and fd["time"] / dp["time"], ".0f") + ("x" if fd else ""),
                    _fmt(fd and dp["energy"] / fd["energy"], ".3f"),
                    _fmt(ref["time"], ".3f"),
                    _fmt(ref["energy"]),
                    _fmt(rb and rb["time"], ".2f"),
                    _fmt(rb and rb["energy"]),
                    _fmt(rb and ref["energy"] / rb["energy"], ".3f"),
                    _fmt(c2f["time"], ".3f"),
                    _fmt(100 * (c2f["energy"] / dp["energy"] - 1), ".2f") + "%",
                    _fmt(dp["err_max"], ".2e"),
                    _fmt(ref["err_max"], ".2e"),
                    _fmt(fd and fd["err_max"], ".2e"),
                    _fmt(rb and rb["err_max"], ".2e"),
                ]
            )
            + " |"
        )
    return "\n".join(lines)


# ----------------------------------------------------------------------------- issue 34

#: Targets of issue 34: dp+refine time over dp time, at most this at N (the first key <= N).
REFINE_TARGETS = {100: 3.0, 400: 1.5}


def _target(n: int) -> float | None:
    keys = [k for k in REFINE_TARGETS if k <= n]
    return REFINE_TARGETS[max(keys)] if keys else None


def _load(load: tuple[float, float, float]) -> str:
    return " ".join(f"{x:.2f}" for x in load)


def _baseline_energies(path: Path | None) -> dict[tuple[str, int], float]:
    """dp+refine's energy per (case, N) in an earlier run's JSON (empty without one)."""
    if path is None:
        return {}
    data = json.loads(path.read_text())
    return {(r["case"], r["N"]): r["methods"]["ours-dp+refine"]["energy"] for r in data["rows"]}


def refine_rows(rows: list[dict], baseline: dict[tuple[str, int], float]) -> list[dict]:
    """One row per pair: dp+refine against dp (time ratios wall and CPU, energies, gain),
    against fdasrsf (time, energy) and against the baseline's energy."""
    out = []
    for row in rows:
        m = row["methods"]
        dp, ref = m["ours-dp"], m["ours-dp+refine"]
        fd, rb = m.get("fdasrsf-DP"), m.get("fdasrsf-RBFGS")
        old = baseline.get((row["case"], row["N"]))
        out.append(
            {
                "case": row["case"],
                "N": row["N"],
                "dp_s": dp["time"],
                "ref_s": ref["time"],
                "ratio": ref["time"] / dp["time"],
                "ratio_cpu": ref["cpu"] / dp["cpu"],
                "target": _target(row["N"]),
                "iterations": ref["iterations"],
                "stop": ref["refine_stop"],
                "E_dp": dp["energy"],
                "E_ref": ref["energy"],
                "gain_pct": 100.0 * (1.0 - ref["energy"] / dp["energy"]),
                "E_ref_baseline": old,
                "E_over_baseline": None if old is None else ref["energy"] / old,
                "fd_dp_s": fd and fd["time"],
                "fd_dp_E": fd and fd["energy"],
                "rbfgs_s": rb and rb["time"],
                "rbfgs_E": rb and rb["energy"],
            }
        )
    return out


def refine_markdown(rows: list[dict]) -> str:
    head = (
        "| case | N | dp s | dp+refine s | ratio | ratio CPU | target | iterations | E dp | E dp+refine "
        "| gain | E / baseline | fd DP s | fd DP E | RBFGS s | RBFGS E |"
    )
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in rows:
        cells = [
            r["case"],
            str(r["N"]),
            _fmt(r["dp_s"], ".4f"),
            _fmt(r["ref_s"], ".4f"),
            _fmt(r["ratio"], ".2f") + "x",
            _fmt(r["ratio_cpu"], ".2f") + "x",
            "-" if r["target"] is None else f"<= {r['target']}x",
            f"{r['iterations']} ({r['stop']})",
            _fmt(r["E_dp"], ".6g"),
            _fmt(r["E_ref"], ".6g"),
            _fmt(r["gain_pct"], ".2f") + "%",
            _fmt(r["E_over_baseline"], ".5f"),
            _fmt(r["fd_dp_s"], ".2f"),
            _fmt(r["fd_dp_E"], ".4g"),
            _fmt(r["rbfgs_s"], ".2f"),
            _fmt(r["rbfgs_E"], ".4g"),
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def refine_summary(rows: list[dict]) -> str:
    """The worst ratio per N against its target, and the worst energy against the baseline."""
    parts = []
    for n in sorted({r["N"] for r in rows}):
        at = [r for r in rows if r["N"] == n]
        worst, worst_cpu, target = max(r["ratio"] for r in at), max(r["ratio_cpu"] for r in at), _target(n)
        verdict = "" if target is None else (" met" if worst <= target else " NOT met") + f" (<= {target}x)"
        parts.append(f"N={n}: worst dp+refine/dp {worst:.2f}x wall, {worst_cpu:.2f}x CPU{verdict}")
    over = [r["E_over_baseline"] for r in rows if r["E_over_baseline"] is not None]
    if over:
        parts.append(f"dp+refine energy / baseline: worst {max(over):.5f}, best {min(over):.5f}")
    return "\n".join(parts)


if __name__ == "__main__":
    sys.exit(main())
