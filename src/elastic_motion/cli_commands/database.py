"""Database sub-commands: ``matrix``, ``search``, ``classify``, ``mean``, ``cluster``.

Thin wrappers over :mod:`elastic_motion.apps.database` and :mod:`elastic_motion.apps.statistics`;
progress goes to stderr, results to stdout; ``--json [PATH]`` writes the report to PATH (or
prints it on stdout), as every command does.

One option name per concept, as in the other commands: ``--method`` the curve
representation, ``-o/--output`` the output, ``--no-align``, ``--warp`` and
``--neighbourhood`` the warp; ``cluster --linkage`` the clustering linkage. The spellings of
earlier releases (``--repr``, ``--out``, ``--no-align-heading``) still work for one release,
hidden from ``--help``, with a note on stderr.

Each command is one call of its Python function (``compute_matrix``, ``knn_search`` /
``find_within``, ``classify_motions``, ``mean_motion``, ``cluster_motions`` of
:mod:`elastic_motion.apps.database`) and prints its result; a command imports its app inside
``run_*`` (the command line starts without loading what the other commands need).

Exit codes: 0 success, 1 incomplete/interrupted run, 2 bad input, 3 cluster unreachable.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Any

from elastic_motion.cli_commands._argparse import (
    EXIT_INCOMPLETE,
    print_error,
)
from elastic_motion.cli_commands._common import (
    CommandError,
    add_joint_limits_option,
    add_json_option,
    add_quiet_option,
    check_output,
    progress_for,
)
from elastic_motion.cli_commands._database_options import (
    ENGINES,
    FIELD_FLAGS,
    LINKAGES,
    USER_ERRORS,
    add_distance_terms,
    add_method,
    add_preparation,
    add_warp,
    alias,
    defaults_unset,
    fail,
    joints_option,
)
from elastic_motion.vocabulary import OUTPUT_MOTION_EXTENSIONS


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``matrix``, ``search``, ``classify``, ``mean`` and ``cluster`` to ``subparsers``."""
    _register_matrix(subparsers)
    _register_search(subparsers)
    _register_classify(subparsers)
    _register_mean(subparsers)
    _register_cluster(subparsers)


# --------------------------------------------------------------------------------------------
# matrix
# --------------------------------------------------------------------------------------------


def _register_matrix(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "matrix",
        help="all-pairs elastic distances of a motion database (tiles, resumable, Dask)",
        description=(
            "Compute all-pairs elastic distances (Lie and Euler representations) of the motions in "
            "files/folders, tile by tile, into OUTPUT: distances_<method>.npy, names.csv, report.json. "
            "Re-running the same command resumes an interrupted run."
        ),
    )
    p.add_argument("inputs", nargs="+", help="motion files and/or folders")
    p.add_argument("-o", "--output", required=True, help="output folder (created; required)")
    alias(p, "--out", "--output")
    p.add_argument(
        "--engine",
        choices=ENGINES,
        default="serial",
        help="serial: this process; local: a Dask cluster of --workers processes started here (only "
        "when the work pays for its start; else serial, and the report says so); dask: the Dask "
        "scheduler at --scheduler (default: serial)",
    )
    p.add_argument(
        "--scheduler",
        default=None,
        help="Dask scheduler address for --engine dask, e.g. tcp://host:8786 (default: none)",
    )
    p.add_argument("--workers", type=int, default=2, help="worker processes of --engine local (default: 2)")
    p.add_argument(
        "--timeout",
        type=float,
        default=10.0,
        metavar="SECONDS",
        help="seconds to wait for the Dask scheduler to answer (connection and handshake; something "
        "else at the address is an error within this time) and, mid-run, for a worker when none is "
        "left (default: 10)",
    )
    add_method(p, several=True)
    p.add_argument(
        "--tile-size",
        type=int,
        default=32,
        metavar="N",
        help="motions per tile side: a tile (one task) holds up to N^2 pairs (default: 32)",
    )
    p.add_argument("--recursive", action="store_true", help="search folders recursively (default: off)")
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace a run with other settings or inputs found in OUTPUT (default: refuse)",
    )
    add_quiet_option(p)
    add_json_option(p)
    add_preparation(p)
    add_warp(p)
    add_distance_terms(p)
    p.set_defaults(func=run_matrix)


