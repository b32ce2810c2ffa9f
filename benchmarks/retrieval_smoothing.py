"""Does a Gaussian low-pass before sampling help the elastic distance? Before / after numbers.

The SRV ``q = v / sqrt|v|`` is a derivative: sampled at 30 fps without a low-pass, what lies
above the Nyquist frequency of the sampled curve, and the choice of the sampling instants,
show in the distance. The candidate fix is :func:`elastic_motion.motion.edit.smooth_motion`
before the curve is sampled, with ``sigma = c / 30`` seconds at the default 30 fps (``c =
0.5`` sampled frames, 1/60 s, the usual anti-aliasing choice, fixed before any number here
was seen; ``c = 1`` is reported beside it as a sensitivity check only, never selected on).
The library's option ``WarpOptions.sample_smoothing`` is this ``sigma`` in seconds.

Sections
--------
* ``reparam``: **reparametrisation noise**. Each clip ``A`` (prepared as every app does,
  :func:`elastic_motion.apps.prepare.prepare_motions`, curve joints, Lie curve) against
  itself replayed on a clock shifted by half a sampled frame: the (smoothed) motion sampled
  at ``0, dt/2, 3 dt/2, ..., T`` instead of ``0, dt, 2 dt, ..., T`` (``dt = 1 / 30`` s or the
  clip's own frame time if longer). That is a pure reparametrisation (elastic distance 0 in
  the continuum). Distances by ``optimal_warp`` with the default ``WarpOptions()``
  (dp+refine), as ``distance_table``. Relative to the clip's SRV norm ``||q_A||`` and, for
  the blend pairs, to ``d(A, B) / 2`` measured with the same smoothing. Then, through
  ``distance_table`` itself (the library's path, ``warp="dp"``), 120 Hz CMU clips against
  themselves shifted by 2 source frames (half a 30 fps frame: other sampling instants) and
  by 4 (a whole frame: the same instants; what is left is the 1/30 s cut at each end).
  Last, ``d(A, B)`` of the rhythm pair (120 Hz) sampled at 15, 30, 60 and 120 fps: without
  low-pass, with ``c = 0.5`` sampled frames, and with ``sigma`` fixed at 1/60 s.
* ``retrieval``: the retrieval protocol of ``docs/database.md`` ("Retrieval quality":
  1-NN leave-one-window-out on 1-s windows, N = 32, DP neighbourhood 6, the fixed candidate
  list ``RETRIEVAL_CANDIDATES`` of ``benchmarks/database.py``, cross-dataset selection, DTW
  on the Euler frames as baseline), run once as it is and once with every window
  low-passed by ``smooth_motion(window, c * duration / N)`` before the database's
  preparation (``prepare_motion``: its steps are rigid or per-joint and commute with the
  low-pass, so this equals smoothing just before its resampling). DTW is reported on the
  unsmoothed frames (the baseline) and on the smoothed ones.
* ``prepare``: what the low-pass costs a database: every CMU BVH and Bandai clip prepared on
  64 cells (``apps.database.preparation.prepare_motion``) without it, with it on the frames
  its geodesic resample reads (the library: ``smooth_motion(frames=frames_read_at_times(...))``)
  and with it on every frame (before); best of 3 runs, seconds, and whether the last two give
  the same arrays bit for bit.
* ``blend``: runs ``benchmarks/blend_quality.py`` (``--only`` passed through) with the
  library's default ``sample_smoothing`` set to ``--sigma`` seconds for this process only
  (the defaults of ``WarpOptions`` and ``motion_curves``), so the blend's warp and the
  distances of its table see the smoothed curves; ``--sigma 0`` is the behaviour before
  the low-pass.

Usage::

    python benchmarks/retrieval_smoothing.py reparam
    python benchmarks/retrieval_smoothing.py retrieval
    python benchmarks/retrieval_smoothing.py prepare
    python benchmarks/retrieval_smoothing.py blend --sigma 0.016667 --only obstacles,rhythm

Writes ``benchmarks/results/retrieval_smoothing_<section>.json``. Data:
``$ELASTIC_MOTION_MOCAP`` or ``../shared/mocap``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

from _common import MOCAP, RESULTS, load_clip, machine_info, write_json
from elastic_motion.apps.align import motion_curves
from elastic_motion.apps.distance import distance_table
from elastic_motion.apps.prepare import PreparedMotions, PrepareOptions, prepare_motions
from elastic_motion.curves import DiscreteCurve, srv_transform
from elastic_motion.motion import (
    drop_tpose,
    read_motion,
    resample_at_times,
    select_frames,
    to_lie_curve,
)
from elastic_motion.motion.edit import smooth_motion
from elastic_motion.warp import WarpOptions, optimal_warp

REPO = Path(__file__).resolve().parents[1]
#: Standard deviations in frames at 30 fps (sigma = c / 30 s): 0 (none), 0.5 (the default, 1/60 s), 1.
LEVELS = (0.0, 0.5, 1.0)
FPS = WarpOptions().sample_fps

#: The blend pairs of ``blend_quality.py`` (same trims), for d(A, B) / 2.
PAIRS = {
    "obstacles": (("cmu/bvh/107_02_30hz.bvh", 1.0, 3.4, True), ("cmu/bvh/108_01_30hz.bvh", 1.3, 4.8, True)),
    "rhythm": (("cmu/bvh/07_01.bvh", None, None, True), ("cmu/bvh/08_02.bvh", None, None, True)),
    "start_walk_stop": (("cmu/bvh/131_01.bvh", None, None, False), ("cmu/bvh/131_02.bvh", None, None, False)),
    "deepmimic_walk_run": (
        ("deepmimic/humanoid3d_walk.txt", None, None, False),
        ("deepmimic/humanoid3d_run.txt", None, None, False),
    ),
    "bandai_normal_tired": (
        ("bandai/dataset-1_walk_normal_001.bvh", None, None, False),
        ("bandai/dataset-1_walk_tired_001.bvh", None, None, False),
    ),
}


def _distance(x: DiscreteCurve, y: DiscreteCurve) -> float:
    sx, sy = srv_transform(x), srv_transform(y)
    return float(optimal_warp(sx.q, sy.q, t0=sx.t, t1=sy.t, **WarpOptions().solver_kwargs()).distance)


def shifted_replay(prep: PreparedMotions, k: int, smoothing: float, fps: float = FPS) -> tuple:
    """Motion ``k``'s Lie curve as ``motion_curves`` samples it (low-pass ``smoothing``
    seconds), and the same smoothed motion replayed on a clock shifted by half a sampled
    frame (module docstring)."""
    (curve,) = motion_curves(prep, "lie", fps=fps, which=[k], smoothing=smoothing)
    m = prep.curve_motion(k)
    rate = min(fps, m.fps)
    if smoothing > 0:
        m = smooth_motion(m, smoothing)
    n = math.floor(m.duration * rate + 1e-6)
    times = np.concatenate([[0.0], (np.arange(n) + 0.5) / rate, [m.duration]])
    times = np.unique(np.clip(times, 0.0, m.duration))
    replay = resample_at_times(m, m.times, times, fps=rate)
    return curve, to_lie_curve(replay, prep.joint_weights, translation_weight=prep.translation_weight)


def reparam() -> dict:
    out: dict = {"levels": LEVELS, "sample_fps": FPS, "pairs": {}}
    for key, (sa, sb) in PAIRS.items():
        prep = prepare_motions(
            [load_clip(*sa), load_clip(*sb)], PrepareOptions(joints="common", drop_tpose=False)
        )
        row: dict = {}
        for c in LEVELS:
            curves = motion_curves(prep, "lie", fps=FPS, smoothing=c / FPS)
            d_ab = _distance(*curves)
            per = []
            for k in range(2):
                a, a2 = shifted_replay(prep, k, c / FPS)
                norm = srv_transform(a).norm()
                per.append({"d_A_Ashifted": _distance(a, a2), "srv_norm": float(norm)})
            row[str(c)] = {
                "d_A_B": d_ab,
                "clips": per,
                "ratio_to_half_d_A_B": [p["d_A_Ashifted"] / (d_ab / 2) for p in per],
            }
        out["pairs"][key] = row
        cells = []
        for c in LEVELS:
            x = row[str(c)]
            ratios = ", ".join(f"{r:.2f}" for r in x["ratio_to_half_d_A_B"])
            d = [p["d_A_Ashifted"] for p in x["clips"]]
            cells.append(f"{d[0]:.3f}, {d[1]:.3f} ({ratios}; d(A,B) {x['d_A_B']:.2f})")
        cells = " | ".join(cells)
        print(f"| {key} | {cells} |", flush=True)
    out["source_shift"] = {}
    print("\n| 120 Hz clip | shift (source frames) | " + " | ".join(f"c = {c:g}" for c in LEVELS) + " |")
    for clip in ("07_01", "08_02", "09_11"):
        a = drop_tpose(read_motion(MOCAP / "cmu" / "bvh" / f"{clip}.bvh"))
        for shift in (2, 4):
            pair = [select_frames(a, slice(0, -shift)), select_frames(a, slice(shift, None))]
            ds = [
                float(
                    distance_table(pair, warp=WarpOptions(method="dp", sample_smoothing=c / FPS)).matrix[0, 1]
                )
                for c in LEVELS
            ]
            out["source_shift"][f"{clip} +{shift}"] = dict(zip(map(str, LEVELS), ds, strict=True))
            print(f"| {clip} | {shift} | " + " | ".join(f"{d:.3f}" for d in ds) + " |", flush=True)
    sa, sb = PAIRS["rhythm"]
    prep = prepare_motions(
        [load_clip(*sa), load_clip(*sb)], PrepareOptions(joints="common", drop_tpose=False)
    )
    out["rate"] = {}
    print("\n| rhythm, sample fps | d(A,B) no low-pass | sigma = 0.5 / fps | sigma = 1/60 s |")
    for fps in (15.0, 30.0, 60.0, 120.0):
        ds = [_distance(*motion_curves(prep, "lie", fps=fps, smoothing=x)) for x in (0.0, 0.5 / fps, 1 / 60)]
        out["rate"][str(fps)] = ds
        print(f"| {fps:g} | " + " | ".join(f"{d:.3f}" for d in ds) + " |", flush=True)
    return out


def retrieval(n_samples: int = 32, max_windows: int = 6, neighbourhood: int = 6) -> dict:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from database import RETRIEVAL_CANDIDATES, retrieval_accuracies, retrieval_windows
    from elastic_motion.apps.database import prepare_motion
    from elastic_motion.apps.database.preparation import same_rest_pose

    data: dict = {}
    for which in ("cmu", "bandai"):
        names, motions, tasks = retrieval_windows(MOCAP, which, max_windows)
        data[which] = {"windows": len(names)}
        for c in LEVELS:
            t0 = time.perf_counter()
            ms = [m if c == 0 else smooth_motion(m, c * m.duration / n_samples) for m in motions]
            prep = same_rest_pose(
                [prepare_motion(n, n_samples, motion=m) for n, m in zip(names, ms, strict=True)]
            )
            data[which][str(c)] = retrieval_accuracies(prep, tasks, neighbourhood)
            print(f"{which} smoothing {c}: {time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)

    cands = list(RETRIEVAL_CANDIDATES)

    def score(which: str, c: float, name: str) -> float:
        return float(np.mean(list(data[which][str(c)][name].values())))

    picks = {}
    for c in LEVELS:
        p_cmu = max(cands, key=lambda n: (score("cmu", c, n), -cands.index(n)))
        p_bandai = max(cands, key=lambda n: (score("bandai", c, n), -cands.index(n)))
        picks[str(c)] = {
            "picked_on_cmu": p_cmu,
            "reported_on_bandai": data["bandai"][str(c)][p_cmu],
            "picked_on_bandai": p_bandai,
            "reported_on_cmu": data["cmu"][str(c)][p_bandai],
        }
    return {
        "protocol": "docs/database.md, Retrieval quality (cross-dataset selection), each level separately",
        "n_samples": n_samples,
        "neighbourhood": neighbourhood,
        "levels": LEVELS,
        "data": data,
        "picks": picks,
        "dtw_baseline_unsmoothed": {w: data[w]["0.0"]["dtw (euler frames)"] for w in ("cmu", "bandai")},
    }


def print_retrieval(r: dict) -> None:
    names = list(r["data"]["cmu"]["0.0"])
    print(
        "| distance | "
        + " | ".join(f"CMU cat. / Bandai content / style, c = {c:g}" for c in r["levels"])
        + " |"
    )
    print("|---|" + "---|" * len(r["levels"]))
    for n in names:
        cells = []
        for c in r["levels"]:
            a, b = r["data"]["cmu"][str(c)][n], r["data"]["bandai"][str(c)][n]
            cells.append(f"{a['category']:.3f} / {b['content']:.3f} / {b['style']:.3f}")
        print(f"| {n} | " + " | ".join(cells) + " |")
    for c in r["levels"]:
        p = r["picks"][str(c)]
        print(
            f"c = {c:g}: picked on CMU {p['picked_on_cmu']!r} -> Bandai {p['reported_on_bandai']}; "
            f"picked on Bandai {p['picked_on_bandai']!r} -> CMU {p['reported_on_cmu']}"
        )


def blend(smoothing: float, only: str | None) -> None:
    """``blend_quality.py`` with the default ``sample_smoothing`` set to ``smoothing`` seconds here."""
    import dataclasses

    import elastic_motion.apps.align as align
    from elastic_motion.warp import options

    fields = [f for f in dataclasses.fields(options.WarpOptions) if f.init]
    defaults = list(options.WarpOptions.__init__.__defaults__)
    defaults[[f.name for f in fields].index("sample_smoothing")] = float(smoothing)
    options.WarpOptions.__init__.__defaults__ = tuple(defaults)
    align.motion_curves.__kwdefaults__["smoothing"] = float(smoothing)
    assert WarpOptions().sample_smoothing == float(smoothing)
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import blend_quality

    out = RESULTS / f"retrieval_smoothing_blend_{1000 * smoothing:.3g}ms.json"
    sys.argv = ["blend_quality.py", "--out", str(out), *(["--only", only] if only else [])]
    blend_quality.main()


def prepare(repeat: int = 3) -> dict:
    """Seconds to prepare every CMU BVH and Bandai clip on 64 cells: no low-pass, the low-pass
    on the frames the resample reads, on every frame (module docstring)."""
    import elastic_motion.motion as mm
    from elastic_motion.apps.database.preparation import prepare_motion

    files = sorted((MOCAP / "cmu" / "bvh").glob("*.bvh")) + sorted((MOCAP / "bandai").glob("*.bvh"))
    smooth = mm.smooth_motion

    def every_frame(motion, sigma, frames=None, **kw):  # the preparation before: all frames
        return smooth(motion, sigma, **kw)

    sigma = WarpOptions().sample_smoothing
    ways = {"none": (smooth, 0.0), "read frames": (smooth, sigma), "every frame": (every_frame, sigma)}
    times: dict[str, list[float]] = {w: [] for w in ways}
    out = {}
    try:
        for _ in range(repeat):
            for way, (function, sm) in ways.items():
                mm.smooth_motion = function  # (preparation calls it as mm.smooth_motion)
                t = time.perf_counter()
                out[way] = [prepare_motion(f, 64, smoothing=sm).motion for f in files]
                times[way].append(time.perf_counter() - t)
    finally:
        mm.smooth_motion = smooth
    same = all(
        np.array_equal(a.rotations, b.rotations) and np.array_equal(a.root_translation, b.root_translation)
        for a, b in zip(out["read frames"], out["every frame"], strict=True)
    )
    best = {w: min(t) for w, t in times.items()}
    print("| clips | none s | low-pass, frames read s | low-pass, every frame s | bit-identical |")
    print("|---|---|---|---|---|")
    cells = " | ".join(f"{best[w]:.2f}" for w in ways)
    print(f"| {len(files)} | {cells} | {same} |")
    return {"clips": len(files), "seconds": best, "runs": times, "bit_identical": same}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("section", choices=("reparam", "retrieval", "prepare", "blend"))
    ap.add_argument("--sigma", type=float, default=1 / 60, help="blend: low-pass, seconds (default 1/60)")
    ap.add_argument("--only", default=None, help="blend: pairs of blend_quality.py, comma-separated")
    args = ap.parse_args()
    if not MOCAP.is_dir():
        raise SystemExit(f"real motion-capture folder not found: {MOCAP} (set ELASTIC_MOTION_MOCAP)")
    if args.section == "blend":
        blend(args.sigma, args.only)
        return
    t0 = time.perf_counter()
    if args.section == "reparam":
        print("| pair | d(A,A'), d(B,B') (/ d(A,B)/2) at c = " + ", ".join(f"{c:g}" for c in LEVELS) + " |")
        res = reparam()
    elif args.section == "prepare":
        res = prepare()
    else:
        res = retrieval()
        print_retrieval(res)
    res["seconds"] = time.perf_counter() - t0
    res["machine"] = machine_info()
    path = write_json(RESULTS / f"retrieval_smoothing_{args.section}.json", res)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
