"""Speed of BVH reading, writing and forward kinematics on a 10,000-frame, 31-joint clip.

Targets (issue "Motions in and out"): read < 0.5 s, write < 0.5 s, FK < 0.3 s.

Two clips are written to a temporary folder and timed: the frames of the CMU file
``131_01.bvh`` (31 joints, 96 channels, 120 Hz) tiled to 10,000 frames (when
``../shared/mocap`` is present), and a synthetic 31-joint skeleton with random rotations
(every value with all 8 decimals: the largest file, the worst case for the parser). Each
timing is the best of ``--repeat`` runs after one warm-up run (numba compilation, file
cache).

Usage: ``python benchmarks/io.py [--frames 10000] [--repeat 5]``. Prints a markdown table
and writes ``benchmarks/results/io.json``.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import tempfile
from pathlib import Path

import numpy as np

from _common import RESULTS, best_time, write_json
from elastic_motion.motion import Motion, Skeleton, forward_kinematics, read_bvh, write_bvh
from elastic_motion.motion.rotations import euler_to_matrix

HERE = Path(__file__).resolve().parent
MOCAP = Path(os.environ.get("ELASTIC_MOTION_MOCAP", HERE.parent.parent / "shared" / "mocap"))
TARGETS = {"read": 0.5, "write": 0.5, "fk": 0.3}


def synthetic_motion(n_frames: int, n_joints: int = 31, seed: int = 0) -> Motion:
    """A chain-and-branch skeleton with random rotations (degrees-scale noise)."""
    rng = np.random.default_rng(seed)
    parents = [-1] + [int(rng.integers(0, j)) for j in range(1, n_joints)]
    channels = [("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")]
    channels += [("Zrotation", "Yrotation", "Xrotation")] * (n_joints - 1)
    sk = Skeleton(
        names=[f"j{k}" for k in range(n_joints)],
        parents=parents,
        offsets=rng.normal(0.0, 5.0, (n_joints, 3)),
        channels=channels,
    )
    angles = rng.uniform(-np.pi, np.pi, (n_frames, n_joints, 3))
    angles[..., 1] *= 0.5
    return Motion(sk, 120.0, rng.normal(0.0, 10.0, (n_frames, 3)), euler_to_matrix(angles, "ZYX"))


def source_motions(n_frames: int) -> list[tuple[Motion, str]]:
    """The CMU clip tiled (when the shared data is there) and the random worst case."""
    out = []
    path = MOCAP / "cmu" / "bvh" / "131_01.bvh"
    if path.is_file():
        m = read_bvh(path)
        reps = -(-n_frames // m.n_frames)
        idx = np.tile(np.arange(m.n_frames), reps)[:n_frames]
        tiled = m.replace(rotations=m.rotations[idx], root_translation=m.root_translation[idx], source=())
        out.append((tiled, f"CMU 131_01.bvh tiled to {n_frames} frames"))
    # Random rotations: every value written with all 8 decimals (the largest file).
    out.append((synthetic_motion(n_frames), f"random rotations, {n_frames} frames"))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=10_000)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)

    records = []
    print(
        f"BVH I/O, best of {args.repeat} runs (targets: read {TARGETS['read']} s, "
        f"write {TARGETS['write']} s, FK {TARGETS['fk']} s)\n"
    )
    print("| clip | joints | channels | file (MB) | read (s) | write (s) | FK (s) | all within target |")
    print("|---|---:|---:|---:|---:|---:|---:|---|")
    for motion, what in source_motions(args.frames):
        with tempfile.TemporaryDirectory() as tmp:
            src = Path(tmp) / "bench.bvh"
            write_bvh(motion, src)
            size_mb = src.stat().st_size / 1e6
            loaded = read_bvh(src)
            out = Path(tmp) / "out.bvh"
            results = {
                "read": best_time(lambda src=src: read_bvh(src), args.repeat),
                "write": best_time(lambda m=loaded, out=out: write_bvh(m, out), args.repeat),
                "fk": best_time(lambda m=loaded: forward_kinematics(m), args.repeat),
            }
        ok = all(results[k] < TARGETS[k] for k in TARGETS)
        times = " | ".join(f"{results[k]:.3f}" for k in ("read", "write", "fk"))
        print(
            f"| {what} | {loaded.n_joints} | {loaded.skeleton.n_channels} | {size_mb:.1f} | "
            f"{times} | {'yes' if ok else 'NO'} |"
        )
        records.append(
            {
                "clip": what,
                "frames": loaded.n_frames,
                "joints": loaded.n_joints,
                "channels": loaded.skeleton.n_channels,
                "file_mb": round(size_mb, 2),
                "seconds": {k: round(v, 4) for k, v in results.items()},
                "within_targets": ok,
            }
        )
    record = {
        "benchmark": "bvh_io",
        "repeat": args.repeat,
        "targets_s": TARGETS,
        "clips": records,
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "machine": platform.machine(),
        "cpus": os.cpu_count(),
    }
    write_json(RESULTS / "io.json", record)
    return 0


if __name__ == "__main__":
    sys.exit(main())