def run_matrix(args: argparse.Namespace) -> int:
    from elastic_motion.apps.database import ClusterUnavailableError, MatrixOptions, compute_matrix
    from elastic_motion.cli_commands._database_running import database_settings, emit, methods

    bar = progress_for("matrix", args)
    try:
        settings = database_settings(args, methods(args.method, several=True))
        options = MatrixOptions(
            engine=args.engine,
            scheduler=args.scheduler,
            n_workers=args.workers,
            connect_timeout=args.timeout,
            recursive=args.recursive,
            overwrite=args.overwrite,
        )
        res = compute_matrix(args.inputs, args.output, settings, options, progress=bar)
    except KeyboardInterrupt:
        print_error("matrix", "interrupted (Ctrl-C): finished tiles are kept; run the same command to resume")
        return EXIT_INCOMPLETE
    except (*USER_ERRORS, ClusterUnavailableError) as exc:  # unreachable scheduler: exit code 3
        return fail("matrix", exc)
    finally:
        bar.close()
    rep = res.summary()
    t = rep.get("timings", {})
    run = (rep.get("runs") or [{}])[-1]
    lines = [
        f"{rep['n_motions']} motions -> {res.out_dir} ({'complete' if res.complete else 'INCOMPLETE'})",
        f"engine {rep['engine']} ({rep['workers']} workers); {rep['comparison']}",
        f"pairs computed this run: {t.get('pairs_computed')} in {t.get('tiles_seconds')} s",
        *(f"not trusted: {n}" for n in [*run.get("tiles_rejected", []), run.get("cache_note")] if n),
        *(f"skipped {sk['path']}: {sk['reason']}" for sk in rep["skipped"]),
    ]
    emit(args, "matrix", rep, args.inputs, [res.out_dir], lines)
    return 0 if res.complete else EXIT_INCOMPLETE


# --------------------------------------------------------------------------------------------
# search
# --------------------------------------------------------------------------------------------


def _register_search(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "search",
        help="nearest motions of a query by elastic distance (exact, pruned by bounds), or --within "
        "long takes",
        description=(
            "Rank the motions of DATABASE (an `index` or `matrix` output folder, whose SRV arrays and "
            "settings are used: the options below that are given and differ from them are named in a note; "
            "or motion files/folders, read with the options below) by elastic distance to QUERY. "
            "The k nearest are exact: cheap lower bounds skip the DP of motions that cannot be "
            "among them (the report gives the fraction pruned). With --within, find where QUERY happens "
            "inside each motion of DATABASE (long takes): the segment (start, stop) and its distance."
        ),
    )
    p.add_argument("query", help="a motion file")
    p.add_argument("database", nargs="+", help="an index or matrix output folder, or motion files/folders")
    p.add_argument("-k", type=int, default=5, help="number of results (default: 5)")
    p.add_argument(
        "--within",
        action="store_true",
        help="partial matching: best segment of each DATABASE motion (free start and end; segments last "
        "1/N to N times the query, N = --neighbourhood; without --samples / --neighbourhood: 48 cells, "
        "N = 4, not the defaults shown below) (default: off)",
    )
    add_method(p, several=False)
    add_quiet_option(p)
    add_json_option(p)
    add_preparation(p)
    add_warp(p)
    add_distance_terms(p)
    defaults_unset(p)  # a stored database uses its own settings: the flags given are compared with them
    p.set_defaults(func=run_search)


