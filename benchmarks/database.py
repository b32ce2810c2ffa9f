"""Benchmark of motion-database distances: throughput, scaling, extrapolation, classification.

Sections (all in one run, on this machine):

1. **Throughput**: all-pairs elastic distances (``compute_matrix``, Lie + Euler, DP) of a
   database of 1-second windows cut from the CMU clips, serial against a Dask
   ``LocalCluster`` with 2 single-threaded workers; also ``--warp none``. Pairs per second.
2. **Scaling**: seconds per pair (one ``optimal_warp``) against the frames ``N`` (at the Lie
   dimension of the CMU skeleton) and against the dimension ``D`` (at fixed ``N``), on real
   SRV arrays; exponents fitted in log-log.
3. **Extrapolation**: the whole CMU database (2,500 trials, 3.1 million pairs per
   representation) on ``k`` workers, and the issue's target (1000 motions x 200 frames
   all-pairs in 10 minutes on 2 cores), from the measured per-pair costs and the measured
   2-worker efficiency. The target run with ``--warp none`` is also *run* end to end
   (1000 generated window files, ``--engine local``).
4. **Classification**: leave-one-out 1-NN accuracy on windows of the Bandai-Namco clips
   (content and style labels from the file names) and of the CMU clips (walk / run / jump /
   cartwheel / dance), for Lie and Euler, with and without warp, against DTW
   (``dtaidistance``) on the Euler-angle frames and on the Lie SRV arrays. The Bandai files
   are CC BY-NC: used here for the benchmark only, never shipped.

Prints markdown tables and writes JSON (default ``benchmarks/results/database.json``) and
the CMU dendrogram ``docs/images/database_dendrogram.png``.

Usage: ``python benchmarks/database.py [--mocap ../shared/mocap] [--quick] [--no-target-run]``

Issue 15, ``--issue15 retrieval``: the retrieval study of ``docs/database.md`` ("Retrieval
quality: protocol and results"). Protocol 2, written down before the new candidates'
accuracies were computed: the 1-second windows (31 CMU, 50 Bandai), N = 32, DP neighbourhood
6, 1-NN leave-one-window-out and mean average precision, DTW on the Euler frames as the
baseline; candidates ``RETRIEVAL_CANDIDATES`` + ``RETRIEVAL_CANDIDATES_2`` (label-free:
balanced pose weight, cyclic matching); reported (1) for the pre-declared hypothesis
``RETRIEVAL_HYPOTHESIS``, (2) by cross-dataset selection (best on CMU reported on Bandai and
the reverse), (3) by nested leave-one-window-out selection inside each dataset and task
(candidate chosen on the windows of the other clips only).

The scale targets of issue 15 (the 1000 x 200-frame all-pairs run at the database defaults,
measured end to end, its energy check against the exact DP, the Dask speed-ups) are in
``benchmarks/database_scale.py`` (also the Dask speed-ups: the JSON's ``speedup`` entry here is
an earlier release's, printed with its date); the ``--issue15 scale, scale10, scale_quality``
sections here run the same pipeline with the earlier benchmark's settings (neighbourhood 6,
tiles of 64) and are kept for comparison with the numbers measured before.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from _common import CMU_CLIPS, write_json
from elastic_motion.apps.database import (
    DatabaseSettings,
    build_srv_cache,
    compute_matrix,
    distance_matrix,
    pair_distance,
    prepare_motion,
    single_threaded_blas,
)
from elastic_motion.apps.database.preparation import same_rest_pose
from elastic_motion.apps.statistics import bandai_labels, cluster, cmu_label, dtw_matrix, knn_evaluate
from elastic_motion.motion import drop_tpose, read_motion, select_frames, to_euler_curve, write_bvh
from elastic_motion.warp import WarpOptions

REPO = Path(__file__).resolve().parents[1]
CMU_TRIALS = 2500


def windows(motion, seconds: float, max_windows: int) -> list:
    """Non-overlapping windows of ``seconds`` (evenly spread), or the whole clip if shorter."""
    w = round(seconds * motion.fps) + 1
    f = motion.n_frames
    if f <= w:
        return [motion]
    n = min(max_windows, (f - 1) // (w - 1))
    starts = np.linspace(0, f - w, n).round().astype(int)
    return [select_frames(motion, slice(s, s + w)) for s in starts]


def cut_windows(paths: list[Path], seconds: float, max_windows: int) -> tuple[list[str], list, list[str]]:
    """Names, window motions and source clip of each window."""
    names, motions, clips = [], [], []
    for p in paths:
        m = drop_tpose(read_motion(p))
        for k, w in enumerate(windows(m, seconds, max_windows)):
            names.append(f"{p.stem}#{k}")
            motions.append(w)
            clips.append(p.stem)
    return names, motions, clips


def fit_exponent(x: list[float], y: list[float]) -> float:
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


def per_pair_seconds(q: list[np.ndarray], spec: WarpOptions, pairs: int, repeat: int = 3) -> float:
    """Median over ``pairs`` pairs of consecutive arrays of ``q`` of the best of ``repeat`` runs."""
    pair_distance(q[0], q[1], spec)  # warm-up (numba)
    with single_threaded_blas():  # as in the tiles (see elastic_motion.apps.database)
        return _per_pair(q, spec, pairs, repeat)


def _per_pair(q: list[np.ndarray], spec: WarpOptions, pairs: int, repeat: int) -> float:
    times = []
    for k in range(pairs):
        a, b = q[k % len(q)], q[(k + 1) % len(q)]
        best = math.inf
        for _ in range(repeat):
            t0 = time.perf_counter()
            pair_distance(a, b, spec)
            best = min(best, time.perf_counter() - t0)
        times.append(best)
    return float(np.median(times))


# --------------------------------------------------------------------------------------------
# 1. Throughput
# --------------------------------------------------------------------------------------------


def throughput(cmu: Path, tmp: Path, n_samples: int, max_windows: int, seconds: float) -> dict:
    """serial (numba's default threads), serial on one thread, local Dask with 2 workers."""
    import numba

    names, motions, _ = cut_windows([cmu / f"{c}.bvh" for c in CMU_CLIPS], seconds, max_windows)
    src = tmp / "windows"
    src.mkdir()
    for n, m in zip(names, motions, strict=True):
        write_bvh(m, src / f"{n.replace('#', '_w')}.bvh")
    out = {"motions": len(names), "n_samples": n_samples, "window_seconds": seconds, "rows": []}
    default_threads = numba.get_num_threads()
    for warp in ("dp", "none"):
        s = DatabaseSettings(n_samples=n_samples, tile_size=8, warp=WarpOptions(method=warp, neighbourhood=6))
        ref = None
        for engine, threads in (("serial", default_threads), ("serial", 1), ("local", 1)):
            dest = tmp / f"out_{warp}_{engine}_{threads}"
            numba.set_num_threads(threads)
            t0 = time.perf_counter()
            res = compute_matrix([src], dest, s, engine=engine, n_workers=2)
            wall = time.perf_counter() - t0
            numba.set_num_threads(default_threads)
            t = res.report["timings"]
            arrays = {r: np.load(dest / f"distances_{r}.npy") for r in ("lie", "euler")}
            if ref is None:
                ref = arrays
            same = all(arrays[r].tobytes() == ref[r].tobytes() for r in arrays)
            out["rows"].append(
                {
                    "warp": warp,
                    "engine": engine,
                    "workers": res.report["workers"],
                    "numba_threads": threads,
                    "pairs": t["pairs_computed"],
                    "tiles_seconds": t["tiles_seconds"],
                    "pairs_per_second": t["pairs_per_second"],
                    "wall_seconds_incl_startup": round(wall, 2),
                    "identical_to_serial": same,
                }
            )
    return out


# --------------------------------------------------------------------------------------------
# 2. Scaling
# --------------------------------------------------------------------------------------------


def scaling(cmu: Path, pairs: int, ns: list[int], joints: list[int], d_n: int) -> dict:
    """Cost against N (whole clips, Lie, D = 78) and against D (the first J joints of the
    skeleton, D = 3 + 3 J; the largest D concatenates the Lie and Euler SRV arrays)."""
    paths = [cmu / f"{c}.bvh" for c in ("07_01", "08_02", "09_11", "107_02_30hz", "108_01_30hz", "49_08")]
    spec = WarpOptions(method="dp", neighbourhood=6)
    rows_n = []
    for n in ns:
        c = build_srv_cache(paths, DatabaseSettings(n_samples=n, representations=("lie",)))
        rows_n.append(
            {"N": n, "D": int(c.q["lie"][0].shape[1]), "seconds": per_pair_seconds(c.q["lie"], spec, pairs)}
        )
    names = read_motion(paths[0]).skeleton.names
    rows_d = []
    for j in joints:
        s = DatabaseSettings(
            n_samples=d_n, representations=("lie", "euler"), joints=tuple(names[:j]), drop_fingers=False
        )
        c = build_srv_cache(paths, s)
        rows_d.append(
            {"N": d_n, "D": int(c.q["lie"][0].shape[1]), "seconds": per_pair_seconds(c.q["lie"], spec, pairs)}
        )
    both = [np.concatenate([a, b], axis=1) for a, b in zip(c.q["lie"], c.q["euler"], strict=True)]
    rows_d.append({"N": d_n, "D": int(both[0].shape[1]), "seconds": per_pair_seconds(both, spec, pairs)})
    half = len(rows_n) // 2
    return {
        "neighbourhood": 6,
        "vs_N": rows_n,
        "vs_D": rows_d,
        "exponent_N": fit_exponent([r["N"] for r in rows_n], [r["seconds"] for r in rows_n]),
        "exponent_N_upper_half": fit_exponent(
            [r["N"] for r in rows_n[half:]], [r["seconds"] for r in rows_n[half:]]
        ),
        "exponent_D": fit_exponent([r["D"] for r in rows_d], [r["seconds"] for r in rows_d]),
    }


def variants_at(cmu: Path, n: int, pairs: int) -> dict:
    """Seconds per pair at N frames for the exact DP and the faster options."""
    paths = [cmu / f"{c}.bvh" for c in ("07_01", "08_02", "09_11", "107_02_30hz", "108_01_30hz", "49_08")]
    c = build_srv_cache(paths, DatabaseSettings(n_samples=n, representations=("lie",)))
    q = c.q["lie"]
    out = {}
    for label, spec in [
        ("dp, neighbourhood 6", WarpOptions("dp", 6)),
        ("dp, neighbourhood 10", WarpOptions("dp", 10)),
        ("dp coarse-to-fine, neighbourhood 4", WarpOptions("dp", 4, coarse_to_fine=True)),
        ("none (no warp)", WarpOptions("none")),
    ]:
        out[label] = per_pair_seconds(q, spec, pairs if spec.method == "dp" else 200)
    return out


# --------------------------------------------------------------------------------------------
# 3. Extrapolation and the target run
# --------------------------------------------------------------------------------------------


def extrapolate(per_pair: dict[int, float], workers: list[int]) -> list[dict]:
    """Hours for the whole CMU database: pairs x single-core seconds per pair / k workers
    (linear scaling: each worker its own core, tiles independent, no shared state)."""
    pairs = CMU_TRIALS * (CMU_TRIALS - 1) // 2
    rows = []
    for n, sec in sorted(per_pair.items()):
        for k in workers:
            rows.append(
                {"N": n, "workers": k, "pairs": pairs, "hours_per_representation": pairs * sec / k / 3600}
            )
    return rows


def target_run(
    cmu: Path,
    tmp: Path,
    m: int,
    n_samples: int,
    warp: str = "none",
    reps: tuple[str, ...] = ("lie", "euler"),
    neighbourhood: int = 6,
) -> dict:
    """Generate ``m`` files of exactly 200 frames (windows of the 120 Hz CMU clips at random
    starts) and run the whole pipeline (read, SRV, all pairs) with ``engine="local"`` (2 workers)."""
    rng = np.random.default_rng(0)
    clips = [drop_tpose(read_motion(cmu / f"{c}.bvh")) for c in CMU_CLIPS]
    clips = [c for c in clips if c.fps == 120 and c.n_frames >= 200]
    src = tmp / f"target_{warp}_{n_samples}"
    src.mkdir()
    t0 = time.perf_counter()
    for k in range(m):
        clip = clips[k % len(clips)]
        s = int(rng.integers(0, clip.n_frames - 200 + 1))
        write_bvh(select_frames(clip, slice(s, s + 200)), src / f"w{k:04d}.bvh")
    t_write = time.perf_counter() - t0
    s = DatabaseSettings(
        n_samples=n_samples,
        tile_size=64,
        representations=reps,
        warp=WarpOptions(method=warp, neighbourhood=neighbourhood),
    )
    t0 = time.perf_counter()
    res = compute_matrix([src], tmp / f"target_out_{warp}_{n_samples}", s, engine="local", n_workers=2)
    wall = time.perf_counter() - t0
    t = res.report["timings"]
    return {
        "motions": m,
        "frames_per_input": 200,
        "n_samples": n_samples,
        "warp": warp,
        "neighbourhood": neighbourhood,
        "representations": list(reps),
        "engine": "local (2 workers)",
        "complete": res.complete,
        "seconds_writing_inputs": round(t_write, 1),
        "seconds_read_and_srv": t["read_seconds"],
        "seconds_tiles": t["tiles_seconds"],
        "seconds_total": round(wall, 1),
        "pairs": t["pairs_computed"],
    }


# --------------------------------------------------------------------------------------------
# 4. Classification
# --------------------------------------------------------------------------------------------


def features(names: list[str], motions: list, n_samples: int) -> tuple[dict, list[np.ndarray]]:
    cache = build_srv_cache(names, DatabaseSettings(n_samples=n_samples), motions=motions)
    if len(cache) != len(names) or len(set(cache.groups.tolist())) != 1:
        raise RuntimeError(f"windows must be readable and share one skeleton; skipped: {cache.skipped}")
    order = [cache.paths.index(n) for n in names]
    q = {r: [cache.q[r][k] for k in order] for r in ("lie", "euler")}
    # the DTW baseline sees the frames the database sees: one rest pose per skeleton
    prep = same_rest_pose(
        [prepare_motion(n, n_samples, motion=m) for n, m in zip(names, motions, strict=True)]
    )
    euler_frames = [to_euler_curve(p.motion).values for p in prep]
    return q, euler_frames


def matrices(q: dict, euler_frames: list[np.ndarray], neighbourhood: int) -> tuple[dict, dict]:
    mats, secs = {}, {}
    for r in ("lie", "euler"):
        for warp in ("dp", "none"):
            t0 = time.perf_counter()
            mats[f"{r} {warp}"] = distance_matrix(q[r], WarpOptions(warp, neighbourhood))
            secs[f"{r} {warp}"] = time.perf_counter() - t0
    for label, feats in (("dtw euler frames", euler_frames), ("dtw lie srv", q["lie"])):
        t0 = time.perf_counter()
        mats[label] = dtw_matrix(feats, parallel=False)
        secs[label] = time.perf_counter() - t0
    return mats, secs


def evaluate(mats: dict, labels: list, blocks: list | None = None, only: set | None = None) -> dict:
    out = {}
    for label, d in mats.items():
        ev = knn_evaluate(d, labels, 1, blocks=blocks)
        if only is not None:
            sel = [i for i, lab in enumerate(labels) if lab in only and ev.predictions[i] is not None]
            acc = float(np.mean([ev.predictions[i] == labels[i] for i in sel])) if sel else float("nan")
            out[label] = {"accuracy": acc, "evaluated": len(sel)}
        else:
            out[label] = {"accuracy": ev.accuracy, "evaluated": ev.n_evaluated, "per_class": ev.per_class}
    return out


def classification(mocap: Path, n_samples: int, max_windows: int, neighbourhood: int) -> dict:
    res: dict = {"n_samples": n_samples, "window_seconds": 1.0, "neighbourhood": neighbourhood}
    # Bandai: content and style
    bandai = sorted((mocap / "bandai").glob("*.bvh"))
    names, motions, clips = cut_windows(bandai, 1.0, max_windows)
    q, ef = features(names, motions, n_samples)
    mats, secs = matrices(q, ef, neighbourhood)
    content = [bandai_labels(c)[0] for c in clips]
    style = [bandai_labels(c)[1] if bandai_labels(c)[0] == "walk" else None for c in clips]
    res["bandai"] = {
        "windows": len(names),
        "clips": len(bandai),
        "seconds": secs,
        "content_loo": evaluate(mats, content),
        "content_chance": max(content.count(c) for c in set(content)) / len(content),
        "style_loo_walks": evaluate(mats, style),
        "style_chance": max(style.count(c) for c in set(style) if c) / sum(1 for s in style if s),
    }
    # CMU: categories
    cmu = [mocap / "cmu" / "bvh" / f"{c}.bvh" for c in CMU_CLIPS]
    names, motions, clips = cut_windows(cmu, 1.0, max_windows)
    q, ef = features(names, motions, n_samples)
    mats, secs = matrices(q, ef, neighbourhood)
    cat = [cmu_label(c) for c in clips]
    res["cmu"] = {
        "windows": len(names),
        "clips": len(cmu),
        "seconds": secs,
        "loo": evaluate(mats, cat),
        "chance": max(cat.count(c) for c in set(cat)) / len(cat),
        "walk_leave_one_clip_out": evaluate(mats, cat, blocks=clips, only={"walk"}),
        "labels": dict(zip(names, cat, strict=True)),
    }
    res["_cmu_for_plot"] = (mats["lie dp"], names, cat)
    return res


# --------------------------------------------------------------------------------------------
# Output
# --------------------------------------------------------------------------------------------


def markdown(r: dict) -> str:
    lines = []
    th = r["throughput"]
    lines += [
        f"### Throughput: {th['motions']} CMU windows of {th['window_seconds']:g} s, N = {th['n_samples']}, "
        "Lie + Euler",
        "",
        "| warp | engine | workers x numba threads | pairs | tile seconds | pairs/s "
        "| wall s (incl. start-up) | = serial |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for row in th["rows"]:
        wt = f"{row['workers']} x {row['numba_threads']}"
        cells = [row["warp"], row["engine"], wt, row["pairs"], f"{row['tiles_seconds']:.2f}"]
        cells += [
            f"{row['pairs_per_second']:.1f}",
            f"{row['wall_seconds_incl_startup']:.1f}",
            row["identical_to_serial"],
        ]
        lines.append("| " + " | ".join(str(c) for c in cells) + " |")
    sc = r["scaling"]
    lines += [
        "",
        "### Seconds per pair (one optimal warp, neighbourhood 6)",
        "",
        "| N | D | ms/pair |",
        "|---|---|---|",
    ]
    for row in sc["vs_N"] + sc["vs_D"]:
        lines.append(f"| {row['N']} | {row['D']} | {1e3 * row['seconds']:.2f} |")
    lines.append(
        f"\nFitted exponents: time ~ N^{sc['exponent_N']:.2f} "
        f"(upper half of N: N^{sc['exponent_N_upper_half']:.2f}), time ~ D^{sc['exponent_D']:.2f}."
    )
    lines += [
        "",
        f"### Per-pair cost at N = {r['target']['N']} (Lie, D = 78)",
        "",
        "| method | ms/pair |",
        "|---|---|",
    ]
    for k, v in r["target"]["per_pair"].items():
        lines.append(f"| {k} | {1e3 * v:.3f} |")
    lines += [
        "",
        f"### Target: 1000 motions x {r['target']['N']} frames all-pairs (499,500 pairs, one representation) "
        f"on 2 workers (measured speed-up {r['speedup_2_workers']:.2f})",
        "",
        "| method | minutes at the measured speed-up | minutes at 2x (linear) | under 10 min |",
        "|---|---|---|---|",
    ]
    for k, v in r["target"]["estimate_minutes"].items():
        lin = r["target"]["estimate_minutes_linear"][k]
        verdict = "yes" if v < 10 else ("only at 2x" if lin < 10 else "no")
        lines.append(f"| {k} | {v:.1f} | {lin:.1f} | {verdict} |")
    for key in ("target_run", "target_run_dp"):
        if r.get(key):
            tr = r[key]
            reps = "+".join(tr["representations"])
            lines.append(
                f"\nMeasured end to end ({tr['motions']} files of {tr.get('frames_per_input', '?')} frames, "
                f"N = {tr['n_samples']}, --warp {tr['warp']}, "
                f"{reps}, {tr['engine']}): read + SRV {tr['seconds_read_and_srv']:.0f} s, "
                f"tiles {tr['seconds_tiles']:.0f} s, total {tr['seconds_total']:.0f} s "
                f"for {tr['pairs']} pairs."
            )
    lines += [
        "",
        f"### Whole CMU database ({CMU_TRIALS} trials, {CMU_TRIALS * (CMU_TRIALS - 1) // 2:,} pairs per "
        "representation), exact DP (neighbourhood 6, one core per worker), minutes, linear in the workers",
        "",
        "| N | " + " | ".join(f"{k} workers" for k in r["extrapolation_workers"]) + " |",
        "|---|" + "---|" * len(r["extrapolation_workers"]),
    ]
    by_n: dict[int, list] = {}
    for row in r["extrapolation"]:
        by_n.setdefault(row["N"], []).append(60 * row["hours_per_representation"])
    for n, ms in by_n.items():
        lines.append(f"| {n} | " + " | ".join(f"{x:.1f}" for x in ms) + " |")
    cl = r["classification"]
    methods = list(cl["cmu"]["loo"])
    lines += [
        "",
        f"### 1-NN accuracy (windows of {cl['window_seconds']:g} s, N = {cl['n_samples']})",
        "",
        "| method | Bandai content (LOO) | Bandai style, walks (LOO) | CMU category (LOO) "
        "| CMU walk, leave one clip out |",
        "|---|---|---|---|---|",
    ]
    b, c = cl["bandai"], cl["cmu"]
    for m in methods:
        lines.append(
            f"| {m} | {b['content_loo'][m]['accuracy']:.3f} | {b['style_loo_walks'][m]['accuracy']:.3f} | "
            f"{c['loo'][m]['accuracy']:.3f} | {c['walk_leave_one_clip_out'][m]['accuracy']:.3f} |"
        )
    lines.append(
        f"| (majority class) | {b['content_chance']:.3f} | {b['style_chance']:.3f} | {c['chance']:.3f} | - |"
    )
    lines.append(
        f"\nBandai: {b['windows']} windows of {b['clips']} clips; CMU: {c['windows']} windows of "
        f"{c['clips']} clips; evaluated: {c['walk_leave_one_clip_out'][methods[0]]['evaluated']} CMU walk "
        "windows leave-one-clip-out."
    )
    return "\n".join(lines)


# --------------------------------------------------------------------------------------------
# Issue 15: retrieval protocol, exact search with bounds, partial matching, PCA, scale
# --------------------------------------------------------------------------------------------

#: The candidate distances of the retrieval study, fixed before any accuracy was looked at
#: (docs/database.md, "Retrieval quality"): Lie SRV variants (root, joint weights, a pose term)
#: and the Euler SRV. Keys: rep (lie/euler), heading (heading-relative root), tscale (factor of
#: the translation weight), jpow (joint weights ** jpow: 0 = uniform), pose (weight of the pose
#: term, or ``"balanced"``: ``preparation.balanced_pose_weight``), cyclic (best cyclic shift:
#: ``distance_matrix(cyclic=True)``).
RETRIEVAL_CANDIDATES = {
    "lie": {},
    "lie, heading-relative root": {"heading": True},
    "lie, translation weight / 4": {"tscale": 0.25},
    "lie, uniform joint weights": {"jpow": 0.0},
    "lie + pose 0.25": {"pose": 0.25},
    "lie + pose 1": {"pose": 1.0},
    "lie + pose 4": {"pose": 4.0},
    "lie, uniform joints + pose 1": {"jpow": 0.0, "pose": 1.0},
    "euler": {"rep": "euler"},
}

#: Protocol 2 (docs/database.md, "Retrieval quality"): candidates added after the diagnosis,
#: fixed before any of their accuracies was computed. All label-free: the pose weight is
#: balanced on the unlabelled windows (``preparation.balanced_pose_weight``), "cyclic" matches
#: every cyclic shift of the window (phase-free, ``distance_matrix(cyclic=True)``).
RETRIEVAL_CANDIDATES_2 = {
    "lie + pose balanced": {"pose": "balanced"},
    "euler + pose balanced": {"rep": "euler", "pose": "balanced"},
    "lie, cyclic": {"cyclic": True},
    "lie + pose balanced, cyclic": {"pose": "balanced", "cyclic": True},
    "euler, cyclic": {"rep": "euler", "cyclic": True},
    "euler + pose balanced, cyclic": {"rep": "euler", "pose": "balanced", "cyclic": True},
    "lie, heading-relative root + pose balanced, cyclic": {
        "heading": True,
        "pose": "balanced",
        "cyclic": True,
    },
}

#: Protocol 2's pre-declared hypothesis (from the diagnosis: the pose term and the gait phase).
RETRIEVAL_HYPOTHESIS = "lie + pose balanced, cyclic"


def srvs_and_poses(prepared: list, spec: dict) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The SRV arrays and the pose arrays (``preparation.pose_arrays``: ``w_j^(1/2) (R_j - I) /
    sqrt(2)`` of the non-root joints on the cells) of prepared windows for one candidate's root
    and weights."""
    from elastic_motion.apps.database.preparation import heading_relative_root, pose_arrays
    from elastic_motion.curves import srv_transform
    from elastic_motion.motion import group_weights, to_lie_curve

    ms = [p.motion for p in prepared]
    if spec.get("heading"):
        ms = [heading_relative_root(m) for m in ms]
    jw, tw = group_weights(ms)
    jw = np.asarray(jw) ** spec.get("jpow", 1.0)
    tw = tw * spec.get("tscale", 1.0)
    srvs, poses = [], []
    for m in ms:
        if spec.get("rep", "lie") == "lie":
            q = srv_transform(to_lie_curve(m, jw, translation_weight=tw)).q
        else:
            q = srv_transform(to_euler_curve(m)).q
        srvs.append(q)
        poses.append(pose_arrays(m, jw))
    return srvs, poses


def candidate_pose_weight(prepared: list, spec: dict) -> float:
    """The weight of the candidate's pose term (``preparation.balanced_pose_weight`` for ``"balanced"``)."""
    from elastic_motion.apps.database.preparation import balanced_pose_weight

    lam = spec.get("pose", 0.0)
    return balanced_pose_weight(*srvs_and_poses(prepared, spec)) if lam == "balanced" else float(lam)


def candidate_srvs(prepared: list, spec: dict) -> list[np.ndarray]:
    """SRV arrays of prepared windows for one candidate of :data:`RETRIEVAL_CANDIDATES` (or
    :data:`RETRIEVAL_CANDIDATES_2`).

    The pose term appends ``sqrt(pose) * w_j^(1/2) * (R_j - I) / sqrt(2)`` of the non-root joints at
    the cell midpoints to the SRV array (the DP then warps it like an SRV component);
    ``pose="balanced"`` takes the weight from ``preparation.balanced_pose_weight`` of these
    windows (no labels)."""
    from elastic_motion.apps.database.preparation import balanced_pose_weight, with_pose_term

    srvs, poses = srvs_and_poses(prepared, spec)
    lam = spec.get("pose", 0.0)
    if lam == "balanced":
        lam = balanced_pose_weight(srvs, poses)
    if not lam:
        return [np.ascontiguousarray(q) for q in srvs]
    return [with_pose_term(q, p, lam) for q, p in zip(srvs, poses, strict=True)]


def cyclic_dtw_matrix(frames: list[np.ndarray]) -> np.ndarray:
    """DTW on the frames with the same best cyclic shift (an informational row, not the baseline)."""
    m = len(frames)
    fs = np.stack(frames)
    best = np.full((m, m), np.inf)
    for s in range(fs.shape[1]):
        d = dtw_matrix(list(fs) + list(np.roll(fs, s, axis=1)), parallel=False)[:m, m:]
        best = np.minimum(best, d)
    np.fill_diagonal(best, 0.0)
    return np.minimum(best, best.T)


def mean_average_precision(d: np.ndarray, labels: list) -> float:
    """Mean over the labelled windows of the average precision of their ranking of the other
    labelled windows (same label = relevant); windows without another of their label skipped."""
    valid = [i for i, lab in enumerate(labels) if lab]
    aps = []
    for i in valid:
        others = [j for j in valid if j != i]
        rel = np.array([labels[j] == labels[i] for j in others])
        if not rel.any():
            continue
        order = np.argsort(d[i, others], kind="stable")
        hits = rel[order]
        prec = np.cumsum(hits) / np.arange(1, len(hits) + 1)
        aps.append(float(prec[hits].mean()))
    return float(np.mean(aps))


def retrieval_windows(mocap: Path, which: str, max_windows: int) -> tuple[list, list, dict]:
    """The 1-second windows of the retrieval protocol and their labels: ``which`` is ``"cmu"``
    (task ``category``) or ``"bandai"`` (``content``; ``style`` of the walks, None else).
    Returns the window names, the motions and the labels per task."""
    paths = (
        sorted((mocap / "bandai").glob("*.bvh"))
        if which == "bandai"
        else [mocap / "cmu" / "bvh" / f"{c}.bvh" for c in CMU_CLIPS]
    )
    names, motions, clips = cut_windows(paths, 1.0, max_windows)
    if which == "cmu":
        return names, motions, {"category": [cmu_label(c) for c in clips]}
    lab = [bandai_labels(c) for c in clips]
    return (
        names,
        motions,
        {
            "content": [x[0] for x in lab],
            "style": [x[1] if x[0] == "walk" else None for x in lab],
        },
    )


def retrieval_matrices(prep: list, neighbourhood: int, candidates: dict) -> dict:
    """Distance matrix of every candidate (the database's pair distances, phase-free with
    ``cyclic``: ``tiles.pair_distances(cyclic=True)``, every cyclic shift of either window)."""
    warp = WarpOptions("dp", neighbourhood)
    return {
        name: distance_matrix(candidate_srvs(prep, spec), warp, cyclic=bool(spec.get("cyclic")))
        for name, spec in candidates.items()
    }


def library_matrix(names: list, motions: list, n_samples: int, neighbourhood: int) -> np.ndarray:
    """The hypothesis through the database's own path, as ``elastic-motion matrix --pose-weight
    balanced --cyclic`` computes it: ``build_srv_cache`` (pose term appended with the balanced
    weight of the group) and ``distance_matrix(cyclic=True)``; the windows in input order."""
    settings = DatabaseSettings(
        n_samples=n_samples,
        representations=("lie",),
        warp=WarpOptions("dp", neighbourhood),
        pose_weight="balanced",
        cyclic=True,
    )
    cache = build_srv_cache(names, settings, motions=motions)
    assert cache.names == names and len(cache.pose_weights["lie"]) == 1, "one skeleton, input order"
    return distance_matrix(cache.q["lie"], settings.warp, cyclic=True)


def retrieval_accuracies(prep: list, tasks: dict, neighbourhood: int, candidates: dict | None = None) -> dict:
    """1-NN accuracy per task of every candidate distance (default :data:`RETRIEVAL_CANDIDATES`)
    and of DTW on the Euler frames, for prepared windows."""
    mats = retrieval_matrices(prep, neighbourhood, RETRIEVAL_CANDIDATES if candidates is None else candidates)
    mats["dtw (euler frames)"] = dtw_matrix([to_euler_curve(p.motion).values for p in prep], parallel=False)
    return {n: {t: knn_evaluate(d, y, 1).accuracy for t, y in tasks.items()} for n, d in mats.items()}


def _inner_score(d: np.ndarray, labels: list) -> tuple[float, float]:
    return knn_evaluate(d, labels, 1).accuracy, mean_average_precision(d, labels)


def nested_selection(mats: dict, labels: list, clips: list, candidates: list) -> dict:
    """Nested leave-one-window-out: for each labelled window ``i``, every candidate is scored
    on the windows of the *other clips* only (1-NN leave-one-out accuracy, ties by mean
    average precision, then list order); the best classifies ``i`` against all other windows."""
    valid = [i for i, lab in enumerate(labels) if lab]
    correct, picks = [], {}
    for i in valid:
        inner = [k for k in range(len(labels)) if clips[k] != clips[i]]
        sub = [labels[k] for k in inner]
        scores = {c: _inner_score(mats[c][np.ix_(inner, inner)], sub) for c in candidates}
        pick = max(candidates, key=lambda c: (*scores[c], -candidates.index(c)))
        picks[pick] = picks.get(pick, 0) + 1
        row = mats[pick][i].copy()
        row[i] = np.inf
        row[[k for k in range(len(labels)) if not labels[k]]] = np.inf
        correct.append(labels[int(np.argmin(row))] == labels[i])
    return {"accuracy": float(np.mean(correct)), "evaluated": len(correct), "picks": picks}


def retrieval(mocap: Path, n_samples: int = 32, max_windows: int = 6, neighbourhood: int = 6) -> dict:
    """Protocol 2 (docs/database.md, "Retrieval quality"; fixed before the new candidates'
    accuracies were computed): the windows, metrics and DTW baseline of protocol 1, the
    candidates of :data:`RETRIEVAL_CANDIDATES` and :data:`RETRIEVAL_CANDIDATES_2`, reported

    1. the pre-declared hypothesis :data:`RETRIEVAL_HYPOTHESIS` as it is;
    2. cross-dataset selection: the candidate with the best CMU category accuracy is reported
       on Bandai, the best on Bandai (mean of content and style) on CMU (ties: mean average
       precision, then list order);
    3. nested leave-one-window-out inside each dataset and task (:func:`nested_selection`).

    1-NN leave-one-window-out accuracy and mean average precision (:func:`mean_average_precision`)
    per task; ceilings: the windows whose label no other window has can never be right."""
    cands = {**RETRIEVAL_CANDIDATES, **RETRIEVAL_CANDIDATES_2}
    names_c = list(cands)
    data = {}
    for which in ("cmu", "bandai"):
        names, motions, tasks = retrieval_windows(mocap, which, max_windows)
        clips = [n.split("#")[0] for n in names]
        # one rest pose per skeleton, as the database prepares them (CMU mixes two conversions)
        prep = same_rest_pose(
            [prepare_motion(n, n_samples, motion=m) for n, m in zip(names, motions, strict=True)]
        )
        mats = retrieval_matrices(prep, neighbourhood, cands)
        frames = [to_euler_curve(p.motion).values for p in prep]
        mats["dtw (euler frames)"] = dtw_matrix(frames, parallel=False)
        mats["dtw, cyclic (not a candidate)"] = cyclic_dtw_matrix(frames)
        lib = library_matrix(names, motions, n_samples, neighbourhood)
        lib_diff = float(np.max(np.abs(lib - mats[RETRIEVAL_HYPOTHESIS])))
        lams = {n: candidate_pose_weight(prep, sp) for n, sp in cands.items() if sp.get("pose") == "balanced"}
        data[which] = {
            "windows": len(prep),
            "clips": len(set(clips)),
            "ceiling": {
                t: sum(1 for lab in y if lab and y.count(lab) > 1) / sum(1 for lab in y if lab)
                for t, y in tasks.items()
            },
            "balanced_pose_weight": lams,
            "library_max_abs_difference": lib_diff,
            "accuracy": {
                n: {t: knn_evaluate(d, y, 1).accuracy for t, y in tasks.items()} for n, d in mats.items()
            },
            "map": {n: {t: mean_average_precision(d, y) for t, y in tasks.items()} for n, d in mats.items()},
            "nested": {t: nested_selection(mats, y, clips, names_c) for t, y in tasks.items()},
        }

    def score(which: str, name: str) -> tuple:
        acc, mp = data[which]["accuracy"][name], data[which]["map"][name]
        return float(np.mean(list(acc.values()))), float(np.mean(list(mp.values())))

    pick_cmu = max(names_c, key=lambda c: (*score("cmu", c), -names_c.index(c)))
    pick_bandai = max(names_c, key=lambda c: (*score("bandai", c), -names_c.index(c)))
    return {
        "protocol": "protocol 2 (docs/database.md): hypothesis, cross-dataset selection, nested "
        "leave-one-window-out selection; 1-NN leave-one-window-out, 1-s windows",
        "n_samples": n_samples,
        "neighbourhood": neighbourhood,
        "candidates_1": list(RETRIEVAL_CANDIDATES),
        "candidates_2": list(RETRIEVAL_CANDIDATES_2),
        "hypothesis": RETRIEVAL_HYPOTHESIS,
        "data": data,
        "picked_on_cmu": pick_cmu,
        "reported_on_bandai": data["bandai"]["accuracy"][pick_cmu],
        "picked_on_bandai": pick_bandai,
        "reported_on_cmu": data["cmu"]["accuracy"][pick_bandai],
    }


def search_bench(mocap: Path, tmp: Path, n_samples: int = 32, max_windows: int = 16) -> dict:
    """Exact k-NN with bounds against brute force: every CMU + Bandai window as a query in turn
    (an index of all windows), k = 1 and 5."""
    from elastic_motion.apps.database import build_index, knn_search, query_distances

    src = tmp / "search_windows"
    src.mkdir()
    paths = [mocap / "cmu" / "bvh" / f"{c}.bvh" for c in CMU_CLIPS] + sorted((mocap / "bandai").glob("*.bvh"))
    names, motions, _ = cut_windows(paths, 1.0, max_windows)
    files = []
    for n, m in zip(names, motions, strict=True):
        files.append(write_bvh(m, src / f"{n.replace('#', '_w')}.bvh"))
    idx = tmp / "search_index"
    s = DatabaseSettings(n_samples=n_samples, representations=("lie",), warp=WarpOptions("dp", 6))
    t0 = time.perf_counter()
    build_index([src], idx, s)
    t_index = time.perf_counter() - t0
    rows = []
    for k in (1, 5):
        same, pruned, t_knn, t_brute = 0, [], 0.0, 0.0
        queries = files[:: max(1, len(files) // 40)]
        for q in queries:
            t0 = time.perf_counter()
            r = knn_search(q, idx, k)
            t_knn += time.perf_counter() - t0
            t0 = time.perf_counter()
            b = query_distances(q, idx)
            t_brute += time.perf_counter() - t0
            want = b.nearest(k)
            same += int(
                r.indices.tolist() == want.tolist() and r.distances.tolist() == b.distances[want].tolist()
            )
            pruned.append(r.fraction_pruned)
        rows.append(
            {
                "k": k,
                "queries": len(queries),
                "database": len(files),
                "equal_to_brute_force": same,
                "fraction_pruned_mean": float(np.mean(pruned)),
                "fraction_pruned_min": float(np.min(pruned)),
                "seconds_per_query_knn": t_knn / len(queries),
                "seconds_per_query_brute": t_brute / len(queries),
            }
        )
    return {"n_samples": n_samples, "seconds_index": t_index, "rows": rows}


def partial_bench(mocap: Path, tmp: Path) -> dict:
    """Partial matching on the longest takes (01_01: 2752 frames, 55_01: 1807): queries cut
    from them (found back?), the 49_08 cartwheel and a 107_02 turn against them."""
    from elastic_motion.apps.database import find_within

    cmu = mocap / "cmu" / "bvh"
    takes = [cmu / "01_01.bvh", cmu / "55_01.bvh", cmu / "107_02_30hz.bvh", cmu / "49_08.bvh"]
    queries = []
    for clip, a, b in (
        ("01_01", 1200, 1440),
        ("55_01", 600, 900),
        ("49_08", 100, 340),
        ("107_02_30hz", 80, 120),
    ):
        m = drop_tpose(read_motion(cmu / f"{clip}.bvh"))
        f = tmp / f"q_{clip}_{a}_{b}.bvh"
        write_bvh(select_frames(m, slice(a, b + 1)), f)
        queries.append((f, clip, a / m.fps, b / m.fps))
    rows = []
    for f, clip, a, b in queries:
        t0 = time.perf_counter()
        res = find_within(f, takes, n_samples=48, neighbourhood=4)
        wall = time.perf_counter() - t0
        best = res.matches[0]
        rows.append(
            {
                "query": f.stem,
                "cut_from": clip,
                "cut_seconds": [round(a, 3), round(b, 3)],
                "best": best.name,
                "best_seconds": [round(best.start, 3), round(best.stop, 3)],
                "best_distance": best.distance,
                "second": res.matches[1].name,
                "second_distance": res.matches[1].distance,
                "seconds_total": wall,
                "seconds_dp": res.seconds,
            }
        )
    return {"takes": [t.name for t in takes], "rows": rows}


def pca_bench(mocap: Path, tmp: Path) -> dict:
    from elastic_motion.apps.pca import motion_pca, write_modes

    out = {}
    sets = {
        "bandai styled walks": sorted((mocap / "bandai").glob("dataset-1_walk_*.bvh")),
        "cmu walks": [
            mocap / "cmu" / "bvh" / f"{c}.bvh" for c in ("07_01", "08_02", "107_02_30hz", "108_01_30hz")
        ],
    }
    for name, files in sets.items():
        t0 = time.perf_counter()
        model = motion_pca(files, n_samples=48, warp=WarpOptions("dp", 6))
        paths = write_modes(model, tmp / name.replace(" ", "_"), n_modes=2)
        out[name] = {
            "files": len(files),
            "explained": model.explained.tolist(),
            "sigmas": model.sigmas.tolist(),
            "karcher_energies": model.karcher_energies.tolist(),
            "seconds": time.perf_counter() - t0,
            "bvh_written": len(paths),
        }
    return out


def scale_quality(cmu: Path, tmp: Path, pairs: int = 200, n_samples: int = 64) -> dict:
    """Energy of the scale run's pair distance (DP, neighbourhood 6, N = 64) above finer solves of
    the same SRV arrays, on a sample of pairs of 200-frame windows: the DP with neighbourhood 10
    (the library's default) and the DP refined off the grid (``dp+refine``)."""
    rng = np.random.default_rng(2)
    clips = [drop_tpose(read_motion(cmu / f"{c}.bvh")) for c in CMU_CLIPS]
    clips = [c for c in clips if c.fps == 120 and c.n_frames >= 200]
    names, motions = [], []
    for k in range(2 * pairs):
        clip = clips[k % len(clips)]
        s = int(rng.integers(0, clip.n_frames - 200 + 1))
        names.append(f"w{k}")
        motions.append(select_frames(clip, slice(s, s + 200)))
    cache = build_srv_cache(
        names, DatabaseSettings(n_samples=n_samples, representations=("lie",)), motions=motions
    )
    q = cache.q["lie"]
    from elastic_motion.warp import optimal_warp

    excess: dict[str, list[float]] = {"dp, neighbourhood 10": [], "dp+refine, neighbourhood 6": []}
    with single_threaded_blas():
        for k in range(pairs):
            a, b = q[2 * k], q[2 * k + 1]
            e6 = optimal_warp(a, b, method="dp", neighbourhood=6).energy
            e10 = optimal_warp(a, b, method="dp", neighbourhood=10).energy
            er = optimal_warp(a, b, method="dp+refine", neighbourhood=6).energy
            excess["dp, neighbourhood 10"].append(e6 / e10 - 1.0)
            excess["dp+refine, neighbourhood 6"].append(e6 / er - 1.0)
    return {
        "pairs": pairs,
        "n_samples": n_samples,
        "energy_excess": {
            k: {
                "median": float(np.median(v)),
                "p99": float(np.quantile(v, 0.99)),
                "max": float(np.max(v)),
                "share_over_0.1%": float(np.mean(np.array(v) > 1e-3)),
            }
            for k, v in excess.items()
        },
    }


def issue15(args, cmu: Path) -> dict:
    """The issue-15 sections (``--issue15 SECTION,...``)."""
    out_path = args.out.with_name("database_issue15.json")
    result = json.loads(out_path.read_text()) if out_path.exists() else {}
    tmp = Path(tempfile.mkdtemp(prefix="em-db-15-"))
    try:
        for section in args.issue15.split(","):
            t0 = time.perf_counter()
            if section == "retrieval":
                result["retrieval"] = retrieval(args.mocap)
            elif section == "search":
                result["search"] = search_bench(args.mocap, tmp)
            elif section == "partial":
                result["partial"] = partial_bench(args.mocap, tmp)
            elif section == "pca":
                result["pca"] = pca_bench(args.mocap, tmp)
            elif section == "scale_quality":
                result["scale_quality"] = scale_quality(cmu, tmp)
            elif section == "scale10":
                result["scale_1000x200_nb10"] = target_run(
                    cmu, tmp, m=1000, n_samples=64, warp="dp", reps=("lie",), neighbourhood=10
                )
            elif section == "scale":
                result["scale_1000x200"] = target_run(
                    cmu, tmp, m=1000, n_samples=64, warp="dp", reps=("lie",)
                )
            else:
                raise SystemExit(f"--issue15: unknown section {section!r}")
            result.setdefault("meta", {})[section] = {
                "seconds": round(time.perf_counter() - t0, 1),
                "load_average_after": os.getloadavg(),
                "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
            }
            write_json(out_path, result)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(markdown15(result))
    return result


def markdown15(r: dict) -> str:
    lines = []
    if "retrieval" in r:
        rt = r["retrieval"]
        c, b = rt["data"]["cmu"], rt["data"]["bandai"]
        lines += [
            f"### Retrieval ({rt['protocol']}; N = {rt['n_samples']}, "
            f"DP neighbourhood {rt['neighbourhood']})",
            "",
            "1-NN accuracy (mean average precision); * = protocol 2's new candidates.",
            "",
            "| distance | CMU category | Bandai content | Bandai style (walks) |",
            "|---|---|---|---|",
        ]
        for name in c["accuracy"]:
            star = " *" if name in rt.get("candidates_2", ()) else ""
            lines.append(
                f"| {name}{star} | "
                f"{c['accuracy'][name]['category']:.3f} ({c['map'][name]['category']:.3f}) | "
                f"{b['accuracy'][name]['content']:.3f} ({b['map'][name]['content']:.3f}) | "
                f"{b['accuracy'][name]['style']:.3f} ({b['map'][name]['style']:.3f}) |"
            )
        lines.append(
            f"| ceiling | {c['ceiling']['category']:.3f} | {b['ceiling']['content']:.3f} | "
            f"{b['ceiling']['style']:.3f} |"
        )
        n = {**c["nested"], **b["nested"]}
        lines.append(
            f"| nested selection | {n['category']['accuracy']:.3f} | {n['content']['accuracy']:.3f} | "
            f"{n['style']['accuracy']:.3f} |"
        )
        lines.append(
            f"\nWindows: CMU {c['windows']} of {c['clips']} clips, Bandai {b['windows']} of {b['clips']} "
            f"clips. Hypothesis: **{rt['hypothesis']}**. Picked on CMU: **{rt['picked_on_cmu']}** -> "
            f"Bandai content {rt['reported_on_bandai']['content']:.3f}, style "
            f"{rt['reported_on_bandai']['style']:.3f}. Picked on Bandai: **{rt['picked_on_bandai']}** -> "
            f"CMU {rt['reported_on_cmu']['category']:.3f}. Nested picks: "
            + "; ".join(f"{t}: {v['picks']}" for t, v in n.items())
            + ". Balanced pose weights: CMU "
            + ", ".join(f"{k} {v:.2f}" for k, v in c["balanced_pose_weight"].items())
            + "; Bandai "
            + ", ".join(f"{k} {v:.2f}" for k, v in b["balanced_pose_weight"].items())
            + f". The hypothesis through the database's path (`--pose-weight balanced --cyclic`): "
            f"largest difference {c['library_max_abs_difference']:.1e} (CMU), "
            f"{b['library_max_abs_difference']:.1e} (Bandai)."
        )
    if "search" in r:
        lines += [
            "",
            f"### Exact k-NN search with bounds (index build {r['search']['seconds_index']:.1f} s)",
            "",
            "| k | queries | database | = brute force | pruned (mean / min) | s/query k-NN | s/query brute |",
            "|---|---|---|---|---|---|---|",
        ]
        for x in r["search"]["rows"]:
            lines.append(
                f"| {x['k']} | {x['queries']} | {x['database']} | "
                f"{x['equal_to_brute_force']}/{x['queries']} | "
                f"{x['fraction_pruned_mean']:.2f} / {x['fraction_pruned_min']:.2f} | "
                f"{x['seconds_per_query_knn']:.3f} | "
                f"{x['seconds_per_query_brute']:.3f} |"
            )
    if "partial" in r:
        lines += [
            "",
            f"### Partial matching (takes: {', '.join(r['partial']['takes'])})",
            "",
            "| query (cut from, s) | best take (s) | distance | runner-up (distance) | s total (DP) |",
            "|---|---|---|---|---|",
        ]
        for x in r["partial"]["rows"]:
            lines.append(
                f"| {x['cut_from']} {x['cut_seconds'][0]:.2f}-{x['cut_seconds'][1]:.2f} | {x['best']} "
                f"{x['best_seconds'][0]:.2f}-{x['best_seconds'][1]:.2f} | {x['best_distance']:.3f} | "
                f"{x['second']} ({x['second_distance']:.3f}) | "
                f"{x['seconds_total']:.2f} ({x['seconds_dp']:.2f}) |"
            )
    if "pca" in r:
        lines += [
            "",
            "### PCA of aligned motions (variance explained by the first modes)",
            "",
            "| set | files | mode 1 | mode 2 | mode 3 | Karcher energy first -> last |",
            "|---|---|---|---|---|---|",
        ]
        for name, x in r["pca"].items():
            e = x["explained"] + [float("nan")] * 3
            lines.append(
                f"| {name} | {x['files']} | {e[0]:.3f} | {e[1]:.3f} | {e[2]:.3f} | "
                f"{x['karcher_energies'][0]:.3f} -> {x['karcher_energies'][-1]:.3f} |"
            )
    if "speedup" in r:
        sp = r["speedup"]
        lines += [
            "",
            f"### Dask speed-up ({sp['motions']} windows of 200 frames, {sp['pairs']} pairs, "
            f"N = {sp['n_samples']}; earlier settings and release, measured "
            f"{r.get('meta', {}).get('speedup', {}).get('date', '?')}: the current numbers are "
            "`benchmarks/database_scale.py`'s)",
            "",
            "| engine | seconds | speed-up |",
            "|---|---|---|",
        ]
        for k, v in sp["seconds"].items():
            lines.append(f"| {k} | {v:.1f} | {sp['speedup'][k]:.2f} |")
    if "scale_quality" in r:
        sq = r["scale_quality"]
        lines += [
            "",
            f"### Energy of the scale run's DP above finer solves ({sq['pairs']} pairs, "
            f"N = {sq['n_samples']})",
            "",
            "| reference | median | p99 | max | share > 0.1 % |",
            "|---|---|---|---|---|",
        ]
        for k, v in sq["energy_excess"].items():
            lines.append(
                f"| {k} | {100 * v['median']:.3f} % | {100 * v['p99']:.3f} % | {100 * v['max']:.3f} % | "
                f"{100 * v['share_over_0.1%']:.1f} % |"
            )
    for key, sec in (("scale_1000x200", "scale"), ("scale_1000x200_nb10", "scale10")):
        if key not in r:
            continue
        tr = r[key]
        meta = r.get("meta", {}).get(sec, {})
        lines.append(
            f"\n1000 x 200 all pairs (earlier settings and release, {meta.get('date', '?')}; current: "
            f"benchmarks/database_scale.py; measured, N = {tr['n_samples']}, DP neighbourhood "
            f"{tr.get('neighbourhood', 6)}, Lie, {tr['engine']}): read + SRV "
            f"{tr['seconds_read_and_srv']:.0f} s, tiles {tr['seconds_tiles']:.0f} s, "
            f"total {tr['seconds_total']:.0f} s "
            f"for {tr['pairs']} pairs (load average after: {meta.get('load_average_after')})."
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--mocap",
        type=Path,
        default=Path(os.environ.get("ELASTIC_MOTION_MOCAP", REPO.parent / "shared" / "mocap")),
    )
    parser.add_argument("--quick", action="store_true", help="smaller sizes (a smoke test of the script)")
    parser.add_argument("--markdown", action="store_true", help="only print the tables of the existing JSON")
    parser.add_argument("--no-target-run", action="store_true", help="skip the 1000-file --warp none run")
    parser.add_argument(
        "--target-dp-run",
        action="store_true",
        help="only run the 1000-file DP run (Lie, N = 64, local) and add it to the existing JSON (~10 min)",
    )
    parser.add_argument(
        "--issue15",
        default=None,
        metavar="SECTIONS",
        help="only these issue-15 sections, comma-separated: retrieval, search, partial, pca, "
        "scale, scale_quality (written to database_issue15.json beside --out)",
    )
    parser.add_argument("--out", type=Path, default=REPO / "benchmarks" / "results" / "database.json")
    parser.add_argument("--plot", type=Path, default=REPO / "docs" / "images" / "database_dendrogram.png")
    args = parser.parse_args()
    cmu = args.mocap / "cmu" / "bvh"
    q = args.quick
    result: dict = {
        "machine": {
            "cpus": os.cpu_count(),
            "platform": platform.platform(),
            "python": platform.python_version(),
        },
        "quick": q,
    }
    if args.markdown:
        print(markdown(json.loads(args.out.read_text())))
        return
    if args.issue15:
        issue15(args, cmu)
        return
    tmp = Path(tempfile.mkdtemp(prefix="em-db-bench-"))
    if args.target_dp_run:
        try:
            result = json.loads(args.out.read_text())
            result["target_run_dp"] = target_run(cmu, tmp, m=1000, n_samples=64, warp="dp", reps=("lie",))
            result["target_run_dp"]["load_average_after"] = os.getloadavg()
            result["target_run_dp"]["date"] = time.strftime("%Y-%m-%d %H:%M")
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        write_json(args.out, result)
        print(markdown(result))
        return
    try:
        t0 = time.perf_counter()
        result["throughput"] = throughput(
            cmu, tmp, n_samples=32 if q else 200, max_windows=2 if q else 16, seconds=1.0
        )
        rows = {(r["warp"], r["engine"], r["numba_threads"]): r for r in result["throughput"]["rows"]}
        speedup = rows[("dp", "local", 1)]["pairs_per_second"] / rows[("dp", "serial", 1)]["pairs_per_second"]
        result["speedup_2_workers"] = speedup
        result["efficiency_2_workers"] = min(1.0, speedup / 2)
        import numba

        numba.set_num_threads(1)  # per-pair costs below: one core
        result["scaling"] = scaling(
            cmu,
            pairs=3 if q else 10,
            ns=[16, 32, 64] if q else [16, 32, 64, 128, 256, 512],
            joints=[1, 4, 25] if q else [1, 2, 4, 10, 25],
            d_n=32 if q else 128,
        )
        target_n = 64 if q else 200
        per_pair = variants_at(cmu, target_n, pairs=2 if q else 6)
        pairs_1000 = 1000 * 999 // 2
        result["target"] = {
            "N": target_n,
            "per_pair": per_pair,
            # two workers at the measured speed-up over one single-threaded process
            "estimate_minutes": {k: pairs_1000 * v / max(speedup, 1e-9) / 60 for k, v in per_pair.items()},
            "estimate_minutes_linear": {k: pairs_1000 * v / 2 / 60 for k, v in per_pair.items()},
        }
        n64 = next(row["seconds"] for row in result["scaling"]["vs_N"] if row["N"] == 64)
        result["target"]["per_pair"]["dp, neighbourhood 6, resampled to N = 64"] = n64
        result["target"]["estimate_minutes"]["dp, neighbourhood 6, resampled to N = 64"] = (
            pairs_1000 * n64 / max(speedup, 1e-9) / 60
        )
        result["target"]["estimate_minutes_linear"]["dp, neighbourhood 6, resampled to N = 64"] = (
            pairs_1000 * n64 / 2 / 60
        )
        if not args.no_target_run:
            result["target_run"] = target_run(cmu, tmp, m=100 if q else 1000, n_samples=target_n)
        per_n = {row["N"]: row["seconds"] for row in result["scaling"]["vs_N"] if row["N"] in (64, 128)}
        per_n[target_n] = per_pair["dp, neighbourhood 6"]
        result["extrapolation_workers"] = [1, 2, 8, 32, 128]
        result["extrapolation"] = extrapolate(per_n, result["extrapolation_workers"])
        result["classification"] = classification(
            args.mocap, n_samples=24 if q else 32, max_windows=2 if q else 6, neighbourhood=6
        )
        d, names, cat = result["classification"].pop("_cmu_for_plot")
        if not q:
            from elastic_motion.apps.plots_database import plot_dendrogram

            args.plot.parent.mkdir(parents=True, exist_ok=True)
            plot_dendrogram(
                cluster(d, names),
                args.plot,
                colors=cat,
                title="CMU 1-s windows, Lie elastic distance (DP), average linkage",
            )
            result["dendrogram"] = (
                os.fspath(args.plot.relative_to(REPO))
                if args.plot.is_relative_to(REPO)
                else os.fspath(args.plot)
            )
        result["seconds_total"] = round(time.perf_counter() - t0, 1)
        result["load_average_at_end"] = os.getloadavg()
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if args.out.exists() and not q:  # keep the (slow, separately run) DP target run
        old = json.loads(args.out.read_text())
        if "target_run_dp" in old:
            result["target_run_dp"] = old["target_run_dp"]
    print(markdown(result))
    write_json(args.out, result)
    print(f"\nwritten {args.out}")


if __name__ == "__main__":
    main()
