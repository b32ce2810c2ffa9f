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

import numpy as np

from elastic_motion._options import with_overrides
from elastic_motion._validation import check_parameters
from elastic_motion.defaults import (
    DEFAULT_LANDMARK_WEIGHT,
    DEFAULT_MAX_STEP,
    DEFAULT_METHOD,
    DEFAULT_REFINE_MAX_ITER,
    DEFAULT_REFINE_TOL,
    DEFAULT_SAMPLE_FPS,
    DEFAULT_SAMPLE_SMOOTHING,
)
from elastic_motion.errors import OptionError
from elastic_motion.vocabulary import WARP_METHODS, WarpMethod
from elastic_motion.warp.dp import as_steps
from elastic_motion.warp.landmarks import PENALTIES, Penalty

__all__ = [
    "DEFAULT_LANDMARK_WEIGHT",
    "DEFAULT_MAX_STEP",
    "DEFAULT_SAMPLE_FPS",
    "DEFAULT_SAMPLE_SMOOTHING",
    "SOLVER_METHODS",
    "WARP_METHODS",
    "SolverMethod",
    "WarpMethod",
    "WarpOptions",
    "WarpSolverOptions",
    "solver_options",
]

# The defaults (DEFAULT_MAX_STEP, DEFAULT_LANDMARK_WEIGHT, DEFAULT_SAMPLE_FPS,
# DEFAULT_SAMPLE_SMOOTHING, DEFAULT_METHOD) live in elastic_motion.defaults and the warp methods
# (WarpMethod, WARP_METHODS: none, dp, dp+refine) in elastic_motion.vocabulary, where the
# command line reads them without loading numpy; they are re-exported here.

#: Solvers of :func:`elastic_motion.warp.optimal_warp`: dynamic programming, DP then gradient
#: refinement off the grid, refinement alone from the identity (a local method).
SolverMethod = Literal["dp", "dp+refine", "refine"]
SOLVER_METHODS = ("dp", "dp+refine", "refine")