#: The settings fields ``search --within`` uses (``find_within``'s keywords), by flag.
_WITHIN_FIELDS = {
    "n_samples": "n_samples",
    "warp.neighbourhood": "neighbourhood",
    "drop_fingers": "drop_fingers",
}


def _run_within(args: argparse.Namespace) -> int:
    from elastic_motion.apps.database import find_within, is_stored_database
    from elastic_motion.apps.database.settings import flat_settings
    from elastic_motion.cli_commands._database_running import database_settings, emit, given_fields, methods

    bar = progress_for("search", args)
    try:
        (method,) = methods(args.method, several=False)
        settings = database_settings(args, (method,))
        values = flat_settings(settings.to_json())
        given = {f: values[f] for f in given_fields(args)}
        # what partial matching cannot honour (a DP warp or no pose term given is no request)
        unused = [
            FIELD_FLAGS[f]
            for f, v in given.items()
            if f not in _WITHIN_FIELDS and (f, v) not in (("warp.method", "dp"), ("pose_weight", 0.0))
        ]
        if unused:
            raise CommandError(
                f"--within: expected none of {', '.join(unused)} (partial matching is on the SRV of the "
                "query's joints, with its own open-ended DP; it uses --samples, --neighbourhood and "
                "--keep-fingers)"
            )
        if is_stored_database(args.database if len(args.database) > 1 else args.database[0]):
            raise CommandError(
                "--within: expected motion files or folders (the long takes); got a stored database (an "
                "index or matrix folder), whose SRV arrays are resampled to a fixed grid"
            )
        kw = {
            _WITHIN_FIELDS[f]: v for f, v in given.items() if f in _WITHIN_FIELDS
        }  # others: the API's defaults
        res = find_within(args.query, args.database, method, progress=bar, **kw)
    except USER_ERRORS as exc:
        return fail("search", exc)
    finally:
        bar.close()
    s = res.summary()
    matches = s["matches"][: args.k]
    lines = [
        f"{r + 1:3d}  {m['distance']:10.4f}  {m['name']}  {m['start']:.2f}-{m['stop']:.2f} s "
        f"(frames {m['start_frame']}-{m['stop_frame']})"
        for r, m in enumerate(matches)
    ]
    lines += [f"skipped {sk['path']}: {sk['reason']}" for sk in res.skipped]
    body = {**s, "matches": matches, "within": True}
    emit(args, "search", body, [args.query, *args.database], [], lines)
    return 0


def _refuse_other_reading(args: argparse.Namespace, db: Any, built: Any) -> None:
    """A stored database reads every file, the query too, with the ``--up`` and ``--units`` it
    was built with: other ones given are refused (a query read otherwise than the motions it
    is compared with would be measured lying down or scaled)."""
    for flag, name in (("--up", "up"), ("--units", "units")):
        asked, was = getattr(args, name), getattr(built, name)
        if asked is not None and asked != was:
            raise CommandError(
                f"{flag}: expected {was or 'none'} (the stored database {os.fspath(Path(db))} was built "
                f"with {flag} {was or 'not given: detected per file'}, which also reads the query); got "
                f"{asked!r}: build it again with {flag} {asked}, or search the motion files"
            )


