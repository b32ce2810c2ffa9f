"""An interactive 3D player for motions, in one HTML page that works offline.

``elastic-motion view A.bvh [B.bvh ...] -o view.html`` and the demo's ``index.html`` use
:func:`build_viewer`: the skeletons drawn by plotly.js (``pip install
"elastic-motion[viewer]"``; its JavaScript is written into the page, or beside it, so the
page opens from ``file://`` without a network or a server), with

* orbit and zoom (plotly's 3D scene), play / pause, speed, a frame slider;
* a first camera that follows the figures, fitted so that they fill the scene, or the
  whole travelled paths (a switch); each clip's label above its figure, never overlapping
  another;
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

Modules: :mod:`.options` (:class:`ViewerOptions` and the vocabularies), :mod:`.reports`
(finding and reading the reports), :mod:`.clips` (one clip made ready for display),
:mod:`.page` (the HTML and JavaScript), :mod:`.browser` (a headless browser for the tests).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from elastic_motion._io import atomic_write_text
from elastic_motion._options import with_overrides
from elastic_motion.apps.viewer.clips import ClipView, ViewerClip, b64, clip_view, load_clip
from elastic_motion.apps.viewer.options import (
    CONTACT_MARKS,
    LAYOUTS,
    ContactMarks,
    Layout,
    ViewerOptions,
    contact_marks,
)
from elastic_motion.apps.viewer.page import page_html, plotly_js, viewer_fragment
from elastic_motion.apps.viewer.reports import find_report, read_report
from elastic_motion.errors import OptionError
from elastic_motion.motion.contacts import floor_height

__all__ = [
    "CONTACT_MARKS",
    "LAYOUTS",
    "ContactMarks",
    "Layout",
    "ViewerClip",
    "ViewerOptions",
    "ViewerPage",
    "build_viewer",
    "contact_marks",
    "find_report",
    "plotly_js",
    "write_viewer",
]

#: A clip whose floor is farther than this from the first clip's gets a note (metres).
_FLOOR_NOTE_M = 0.02


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
            "notes": [str(n) for n in self.notes],
        }


def build_viewer(
    sources: Sequence[Any],
    options: ViewerOptions | None = None,
    *,
    labels: Sequence[str] | None = None,
    reports: Sequence[Any] | None = None,
    **overrides: Any,
) -> ViewerPage:
    """Build the interactive 3D viewer of one or more motions (module docstring).

    Parameters
    ----------
    sources : sequence of path or Motion
        Motion files (``.bvh``, ``.amc``, DeepMimic) or ``Motion`` objects, shown in order.
    options : ViewerOptions, optional
        Layout, decimation, contacts, where plotly.js comes from, title, HTML id; or give
        its fields as keywords (``contacts="detect"``, ``plotly_src="plotly.min.js"``).
    labels : sequence of str, optional
        Names on the page (default: file stems, ``Motion.name``).
    reports : sequence, optional
        Per source: a report path, a report dict (``BlendResult.summary()``,
        ``LoopResult.summary()`` or a ``--json`` file's content), ``None`` to look for one
        beside the file (:func:`find_report`), or ``False`` for none. Default: look.

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
    opts = with_overrides(ViewerOptions, options, overrides)
    sources = list(sources)
    _check_counts(sources, labels, reports)
    views, floors = [], []
    for k, src in enumerate(sources):
        motion, path = load_clip(src, labels[k] if labels is not None else None, up=opts.up, units=opts.units)
        rep = _report_of(reports[k] if reports is not None else None, path)
        views.append(_without_contacts(clip_view(motion, path, rep, index=k, options=opts), opts))
        floors.append(floor_height(motion))  # metres (the file's numbers when the unit is unknown)
    clips = [v.clip for v in views]
    notes = _notes(clips, floors)
    spec = {
        "id": opts.element_id,
        "title": opts.title,
        "clips": [v.data for v in views],
        "floor": floors[0],
        "layout": opts.layout,
        "notes": notes,
    }
    spec["ranges"], spec["camera"] = _place(views, floors[0])
    fragment = viewer_fragment(spec)
    html = page_html(opts.title, fragment, plotly_src=opts.plotly_src)
    return ViewerPage(tuple(clips), fragment, html, tuple(notes))


def _check_counts(sources: list[Any], labels: Sequence[str] | None, reports: Sequence[Any] | None) -> None:
    if not sources:
        raise OptionError("motions", "expected at least one motion; got none")
    if labels is not None and len(labels) != len(sources):
        raise OptionError("labels", f"expected {len(sources)} labels (one per motion); got {len(labels)}")
    if reports is not None and len(reports) != len(sources):
        raise OptionError("reports", f"expected {len(sources)} reports (one per motion); got {len(reports)}")


def _report_of(given: Any, path: str | None) -> tuple[str, dict[str, Any]] | None:
    """The report of one source (:func:`build_viewer`'s ``reports``): ``(where, content)``."""
    if isinstance(given, dict):
        return ("given", given)
    if isinstance(given, str | os.PathLike):
        data = read_report(Path(given))
        if data is None:
            raise OptionError("reports", f"{os.fspath(given)}: expected a JSON report; got none readable")
        return (os.fspath(given), data)
    if given is None and path is not None:
        hit = find_report(path)
        return (str(hit[0]), hit[1]) if hit is not None else None
    return None


def _without_contacts(view: ClipView, opts: ViewerOptions) -> ClipView:
    """``view`` without its contacts when ``opts.contacts`` is ``"off"``."""
    if opts.contacts != "off" or view.data["contacts"] is None:
        return view
    view.data["contacts"] = None
    view.data["footprints"] = []
    return ClipView(replace(view.clip, contacts=False), view.data, view.points)


def _notes(clips: list[ViewerClip], floors: list[float]) -> list[str]:
    """What the page says: each clip's notes, its decimation, floors that differ from the first."""
    notes: list[str] = []
    for clip in clips:
        notes += list(clip.notes)
        if clip.step > 1:
            notes.append(
                f"{clip.label}: {clip.frames} frames at {clip.fps:g} fps, shown 1 frame in {clip.step} "
                f"({clip.shown_frames} frames, {clip.fps / clip.step:g} fps) to keep the page responsive"
            )
    for c, fl in zip(clips, floors, strict=True):
        if abs(fl - floors[0]) > _FLOOR_NOTE_M:
            notes.append(
                f"{c.label}: its floor is {fl - floors[0]:+.2f} m from the floor drawn ({clips[0].label}'s)"
            )
    return notes


def _place(views: list[ClipView], floor: float) -> tuple[dict[str, list[list[float]]], dict[str, Any]]:
    """Place the clips side by side (each clip's ``offset`` and ``pos`` in its data) and return
    the scene ranges of both layouts (traces and footprints included), floor at the bottom, and
    what the page's following camera needs (:func:`_follow`)."""
    shown = [v.points for v in views]
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
    for v, o in zip(views, offsets, strict=True):
        v.data["offset"] = o.round(4).tolist()
    for v, p in zip(views, shown, strict=True):
        v.data["pos"] = b64(p.astype(np.float32))

    def box(offs: np.ndarray) -> list[list[float]]:
        a = np.min(lo + offs, axis=0)
        b = np.max(hi + offs, axis=0)
        a[2] = min(a[2], floor)
        pad = 0.15 * max(1.0, float(np.max(b - a)) * 0.1)
        return [[float(a[i] - pad), float(b[i] + pad)] for i in range(3)]

    return {"side": box(offsets), "overlay": box(np.zeros_like(offsets))}, _follow(shown, floor, axis)


def _follow(shown: list[np.ndarray], floor: float, axis: int) -> dict[str, Any]:
    """What the page's following camera needs to keep every figure whole in its window.

    The page centres a window on the figures' roots (joint 0) at each frame (``page.py``);
    with ``reach`` around each root and ``z`` from under the floor to above the highest head,
    no joint of any frame leaves it.

    Parameters
    ----------
    shown : list of ndarray, each shape (K, P, 3)
        Each clip's drawn points (plotly axes: x, -z, y), metres, before placing.
    floor : float
        Height of the floor drawn, metres.
    axis : int
        0 or 1: the horizontal axis along which the clips are placed side by side (the
        camera looks across it, so that the clips stand next to each other on screen).

    Returns
    -------
    dict
        ``axis``; ``reach`` (metres, x and y): the largest distance along each horizontal axis
        of a joint from its clip's root over all frames, plus a margin; ``z`` (metres): the
        window's height range, a little below the floor to a little above the highest joint.
    """
    reach = np.max([np.abs(p[:, :, :2] - p[:, :1, :2]).max(axis=(0, 1)) for p in shown], axis=0)
    top = max(float(p[..., 2].max()) for p in shown)
    low = min(floor, min(float(p[..., 2].min()) for p in shown))
    height = max(top - low, 0.5)
    return {
        "axis": axis,
        "reach": (reach + 0.1 * height).round(4).tolist(),
        "z": [round(low - 0.05 * height, 4), round(top + 0.12 * height, 4)],
    }


def write_viewer(page: ViewerPage, path: str | os.PathLike[str], *, protected: Sequence[Any] = ()) -> Path:
    """Write ``page.html`` atomically to ``path`` (never onto one of ``protected``)."""
    return atomic_write_text(path, page.html, protected=protected)
