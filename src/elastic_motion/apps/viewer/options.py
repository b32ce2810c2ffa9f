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
from typing import Any, Literal

from elastic_motion._options import choices
from elastic_motion.errors import OptionError

__all__ = ["CONTACT_MARKS", "LAYOUTS", "ContactMarks", "Layout", "ViewerOptions", "contact_marks"]

#: How the clips are placed at first (the page has a switch): side by side, or on one spot.
Layout = Literal["side", "overlay"]
#: The values of :data:`Layout`.
LAYOUTS: tuple[str, ...] = choices(Layout)
#: Which contacts are marked: from the reports; from the reports, else detected on the
#: motion; none.
ContactMarks = Literal["report", "detect", "off"]
#: The values of :data:`ContactMarks`.
CONTACT_MARKS: tuple[str, ...] = choices(ContactMarks)


def contact_marks(value: Any) -> str:
    """``value`` as one of :data:`CONTACT_MARKS` (``"none"`` is ``"off"``); an
    :class:`OptionError` naming ``contacts`` otherwise."""
    if value == "none":
        return "off"
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
    """

    layout: Layout = "side"
    max_frames: int = 2000
    max_fps: float = 30.0
    contacts: ContactMarks = "report"
    plotly_src: str | None = None
    title: str = "elastic-motion viewer"
    element_id: str = "em-viewer"

    def __post_init__(self) -> None:
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
