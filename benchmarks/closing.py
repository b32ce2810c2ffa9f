"""Benchmark of curve closing (paper 000, sec. 4) and motion looping (sec. 5.4) on real clips.

Cases
-----
* **Speed**: 600-frame, 31-joint motions as curves in ``R^3 x SO(3)^31`` (default weights
  of :func:`elastic_motion.motion.to_lie_curve`), every joint and the root closed
  (``root="inplace"`` mask), closed until every joint's seam angle is below 1e-3 rad
  (``tol = 1e-3 sqrt(min weight)`` on the weighted gap, which bounds every joint's angle),
  by Gauss-Newton, by the gradient flow with the exact discrete gradient and with the
  paper's formula, and Gauss-Newton with C1. Clips: CMU 49_08 (cartwheels) resampled to
  600 frames -- its finger joints flip by 180 degrees between frames, and they are closed
  here too -- and CMU 01_01 frames 1-600 (no flips). Time: best of ``--repeat`` full
  :func:`~elastic_motion.closing.close_curve` calls (after one warm-up).
* **Real cases**: CMU 49_08 (BVH), CMU backflip (ASF/AMC), DeepMimic cartwheel, backflip,
  run, looped with :func:`elastic_motion.apps.loop.loop_motion` (``root="travel"``,
  finger joints free) on the Lie curve and on the Euler-angle curve (baseline), C0 and C1;
  the seam and deviation metrics of :func:`elastic_motion.apps.metrics.seam_metrics` over the
  closed joints.

Prints markdown tables and writes JSON (default ``benchmarks/results/closing.json``).
Real data is read from ``$ELASTIC_MOTION_MOCAP`` or ``../shared/mocap``.

Usage: ``python benchmarks/closing.py [--repeat 5] [--out PATH]``
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np

from _common import timed_best, write_json
from elastic_motion.apps.loop import loop_motion
from elastic_motion.apps.metrics import seam_metrics
from elastic_motion.apps.prepare import PrepareOptions
from elastic_motion.closing import close_curve, closing_gap, kkt_residual, project_closed, project_closed_rd
from elastic_motion.curves import DiscreteCurve
from elastic_motion.groups import Euclidean
from elastic_motion.motion import (
    drop_tpose,
    finger_joints,
    read_motion,
    resample_at_times,
    select_frames,
    to_euler_curve,
    to_lie_curve,
)

MOCAP = Path(os.environ.get("ELASTIC_MOTION_MOCAP", Path(__file__).resolve().parents[2] / "shared" / "mocap"))

REAL_CASES = {
    "CMU 49_08 cartwheels (BVH)": "cmu/bvh/49_08.bvh",
    "CMU backflip (ASF/AMC)": "cmu/asfamc/backflip.amc",
    "DeepMimic cartwheel": "deepmimic/humanoid3d_cartwheel.txt",
    "DeepMimic backflip": "deepmimic/humanoid3d_backflip.txt",
    "DeepMimic run": "deepmimic/humanoid3d_run.txt",
}


def speed_motions():
    m = drop_tpose(read_motion(MOCAP / "cmu/bvh/49_08.bvh"))
    src = m.times
    dst = np.linspace(0.0, m.duration, 600)
    yield "CMU 49_08 resampled to 600 frames", resample_at_times(m, src, dst, fps=599 / m.duration)
    m = drop_tpose(read_motion(MOCAP / "cmu/bvh/01_01.bvh"))
    yield "CMU 01_01 frames 1-600", select_frames(m, slice(0, 600))


def speed_rows(repeat: int) -> list[dict]:
    rows = []
    for label, motion in speed_motions():
        curve = to_lie_curve(motion)
        w = curve.group.weights[3:]
        tol = 1e-3 * float(np.sqrt(w.min()))
        before = closing_gap(curve)
        for name, kw in [
            ("gauss-newton", dict(method="gauss-newton")),
            ("gradient (exact)", dict(method="gradient", max_iter=5000)),
            ("gradient (paper eq. 17)", dict(method="gradient", gradient="paper", max_iter=5000)),
            ("gauss-newton, C1", dict(method="gauss-newton", c1=True)),
            ("kkt (nearest closed curve)", dict(method="kkt")),
        ]:

            def run(kw=kw, c=curve, tl=tol):
                if kw.get("method") == "kkt":
                    return project_closed(c)
                return close_curve(c, tol=tl, **kw)

            t, res = timed_best(run, repeat)
            after = closing_gap(res.curve)
            rows.append(
                {
                    "motion": label,
                    "frames": motion.n_frames,
                    "joints": motion.n_joints,
                    "method": name,
                    "tol_weighted": tol,
                    "gap_before_max_rad": float(before.rotation_gaps.max()),
                    "gap_after_max_rad": float(after.rotation_gaps.max()),
                    "velocity_gap_after": res.velocity_gap,
                    "iterations": res.iterations,
                    "converged": res.converged,
                    "time_ms": t * 1e3,
                    "target_ms": 1000.0,
                    "met": bool(res.converged and after.rotation_gaps.max() < 1e-3 and t < 1.0),
                }
            )
    return rows


def metric_subset(m) -> dict:
    keys = [
        "seam_angle_max_deg",
        "seam_angle_mean_deg",
        "seam_angular_velocity_max_deg_s",
        "seam_position_max_m",
        "seam_velocity_max_m_s",
        "foot_sliding_m_s",
        "foot_sliding_seam_m_s",
        "deviation_max_m",
        "deviation_mean_m",
    ]
    summary = m.summary()
    return {k: float(summary[k]) for k in keys if k in summary}


def real_rows() -> list[dict]:
    rows = []
    for label, rel in REAL_CASES.items():
        motion = drop_tpose(read_motion(MOCAP / rel))
        fingers = set(finger_joints(motion.skeleton))
        closed = [n for n in motion.skeleton.names if n not in fingers]
        base = {"case": label, "frames": motion.n_frames, "joints": motion.n_joints, "fps": motion.fps}
        rows.append(
            {
                **base,
                "variant": "original",
                **metric_subset(seam_metrics(motion, original=motion, joints=closed)),
            }
        )
        for rep in ("lie", "euler-elastic"):
            for c1 in (False, True):
                t0 = time.perf_counter()
                try:
                    res = loop_motion(
                        motion,
                        method=rep,
                        seam="c1" if c1 else "c0",
                        prepare=PrepareOptions(drop_tpose=False),
                        window=None,  # the whole clip, whatever it changes: the solvers compared
                        force=True,
                    )
                except ValueError as exc:
                    rows.append({**base, "variant": f"{rep}{' C1' if c1 else ''}", "error": str(exc)})
                    continue
                t = time.perf_counter() - t0
                met = res.seam_after  # against the prepared input (metres), closed joints
                rows.append(
                    {
                        **base,
                        "variant": f"{rep}{' C1' if c1 else ''}",
                        "iterations": res.closing.iterations,
                        "converged": res.closing.converged,
                        "time_ms": t * 1e3,
                        "heading_change_deg": float(np.degrees(res.heading_change)),
                        **metric_subset(met),
                    }
                )
    return rows


NEAREST_CASES = {**REAL_CASES, "CMU 09_11 run": "cmu/bvh/09_11.bvh"}


def loop_mask(motion, closed_joint, up=1):
    """The mask of loop_motion(root="travel") on the Lie curve (root height, swing, joints)."""
    j = motion.n_joints
    rot = np.repeat(closed_joint, 3).reshape(j, 3)
    rot[0, up] = False
    pos = np.zeros(3, dtype=bool)
    pos[up] = True
    return np.concatenate([pos, rot.ravel()])


def nearest_rows() -> list[dict]:
    """SRV L2 change ||q - q_orig|| of the Gauss-Newton flow, the R^d Newton projection and the
    constrained projection (KKT), with each result's KKT residual (issue 11)."""
    rows = []
    for label, rel in NEAREST_CASES.items():
        from elastic_motion.apps.prepare import prepare_motions

        motion = prepare_motions([MOCAP / rel]).motions[0]
        fingers = set(finger_joints(motion.skeleton))
        closed_joint = np.array([n not in fingers for n in motion.skeleton.names])
        lie = to_lie_curve(motion)
        mask = loop_mask(motion, closed_joint)
        gn = close_curve(lie, factors=mask, tol=1e-10)
        kk = project_closed(lie, factors=mask)
        rows.append(
            {
                "case": label,
                "curve": "Lie R^3 x SO(3)^J",
                "first_order": "gauss-newton",
                "change_first_order": gn.change,
                "change_kkt": kk.change,
                "improvement_pct": 100 * (1 - kk.change / gn.change),
                "kkt_residual_first_order": kkt_residual(gn.srv, lie, factors=mask)[0],
                "kkt_residual_kkt": kk.kkt_residual,
                "time_first_order_ms": gn.time * 1e3,
                "time_kkt_ms": kk.time * 1e3,
            }
        )
        rd = to_euler_curve(motion)
        curve = DiscreteCurve(rd.values, Euclidean(rd.group.dim, weight=lie.group.weights), rd.t)
        emask = np.concatenate([mask[:3], np.repeat(closed_joint, 3)])
        emask[3] = False  # outermost root angle: the heading (CMU / DeepMimic root orders start with it)
        nt = project_closed_rd(curve, factors=emask, tol=1e-10)
        kr = project_closed(curve, factors=emask)
        rows.append(
            {
                "case": label,
                "curve": "Euler R^d",
                "first_order": "newton (paper 001 Thm. 2)",
                "change_first_order": nt.change,
                "change_kkt": kr.change,
                "improvement_pct": 100 * (1 - kr.change / nt.change),
                "kkt_residual_first_order": kkt_residual(nt.srv, curve, factors=emask)[0],
                "kkt_residual_kkt": kr.kkt_residual,
                "time_first_order_ms": nt.time * 1e3,
                "time_kkt_ms": kr.time * 1e3,
            }
        )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results" / "closing.json")
    args = parser.parse_args()
    if not MOCAP.is_dir():
        raise SystemExit(f"real motion-capture folder not found: {MOCAP} (set ELASTIC_MOTION_MOCAP)")

    speed = speed_rows(args.repeat)
    print("### Speed: closing 600-frame, 31-joint motions until every joint's seam angle < 1e-3 rad\n")
    print("| motion | method | iterations | seam before (rad, max) | after (rad, max) | time (ms) | < 1 s |")
    print("|---|---|---:|---:|---:|---:|---|")
    for r in speed:
        print(
            f"| {r['motion']} | {r['method']} | {r['iterations']} | {r['gap_before_max_rad']:.3f} | "
            f"{r['gap_after_max_rad']:.1e} | {r['time_ms']:.0f} | {'yes' if r['met'] else 'NO'} |"
        )

    nearest = nearest_rows()
    print("\n### The closed curve nearest the original (SRV L2 change ||q - q_orig||, loop mask)\n")
    print(
        "| case | curve | first-order solver | change | change (KKT) | nearer by | KKT residual "
        "first-order / KKT | time first-order / KKT (ms) |"
    )
    print("|---|---|---|---:|---:|---:|---:|---:|")
    for r in nearest:
        print(
            f"| {r['case']} | {r['curve']} | {r['first_order']} | {r['change_first_order']:.5g} | "
            f"{r['change_kkt']:.5g} | {r['improvement_pct']:.2f} % | {r['kkt_residual_first_order']:.1e} / "
            f"{r['kkt_residual_kkt']:.1e} | {r['time_first_order_ms']:.0f} / {r['time_kkt_ms']:.0f} |"
        )

    real = real_rows()
    print("\n### Real cases (root='travel', finger joints free; metrics over the closed joints)\n")
    print(
        "| case | variant | seam angle max / mean (deg) | seam ang. vel. max (deg/s) | "
        "seam FK pos. max (m) | seam FK vel. jump (m/s) | deviation max / mean (m) | "
        "foot sliding (m/s) | heading (deg) | time (ms) |"
    )
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in real:
        if "error" in r:
            print(f"| {r['case']} | {r['variant']} | error: {r['error']} | | | | | | | |")
            continue
        dev = (
            "-" if r["variant"] == "original" else f"{r['deviation_max_m']:.3f} / {r['deviation_mean_m']:.3f}"
        )
        head = f"{r['heading_change_deg']:.1f}" if "heading_change_deg" in r else "-"
        tm = f"{r['time_ms']:.0f}" if "time_ms" in r else "-"
        print(
            f"| {r['case']} ({r['frames']} fr.) | {r['variant']} | {r['seam_angle_max_deg']:.3g} / "
            f"{r['seam_angle_mean_deg']:.3g} | {r['seam_angular_velocity_max_deg_s']:.3g} | "
            f"{r['seam_position_max_m']:.3g} | {r['seam_velocity_max_m_s']:.3g} | {dev} | "
            f"{r['foot_sliding_m_s']:.3f} | {head} | {tm} |"
        )

    result = {
        "machine": {
            "cpu_count": os.cpu_count(),
            "python": platform.python_version(),
            "numpy": np.__version__,
        },
        "repeat": args.repeat,
        "speed": speed,
        "nearest": nearest,
        "real_cases": real,
    }
    write_json(args.out, result)
    print(f"\nwrote {args.out}")


if __name__ == "__main__":
    main()
