"""Database sub-commands: ``matrix``, ``search``, ``classify``, ``mean``, ``cluster``.

Thin wrappers over :mod:`elastic_motion.apps.database` and :mod:`elastic_motion.apps.statistics`;
progress goes to stderr, results to stdout; ``--json [PATH]`` writes the report to PATH (or
prints it on stdout), as every command does.
Exit codes: 0 success, 1 incomplete/interrupted run, 2 bad input, 3 cluster unreachable.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from elastic_motion.cli_commands._common import (
    CommandError,
    add_json_option,
    add_quiet_option,
    check_output,
    emit_report,
    fail,
    progress_for,
)
from elastic_motion.errors import ParseError


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``matrix``, ``search``, ``classify``, ``mean`` and ``cluster`` to ``subparsers``."""
    _register_matrix(subparsers)
    _register_search(subparsers)
    _register_classify(subparsers)
    _register_mean(subparsers)
    _register_cluster(subparsers)


# --------------------------------------------------------------------------------------------
# Shared options
# --------------------------------------------------------------------------------------------


def _add_preparation(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--samples", type=int, default=64, help="frames per motion after resampling, minus one (default 64)"
    )
    p.add_argument(
        "--joints",
        default="all",
        help="'all' (group motions by skeleton), 'common' (joints shared by all motions) or a comma list",
    )
    p.add_argument(
        "--keep-fingers", action="store_true", help="keep finger/thumb joints (dropped by default)"
    )
    p.add_argument("--no-align-heading", action="store_true", help="do not remove the heading at frame 0")


def _joints(value: str) -> str | tuple[str, ...]:
    return value if value in ("all", "common") else tuple(v.strip() for v in value.split(",") if v.strip())


def _add_pair(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--warp", choices=("dp", "none"), default="dp", help="dp: elastic distance; none: no warping"
    )
    p.add_argument(
        "--neighbourhood", type=int, default=6, help="DP slopes: coprime (a, b) up to this (default 6)"
    )
    p.add_argument(
        "--coarse-to-fine", action="store_true", help="banded coarse-to-fine DP (faster, approximate)"
    )


def _settings(args: argparse.Namespace, reps: tuple[str, ...]):
    from elastic_motion.apps.database import DatabaseSettings, PairSpec

    return DatabaseSettings(
        n_samples=args.samples,
        representations=reps,
        pair=PairSpec(warp=args.warp, neighbourhood=args.neighbourhood, coarse_to_fine=args.coarse_to_fine),
        joints=_joints(args.joints),
        drop_fingers=not args.keep_fingers,
        align_heading=not args.no_align_heading,
        tile_size=getattr(args, "tile_size", 32),
    )


def _fail(cmd: str, exc: BaseException, code: int = 2) -> int:
    """Print the error the way every command does; ``code`` 1 incomplete, 2 bad input, 3 unreachable."""
    fail(cmd, str(exc))
    return code


def _emit(args: argparse.Namespace, command: str, body: dict, inputs, outputs, lines: list[str]) -> None:
    """The shared report: header (command, version, time, inputs, outputs) + ``body``."""
    from elastic_motion.apps.report import report_header

    report = {**report_header(command, inputs=inputs, outputs=outputs), **body}
    emit_report(args, report, [str(p) for p in inputs], "\n".join(lines))


# --------------------------------------------------------------------------------------------
# matrix
# --------------------------------------------------------------------------------------------


