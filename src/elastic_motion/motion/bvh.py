"""BVH (Biovision Hierarchy) reader and writer.

What the reader accepts
-----------------------
* Any per-joint channel set: 0 to 6 channels in any order, position channels on any joint
  (the Bandai files have six on every joint), any Euler order per joint; ``End Site``
  blocks (also several under one joint).
* Free whitespace: tabs, blank lines, several tokens per line or one per line, ``{`` on
  the name's line or its own; CRLF, CR or LF line ends; numbers like ``.0083333``, ``1.``,
  ``-5e-3``.
* Channel semantics: rotation channels are intrinsic Euler angles in **degrees**, applied
  in channel order (``Zrotation Xrotation Yrotation``: ``R = Rz @ Rx @ Ry``). Position
  channels give the joint's translation from its parent and *replace* its ``OFFSET``
  (axes without a channel keep the offset value). See :mod:`.skeleton`.
* Frame rate: ``fps = 1 / Frame Time``, snapped to the nearest integer when within 0.01 %
  (files store ``0.0083333`` for 120 Hz, ``0.0333333`` for 30 Hz).

What it rejects, with a :class:`~elastic_motion.errors.ParseError` naming file, line and
expectation: a truncated file, a frame with the wrong number of values, a non-numeric or
non-finite value, a frame count different from ``Frames:``, zero frames, a repeated joint
name, an unknown channel; a declared frame count, frame rate or duration beyond the
resource limits (:mod:`elastic_motion.limits`), checked before anything is allocated.

Lengths are in the file's unit, which BVH does not record: pass ``units=`` to the reader
or let it guess from the rest-pose size of the skeleton (:func:`guess_units`).

The up axis is not recorded either. BVH is Y-up by convention, but Blender's BVH exports
are Z-up (its exporter writes its Z-up armature space). The reader labels the
motion with the up axis detected from the motion itself (:func:`.axes.detect_up_axis`),
positions kept as they are in the file; ``up_axis="y"`` or ``"z"`` forces the label. An
ambiguous detection labels ``"y"``; ``detect_up_axis(motion)`` on the result gives the same
estimate, with ``fallback`` set, for the caller to warn.
"""

from __future__ import annotations

import math
import os
import re
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numba import njit

from elastic_motion import limits
from elastic_motion._io import atomic_write_text, read_text
from elastic_motion.errors import ParseError
from elastic_motion.groups import SO3
from elastic_motion.motion.axes import detect_up_axis
from elastic_motion.motion.representations import unwrap_euler
from elastic_motion.motion.rotations import euler_to_matrix, matrix_to_euler, nearest_euler, valid_euler_order
from elastic_motion.motion.skeleton import (
    POSITION_CHANNELS,
    ROTATION_CHANNELS,
    UNITS,
    Motion,
    Skeleton,
)

__all__ = ["guess_units", "read_bvh", "rotation_channel_fit", "snap_fps", "write_bvh"]

_NUMBER = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?", re.ASCII)
_MAX_CHANNELS = 6
# A translation within this (relative) distance of a joint's offset on an axis without a position
# channel is the offset written back (blending equal values can move them by an ulp).
_SAME_LENGTH = 1e-12
# Rotation channels that miss a rotation by less than this are said to hold it (rounding).
_FIT_TOLERANCE_DEG = 1e-7
_TYPICAL_HEIGHT_M = 1.7


def snap_fps(frame_time: float) -> float:
    """``1 / frame_time``, rounded to an integer when within 0.01 % of one.

    Parameters
    ----------
    frame_time : float
        Seconds per frame (> 0).

    Returns
    -------
    float
        Frames per second: ``120.0`` for ``0.0083333``, ``29.97...`` stays as it is.
    """
    fps = 1.0 / frame_time
    if not math.isfinite(fps):
        return fps
    r = round(fps)
    if r > 0 and abs(r - fps) <= 1e-4 * fps:
        return float(r)
    return fps


def guess_units(skeleton: Skeleton) -> float | None:
    """Guess the size of the file's length unit from the skeleton's rest pose.

    The rest pose (all rotations identity, offsets as translations, end sites included)
    of a human skeleton spans about 1.7 m along its largest axis (height, or arm span in
    a T-pose). The unit among ``m, cm, mm, inch, cmu`` (:data:`.skeleton.UNITS`) that
    brings the span closest to 1.7 m on a log scale wins, e.g. a span of 30 gives
    ``"cmu"`` (1.69 m), 170 gives ``"cm"``, 67 gives ``"inch"``.

    Parameters
    ----------
    skeleton : Skeleton

    Returns
    -------
    float or None
        Metres per unit, ``None`` for a degenerate skeleton (zero span).
    """
    n = skeleton.n_joints
    pos = np.zeros((n, 3))
    for j in range(1, n):
        pos[j] = pos[skeleton.parents[j]] + skeleton.offsets[j]
    pts = [pos]
    if skeleton.end_site_parents.size:
        pts.append(pos[skeleton.end_site_parents] + skeleton.end_site_offsets)
    pts = np.concatenate(pts)
    span = float((pts.max(axis=0) - pts.min(axis=0)).max())
    if not (span > 0 and math.isfinite(span)):
        return None
    best = min(UNITS.values(), key=lambda s: abs(math.log(span * s / _TYPICAL_HEIGHT_M)))
    return best


