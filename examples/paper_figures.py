"""Reproduce the blend and loop figures of the two papers on real motion capture.

Writes small PNGs into ``--out`` (default ``docs/images/``) and prints the quality metrics
of every blend (the numbers quoted in ``docs/applications.md``):

* ``paper_obstacles_feet.png`` -- paper 000 Fig. 4 / paper 001 Fig. 6: CMU 107_02 (its
  first out-walk, 1.0-3.4 s) and 108_01 (1.3-4.8 s), walks stepping over obstacles,
  blended halfway by every method; trajectories of both feet. ``paper_obstacles_warp.png``:
  the warps of the Euler and Lie methods, with the landmarks.
* ``paper_rhythm_feet.png`` -- paper 001 Fig. 5: two walks with different rhythm, CMU
  07_01 and 08_02 (two subjects), every method. ``paper_rhythm131_feet.png``: the same for
  CMU 131_01 and 131_02 ("start, walk, stop", different numbers of steps).
* ``paper_<tag>_warps.png`` -- the warps of (c), (d), Lie + warp and Lie + landmarks side by
  side, the landmarks (paired by phase) in red.
* ``transition_walk_run.png`` -- a DeepMimic walk -> run transition (weight curve);
  ``blendspace_speed_sweep.png`` -- a blend space of CMU walks and a run by speed.
* ``paper_loop_<clip>.png`` -- paper 000 Fig. 5-7: CMU 49_08 (cartwheels), DeepMimic
  cartwheel and backflip played three times before and after closing
  (``examples/loops.py`` compares the Lie and the Euler closing in more detail).

Data: ``$ELASTIC_MOTION_MOCAP`` or ``../shared/mocap`` (CMU: "The data used in this project
was obtained from mocap.cs.cmu.edu. The database was created with funding from NSF
EIA-0196217."); the DeepMimic clips also come with ``pip install pybullet``.

Usage: ``python examples/paper_figures.py [--out DIR] [--only obstacles,rhythm,loops]``
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from elastic_motion.apps.align import align_motions
from elastic_motion.apps.blend import blend_motions
from elastic_motion.apps.loop import loop_motion
from elastic_motion.apps.render import plot_foot_trajectories, plot_seam, plot_warp
from elastic_motion.motion import drop_tpose, read_motion, trim
from elastic_motion.motion.looping import repeat_motion

REPO = Path(__file__).resolve().parents[1]
MOCAP = Path(os.environ.get("ELASTIC_MOTION_MOCAP", REPO.parent / "shared" / "mocap"))

#: (label, method, warp, landmarks) -- paper 001 Fig. 5-6 (a)-(d), then paper 000 Fig. 4 and
#: the Lie method with landmarks (paper 002's future work). Landmarks "auto": foot strikes,
#: toe-offs and knee crossings paired by phase (the warp without landmarks as the prior).
METHODS = (
    ("(a) Euler, linear", "euler-linear", "none", None),
    ("(b) Euler, elastic", "euler-elastic", "none", None),
    ("(c) Euler, elastic + warp", "euler-elastic", "dp", None),
    ("(d) Euler, + warp + landmarks", "euler-elastic", "dp", "auto"),
    ("Lie group", "lie", "none", None),
    ("Lie group + warp", "lie", "dp", None),
    ("Lie + warp + landmarks", "lie", "dp", "auto"),
)


def load(rel: str, start: float | None = None, stop: float | None = None):
    m = drop_tpose(read_motion(MOCAP / rel))
    if start is not None or stop is not None:
        m = trim(m, start, stop)
    return m


def blend_all(a, b, tag: str, out: Path, title: str) -> dict:
    """Blend a and b halfway by every method; one feet figure; metrics per method."""
    results, rows = [], {}
    for label, method, warp, lm in METHODS:
        t0 = time.perf_counter()
        # the papers' blends: without the pose anchoring, the foot-skate clean-up and the
        # contact-guided warp (the library's defaults; the last row below has them)
        res = blend_motions(
            [a, b],
            0.5,
            method=method,
            warp=warp,
            landmarks=lm,
            metrics=True,
            contacts="off",
            anchor=False,
            contact_warp="off",
        )
        met = res.metrics.summary()
        rows[label] = {
            "foot_sliding_m_s": met["foot_sliding"]["result"]["mean_speed_m_s"],
            "distance_to_a": met["distances"]["result_to_inputs"][0],
            "distance_to_b": met["distances"]["result_to_inputs"][1],
            "landmarks_s": [list(p) for p in res.landmarks],
            "frames": res.motion.n_frames,
            "seconds": time.perf_counter() - t0,
        }
        results.append((label, res))
    first = results[0][1]
    pa, pb = first.prepared.motions
    rows["inputs"] = {
        "foot_sliding_m_s": [x["mean_speed_m_s"] for x in first.metrics.summary()["foot_sliding"]["inputs"]],
        "distance_a_b": float(first.metrics.distances_between_inputs[0, 1]),
        "notes": [str(n) for n in first.notes],
    }
    fig = plot_foot_trajectories(
        [pa, pb] + [r.motion for _, r in results],
        out / f"paper_{tag}_feet.png",
        labels=[f"A: {a.name}", f"B: {b.name}"] + [lab for lab, _ in results],
        ncols=3,
        title=title,
        panel_size=(2.9, 1.5),
        dpi=80,
    )
    del fig
    warps_side_by_side(results, out / f"paper_{tag}_warps.png", title)
    # the same Lie + warp blend with the pose anchoring and the clean-up (blend_motions' defaults)
    clean = blend_motions([a, b], 0.5, method="lie", warp="dp")
    if clean.cleanup is not None and clean.cleanup.applied:
        c = clean.cleanup
        rows["Lie group + warp, clean-up"] = {
            "skating_before_m_s": c.skating_before.mean_speed,
            "skating_after_m_s": c.skating_after.mean_speed,
            "below_floor_m": [c.skating_before.below_floor, c.skating_after.below_floor],
            "max_change_m": c.max_position_change,
        }
    return rows


def warps_side_by_side(results, path: Path, title: str) -> None:
    """The warps of (c), (d), Lie + warp and Lie + landmarks side by side (seconds), landmarks dotted."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pick = [(lab, r) for lab, r in results if r.warp != "none"]
    fig, axes = plt.subplots(1, len(pick), figsize=(2.6 * len(pick), 2.6), sharey=True)
    for ax, (lab, r) in zip(axes, pick, strict=True):
        da, db = (m.duration for m in r.prepared.motions)
        v = r.warps[1]
        ax.plot(v[:, 0] * da, v[:, 1] * db, color="k", lw=1.2)
        ax.plot([0, da], [0, db], color="0.7", lw=0.6, ls="--")
        for ta, tb in r.landmarks:
            ax.plot(ta, tb, "o", ms=3, color="tab:red")
        ax.set_title(lab, fontsize=8)
        ax.set_xlabel("time in A (s)", fontsize=7)
        ax.tick_params(labelsize=6)
    axes[0].set_ylabel("time in B (s)", fontsize=7)
    fig.suptitle(title + ": warps (red: landmarks paired by phase)", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def obstacles(out: Path) -> dict:
    a = load("cmu/bvh/107_02_30hz.bvh", 1.0, 3.4)
    b = load("cmu/bvh/108_01_30hz.bvh", 1.3, 4.8)
    rows = blend_all(a, b, "obstacles", out, "CMU 107_02 x 108_01 (obstacles), 50 % blends: feet, side view")
    # the warps with landmarks (Euler) and without (Lie), paper 001 Fig. 6 (d) vs paper 000 Fig. 4
    eu = align_motions(a, b, method="euler-elastic", landmarks="auto")
    plot_warp(eu, out / "paper_obstacles_warp_euler.png", title="Euler + warp + landmarks", dpi=70)
    lie = align_motions(a, b, method="lie")
    plot_warp(lie, out / "paper_obstacles_warp_lie.png", title="Lie + warp (no landmarks)", dpi=70)
    rows["warp_distance"] = {"euler_landmarks": eu.distance, "lie": lie.distance}
    return rows


def transitions(out: Path) -> dict:
    """A walk -> run transition (a weight curve) and a speed sweep of a blend space (CMU walks
    07_01 and 08_02 and run 09_11, one gait cycle each)."""
    from elastic_motion.apps.blendspace import blendspace, motion_speed

    rows = {}
    walk, run = load("deepmimic/humanoid3d_walk.txt"), load("deepmimic/humanoid3d_run.txt")
    walk3 = repeat_motion(walk, 3)
    run3 = repeat_motion(run, 3)
    res = blend_motions([walk3, run3], weight_curve="0:0,0.2:0,0.8:1,1:1", warp="dp")
    plot_foot_trajectories(
        [res.prepared.motions[0], res.prepared.motions[1], res.motion],
        out / "transition_walk_run.png",
        labels=["walk (DeepMimic, 3 cycles)", "run (3 cycles)", "walk -> run (weight 0 -> 1)"],
        ncols=3,
        title="A transition: weight curve 0:0, 0.2:0, 0.8:1, 1:1",
        panel_size=(3.4, 1.5),
        dpi=80,
    )
    rows["transition_walk_run"] = {
        "duration_s": res.motion.duration,
        "skating_after_m_s": None if res.cleanup is None else res.cleanup.skating_after.mean_speed,
    }
    files = [load(f"cmu/bvh/{k}.bvh") for k in ("07_01", "08_02", "09_11")]
    if files:
        space = blendspace(files, one_cycle=True)
        ps = np.linspace(space.params[0], space.params[-1], 5)
        sweep = [space.at(p).motion for p in ps]
        plot_foot_trajectories(
            sweep,
            out / "blendspace_speed_sweep.png",
            labels=[f"{p:.2f} m/s -> {motion_speed(m):.2f} m/s" for p, m in zip(ps, sweep, strict=True)],
            ncols=5,
            title="Blend space: CMU walks 07_01, 08_02 and run 09_11 placed by speed, one cycle each",
            panel_size=(2.4, 1.5),
            dpi=80,
        )
        rows["speed_sweep"] = {
            "params": ps.tolist(),
            "speeds": [motion_speed(m) for m in sweep],
            "notes": [str(n) for n in space.notes],
        }
    return rows


def rhythm(out: Path) -> dict:
    a, b = load("cmu/bvh/07_01.bvh"), load("cmu/bvh/08_02.bvh")
    rows = {
        "07_01 x 08_02": blend_all(a, b, "rhythm", out, "CMU 07_01 x 08_02 (different rhythm), 50 % blends")
    }
    a, b = load("cmu/bvh/131_01.bvh"), load("cmu/bvh/131_02.bvh")
    rows["131_01 x 131_02"] = blend_all(
        a, b, "rhythm131", out, "CMU 131_01 x 131_02 (start, walk, stop; different steps), 50 % blends"
    )
    return rows


def loops(out: Path) -> dict:
    rows = {}
    for key, rel, label in (
        ("cmu_49_08", "cmu/bvh/49_08.bvh", "CMU 49_08 cartwheels"),
        ("dm_cartwheel", "deepmimic/humanoid3d_cartwheel.txt", "DeepMimic cartwheel"),
        ("dm_backflip", "deepmimic/humanoid3d_backflip.txt", "DeepMimic backflip"),
    ):
        t0 = time.perf_counter()
        res = loop_motion(load(rel), seam="c0", window=None, force=True)  # the paper closes C0, whole
        m = res.original  # prepared: metres, Y-up
        before, after = res.seam_before, res.seam_after
        plot_seam(
            m,
            res.motion,
            out / f"paper_loop_{key}.png",
            title=f"{label}: 3 cycles, before / after closing",
            dpi=75,
        )
        rows[key] = {
            "seam_position_max_m": [before.seam_position_max_m, after.seam_position_max_m],
            "seam_angle_max_deg": [before.seam_angle_max_deg, after.seam_angle_max_deg],
            "deviation_max_m": after.deviation_max_m,
            "foot_sliding_m_s": [before.foot_sliding_m_s, after.foot_sliding_m_s],
            "seconds": time.perf_counter() - t0,
        }
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(REPO / "docs" / "images"), help="folder for the PNGs")
    parser.add_argument("--only", default="obstacles,rhythm,loops,transitions", help="comma-separated subset")
    args = parser.parse_args()
    if not MOCAP.is_dir():
        raise SystemExit(f"real motion-capture folder not found: {MOCAP} (set ELASTIC_MOTION_MOCAP)")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    report = {}
    for name in args.only.split(","):
        report[name] = {"obstacles": obstacles, "rhythm": rhythm, "loops": loops, "transitions": transitions}[
            name
        ](out)
    print(json.dumps(report, indent=1, default=float))


if __name__ == "__main__":
    main()
