"""Benchmark of issue 34: the whole exact k-nearest search over an index against brute-force DTW.

Databases: the first M (``--sizes``, default 250, 1000, 2500) of the windows of
``database_scale.py`` (BVH files of 200 frames at random starts of the 120 Hz CMU clips, seed
0), each indexed once by ``build_index`` with the database defaults (Lie, 64 cells, the
low-pass of 1/60 s since issue 34, exact DP with neighbourhood 10; the build is timed, not
compared). Queries: ``--queries`` (default 24)
windows at other random starts of the same clips (seed 1), the same for every size; k = 5.

Per size, one new Python process (imports and one search of a small other index first, not
timed: numba's kernels loaded from their cache as any earlier command leaves them; the index
of the size never opened before the first timed query) runs per query, in turn (the order of
the two alternated):

- **search** (ours): ``knn_search(query_file, index, k)``, the call ``elastic-motion search``
  makes: it reads and prepares the query file, opens the index (``index.json``, records,
  norms), computes the bounds and the DPs the bounds cannot exclude (reading and checking only
  their rows);
- **DTW brute force** (the anchor): ``dtaidistance.dtw_ndim.distance_matrix_fast`` of the
  query against every window (one block row, its parallel C code), on the same features: the
  SRV arrays of the index (one ``.npy`` of every window, loaded in the call) and the query's SRV
  array as the search computes it (``query_srv``, given), then the k smallest;
- **every DP** (the exactness check, timed apart): ``query_distances(query_file, index)``: the
  k nearest by ranking every distance must be the search's, indices and distances bit for bit.
  (DTW is another distance: its neighbours are only counted, ``dtw_overlap``.)

Also the command line end to end, for ``--cli-queries`` queries: ``elastic-motion search
QUERY INDEX -k 5`` in a new process (interpreter start and imports included) against a new
process that imports numpy and dtaidistance, loads the features and runs the same DTW brute
force. Each process and section records the load average (``uptime``); the machine may be
shared: the ratios are of runs in turn, medians.

Prints a table and writes ``benchmarks/results/search.json``.

Usage::

    python benchmarks/search.py                    # ~15 min on an idle machine (the builds: ~10)
    python benchmarks/search.py --keep /tmp/em-search-bench   # windows and indexes kept, reused
    python benchmarks/search.py --quick            # smoke test (40 and 80 windows, 4 queries)
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from _common import MOCAP, RESULTS, machine_info, write_json
from database_scale import load, settings, write_windows
from elastic_motion.apps.database import DEFAULT_WARP

K = 5
#: What ``elastic-motion search`` runs (the console script's code).
CLI_CODE = "import sys\nfrom elastic_motion.cli import main\nsys.exit(main())\n"
#: The DTW brute force in a new process: features, query features, k.
DTW_CODE = (
    "import sys\nimport numpy as np\nfrom dtaidistance import dtw_ndim\n"
    "feats = np.load(sys.argv[1])\nq = np.load(sys.argv[2])\n"
    "d = np.asarray(dtw_ndim.distance_matrix_fast([q, *feats], block=((0, 1), (1, len(feats) + 1)), "
    "compact=True, parallel=True))\n"
    "print(np.argsort(d, kind='stable')[: int(sys.argv[3])].tolist())\n"
)


def dtw_brute_force(features: Path, query: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The anchor: DTW (dtaidistance, C) of ``query`` against every window of ``features``
    (loaded here); the ``k`` nearest (ties by index) and every distance."""
    from dtaidistance import dtw_ndim

    feats = np.load(features)
    d = np.asarray(
        dtw_ndim.distance_matrix_fast(
            [query, *feats], block=((0, 1), (1, len(feats) + 1)), compact=True, parallel=True
        )
    )
    return np.argsort(d, kind="stable")[:k], d


# --------------------------------------------------------------------------------------------
# The measuring process
# --------------------------------------------------------------------------------------------