def run_search(args: argparse.Namespace) -> int:
    from elastic_motion.apps.database import is_stored_database, knn_search
    from elastic_motion.apps.database.settings import ignored_settings_note
    from elastic_motion.cli_commands._database_running import database_settings, emit, given_fields, methods

    if args.within:
        return _run_within(args)
    db = args.database[0] if len(args.database) == 1 else args.database
    bar = progress_for("search", args)
    try:
        (method,) = methods(args.method, several=False)
        settings = database_settings(args, (method,))
        # a stored database is measured as it was built: name only the flags given that differ
        stored = is_stored_database(db)
        res = knn_search(args.query, db, args.k, method, None if stored else settings, progress=bar)
        if stored:
            _refuse_other_reading(args, db, res.settings)
    except USER_ERRORS as exc:
        return fail("search", exc)
    finally:
        bar.close()
    s = res.summary()
    note = ignored_settings_note(settings, res.settings, given_fields(args)) if stored else None
    ignored = [] if note is None else [note]
    s["notes"] = [*ignored, *s["notes"]]
    results = s["results"]
    lines = [f"{r['rank']:3d}  {r['distance']:10.4f}  {r['name']}" for r in results]
    if not results:
        lines = [
            res.notes[-1]
            if res.group < 0
            else "no comparable motion (different skeletons? try --joints common)"
        ]
    else:
        lines.append(
            f"exact {min(args.k, s['candidates'])} nearest: full DP on {s['computed']} of "
            f"{s['candidates']} motions ({100 * s['fraction_pruned']:.0f}% pruned by the bounds)"
        )
    # and what reading a stored database said (an index of an earlier format: rebuild it)
    said = [n for n in res.notes if stored and n.startswith(f"{os.fspath(Path(db))}: ")]
    lines += [f"note: {n}" for n in [*ignored, *said]]
    body = {
        "query": args.query,
        "representation": method.key,
        "method": res.method,
        "results": results,
        "candidates": s["candidates"],
        "computed": s["computed"],
        "fraction_pruned": s["fraction_pruned"],
        "group": s["group"],
        "settings": s["settings"],
        "skipped": s["skipped"],
        "notes": s["notes"],
    }
    emit(args, "search", body, [args.query, *args.database], [], lines)
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
        "--labels",
        required=True,
        help="CSV file name,label or bandai-content | bandai-style | cmu (required)",
    )
    p.add_argument("-k", type=int, default=1, help="neighbours that vote (default: 1)")
    add_method(p, several=True)
    add_json_option(p)
    p.set_defaults(func=run_classify)


def run_classify(args: argparse.Namespace) -> int:
    from elastic_motion.apps.database import classify_motions
    from elastic_motion.cli_commands._database_running import emit, methods

    try:
        results = {
            rep.key: classify_motions(args.matrix_dir, args.labels, k=args.k, method=rep)
            for rep in methods(args.method, several=True)
        }
    except USER_ERRORS as exc:
        return fail("classify", exc)
    lines = []
    for key, res in results.items():
        ev = res.evaluation
        lines.append(f"{key}: {ev.accuracy:.3f} ({ev.n_evaluated} evaluated, k={ev.k})")
        lines += [f"    {c:20s} {ok}/{n}" for c, (ok, n) in ev.per_class.items()]
    body = {"results": {key: res.summary() for key, res in results.items()}}
    emit(args, "classify", body, [args.matrix_dir], [], lines)
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
    p.add_argument("-o", "--output", required=True, help="output .bvh, .gltf or .glb file (required)")
    alias(p, "--out", "--output")
    add_method(p, several=False)
    p.add_argument("--max-iter", type=int, default=20, help="alignment iterations at most (default: 20)")
    p.add_argument(
        "--tol", type=float, default=1e-4, help="relative energy decrease to stop at (default: 1e-4)"
    )
    p.add_argument(
        "--fps",
        type=float,
        default=None,
        metavar="FPS",
        help="frames per second of the output (default: the first file's frame rate)",
    )
    p.add_argument(
        "--plot",
        default=None,
        metavar="PNG",
        help="also write the energy per iteration as a PNG (default: no plot)",
    )
    add_joint_limits_option(
        p,
        "keep",
        "the mean's DOF angles that every input respects are moved into their ranges, eased over "
        "0.15 s (the report says which joints and frames changed, by how much)",
    )
    add_quiet_option(p)
    add_json_option(p)
    add_preparation(p)
    add_warp(p, mean=True)
    p.set_defaults(func=run_mean)