@dataclass(frozen=True)
class WarpOptions:
    """How to find the optimal time warp.

    Attributes
    ----------
    method : {"dp+refine", "dp", "none"}, default "dp+refine"
        ``"dp"``: dynamic programming, exact on its grid but with slopes in ``[1/10, 10]``;
        ``"dp+refine"``: then gradient refinement off the grid (never increases the energy;
        the default, as it reaches the elastic distance when the best warp is steeper or
        flatter than the DP's slopes: ``docs/warp.md``, "Default method"); it stops when the
        energy decreased by less than ``1e-7`` (relative) per iteration over the last 20
        iterations, or after 1000 (:class:`WarpSolverOptions` ``tol``, ``max_iter``), and costs
        1 to 3 times the DP alone (``benchmarks/warp.py``); ``"none"``: the identity
        (distances of parametrised curves).
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

    method: WarpMethod = DEFAULT_METHOD
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

    def solver_options(self) -> WarpSolverOptions:
        """The :class:`WarpSolverOptions` this object fills (``method``, ``neighbourhood``,
        ``coarse_to_fine``; not for ``"none"``)."""
        return WarpSolverOptions(**self.solver_kwargs())

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


@dataclass(frozen=True, eq=False)
class WarpSolverOptions:
    """How :func:`elastic_motion.warp.optimal_warp` finds a warp between two SRV arrays, and
    how its feature term weighs the landmark pairs (compared by identity: some fields may hold
    arrays or a callable).

    The data of a call are the two SRV arrays, their grids and the landmark pairs; everything
    else is here. The weight, the penalty, the windows and the symmetric form of the feature
    term are options, not data: they are chosen once for a batch of pairs (the app-level
    :class:`WarpOptions` holds the relative ``landmark_weight`` the same way) and say how the
    pairs are penalised, not which pairs there are. ``closed`` is one too: it says what the
    curves are for every pair of a batch (the seed becomes a variable).

    Attributes
    ----------
    method : {"dp+refine", "dp", "refine"}, default "dp+refine"
        ``"dp"``: dynamic programming, exact on its grid, slopes in ``[1/m, m]``.
        ``"dp+refine"``: then gradient refinement off the grid (never increases the energy);
        it reaches the elastic distance as the grid is refined also when the best warp is
        steeper or flatter than the DP's slopes (``docs/warp.md``, "Default method").
        ``"refine"``: gradient refinement started from the identity (a local method).
    neighbourhood : int or array_like of shape (K, 2), default 10
        Slopes of the DP edges: an int ``m`` gives all coprime ``(a, b)`` with
        ``1 <= a, b <= m`` (default 10: the 63 slopes of fdasrsf's DP); or explicit
        ``(domain step, range step)`` pairs in grid nodes.
    grid : (array_like, array_like) or None, default None
        DP nodes ``(u, v)`` on the domain and the range (each from 0 to 1). Default: the
        break points ``t0`` and ``t1``, on which the DP is exact. Not with ``closed`` nor
        ``coarse_to_fine``.
    coarse_to_fine : bool, default False
        Banded DP for long curves: solve on merged cells (down to 100-200 cells), then only in
        a band of ``band`` range nodes around the upsampled warp. Faster, not exact.
    band : int or None, default None
        Half-width of the band (range nodes, >= 1; default ``2 * max step``).
    closed : bool, default False
        Closed curves: also optimise the seed, a cyclic shift of q1's start by whole cells,
        coarse to fine (``seed_shift`` of :class:`~elastic_motion.warp.WarpResult`). The
        energy stays the open-curve (``L^2``) one; paper 001's closed-curve energy is
        :func:`elastic_motion.closed_curves.match_closed`.
    seeds : {"both", "q1"}, default "both"
        Closed curves: ``"both"`` searches seeds on the break points of both curves (q1
        against q0, and q0 against q1 turned into a seed and warp of q1 exactly by
        :func:`~elastic_motion.warp.swap_closed_match`) and keeps the lower objective, so that
        swapping the curves gives the same energy up to the grid; ``"q1"``: only on q1's.
    tol : float, default 1e-7
        Refinement: stop when the energy decreased by less than ``tol`` (relative) per
        iteration, averaged over the last 20 iterations
        (``E[k - 20] - E[k] < 20 tol |E[k]|``). Non-negative.
    max_iter : int, default 1000
        Refinement: maximal number of iterations.
    lam : float, default 1
        Absolute weight of the landmark term (>= 0; :meth:`WarpOptions.absolute_landmark_weight`
        converts the relative one).
    penalty : {"squared", "abs", "window"} or callable, default "squared"
        Decomposable penalty ``FM(x, target)`` (:mod:`elastic_motion.warp.landmarks`).
    windows : float or array_like of shape (M,), optional
        Hard windows ``|phi(theta0_m) - theta1_m| <= d_m`` (never violated; checked against the
        pairs at the call).
    symmetric : bool, default False
        Symmetric feature term (paper 001, sec. 2.4): also ``FM(phi^{-1}(theta1_m), theta0_m)``.
    """

    method: SolverMethod = DEFAULT_METHOD
    neighbourhood: Any = DEFAULT_MAX_STEP
    grid: tuple[Any, Any] | None = None
    coarse_to_fine: bool = False
    band: int | None = None
    closed: bool = False
    seeds: Literal["both", "q1"] = "both"
    tol: float = DEFAULT_REFINE_TOL
    max_iter: int = DEFAULT_REFINE_MAX_ITER
    lam: float = 1.0
    penalty: Penalty = "squared"
    windows: Any = None
    symmetric: bool = False

    def __post_init__(self) -> None:
        # None is "the default" (keyword calls of optimal_warp passed None for it)
        if self.method is None:
            object.__setattr__(self, "method", DEFAULT_METHOD)
        if self.neighbourhood is None:
            object.__setattr__(self, "neighbourhood", DEFAULT_MAX_STEP)
        object.__setattr__(self, "coarse_to_fine", bool(self.coarse_to_fine))
        object.__setattr__(self, "closed", bool(self.closed))
        object.__setattr__(self, "symmetric", bool(self.symmetric))
        if self.method not in SOLVER_METHODS:
            raise OptionError("method", f"expected 'dp', 'dp+refine' or 'refine'; got {self.method!r}")
        as_steps(self.neighbourhood)  # raises naming the neighbourhood
        if self.grid is not None:
            object.__setattr__(self, "grid", _check_grid(self.grid))
        if self.closed and self.grid is not None:
            raise OptionError("grid", "a custom DP grid is not supported with closed=True")
        if self.coarse_to_fine and self.grid is not None:
            raise OptionError("coarse_to_fine", "needs the default grid (grid=None)")
        if self.band is not None and int(self.band) < 1:
            raise OptionError("band", f"expected a half-width >= 1; got {self.band!r}")
        if not (np.isfinite(self.tol) and self.tol >= 0):
            raise OptionError("tol", f"expected a relative tolerance >= 0; got {self.tol!r}")
        if isinstance(self.max_iter, bool) or int(self.max_iter) != self.max_iter or self.max_iter < 0:
            raise OptionError("max_iter", f"expected a non-negative integer; got {self.max_iter!r}")
        if self.seeds not in ("both", "q1"):
            raise OptionError("seeds", f"expected 'both' or 'q1'; got {self.seeds!r}")
        lam = float(self.lam)
        if not np.isfinite(lam) or lam < 0.0:
            raise OptionError("lam", f"expected a finite weight >= 0; got {lam!r}")
        if not callable(self.penalty) and self.penalty not in PENALTIES:
            raise OptionError(
                "penalty",
                f"expected 'squared', 'abs', 'window' or a callable f(x, target); got {self.penalty!r}",
            )

    def band_width(self, max_step: int) -> int:
        """The band's half-width: ``band``, or ``2 * max_step``."""
        return 2 * max_step if self.band is None else int(self.band)

    def replace(self, **changes: Any) -> WarpSolverOptions:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)


