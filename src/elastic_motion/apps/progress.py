"""A minimal progress reporter for the command line (stderr), with no dependency.

Numerical code never prints: long-running functions of the package take an optional
callback ``progress(stage, done, total)`` (the protocol of :mod:`elastic_motion.apps.database`).
The CLI passes a :class:`ProgressBar` (it is such a callable) and the bar draws itself on
stderr::

    blend: warp  [##########----------]  2/4  1.3 s

Rules, so that short commands stay quiet and logs stay clean:

* Nothing is drawn before ``delay`` seconds (default 1 s) have passed since the bar was
  created: work that takes under a second shows no bar.
* The bar is redrawn in place (carriage return) only when the stream is a terminal; on a
  pipe or a file (CI logs, tests) it writes nothing, unless ``ELASTIC_MOTION_PROGRESS=1``,
  in which case each stage gets one plain line (with the seconds since the start).
* ``ELASTIC_MOTION_PROGRESS=0`` (or ``enabled=False``, the CLI's ``--quiet``) turns it off.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable
from typing import TextIO

__all__ = ["Progress", "ProgressBar", "null_progress"]

#: The callback protocol: ``progress(stage, done, total)``; ``total = 0`` means unknown.
Progress = Callable[[str, int, int], None]


def null_progress(stage: str, done: int, total: int) -> None:
    """A progress callback that does nothing."""


class ProgressBar:
    """A stderr progress bar usable as a ``progress(stage, done, total)`` callback.

    Parameters
    ----------
    label : str
        Printed before the stage name (e.g. the command, ``"blend"``).
    stream : file-like, optional
        Default ``sys.stderr``.
    delay : float, default 1.0
        Seconds before anything is drawn.
    enabled : bool, optional
        Force on or off; default from ``ELASTIC_MOTION_PROGRESS`` (``"0"`` off, ``"1"``
        on even when the stream is not a terminal), otherwise on for terminals only.
    width : int, default 24
        Characters of the bar.

    Examples
    --------
    >>> bar = ProgressBar("demo", enabled=False)
    >>> for i in range(3):
    ...     bar("render", i + 1, 3)
    >>> bar.close()
    """

    def __init__(
        self,
        label: str = "",
        *,
        stream: TextIO | None = None,
        delay: float = 1.0,
        enabled: bool | None = None,
        width: int = 24,
    ) -> None:
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.delay = float(delay)
        self.width = int(width)
        env = os.environ.get("ELASTIC_MOTION_PROGRESS", "")
        try:
            tty = bool(self.stream.isatty())
        except (AttributeError, ValueError):
            tty = False
        self._lines = env == "1" and not tty  # plain lines instead of a live bar
        if enabled is None:
            enabled = env != "0" and (tty or env == "1")
        self.enabled = bool(enabled)
        self._t0 = time.perf_counter()
        self._stage_t0 = self._t0
        self._stage: str | None = None
        self._drawn = False
        self._last_draw = 0.0
        self._last_done = -1

    # -- the callback ------------------------------------------------------------------------
    def __call__(self, stage: str, done: int, total: int) -> None:
        """Report that ``done`` of ``total`` steps of ``stage`` are finished."""
        if not self.enabled:
            return
        now = time.perf_counter()
        new_stage = stage != self._stage
        if new_stage:
            self._finish_line()
            self._stage = stage
            self._stage_t0 = now
        if now - self._t0 < self.delay:
            return
        finished = total > 0 and done >= total
        if self._lines:  # one plain line per stage, and one when a counted stage is done
            if new_stage or (finished and done != self._last_done):
                self._write(f"{self._prefix()}{stage}: {done}/{total} ({now - self._t0:.1f} s)\n")
                self._last_done = done
            return
        if not finished and now - self._last_draw < 0.1:  # at most 10 redraws a second
            return
        self._last_draw = now
        self._write("\r" + self._render(stage, done, total, now - self._stage_t0))
        self._drawn = True

    def _prefix(self) -> str:
        return f"{self.label}: " if self.label else ""

    def _render(self, stage: str, done: int, total: int, elapsed: float) -> str:
        if total > 0:
            frac = min(max(done / total, 0.0), 1.0)
            fill = round(frac * self.width)
            bar = "#" * fill + "-" * (self.width - fill)
            return f"{self._prefix()}{stage:<12.12} [{bar}] {done}/{total} {elapsed:5.1f} s "
        return f"{self._prefix()}{stage:<12.12} {done} {elapsed:5.1f} s "

    def _write(self, text: str) -> None:
        try:
            self.stream.write(text)
            self.stream.flush()
        except (OSError, ValueError):  # closed stream: progress is never worth a crash
            self.enabled = False

    def _finish_line(self) -> None:
        if self._drawn:
            self._write("\n")
            self._drawn = False

    def close(self) -> None:
        """End the current line (call when the work is done)."""
        if self.enabled:
            self._finish_line()

    def __enter__(self) -> ProgressBar:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
