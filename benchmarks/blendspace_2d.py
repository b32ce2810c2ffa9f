"""Benchmark of issue 33's blends: a 2-D blend space (speed x turning rate) and N motions
with time-varying weights, on the DeepMimic walk, turning walks and run.

**2-D blend space** (:func:`elastic_motion.apps.blendspace2d.blendspace_2d`, the library's
default blend options: Lie curves, pose anchoring, contacts kept): humanoid3d_walk,
walker/turn_left0, turn_left1, turn_right0, turn_right1 and humanoid3d_run placed by their
root speed (m/s) and turning rate (deg/s about the up axis, positive to the left). Rows: a
grid of points inside the convex hull; for each, the miss of the plain barycentric weights
and of the corrected blend (:meth:`~elastic_motion.apps.blendspace2d.BlendSpace2D.at`: the
largest over the two axes of ``|measured - asked| / range``), the blends made and the time.
Target (issue 33): every miss under 5 %.

**Time-varying weights** (``weight_curve``, three motions: walk, turn_left1, run): the joint
positions (forward kinematics, m) of a constant weight curve against the constant-weight
blend (target ~1e-9), of ``w = e_k`` against input ``k`` (target 1e-6), and the time of a
changing curve (walk -> turn -> run) against the constant-weight blend; and the figure
``docs/images/weight_curve_walk_turn_run.png``: three cycles of each, walk -> left turn -> run
with the library's default options, its first and last frames against the walk's first and
the run's last (joint positions relative to the root).

Writes ``benchmarks/results/blendspace_2d.json`` and the figure
``docs/images/blendspace_2d.png`` (the plane, its triangles, the points asked and measured;
the root's heading over time of the blends at 1.5 m/s).

Data: ``$ELASTIC_MOTION_MOCAP`` or ``../shared/mocap``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from _common import MOCAP, REPO, RESULTS, machine_info, write_json
from elastic_motion.apps.blend import blend_motions
from elastic_motion.apps.blendspace2d import NOTE_HIT, blendspace_2d
from elastic_motion.motion import forward_kinematics
from elastic_motion.motion.edit import heading_angle

CLIPS = (
    "humanoid3d_walk.txt",
    "walker/turn_left0.txt",
    "walker/turn_left1.txt",
    "walker/turn_right0.txt",
    "walker/turn_right1.txt",
    "humanoid3d_run.txt",
)
GRID = [(s, t) for s in (1.0, 1.5, 2.0, 2.5, 3.0) for t in (-40.0, -20.0, 0.0, 20.0)]
FIGURE = REPO / "docs" / "images" / "blendspace_2d.png"
FIGURE_CURVE = REPO / "docs" / "images" / "weight_curve_walk_turn_run.png"
THREE_CURVE = "0:1/0/0,0.25:1/0/0,0.4:0/1/0,0.6:0/1/0,0.75:0/0/1,1:0/0/1"


def space_rows(space) -> list[dict]:
    rows = []
    for p in GRID:
        if not space.inside(p):
            continue
        t0 = time.perf_counter()
        res = space.at(p)
        dt = time.perf_counter() - t0
        (hit,) = (n for n in res.notes if n.kind == NOTE_HIT)
        plain = space.measure(space._blend(space.weights(p)).motion)
        rows.append(
            {
                "asked": list(p),
                "plain_measured": plain.tolist(),
                "plain_miss": float(np.abs((plain - p) / space.scale).max()),
                "measured": hit.data["measured"],
                "miss": hit.data["miss"],
                "blends": hit.data["blends"],
                "weights": res.weights.tolist(),
                "time_s": dt,
                "heading_deg": np.degrees(np.unwrap(heading_angle(res.motion.rotations[:, 0], 1))).tolist(),
                "fps": res.motion.fps,
            }
        )
        print(f"asked {p}: miss {100 * hit.data['miss']:.2f} %, {dt:.1f} s", flush=True)
    return rows


def weight_curve_rows(paths: list[str]) -> dict:
    plain = {"warp": "dp", "contacts": "off", "trim_ends": False}
    t0 = time.perf_counter()
    const = blend_motions(paths, [0.2, 0.3, 0.5], **plain)
    t_const = time.perf_counter() - t0
    curve = blend_motions(paths, weight_curve="0:0.2/0.3/0.5,1:0.2/0.3/0.5", **plain)
    out = {
        "constant_vs_blend_m": float(
            np.abs(forward_kinematics(curve.motion) - forward_kinematics(const.motion)).max()
        ),
        "unit_weight_vs_input_m": [],
        "constant_blend_s": t_const,
    }
    for k in range(3):
        keys = ",".join(f"{u}:" + "/".join("1" if i == k else "0" for i in range(3)) for u in (0, 1))
        res = blend_motions(paths, weight_curve=keys, **plain)
        pk = res.prepared.motions[k]
        n = min(res.motion.n_frames, pk.n_frames)
        err = np.abs(forward_kinematics(res.motion)[:n] - forward_kinematics(pk)[:n]).max()
        out["unit_weight_vs_input_m"].append(float(err))
    t0 = time.perf_counter()
    blend_motions(paths, weight_curve="0:1/0/0,0.5:0/1/0,1:0/0/1", **plain)
    out["changing_curve_s"] = time.perf_counter() - t0
    return out


def weight_curve_figure(paths: list[str], path: Path) -> dict:
    """Walk -> left turn -> run, three cycles each, with the library's default options: the
    foot trajectories of the inputs and of the blend; its start against the walk's and its end
    against the run's last frame (FK, m, after the clean-up)."""
    from elastic_motion.apps.render import plot_foot_trajectories
    from elastic_motion.motion import read_motion
    from elastic_motion.motion.looping import repeat_motion

    ms = [repeat_motion(read_motion(p), 3) for p in paths]
    t0 = time.perf_counter()
    res = blend_motions(ms, weight_curve=THREE_CURVE)
    dt = time.perf_counter() - t0
    fk = forward_kinematics(res.motion)
    first = forward_kinematics(res.prepared.motions[0])[0]
    last = forward_kinematics(res.prepared.motions[2])[-1]
    rel = lambda x: x - x[:1]  # noqa: E731 -- positions relative to the root
    plot_foot_trajectories(
        [*res.prepared.motions, res.motion],
        path,
        labels=["walk (3 cycles)", "turn_left1 (3 cycles)", "run (3 cycles)", "walk -> turn -> run"],
        ncols=4,
        title=f"Time-varying weights of three motions in SRV space: {THREE_CURVE}",
        panel_size=(3.0, 1.5),
        dpi=80,
    )
    return {
        "curve": THREE_CURVE,
        "time_s": dt,
        "duration_s": res.motion.duration,
        "start_vs_walk_m": float(np.abs(rel(fk[0]) - rel(first)).max()),
        "end_vs_run_m": float(np.abs(rel(fk[-1]) - rel(last)).max()),
        "skating_after_m_s": None if res.cleanup is None else res.cleanup.skating_after.mean_speed,
    }


