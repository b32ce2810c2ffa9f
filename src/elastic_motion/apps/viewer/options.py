"""The options of the viewer (:func:`elastic_motion.apps.viewer.build_viewer`): one frozen
:class:`ViewerOptions`, and the vocabularies the command line's choices are read from.

Contacts use the words of the contact policy (:mod:`elastic_motion.motion.contacts`):
``"report"`` marks what a report says, ``"off"`` marks nothing; the viewer adds ``"detect"``
(detect them on the motion when no report gives them). ``"none"`` is accepted for ``"off"``
(the viewer's word before the vocabulary was shared).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

from elastic_motion.apps.prepare import PrepareOptions
from elastic_motion.defaults import (
    VIEWER_CONTACTS,
    VIEWER_LAYOUT,
    VIEWER_MAX_FPS,
    VIEWER_MAX_FRAMES,
    VIEWER_TITLE,
)
from elastic_motion.errors import OptionError
from elastic_motion.vocabulary import CONTACT_MARK_ALIASES, CONTACT_MARKS, LAYOUTS, ContactMarks, Layout

__all__ = ["CONTACT_MARKS", "LAYOUTS", "ContactMarks", "Layout", "ViewerOptions", "contact_marks"]

# How the clips are placed at first (Layout: side by side, or on one spot) and which contacts
# are marked (ContactMarks: from the reports; from the reports, else detected on the motion;
# none), with their values LAYOUTS and CONTACT_MARKS: from elastic_motion.vocabulary.


def contact_marks(value: Any) -> str:
    """``value`` as one of :data:`CONTACT_MARKS` (``"none"`` is ``"off"``); an
    :class:`OptionError` naming ``contacts`` otherwise."""
    value = CONTACT_MARK_ALIASES.get(value, value) if isinstance(value, str) else value
    if value not in CONTACT_MARKS:
        raise OptionError("contacts", f"expected 'report', 'detect' or 'off' ('none'); got {value!r}")
    return value


@dataclass(frozen=True)
class ViewerOptions:
    """How :func:`elastic_motion.apps.viewer.build_viewer` shows motions.

    Attributes
    ----------
    layout : {"side", "overlay"}, default "side"
        Initial layout (the page has a switch): clips side by side, or on one spot.
    max_frames : int, default 2000
        At most this many frames of a clip are shown (decimated, said on the page).
    max_fps : float, default 30.0
        At most this many frames per second are shown.
    contacts : {"report", "detect", "off"}, default "report"
        Mark contacts from the report; also detect them
        (:func:`elastic_motion.motion.contacts.detect_contacts`) when no report gives them;
        or never (``"none"`` is accepted for ``"off"``).
    plotly_src : str or None, default None
        Load plotly.js from this (relative) URL in the page instead of writing it into the
        page.
    title : str, default "elastic-motion viewer"
        Title of the page and of the viewer.
    element_id : str, default "em-viewer"
        HTML id of the viewer (several viewers on one page need different ids).
    up : {"x", "y", "z"} or None, default None
        Up axis of every file shown (:attr:`elastic_motion.apps.prepare.PrepareOptions.up`;
        None: as detected when reading).
    units : str or None, default None
        Length unit of every BVH file shown (None: guessed from the skeleton's size).
    """

    layout: Layout = VIEWER_LAYOUT
    max_frames: int = VIEWER_MAX_FRAMES
    max_fps: float = VIEWER_MAX_FPS
    contacts: ContactMarks = VIEWER_CONTACTS
    plotly_src: str | None = None
    title: str = VIEWER_TITLE
    element_id: str = "em-viewer"
    up: str | None = None
    units: str | None = None

    def __post_init__(self) -> None:
        PrepareOptions(up=self.up, units=self.units)  # type: ignore[arg-type]  # checks them, naming the field
        if self.layout not in LAYOUTS:
            raise OptionError("layout", f"expected 'side' or 'overlay'; got {self.layout!r}")
        object.__setattr__(self, "contacts", contact_marks(self.contacts))
        if not isinstance(self.max_frames, int) or self.max_frames < 2:
            raise OptionError("max_frames", f"expected an integer >= 2; got {self.max_frames!r}")
        fps = self.max_fps
        if not (isinstance(fps, int | float) and math.isfinite(fps) and fps > 0):
            raise OptionError("max_fps", f"expected a positive number of frames per second; got {fps!r}")

    def replace(self, **changes: Any) -> ViewerOptions:
        """A copy with ``changes`` (validated again)."""
        return replace(self, **changes)