def run_mean(args: argparse.Namespace) -> int:
    from elastic_motion.apps.database import MeanOptions, mean_motion
    from elastic_motion.apps.prepare import output_notes
    from elastic_motion.cli_commands._database_running import emit, methods
    from elastic_motion.motion import write_motion
    from elastic_motion.warp import WarpOptions

    bar = progress_for("mean", args)
    try:
        check_output(args.output, args.files, suffixes=OUTPUT_MOTION_EXTENSIONS, what="--output")
        (method,) = methods(args.method, several=False)
        options = MeanOptions(
            n_samples=args.samples,
            method=method.name,
            joints=joints_option(args.joints),
            drop_fingers=not args.keep_fingers,
            align_heading=not args.no_align,
            warp=WarpOptions(
                method=args.warp, neighbourhood=args.neighbourhood, coarse_to_fine=args.coarse_to_fine
            ),
            max_iter=args.max_iter,
            up=args.up,
            units=args.units,
            tol=args.tol,
            fps=args.fps,
            joint_limits=args.joint_limits,
        )
        res = mean_motion(args.files, options, progress=bar)
        path = write_motion(res.motion, args.output, protected=args.files)
    except USER_ERRORS as exc:
        return fail("mean", exc)
    finally:
        bar.close()
    body: dict[str, Any] = {**res.summary(), "output": str(path)}
    outputs: list[Any] = [path]
    if args.plot:
        from elastic_motion.apps.plots_database import plot_energies

        body["plot"] = str(plot_energies(res.energies, args.plot, title="Karcher mean energy"))
        outputs.append(body["plot"])
    state = "converged" if res.converged else "not converged (raise --max-iter)"
    lines = [f"iteration {i:3d}  energy {e:.6g}" for i, e in enumerate(body["energies"], 1)]
    frames = f"{body['frames']} frames at {body['fps']:g} fps"
    lines.append(f"{state}; mean of {len(args.files)} motions -> {path} ({frames})")
    # a joint with 1-2 rotation channels is written as the nearest rotation it holds: say so
    channel_notes = output_notes(res.motion, path)
    body["output_notes"] = [str(n) for n in channel_notes]
    lines += [f"note: {n}" for n in channel_notes]
    emit(args, "mean", body, args.files, outputs, lines)
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
    add_method(p, several=False)
    p.add_argument(
        "--linkage",
        choices=LINKAGES,
        default="average",
        help="distance between clusters: average (UPGMA), complete, single or weighted (WPGMA) "
        "(default: average)",
    )
    p.add_argument(
        "--clusters", type=int, default=None, metavar="K", help="cut into K flat clusters (default: no cut)"
    )
    p.add_argument("--plot", default=None, metavar="PNG", help="dendrogram PNG to write (default: no plot)")
    p.add_argument(
        "--labels",
        default=None,
        help="colour leaves: CSV name,label or bandai-content | bandai-style | cmu (default: no colours)",
    )
    add_json_option(p)
    p.set_defaults(func=run_cluster)


def run_cluster(args: argparse.Namespace) -> int:
    from elastic_motion.apps.database import cluster_motions
    from elastic_motion.cli_commands._database_running import emit, methods

    try:
        (method,) = methods(args.method, several=False)
        res = cluster_motions(
            args.matrix_dir,
            method=method,
            linkage=args.linkage,
            n_clusters=args.clusters,
            labels=args.labels if args.plot else None,  # the labels colour the plot's leaves
        )
    except USER_ERRORS as exc:
        return fail("cluster", exc)
    out = res.summary()
    if args.plot:
        out["plot"] = str(res.plot(args.plot))
    lines = [f"{c:3d}  {n}" for n, c in out.get("clusters", {}).items()]
    if args.plot:
        lines.append(f"dendrogram -> {out['plot']}")
    if res.clusters is None and not args.plot:
        lines.append("nothing to show: pass --clusters K and/or --plot FILE.png (or --json for the linkage)")
    emit(args, "cluster", out, [args.matrix_dir], [out["plot"]] if args.plot else [], lines)
    return 0
