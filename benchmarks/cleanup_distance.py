"""Where the foot clean-up's elastic distance comes from (issue 29's distance row).

For the library's default blend (``blend_quality.py``'s default row: contacts kept, ends
trimmed, the contact-guided warp's rule) of each pair asked for, ``R0`` the blend before the
clean-up and ``R`` after it, all on the fine measure (cubic splines at 120 fps,
``blend_quality.FINE``), as fractions of ``d(A, B) / 2``, ``A`` and ``B`` the inputs over the
span the blend covers (``blend_quality.matched_spans``: its ends are trimmed):

* **d(R, A)**, **d(R, B)**, **d(R0, A)**, **d(R0, B)**, **d(R, R0)**: what the clean-up costs.
* **by joints**: ``d(R0, R0 + the clean-up's change on one group only)`` for the root
  translation, the hips (upper legs), knees, ankles, toes and every other joint. The SRV
  residual of the groups adds about in quadrature to ``d(R, R0)``.
* **by time scale**: ``d(R0, R_s)`` where ``R_s`` is ``R0`` with the clean-up's change (each
  joint's ``log(R0^T R)`` and the root offset) through a Gaussian of ``s`` frames
  (:func:`elastic_motion.motion.edit.smooth_change`): how much of ``d(R, R0)`` is the change's
  fast part (the SRV is made of velocities: a change of the same size costs more the faster it
  varies). ``R_s`` no longer plants the feet: a measure, not a candidate.
* **change**: per leg joint, the change's largest and RMS angle (deg) and angular speed
  (deg/s).

Prints a markdown table, writes JSON (default ``benchmarks/results/cleanup_distance.json``).
Data: ``$ELASTIC_MOTION_MOCAP`` or ``../shared/mocap``.

Usage: ``python benchmarks/cleanup_distance.py [--only deepmimic_walk_run,...] [--out PATH]``
"""

from __future__ import annotations

import argparse

import numpy as np

from _common import machine_info, write_json
from blend_quality import distances as _distances
from blend_quality import matched_spans, pairs
from elastic_motion.apps.blend import blend_motions
from elastic_motion.apps.cleanup import find_legs
from elastic_motion.groups import SO3
from elastic_motion.motion.edit import smooth_change

SCALES = (1.0, 2.0, 4.0, 8.0)
DEFAULT_ONLY = ("obstacles", "bandai_happy_sad", "deepmimic_walk_run")


def distances(motions: list, labels: list[str]) -> np.ndarray:
    return _distances(motions, labels, fine=True)


def groups(r0, r) -> dict:
    """The clean-up's change on one group of joints (or the root translation) at a time."""
    legs, _ = find_legs(r0)
    by = {
        "hips": [leg.hip for leg in legs],
        "knees": [leg.knee for leg in legs],
        "ankles": [leg.ankle for leg in legs],
        "toes": [leg.toe for leg in legs if leg.toe >= 0],
    }
    on_legs = {j for js in by.values() for j in js}
    by["other joints"] = [j for j in range(r0.n_joints) if j not in on_legs]
    out = {"root translation": r0.replace(root_translation=r.root_translation)}
    for name, js in by.items():
        rot = r0.rotations.copy()
        rot[:, js] = r.rotations[:, js]
        out[name] = r0.replace(rotations=rot)
    return out


def change(r0, r) -> dict:
    """Per leg joint, the change's angle and angular speed (deg, deg/s): max and RMS."""
    rel = SO3().log(np.swapaxes(r0.rotations, -1, -2) @ r.rotations)
    angle = np.degrees(np.linalg.norm(rel, axis=-1))
    speed = np.degrees(np.linalg.norm(np.diff(rel, axis=0), axis=-1)) * r.fps
    legs, _ = find_legs(r0)
    out = {}
    for j in sorted({j for leg in legs for j in (leg.hip, leg.knee, leg.ankle) if j >= 0}):
        out[r0.skeleton.names[j]] = {
            "angle_max_deg": float(angle[:, j].max()),
            "angle_rms_deg": float(np.sqrt((angle[:, j] ** 2).mean())),
            "speed_max_deg_s": float(speed[:, j].max()),
            "speed_rms_deg_s": float(np.sqrt((speed[:, j] ** 2).mean())),
        }
    return out


def run_pair(key: str, a, b) -> dict:
    res = blend_motions([a, b], 0.5, trim_ends=True, contact_warp="auto")
    r, r0 = res.motion, res.before_cleanup
    # the default blend trims its ends: against the inputs over the span it blends
    d = distances([*matched_spans(res), r, r0], ["A", "B", "R", "R0"])
    half = d[0, 1] / 2
    parts = groups(r0, r)
    smoothed = {f"{s:g}": smooth_change(r0, r, s) for s in SCALES}
    dp = distances([r0, *parts.values(), *smoothed.values()], ["R0", *parts, *smoothed])
    n = len(parts)
    return {
        "pair": key,
        "half_d_A_B_fine": float(half),
        "smooth_s": None if res.cleanup is None else res.cleanup.smooth,
        "d_R_A": float(d[2, 0] / half),
        "d_R_B": float(d[2, 1] / half),
        "d_R0_A": float(d[3, 0] / half),
        "d_R0_B": float(d[3, 1] / half),
        "d_R_R0": float(d[2, 3] / half),
        "by_joints": {name: float(dp[0, 1 + i] / half) for i, name in enumerate(parts)},
        "by_scale_frames": {s: float(dp[0, 1 + n + i] / half) for i, s in enumerate(smoothed)},
        "change": change(r0, r),
    }


def fmt(x: float) -> str:
    return f"{x:.3f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--only", default=",".join(DEFAULT_ONLY), help="comma-separated pairs (default: %(default)s)"
    )
    ap.add_argument(
        "--out", default="benchmarks/results/cleanup_distance.json", help="(default: %(default)s)"
    )
    args = ap.parse_args()
    todo = pairs()
    rows = [run_pair(k, *todo[k]()) for k in args.only.split(",")]
    print("All as fractions of d(A, B) / 2, fine measure.\n")
    heads = ["pair", "smooth (s)", "d(R,A)", "d(R,B)", "d(R0,A)", "d(R0,B)", "d(R,R0)"]
    print("| " + " | ".join(heads) + " |\n|" + "---|" * len(heads))
    for r in rows:
        cells = [r["d_R_A"], r["d_R_B"], r["d_R0_A"], r["d_R0_B"], r["d_R_R0"]]
        print(f"| {r['pair']} | {r['smooth_s']} | " + " | ".join(map(fmt, cells)) + " |")
    names = list(rows[0]["by_joints"])
    print("\nd(R0, R0 with the change on one group only):\n")
    print("| pair | " + " | ".join(names) + " |\n|" + "---|" * (len(names) + 1))
    for r in rows:
        print(f"| {r['pair']} | " + " | ".join(fmt(r["by_joints"][k]) for k in names) + " |")
    print("\nd(R0, R0 with the change smoothed by s frames):\n")
    print("| pair | d(R,R0) | " + " | ".join(f"s = {s:g}" for s in SCALES) + " |")
    print("|" + "---|" * (len(SCALES) + 2))
    for r in rows:
        cells = [r["d_R_R0"], *r["by_scale_frames"].values()]
        print(f"| {r['pair']} | " + " | ".join(map(fmt, cells)) + " |")
    write_json(args.out, {"machine": machine_info(), "rows": rows})


if __name__ == "__main__":
    main()