def worker(spec: dict) -> dict:
    """Run in a new process: the per-query measurements of one database (module docstring)."""
    import psutil

    from elastic_motion.apps.database import knn_search, load_index, query_distances
    from elastic_motion.apps.database.query import query_srv

    # interpreter start and imports (this script's: numpy, elastic_motion.apps.database)
    out: dict = {"seconds_imports": time.time() - psutil.Process().create_time()}
    t0 = time.perf_counter()
    knn_search(spec["warm_query"], spec["warm_index"], K)  # numba's kernels loaded, lazy imports
    out["seconds_first_search_of_the_process"] = time.perf_counter() - t0
    with load_index(spec["warm_index"]) as idx:  # dtaidistance loaded and run once
        q = query_srv(spec["warm_query"], idx.cache)
    dtw_brute_force(Path(spec["warm_features"]), q, K)
    with load_index(spec["index"]) as idx:  # the anchor's query features (not timed)
        qfeats = [query_srv(f, idx.cache) for f in spec["queries"]]
    features = Path(spec["features"])
    rows = []
    for j, (qfile, qf) in enumerate(zip(spec["queries"], qfeats, strict=True)):
        times = {}
        for what in ("search", "dtw") if j % 2 == 0 else ("dtw", "search"):
            t0 = time.perf_counter()
            if what == "search":
                res = knn_search(qfile, spec["index"], K)
            else:
                top_dtw, _ = dtw_brute_force(features, qf, K)
            times[what] = time.perf_counter() - t0
        t0 = time.perf_counter()
        brute = query_distances(qfile, spec["index"])
        t_every = time.perf_counter() - t0
        want = brute.nearest(K)
        rows.append(
            {
                "query": Path(qfile).name,
                "seconds_search": times["search"],
                "seconds_search_bounds_and_dps": res.seconds,
                "seconds_dtw": times["dtw"],
                "seconds_every_dp": t_every,
                "equal_to_every_dp": res.indices.tolist() == want.tolist()
                and res.distances.tolist() == brute.distances[want].tolist(),
                "computed": res.n_computed,
                "candidates": res.candidates,
                "fraction_pruned": res.fraction_pruned,
                "dtw_overlap": len(set(top_dtw.tolist()) & set(res.indices.tolist())),
                "load_average": os.getloadavg()[0],
            }
        )
    out["rows"] = rows
    return out


def run_worker(spec: dict, tmp: Path) -> dict:
    """:func:`worker` in a new Python process."""
    path = tmp / "spec.json"
    path.write_text(json.dumps(spec))
    proc = subprocess.run(
        [sys.executable, __file__, "--worker", str(path)], capture_output=True, text=True, check=False
    )
    if proc.returncode:
        raise RuntimeError(f"the measuring process failed:\n{proc.stderr[-3000:]}")
    return json.loads((tmp / "spec.json.out").read_text())


def cli_end_to_end(index: Path, features: Path, queries: list[Path], qfeats: list[Path]) -> dict:
    """``elastic-motion search`` and the DTW script, each a new process, in turn: wall seconds."""
    ours, anchor = [], []
    for j, (q, qf) in enumerate(zip(queries, qfeats, strict=True)):
        for what in ("cli", "dtw") if j % 2 == 0 else ("dtw", "cli"):
            cmd = (
                [sys.executable, "-c", CLI_CODE, "search", str(q), str(index), "-k", str(K), "--quiet"]
                if what == "cli"
                else [sys.executable, "-c", DTW_CODE, str(features), str(qf), str(K)]
            )
            t0 = time.perf_counter()
            proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
            dt = time.perf_counter() - t0
            if proc.returncode:
                raise RuntimeError(f"{cmd[3:]} failed:\n{proc.stderr[-2000:]}")
            (ours if what == "cli" else anchor).append(dt)
    return {
        "queries": len(queries),
        "seconds_cli": float(np.median(ours)),
        "seconds_dtw_script": float(np.median(anchor)),
        "ratio": float(np.median(np.array(anchor) / np.array(ours))),
    }


# --------------------------------------------------------------------------------------------
# Databases
# --------------------------------------------------------------------------------------------


def indexed(files: list[Path], out: Path) -> tuple[Path, float | None]:
    """The index of ``files`` at ``out`` (reused when it is this library's index of these
    files) and the seconds its build took (None: reused)."""
    from elastic_motion.apps.database import build_index, load_index
    from elastic_motion.errors import OptionError

    try:
        with load_index(out) as idx:
            kept = idx.cache.settings == settings(warp=DEFAULT_WARP)  # not an index of other settings
            if kept and idx.meta["inputs"] == [os.fspath(f) for f in files] and not idx.notes:
                return out, None
    except OptionError:
        pass
    t0 = time.perf_counter()
    build_index(files, out, settings(warp=DEFAULT_WARP), overwrite=True)  # the search's defaults
    return out, time.perf_counter() - t0