def _resolve_units(units: str | float | None, skeleton: Skeleton) -> float | None:
    if units is None:
        return guess_units(skeleton)
    if isinstance(units, str):
        if units not in UNITS:
            raise ValueError(f"units: expected one of {sorted(UNITS)} or metres per unit; got {units!r}")
        return UNITS[units]
    value = float(units)
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"units: expected a positive number of metres per unit; got {units!r}")
    return value


# ------------------------------------------------------------------------------------------
# Reading
# ------------------------------------------------------------------------------------------
class _Tokens:
    """Whitespace tokens of lines ``[0, stop)`` with their 1-based line numbers."""

    def __init__(self, path: str, lines: list[str], stop: int) -> None:
        self.path = path
        self.items: list[tuple[str, int]] = []
        for i in range(stop):
            for tok in lines[i].split():
                self.items.append((tok, i + 1))
        self.pos = 0
        self.last_line = stop if stop > 0 else 1

    def error(self, line: int | None, message: str) -> ParseError:
        return ParseError(self.path, line, message)

    def peek(self) -> tuple[str, int] | None:
        return self.items[self.pos] if self.pos < len(self.items) else None

    def next(self, expected: str) -> tuple[str, int]:
        if self.pos >= len(self.items):
            raise self.error(self.last_line, f"expected {expected}, found the end of the file")
        item = self.items[self.pos]
        self.pos += 1
        return item

    def keyword(self, word: str) -> int:
        tok, line = self.next(word)
        if tok.upper() != word.upper():
            raise self.error(line, f"expected {word}, found {tok!r}")
        return line

    def number(self, what: str) -> float:
        tok, line = self.next(what)
        if not _NUMBER.fullmatch(tok):
            raise self.error(line, f"expected {what} (a number), found {tok!r}")
        value = float(tok)
        if not math.isfinite(value):
            raise self.error(line, f"expected {what} (a finite number), found {tok!r}")
        return value

    def named_brace(self, line: int) -> bool:
        """``{`` ending ``line`` and another ``{`` opening a later line: the first is a name.

        ``JOINT {`` then ``{`` can only be a joint named ``{`` (an ASF bone may be, and
        :func:`write_bvh` writes it so); ``JOINT {`` then ``OFFSET`` has no name.
        """
        i = self.pos
        return (
            i + 1 < len(self.items)
            and self.items[i] == ("{", line)
            and self.items[i + 1][0] == "{"
            and self.items[i + 1][1] != line
        )

    def rest_of_line(self, line: int) -> list[str]:
        out = []
        while self.pos < len(self.items) and self.items[self.pos][1] == line:
            tok = self.items[self.pos][0]
            if tok == "{":
                break
            out.append(tok)
            self.pos += 1
        return out