def figure(space, rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(11, 4.6))
    x = space.params
    ax.triplot(x[:, 0], x[:, 1], space.triangles, color="0.7", lw=1)
    ax.plot(x[:, 0], x[:, 1], "ko")
    for lab, (a, b) in zip(space.prepared.labels, x, strict=True):
        ax.annotate(
            lab.replace("humanoid3d_", ""), (a, b), textcoords="offset points", xytext=(4, 4), fontsize=8
        )
    for r in rows:
        a, m, pm = np.array(r["asked"]), np.array(r["measured"]), np.array(r["plain_measured"])
        ax.plot(*a, "x", color="tab:blue", ms=8)
        ax.plot([a[0], pm[0]], [a[1], pm[1]], color="tab:red", lw=0.8)
        ax.plot(*pm, ".", color="tab:red")
        ax.plot(*m, "o", mfc="none", color="tab:green")
    ax.plot([], [], "x", color="tab:blue", label="asked")
    ax.plot([], [], ".", color="tab:red", label="barycentric weights (measured)")
    ax.plot([], [], "o", mfc="none", color="tab:green", label="corrected (measured)")
    ax.set_xlabel("root speed (m/s)")
    ax.set_ylabel("turning rate (deg/s, + left)")
    ax.legend(fontsize=8, loc="lower right")
    ax.set_title("DeepMimic walks, turns, run: speed x turning rate")
    for r in rows:
        if r["asked"][0] == 1.5:
            h = np.array(r["heading_deg"])
            t = np.arange(h.shape[0]) / r["fps"]
            ax2.plot(
                t, h - h[0], label=f"asked {r['asked'][1]:+.0f} deg/s (measured {r['measured'][1]:+.1f})"
            )
    ax2.set_xlabel("time (s)")
    ax2.set_ylabel("root heading change (deg)")
    ax2.set_title("blends at 1.5 m/s: the root's heading")
    ax2.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=100)
    tmp.replace(path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=str(RESULTS / "blendspace_2d.json"))
    ap.add_argument("--figure", default=str(FIGURE))
    args = ap.parse_args()
    if not MOCAP.is_dir():
        raise SystemExit(f"real motion-capture folder not found: {MOCAP} (set ELASTIC_MOTION_MOCAP)")
    paths = [str(MOCAP / "deepmimic" / c) for c in CLIPS]
    t0 = time.perf_counter()
    space = blendspace_2d(paths, ("speed", "turn"))
    build = time.perf_counter() - t0
    rows = space_rows(space)
    print(f"\n2-D blend space: {len(CLIPS)} DeepMimic clips, built in {build:.2f} s")
    print("| motion | speed m/s | turn deg/s |\n|---|---|---|")
    for lab, (a, b) in zip(space.prepared.labels, space.params, strict=True):
        print(f"| {lab} | {a:.3f} | {b:.1f} |")
    print(
        "\n| asked (m/s, deg/s) | barycentric: measured | miss % | corrected: measured | miss % "
        "| blends | s |"
    )
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        a, pm, m = r["asked"], r["plain_measured"], r["measured"]
        print(
            f"| {a[0]:g}, {a[1]:+g} | {pm[0]:.3f}, {pm[1]:+.1f} | {100 * r['plain_miss']:.1f} "
            f"| {m[0]:.3f}, {m[1]:+.1f} | {100 * r['miss']:.2f} | {r['blends']} | {r['time_s']:.1f} |"
        )
    worst = max(r["miss"] for r in rows)
    print(
        f"\nlargest miss: barycentric {100 * max(r['plain_miss'] for r in rows):.1f} %, corrected "
        f"{100 * worst:.2f} % (target < 5 %)"
    )
    wc = weight_curve_rows([paths[0], paths[2], paths[5]])
    print(
        "\nweight curves (walk, turn_left1, run): constant curve vs constant blend "
        f"{wc['constant_vs_blend_m']:.2e} m; "
        f"w = e_k vs input k {', '.join(f'{e:.2e}' for e in wc['unit_weight_vs_input_m'])} m; "
        f"changing curve {wc['changing_curve_s']:.2f} s (constant blend {wc['constant_blend_s']:.2f} s)"
    )
    wc["figure"] = weight_curve_figure([paths[0], paths[2], paths[5]], FIGURE_CURVE)
    f = wc["figure"]
    print(
        f"walk -> turn_left1 -> run ({THREE_CURVE}), default options: {f['duration_s']:.2f} s in "
        f"{f['time_s']:.1f} s; first frame vs the walk's {f['start_vs_walk_m']:.3f} m, last vs the run's "
        f"{f['end_vs_run_m']:.3f} m (joint positions relative to the root)"
    )
    figure(space, rows, Path(args.figure))
    for r in rows:
        del r["heading_deg"]
    write_json(
        args.out,
        {
            "machine": machine_info(),
            "space": {
                "build_s": build,
                **{k: v for k, v in space.summary().items() if k != "template_warps"},
            },
            "rows": rows,
            "largest_miss": worst,
            "target_miss": 0.05,
            "weight_curves": wc,
        },
    )
    print(f"wrote {args.out} and {args.figure}")


if __name__ == "__main__":
    main()