def features_of(index: Path) -> Path:
    """Every window's SRV array of ``index`` as one ``(M, n, D)`` ``.npy`` beside it (the DTW's input)."""
    from elastic_motion.apps.database import load_index

    out = index.parent / f"{index.name}.features.npy"
    if not out.exists() or out.stat().st_mtime < (index / "index.json").stat().st_mtime:
        with load_index(index) as idx:
            np.save(out, np.stack(list(idx.cache.q["lie"])))
    return out


def measure_size(m: int, windows: list[Path], queries: list[Path], work: Path, args) -> dict:
    """Index, per-query measurements and the command line at ``m`` windows."""
    from elastic_motion.apps.database import load_index
    from elastic_motion.apps.database.query import query_srv

    index, build_seconds = indexed(windows[:m], work / f"index_{m}")
    features = features_of(index)
    warm, _ = indexed(windows[-12:], work / "index_warm")
    spec = {
        "index": str(index),
        "features": str(features),
        "queries": [str(q) for q in queries],
        "warm_index": str(warm),
        "warm_query": str(windows[-13]),
        "warm_features": str(features_of(warm)),
    }
    before = load("before")["load_average"]
    out = run_worker(spec, work)
    rows = out.pop("rows")
    cli_q = queries[: args.cli_queries]
    qfeats = []
    with load_index(index) as idx:
        for j, q in enumerate(cli_q):
            qfeats.append(work / f"query_{j}.npy")
            np.save(qfeats[-1], query_srv(q, idx.cache))
    cli = cli_end_to_end(index, features, cli_q, qfeats) if cli_q else None
    after = load("after")["load_average"]

    def med(key: str) -> float:
        return float(np.median([r[key] for r in rows]))

    return {
        "windows": m,
        "queries": len(rows),
        "k": K,
        "seconds_build": build_seconds,
        **out,
        "equal_to_every_dp": sum(r["equal_to_every_dp"] for r in rows),
        "fraction_pruned_mean": float(np.mean([r["fraction_pruned"] for r in rows])),
        "fraction_pruned_min": float(np.min([r["fraction_pruned"] for r in rows])),
        "computed_median": med("computed"),
        "seconds_search": med("seconds_search"),
        "seconds_search_bounds_and_dps": med("seconds_search_bounds_and_dps"),
        "seconds_dtw": med("seconds_dtw"),
        "seconds_every_dp": med("seconds_every_dp"),
        "ratio_dtw_over_search": float(np.median([r["seconds_dtw"] / r["seconds_search"] for r in rows])),
        "ratio_dtw_over_search_min": float(np.min([r["seconds_dtw"] / r["seconds_search"] for r in rows])),
        "ratio_of_totals": sum(r["seconds_dtw"] for r in rows) / sum(r["seconds_search"] for r in rows),
        "share_of_queries_at_least_3x": float(
            np.mean([r["seconds_dtw"] >= 3 * r["seconds_search"] for r in rows])
        ),
        "dtw_overlap_mean": float(np.mean([r["dtw_overlap"] for r in rows])),
        "cli": cli,
        "load_average_before_after": [before, after],
        "rows": rows,
    }


# --------------------------------------------------------------------------------------------
# Report
# --------------------------------------------------------------------------------------------