class _Hierarchy:
    """``HIERARCHY ... ROOT ... }`` read token by token into the lists of a :class:`Skeleton`.

    Iterative descent (no recursion: a deeply nested file cannot overflow the stack): the
    stack holds the open joints; each item of the innermost one is an ``OFFSET``, a
    ``CHANNELS`` list, a ``JOINT`` (opened), an ``End Site`` or the closing ``}``.
    """

    def __init__(self, tokens: _Tokens) -> None:
        self.tokens = tokens
        self.names: list[str] = []
        self.parents: list[int] = []
        self.offsets: list[list[float] | None] = []
        self.channels: list[tuple[str, ...] | None] = []
        self.es_parents: list[int] = []
        self.es_offsets: list[list[float]] = []
        self.name_lines: dict[str, int] = {}

    def parse(self) -> tuple[Skeleton, int]:
        """The skeleton and the line of ``MOTION``, which must end its line."""
        tokens = self.tokens
        tokens.keyword("HIERARCHY")
        tok, line = tokens.next("ROOT")
        if tok.upper() != "ROOT":
            raise tokens.error(line, f"expected ROOT, found {tok!r}")
        stack: list[int] = [self.open_joint(line, -1)]
        while stack:
            self.item(stack)
        motion_line = tokens.keyword("MOTION")
        if tokens.peek() is not None:
            tok, line = tokens.peek()
            raise tokens.error(line, f"expected 'Frames:' on the line after MOTION, found {tok!r}")
        skeleton = Skeleton(
            names=self.names,
            parents=self.parents,
            offsets=self.offsets,
            channels=self.channels,
            end_site_parents=self.es_parents,
            end_site_offsets=np.array(self.es_offsets).reshape(-1, 3),
        )
        return skeleton, motion_line

    def item(self, stack: list[int]) -> None:
        """Read the next item of the innermost open joint ``stack[-1]``."""
        tokens = self.tokens
        j = stack[-1]
        tok, line = tokens.next(f"OFFSET, CHANNELS, JOINT, End Site or '}}' in joint {self.names[j]!r}")
        word = tok.upper()
        if word == "OFFSET":
            if self.offsets[j] is not None:
                raise tokens.error(line, f"joint {self.names[j]!r} has a second OFFSET")
            self.offsets[j] = [tokens.number("an OFFSET value") for _ in range(3)]
        elif word == "CHANNELS":
            if self.channels[j] is not None:
                raise tokens.error(line, f"joint {self.names[j]!r} has a second CHANNELS line")
            self.channels[j] = self.channel_list(j)
        elif word == "JOINT":
            stack.append(self.open_joint(line, j))
        elif word == "END":
            self.end_site(j)
        elif tok == "}":
            if self.offsets[j] is None:
                raise tokens.error(line, f"joint {self.names[j]!r} has no OFFSET")
            if self.channels[j] is None:
                self.channels[j] = ()
            stack.pop()
        else:
            raise tokens.error(
                line,
                f"expected OFFSET, CHANNELS, JOINT, End Site or '}}' in joint {self.names[j]!r}, "
                f"found {tok!r}",
            )

    def open_joint(self, kind_line: int, parent: int) -> int:
        """The name after ``ROOT``/``JOINT`` on ``kind_line`` and its ``{``; the new joint's index."""
        tokens = self.tokens
        name_toks = tokens.rest_of_line(kind_line)
        if not name_toks and tokens.named_brace(kind_line):
            name_toks = [tokens.next("a joint name")[0]]
        if not name_toks:
            raise tokens.error(kind_line, "expected a joint name after ROOT/JOINT")
        name = " ".join(name_toks)
        if name in self.name_lines:
            raise tokens.error(
                kind_line, f"joint name {name!r} is used twice (first on line {self.name_lines[name]})"
            )
        self.name_lines[name] = kind_line
        if len(self.names) >= limits.current().max_joints:
            limits.check_clip(tokens.path, kind_line, joints=len(self.names) + 1)
        b, bline = tokens.next("'{'")
        if b != "{":
            raise tokens.error(bline, f"expected '{{' to open joint {name!r}, found {b!r}")
        self.names.append(name)
        self.parents.append(parent)
        self.offsets.append(None)
        self.channels.append(None)
        return len(self.names) - 1

    def channel_list(self, j: int) -> tuple[str, ...]:
        """The count and names after ``CHANNELS`` (distinct, known names)."""
        tokens = self.tokens
        ntok, nline = tokens.next("the number of channels")
        if not (ntok.isascii() and ntok.isdigit()) or int(ntok) > _MAX_CHANNELS:
            raise tokens.error(
                nline, f"expected the number of channels (0 to {_MAX_CHANNELS}), found {ntok!r}"
            )
        chans: list[str] = []
        for _ in range(int(ntok)):
            c, cline = tokens.next("a channel name")
            if c not in POSITION_CHANNELS and c not in ROTATION_CHANNELS:
                raise tokens.error(cline, f"expected a channel name (Xposition ... Zrotation), found {c!r}")
            if c in chans:
                raise tokens.error(cline, f"channel {c!r} repeated in joint {self.names[j]!r}")
            chans.append(c)
        return tuple(chans)

    def end_site(self, j: int) -> None:
        """``Site [name] { OFFSET x y z }`` after ``End``: an end site of joint ``j``."""
        tokens = self.tokens
        site, sline = tokens.next("Site")
        if site.upper() != "SITE":
            raise tokens.error(sline, f"expected 'Site' after 'End', found {site!r}")
        tokens.rest_of_line(sline)  # some exporters name their end sites
        b, bline = tokens.next("'{'")
        if b != "{":
            raise tokens.error(bline, f"expected '{{' to open the End Site, found {b!r}")
        tokens.keyword("OFFSET")
        self.es_offsets.append([tokens.number("an End Site OFFSET value") for _ in range(3)])
        self.es_parents.append(j)
        b, bline = tokens.next("'}'")
        if b != "}":
            raise tokens.error(bline, f"expected '}}' to close the End Site, found {b!r}")


def _parse_hierarchy(tokens: _Tokens) -> tuple[Skeleton, int]:
    """Parse ``HIERARCHY ... ROOT ... }``; return the skeleton and the line after it."""
    return _Hierarchy(tokens).parse()


_FRAMES = re.compile(r"\s*Frames\s*:\s*(\S*)\s*", re.IGNORECASE)
_FRAME_TIME = re.compile(r"\s*Frame\s+Time\s*:\s*(\S*)\s*", re.IGNORECASE)


def _header_value(path: str, lines: list[str], i: int, pattern: re.Pattern, what: str) -> tuple[str, int]:
    """Find the next non-blank line from ``i``; it must match ``pattern``."""
    while i < len(lines) and not lines[i].strip():
        i += 1
    if i >= len(lines):
        raise ParseError(path, len(lines), f"expected '{what} ...', found the end of the file")
    m = pattern.fullmatch(lines[i])
    if m is None:
        raise ParseError(path, i + 1, f"expected '{what} <value>', found {lines[i].strip()[:60]!r}")
    return m.group(1), i


# Exact powers of ten: m / 10^k with m < 2^53 and k <= 22 is one correctly rounded
# operation on exact operands, i.e. the same double as Python's float() of the text.
_POW10 = np.array([10.0**k for k in range(23)])


# The frame kernel's helpers are inlined into it (numba IR inlining): a plain call per
# number made the kernel 1.9x slower (8.1 against 4.6 ms for the 2.1 MB of CMU 01_01).
@njit(cache=True, inline="always")
def _is_blank(c: int) -> bool:
    """Space, tab, CR, VT or FF (not LF, which ends a frame line)."""
    return c == 32 or c == 9 or c == 13 or c == 11 or c == 12


@njit(cache=True, inline="always")
def _exponent_end(buf: np.ndarray, i: int) -> tuple[int, int]:
    """The optional exponent ``e[+-]digits`` (or ``E``) at ``buf[i]`` and the end of the number.

    Returns ``(i, exp)``: the position after the number and its decimal exponent (0 without
    one); ``i = -1`` for an ``e`` without digits, an exponent above 400, or a number not
    followed by whitespace or the end of the buffer.
    """  # pragma: no cover - numba
    n = buf.size
    exp = 0
    if i < n and (buf[i] == 101 or buf[i] == 69):
        i += 1
        eneg = i < n and buf[i] == 45
        if i < n and (buf[i] == 45 or buf[i] == 43):
            i += 1
        if not (i < n and 48 <= buf[i] <= 57):
            return -1, 0
        while i < n and 48 <= buf[i] <= 57:
            exp = exp * 10 + (buf[i] - 48)
            i += 1
            if exp > 400:
                return -1, 0
        if eneg:
            exp = -exp
    if i < n and not (_is_blank(buf[i]) or buf[i] == 10):
        return -1, 0
    return i, exp


