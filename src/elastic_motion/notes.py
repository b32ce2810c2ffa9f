"""Notes: what an app did, in words for people and as a kind for code.

Every app result (a blend, a loop, a preparation, contacts found on a motion) carries a
tuple of :class:`Note`. People read ``str(note)`` (the CLI prints it after ``note:``, JSON
reports list the texts); code that must react to a note tests ``note.kind`` and reads
``note.data``, never the text's opening words.

A kind is a short dotted name, ``"<app>.<what>"`` (``"loop.hitch"``, ``"contacts.missed_stances"``);
each module that writes notes lists its kinds as constants beside the code that writes them.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

__all__ = ["Note", "first_of_kind", "note_texts", "of_kind"]


@dataclass(frozen=True)
class Note:
    """One note of a result.

    Attributes
    ----------
    kind : str
        What the note is about, for code (``"loop.hitch"``); stable across releases.
    text : str
        The sentence a person reads; ``str(note)`` is this text.
    data : dict, optional
        The numbers behind the text (JSON-ready scalars, lists and dicts); a copy of what
        was given, not to be changed.
    """

    kind: str
    text: str
    data: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.kind, str) or not self.kind:
            raise ValueError(f"kind: expected a non-empty string; got {self.kind!r}")
        if not isinstance(self.text, str):
            raise ValueError(f"text: expected a string; got {type(self.text).__name__}")
        object.__setattr__(self, "data", dict(self.data))

    def __str__(self) -> str:
        return self.text

    def __hash__(self) -> int:
        return hash((self.kind, self.text))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Note):
            return NotImplemented
        return (self.kind, self.text, self.data) == (other.kind, other.text, other.data)

    def with_text(self, text: str) -> Note:
        """The same note (kind and data) with another text."""
        return Note(self.kind, text, self.data)


def note_texts(notes: Iterable[Note]) -> list[str]:
    """The texts of ``notes``, in order (what a JSON report lists and the CLI prints)."""
    return [str(n) for n in notes]


def of_kind(notes: Iterable[Note], *kinds: str) -> list[Note]:
    """The notes of any of ``kinds``, in order."""
    return [n for n in notes if n.kind in kinds]


def first_of_kind(notes: Iterable[Note], *kinds: str) -> Note | None:
    """The first note of any of ``kinds``, or None."""
    return next((n for n in notes if n.kind in kinds), None)