def markdown(r: dict) -> str:
    lines = [
        f"### Exact {K}-nearest search over an index against brute-force DTW (dtaidistance), whole call",
        "",
        "| windows | = every DP | pruned mean / min | DPs (median) | search s | of it bounds + DPs s | "
        "DTW brute force s | **DTW / search** (min) | of the totals | queries >= 3x | every DP s | "
        "CLI s / DTW script s (ratio) | load before -> after |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for s in r["sizes"]:
        cli = s.get("cli")
        cli_txt = "-"
        if cli:
            cli_txt = f"{cli['seconds_cli']:.2f} / {cli['seconds_dtw_script']:.2f} ({cli['ratio']:.2f}x)"
        la = s["load_average_before_after"]
        lines.append(
            f"| {s['windows']} | {s['equal_to_every_dp']}/{s['queries']} | {s['fraction_pruned_mean']:.3f} / "
            f"{s['fraction_pruned_min']:.3f} | {s['computed_median']:.0f} | {s['seconds_search']:.3f} | "
            f"{s['seconds_search_bounds_and_dps']:.3f} | {s['seconds_dtw']:.3f} | "
            f"**{s['ratio_dtw_over_search']:.2f}x** ({s['ratio_dtw_over_search_min']:.2f}x) | "
            f"{s['ratio_of_totals']:.2f}x | {100 * s['share_of_queries_at_least_3x']:.0f} % | "
            f"{s['seconds_every_dp']:.2f} | {cli_txt} | {la[0][0]:.2f} -> {la[1][0]:.2f} |"
        )
    s0 = r["sizes"][-1]
    lines += [
        "",
        f"Medians over the queries; DTW / search is the median of the per-query ratios (in turn, same "
        f"process). Not timed: imports ({s0['seconds_imports']:.2f} s) and the process's first search "
        f"({s0['seconds_first_search_of_the_process']:.2f} s: numba's kernels loaded from their cache). "
        f"Of the DTW's {K} nearest, {s0['dtw_overlap_mean']:.1f} are the search's on average (another "
        f"distance). Load average (1 min) before -> after each size; machine: {r['machine']['cpu_count']} "
        f"CPUs, {r['machine']['date']}.",
    ]
    return "\n".join(lines)


def _arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--mocap", type=Path, default=MOCAP)
    parser.add_argument("--sizes", default="250,1000,2500", help="database sizes (windows), comma-separated")
    parser.add_argument("--queries", type=int, default=24, help="query windows (default 24)")
    parser.add_argument("--cli-queries", type=int, default=3, help="queries also run as commands (default 3)")
    parser.add_argument("--keep", type=Path, default=None, help="keep windows and indexes here (reused)")
    parser.add_argument("--quick", action="store_true", help="small sizes (a smoke test of the script)")
    parser.add_argument("--out", type=Path, default=RESULTS / "search.json")
    parser.add_argument("--markdown", action="store_true", help="only print the table of the existing JSON")
    parser.add_argument("--worker", type=Path, default=None, help=argparse.SUPPRESS)
    return parser.parse_args()


def _windows(cmu: Path, folder: Path, m: int, seed: int) -> list[Path]:
    """``m`` windows of ``database_scale.write_windows`` in ``folder`` (written unless there)."""
    files = sorted(folder.glob("w*.bvh")) if folder.exists() else []
    if len(files) != m:
        shutil.rmtree(folder, ignore_errors=True)
        secs = write_windows(cmu, folder, m, seed=seed)
        print(f"wrote {m} windows to {folder} in {secs:.0f} s", flush=True)
        files = sorted(folder.glob("w*.bvh"))
    return files


def main() -> None:
    args = _arguments()
    if args.worker is not None:
        write_json(Path(f"{args.worker}.out"), worker(json.loads(args.worker.read_text())))
        return
    if args.markdown:
        print(markdown(json.loads(args.out.read_text())))
        return
    sizes = [40, 80] if args.quick else [int(x) for x in args.sizes.split(",")]
    n_queries = 4 if args.quick else args.queries
    work = args.keep or Path(tempfile.mkdtemp(prefix="em-search-"))
    work.mkdir(parents=True, exist_ok=True)
    result: dict = {"machine": machine_info(), "sizes": []}
    try:
        cmu = args.mocap / "cmu" / "bvh"
        windows = _windows(cmu, work / "windows", max(sizes), seed=0)
        queries = _windows(cmu, work / "queries", n_queries, seed=1)
        for m in sizes:
            print(f"[{time.strftime('%H:%M:%S')}] {m} windows ...", flush=True)
            result["sizes"].append(measure_size(m, windows, queries, work, args))
            print(markdown(result), flush=True)
    finally:
        if args.keep is None:
            shutil.rmtree(work, ignore_errors=True)
    if not args.quick:
        write_json(args.out, result)
        print(f"\nwritten {args.out}")


if __name__ == "__main__":
    main()