@njit(cache=True, inline="always")
def _scaled(m: int, p: int, pow10: np.ndarray) -> float:
    """``m * 10^p``, one correctly rounded operation (``m < 2^53``); NaN for ``|p| > 22``."""
    if p < -22 or p > 22:
        return np.nan
    if p < 0:
        return float(m) / pow10[-p]
    return float(m) * pow10[p]


@njit(cache=True, inline="always")
def _rows_complete(row: int, col: int, n_ch: int, n_frames: int) -> int:
    """0 when the last line (``col`` values, no LF) completes ``n_frames`` rows, else 1."""
    if col != 0:
        if col != n_ch:
            return 1
        row += 1
    return 0 if row == n_frames else 1


@njit(cache=True)
def _parse_frames_fast(buf: np.ndarray, n_ch: int, n_frames: int, pow10: np.ndarray, out: np.ndarray) -> int:
    """Parse the ASCII frame block ``buf`` (uint8, LF line ends) into ``out`` (F * C).

    Returns 0 when every non-blank line holds exactly ``n_ch`` plain decimal numbers
    (``[+-]digits[.digits][e[+-]digits]``, at most 15 significant digits, decimal exponent
    within +-22) and there are ``n_frames`` such lines; 1 otherwise, and the caller falls
    back to the general path, which also words the error. Whitespace: space, tab, CR, VT, FF.
    """  # pragma: no cover - numba
    n = buf.size
    i = 0
    row = 0
    col = 0
    while i < n:
        c = buf[i]
        if c == 10:
            if col != 0:
                if col != n_ch:
                    return 1
                row += 1
                col = 0
            i += 1
            continue
        if _is_blank(c):
            i += 1
            continue
        if row >= n_frames or col >= n_ch:
            return 1
        neg = c == 45
        if neg or c == 43:
            i += 1
        # mantissa m: the digits before and after the point; its significant digits are
        # counted and checked once it is read (more than 15: not exact in a double)
        start = i
        m = 0
        digits = 0
        while i < n and 48 <= buf[i] <= 57:
            d = buf[i] - 48
            digits += (m > 0) | (d > 0)
            m = m * 10 + d
            i += 1
        whole = i - start
        frac = 0
        if i < n and buf[i] == 46:
            i += 1
            while i < n and 48 <= buf[i] <= 57:
                d = buf[i] - 48
                digits += (m > 0) | (d > 0)
                m = m * 10 + d
                frac += 1
                i += 1
        if (whole == 0 and frac == 0) or digits > 15:
            return 1
        i, exp = _exponent_end(buf, i)
        if i < 0:
            return 1
        v = _scaled(m, exp - frac, pow10)
        if v != v:  # the exponent is beyond +-22
            return 1
        out[row * n_ch + col] = -v if neg else v
        col += 1
    return _rows_complete(row, col, n_ch, n_frames)


def _scan_values(path: str, lines: list[str], first: int, rows: list[int], n_ch: int) -> np.ndarray:
    """Slow path: parse frame lines one by one, reporting the first bad token."""
    out = np.empty((len(rows), n_ch))
    for r, i in enumerate(rows):
        toks = lines[i].split()
        for k, tok in enumerate(toks):
            if not _NUMBER.fullmatch(tok):
                raise ParseError(
                    path, i + 1, f"expected a number (value {k + 1} of {n_ch} in frame {r}), found {tok!r}"
                )
        out[r] = [float(t) for t in toks]
    return out


def _parse_frames(path: str, text: str, lines: list[str], first: int, n_frames: int, n_ch: int) -> np.ndarray:
    """Values of the frame lines ``lines[first:]``, shape ``(n_frames, n_ch)``."""
    offset = sum(len(line) + 1 for line in lines[:first])
    if n_ch > 0 and n_frames <= len(lines) - first:  # a frame takes a line: no more frames than lines
        # Fast path (numba, one pass): plain ASCII decimals with the right counts.
        block = text[offset:]
        if block.isascii():
            out = np.empty(n_frames * n_ch)
            buf = np.frombuffer(block.encode("ascii"), dtype=np.uint8)
            if _parse_frames_fast(buf, n_ch, n_frames, _POW10, out) == 0:
                return out.reshape(n_frames, n_ch)
    # General path: count tokens per line (and word the errors), then parse.
    rows = []
    for i in range(first, len(lines)):
        count = len(lines[i].split())
        if count == 0:
            continue
        if count != n_ch:
            raise ParseError(
                path,
                i + 1,
                f"expected {n_ch} values (one per channel) in frame {len(rows)}, found {count}",
            )
        rows.append(i)
    if n_ch == 0:  # nothing to read: frame lines are blank
        if rows:
            raise ParseError(
                path, rows[0] + 1, f"expected 0 values per frame, found {len(lines[rows[0]].split())}"
            )
        return np.zeros((n_frames, 0))
    if len(rows) != n_frames:
        where = rows[-1] + 1 if rows else len(lines)
        hint = " (truncated file?)" if len(rows) < n_frames else ""
        raise ParseError(
            path, where, f"expected {n_frames} frames (the Frames: header), found {len(rows)}{hint}"
        )
    # numpy parses the whole block; the per-line counts above already hold.
    values = None
    try:
        with warnings.catch_warnings():  # numpy < 2 warns (instead of raising) on bad text
            warnings.simplefilter("ignore", DeprecationWarning)
            flat = np.fromstring(text[offset:], sep=" ")
        if flat.size == n_frames * n_ch:
            values = flat.reshape(n_frames, n_ch)
    except ValueError:
        pass
    if values is None:
        values = _scan_values(path, lines, first, rows, n_ch)
    bad = ~np.isfinite(values)
    if bad.any():
        r, k = (int(v) for v in np.argwhere(bad)[0])
        raise ParseError(
            path, rows[r] + 1, f"expected a finite number (value {k + 1} in frame {r}), found {values[r, k]}"
        )
    return values


