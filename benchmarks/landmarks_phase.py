"""Do real walks need feature points? Paper 001's claim, tried on blends (issue 33).

Paper 001 shows feature points rescuing matches that the plain elastic warp gets wrong (its
planar Fig. 3-4, reproduced by ``examples/warp_2d.py``: which pair of extrema vanishes, which
finger goes to which). For blends of walks the question is whether the plain warp of the Lie
curves ever matches an event of one input to the wrong event of the other — a heel strike of
the left foot to one of the right, half a step off. This benchmark moves B's phase through a
whole step (its first ``shift`` seconds dropped) and blends each pair twice with the library's
default options: the plain warp (``landmarks=None``) and heel strikes / toe-offs / knee passes
detected and paired by phase (``landmarks="auto"``).

Columns, per pair and shift:

* ``plain offset``: the largest gap, over every detected event of A, between where the plain
  warp puts it in B and B's nearest event of the **same kind** (the ``landmark_pairing``
  record of the landmark run); ``half step``: half of B's median interval between consecutive
  heel strikes (either foot): about the gap at which the plain warp would sit nearer the
  other foot's event;
* skating (m/s over the output's own detected contacts), skids and slid distance of each
  blend, measured on the output exactly as on the inputs
  (:func:`elastic_motion.apps.metrics.foot_quality` via the blend's metrics).

Writes ``benchmarks/results/landmarks_phase.json``.  Data: ``$ELASTIC_MOTION_MOCAP`` or
``../shared/mocap``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from _common import MOCAP, RESULTS, machine_info, write_json
from elastic_motion.apps.blend import blend_motions
from elastic_motion.apps.landmarks import detect_events
from elastic_motion.apps.prepare import PrepareOptions

PAIRS = (("07_01", "08_02"), ("07_01", "09_11"), ("131_01", "131_02"))
SHIFTS = (0.0, 0.25, 0.5, 0.75)


def _half_step(res) -> float:
    """Half the median time between consecutive heel strikes (either foot) of input B, s."""
    events = detect_events(res.prepared.motions[1], ("left_heel_strike", "right_heel_strike"))
    strikes = np.sort([e.time for e in events])
    return float(np.median(np.diff(strikes)) / 2) if strikes.size > 1 else float("nan")


def _feet(res) -> dict:
    feet = res.metrics.summary()["feet"]
    r = feet["result"]
    return {
        "skating_m_s": r["skating_m_s"],
        "skids": r["skid_count"],
        "slid_m": r["slid_m"],
        "inputs_skating_m_s": [x["skating_m_s"] for x in feet["inputs"]],
        "inputs_skids": [x["skid_count"] for x in feet["inputs"]],
    }


def row(a: str, b: str, shift: float) -> dict:
    files = [MOCAP / "cmu" / "bvh" / f"{a}.bvh", MOCAP / "cmu" / "bvh" / f"{b}.bvh"]
    out: dict = {"pair": f"{a} x {b}", "shift_s": shift}
    for name, lm in (("plain", None), ("landmarks", "auto")):
        t0 = time.perf_counter()
        prepare = PrepareOptions(trim=(None, (shift, None)))
        res = blend_motions(files, 0.5, landmarks=lm, prepare=prepare, metrics=True)
        out[name] = {**_feet(res), "seconds": time.perf_counter() - t0}
        if lm is not None:
            pairs = (res.landmark_pairing or {}).get("pairs", [])
            out["events_paired"] = len(pairs)
            out["plain_offset_s"] = max((abs(p["offset_s"]) for p in pairs), default=0.0)
            out["half_step_s"] = _half_step(res)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(RESULTS / "landmarks_phase.json"))
    args = ap.parse_args(argv)
    rows = []
    head = (
        f"{'pair':17s} {'shift':>5s} {'events':>6s} {'plain off':>9s} {'half step':>9s} "
        f"{'skate plain':>11s} {'skate lm':>8s} {'skids p/lm':>10s} {'inputs skate':>13s}"
    )
    print(head)
    for a, b in PAIRS:
        for s in SHIFTS:
            r = row(a, b, s)
            rows.append(r)
            p, lm = r["plain"], r["landmarks"]
            print(
                f"{r['pair']:17s} {s:5.2f} {r['events_paired']:6d} {r['plain_offset_s']:9.3f} "
                f"{r['half_step_s']:9.3f} {p['skating_m_s']:11.3f} {lm['skating_m_s']:8.3f} "
                f"{p['skids']:>4d}/{lm['skids']:<5d} "
                f"{p['inputs_skating_m_s'][0]:6.3f},{p['inputs_skating_m_s'][1]:.3f}",
                flush=True,
            )
    worst = max(r["plain_offset_s"] / r["half_step_s"] for r in rows)
    print(f"largest plain-warp event offset / half step: {worst:.2f} (1 would be the other foot)")
    write_json(args.out, {"machine": machine_info(), "rows": rows, "worst_offset_per_half_step": worst})
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
