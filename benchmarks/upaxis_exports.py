"""Benchmark of up-axis detection on Z-up exports (issue 31): what ``info`` says of the
files Blender writes, in full and in place.

Rows: every shared clip (CMU BVH, Bandai BVH, DeepMimic), each exported

* **simulated** (no Blender): Blender's armature space built from the Y-up clip (offsets,
  local rotations and translations turned by ``(x, y, z) -> (x, -z, y)``), in full and in
  place (the hips held at their mean horizontal position, their height kept: the planted
  feet slide back as on a treadmill), and in place Y-up; plus in-place windows of 1.5 s
  (half-overlapping, at most 12 per clip), Y-up and Z-up;
* **Blender** (``--blender``, Blender 3.4 headless, one launch): each BVH imported
  (DeepMimic clips written as BVH first) and exported in full, with
  ``root_transform_only``, and in place (the bone that carries the travel keyed at its mean
  horizontal position).

A file counts as right when :func:`elastic_motion.motion.read_bvh` labels it with the
axis it was written with (the detector's ``up_axis``: ambiguous estimates fall back to y).

Measured: simulated full 43/43, in place Z-up 43/43 (42 before issue 31: the DeepMimic
crawl), Y-up 43/43, windows 372/378 (364 before); Blender 129/129 (125/129 before: the
Bandai old-style walk in place, the DeepMimic crawl in place, the get-up face down in full
and root-only were ambiguous).

Usage: ``python benchmarks/upaxis_exports.py [--blender] [--out PATH]``; prints a table and
writes ``benchmarks/results/upaxis_exports.json``.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from _common import MOCAP, RESULTS, machine_info, write_json
from elastic_motion.motion import (
    Motion,
    detect_up_axis,
    drop_tpose,
    read_bvh,
    read_motion,
    select_frames,
    write_bvh,
)

BLENDER_SCRIPT = Path(__file__).resolve().parents[1] / "tests" / "apps" / "test_blender_upaxis.py"
# the simulated exports are the tests' own (one home: tests/motion/motion_testlib.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "motion"))
from motion_testlib import blender_export, in_place  # noqa: E402


def clips() -> list[tuple[str, Path]]:
    files = sorted((MOCAP / "cmu" / "bvh").glob("*.bvh")) + sorted((MOCAP / "bandai").glob("*.bvh"))
    dm = MOCAP / "deepmimic"
    files += sorted(dm.glob("humanoid3d_*.txt")) + sorted((dm / "walker").glob("*.txt"))
    return [(p.name, p) for p in files]


def load(path: Path) -> Motion:
    m = read_motion(path)
    return drop_tpose(m) if "cmu" in path.parts else m


def read_as(m: Motion, work: Path) -> tuple[str, float]:
    back = read_bvh(write_bvh(m, work / "x.bvh"))
    return back.up_axis, detect_up_axis(back).confidence


def simulated(work: Path) -> dict:
    rows = []
    for name, path in clips():
        m = load(path).replace(up_axis="y")
        z = blender_export(m)
        row = {"clip": name}
        for kind, x, want in (
            ("full_z", z, "z"),
            ("in_place_z", in_place(z, "z"), "z"),
            ("in_place_y", in_place(m, "y"), "y"),
        ):
            got, margin = read_as(x, work)
            row[kind] = {"read": got, "right": got == want, "margin": round(margin, 3)}
        w = round(1.5 * m.fps)
        starts = list(range(0, max(m.n_frames - w, 1), max(w // 2, 1)))[:12]
        right = 0
        for s in starts:
            win = select_frames(m, slice(s, min(s + w, m.n_frames)))
            right += read_as(in_place(win, "y"), work)[0] == "y"
            right += read_as(in_place(blender_export(win), "z"), work)[0] == "z"
        row["windows"] = {"right": right, "of": 2 * len(starts)}
        rows.append(row)
        print(
            f"{name:36s} "
            + " ".join(f"{k}={row[k]['read']}" for k in ("full_z", "in_place_z", "in_place_y"))
            + f" windows {right}/{2 * len(starts)}",
            flush=True,
        )
    return {"rows": rows}


def blender(work: Path) -> dict:
    exe = shutil.which("blender")
    if exe is None:
        return {"skipped": "blender is not installed"}
    src = work / "src"
    src.mkdir()
    jobs = []
    for k, (_, path) in enumerate(clips()):
        if path.suffix != ".bvh":
            path = write_bvh(read_motion(path), src / f"{path.stem}.bvh")
        n = read_bvh(path).n_frames
        jobs.append([f"c{k}", str(path), 1, n])
    code = BLENDER_SCRIPT.read_text()
    script = work / "export.py"
    script.write_text(code[code.index('r"""') + 4 : code.index('"""\n\n\n@pytest.fixture')])
    proc = subprocess.run(
        [exe, "-b", "--factory-startup", "--python", str(script), "--", str(work), json.dumps(jobs)],
        capture_output=True,
        text=True,
        timeout=1800,
    )
    if "EMRESULT" not in proc.stdout:
        raise RuntimeError(proc.stdout[-2000:] + proc.stderr[-2000:])
    rows = []
    for (key, *_), (name, _) in zip(jobs, clips(), strict=True):
        row = {"clip": name}
        for kind in ("full", "root_only", "in_place"):
            m = read_bvh(work / f"{key}_{kind}.bvh")
            row[kind] = {
                "read": m.up_axis,
                "right": m.up_axis == "z",
                "margin": round(detect_up_axis(m).confidence, 3),
            }
        rows.append(row)
    return {"rows": rows}


def table(result: dict) -> str:
    out = []
    sim = result["simulated"]["rows"]
    for kind in ("full_z", "in_place_z", "in_place_y"):
        out.append(f"simulated {kind:12s} {sum(r[kind]['right'] for r in sim)}/{len(sim)}")
    right, of = sum(r["windows"]["right"] for r in sim), sum(r["windows"]["of"] for r in sim)
    out.append(f"simulated windows     {right}/{of}")
    bl = result.get("blender", {}).get("rows")
    if bl:
        for kind in ("full", "root_only", "in_place"):
            out.append(f"blender {kind:14s} {sum(r[kind]['right'] for r in bl)}/{len(bl)}")
        wrong = [(r["clip"], k) for r in bl for k in ("full", "root_only", "in_place") if not r[k]["right"]]
        out.append(f"blender wrong: {wrong or 'none'}")
    return "\n".join(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--blender", action="store_true", help="also export with Blender (about 3 minutes)")
    ap.add_argument("--out", type=Path, default=RESULTS / "upaxis_exports.json")
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="em-upaxis-"))
    try:
        result = {"machine": machine_info(), "simulated": simulated(work)}
        if args.blender:
            result["blender"] = blender(work)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(table(result))
    write_json(args.out, result)
    print(f"\nwritten {args.out}")


if __name__ == "__main__":
    main()
