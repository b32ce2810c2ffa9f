"""One options object for the time warp, passed unchanged through every layer.

:class:`WarpOptions` says *how* a warp is found: the solver (``method``), the DP slopes
(``neighbourhood``), the banded coarse-to-fine DP, the frame rate of the curves the warp is
computed on (``sample_fps``), the Gaussian low-pass applied to a motion before it is sampled
at that rate (``sample_smoothing``) and the *relative* landmark weight (``landmark_weight``). The
warp layer itself (:func:`elastic_motion.warp.optimal_warp`) takes an *absolute* landmark
weight ``lam``; :meth:`WarpOptions.absolute_landmark_weight` is the one conversion between
the two, so the two numbers never share a name.

Relative landmark weight
------------------------
The feature term of the warp energy is ``lam * sum_m FM(phi(theta0_m), theta1_m)`` (paper
001, eq. 21) with ``lam = landmark_weight * (||q0||^2 + ||q1||^2)``: with the squared
penalty and the default 100, missing a landmark by 5 % of the clip costs a quarter of the
two curves' squared SRV norms, enough to pull the warp onto the landmarks, whatever the
representation and the clip length.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any, Literal

from elastic_motion.errors import OptionError

__all__ = [
    "DEFAULT_LANDMARK_WEIGHT",
    "DEFAULT_MAX_STEP",
    "DEFAULT_SAMPLE_FPS",
    "DEFAULT_SAMPLE_SMOOTHING",
    "WARP_METHODS",
    "WarpOptions",
]

#: Default DP neighbourhood: coprime slopes ``(a, b)`` with ``a, b <= 10`` (fdasrsf's 63).
DEFAULT_MAX_STEP = 10
#: Default relative landmark weight (module docstring).
DEFAULT_LANDMARK_WEIGHT = 100.0
#: Default frame rate (at most) of the curves a warp between motions is computed on.
DEFAULT_SAMPLE_FPS = 30.0
#: Default low-pass before sampling a motion's curve: Gaussian standard deviation in seconds
#: (1/60 s: half a frame at the default 30 fps, -3 dB at 8 Hz; 0: none). Measured in
#: ``docs/applications.md``, "Smoothing before the SRV".
DEFAULT_SAMPLE_SMOOTHING = 1.0 / 60.0
#: Warp methods: none (identity), dynamic programming, DP then gradient refinement off the grid.
WARP_METHODS = ("none", "dp", "dp+refine")

WarpMethod = Literal["none", "dp", "dp+refine"]


@dataclass(frozen=True)
class WarpOptions:
    """How to find the optimal time warp.

    Attributes
    ----------
    method : {"dp+refine", "dp", "none"}, default "dp+refine"
        ``"dp"``: dynamic programming, exact on its grid but with slopes in ``[1/10, 10]``;
        ``"dp+refine"``: then gradient refinement off the grid (never increases the energy;
        the default, as it reaches the elastic distance when the best warp is steeper or
        flatter than the DP's slopes: ``docs/warp.md``, "Default method"); ``"none"``: the
        identity (distances of parametrised curves).
    neighbourhood : int, default 10
        DP slopes: all coprime ``(a, b)`` with ``1 <= a, b <= neighbourhood``.
    coarse_to_fine : bool, default False
        Banded coarse-to-fine DP (faster on long curves, may miss the optimum by a little:
        ``docs/warp.md``).
    sample_fps : float, default 30
        Motions are resampled to at most this many frames per second before the warp is
        computed (a warp is a function on ``[0, 1]``; the DP cost grows with the square of
        the frame count). Ignored by the curve-level solver.
    sample_smoothing : float, default 1/60
        Gaussian low-pass of a motion in time before its curve is sampled at
        ``sample_fps`` (:func:`elastic_motion.motion.edit.smooth_motion`), standard deviation
        in seconds (0: none). The default is half a frame at the default 30 fps (the usual
        anti-aliasing choice, -3 dB at 8 Hz); fixed in seconds, not in frames, so the
        distance does not grow with ``sample_fps`` (``docs/applications.md``, "Smoothing
        before the SRV"). Below 30 fps it is less than half a sampled frame: set it to
        ``0.5 / sample_fps`` there. Ignored by the curve-level solver.
    landmark_weight : float, default 100
        Relative weight of the landmark term (module docstring); must be >= 0.
    """

    method: WarpMethod = "dp+refine"
    neighbourhood: int = DEFAULT_MAX_STEP
    coarse_to_fine: bool = False
    sample_fps: float = DEFAULT_SAMPLE_FPS
    landmark_weight: float = DEFAULT_LANDMARK_WEIGHT
    sample_smoothing: float = DEFAULT_SAMPLE_SMOOTHING

    def __post_init__(self) -> None:
        if self.method not in WARP_METHODS:
            raise OptionError("warp", f"expected one of {list(WARP_METHODS)}; got {self.method!r}")
        n = self.neighbourhood
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise OptionError("neighbourhood", f"expected an integer >= 1 (the largest DP step); got {n!r}")
        fps = self.sample_fps
        if not (isinstance(fps, int | float) and math.isfinite(fps) and fps > 0):
            raise OptionError("sample_fps", f"expected a positive finite frame rate; got {fps!r}")
        lw = self.landmark_weight
        if not (isinstance(lw, int | float) and math.isfinite(lw) and lw >= 0):
            raise OptionError("landmark_weight", f"expected a finite weight >= 0; got {lw!r}")
        sm = self.sample_smoothing
        if isinstance(sm, bool) or not (isinstance(sm, int | float) and math.isfinite(sm) and sm >= 0):
            raise OptionError(
                "sample_smoothing", f"expected a finite standard deviation >= 0 in seconds; got {sm!r}"
            )
        object.__setattr__(self, "sample_smoothing", float(sm))
        object.__setattr__(self, "coarse_to_fine", bool(self.coarse_to_fine))
        object.__setattr__(self, "sample_fps", float(fps))
        object.__setattr__(self, "landmark_weight", float(lw))

    def absolute_landmark_weight(self, norm0_sq: float, norm1_sq: float) -> float:
        """The solver's ``lam`` for SRV functions of squared norms ``norm0_sq``, ``norm1_sq``."""
        return self.landmark_weight * (float(norm0_sq) + float(norm1_sq))

    def solver_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of :func:`elastic_motion.warp.optimal_warp` (not for ``"none"``)."""
        if self.method == "none":
            raise OptionError("warp", "'none' has no solver; use the identity warp")
        return {
            "method": self.method,
            "neighbourhood": self.neighbourhood,
            "coarse_to_fine": self.coarse_to_fine,
        }

    def replace(self, **changes: Any) -> WarpOptions:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    def to_json(self) -> dict[str, Any]:
        """The fields as a JSON-ready dict."""
        return asdict(self)

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> WarpOptions:
        """Inverse of :meth:`to_json`; unknown keys are an error naming them."""
        known = set(cls.__dataclass_fields__)
        bad = sorted(set(data) - known)
        if bad:
            raise OptionError("warp options", f"unknown fields {bad}; expected some of {sorted(known)}")
        return cls(**data)
