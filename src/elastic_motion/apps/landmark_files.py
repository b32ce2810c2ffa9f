"""Landmark files: pairs of times ``(tA, tB)`` a warp of B onto A must meet, read once for
the Python API and the command line.

Accepted formats
----------------
* The report of ``elastic-motion landmarks A B --json``: its ``pairs_s`` (seconds) and its
  ``landmark_weight``, the relative weight ``--landmarks auto`` meets the pairs with, so that
  the file gives the warp (and the blend) that ``auto`` gives. Its ``inputs`` name the two
  clips: a file made for other clips, or for the same two the other way round, is refused
  when the caller says which inputs it reads them for.
* JSON ``{"units": "seconds" | "frames", "pairs": [[a, b], ...]}``.
* Text, one pair per line (``a b``, ``a,b`` or ``a:b``; ``#`` starts a comment).

Times are in ``units`` (:data:`TimeUnit`: ``"seconds"`` or ``"frames"``) unless suffixed with
``s`` or ``f``; frames count from each clip's first frame kept (after trimming), at that
clip's frame rate.

The command line's ``--landmarks`` takes ``auto``, ``none``, such a file, or inline pairs
``"tA:tB,..."``: :func:`parse_landmarks` reads that text, for the commands and for the Python
functions that take it (:func:`elastic_motion.apps.render_files.render_motions`).

Use::

    lm = em.read_landmarks("pairs.json", inputs=["walk.bvh", "run.bvh"])
    res = em.blend(["walk.bvh", "run.bvh"], 0.5, landmarks=lm)   # = blend --landmarks pairs.json

A :class:`LandmarkFile` given as ``landmarks`` brings its pairs and, when it records one, its
weight (:meth:`LandmarkFile.warp_options`); pass ``landmarks=lm.pairs`` to meet them with the
weight of your own ``warp`` options instead.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from elastic_motion._io import read_text
from elastic_motion.errors import OptionError, ParseError
from elastic_motion.vocabulary import TIME_UNITS, TimeUnit
from elastic_motion.warp import WarpOptions

__all__ = ["TIME_UNITS", "LandmarkFile", "TimeUnit", "landmark_time", "parse_landmarks", "read_landmark_file"]

# The unit of a landmark time without a suffix: TimeUnit ("seconds", "frames") and its values
# TIME_UNITS, from elastic_motion.vocabulary.


@dataclass(frozen=True)
class LandmarkFile:
    """The pairs of a landmarks file (module docstring).

    Attributes
    ----------
    path : str
    pairs : tuple of (float, float)
        ``(tA, tB)`` in seconds from each clip's first frame.
    landmark_weight : float or None
        The relative weight the file records (the report of ``elastic-motion landmarks``),
        else None.
    inputs : tuple of str or None
        The two clips the file was made for, when it says.
    """

    path: str
    pairs: tuple[tuple[float, float], ...]
    landmark_weight: float | None = None
    inputs: tuple[str, ...] | None = None

    def warp_options(self, warp: str | WarpOptions | None = None) -> WarpOptions:
        """``warp`` (a method name is short for ``WarpOptions(method=name)``; default
        ``WarpOptions()``) with the file's landmark weight, when it records one."""
        base = WarpOptions() if warp is None else WarpOptions(method=warp) if isinstance(warp, str) else warp
        return base if self.landmark_weight is None else base.replace(landmark_weight=self.landmark_weight)


def landmark_time(value: str, unit: str, fps: float | None) -> float:
    """One time of a landmark pair, in seconds.

    ``value`` is a number in ``unit`` (``"seconds"`` or ``"frames"``), or a number suffixed
    with ``s`` (seconds) or ``f`` (frames, at ``fps``). Raises ``ValueError`` saying what was
    expected.
    """
    v = value.strip().lower()
    if v.endswith("s"):
        unit, v = "seconds", v[:-1]
    elif v.endswith("f"):
        unit, v = "frames", v[:-1]
    try:
        x = float(v)
    except ValueError:
        raise ValueError(f"expected a time (seconds, or frames with 'f'); got {value!r}") from None
    if not math.isfinite(x):
        raise ValueError(f"expected a finite time; got {value!r}")
    if unit == "frames":
        if fps is None:
            raise ValueError(f"{value!r} is in frames: give the clips' frame rates (fps=(fps_a, fps_b))")
        return x / fps
    return x


