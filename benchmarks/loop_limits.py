"""Benchmark of loops with joint limits kept (issue 33): time and convergence against the same
loop with the limits only reported.

Rows: every shared clip with joint limits (the CMU ASF/AMC clips: the ASF ``limits``; the BVH,
DeepMimic and Bandai clips carry none and the project has no standard human limit set), looped
with the default options (``force=True``) and ``joint_limits="report"`` then ``"keep"``, the
two alternated ``--repeat`` times in this process and each timed by its best run (the machine
is shared: the best run is the one least slowed by others). Per row: wall time of each, the
ratio keep/report (wall, and process CPU time), whether the loop with limits converged (the
closing, and every limits solve: no ``joint_limits.message``), the window, limit solves (and
their probes, one Newton iteration each), pinned rows, contacts released, the seam's largest
angle, and the largest excess over a limit the input respected on the *written BVH*, read
back (``check_joint_limits``; frames 0 and ``F - 1`` excluded, as in :mod:`elastic_motion.apps.loop.limits`).

Targets (issue 33): keep at most 2x the time of report, and converged on every clip (every
kept limit within ``limit_tol``, 0.5 deg, on the written BVH).

Usage: ``python benchmarks/loop_limits.py [--only backflip ...] [--repeat 2] [--out PATH]``
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


def run(path: Path, mode: str) -> tuple[float, float, object]:
    """One loop: wall and process CPU seconds, and the result."""
    t, c = time.perf_counter(), time.process_time()
    res = loop_motion(path, joint_limits=mode, force=True)
    return time.perf_counter() - t, time.process_time() - c, res


def row(name: str, repeat: int) -> dict:
    """Report and keep of one clip, alternated ``repeat`` times; the best time of each."""
    times: dict[str, list[tuple[float, float]]] = {"report": [], "keep": []}
    out = {}
    for _ in range(repeat):
        for mode in ("report", "keep"):
            wall, cpu, out[mode] = run(MOCAP / CLIPS[name], mode)
            times[mode].append((wall, cpu))
    res = out["keep"]
    jl = res.joint_limits
    limits = read_joint_limits(res.original)
    kept = res.contacts_kept
    best = {m: (min(w for w, _ in t), min(c for _, c in t)) for m, t in times.items()}
    return {
        "clip": name,
        "report_s": best["report"][0],
        "keep_s": best["keep"][0],
        "ratio": best["keep"][0] / best["report"][0],
        "ratio_cpu": best["keep"][1] / best["report"][1],
        "times": times,
        "converged": bool(res.closing.converged) and not jl.message,
        "window": None if res.window is None else [res.window.start, res.window.stop],
        "solves": jl.rounds,
        "probes": jl.probes,
        "pinned": jl.pinned,
        "released": [] if kept is None else [dict(r) for r in kept.released],
        "new_violations": list(jl.new_violations),
        "message": jl.message,
        "seam_max_deg": res.seam_after.seam_angle_max_deg,
        "written_new_excess_deg": new_excess_deg(res, limits, 0.5),
        "report_written_new_excess_deg": new_excess_deg(out["report"], limits, 0.5),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="*", default=list(CLIPS))
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--out", default=str(RESULTS / "loop_limits.json"))
    args = ap.parse_args()
    rows = []
    print(
        f"{'clip':<12} {'report s':>8} {'keep s':>7} {'ratio':>6} {'cpu ratio':>9} {'<=2x':>5} {'conv':>5} "
        f"{'window':>11} {'solves':>6} {'probes':>6} {'pinned':>6} {'released':>8} "
        f"{'exc report':>10} {'exc keep':>8}"
    )
    for name in args.only:
        r = row(name, args.repeat)
        print(
            f"{name:<12} {r['report_s']:8.1f} {r['keep_s']:7.1f} {r['ratio']:6.2f} {r['ratio_cpu']:9.2f} "
            f"{'yes' if r['ratio'] <= 2.0 else 'NO':>5} {'yes' if r['converged'] else 'NO':>5} "
            f"{r['window']!s:>11} {r['solves']:6d} {r['probes']:6d} {r['pinned']:6d} {len(r['released']):8d} "
            f"{r['report_written_new_excess_deg']:10.2f} {r['written_new_excess_deg']:8.2f}",
            flush=True,
        )
        if r["message"]:
            print(f"  {name}: {r['message']}")
        rows.append(r)
    print("(excess: the largest new excess over a limit on the written BVH, degrees; limit_tol 0.5)")
    print(f"wrote {write_json(args.out, {'machine': machine_info(), 'repeat': args.repeat, 'rows': rows})}")


if __name__ == "__main__":
    main()