def _register_matrix(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "matrix",
        help="all-pairs elastic distances of a motion database (tiles, resumable, Dask)",
        description=(
            "Compute all-pairs elastic distances (Lie and Euler representations) of the motions in "
            "files/folders, tile by tile, into OUT: distances_<repr>.npy, names.csv, report.json. "
            "Re-running the same command resumes an interrupted run."
        ),
    )
    p.add_argument("inputs", nargs="+", help="motion files and/or folders")
    p.add_argument("-o", "--out", required=True, help="output folder")
    p.add_argument("--engine", choices=("serial", "local", "dask"), default="serial")
    p.add_argument(
        "--scheduler", default=None, help="Dask scheduler address for --engine dask (tcp://host:8786)"
    )
    p.add_argument("--workers", type=int, default=2, help="worker processes of --engine local (default 2)")
    p.add_argument(
        "--timeout", type=float, default=10.0, help="seconds to wait for the scheduler (default 10)"
    )
    p.add_argument("--repr", default="lie,euler", help="representations, comma separated (default lie,euler)")
    p.add_argument("--tile-size", type=int, default=32, help="motions per tile side (default 32)")
    p.add_argument("--recursive", action="store_true", help="search folders recursively")
    p.add_argument("--overwrite", action="store_true", help="replace a different run found in OUT")
    add_quiet_option(p)
    add_json_option(p)
    _add_preparation(p)
    _add_pair(p)
    p.set_defaults(func=run_matrix)


def run_matrix(args: argparse.Namespace) -> int:
    from elastic_motion.apps.database import ClusterUnavailableError, compute_matrix

    bar = progress_for("matrix", args)
    try:
        settings = _settings(args, tuple(r.strip() for r in args.repr.split(",") if r.strip()))
        res = compute_matrix(
            args.inputs,
            args.out,
            settings,
            engine=args.engine,
            scheduler=args.scheduler,
            n_workers=args.workers,
            connect_timeout=args.timeout,
            recursive=args.recursive,
            overwrite=args.overwrite,
            progress=bar,
        )
    except ClusterUnavailableError as exc:
        return _fail("matrix", exc, 3)
    except (ValueError, FileNotFoundError, ParseError) as exc:
        return _fail("matrix", exc)
    except KeyboardInterrupt:
        print(
            "elastic-motion matrix: interrupted; finished tiles are kept, run the same command to resume",
            file=sys.stderr,
        )
        return 1
    finally:
        bar.close()
    rep = res.report
    t = rep.get("timings", {})
    lines = [
        f"{rep['n_motions']} motions -> {res.out_dir} ({'complete' if res.complete else 'INCOMPLETE'})",
        f"engine {rep['engine']} ({rep['workers']} workers); {rep['comparison']}",
        f"pairs computed this run: {t.get('pairs_computed')} in {t.get('tiles_seconds')} s",
        *(f"skipped {sk['path']}: {sk['reason']}" for sk in rep["skipped"]),
    ]
    _emit(args, "matrix", rep, args.inputs, [res.out_dir], lines)
    return 0 if res.complete else 1


# --------------------------------------------------------------------------------------------
# search
# --------------------------------------------------------------------------------------------


def _register_search(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "search",
        help="nearest motions of a query by elastic distance",
        description=(
            "Rank the motions of DB (a `matrix` output folder, whose SRV cache and settings are used, or "
            "motion files/folders) by elastic distance to QUERY."
        ),
    )
    p.add_argument("query", help="a motion file")
    p.add_argument("database", nargs="+", help="a matrix output folder, or motion files/folders")
    p.add_argument("-k", type=int, default=5, help="number of results (default 5)")
    p.add_argument("--repr", choices=("lie", "euler"), default="lie")
    add_quiet_option(p)
    add_json_option(p)
    _add_preparation(p)
    _add_pair(p)
    p.set_defaults(func=run_search)


def run_search(args: argparse.Namespace) -> int:
    from elastic_motion.apps.database import query_distances
    from elastic_motion.apps.statistics import nearest

    db = args.database[0] if len(args.database) == 1 else args.database
    bar = progress_for("search", args)
    try:
        names, paths, d, info = query_distances(
            args.query, db, args.repr, _settings(args, (args.repr,)), progress=bar
        )
    except (ValueError, FileNotFoundError, ParseError, KeyError) as exc:
        return _fail("search", exc)
    finally:
        bar.close()
    query = str(Path(args.query).resolve())
    exclude = [k for k, p in enumerate(paths) if p == query]
    idx = nearest(d, args.k, exclude=exclude)
    results = [
        {"rank": r + 1, "name": names[k], "path": paths[k], "distance": float(d[k])}
        for r, k in enumerate(idx)
    ]
    lines = [f"{r['rank']:3d}  {r['distance']:10.4f}  {r['name']}" for r in results] or [
        "no comparable motion (different skeletons? try --joints common)"
    ]
    body = {"query": args.query, "representation": args.repr, "results": results, **info}
    _emit(args, "search", body, [args.query, *args.database], [], lines)
    return 0