def solver_options(
    options: WarpSolverOptions | WarpOptions | None, overrides: dict[str, Any]
) -> WarpSolverOptions:
    """The options :func:`elastic_motion.warp.optimal_warp` runs with.

    ``options`` may be a :class:`WarpSolverOptions` (changed by ``overrides``, the rule of
    :func:`elastic_motion._options.with_overrides`) or the app-level :class:`WarpOptions`, which
    fills ``method``, ``neighbourhood`` and ``coarse_to_fine``: a keyword that *disagrees* with
    one of those is an error (no silent precedence between two ways of saying one thing), one
    that agrees is accepted; ``method="none"`` is an error (the identity needs no solver).
    A keyword given as None means its default.
    """
    if isinstance(options, WarpOptions):
        if options.method == "none":
            raise OptionError(
                "options", "method 'none' has no solver (the identity warp needs no optimal_warp)"
            )
        filled = options.solver_kwargs()
        given = {k: v for k, v in overrides.items() if not (k in filled and v is None)}
        for key, value in filled.items():
            if key in given and not _same(key, given[key], value):
                raise OptionError(
                    key,
                    f"{given[key]!r} given both explicitly and as options.{key} = {value!r}; "
                    "pass one of them",
                )
        return with_overrides(WarpSolverOptions, WarpSolverOptions(**filled), given)
    if options is not None and not isinstance(options, WarpSolverOptions):
        raise OptionError(
            "options", f"expected a WarpOptions, a WarpSolverOptions or None; got {type(options).__name__}"
        )
    return with_overrides(WarpSolverOptions, options, overrides)


def _same(key: str, given: Any, value: Any) -> bool:
    if key == "neighbourhood":
        return bool(np.array_equal(np.asarray(given), np.asarray(value)))
    return bool(given == value)


def _check_grid(grid: Any) -> tuple[np.ndarray, np.ndarray]:
    try:
        gu, gv = grid
    except (TypeError, ValueError) as exc:
        raise OptionError("grid", "expected a pair (domain nodes, range nodes)") from exc
    return check_parameters(gu, "grid[0]"), check_parameters(gv, "grid[1]")