def read_bvh(
    path: str | os.PathLike[str],
    *,
    units: str | float | None = None,
    up_axis: str | None = None,
) -> Motion:
    """Read a BVH file.

    Parameters
    ----------
    path : str or os.PathLike
    units : str or float, optional
        Length unit of the file: a name from :data:`.skeleton.UNITS` (``"m"``, ``"cm"``,
        ``"cmu"``, ...) or metres per unit. Default: guessed by :func:`guess_units`.
    up_axis : {"x", "y", "z"}, optional
        Label for ``Motion.up_axis`` (positions are never changed). Default: detected from
        the motion, :func:`.axes.detect_up_axis` ``(motion).up_axis``: the detected axis,
        or ``"y"`` when the estimate is ambiguous, upside down or the skeleton is not a
        human one (no torso and two legs below the hips). Every file of the project's test
        data is detected Y-up; Blender's BVH exports come out ``"z"``.

    Returns
    -------
    Motion
        ``rotations (F, J, 3, 3)``, ``root_translation (F, 3)``, ``joint_translations
        (F, J, 3)`` when a non-root joint has position channels, ``fps`` from
        ``Frame Time`` (see :func:`snap_fps`), ``up_axis`` as above.

    Raises
    ------
    ParseError
        For any malformed content; the message names the file, the line and what was
        expected.
    ValueError
        For an ``up_axis`` other than ``"x"``, ``"y"``, ``"z"`` or ``None``.
    """
    path_s = os.fspath(path)
    if up_axis is not None and up_axis not in ("x", "y", "z"):
        raise ValueError(f"up_axis: expected 'x', 'y', 'z' or None (detect) for {path_s!r}; got {up_axis!r}")
    text = read_text(path)
    if "\r" in text:
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    lines = text.split("\n")
    skeleton, motion_line = _read_hierarchy(path_s, lines)
    n_frames, fps, first = _motion_header(path_s, lines, motion_line, skeleton.n_joints)
    values = _parse_frames(path_s, text, lines, first, n_frames, skeleton.n_channels)
    motion = _motion_from_values(skeleton, values, fps, units, up_axis or "y", path_s)
    if up_axis is None:
        detected = detect_up_axis(motion).up_axis
        if detected != motion.up_axis:
            motion = motion.replace(up_axis=detected)
    return motion


def _read_hierarchy(path: str, lines: list[str]) -> tuple[Skeleton, int]:
    """The skeleton of the lines up to the ``MOTION`` line and the index of the line after it."""
    motion_at = None
    for i, line in enumerate(lines):
        if line.strip().upper() == "MOTION" or line.lstrip().upper().startswith("MOTION "):
            motion_at = i
            break
    tokens = _Tokens(path, lines, motion_at + 1 if motion_at is not None else len(lines))
    try:
        return _parse_hierarchy(tokens)
    except ValueError as exc:
        if isinstance(exc, ParseError):
            raise
        raise ParseError(path, None, str(exc)) from exc


def _motion_header(path: str, lines: list[str], i: int, n_joints: int) -> tuple[int, float, int]:
    """``Frames:`` and ``Frame Time:`` from line index ``i`` on, checked against the limits
    before anything is allocated: the frame count, the frame rate and the index of the first
    frame line."""
    frames_tok, i = _header_value(path, lines, i, _FRAMES, "Frames:")
    if not (frames_tok.isascii() and frames_tok.isdigit()):
        raise ParseError(path, i + 1, f"expected the number of frames (an integer), found {frames_tok!r}")
    if len(frames_tok) > 30:  # int() of a long digit string is slow (and pointless: over every limit)
        frames_tok = frames_tok[:30] + "..."
        raise ParseError(
            path,
            i + 1,
            f"expected a frame count of at most {limits.current().max_frames} "
            f"(limit max_frames), found {frames_tok!r}",
        )
    n_frames = int(frames_tok)
    if n_frames == 0:
        raise ParseError(path, i + 1, "expected at least one frame, found 'Frames: 0'")
    # before anything is allocated: the declared count against the limits
    limits.check_clip(path, i + 1, frames=n_frames, joints=n_joints)
    frames_line = i + 1
    ft_tok, i = _header_value(path, lines, i + 1, _FRAME_TIME, "Frame Time:")
    if not _NUMBER.fullmatch(ft_tok) or not (0 < float(ft_tok) < math.inf):
        raise ParseError(path, i + 1, f"expected a positive frame time in seconds, found {ft_tok!r}")
    fps = snap_fps(float(ft_tok))
    if not math.isfinite(fps):
        raise ParseError(path, i + 1, f"expected a frame time of at least 1e-300 s, found {ft_tok!r}")
    limits.check_clip(path, i + 1, fps=fps)
    limits.check_clip(path, frames_line, duration=n_frames / fps)
    return n_frames, fps, i + 1


