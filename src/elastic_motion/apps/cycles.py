"""Gait cycles from the contacts, and matching the cycles of two motions.

Conventions
-----------
* A **gait cycle** (:func:`gait_cycles`) runs from one heel strike of a foot to its next:
  the strikes are the starts of the contacts of that foot's ankle joint
  (:func:`elastic_motion.apps.landmarks.contact_events`, contacts from
  :func:`elastic_motion.motion.contacts.detect_contacts`). The foot is the one with more
  strikes (the left one on a tie). The parts before the first and after the last strike
  are not cycles. Times are seconds from the first frame.
* **Matching** (:func:`match_cycles`): ``n_A`` cycles against ``n_B``. The matched cycles are
  two runs of ``n = min(n_A, n_B)`` consecutive cycles, one in each motion (a warp is
  increasing: it cannot reorder or interleave cycles); of all the windows of the longer
  run, the one whose cycle durations are most alike and most typical of each clip (least
  ``sum_i |log(dA_i / dB_i)| + |log(dA_i / med dA)| + |log(dB_i / med dB)|``, ``med``: the
  clip's median cycle duration, which keeps starts and stops out; the earliest on a tie).
  So 4 steps against 6 (2 cycles against 3) become cycles 1-2 of A against the two most
  alike consecutive cycles of B.
* Within matched cycles the warp passes through every cycle boundary and every strike of
  the other foot (landmarks: "steps matched one by one"), see
  :func:`elastic_motion.apps.blend.blend_motions` (``cycles=True``: :mod:`elastic_motion.apps.blend.inputs`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from elastic_motion.apps.landmarks import contact_events
from elastic_motion.motion import Motion
from elastic_motion.motion.contacts import ContactOptions

__all__ = ["CycleMatch", "GaitCycles", "gait_cycles", "match_cycles"]


@dataclass(frozen=True)
class GaitCycles:
    """Gait cycles of a motion (:func:`gait_cycles`).

    Attributes
    ----------
    foot : str
        ``"left"`` or ``"right"``: whose heel strikes bound the cycles (``""`` when none).
    strikes : tuple of float
        Heel strikes of that foot (s); ``len(strikes) - 1`` cycles.
    other_strikes : tuple of float
        Heel strikes of the other foot (s).
    duration : float
        The clip's duration (s).
    """

    foot: str
    strikes: tuple[float, ...]
    other_strikes: tuple[float, ...]
    duration: float

    @property
    def n_cycles(self) -> int:
        return max(len(self.strikes) - 1, 0)

    def cycle(self, i: int) -> tuple[float, float]:
        """Start and end (s) of cycle ``i``."""
        return self.strikes[i], self.strikes[i + 1]

    def summary(self) -> dict[str, Any]:
        """JSON-ready."""
        return {
            "foot": self.foot,
            "cycles": self.n_cycles,
            "strikes_s": list(self.strikes),
            "cycle_durations_s": np.diff(self.strikes).tolist() if self.n_cycles else [],
            "other_foot_strikes_s": list(self.other_strikes),
        }


def gait_cycles(
    motion: Motion, options: ContactOptions | None = None, *, foot: str | None = None
) -> GaitCycles:
    """Segment a motion's gait cycles from its contacts (module docstring).

    Parameters
    ----------
    motion : Motion
        Prepared (metres, Y-up) or with thresholds in ``options`` suited to its unit.
    options : ContactOptions, optional
    foot : {"left", "right"}, optional
        Whose strikes bound the cycles (default: the foot with more strikes).

    Returns
    -------
    GaitCycles
        With no cycle (``foot=""``) when neither foot strikes twice.
    """
    ev = contact_events(motion, options=options)
    left = tuple(e.time for e in ev if e.kind == "left_heel_strike")
    right = tuple(e.time for e in ev if e.kind == "right_heel_strike")
    if foot == "left":
        return (
            GaitCycles("left", left, right, motion.duration)
            if len(left) >= 2
            else GaitCycles("", (), (), motion.duration)
        )
    if foot == "right":
        return (
            GaitCycles("right", right, left, motion.duration)
            if len(right) >= 2
            else GaitCycles("", (), (), motion.duration)
        )
    if max(len(left), len(right)) < 2:
        return GaitCycles("", (), (), motion.duration)
    if len(right) > len(left):
        return GaitCycles("right", right, left, motion.duration)
    return GaitCycles("left", left, right, motion.duration)


@dataclass(frozen=True)
class CycleMatch:
    """Matched cycles of two motions (:func:`match_cycles`).

    Attributes
    ----------
    cycles_a, cycles_b : GaitCycles
    first_a, first_b : int
        Index of the first matched cycle in each.
    n : int
        Number of matched cycles (0: no match).
    landmarks : tuple of (float, float)
        Pairs ``(tA, tB)`` (s): inner cycle boundaries and the other foot's strikes, relative
        to the start of the matched span in each motion.
    span_a, span_b : (float, float)
        The matched spans (s) in each motion.
    why : str
        How they were matched, in words (or why not).
    """

    cycles_a: GaitCycles
    cycles_b: GaitCycles
    first_a: int
    first_b: int
    n: int
    landmarks: tuple[tuple[float, float], ...]
    span_a: tuple[float, float]
    span_b: tuple[float, float]
    why: str

    def summary(self) -> dict[str, Any]:
        """JSON-ready."""
        return {
            "matched_cycles": self.n,
            "cycles_a": self.cycles_a.summary(),
            "cycles_b": self.cycles_b.summary(),
            "first_a": self.first_a,
            "first_b": self.first_b,
            "span_a_s": list(self.span_a),
            "span_b_s": list(self.span_b),
            "landmarks_s": [list(p) for p in self.landmarks],
            "why": self.why,
        }


def _other_in(strikes: tuple[float, ...], start: float, stop: float) -> float | None:
    inside = [t for t in strikes if start < t < stop]
    return inside[0] if inside else None


def match_cycles(cycles_a: GaitCycles, cycles_b: GaitCycles, *, max_cycles: int | None = None) -> CycleMatch:
    """Match consecutive cycles of A and B (module docstring).

    Parameters
    ----------
    cycles_a, cycles_b : GaitCycles
    max_cycles : int, optional
        At most this many matched cycles (the first of the best window; ``1`` for a loop).

    Returns
    -------
    CycleMatch
        ``n = 0`` (and ``why`` saying so) when a motion has no cycle or the cycles are bounded
        by different feet on one side only.
    """
    na, nb = cycles_a.n_cycles, cycles_b.n_cycles
    if na == 0 or nb == 0:
        who = [lab for lab, n in (("A", na), ("B", nb)) if n == 0]
        return CycleMatch(
            cycles_a, cycles_b, 0, 0, 0, (), (0.0, 0.0), (0.0, 0.0),
            f"no gait cycle in {' and '.join(who)} (a foot must strike twice): fall back to the global warp",
        )  # fmt: skip
    da = np.diff(cycles_a.strikes)
    db = np.diff(cycles_b.strikes)
    n = min(na, nb)
    if max_cycles is not None:
        n = max(1, min(n, int(max_cycles)))
    best = None
    for ia in range(na - n + 1):
        for ib in range(nb - n + 1):
            wa, wb = da[ia : ia + n], db[ib : ib + n]
            cost = float(
                np.abs(np.log(wa / wb)).sum()
                + np.abs(np.log(wa / np.median(da))).sum()
                + np.abs(np.log(wb / np.median(db))).sum()
            )
            if best is None or cost < best[0] - 1e-12:
                best = (cost, ia, ib)
    assert best is not None
    cost, ia, ib = best
    a0, a1 = cycles_a.strikes[ia], cycles_a.strikes[ia + n]
    b0, b1 = cycles_b.strikes[ib], cycles_b.strikes[ib + n]
    lms: list[tuple[float, float]] = []
    for i in range(n):
        sa, ea = cycles_a.cycle(ia + i)
        sb, eb = cycles_b.cycle(ib + i)
        if i > 0:
            lms.append((sa - a0, sb - b0))
        oa = _other_in(cycles_a.other_strikes, sa, ea)
        ob = _other_in(cycles_b.other_strikes, sb, eb)
        if oa is not None and ob is not None:
            lms.append((oa - a0, ob - b0))
    why = (
        f"{na} cycles of A ({cycles_a.foot} heel strikes) against {nb} of B ({cycles_b.foot}): "
        f"A's cycles {ia + 1}-{ia + n} matched to B's cycles {ib + 1}-{ib + n}, the consecutive cycles "
        f"with the most alike and typical durations (cost {cost:.3f}); the warp passes through "
        f"{len(lms)} inner cycle boundaries and other-foot strikes"
    )
    return CycleMatch(cycles_a, cycles_b, ia, ib, n, tuple(lms), (a0, a1), (b0, b1), why)
