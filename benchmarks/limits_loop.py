"""Loops with joint limits kept versus not (issue 33): time ratio and convergence per clip.

Every shared clip with joint limits (the CMU ASF/AMC clips) is looped over the whole clip
(``window=None``, ``force=True``) with ``joint_limits="report"`` and ``"keep"``; the table
gives both times, their ratio, whether the closing converged, the limits the plain loop
crosses and those left after keeping them.

    PYTHONPATH=src python benchmarks/limits_loop.py      # -> benchmarks/results/limits_loop.json
"""

from __future__ import annotations

import argparse
import time

from _common import MOCAP, RESULTS, machine_info, write_json
from elastic_motion.apps.loop import loop_motion

CLIPS = ["02_01.amc", "backflip.amc", "charleston1.amc", "charleston2.amc"]


def _row(name: str) -> dict:
    path = MOCAP / "cmu" / "asfamc" / name
    row: dict = {"clip": name}
    for mode in ("report", "keep"):
        t0 = time.perf_counter()
        res = loop_motion(path, joint_limits=mode, window=None, force=True)
        row[f"{mode}_s"] = time.perf_counter() - t0
        jl = res.joint_limits
        row[f"{mode}_converged"] = bool(res.closing.converged)
        row[f"{mode}_new_violations"] = len(jl.new_violations) if jl is not None else None
        if mode == "keep" and jl is not None:
            row["pinned"] = jl.pinned
            row["keep_message"] = jl.message
    row["ratio"] = row["keep_s"] / row["report_s"]
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--clips", nargs="*", default=CLIPS)
    ap.add_argument("--out", default=str(RESULTS / "limits_loop.json"))
    args = ap.parse_args()
    rows = []
    print(
        f"{'clip':18s} {'plain s':>8s} {'keep s':>8s} {'ratio':>6s} {'conv':>9s} {'crossed':>8s} {'left':>5s}"
    )
    for name in args.clips:
        r = _row(name)
        rows.append(r)
        conv = f"{r['report_converged']!s:.1}/{r['keep_converged']!s:.1}"
        print(
            f"{name:18s} {r['report_s']:8.1f} {r['keep_s']:8.1f} {r['ratio']:6.1f} {conv:>9s} "
            f"{r['report_new_violations']!s:>8s} {r['keep_new_violations']!s:>5s}",
            flush=True,
        )
    write_json(args.out, {"machine": machine_info(), "rows": rows})


if __name__ == "__main__":
    main()
