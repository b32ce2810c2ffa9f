"""One clip of the viewer: the motion read, decimated for display, its bones by side, and the
contacts, loop seams and blend warps its report gives (:mod:`.reports`), as the data the
page's script draws (:mod:`.page`).

Conventions (also in :mod:`elastic_motion.apps.viewer`): displayed coordinates are the
motion's ``(x, y, z)`` in metres, Y-up, drawn as plotly's ``(x, -z, y)``; a clip shows every
``step``-th frame so that at most ``max_fps`` frames per second and ``max_frames`` frames
are shown; display data is float32 (positions) and uint8 (contact masks), base64-encoded.
"""

from __future__ import annotations

import base64
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from elastic_motion.apps.palette import CLIP_COLOURS, LEFT, RIGHT, bone_colours
from elastic_motion.apps.prepare import PrepareOptions, load_motion
from elastic_motion.apps.viewer.options import ViewerOptions
from elastic_motion.apps.viewer.reports import loop_seams, match_frames, report_contacts, warp_plot
from elastic_motion.motion import Motion, forward_kinematics
from elastic_motion.motion.contacts import detect_contacts

__all__ = ["ClipView", "ViewerClip", "b64", "clip_view", "load_clip", "to_plotly"]


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
            "notes": [str(n) for n in self.notes],
        }


@dataclass(frozen=True, eq=False)
class ClipView:
    """A clip made ready for the page (:func:`clip_view`).

    Attributes
    ----------
    clip : ViewerClip
        What the page says about the clip.
    data : dict
        The clip's display data for the page's script (without its placement and positions,
        which :func:`elastic_motion.apps.viewer.build_viewer` adds).
    points : ndarray, shape (K, P, 3)
        The shown frames' joint and end-site positions, plotly coordinates, metres.
    """

    clip: ViewerClip
    data: dict[str, Any]
    points: np.ndarray


def b64(a: np.ndarray) -> str:
    """The bytes of an array (C order, its own dtype) as base64 text, for the page's script."""
    return base64.b64encode(np.ascontiguousarray(a).tobytes()).decode("ascii")


def load_clip(
    source: Any, label: str | None, *, up: str | None = None, units: str | None = None
) -> tuple[Motion, str | None]:
    """A motion to show, read without dropping a T-pose frame (the viewer shows every frame,
    so that frame numbers match the reports), and the path read (None for a ``Motion``);
    ``up`` and ``units`` as :class:`~elastic_motion.apps.prepare.PrepareOptions`'."""
    opts = PrepareOptions(drop_tpose=False, check_up_axis=False, up=up, units=units)  # type: ignore[arg-type]
    if isinstance(source, Motion):
        m, _ = load_motion(source, opts, label=label)
        return m, None
    p = Path(source)
    m, _ = load_motion(str(p), opts, label=label)
    return m, str(p)


def to_plotly(p: np.ndarray) -> np.ndarray:
    """Motion (x, y, z), Y-up -> plotly (x, -z, y), Z-up."""
    return np.stack([p[..., 0], -p[..., 2], p[..., 1]], axis=-1)


def _segments(motion: Motion) -> dict[str, list[list[int]]]:
    """The bones as point index pairs, by side: ``"L"``, ``"R"``, ``"C"`` (the rest)."""
    a, b, colours = bone_colours(motion)
    segs: dict[str, list[list[int]]] = {"L": [], "R": [], "C": []}
    for i, j, c in zip(a, b, colours, strict=True):
        segs["L" if c == LEFT else "R" if c == RIGHT else "C"].append([int(i), int(j)])
    return segs


@dataclass
class _Marks:
    """What a clip's report gives to mark: contacts, seams, the warp plot, the report used."""

    contacts: dict[str, list[tuple[int, int]]] | None = None
    seams: list[float] | None = None
    warp: dict[str, Any] | None = None
    used: str | None = None


