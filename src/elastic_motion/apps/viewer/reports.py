"""The JSON reports the viewer reads beside a motion: finding them, checking that they match
the motion, and what they give to show (contacts, loop seams, a blend's time warps).

A report is used only when it matches the motion beside it (same frame count and frame rate,
or a loop's ``--repeat`` preview of it; contact joints that exist and intervals within the
clip); otherwise the functions here say why, in a note, and the viewer ignores it.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from elastic_motion.motion import Motion

__all__ = ["find_report", "loop_seams", "match_frames", "read_report", "report_contacts", "warp_plot"]

#: At most this many ``*.json`` files of a folder are read looking for a motion's report.
_MAX_REPORTS_SCANNED = 200
#: Larger files are not read as reports (bytes).
_MAX_REPORT_BYTES = 50_000_000


def read_report(path: Path) -> dict[str, Any] | None:
    """The JSON object in ``path``; None when it is not one, unreadable or over 50 MB."""
    try:
        if path.stat().st_size > _MAX_REPORT_BYTES:
            return None
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, UnicodeDecodeError):
        return None
    return data if isinstance(data, dict) else None


def _names_file(report: dict[str, Any], folder: Path, target: Path) -> bool:
    outs = report.get("outputs")
    if not isinstance(outs, list):
        return False
    tgt = target.resolve()
    for o in outs:
        if not isinstance(o, str) or Path(o).name != target.name:
            continue
        for base in (folder, Path.cwd()):
            p = Path(o) if os.path.isabs(o) else base / o
            try:
                if p.resolve() == tgt:
                    return True
            except OSError:
                continue
        if not os.path.isabs(o) and "/" not in o and os.sep not in o:
            return True  # a bare file name: written in the folder the command ran in
    return False


def find_report(path: str | os.PathLike[str]) -> tuple[Path, dict[str, Any]] | None:
    """The JSON report that lists ``path`` among its outputs, in the same folder.

    Looks at ``PATH.json`` first, then at every ``*.json`` file of the folder (at most 200,
    each at most 50 MB) whose ``outputs`` name the file; the newest (``created``) wins.

    Parameters
    ----------
    path : path
        A motion file written by ``elastic-motion loop`` or ``blend``.

    Returns
    -------
    (Path, dict) or None
    """
    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    found: list[tuple[str, Path, dict[str, Any]]] = []
    first = target.with_suffix(".json")
    candidates = [first] if first.is_file() else []
    try:
        others = sorted(p for p in folder.glob("*.json") if p != first)[:_MAX_REPORTS_SCANNED]
    except OSError:
        others = []
    for p in candidates + others:
        rep = read_report(p)
        if rep is not None and _names_file(rep, folder, target):
            found.append((str(rep.get("created", "")), p, rep))
    if not found:
        return None
    found.sort(key=lambda x: x[0])
    return found[-1][1], found[-1][2]


def _as_list(x: Any) -> list | None:
    return x if isinstance(x, list) else None


def match_frames(report: dict[str, Any], n_frames: int, fps: float) -> tuple[int, str]:
    """Cycles of the report's clip in the motion (1: the same clip), or 0 and why not."""
    rf = report.get("frames")
    rfps = report.get("fps")
    if not isinstance(rf, int) or rf < 2:
        return 0, "it gives no frame count"
    if isinstance(rfps, int | float) and abs(float(rfps) - fps) > 1e-6 * max(1.0, fps):
        return 0, f"it is for {float(rfps):g} fps, the motion is at {fps:g} fps"
    if rf == n_frames:
        return 1, ""
    if is_loop(report) and (n_frames - 1) % (rf - 1) == 0:
        return (n_frames - 1) // (rf - 1), ""  # a --repeat preview: cycles (F - 1) + 1 frames
    return 0, f"it is for {rf} frames, the motion has {n_frames}"


def is_loop(report: dict[str, Any]) -> bool:
    """Whether ``report`` is a loop's (its clip repeats with a seam)."""
    return report.get("command") == "loop" or "seam_after" in report


def report_contacts(
    report: dict[str, Any], names: Sequence[str], n_frames: int, cycles: int, notes: list[str], what: str
) -> dict[str, list[tuple[int, int]]] | None:
    """The contact intervals ``[start, stop)`` per joint the report gives (a loop's contacts,
    or those a blend planted), repeated over ``cycles``; None when it gives none or they do
    not fit the motion (``notes`` then say why, naming the report as ``what``)."""
    con = report.get("contacts")
    if con is None and isinstance(report.get("cleanup"), dict):  # a blend: the contacts it planted
        con = report["cleanup"].get("contacts")
    if con is None:
        return None
    joints = con.get("joints") if isinstance(con, dict) else None
    if not isinstance(joints, dict):
        notes.append(f"{what}: its contacts are not in the expected form (joints -> frames): ignored")
        return None
    out: dict[str, list[tuple[int, int]]] = {}
    cycle_frames = (n_frames - 1) // cycles + 1 if cycles > 1 else n_frames
    for name, entry in joints.items():
        runs = _as_list(entry.get("frames")) if isinstance(entry, dict) else None
        if name not in names or runs is None:
            notes.append(f"{what}: contact joint {name!r} is not in the motion: its contacts are ignored")
            return None
        ok = all(
            isinstance(r, list) and len(r) == 2 and all(isinstance(v, int) for v in r) and 0 <= r[0] < r[1]
            for r in runs
        )
        if not ok or any(r[1] > cycle_frames for r in runs):
            notes.append(f"{what}: contact intervals of {name!r} are outside the clip's frames: ignored")
            return None
        spans = []
        for k in range(cycles):
            spans += [(a + k * (cycle_frames - 1), b + k * (cycle_frames - 1)) for a, b in runs]
        out[name] = spans
    return out


