"""An interactive 3D player for motions, in one HTML page that works offline.

``elastic-motion view A.bvh [B.bvh ...] -o view.html`` and the demo's ``index.html`` use
:func:`build_viewer`: the skeletons drawn by plotly.js (``pip install
"elastic-motion[viewer]"``; its JavaScript is written into the page, or beside it, so the
page opens from ``file://`` without a network or a server), with

* orbit and zoom (plotly's 3D scene), play / pause, speed, a frame slider;
* clips side by side or overlaid on one floor;
* joint trajectories on demand (pick joints in a list);
* contacts (planted joints marked in the scene, intervals on a timeline, a footprint where
  each contact starts) and the loop seam (on the timeline), when the motion came from
  ``loop`` or ``blend``: read from the JSON report beside it (:func:`find_report`);
* the time warp of a blend as a plot linked to the player (the cursor follows the slider;
  a click on the plot moves the player there).

Conventions
-----------
* Motions are read with :func:`elastic_motion.apps.prepare.load_motion` without dropping
  a T-pose frame (the viewer shows every frame of the file, so that frame numbers match
  the reports): metres when the unit is known, Y-up.
* Displayed coordinates are the motion's ``(x, y, z)`` drawn as plotly's ``(x, -z, y)``
  (a rotation, not a mirror: plotly's scene turns about its z axis, so "up" stays up when
  orbiting; the same map Blender's importer applies).
* The floor is drawn at the first clip's floor height
  (:func:`elastic_motion.motion.contacts.floor_height`); a clip whose own floor differs by
  more than 2 cm gets a note.
* **Decimation.** A clip is shown at most ``max_fps`` frames per second and at most
  ``max_frames`` frames (every ``step``-th frame of the file); the page says so. Display
  data is float32, a few MB for 10,000 frames of 31 joints once decimated.
* A report is used only when it matches the motion beside it (same frame count and frame
  rate; contact joints that exist and intervals within the clip); otherwise it is ignored
  and the page says why.
"""

from __future__ import annotations

import base64
import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from elastic_motion.errors import OptionError

__all__ = ["ViewerClip", "ViewerPage", "build_viewer", "find_report", "plotly_js", "write_viewer"]

