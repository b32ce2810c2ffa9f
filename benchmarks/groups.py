"""Benchmark of the group and curve kernels against scipy, in the same run.

Cases
-----
* ``exp`` / ``log`` of 1e6 rotations: ours (``SO3.exp`` / ``SO3.log``, matrices) against
  scipy ``Rotation.from_rotvec(v).as_matrix()`` and ``Rotation.from_matrix(R).as_rotvec()``,
  and scipy's quaternion-only path (``from_rotvec`` / ``as_rotvec`` on a ready Rotation),
  which does not produce or read matrices.
* SRVT and inverse SRVT of a 1000-frame curve in ``R^3 x SO(3)^31``.

Each time is the best of ``--repeat`` runs on one thread (numba kernels are serial).
Prints a markdown table and writes JSON (default ``benchmarks/results/groups.json``).

Usage: ``python benchmarks/groups.py [--n 1000000] [--repeat 7] [--out PATH]``
"""

from __future__ import annotations

import argparse
import os
import platform
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from _common import RESULTS, best_time, write_json
from elastic_motion.curves import DiscreteCurve, inverse_srv_transform, srv_transform
from elastic_motion.groups import SO3, animation_group


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--n", type=int, default=1_000_000, help="rotations for exp/log")
    parser.add_argument("--frames", type=int, default=1000, help="frames of the SRVT curve")
    parser.add_argument("--joints", type=int, default=31)
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--out", type=Path, default=RESULTS / "groups.json")
    args = parser.parse_args()

    rng = np.random.default_rng(0)
    g = SO3()
    v = rng.normal(size=(args.n, 3))
    mats = g.exp(v)
    rot = Rotation.from_rotvec(v)
    rows = []

    def row(case, ours, ref, ref_name, target):
        rows.append(
            {
                "case": case,
                "ours_ms": ours * 1e3,
                "reference": ref_name,
                "reference_ms": None if ref is None else ref * 1e3,
                "speedup": None if ref is None else ref / ours,
                "target_ms": target,
                "met": ours * 1e3 < target,
            }
        )

    t_exp = best_time(lambda: g.exp(v), args.repeat)
    row(
        f"exp, {args.n:.0e} rotations",
        t_exp,
        best_time(lambda: Rotation.from_rotvec(v).as_matrix(), args.repeat),
        "scipy from_rotvec().as_matrix()",
        50,
    )
    row(
        f"exp, {args.n:.0e} rotations (scipy without matrices)",
        t_exp,
        best_time(lambda: Rotation.from_rotvec(v), args.repeat),
        "scipy from_rotvec()",
        50,
    )
    t_log = best_time(lambda: g.log(mats), args.repeat)
    row(
        f"log, {args.n:.0e} rotations",
        t_log,
        best_time(lambda: Rotation.from_matrix(mats).as_rotvec(), args.repeat),
        "scipy from_matrix().as_rotvec()",
        50,
    )
    row(
        f"log, {args.n:.0e} rotations (scipy without matrices)",
        t_log,
        best_time(lambda: rot.as_rotvec(), args.repeat),
        "scipy as_rotvec()",
        50,
    )

    group = animation_group(args.joints)
    steps = np.cumsum(rng.normal(scale=0.05, size=(args.frames, group.dim)), axis=0)
    curve = DiscreteCurve(group.exp(steps), group)
    srv = srv_transform(curve)
    row(
        f"SRVT, {args.frames} frames, R^3 x SO(3)^{args.joints}",
        best_time(lambda: srv_transform(curve), args.repeat),
        None,
        "-",
        5,
    )
    row(
        f"inverse SRVT, {args.frames} frames, R^3 x SO(3)^{args.joints}",
        best_time(lambda: inverse_srv_transform(srv), args.repeat),
        None,
        "-",
        5,
    )

    print("| case | ours (ms) | reference | reference (ms) | speed-up | target (ms) | met |")
    print("|---|---:|---|---:|---:|---:|---|")
    for r in rows:
        ref_ms = "-" if r["reference_ms"] is None else f"{r['reference_ms']:.1f}"
        sp = "-" if r["speedup"] is None else f"{r['speedup']:.1f}x"
        print(
            f"| {r['case']} | {r['ours_ms']:.2f} | {r['reference']} | {ref_ms} | {sp} | "
            f"< {r['target_ms']} | {'yes' if r['met'] else 'NO'} |"
        )

    result = {
        "machine": {
            "cpu_count": os.cpu_count(),
            "python": platform.python_version(),
            "numpy": np.__version__,
        },
        "repeat": args.repeat,
        "rows": rows,
    }
    write_json(args.out, result)
    print(f"\nwrote {args.out}")


if __name__ == "__main__":
    main()