def loop_seams(
    report: dict[str, Any], motion: Motion, cycles: int, notes: list[str], what: str
) -> list[float]:
    """The seam times (seconds) of a loop's report played ``cycles`` times in ``motion``
    (empty for other reports); a note gives the seam's largest joint angle before and after."""
    if not is_loop(report):
        return []
    f, fps = motion.n_frames, float(motion.fps)
    period = (f - 1) // cycles
    seams = [k * period / fps for k in range(1, cycles + 1)]
    sa, sb = report.get("seam_after") or {}, report.get("seam_before") or {}
    ang = (sb.get("seam_angle_max_deg"), sa.get("seam_angle_max_deg"))
    if all(isinstance(v, int | float) for v in ang):
        notes.append(
            f"{motion.name}: loop seam, largest joint angle {ang[0]:.3g} -> {ang[1]:.3g} deg (from {what})"
        )
    return seams


def _blend_timing(report: dict[str, Any], n_frames: int, fps: float) -> tuple[np.ndarray, list, str]:
    """Curve parameter ``u`` of every frame (blend step 4) and the warps, or a reason."""
    warps_raw = _as_list(report.get("warp_vertices"))
    weights = _as_list(report.get("weights"))
    prep = _as_list(report.get("preparation"))
    if not warps_raw:
        return np.zeros(0), [], "it has no warp_vertices"
    try:
        warps = [np.asarray(w, dtype=np.float64).reshape(-1, 2) for w in warps_raw]
    except (TypeError, ValueError):
        return np.zeros(0), [], "its warp_vertices are not (V, 2) lists"
    for w in warps:
        if (
            w.shape[0] < 2
            or not np.isfinite(w).all()
            or (np.diff(w[:, 0]) < -1e-12).any()
            or (np.diff(w[:, 1]) < -1e-12).any()
        ):
            return np.zeros(0), [], "its warp_vertices are not increasing warps"
    u = np.linspace(0.0, 1.0, n_frames)
    if weights and prep and len(weights) == len(warps) == len(prep):
        try:
            w = np.asarray(weights, dtype=np.float64)
            d = np.array([(int(p["frames_kept"]) - 1) / float(p["fps"]) for p in prep])
        except (KeyError, TypeError, ValueError, ZeroDivisionError):
            return u, warps, ""
        x = np.unique(np.concatenate([v[:, 0] for v in warps] + [np.linspace(0.0, 1.0, 257)]))
        total = sum(wk * dk * np.interp(x, v[:, 0], v[:, 1]) for v, wk, dk in zip(warps, w, d, strict=True))
        if (np.diff(total) > 0).all() and math.floor(total[-1] * fps + 1e-6) + 1 == n_frames:
            u = np.interp(np.arange(n_frames) / fps, total, x)
    return u, warps, ""


def warp_plot(
    report: dict[str, Any], n_frames: int, fps: float, keep: np.ndarray, notes: list[str], what: str
) -> dict[str, Any] | None:
    """The blend's time warps as the viewer plots them, at the shown frames ``keep``: each
    input's matched time (seconds, or curve parameter when its duration is unknown) per
    frame; None when the report has no usable warps (``notes`` say why)."""
    u, warps, why = _blend_timing(report, n_frames, fps)
    if why:
        notes.append(f"{what}: {why}: no warp plot")
        return None
    prep = _as_list(report.get("preparation")) or []
    labels = [
        str(p.get("label", f"input {k}")) if isinstance(p, dict) else f"input {k}" for k, p in enumerate(prep)
    ]
    labels += [f"input {k}" for k in range(len(labels), len(warps))]
    durs = []
    for k in range(len(warps)):
        try:
            durs.append((int(prep[k]["frames_kept"]) - 1) / float(prep[k]["fps"]))
        except (IndexError, KeyError, TypeError, ValueError, ZeroDivisionError):
            durs.append(None)
    curves = []
    for v, d in zip(warps, durs, strict=True):
        y = np.interp(u[keep], v[:, 0], v[:, 1])
        curves.append((y * d).round(5).tolist() if d is not None else y.round(5).tolist())
    return {"inputs": labels[: len(warps)], "seconds": [d is not None for d in durs], "curves": curves}
