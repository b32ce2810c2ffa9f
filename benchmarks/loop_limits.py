"""Benchmark of loops with joint limits kept (issue 33): time and convergence against the same
loop with the limits only reported.

Rows: every shared clip with joint limits (the CMU ASF/AMC clips: the ASF ``limits``; the BVH,
DeepMimic and Bandai clips carry none and the project has no standard human limit set), looped
with the default options (``force=True``) and ``joint_limits="report"`` then ``"keep"``.
Per row: wall time, the time ratio keep/report, whether the loop converged (the closing, and
every limits solve: no ``joint_limits.message``), the window, limit solves and pinned rows,
the seam's largest angle, and the largest excess over a limit the input respected on the
*written BVH*, read back (``check_joint_limits``; frames 0 and ``F - 1`` excluded, as in
:mod:`elastic_motion.apps.loop.limits`).

Targets (issue 33): keep at most 2x the time of report, and converged on every clip.

Usage: ``python benchmarks/loop_limits.py [--only backflip ...] [--out PATH]``
Real data from ``$ELASTIC_MOTION_MOCAP`` or ``../shared/mocap``.
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import numpy as np

import elastic_motion as em
from _common import MOCAP, RESULTS, machine_info, write_json
from elastic_motion.apps.loop import loop_motion
from elastic_motion.motion import read_motion
from elastic_motion.motion.asfamc import read_joint_limits
from elastic_motion.motion.joint_limits import check_joint_limits

CLIPS = {
    "02_01": "cmu/asfamc/02_01.amc",
    "backflip": "cmu/asfamc/backflip.amc",
    "charleston1": "cmu/asfamc/charleston1.amc",
    "charleston2": "cmu/asfamc/charleston2.amc",
}


def new_excess_deg(res, limits, tol_deg: float) -> float:
    """Largest excess (degrees) on the written BVH, read back, over a limit the looped input
    respected (within ``tol_deg``); frames 0 and ``F - 1`` excluded."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "loop.bvh"
        em.write(res, out)
        written = read_motion(out)
    before = check_joint_limits(res.original, limits)
    after = check_joint_limits(written, limits)
    new = before.excess <= math.radians(tol_deg)
    new[[0, -1]] = False
    return float(np.degrees(np.max(np.where(new, after.excess, 0.0), initial=0.0)))


def run(path: Path, mode: str) -> dict:
    t = time.perf_counter()
    res = loop_motion(path, joint_limits=mode, force=True)
    seconds = time.perf_counter() - t
    jl = res.joint_limits
    limits = read_joint_limits(res.original)
    return {
        "mode": mode,
        "seconds": seconds,
        "converged": bool(res.closing.converged) and not (mode == "keep" and jl.message),
        "window": None if res.window is None else [res.window.start, res.window.stop],
        "solves": jl.rounds,
        "pinned": jl.pinned,
        "new_violations": list(jl.new_violations),
        "message": jl.message,
        "seam_max_deg": res.seam_after.seam_angle_max_deg,
        "written_new_excess_deg": new_excess_deg(res, limits, 0.5),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="*", default=list(CLIPS))
    ap.add_argument("--out", default=str(RESULTS / "loop_limits.json"))
    args = ap.parse_args()
    rows = []
    head = f"{'clip':<12} {'mode':<7} {'time s':>7} {'ratio':>6} {'conv':>5} {'window':>11} "
    print(head + f"{'solves':>6} {'pinned':>6} {'seam deg':>9} {'new excess deg':>14}")
    for name in args.only:
        free = run(MOCAP / CLIPS[name], "report")
        kept = run(MOCAP / CLIPS[name], "keep")
        kept["ratio"] = kept["seconds"] / free["seconds"]
        for r in (free, kept):
            print(
                f"{name:<12} {r['mode']:<7} {r['seconds']:7.1f} {r.get('ratio', 1.0):6.2f} "
                f"{'yes' if r['converged'] else 'NO':>5} {r['window']!s:>11} {r['solves']:6d} "
                f"{r['pinned']:6d} {r['seam_max_deg']:9.2g} {r['written_new_excess_deg']:14.2f}",
                flush=True,
            )
            rows.append({"clip": name, **r})
    print(f"wrote {write_json(args.out, {'machine': machine_info(), 'rows': rows})}")


if __name__ == "__main__":
    main()