# --------------------------------------------------------------------------------------------
# classify
# --------------------------------------------------------------------------------------------


def _register_classify(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "classify",
        help="leave-one-out k-NN classification accuracy from a distance matrix",
        description=(
            "Leave-one-out k-NN classification of the motions of a `matrix` output folder. Labels come "
            "from a CSV (name,label), or from the file names: 'bandai-content', 'bandai-style' or 'cmu'."
        ),
    )
    p.add_argument("matrix_dir", help="output folder of `elastic-motion matrix`")
    p.add_argument(
        "--labels", required=True, help="CSV file name,label or bandai-content | bandai-style | cmu"
    )
    p.add_argument("-k", type=int, default=1)
    p.add_argument("--repr", default="lie,euler", help="representations to evaluate (default lie,euler)")
    add_json_option(p)
    p.set_defaults(func=run_classify)


def _labels_for(names: list[str], spec: str) -> list[str | None]:
    from elastic_motion.apps.statistics import bandai_labels, cmu_label

    if spec in ("bandai-content", "bandai-style"):
        part = 0 if spec == "bandai-content" else 1
        return [(lab[part] if (lab := bandai_labels(n)) else None) for n in names]
    if spec == "cmu":
        return [cmu_label(n) for n in names]
    import csv

    with open(spec, newline="") as fh:
        table = {row[0]: row[1] for row in csv.reader(fh) if len(row) >= 2}
    return [table.get(n) for n in names]


def run_classify(args: argparse.Namespace) -> int:
    from elastic_motion.apps.database import load_matrix
    from elastic_motion.apps.statistics import knn_evaluate

    out = {}
    try:
        for rep in [r.strip() for r in args.repr.split(",") if r.strip()]:
            m = load_matrix(args.matrix_dir, rep)
            labels = _labels_for(m.names, args.labels)
            ev = knn_evaluate(m.distances, labels, args.k)
            out[rep] = {
                "accuracy": ev.accuracy,
                "evaluated": ev.n_evaluated,
                "k": ev.k,
                "per_class": ev.per_class,
                "predictions": dict(zip(m.names, ev.predictions, strict=True)),
            }
    except (ValueError, FileNotFoundError, OSError) as exc:
        return _fail("classify", exc)
    lines = []
    for rep, r in out.items():
        lines.append(f"{rep}: {r['accuracy']:.3f} ({r['evaluated']} evaluated, k={r['k']})")
        lines += [f"    {c:20s} {ok}/{n}" for c, (ok, n) in r["per_class"].items()]
    _emit(args, "classify", {"results": out}, [args.matrix_dir], [], lines)
    return 0


# --------------------------------------------------------------------------------------------
# mean
# --------------------------------------------------------------------------------------------


def _register_mean(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "mean",
        help="Karcher mean of several motions, written as BVH",
        description=(
            "Align all motions to the current mean (optimal warp), average their SRV functions, repeat to "
            "convergence; write the mean as BVH and report the energy per iteration."
        ),
    )
    p.add_argument("files", nargs="+", help="motion files of one skeleton")
    p.add_argument("-o", "--out", required=True, help="output .bvh")
    p.add_argument("--repr", choices=("lie", "euler"), default="lie")
    p.add_argument("--max-iter", type=int, default=20)
    p.add_argument("--tol", type=float, default=1e-4, help="relative energy decrease to stop (default 1e-4)")
    p.add_argument(
        "--fps", type=float, default=None, help="frame rate of the output (default: the first file's)"
    )
    p.add_argument("--plot", default=None, help="also write the energy per iteration as a PNG")
    add_quiet_option(p)
    add_json_option(p)
    _add_preparation(p)
    _add_pair(p)
    p.set_defaults(func=run_mean)


