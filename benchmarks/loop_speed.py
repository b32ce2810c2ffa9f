"""Benchmark of loop speed and memory (issue 30): whole clips closed with their contacts kept.

Rows: CMU 55_01 (a 15 s walk, 1807 frames at 120 fps: 3462 contact rows on its 30 fps grid)
and CMU 49_08 (cartwheels), looped whole with ``contacts="keep"`` (the projection solves the
closing and every contact frame together, :mod:`elastic_motion.apps.loop.kept_contacts`),
and each clip with the default options (the safe window). Each run is a fresh Python process
that reads the clip and calls :func:`elastic_motion.loop` (so the numba kernels are loaded
from their cache, as on a user's second run), timed around the call; its peak resident memory
(``ru_maxrss``, the whole process: Python, numpy, numba and the clip included) is reported
with the floor every run pays, a process that only reads the clip.

``--against REV`` (default ``aac1815``, the code issue 30 was measured on) runs the same rows
on that revision of ``src/`` (``git archive``, in a temporary folder) in the same run, and the
table gives the ratios; ``--against none`` skips it (the old code takes minutes on 55_01).

Targets (issue 30): 55_01 whole with contacts under 60 s and 300 MB; 49_08 under 15 s.

Usage: ``python benchmarks/loop_speed.py [--against REV|none] [--only 55_01 ...] [--out PATH]``
Real data from ``$ELASTIC_MOTION_MOCAP`` or ``../shared/mocap``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from _common import MOCAP, REPO, RESULTS, baseline_src, machine_info, write_json

CLIPS = {"55_01": "cmu/bvh/55_01.bvh", "49_08": "cmu/bvh/49_08.bvh"}
#: mode: keyword arguments of the loop (``None``: read the clip only, the memory floor)
MODES = {
    "read only": None,
    "whole, contacts keep": {"window": None, "contacts": "keep"},
    "default": {},
}

# One run, in its own process: the code on sys.path (this tree's or the baseline's).
RUNNER = """
import json, resource, sys, time
import elastic_motion as em
try:  # (older code has no LoopOptions and no refusals)
    from elastic_motion.apps.loop import LoopOptions
    refuses = "force" in LoopOptions.__dataclass_fields__
except ImportError:
    refuses = False
path, kwargs = sys.argv[1], json.loads(sys.argv[2])
motion = em.read(path)
out = {}
if kwargs is not None:
    if kwargs and refuses:
        kwargs["force"] = True  # a whole loop is measured, whatever it changes
    t = time.perf_counter()
    try:
        res = em.loop(motion, **kwargs)
        out["converged"] = bool(res.closing.converged)
        kept = res.contacts_kept
        out["rows"] = kept.get("rows") if isinstance(kept, dict) else getattr(kept, "rows", None)
        out["window"] = None if res.window is None else [res.window.start, res.window.stop]
    except Exception as exc:  # a refusal is a result too
        out["error"] = type(exc).__name__ + ": " + str(exc).splitlines()[0]
    out["seconds"] = time.perf_counter() - t
out["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps(out))
"""


def run(src: Path, path: Path, kwargs: dict | None) -> dict:
    """One row in a fresh process with ``src`` first on ``sys.path``."""
    env = {**os.environ, "PYTHONPATH": str(src)}
    proc = subprocess.run(
        [sys.executable, "-c", RUNNER, str(path), json.dumps(kwargs)],
        capture_output=True,
        text=True,
        env=env,
        check=False,
    )
    if proc.returncode != 0:
        return {"error": (proc.stderr.strip().splitlines() or ["failed"])[-1]}
    return json.loads(proc.stdout.strip().splitlines()[-1])


def fmt(v: object, spec: str = ".3g") -> str:
    return "-" if v is None else format(v, spec) if isinstance(v, float) else str(v)


def targets(rows: list[dict]) -> dict:
    """Issue 30's speed targets on this tree's rows."""

    def find(clip: str, mode: str) -> dict:
        return next((r for r in rows if r["clip"] == clip and r["mode"] == mode and r["code"] == "this"), {})

    whole_55, whole_49 = find("55_01", "whole, contacts keep"), find("49_08", "whole, contacts keep")
    return {
        "55_01_whole_s": whole_55.get("seconds"),
        "55_01_whole_peak_mb": whole_55.get("peak_mb"),
        "55_01_met": whole_55.get("seconds", 1e9) < 60 and whole_55.get("peak_mb", 1e9) < 300,
        "49_08_whole_s": whole_49.get("seconds"),
        "49_08_met": whole_49.get("seconds", 1e9) < 15,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--against", default="aac1815", help="git revision to compare with, or 'none'")
    ap.add_argument("--only", nargs="*", default=None, help="clip names (default: all)")
    ap.add_argument("--out", default=str(RESULTS / "loop_speed.json"))
    args = ap.parse_args()
    rows: list[dict] = []
    with tempfile.TemporaryDirectory() as tmp:
        codes = {"this": REPO / "src"}
        if args.against != "none":
            codes[args.against] = baseline_src(args.against, Path(tmp))
        for clip, rel in CLIPS.items():
            if args.only and clip not in args.only:
                continue
            path = MOCAP / rel
            if not path.exists():
                print(f"skip {clip}: {path} not found")
                continue
            for mode, kwargs in MODES.items():
                for code, src in codes.items():
                    if mode == "default" and code != "this":
                        continue  # the old default is the whole clip: the row above
                    r = {"clip": clip, "mode": mode, "code": code, **run(src, path, kwargs)}
                    print(json.dumps(r), flush=True)
                    rows.append(r)
    print("\n| clip | mode | code | seconds | peak MB | time ratio | memory ratio | rows | note |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        same = [o for o in rows if (o["clip"], o["mode"]) == (r["clip"], r["mode"])]
        ref = next((o for o in same if o["code"] == args.against), None)
        t_ratio = r["seconds"] / ref["seconds"] if ref and r.get("seconds") and ref.get("seconds") else None
        m_ratio = r["peak_mb"] / ref["peak_mb"] if ref and r.get("peak_mb") and ref.get("peak_mb") else None
        note = r.get("error") or ("" if r.get("converged", True) else "not converged")
        print(
            f"| {r['clip']} | {r['mode']} | {r['code']} | {fmt(r.get('seconds'))} "
            f"| {fmt(r.get('peak_mb'), '.0f')} "
            f"| {fmt(t_ratio, '.2f')} | {fmt(m_ratio, '.2f')} | {fmt(r.get('rows'))} | {note} |"
        )
    goal = targets(rows)
    print(f"\nissue 30 speed targets: {goal}")
    write_json(args.out, {"machine": machine_info(), "against": args.against, "rows": rows, "targets": goal})
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
