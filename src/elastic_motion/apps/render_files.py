"""Pictures of motion files: ``elastic-motion render`` as a Python function.

:func:`render_motions` reads each input with the preparation step of one input
(:func:`elastic_motion.apps.prepare.load_motion`: metres, Y-up, a T-pose frame dropped, its
own trim range), names the panels after the motions unless told otherwise, and draws them with
:func:`elastic_motion.apps.render.render` into one file: the same picture the command draws
from the same options. ``landmarks`` of the warp picture may be given as the command line
takes them (a landmarks file's path, inline pairs ``"tA:tB,..."``, ``"auto"``): read with the
clips' frame rates (:func:`elastic_motion.apps.landmark_files.parse_landmarks`); a file's
recorded weight is the weight the warp meets its pairs with.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from elastic_motion.apps.landmark_files import LandmarkFile, parse_landmarks
from elastic_motion.apps.prepare import PrepareOptions, Source, load_motion
from elastic_motion.apps.progress import Progress
from elastic_motion.apps.render import RenderKind, render, render_kind
from elastic_motion.errors import OptionError
from elastic_motion.motion import Motion

__all__ = ["RenderResult", "render_motions"]


@dataclass(frozen=True, eq=False)
class RenderResult:
    """What :func:`render_motions` drew.

    Attributes
    ----------
    path : pathlib.Path
        The file written.
    kind : str
        The picture drawn (``"auto"`` resolved: ``"animation"`` or ``"feet"``).
    labels : tuple of str
        The panel titles.
    motions : tuple of Motion
        The motions as drawn (prepared).
    notes : tuple
        What the preparation noted (one :class:`~elastic_motion.notes.Note` per remark).
    """

    path: Path
    kind: str
    labels: tuple[str, ...]
    motions: tuple[Motion, ...] = field(repr=False)
    notes: tuple[Any, ...] = ()

    def summary(self) -> dict[str, Any]:
        """The fields of the ``render`` command's report besides the shared header."""
        return {"kind": self.kind, "labels": list(self.labels)}


def render_motions(
    sources: Sequence[Source],
    path: str | os.PathLike[str],
    *,
    kind: RenderKind = "auto",
    labels: Sequence[str] | None = None,
    prepare: PrepareOptions | None = None,
    protected: Sequence[str | os.PathLike[str]] = (),
    progress: Progress | None = None,
    **kw: Any,
) -> RenderResult:
    """Read motions and draw them into one file (module docstring).

    Parameters
    ----------
    sources : sequence of path or Motion
        Motion files (``.bvh``, ``.amc``, DeepMimic) or ``Motion`` objects.
    path : str or os.PathLike
        ``.gif``/``.mp4`` (an animation) or ``.png``/``.svg``/``.pdf`` (a still).
    kind : {"auto", "animation", "feet", "warp", "seam", "sphere"}
        The picture (:func:`elastic_motion.apps.render.render`).
    labels : sequence of str, optional
        Panel titles, one per motion (default: the motions' names).
    prepare : PrepareOptions, optional
        The preparation of each input (default ``PrepareOptions()``); ``trim`` gives one
        range for all inputs or one per input.
    protected : sequence of paths
        Files never overwritten (the inputs are added).
    progress : callable, optional
        ``progress("render", frame, frames)`` (animations).
    **kw
        The keywords of the picture (:data:`elastic_motion.apps.render.RENDER_KEYWORDS`);
        ``landmarks`` of ``kind="warp"`` also as text (module docstring).

    Returns
    -------
    RenderResult

    Raises
    ------
    OptionError
        ``labels`` not one per motion; bad landmarks text; bad preparation options.
    TypeError
        A keyword the picture does not use.
    """
    kind = render_kind(kind, path)
    options = PrepareOptions() if prepare is None else prepare
    inputs = list(sources)
    motions, notes = [], []
    for k, source in enumerate(inputs):
        m, prep = load_motion(source, options, trim=options.trim_for(k, len(inputs)))
        motions.append(m)
        notes += prep.notes
    labels = [m.name for m in motions] if labels is None else list(labels)
    if len(labels) != len(motions):
        raise OptionError("labels", f"expected {len(motions)} labels; got {len(labels)}")
    if kind == "warp" and kw.get("landmarks") is not None:
        kw.update(_warp_landmarks(kw, motions))
    files = [os.fspath(s) for s in inputs if not isinstance(s, Motion)]
    out = render(
        motions, path, kind=kind, labels=labels, protected=[*files, *protected], progress=progress, **kw
    )
    return RenderResult(Path(out), kind, tuple(labels), tuple(motions), tuple(notes))


def _warp_landmarks(kw: dict[str, Any], motions: Sequence[Motion]) -> dict[str, Any]:
    """The ``landmarks`` (and ``warp``) keywords of the warp picture: text read with the
    clips' frame rates; a file's pairs, met with the weight it records."""
    landmarks = kw["landmarks"]
    if isinstance(landmarks, str):
        landmarks = parse_landmarks(landmarks, units="seconds", fps=(motions[0].fps, motions[-1].fps))
    if not isinstance(landmarks, LandmarkFile):
        return {"landmarks": landmarks}
    out: dict[str, Any] = {"landmarks": list(landmarks.pairs)}
    if landmarks.landmark_weight is not None:
        out["warp"] = landmarks.warp_options(kw.get("warp"))
    return out