def _motion_from_values(
    skeleton: Skeleton,
    values: np.ndarray,
    fps: float,
    units: str | float | None,
    up_axis: str,
    path: str,
) -> Motion:
    f = values.shape[0]
    j = skeleton.n_joints
    orders = skeleton.euler_orders
    # Column of each (joint, angle slot) and (joint, axis) in the frame; -1 when absent.
    rot_cols = np.full((j, 3), -1)
    pos_cols = np.full((j, 3), -1)
    col = 0
    for jj, chans in enumerate(skeleton.channels):
        slot = 0
        for c in chans:
            if c in POSITION_CHANNELS:
                pos_cols[jj, POSITION_CHANNELS[c]] = col
            else:
                rot_cols[jj, slot] = col
                slot += 1
            col += 1
    padded = np.concatenate([values, np.zeros((f, 1))], axis=1)  # column -1 reads zeros
    angles = np.deg2rad(padded[:, rot_cols])  # (F, J, 3)
    rotations = np.empty((f, j, 3, 3))
    for order in sorted(set(orders)):
        idx = [k for k in range(j) if orders[k] == order]
        rotations[:, idx] = euler_to_matrix(angles[:, idx], order)
    translations = np.where(pos_cols >= 0, padded[:, pos_cols], skeleton.offsets)  # (F, J, 3)
    has_pos = (pos_cols >= 0).any(axis=1)
    joint_translations = translations if has_pos[1:].any() else None
    return Motion(
        skeleton=skeleton,
        fps=fps,
        root_translation=translations[:, 0].copy(),
        rotations=rotations,
        joint_translations=joint_translations,
        metres_per_unit=_resolve_units(units, skeleton),
        up_axis=up_axis,
        source=(path,),
        name=Path(path).stem,
    )


# ------------------------------------------------------------------------------------------
# Writing
# ------------------------------------------------------------------------------------------
@njit(cache=True)
def _format_fixed_kernel(data: np.ndarray, decimals: int, buf: np.ndarray) -> int:
    """Write ``data`` (F, C) as text rows into ``buf``: each value rounded to ``decimals``
    digits after the point, trailing zeros (and a bare point) dropped, no ``-0``;
    values separated by one space, rows ended by a newline. Returns the byte count, or
    -1 if a value is too large for exact fixed point, ``|v| 10^decimals >= 2^53`` (the
    caller then formats in Python). The last digit may differ from ``%.{decimals}f`` by
    one where ``|v| 10^decimals`` rounds in floating point; the value stays within one
    unit of that digit.
    """  # pragma: no cover - numba
    scale = 1
    for _ in range(decimals):
        scale *= 10
    limit = 9007199254740992.0 / scale  # 2^53: q = round(|v| 10^d) stays exact
    digits = np.empty(24, dtype=np.uint8)
    pos = 0
    f, c = data.shape
    for r in range(f):
        for k in range(c):
            v = data[r, k]
            if not (abs(v) < limit):
                return -1
            # rint is np.round to 0 decimals (ties to even) without the environment that makes
            # loading this kernel import numba's array-math registry (elastic_motion._numba_cache)
            q = np.int64(np.rint(abs(v) * scale))
            if q != 0 and v < 0:
                buf[pos] = 45  # '-'
                pos += 1
            ip = q // scale
            fp = q % scale
            nd = 0
            while True:  # integer part, at least one digit
                digits[nd] = 48 + ip % 10
                nd += 1
                ip //= 10
                if ip == 0:
                    break
            for t in range(nd - 1, -1, -1):
                buf[pos] = digits[t]
                pos += 1
            if fp != 0:
                width = decimals
                while fp % 10 == 0:  # drop trailing zeros
                    fp //= 10
                    width -= 1
                buf[pos] = 46  # '.'
                pos += 1
                for t in range(width - 1, -1, -1):
                    digits[t] = 48 + fp % 10
                    fp //= 10
                for t in range(width):
                    buf[pos] = digits[t]
                    pos += 1
            buf[pos] = 10 if k == c - 1 else 32
            pos += 1
    return pos


def _format_rows(data: np.ndarray, decimals: int) -> str:
    """Frame lines of ``data`` (F, C), ``decimals`` digits at most after the point."""
    f, c = data.shape
    if c == 0:
        return "\n" * f
    data = np.ascontiguousarray(data, dtype=np.float64)
    buf = np.empty(f * c * (22 + decimals), dtype=np.uint8)
    n = _format_fixed_kernel(data, decimals, buf)
    if n >= 0:
        return buf[:n].tobytes().decode("ascii")
    data = np.where(data == 0, 0.0, data)  # no "-0.000"
    row = " ".join([f"%.{decimals}f"] * c) + "\n"
    return (row * f) % tuple(data.ravel())


def _fmt(x: float) -> str:
    r = repr(float(x))
    return "0" if r in ("0.0", "-0.0") else r


