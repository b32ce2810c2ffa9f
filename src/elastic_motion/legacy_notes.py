"""Notes that still answer the text tests of callers written before kinds (one release).

Callers written before :class:`~elastic_motion.notes.Note` matched a note by its opening
words (``n.startswith(MISSED_STANCES_NOTE)``) or by a phrase in it (``"resampled" in n``). A
:class:`LegacyNote` is a ``Note`` -- kind, text, data; ``str(note)`` is the text; equal to the
``Note`` of the same fields -- that also answers ``startswith``, ``endswith`` and ``in`` on its
text, so that those callers keep working while they switch to ``note.kind``. It is not a
``str``: ``" ".join(notes)`` needs ``str(n)``.

Written by :func:`elastic_motion.motion.detect_contacts` (``Contacts.notes``) and
:func:`elastic_motion.apps.prepare.prepare_motions` (``PreparedMotions.notes``). Remove this
module (write plain ``Note``) once no caller tests the texts.
"""

from __future__ import annotations

from typing import Any

from elastic_motion.notes import Note

__all__ = ["LegacyNote"]


class LegacyNote(Note):
    """A :class:`~elastic_motion.notes.Note` whose text answers the ``str`` tests old callers use."""

    def startswith(self, prefix: str | tuple[str, ...], *args: Any) -> bool:
        """``self.text.startswith(prefix, ...)`` (test ``kind`` instead)."""
        return self.text.startswith(prefix, *args)

    def endswith(self, suffix: str | tuple[str, ...], *args: Any) -> bool:
        """``self.text.endswith(suffix, ...)`` (test ``kind`` instead)."""
        return self.text.endswith(suffix, *args)

    def __contains__(self, part: str) -> bool:
        return part in self.text