def read_landmark_file(
    path: str | os.PathLike[str],
    *,
    units: TimeUnit = "seconds",
    fps: tuple[float, float] | None = None,
    inputs: Sequence[str | os.PathLike[str]] | None = None,
) -> LandmarkFile:
    """Read a landmarks file (module docstring).

    Parameters
    ----------
    path : path
    units : {"seconds", "frames"}
        Unit of unsuffixed times in a text file (a JSON ``pairs`` file says its own).
    fps : (float, float), optional
        Frame rates of A and B (after preparation), for times in frames.
    inputs : sequence of path, optional
        The two clips the pairs are for (A, B): a report of ``elastic-motion landmarks`` made
        for other clips, or for these the other way round, is refused.

    Returns
    -------
    LandmarkFile

    Raises
    ------
    ParseError
        A malformed file (names the file and line), a file of other inputs, or times in
        frames without ``fps``.
    """
    if units not in TIME_UNITS:
        raise ValueError(f"units: expected 'seconds' or 'frames'; got {units!r}")
    if fps is not None:
        ok = len(fps) == 2 and all(
            isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x) and x > 0 for x in fps
        )
        if not ok:
            raise ValueError(f"fps: expected the frame rates of A and B, two numbers > 0; got {fps!r}")
    p = Path(path)
    text = read_text(p)  # a regular file within the max_file_bytes limit, else ParseError
    fa, fb = (None, None) if fps is None else fps
    try:
        data = json.loads(text)
    except json.JSONDecodeError:
        data = None
    if isinstance(data, dict):
        return _json_file(p, data, fa, fb, inputs)
    pairs = []
    for n, line in enumerate(text.splitlines(), 1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        parts = line.replace(",", " ").replace(":", " ").split()
        if len(parts) != 2:
            raise ParseError(p, n, f"expected two times (A B); found {line!r}")
        try:
            pairs.append((landmark_time(parts[0], units, fa), landmark_time(parts[1], units, fb)))
        except ValueError as exc:
            raise ParseError(p, n, str(exc)) from None
    return LandmarkFile(str(p), tuple(pairs))


def parse_landmarks(
    value: str | None,
    *,
    units: TimeUnit = "seconds",
    fps: tuple[float, float] | None = None,
    inputs: Sequence[str | os.PathLike[str]] | None = None,
) -> str | list[tuple[float, float]] | LandmarkFile | None:
    """A landmarks argument given as text, as ``--landmarks`` takes it.

    Parameters
    ----------
    value : str or None
        ``"auto"``, ``"none"`` (or None), the path of a landmarks file (module docstring), or
        inline pairs ``"tA:tB,tA:tB,..."`` (times in ``units``, or suffixed ``s``/``f``).
    units : {"seconds", "frames"}
        Unit of times without a suffix (frames count from each clip's first frame kept).
    fps : (float, float), optional
        Frame rates of A and B (after preparation), for times in frames.
    inputs : sequence of path, optional
        The two clips the pairs are for (:func:`read_landmark_file`).

    Returns
    -------
    None, "auto", list of (float, float) or LandmarkFile
        No landmarks; pair events automatically; inline pairs in seconds; a file's pairs
        (with the weight it records).

    Raises
    ------
    OptionError
        ``landmarks``: neither ``auto``, ``none``, an existing file nor pairs ``tA:tB``.
    ParseError
        A malformed file.
    """
    if value is None or value == "none":
        return None
    if value == "auto":
        return "auto"
    if os.path.exists(value):
        return read_landmark_file(value, units=units, fps=fps, inputs=inputs)
    if ":" not in value:
        raise OptionError(
            "landmarks",
            f"expected 'auto', 'none', a file, or pairs like '0.5:0.7,1.4:1.9'; got {value!r} (no such file)",
        )
    fa, fb = (None, None) if fps is None else fps
    pairs = []
    for item in value.split(","):
        if not item.strip():
            continue
        if item.count(":") != 1:
            raise OptionError("landmarks", f"expected 'tA:tB' pairs separated by commas; got {item!r}")
        a, b = item.split(":")
        pairs.append((_inline_time(a, units, fa), _inline_time(b, units, fb)))
    return pairs


def _inline_time(value: str, units: str, fps: float | None) -> float:
    """One time of an inline pair (:func:`parse_landmarks`) in seconds."""
    try:
        return landmark_time(value, units, fps)
    except ValueError as exc:
        raise OptionError("landmarks", str(exc)) from None


def _json_file(p: Path, data: dict, fa: float | None, fb: float | None, inputs) -> LandmarkFile:
    """A JSON landmarks file: the report of ``elastic-motion landmarks`` or ``{"pairs": ...}``."""
    if "pairs_s" in data:
        theirs = data.get("inputs")
        if isinstance(theirs, list) and len(theirs) == 2:
            _check_inputs(p, [str(f) for f in theirs], inputs)
        weight = data.get("landmark_weight")
        number = isinstance(weight, int | float) and not isinstance(weight, bool)
        if weight is not None and not (number and math.isfinite(weight) and weight >= 0):
            raise ParseError(p, None, f"'landmark_weight' must be a finite number >= 0; got {weight!r}")
        try:
            pairs = tuple((float(a), float(b)) for a, b in data["pairs_s"])
        except (TypeError, ValueError):
            raise ParseError(p, None, "'pairs_s' must be a list of [tA, tB] pairs of numbers") from None
        return LandmarkFile(
            str(p),
            pairs,
            None if weight is None else float(weight),
            tuple(str(f) for f in theirs) if isinstance(theirs, list) else None,
        )
    if "pairs" in data:
        u = str(data.get("units", "seconds"))
        if u not in TIME_UNITS:
            raise ParseError(p, None, f"'units' must be 'seconds' or 'frames'; got {u!r}")
        try:
            pairs = tuple(
                (landmark_time(str(a), u, fa), landmark_time(str(b), u, fb)) for a, b in data["pairs"]
            )
        except (TypeError, ValueError) as exc:
            raise ParseError(p, None, f"'pairs': {exc}") from None
        return LandmarkFile(str(p), pairs)
    raise ParseError(p, None, "expected a JSON object with 'pairs' (and 'units') or 'pairs_s'")


def _check_inputs(p: Path, theirs: list[str], inputs) -> None:
    """Refuse the report of ``elastic-motion landmarks`` for other inputs, or for A and B
    swapped (its pairs would pin the wrong clips' times)."""
    if inputs is None or len(inputs) < 2:
        return
    theirs = [Path(f).name for f in theirs]
    mine = [Path(str(f)).name for f in list(inputs)[:2]]
    if theirs == mine:
        return
    why = "the same files the other way round" if theirs == mine[::-1] else "other files"
    raise ParseError(
        p,
        None,
        f"expected landmarks of {mine[0]} and {mine[1]}, in that order; got pairs of "
        f"{theirs[0]} and {theirs[1]} ({why}; run `elastic-motion landmarks` on these inputs)",
    )