#: Colours of the clips' centre lines (limbs keep the side colours of the pictures).
_CLIP_COLOURS = ("#444444", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22", "#7f7f7f")
_MAX_REPORTS_SCANNED = 200
_MAX_REPORT_BYTES = 50_000_000


def plotly_js() -> str:
    """The plotly.js bundle of the installed ``plotly`` package (about 4.6 MB of text).

    Raises
    ------
    ModuleNotFoundError
        ``plotly`` is not installed (``pip install "elastic-motion[viewer]"``).
    """
    try:
        from plotly.offline import get_plotlyjs
    except ImportError as exc:
        raise ModuleNotFoundError(
            'the viewer needs plotly: pip install "elastic-motion[viewer]" (or pip install plotly)',
            name="plotly",
        ) from exc
    return get_plotlyjs()


@dataclass(frozen=True, eq=False)
class ViewerClip:
    """One clip as the page shows it.

    Attributes
    ----------
    label : str
    source : str or None
        The file read (None for a ``Motion`` given directly).
    frames : int
        Frames of the motion.
    fps : float
        Its frame rate.
    step : int
        Every ``step``-th frame is shown.
    shown_frames : int
    report : str or None
        The report used (path, or ``"given"`` for a dict), None when none was used.
    contacts : bool
        Contacts are marked.
    seams : tuple of float
        Seam times (s) marked on the timeline.
    warp : bool
        The blend's time warp is plotted.
    notes : tuple of str
    """

    label: str
    source: str | None
    frames: int
    fps: float
    step: int
    shown_frames: int
    report: str | None = None
    contacts: bool = False
    seams: tuple[float, ...] = ()
    warp: bool = False
    notes: tuple[str, ...] = ()

    def summary(self) -> dict[str, Any]:
        """JSON-ready fields."""
        return {
            "label": self.label,
            "source": self.source,
            "frames": self.frames,
            "fps": self.fps,
            "step": self.step,
            "shown_frames": self.shown_frames,
            "report": self.report,
            "contacts": self.contacts,
            "seams_s": list(self.seams),
            "warp": self.warp,
            "notes": list(self.notes),
        }


@dataclass(frozen=True, eq=False)
class ViewerPage:
    """A viewer built by :func:`build_viewer`.

    Attributes
    ----------
    clips : tuple of ViewerClip
    fragment : str
        The viewer's HTML (a ``<div>`` with its controls and its data and code), to put in a
        page that loads plotly.js first (:attr:`html` is such a page).
    html : str
        A whole page (plotly.js inline, or loaded from ``plotly_src``).
    notes : tuple of str
        What the page says about its data (decimation, reports ignored, floors).
    """

    clips: tuple[ViewerClip, ...]
    fragment: str = field(repr=False)
    html: str = field(repr=False)
    notes: tuple[str, ...] = ()

    def summary(self) -> dict[str, Any]:
        """JSON-ready fields of the ``view`` command's report."""
        return {
            "clips": [c.summary() for c in self.clips],
            "html_bytes": len(self.html.encode("utf-8")),
            "notes": list(self.notes),
        }


# ------------------------------------------------------------------------------------------
# Reports
# ------------------------------------------------------------------------------------------


def _read_json(path: Path) -> dict[str, Any] | None:
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
        rep = _read_json(p)
        if rep is not None and _names_file(rep, folder, target):
            found.append((str(rep.get("created", "")), p, rep))
    if not found:
        return None
    found.sort(key=lambda x: x[0])
    return found[-1][1], found[-1][2]


def _b64(a: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(a).tobytes()).decode("ascii")


def _as_list(x: Any) -> list | None:
    return x if isinstance(x, list) else None


def _match_frames(report: dict[str, Any], n_frames: int, fps: float) -> tuple[int, str]:
    """Cycles of the report's clip in the motion (1: the same clip), or 0 and why not."""
    rf = report.get("frames")
    rfps = report.get("fps")
    if not isinstance(rf, int) or rf < 2:
        return 0, "it gives no frame count"
    if isinstance(rfps, int | float) and abs(float(rfps) - fps) > 1e-6 * max(1.0, fps):
        return 0, f"it is for {float(rfps):g} fps, the motion is at {fps:g} fps"
    if rf == n_frames:
        return 1, ""
    is_loop = report.get("command") == "loop" or "seam_after" in report
    if is_loop and (n_frames - 1) % (rf - 1) == 0:
        return (n_frames - 1) // (rf - 1), ""  # a --repeat preview: cycles (F - 1) + 1 frames
    return 0, f"it is for {rf} frames, the motion has {n_frames}"


def _contacts_from(
    report: dict[str, Any], names: Sequence[str], n_frames: int, cycles: int, notes: list[str], what: str
) -> dict[str, list[tuple[int, int]]] | None:
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


# ------------------------------------------------------------------------------------------
# Clips
# ------------------------------------------------------------------------------------------


def _load(source: Any, label: str | None):
    from elastic_motion.apps.prepare import PrepareOptions, load_motion
    from elastic_motion.motion import Motion

    opts = PrepareOptions(drop_tpose=False, check_up_axis=False)
    if isinstance(source, Motion):
        m, _ = load_motion(source, opts, label=label)
        return m, None
    p = Path(source)
    m, _ = load_motion(str(p), opts, label=label)
    return m, str(p)


def _to_plotly(p: np.ndarray) -> np.ndarray:
    """Motion (x, y, z), Y-up -> plotly (x, -z, y), Z-up."""
    return np.stack([p[..., 0], -p[..., 2], p[..., 1]], axis=-1)


def _clip_data(
    motion,
    source: str | None,
    report: tuple[str, dict[str, Any]] | None,
    *,
    index: int,
    max_frames: int,
    max_fps: float,
    detect: bool,
) -> tuple[ViewerClip, dict[str, Any], np.ndarray]:
    from elastic_motion.apps.render import _bone_colours
    from elastic_motion.motion import forward_kinematics
    from elastic_motion.motion.contacts import detect_contacts

    notes: list[str] = []
    f, fps = motion.n_frames, float(motion.fps)
    scale = motion.metres_per_unit or 1.0
    if motion.metres_per_unit is None:
        notes.append(f"{motion.name}: length unit unknown: drawn in the file's own numbers")
    pos = forward_kinematics(motion, end_sites=True) * scale  # (F, P, 3) metres, Y-up
    step = max(1, math.ceil(fps / max_fps - 1e-9), math.ceil(f / max_frames - 1e-9))
    keep = np.arange(0, f, step)
    shown = pos[keep]
    names = list(motion.skeleton.names)
    a, b, colours = _bone_colours(motion)
    from elastic_motion.apps.render import _LEFT, _RIGHT

    segs = {"L": [], "R": [], "C": []}
    for i, j, c in zip(a, b, colours, strict=True):
        segs["L" if c == _LEFT else "R" if c == _RIGHT else "C"].append([int(i), int(j)])

    contacts: dict[str, list[tuple[int, int]]] | None = None
    seams: list[float] = []
    warp_info = None
    used = None
    if report is not None:
        rpath, rep = report
        what = f"report {rpath}"
        cycles, why = _match_frames(rep, f, fps)
        if cycles == 0:
            notes.append(f"{what} does not match {motion.name} ({why}): ignored")
        else:
            used = rpath
            contacts = _contacts_from(rep, names, f, cycles, notes, what)
            if rep.get("command") == "loop" or "seam_after" in rep:
                period = (f - 1) // cycles
                seams = [k * period / fps for k in range(1, cycles + 1)]
                sa, sb = rep.get("seam_after") or {}, rep.get("seam_before") or {}
                ang = (sb.get("seam_angle_max_deg"), sa.get("seam_angle_max_deg"))
                if all(isinstance(v, int | float) for v in ang):
                    notes.append(
                        f"{motion.name}: loop seam, largest joint angle {ang[0]:.3g} -> {ang[1]:.3g} deg "
                        f"(from {what})"
                    )
            if rep.get("warp_vertices") is not None and cycles == 1:
                u, warps, why_w = _blend_timing(rep, f, fps)
                if why_w:
                    notes.append(f"{what}: {why_w}: no warp plot")
                else:
                    prep = _as_list(rep.get("preparation")) or []
                    labels = [
                        str(p.get("label", f"input {k}")) if isinstance(p, dict) else f"input {k}"
                        for k, p in enumerate(prep)
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
                    warp_info = {
                        "inputs": labels[: len(warps)],
                        "seconds": [d is not None for d in durs],
                        "curves": curves,
                    }
    if contacts is None and detect:
        con = detect_contacts(motion)
        contacts = con.all_intervals()
        if not contacts:
            notes.append(f"{motion.name}: no contacts detected")
    con_data = None
    footprints: list[list[float]] = []
    if contacts:
        cj = list(contacts)
        idx = [names.index(n) for n in cj]
        mask = np.zeros((f, len(cj)), dtype=np.uint8)
        for k, n in enumerate(cj):
            for s, e in contacts[n]:
                mask[s:e, k] = 1
                footprints.append(pos[s, idx[k]].tolist())
        con_data = {"joints": cj, "idx": idx, "mask": _b64(mask[keep]), "intervals": contacts}
    clip = ViewerClip(
        label=motion.name,
        source=source,
        frames=f,
        fps=fps,
        step=step,
        shown_frames=len(keep),
        report=used,
        contacts=con_data is not None,
        seams=tuple(seams),
        warp=warp_info is not None,
        notes=tuple(notes),
    )
    data = {
        "label": motion.name,
        "colour": _CLIP_COLOURS[index % len(_CLIP_COLOURS)],
        "fps": fps / step,
        "fileFps": fps,
        "n": len(keep),
        "P": int(pos.shape[1]),
        "names": names,
        "segs": segs,
        "contacts": con_data,
        "footprints": _to_plotly(np.asarray(footprints).reshape(-1, 3)).round(4).tolist(),
        "seams": seams,
        "warp": warp_info,
        "duration": (len(keep) - 1) * step / fps,
        "info": f"{f} frames at {fps:g} fps" + (f", {len(names)} joints" if names else ""),
    }
    return clip, data, _to_plotly(shown)


def build_viewer(
    sources: Sequence[Any],
    *,
    labels: Sequence[str] | None = None,
    reports: Sequence[Any] | None = None,
    layout: str = "side",
    max_frames: int = 2000,
    max_fps: float = 30.0,
    contacts: str = "report",
    plotly_src: str | None = None,
    title: str = "elastic-motion viewer",
    element_id: str = "em-viewer",
) -> ViewerPage:
    """Build the interactive 3D viewer of one or more motions (module docstring).

    Parameters
    ----------
    sources : sequence of path or Motion
        Motion files (``.bvh``, ``.amc``, DeepMimic) or ``Motion`` objects, shown in order.
    labels : sequence of str, optional
        Names on the page (default: file stems, ``Motion.name``).
    reports : sequence, optional
        Per source: a report path, a report dict (``BlendResult.summary()``,
        ``LoopResult.summary()`` or a ``--json`` file's content), ``None`` to look for one
        beside the file (:func:`find_report`), or ``False`` for none. Default: look.
    layout : {"side", "overlay"}
        Initial layout (the page has a switch): clips side by side, or on one spot.
    max_frames : int
        At most this many frames of a clip are shown (decimated, said on the page).
    max_fps : float
        At most this many frames per second are shown.
    contacts : {"report", "detect", "none"}
        Mark contacts from the report; also detect them
        (:func:`elastic_motion.motion.contacts.detect_contacts`) when no report gives them;
        or never.
    plotly_src : str, optional
        Load plotly.js from this (relative) URL in :attr:`ViewerPage.html` instead of
        writing it into the page.
    title : str
    element_id : str
        HTML id of the viewer (several viewers on one page need different ids).

    Returns
    -------
    ViewerPage

    Raises
    ------
    OptionError
        Bad option values, no sources, a missing file.
    ParseError
        A file that cannot be read (the message names the file).
    ModuleNotFoundError
        plotly is not installed (only when ``plotly_src`` is not given).
    """
    from elastic_motion.apps.viewer.page import page_html, viewer_fragment
    from elastic_motion.motion.contacts import floor_height

    if layout not in ("side", "overlay"):
        raise OptionError("layout", f"expected 'side' or 'overlay'; got {layout!r}")
    if contacts not in ("report", "detect", "none"):
        raise OptionError("contacts", f"expected 'report', 'detect' or 'none'; got {contacts!r}")
    if not isinstance(max_frames, int) or max_frames < 2:
        raise OptionError("max_frames", f"expected an integer >= 2; got {max_frames!r}")
    if not (isinstance(max_fps, int | float) and math.isfinite(max_fps) and max_fps > 0):
        raise OptionError("max_fps", f"expected a positive number of frames per second; got {max_fps!r}")
    sources = list(sources)
    if not sources:
        raise OptionError("motions", "expected at least one motion; got none")
    if labels is not None and len(labels) != len(sources):
        raise OptionError("labels", f"expected {len(sources)} labels (one per motion); got {len(labels)}")
    if reports is not None and len(reports) != len(sources):
        raise OptionError("reports", f"expected {len(sources)} reports (one per motion); got {len(reports)}")
    clips, datas, shown, floors, notes = [], [], [], [], []
    for k, src in enumerate(sources):
        motion, path = _load(src, labels[k] if labels is not None else None)
        rep_in = reports[k] if reports is not None else None
        rep: tuple[str, dict[str, Any]] | None = None
        if isinstance(rep_in, dict):
            rep = ("given", rep_in)
        elif isinstance(rep_in, str | os.PathLike):
            data = _read_json(Path(rep_in))
            if data is None:
                raise OptionError(
                    "reports", f"{os.fspath(rep_in)}: expected a JSON report; got none readable"
                )
            rep = (os.fspath(rep_in), data)
        elif rep_in is None and path is not None:
            hit = find_report(path)
            rep = (str(hit[0]), hit[1]) if hit is not None else None
        clip, data, pts = _clip_data(
            motion, path, rep, index=k, max_frames=max_frames, max_fps=max_fps, detect=contacts == "detect"
        )
        if contacts == "none" and data["contacts"] is not None:
            data["contacts"] = None
            data["footprints"] = []
            clip = ViewerClip(**{**clip.__dict__, "contacts": False})
        clips.append(clip)
        datas.append(data)
        shown.append(pts)
        floors.append(floor_height(motion))  # metres (the file's numbers when the unit is unknown)
        notes += list(clip.notes)
        if clip.step > 1:
            notes.append(
                f"{clip.label}: {clip.frames} frames at {clip.fps:g} fps, shown 1 frame in {clip.step} "
                f"({clip.shown_frames} frames, {clip.fps / clip.step:g} fps) to keep the page responsive"
            )
    floor = floors[0]
    for c, fl in zip(clips, floors, strict=True):
        if abs(fl - floor) > 0.02:
            notes.append(
                f"{c.label}: its floor is {fl - floor:+.2f} m from the floor drawn ({clips[0].label}'s)"
            )
    # side by side: along the horizontal axis in which the clips move least
    lo = np.array([p.reshape(-1, 3).min(axis=0) for p in shown])
    hi = np.array([p.reshape(-1, 3).max(axis=0) for p in shown])
    ext = hi - lo
    axis = 0 if ext[:, 0].max() <= ext[:, 1].max() else 1
    offsets = np.zeros((len(shown), 3))
    cursor = hi[0, axis] + 0.4
    for k in range(1, len(shown)):
        offsets[k, axis] = cursor - lo[k, axis]
        cursor += ext[k, axis] + 0.4
    for d, o in zip(datas, offsets, strict=True):
        d["offset"] = o.round(4).tolist()
    for d, p in zip(datas, shown, strict=True):
        d["pos"] = _b64(p.astype(np.float32))

    # scene ranges for both layouts (traces and footprints included), floor at the bottom
    def box(offs: np.ndarray) -> list[list[float]]:
        a = np.min(lo + offs, axis=0)
        b = np.max(hi + offs, axis=0)
        a[2] = min(a[2], floor)
        pad = 0.15 * max(1.0, float(np.max(b - a)) * 0.1)
        return [[float(a[i] - pad), float(b[i] + pad)] for i in range(3)]

    spec = {
        "id": element_id,
        "title": title,
        "clips": datas,
        "floor": floor,
        "layout": layout,
        "ranges": {"side": box(offsets), "overlay": box(np.zeros_like(offsets))},
        "notes": notes,
    }
    fragment = viewer_fragment(spec)
    html = page_html(title, fragment, plotly_src=plotly_src)
    return ViewerPage(tuple(clips), fragment, html, tuple(notes))


def write_viewer(page: ViewerPage, path: str | os.PathLike[str], *, protected: Sequence[Any] = ()) -> Path:
    """Write ``page.html`` atomically to ``path`` (never onto one of ``protected``)."""
    from elastic_motion._io import atomic_write_text

    return atomic_write_text(path, page.html, protected=protected)