def _position_channels(sk: Skeleton, jj: int, chans: list[str], translations: np.ndarray) -> list[str]:
    """Joint ``jj``'s channels ``chans``, with the position channels it lacks added when its
    translations ``(F, 3)`` move along their axes (further than rounding from its offset).

    A root without position channels gets all three in front; a joint with some position
    channels gets the missing ones after its last one. A joint without position channels
    (other than the root) has no translation but its offset: nothing to add.
    """
    have = [POSITION_CHANNELS[c] for c in chans if c in POSITION_CHANNELS]
    if jj != 0 and not have:
        return chans
    missing = [a for a in range(3) if a not in have]
    if not missing:
        return chans
    offset = sk.offsets[jj, missing]
    dev = np.abs(translations[:, missing] - offset).max(initial=0.0)
    if not dev > _SAME_LENGTH * (1.0 + np.abs(offset).max()):
        return chans
    names = ["Xposition", "Yposition", "Zposition"]
    if not have:
        return [*names, *chans]
    last = max(k for k, c in enumerate(chans) if c in POSITION_CHANNELS)
    return [*chans[: last + 1], *(names[a] for a in missing), *chans[last + 1 :]]


def _output_channels(
    skeleton: Skeleton, euler_orders: str | Sequence[str] | None, translations: np.ndarray
) -> list[tuple[str, ...]]:
    j = skeleton.n_joints
    if euler_orders is None:
        orders: list[str | None] = [None] * j
    elif isinstance(euler_orders, str):
        orders = [euler_orders] * j
    else:
        orders = list(euler_orders)
        if len(orders) != j:
            raise ValueError(f"euler_orders: expected {j} orders (one per joint); got {len(orders)}")
    out = []
    for jj, chans in enumerate(skeleton.channels):
        chans = _position_channels(skeleton, jj, list(chans), translations[:, jj])
        order = orders[jj]
        if order is not None:
            order = order.upper()
            if not valid_euler_order(order):
                raise ValueError(
                    f"euler_orders[{jj}]: expected three distinct axes from 'XYZ'; got {orders[jj]!r}"
                )
            chans = [c for c in chans if c in POSITION_CHANNELS] + [f"{a}rotation" for a in order]
        out.append(tuple(chans))
    return out


def write_bvh(
    motion: Motion,
    path: str | os.PathLike[str],
    *,
    euler_orders: str | Sequence[str] | None = None,
    decimals: int = 8,
    protected: Sequence[str | os.PathLike[str]] = (),
) -> Path:
    """Write a motion as a BVH file, atomically.

    Parameters
    ----------
    motion : Motion
    path : str or os.PathLike
        Destination; refused (``ValueError``) if it is one of ``motion.source``.
    euler_orders : str or sequence of str, optional
        Rotation channel order to write, for all joints (``"ZYX"``) or per joint.
        Default: each joint's channels as in ``motion.skeleton`` (a lossless round trip
        for a motion read from a BVH file: same channels, same rotations).
    decimals : int, default 8
        Digits after the decimal point of the frame values (degrees and length units),
        trailing zeros dropped (``5.23``, not ``5.23000000``). With 8, re-read rotations
        equal the written ones to about 1e-8 degrees.
    protected : sequence of paths, optional
        Further files that must not be overwritten (e.g. the inputs a blend or mean was
        computed from, which ``motion.source`` does not list).

    Returns
    -------
    pathlib.Path
        The written path.

    Notes
    -----
    BVH lists joints depth-first and a frame's values in that order. A skeleton whose
    joints are numbered otherwise (parents still first) is written depth-first, so
    reading the file back gives the same joints in depth-first order. End sites are
    written inside their joints' blocks, so they too come back in depth-first order.

    Angles are continuous over time (no jump of 360 degrees, nor to the other Euler
    solution of three channels, between frames), so a file may hold angles beyond +-180
    degrees. A joint with one or two rotation channels (``Xrotation Zrotation``) is
    written with those channels at any angle; a rotation they cannot hold (a blend of such
    rotations, in general) is written as the nearest one they hold
    (:func:`.rotations.nearest_euler`): :func:`rotation_channel_fit` says which joints and
    by how much, and ``euler_orders`` writes three channels instead. Position channels are
    never dropped: a joint that moves along an axis without one (the root of a computed
    motion, for one) is written with the missing position channels added.

    Raises
    ------
    ValueError
        If ``path`` is an input file of the motion, or for a bad ``euler_orders`` or
        ``decimals``.
    """
    if not (isinstance(decimals, int) and 0 <= decimals <= 15):
        raise ValueError(f"decimals: expected an integer in [0, 15]; got {decimals!r}")
    sk = motion.skeleton
    translations = motion.local_translations()
    channels = _output_channels(sk, euler_orders, translations)
    angles = _output_angles(motion, channels)
    children: list[list[int]] = [[] for _ in range(sk.n_joints)]
    for k in range(1, sk.n_joints):
        children[int(sk.parents[k])].append(k)
    # BVH stores a frame's values in the order joints are declared, depth-first.
    dfs: list[int] = []
    todo = [0]
    while todo:
        k = todo.pop()
        dfs.append(k)
        todo.extend(reversed(children[k]))
    columns = []
    for jj in dfs:
        columns += _joint_columns(channels[jj], angles[:, jj], translations[:, jj])
    data = np.stack(columns, axis=1) if columns else np.zeros((motion.n_frames, 0))
    parts = ["HIERARCHY\n", *_hierarchy_text(sk, channels, children)]
    parts.append(f"MOTION\nFrames: {motion.n_frames}\nFrame Time: {_fmt(1.0 / motion.fps)}\n")
    parts.append(_format_rows(data, decimals))
    return atomic_write_text(path, "".join(parts), protected=[*motion.source, *protected])


def _rotation_axes(chans: Sequence[str]) -> str:
    """The axes of a joint's rotation channels, in channel order (``"XZ"``, ``""``)."""
    return "".join(ROTATION_CHANNELS[c] for c in chans if c in ROTATION_CHANNELS)