def _report_marks(
    motion: Motion, report: tuple[str, dict[str, Any]] | None, keep: np.ndarray, notes: list[str]
) -> _Marks:
    """The marks of ``report`` (its path or ``"given"``, and its content) on ``motion``."""
    marks = _Marks(seams=[])
    if report is None:
        return marks
    rpath, rep = report
    what = f"report {rpath}"
    f, fps = motion.n_frames, float(motion.fps)
    cycles, why = match_frames(rep, f, fps)
    if cycles == 0:
        notes.append(f"{what} does not match {motion.name} ({why}): ignored")
        return marks
    marks.used = rpath
    marks.contacts = report_contacts(rep, list(motion.skeleton.names), f, cycles, notes, what)
    marks.seams = loop_seams(rep, motion, cycles, notes, what)
    if rep.get("warp_vertices") is not None and cycles == 1:
        marks.warp = warp_plot(rep, f, fps, keep, notes, what)
    return marks


def _contact_data(
    contacts: dict[str, list[tuple[int, int]]], names: list[str], pos: np.ndarray, keep: np.ndarray
) -> tuple[dict[str, Any], list[list[float]]]:
    """The contacts as the page marks them (joints, their indices, a mask of the shown frames,
    the intervals) and a footprint where each contact starts (metres, motion coordinates)."""
    cj = list(contacts)
    idx = [names.index(n) for n in cj]
    mask = np.zeros((pos.shape[0], len(cj)), dtype=np.uint8)
    footprints: list[list[float]] = []
    for k, n in enumerate(cj):
        for s, e in contacts[n]:
            mask[s:e, k] = 1
            footprints.append(pos[s, idx[k]].tolist())
    return {"joints": cj, "idx": idx, "mask": b64(mask[keep]), "intervals": contacts}, footprints


def clip_view(
    motion: Motion,
    source: str | None,
    report: tuple[str, dict[str, Any]] | None,
    *,
    index: int,
    options: ViewerOptions,
) -> ClipView:
    """One clip made ready for the page: decimated, its bones by side, the marks of its
    report (``report``: its path or ``"given"``, and its content; None for none), contacts
    detected when ``options.contacts`` is ``"detect"`` and the report gives none. ``index``
    is the clip's place on the page (its colour)."""
    notes: list[str] = []
    f, fps = motion.n_frames, float(motion.fps)
    scale = motion.metres_per_unit or 1.0
    if motion.metres_per_unit is None:
        notes.append(f"{motion.name}: length unit unknown: drawn in the file's own numbers")
    pos = forward_kinematics(motion, end_sites=True) * scale  # (F, P, 3) metres, Y-up
    step = max(1, math.ceil(fps / options.max_fps - 1e-9), math.ceil(f / options.max_frames - 1e-9))
    keep = np.arange(0, f, step)
    names = list(motion.skeleton.names)
    segs = _segments(motion)
    marks = _report_marks(motion, report, keep, notes)
    contacts = marks.contacts
    if contacts is None and options.contacts == "detect":
        contacts = detect_contacts(motion).all_intervals()
        if not contacts:
            notes.append(f"{motion.name}: no contacts detected")
    con_data, footprints = _contact_data(contacts, names, pos, keep) if contacts else (None, [])
    clip = ViewerClip(
        label=motion.name,
        source=source,
        frames=f,
        fps=fps,
        step=step,
        shown_frames=len(keep),
        report=marks.used,
        contacts=con_data is not None,
        seams=tuple(marks.seams or ()),
        warp=marks.warp is not None,
        notes=tuple(notes),
    )
    data = {
        "label": motion.name,
        "colour": CLIP_COLOURS[index % len(CLIP_COLOURS)],
        "fps": fps / step,
        "fileFps": fps,
        "n": len(keep),
        "P": int(pos.shape[1]),
        "names": names,
        "segs": segs,
        "contacts": con_data,
        "footprints": to_plotly(np.asarray(footprints).reshape(-1, 3)).round(4).tolist(),
        "seams": marks.seams or [],
        "warp": marks.warp,
        "duration": (len(keep) - 1) * step / fps,
        "info": f"{f} frames at {fps:g} fps" + (f", {len(names)} joints" if names else ""),
    }
    return ClipView(clip, data, to_plotly(pos[keep]))