def run_mean(args: argparse.Namespace) -> int:
    from elastic_motion.apps.statistics import mean_motion
    from elastic_motion.motion import write_bvh

    try:
        check_output(args.out, args.files, suffixes=(".bvh",))
    except CommandError as exc:
        return _fail("mean", exc)
    bar = progress_for("mean", args)
    try:
        motion, res, info = mean_motion(
            args.files,
            n_samples=args.samples,
            representation=args.repr,
            joints=_joints(args.joints),
            drop_fingers=not args.keep_fingers,
            align_heading=not args.no_align_heading,
            warp=args.warp,
            neighbourhood=args.neighbourhood,
            max_iter=args.max_iter,
            tol=args.tol,
            fps=args.fps,
            progress=bar,
        )
        path = write_bvh(motion, args.out, protected=args.files)
    except (ValueError, FileNotFoundError, ParseError, KeyError) as exc:
        return _fail("mean", exc)
    finally:
        bar.close()
    info["output"] = str(path)
    if args.plot:
        from elastic_motion.apps.plots_database import plot_energies

        info["plot"] = str(plot_energies(res.energies, args.plot, title="Karcher mean energy"))
    state = "converged" if info["converged"] else "not converged (raise --max-iter)"
    lines = [f"iteration {i:3d}  energy {e:.6g}" for i, e in enumerate(info["energies"], 1)]
    frames = f"{info['frames']} frames at {info['fps']:g} fps"
    lines.append(f"{state}; mean of {len(args.files)} motions -> {path} ({frames})")
    _emit(args, "mean", info, args.files, [path] + ([info["plot"]] if args.plot else []), lines)
    return 0


# --------------------------------------------------------------------------------------------
# cluster
# --------------------------------------------------------------------------------------------


def _register_cluster(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "cluster",
        help="hierarchical clustering of a distance matrix, with a dendrogram plot",
        description="Agglomerative clustering of the motions of a `matrix` output folder.",
    )
    p.add_argument("matrix_dir", help="output folder of `elastic-motion matrix`")
    p.add_argument("--repr", choices=("lie", "euler"), default="lie")
    p.add_argument("--method", choices=("average", "complete", "single", "weighted"), default="average")
    p.add_argument("--clusters", type=int, default=None, help="cut into this many flat clusters")
    p.add_argument("--plot", default=None, help="dendrogram PNG to write")
    p.add_argument(
        "--labels", default=None, help="colour leaves: CSV name,label or bandai-content|bandai-style|cmu"
    )
    add_json_option(p)
    p.set_defaults(func=run_cluster)


def run_cluster(args: argparse.Namespace) -> int:
    from elastic_motion.apps.database import load_matrix
    from elastic_motion.apps.statistics import cluster

    try:
        m = load_matrix(args.matrix_dir, args.repr)
        res = cluster(m.distances, m.names, method=args.method, n_clusters=args.clusters)
    except (ValueError, FileNotFoundError, OSError) as exc:
        return _fail("cluster", exc)
    out: dict[str, Any] = {"method": res.method, "representation": args.repr, "linkage": res.linkage.tolist()}
    if res.labels is not None:
        out["clusters"] = dict(zip(m.names, res.labels.tolist(), strict=True))
    if args.plot:
        from elastic_motion.apps.plots_database import plot_dendrogram

        colors = None
        if args.labels:
            labs = _labels_for(m.names, args.labels)
            colors = [lab or "?" for lab in labs]
        out["plot"] = str(
            plot_dendrogram(res, args.plot, title=f"{args.repr} elastic distance", colors=colors)
        )
    lines = [f"{c:3d}  {n}" for n, c in out.get("clusters", {}).items()]
    if args.plot:
        lines.append(f"dendrogram -> {out['plot']}")
    if res.labels is None and not args.plot:
        lines.append("nothing to show: pass --clusters K and/or --plot FILE.png (or --json for the linkage)")
    _emit(args, "cluster", out, [args.matrix_dir], [out["plot"]] if args.plot else [], lines)
    return 0
