"""Progress bars for the command line (stderr), drawn by the optional package ``tqdm``.

Numerical code never prints: long-running functions of the package take an optional
callback ``progress(stage, done, total)`` (the protocol of :mod:`elastic_motion.apps.database`).
The CLI passes a :class:`ProgressBar` (it is such a callable), which draws one tqdm bar per
stage on stderr::

    blend: warp:  50%|#####     | 2/4 [00:01<00:01,  1.90 steps/s]

Rules, so that short commands stay quiet and logs stay clean:

* A stage shows nothing before ``delay`` seconds (default 1 s) have passed since it began:
  work that takes under a second shows no bar.
* Bars are drawn only when the stream is a terminal; on a pipe or a file (CI logs, tests)
  nothing is written, unless ``ELASTIC_MOTION_PROGRESS=1`` (then the bar is redrawn at most
  every 5 s, in ASCII).
* ``ELASTIC_MOTION_PROGRESS=0`` (or ``enabled=False``, the CLI's ``--quiet``) turns it off.
* Without tqdm (``pip install "elastic-motion[progress]"``) a :class:`ProgressBar` is a
  silent no-op.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from typing import Any, TextIO

__all__ = ["Progress", "ProgressBar", "null_progress"]

#: The callback protocol: ``progress(stage, done, total)``; ``total = 0`` means unknown.
Progress = Callable[[str, int, int], None]

#: Seconds between redraws when the stream is not a terminal (``ELASTIC_MOTION_PROGRESS=1``).
_LOG_INTERVAL = 5.0


def null_progress(stage: str, done: int, total: int) -> None:
    """A progress callback that does nothing."""


def _tqdm_class() -> type | None:
    """tqdm's bar class without its monitor thread, or ``None`` when tqdm is not installed."""
    try:
        from tqdm import tqdm
    except ImportError:
        return None

    class _Bar(tqdm):
        monitor_interval = 0  # no background thread (it would outlive short commands and forks)

    return _Bar


class ProgressBar:
    """A stderr progress bar usable as a ``progress(stage, done, total)`` callback.

    Each stage gets its own tqdm bar (labelled ``"LABEL: STAGE"``), closed when the next
    stage starts or on :meth:`close`; a finished bar stays on screen.

    Parameters
    ----------
    label : str
        Printed before the stage name (e.g. the command, ``"blend"``).
    stream : file-like, optional
        Default ``sys.stderr``.
    delay : float, default 1.0
        Seconds a stage must run before its bar is drawn.
    enabled : bool, optional
        Force on or off; default from ``ELASTIC_MOTION_PROGRESS`` (``"0"`` off, ``"1"`` on
        even when the stream is not a terminal), otherwise on for terminals only.
        ``ELASTIC_MOTION_PROGRESS=0`` wins over ``enabled=True``. Always off when tqdm is
        not installed.

    Attributes
    ----------
    enabled : bool
        Whether anything can be drawn.

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
    ) -> None:
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.delay = float(delay)
        env = os.environ.get("ELASTIC_MOTION_PROGRESS", "")
        try:
            self._tty = bool(self.stream.isatty())
        except (AttributeError, ValueError):
            self._tty = False
        if enabled is None:
            enabled = self._tty or env == "1"
        self._cls = _tqdm_class() if enabled and env != "0" else None
        self.enabled = self._cls is not None
        self._stage: str | None = None
        self._bar: Any = None

    def __call__(self, stage: str, done: int, total: int) -> None:
        """Report that ``done`` of ``total`` steps of ``stage`` are finished (``total=0``: unknown)."""
        if not self.enabled:
            return
        try:
            if stage != self._stage or self._bar is None:
                self._close_bar()
                self._stage = stage
                self._bar = self._new_bar(stage, total)
            bar = self._bar
            new_total = total if total > 0 else None
            if bar.total != new_total:
                bar.total = new_total
            bar.update(done - bar.n)
        except (OSError, ValueError):  # closed stream: progress is never worth a crash
            self.enabled = False

    def _new_bar(self, stage: str, total: int) -> Any:
        assert self._cls is not None
        return self._cls(
            total=total if total > 0 else None,
            desc=f"{self.label}: {stage}" if self.label else stage,
            file=self.stream,
            delay=self.delay,
            leave=True,
            miniters=1,
            mininterval=0.1 if self._tty else _LOG_INTERVAL,
            dynamic_ncols=self._tty,
            ncols=None if self._tty else 80,
            ascii=None if self._tty else True,
            unit=" steps",
        )

    def _close_bar(self) -> None:
        bar, self._bar = self._bar, None
        if bar is not None:
            try:
                bar.close()
            except (OSError, ValueError):
                self.enabled = False

    def close(self) -> None:
        """Close the current stage's bar (call when the work is done)."""
        self._close_bar()
        self._stage = None

    def __enter__(self) -> ProgressBar:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
