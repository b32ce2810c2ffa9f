"""Seamless loops of real clips (paper 000, sec. 5.4, Fig. 5-7), Lie group against Euler angles.

Writes into ``--out`` (default ``docs/images/``):

* ``loop_<case>.png`` for CMU 49_08 (cartwheels), the CMU backflip (ASF/AMC) and the DeepMimic
  cartwheel, backflip and run: the trajectory of a foot or hand while the clip plays three
  times in a row (``root="travel"``: each cycle starts where the last ended), side view
  (horizontal: the floor direction the clip travels most along; vertical: height), seams
  marked. Rows: the original clip, closed on the Lie curve, closed on the Euler curve.
* ``loop_seam_closeup.png``: the last frames of a cycle and the first frames of the next
  (DeepMimic cartwheel, left half of the skeleton), before and after closing (cf. Fig. 6).
* ``loop_c0_c1.png``: joint angular speed around the seam of the repeated DeepMimic run for
  the original, C0 and C1 closing.
* ``loop_euler_float.png``: root height and the accumulated root rotation of the DeepMimic
  backflip: the Euler closing undoes the flip (the character floats).
* ``closing_so3.png``: the closing flow on a curve in SO(3) (cf. Fig. 3): the paths of
  ``(1,0,0)`` and ``(0,1,0)`` on the sphere, at several iterations of the gradient flow.

Real data is read from ``$ELASTIC_MOTION_MOCAP`` or ``../shared/mocap``.

Usage: ``python examples/loops.py [--out DIR]``
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from elastic_motion.apps.loop import loop_motion
from elastic_motion.apps.metrics import seam_metrics
from elastic_motion.closing import close_curve
from elastic_motion.curves import DiscreteCurve
from elastic_motion.groups import SO3
from elastic_motion.motion import drop_tpose, forward_kinematics, read_motion
from elastic_motion.motion.contacts import detect_contacts
from elastic_motion.motion.looping import repeat_motion

MOCAP = Path(os.environ.get("ELASTIC_MOTION_MOCAP", Path(__file__).resolve().parents[2] / "shared" / "mocap"))
SO3G = SO3()

# case: (file, point to trace: joint name, or "end:<joint>" for the end site below it)
CASES = {
    "cmu_49_08": ("cmu/bvh/49_08.bvh", "LeftHand", "CMU 49_08 cartwheels, left hand (wrist)"),
    "cmu_backflip": ("cmu/asfamc/backflip.amc", "end:ltoes", "CMU backflip (ASF/AMC), left toe"),
    "dm_cartwheel": (
        "deepmimic/humanoid3d_cartwheel.txt",
        "end:left_ankle",
        "DeepMimic cartwheel, left foot",
    ),
    "dm_backflip": ("deepmimic/humanoid3d_backflip.txt", "end:right_ankle", "DeepMimic backflip, right foot"),
    "dm_run": ("deepmimic/humanoid3d_run.txt", "end:left_ankle", "DeepMimic run, left foot"),
}


def point_index(motion, spec: str) -> int:
    sk = motion.skeleton
    if spec.startswith("end:"):
        j = sk.index(spec[4:])
        ends = np.flatnonzero(sk.end_site_parents == j)
        return sk.n_joints + int(ends[0])
    return sk.index(spec)


def trace(motion, spec: str, cycles: int = 3) -> np.ndarray:
    rep = repeat_motion(motion, cycles)
    return forward_kinematics(rep, end_sites=True)[:, point_index(motion, spec)] * (
        motion.metres_per_unit or 1.0
    )


def side_view(paths: list[np.ndarray], up: int):
    """Project 3D paths on (main floor direction, height), one direction for all."""
    floor = [k for k in range(3) if k != up]
    allp = np.concatenate(paths)[:, floor]
    centred = allp - allp.mean(axis=0)
    direction = np.linalg.svd(centred, full_matrices=False)[2][0]
    if direction @ (paths[0][-1, floor] - paths[0][0, floor]) < 0:
        direction = -direction
    return [np.column_stack([p[:, floor] @ direction, p[:, up]]) for p in paths]


def plot_case(key: str, out: Path) -> dict:
    rel, spec, title = CASES[key]
    lie = loop_motion(MOCAP / rel, seam="c0", window=None, force=True)
    m = lie.original  # prepared: T-pose dropped, metres, Y-up
    eul = loop_motion(m, method="euler-elastic", seam="c0", window=None, force=True)
    up = "xyz".index(m.up_axis)
    rows = [
        ("original", m),
        ("Lie group (SO(3)^J), closed", lie.motion),
        ("Euler angles (R^d), closed", eul.motion),
    ]
    paths = side_view([trace(mm, spec) for _, mm in rows], up)
    f = m.n_frames
    # the input's contacts of the traced joint (the end site's joint), frames of 3 cycles
    contacts = detect_contacts(m)
    joint = m.skeleton.names[point_index(m, spec)] if not spec.startswith("end:") else spec[4:]
    planted = np.zeros(3 * (f - 1) + 1, dtype=bool)
    if joint in contacts.joints:
        col = contacts.mask[:, contacts.joints.index(joint)]
        for k in range(3):
            planted[k * (f - 1) : k * (f - 1) + f] |= col
    seams = [f - 1, 2 * (f - 1)]
    lo = np.min([p.min(axis=0) for p in paths], axis=0) - 0.1
    hi = np.max([p.max(axis=0) for p in paths], axis=0) + 0.1
    row_h = min(3.2, max(1.4, 10.0 * (hi[1] - lo[1]) / (hi[0] - lo[0]))) + 0.8
    fig, axes = plt.subplots(3, 1, figsize=(11, 3 * row_h + 0.6))
    for ax, (label, mm), p in zip(axes, rows, paths, strict=True):
        ax.plot(p[:, 0], p[:, 1], "C0", lw=1.2)
        if planted.any():
            ax.plot(p[planted, 0], p[planted, 1], ".", color="C1", ms=3, label="input's contacts (frames)")
            ax.legend(loc="upper right", fontsize=8)
        for s in seams:
            ax.plot(p[s - 1 : s + 1, 0], p[s - 1 : s + 1, 1], "r-", lw=2.5)
            ax.plot(p[s, 0], p[s, 1], "o", mfc="none", mec="r", ms=10, mew=1.5)
        met = seam_metrics(mm, original=m, joints=lie.closed_joints)
        txt = (
            f"seam: max joint angle {met.seam_angle_max_deg:.2g} deg, FK gap {met.seam_position_max_m:.2g} m"
        )
        if mm is not m:
            txt += (
                f"; deviation from original max {met.deviation_max_m:.2f} m, "
                f"mean {met.deviation_mean_m:.3f} m"
            )
        ax.set_title(f"{label}: {txt}", fontsize=9)
        ax.set_xlabel("distance along the main direction of travel (m)")
        ax.set_ylabel("height (m)")
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
    for ax in axes:
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
    fig.suptitle(
        f"{title}: played 3 times; red = the step across each seam (circles: first frame of the next cycle)"
    )
    fig.tight_layout()
    path = out / f"loop_{key}.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return {"case": key, "file": str(path)}


def plot_seam_closeup(out: Path) -> None:
    m = drop_tpose(read_motion(MOCAP / CASES["dm_cartwheel"][0]))
    lie = loop_motion(m, seam="c0", window=None, force=True)
    sk = m.skeleton
    left = [j for j, n in enumerate(sk.names) if not n.startswith("right")]
    fig, axes = plt.subplots(1, 2, figsize=(11, 5))
    f = m.n_frames
    for ax, (label, mm) in zip(axes, [("original", m), ("closed (Lie group)", lie.motion)], strict=True):
        rep = repeat_motion(mm, 2)
        pos = forward_kinematics(rep) * (mm.metres_per_unit or 1.0)
        up = "xyz".index(mm.up_axis)
        view = side_view([pos.reshape(-1, 3)], up)[0].reshape(pos.shape[0], pos.shape[1], 2)
        for fr, col in [(k, "C0") for k in range(f - 6, f - 1)] + [(k, "C1") for k in range(f - 1, f + 4)]:
            for j in left[1:]:
                p = sk.parents[j]
                if p in left:
                    ax.plot(view[fr, [p, j], 0], view[fr, [p, j], 1], color=col, lw=1.3, alpha=0.8)
        ax.set_title(f"{label}: last 5 frames (blue) and first 5 of the next cycle (orange)", fontsize=9)
        ax.set_xlabel("along the main direction of travel (m)")
        ax.set_ylabel("height (m)")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
    fig.suptitle("DeepMimic cartwheel at the seam, left half of the skeleton (cf. paper 000, Fig. 6)")
    fig.tight_layout()
    fig.savefig(out / "loop_seam_closeup.png", dpi=110)
    plt.close(fig)


def plot_c0_c1(out: Path) -> None:
    m = drop_tpose(read_motion(MOCAP / CASES["dm_run"][0]))
    f = m.n_frames
    fig, ax = plt.subplots(figsize=(10, 4.5))
    joint = m.skeleton.index("right_knee")
    for label, mm, style in [
        ("original", m, "k:"),
        ("closed, C0", loop_motion(m, seam="c0", window=None, force=True).motion, "C0-"),
        ("closed, C1", loop_motion(m, seam="c1", window=None, force=True).motion, "C3-"),
    ]:
        rep = repeat_motion(mm, 3)
        w = (
            np.linalg.norm(SO3G.difference(rep.rotations[:-1, joint], rep.rotations[1:, joint]), axis=-1)
            * m.fps
        )
        t = (np.arange(w.size) + 0.5) / m.fps
        ax.plot(t, np.degrees(w), style, marker=".", lw=1.3, label=label)
    for k in (1, 2):
        ax.axvline((k * (f - 1)) / m.fps, color="r", lw=0.8, alpha=0.6)
    ax.set_xlabel("time (s); red lines: seams")
    ax.set_ylabel("right knee angular speed (deg/s)")
    ax.set_title("DeepMimic run played 3 times: C0 closing leaves a velocity jump at the seam, C1 removes it")
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "loop_c0_c1.png", dpi=110)
    plt.close(fig)


def plot_euler_float(out: Path) -> None:
    m = drop_tpose(read_motion(MOCAP / CASES["dm_backflip"][0]))
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for label, mm, style in [
        ("original (under the Lie curve)", m, "0.6"),
        ("Lie group closed", loop_motion(m, seam="c0", window=None, force=True).motion, "C0--"),
        (
            "Euler closed",
            loop_motion(m, method="euler-elastic", seam="c0", window=None, force=True).motion,
            "C3",
        ),
    ]:
        r = mm.rotations[:, 0]
        turn = np.concatenate([[0], np.cumsum(np.linalg.norm(SO3G.difference(r[:-1], r[1:]), axis=-1))])
        pos = forward_kinematics(mm)
        head = pos[:, mm.skeleton.index("neck"), 1] - pos[:, 0, 1]
        lw = 4.0 if label.startswith("original") else 1.5
        axes[0].plot(
            mm.times,
            np.degrees(turn),
            color=style[:-2] if style.endswith("--") else style,
            ls="--" if style.endswith("--") else "-",
            lw=lw,
            label=label,
        )
        axes[1].plot(
            mm.times,
            head,
            color=style[:-2] if style.endswith("--") else style,
            ls="--" if style.endswith("--") else "-",
            lw=lw,
            label=label,
        )
    axes[0].set_ylabel("accumulated root rotation (deg)")
    axes[1].set_ylabel("neck height above the root (m)")
    for ax in axes:
        ax.set_xlabel("time (s)")
        ax.grid(alpha=0.3)
        ax.legend()
    fig.suptitle(
        "DeepMimic backflip: closing the Euler angles unwinds the 360-degree flip (the root no longer "
        "turns over: the character floats)",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(out / "loop_euler_float.png", dpi=110)
    plt.close(fig)


def plot_so3_flow(out: Path) -> None:
    n = 200
    t = np.linspace(0, 1, n)
    w = 2 * np.pi * 0.85 * t  # a loop that stops short of closing
    v = np.column_stack([0.9 * np.sin(w), 0.9 * (1 - np.cos(w)), 0.4 * np.sin(np.pi * t)])
    curve = DiscreteCurve(SO3G.exp(v), SO3G)
    fig = plt.figure(figsize=(14, 4))
    stages = [
        ("open curve", None),
        ("flow, 3 steps", 3),
        ("flow, 8 steps", 8),
        ("flow, 20 steps", 20),
        ("Gauss-Newton", "gn"),
    ]
    for k, (label, iters) in enumerate(stages):
        if iters is None:
            c = curve
        elif iters == "gn":
            c = close_curve(curve, tol=1e-10).curve
        else:  # small fixed steps (Armijo-checked) to show the flow, as the paper's Fig. 3 does
            c = close_curve(curve, method="gradient", step=0.03, max_iter=iters, tol=0).curve
        ax = fig.add_subplot(1, len(stages), k + 1, projection="3d")
        for e, col in [([1, 0, 0], "C0"), ([0, 1, 0], "C1")]:
            p = c.values @ np.array(e, float)
            ax.plot(*p.T, col, lw=2)
            ax.plot(*p[[0, -1]].T, "o", color=col, ms=4)
            if iters is not None:
                p0 = curve.values @ np.array(e, float)
                ax.plot(*p0.T, col, ls="--", lw=0.8, alpha=0.6)
        gap = np.degrees(np.linalg.norm(SO3G.log(c.values[-1] @ c.values[0].T)))
        ax.set_title(f"{label}: gap {gap:.2g} deg", fontsize=9)
        ax.set_box_aspect((1, 1, 1))
    fig.suptitle(
        "Closing a curve in SO(3): paths of (1,0,0) and (0,1,0); "
        "dashed: the open curve (cf. paper 000, Fig. 3)"
    )
    fig.tight_layout()
    fig.savefig(out / "closing_so3.png", dpi=110)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(
        description="Seamless loops of real clips, Lie group against Euler angles."
    )
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "docs" / "images")
    args = parser.parse_args()
    if not MOCAP.is_dir():
        raise SystemExit(f"real motion-capture folder not found: {MOCAP} (set ELASTIC_MOTION_MOCAP)")
    args.out.mkdir(parents=True, exist_ok=True)
    for key in CASES:
        print(plot_case(key, args.out)["file"])
    plot_seam_closeup(args.out)
    plot_c0_c1(args.out)
    plot_euler_float(args.out)
    plot_so3_flow(args.out)
    print(f"wrote loop_seam_closeup.png, loop_c0_c1.png, loop_euler_float.png, closing_so3.png to {args.out}")


if __name__ == "__main__":
    main()
