"""Joint limits kept by blends and means (issue 33): time, limits crossed, change, distance.

Each case is run with ``joint_limits="off"`` and with the limits kept (best of ``--repeat``
after one warm-up call each). Limits: CMU charleston's ASF file (the inputs are its AMC clips),
and on Bandai pairs the *inputs' own range* (every DOF angle of every non-root joint boxed by
the two inputs' smallest and largest value: tight limits both inputs respect; the plain blend's
contact clean-up bends a knee past it). Per case: times and their ratio, the largest excess
beyond a limit the inputs respect before (the plain result) and after (read back from the
written BVH with the same ``check_joint_limits``), the frames changed and the largest change
of one DOF angle, and the Lie elastic distance of the result to each input before/after.

    PYTHONPATH=src python benchmarks/limits_blend.py    # -> benchmarks/results/limits_blend.json
"""

from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path

import numpy as np

from _common import MOCAP, RESULTS, machine_info, timed_best, write_json
from elastic_motion.apps.blend import blend_motions
from elastic_motion.apps.database.mean import mean_motion
from elastic_motion.apps.distance import distance_table
from elastic_motion.apps.prepare import PrepareOptions
from elastic_motion.motion import read_motion, write_motion
from elastic_motion.motion.asfamc import read_joint_limits
from elastic_motion.motion.joint_limits import JointLimits, check_joint_limits

ASF = MOCAP / "cmu" / "asfamc"
BANDAI = MOCAP / "bandai"
CASES = [
    ("blend", "charleston1 x charleston2", [ASF / "charleston1.amc", ASF / "charleston2.amc"], "asf"),
    (
        "blend",
        "bandai normal x tired",
        [BANDAI / "dataset-1_walk_normal_001.bvh", BANDAI / "dataset-1_walk_tired_001.bvh"],
        "box",
    ),
    (
        "blend",
        "bandai happy x sad",
        [BANDAI / "dataset-1_walk_happy_001.bvh", BANDAI / "dataset-1_walk_sad_001.bvh"],
        "box",
    ),
    ("mean", "charleston1, charleston2", [ASF / "charleston1.amc", ASF / "charleston2.amc"], "asf"),
    (
        "mean",
        "bandai normal, tired",
        [BANDAI / "dataset-1_walk_normal_001.bvh", BANDAI / "dataset-1_walk_tired_001.bvh"],
        "box",
    ),
]


def _run(kind: str, files, limits):
    if kind == "blend":
        res = blend_motions(files, 0.5, joint_limits=limits)
        return res, res.motion, list(res.prepared.motions)
    res = mean_motion(files, joint_limits=limits)
    return res, res.motion, [read_motion(f) for f in files]


def _excess_deg(motion, lim: JointLimits, inputs_ok: np.ndarray) -> float:
    """Largest excess (degrees) beyond a limit of a dof every input respects at all its frames."""
    rep = check_joint_limits(motion, lim)
    return math.degrees(float(rep.excess[:, inputs_ok].max(initial=0.0)))


def _case(kind: str, name: str, files, source: str, repeat: int) -> dict:
    t_off, (_, m_off, inputs) = timed_best(lambda: _run(kind, files, "off"), repeat)
    lim = (
        read_joint_limits(ASF / "charleston.asf")
        if source == "asf"
        else JointLimits.range_of(inputs, inputs[0].skeleton.names[1:])
    )
    lim = lim.restricted_to(m_off.skeleton.names)
    t_on, (kept, m_on, _) = timed_best(lambda: _run(kind, files, lim), repeat)
    ok = np.ones(lim.n_dofs, dtype=bool)
    for m in inputs:
        ok &= check_joint_limits(m, lim).excess.max(axis=0, initial=0.0) <= math.radians(0.01)
    with tempfile.TemporaryDirectory() as tmp:
        back = read_motion(write_motion(m_on, Path(tmp) / "out.bvh"))
    jl = kept.joint_limits
    dist = distance_table([m_off, m_on, *inputs], prepare=PrepareOptions(joints="common")).matrix
    return {
        "kind": kind,
        "case": name,
        "limits": source,
        "limited_dofs": lim.n_dofs,
        "dofs_inputs_respect": int(ok.sum()),
        "off_s": t_off,
        "keep_s": t_on,
        "ratio": t_on / t_off,
        "excess_before_deg": _excess_deg(m_off, lim, ok),
        "excess_after_deg": _excess_deg(back, lim, ok),
        "after_beyond_where_inputs_respect": int(
            ((check_joint_limits(back, lim).excess > math.radians(0.01)) & ~jl.exempt).sum()
        ),
        "changed_frames": jl.changed_frames,
        "frames": m_on.n_frames,
        "max_change_deg": jl.max_change_deg,
        "changed_joints": sorted({r["joint"] for r in jl.changed()}),
        "distance_before": [float(dist[0, 2 + k]) for k in range(len(inputs))],
        "distance_after": [float(dist[1, 2 + k]) for k in range(len(inputs))],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--out", default=str(RESULTS / "limits_blend.json"))
    args = ap.parse_args()
    rows = []
    head = (
        f"{'':5s} {'case':28s} {'off s':>6s} {'keep s':>6s} {'ratio':>5s} {'exc. before':>11s} {'after':>6s}"
    )
    print(head + f" {'changed':>9s} {'max chg':>7s} {'dist before':>13s} {'dist after':>13s}")
    for kind, name, files, source in CASES:
        r = _case(kind, name, files, source, args.repeat)
        rows.append(r)
        db = "/".join(f"{d:.3f}" for d in r["distance_before"])
        da = "/".join(f"{d:.3f}" for d in r["distance_after"])
        print(
            f"{kind:5s} {name:28s} {r['off_s']:6.2f} {r['keep_s']:6.2f} {r['ratio']:5.2f} "
            f"{r['excess_before_deg']:11.2f} {r['excess_after_deg']:6.3f} "
            f"{r['changed_frames']:4d}/{r['frames']:<4d} {r['max_change_deg']:7.2f} {db:>13s} {da:>13s}",
            flush=True,
        )
    targets = {
        "never beyond a limit the inputs respect (written BVH)": all(
            r["after_beyond_where_inputs_respect"] == 0 for r in rows
        ),
        "time with limits at most 2x": all(r["ratio"] <= 2.0 for r in rows),
    }
    print(targets)
    write_json(args.out, {"machine": machine_info(), "rows": rows, "targets": targets})


if __name__ == "__main__":
    main()
