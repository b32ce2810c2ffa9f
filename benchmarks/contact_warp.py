"""The contact-guided warp by default (issue 29, ``contact_warp``): when it runs, what it keeps,
what it costs.

Every pair of ``benchmarks/blend_quality.py`` (:func:`blend_quality.pairs`), blended by the
library's default (``blend_motions([a, b], 0.5)``) with the clean-up (``contacts="keep"``) and
without it (``contacts="report"``), with ``contact_warp="off"`` and ``"auto"``: best time of
``--repeat`` calls each after one warm-up call, the two options timed back to back in this
process. Per row: the rule's decision (``BlendResult.contact_warp``: the skids and slid distance
of the blend on the plain warp and, when it was built, on the guided one, counted as the inputs'
are; the inputs' larger count; ``d(A, B)`` under each warp; which warp was kept and why), the
times and their ratio, and whether the result differs from ``"off"``'s.

    PYTHONPATH=src python benchmarks/contact_warp.py [--only obstacles,...] [--repeat 2]
    # -> benchmarks/results/contact_warp.json
"""

from __future__ import annotations

import argparse

import numpy as np

from _common import RESULTS, machine_info, timed_best, write_json
from blend_quality import pairs
from elastic_motion.apps.blend import blend_motions


def _row(name: str, a, b, contacts: str, repeat: int) -> dict:
    t_off, off = timed_best(lambda: blend_motions([a, b], 0.5, contacts=contacts, contact_warp="off"), repeat)
    t_auto, auto = timed_best(
        lambda: blend_motions([a, b], 0.5, contacts=contacts, contact_warp="auto"), repeat
    )
    same = off.motion.n_frames == auto.motion.n_frames and np.array_equal(
        off.motion.rotations, auto.motion.rotations
    )
    return {
        "pair": name,
        "cleanup": contacts == "keep",
        "decision": auto.contact_warp,
        "seconds_off": t_off,
        "seconds_auto": t_auto,
        "time_ratio": t_auto / t_off,
        "same_as_off": bool(same),
    }


def _line(r: dict) -> str:
    d = r["decision"] or {}
    p, g = d.get("plain") or {}, d.get("guided")
    guided = "-" if g is None else f"{g['skids']}, {g['slid_m']:.3f} ({g['landmark_pairs']} pairs)"
    dist = f"{p.get('distance', float('nan')):.3f}" + (
        "" if g is None else f" -> {g['distance']:.3f} ({g['distance'] / p['distance']:.3f}x)"
    )
    return (
        f"| {r['pair']} | {'on' if r['cleanup'] else 'off'} | {p.get('skids')}, {p.get('slid_m', 0):.3f} / "
        f"{d.get('inputs_skids')} | {guided} | {dist} | {d.get('kept')} | "
        f"{r['seconds_off']:.2f} -> {r['seconds_auto']:.2f} ({r['time_ratio']:.2f}x) |"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default=None, help="comma-separated pairs (default: all)")
    ap.add_argument("--repeat", type=int, default=2, help="timed calls per option (default: 2)")
    ap.add_argument("--out", default=str(RESULTS / "contact_warp.json"))
    args = ap.parse_args()
    table = pairs()
    names = args.only.split(",") if args.only else list(table)
    rows = []
    print(
        "| pair | clean-up | plain: skids, slid (m) / inputs | guided: skids, slid (m) | d(A, B) | kept "
        "| s, off -> auto |\n|---|---|---|---|---|---|---|",
        flush=True,
    )
    for name in names:
        a, b = table[name]()
        for contacts in ("keep", "report"):
            rows.append(_row(name, a, b, contacts, args.repeat))
            print(_line(rows[-1]), flush=True)
    write_json(args.out, {"machine": machine_info(), "rows": rows})
    print(f"\nwrote {args.out}")


if __name__ == "__main__":
    main()