def _output_angles(motion: Motion, channels: list[tuple[str, ...]]) -> np.ndarray:
    """Euler angles ``(F, J, 3)`` in degrees: per joint, the angles of its rotation channels
    in channel order (zeros after them), continuous over time.

    Three channels: :func:`.rotations.matrix_to_euler`, made continuous by
    :func:`.representations.unwrap_euler` (branch and ``2 pi`` shifts). One or two: the
    angles of the nearest rotation those channels hold (:func:`.rotations.nearest_euler`:
    exact for a rotation they hold, at any angle), unwrapped (``np.unwrap``).
    """
    axes = [_rotation_axes(ch) for ch in channels]
    f, j = motion.n_frames, motion.n_joints
    angles = np.zeros((f, j, 3))
    full = [k for k in range(j) if len(axes[k]) == 3]
    for order in sorted({axes[k] for k in full}):
        idx = [k for k in full if axes[k] == order]
        angles[:, idx] = matrix_to_euler(motion.rotations[:, idx], order)
    if full:
        angles[:, full] = unwrap_euler(angles[:, full])
    for k in range(j):
        n = len(axes[k])
        if 0 < n < 3:
            angles[:, k, :n] = np.unwrap(nearest_euler(motion.rotations[:, k], axes[k]), axis=0)
    return np.rad2deg(angles)


def rotation_channel_fit(motion: Motion, euler_orders: str | Sequence[str] | None = None) -> dict[str, float]:
    """The joints whose rotation channels cannot hold their rotations, and by how much.

    A joint with fewer than three rotation channels holds only the rotations of their
    family (``Xrotation Zrotation``: ``Rx(a) @ Rz(b)``; none: the identity). A motion read
    from a BVH file always fits its own channels; a computed one (a blend, a loop) may
    leave the family, and :func:`write_bvh` then writes the nearest rotation the channels
    hold. This gives the largest angle between a rotation and the one written.

    Parameters
    ----------
    motion : Motion
    euler_orders : str or sequence of str, optional
        As in :func:`write_bvh` (three channels on every joint: nothing to report).

    Returns
    -------
    dict of str to float
        Joint name -> largest rotation angle (degrees, over the frames) between the motion's
        rotation and the one its channels hold, for the joints where it exceeds 1e-7 degrees;
        in joint order. Empty when every rotation is written exactly.
    """
    sk = motion.skeleton
    channels = _output_channels(sk, euler_orders, motion.local_translations())
    out: dict[str, float] = {}
    so3 = SO3()
    for k, chans in enumerate(channels):
        axes = _rotation_axes(chans)
        if len(axes) == 3:
            continue
        rot = motion.rotations[:, k]
        if axes:
            t = np.zeros(rot.shape[:-2] + (3,))
            t[..., : len(axes)] = nearest_euler(rot, axes)
            held = euler_to_matrix(t, axes + "".join(a for a in "XYZ" if a not in axes))
        else:
            held = np.broadcast_to(np.eye(3), rot.shape)
        gap = np.degrees(np.linalg.norm(so3.log(np.swapaxes(held, -1, -2) @ rot), axis=-1))
        worst = float(gap.max(initial=0.0))
        if worst > _FIT_TOLERANCE_DEG:
            out[sk.names[k]] = worst
    return out


def _joint_columns(chans: tuple[str, ...], angles: np.ndarray, translations: np.ndarray) -> list[np.ndarray]:
    """The frame columns ``(F,)`` of a joint's channels ``chans``, from its angles ``(F, 3)``
    (degrees, channel order) and translations ``(F, 3)``."""
    columns = []
    slot = 0
    for c in chans:
        if c in POSITION_CHANNELS:
            columns.append(translations[:, POSITION_CHANNELS[c]])
        else:
            columns.append(angles[:, slot])
            slot += 1
    return columns


def _hierarchy_text(sk: Skeleton, channels: list[tuple[str, ...]], children: list[list[int]]) -> list[str]:
    """The ``ROOT ... }`` block: joints depth-first, tab-indented, end sites in their joints."""
    parts = []
    sites: list[list[int]] = [[] for _ in range(sk.n_joints)]
    for e, p in enumerate(sk.end_site_parents):
        sites[int(p)].append(e)
    # Depth-first over the tree with an explicit stack: ("open", k, depth) writes the
    # joint's header and schedules its children, end sites and closing brace.
    stack: list[tuple[str, int, int]] = [("open", 0, 0)]
    while stack:
        action, k, depth = stack.pop()
        ind = "\t" * depth
        if action == "close":
            for e in sites[k]:
                off = " ".join(_fmt(v) for v in sk.end_site_offsets[e])
                parts.append(f"{ind}\tEnd Site\n{ind}\t{{\n{ind}\t\tOFFSET {off}\n{ind}\t}}\n")
            parts.append(f"{ind}}}\n")
            continue
        kind = "ROOT" if k == 0 else "JOINT"
        parts.append(f"{ind}{kind} {sk.names[k]}\n{ind}{{\n")
        parts.append(f"{ind}\tOFFSET {' '.join(_fmt(v) for v in sk.offsets[k])}\n")
        parts.append(f"{ind}\tCHANNELS {len(channels[k])}{''.join(' ' + c for c in channels[k])}\n")
        stack.append(("close", k, depth))
        for c in reversed(children[k]):
            stack.append(("open", c, depth + 1))
    return parts
