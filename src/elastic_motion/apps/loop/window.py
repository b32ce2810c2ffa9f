"""The window stage of a loop: which frames loop (:func:`loop_window`).

The whole clip (``window=None``), the given frames ``(start, stop)``, the best cycle
(``"auto"``), or by default (``"safe"``) the whole clip when its loop changes it by at most
``change_bound`` relative to the root, else the best cycle. The best cycle (``"auto"``): the
cheap pass of :mod:`elastic_motion.apps.loop.window_candidates` proposes a few windows, each
is closed exactly (by the close stage, :class:`~.close.ClipCloser`) and the one whose loop
changes the motion least is kept (:class:`CycleWindow` says how it was chosen; the whole
clip is closed too, for the report). Candidates with kept contacts are ranked by the plain
projection (ranking every candidate with them would cost a constrained projection each) and
the chosen one is closed again with its contacts.

How much a loop changes a window is measured on the closed joints and their end sites
(:func:`~elastic_motion.apps.metrics.seam_metrics`, ``deviation_*``, metres), against the
window's own frames or, in place, the window on its own treadmill (else the travel the
treadmill takes out counts as change, and the shortest, slowest window won: a 13-frame step
of the DeepMimic run, 12 frames of a pause in CMU 107_02).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from elastic_motion.apps.loop.close import ClipCloser, ClosedClip
from elastic_motion.apps.loop.options import LoopOptions
from elastic_motion.apps.loop.window_candidates import CycleCandidates, cycle_candidates
from elastic_motion.apps.metrics import SeamMetrics, seam_metrics
from elastic_motion.errors import OptionError
from elastic_motion.motion import Motion
from elastic_motion.motion.looping import treadmill
from elastic_motion.notes import Note

__all__ = ["WINDOW_CHOICE", "CycleWindow", "WindowedLoop", "loop_window", "relative_change"]


@dataclass(frozen=True, eq=False)
class CycleWindow:
    """The window a loop was made of (:func:`loop_window`).

    Attributes
    ----------
    start, stop : int
        Frames ``[start, stop)`` of the prepared clip.
    fps : float
    deviation_max_m, deviation_mean_m : float
        How much the loop changed the window: FK positions of the closed joints and their
        end sites against the window's own frames (m); with root ``"inplace"`` against the
        window on its own treadmill (the travel taken out is not counted), as for every
        candidate and the whole clip.
    change : float or None
        ``||q - q_orig||_L2`` of the window's closing (SRV units).
    whole : dict
        The same numbers for the whole clip closed (``deviation_max_m``,
        ``deviation_mean_m``, ``change_srv_l2``), or ``{"error": ...}``.
    candidates : tuple of dict
        Every window closed exactly, with its numbers (or its error).
    min_length : float or None
        Shortest window allowed, seconds (``None`` for a given window).
    min_length_default : bool
        Whether ``min_length`` was not given (then 90 % of the period, or half the clip
        without one: ``summary()["min_length_rule"]``).
    period : float or None
        The clip's estimated period, seconds.
    quiet_excluded : bool
        Whether windows that barely move were left out of the candidates
        (:mod:`elastic_motion.apps.loop.window_candidates`, "Quiet windows").
    """

    start: int
    stop: int
    fps: float
    deviation_max_m: float
    deviation_mean_m: float
    change: float | None
    whole: dict
    candidates: tuple[dict, ...]
    min_length: float | None
    min_length_default: bool
    period: float | None
    quiet_excluded: bool = False

    @property
    def length(self) -> float:
        """Length of the cycle in seconds, ``(stop - 1 - start) / fps``."""
        return (self.stop - 1 - self.start) / self.fps

    def summary(self) -> dict[str, Any]:
        """JSON-ready fields (frames, seconds, metres)."""
        return {
            "start_frame": self.start,
            "stop_frame": self.stop,
            "start_s": self.start / self.fps,
            "stop_s": (self.stop - 1) / self.fps,
            "length_s": self.length,
            "deviation_max_m": self.deviation_max_m,
            "deviation_mean_m": self.deviation_mean_m,
            "change_srv_l2": self.change,
            "whole_clip": dict(self.whole),
            "candidates": [dict(c) for c in self.candidates],
            "min_length_s": self.min_length,
            "min_length_from_period": self.min_length_default and self.period is not None,
            "min_length_rule": (
                "given"
                if not self.min_length_default
                else "90 % of the period"
                if self.period is not None
                else "half the clip (no period found)"
            ),
            "period_s": self.period,
            "quiet_windows_excluded": self.quiet_excluded,
        }


@dataclass(frozen=True, eq=False)
class WindowedLoop:
    """The window stage's result (:func:`loop_window`).

    Attributes
    ----------
    window : CycleWindow or None
        How the window was chosen (None: the whole clip).
    clip : Motion
        The looped frames of the prepared clip.
    closed : ClosedClip
        Their loop.
    """

    window: CycleWindow | None
    clip: Motion
    closed: ClosedClip
    choice: Note | None = None


#: Kind of the note that says which frames loop and why (the first line of the output).
WINDOW_CHOICE = "loop.window"


def loop_window(motion: Motion, options: LoopOptions, close: ClipCloser) -> WindowedLoop:
    """The frames of ``motion`` that ``options.window`` asks for, closed by ``close`` (module
    docstring).

    Raises
    ------
    OptionError
        A window outside the clip or shorter than 3 frames; no candidate window could be
        closed; a bad ``min_length`` (:func:`~.window_candidates.cycle_candidates`).
    """
    if options.window is None:
        return WindowedLoop(
            None, motion, close(motion), Note(WINDOW_CHOICE, "window: the whole clip (as asked)")
        )
    if options.window == "safe":
        return _safe_window(motion, options, close)
    keep = options.contact_mode == "keep"
    windows, cand = _windows(motion, options, close)
    trials, best = _rank(motion, windows, close, keep)
    if best is None:
        raise OptionError("window", f"no candidate window could be closed: {trials}")
    (a, b), closed, sm = best
    clip = _frames(motion, a, b)
    if keep:  # the chosen window, closed with what only it needs (contacts)
        closed = close(clip)
        sm = _change(closed, clip, close)
    window = CycleWindow(
        start=a,
        stop=b,
        fps=motion.fps,
        deviation_max_m=float(sm.deviation_max_m),
        deviation_mean_m=float(sm.deviation_mean_m),
        change=closed.closing.change,
        whole=_whole_clip(motion, trials, close, keep),
        candidates=tuple(trials),
        min_length=cand.min_length if cand is not None else None,
        min_length_default=cand.min_length_default if cand is not None else False,
        quiet_excluded=cand.quiet_excluded if cand is not None else False,
        period=cand.period if cand is not None else None,
    )
    return WindowedLoop(window, clip, closed, Note(WINDOW_CHOICE, _window_text(window, options)))


def _frames_text(w: CycleWindow) -> str:
    """``frames a..b (s-t s)`` of a window."""
    return f"frames {w.start}..{w.stop - 1} ({w.start / w.fps:.2f}-{(w.stop - 1) / w.fps:.2f} s)"


def _window_text(window: CycleWindow, options: LoopOptions) -> str:
    if options.window == "auto":
        return (
            f"window: {_frames_text(window)}, the best cycle (as asked), its loop changes it by "
            f"{window.deviation_max_m:.3g} m"
        )
    return f"window: {_frames_text(window)} (as given)"


def _safe_window(motion: Motion, options: LoopOptions, close: ClipCloser) -> WindowedLoop:
    """``window="safe"``: the whole clip when its loop (the plain projection) changes it by at
    most ``change_bound`` relative to the root, else the best cycle; the note says which and why."""
    keep = options.contact_mode == "keep"
    plain = close(motion, "report") if keep else close(motion)
    whole = _change(plain, motion, close).deviation_relative_max_m
    bound = options.change_bound
    if whole <= bound:
        closed = close(motion) if keep else plain
        text = f"window: the whole clip: its loop changes it by at most {whole:.3g} m, within {bound:g} m"
        return WindowedLoop(None, motion, closed, Note(WINDOW_CHOICE, text, {"whole_change_m": whole}))
    auto = loop_window(motion, options.replace(window="auto"), close)
    w = auto.window
    text = (
        f"window: {_frames_text(w)}, the best cycle: the whole clip's loop would change it by up to "
        f"{whole:.3g} m, more than {bound:g} m (--window whole --force loops the whole clip anyway)"
    )
    data = {"whole_change_m": whole, "start": w.start, "stop": w.stop}
    return WindowedLoop(w, auto.clip, auto.closed, Note(WINDOW_CHOICE, text, data))


def _windows(
    motion: Motion, options: LoopOptions, close: ClipCloser
) -> tuple[list[tuple[int, int]], CycleCandidates | None]:
    """The windows to close exactly: the cheap pass's candidates and the whole clip
    (``"auto"``), or the given one (checked against the clip)."""
    f = motion.n_frames
    if options.window == "auto":
        cand = cycle_candidates(
            motion, root=options.root, closed=close.joints.mask, min_length=options.min_length,
            count=options.candidates,
        )  # fmt: skip
        windows = list(cand.windows)
        if (0, f) not in windows:
            windows.append((0, f))  # the whole clip competes too (and is reported)
        return windows, cand
    a, b = options.window
    if not 0 <= a < b <= f or b - a < 3:
        raise OptionError(
            "window", f"expected 0 <= start < stop <= {f} frames, at least 3 frames; got ({a}, {b})"
        )
    return [(a, b)], None


def _rank(
    motion: Motion, windows: list[tuple[int, int]], close: ClipCloser, keep: bool
) -> tuple[list[dict], Any]:
    """Every window closed (without kept contacts when ``keep``: the plain projection ranks
    them), with its numbers or its error, and the best: converged first, then the least
    change (``((start, stop), closed, seam metrics)``, or None when none closed)."""
    trials, best, best_key = [], None, None
    for a, b in windows:
        sub = _frames(motion, a, b)
        try:
            closed = close(sub, "report") if keep else close(sub)
        except ValueError as exc:  # e.g. a seam at the cut locus: try the next candidate
            trials.append({"start": a, "stop": b, "error": str(exc)})
            continue
        sm = _change(closed, sub, close)
        res = closed.closing
        trials.append(
            {
                "start": a,
                "stop": b,
                "deviation_max_m": sm.deviation_max_m,
                "deviation_mean_m": sm.deviation_mean_m,
                "change_srv_l2": res.change,
                "converged": res.converged,
            }
        )
        key = (not res.converged, sm.deviation_max_m)
        if best is None or key < best_key:
            best, best_key = ((a, b), closed, sm), key
    return trials, best


def _whole_clip(motion: Motion, trials: list[dict], close: ClipCloser, keep: bool) -> dict:
    """The numbers of the whole clip closed, for the report: its trial's (the auto window's
    candidates include it, and so does a given window of every frame), else the whole clip
    closed now (another given window), or its error."""
    f = motion.n_frames
    done = [t for t in trials if (t["start"], t["stop"]) == (0, f)]
    if done:
        return {k: v for k, v in done[0].items() if k not in ("start", "stop", "converged")}
    try:
        closed = close(motion, "report") if keep else close(motion)
        sm = _change(closed, motion, close)
    except ValueError as exc:
        return {"error": str(exc)}
    return {
        "deviation_max_m": sm.deviation_max_m,
        "deviation_mean_m": sm.deviation_mean_m,
        "change_srv_l2": closed.closing.change,
    }


def relative_change(loop: Motion, clip: Motion, root: str, joints: tuple[str, ...]) -> float:
    """The most ``loop`` moves a point of ``joints`` relative to the root against ``clip``
    (in place: the clip on its own treadmill), metres."""
    reference = treadmill(clip)[0] if root == "inplace" else clip
    return seam_metrics(loop, original=reference, root=root, joints=joints).deviation_relative_max_m


def _change(closed: ClosedClip, clip: Motion, close: ClipCloser) -> SeamMetrics:
    """How much the loop changed ``clip`` (module docstring): the seam metrics of the loop
    against the clip, in place against the clip on its own treadmill."""
    root = close.options.root
    reference = treadmill(clip)[0] if root == "inplace" else clip
    return seam_metrics(closed.motion, original=reference, root=root, joints=close.joints.closed)


def _frames(motion: Motion, start: int, stop: int) -> Motion:
    """Frames ``[start, stop)`` of ``motion`` (same fps, unit and skeleton)."""
    jt = motion.joint_translations
    return motion.replace(
        root_translation=motion.root_translation[start:stop],
        rotations=motion.rotations[start:stop],
        joint_translations=jt[start:stop] if jt is not None else None,
    )
