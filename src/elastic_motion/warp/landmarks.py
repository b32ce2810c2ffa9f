"""Feature points (landmarks) of the warp problem: data, validation and penalties.

A landmark pair ``(theta0_m, theta1_m)`` asks the warp to map the parameter ``theta0_m``
of curve 0 onto the parameter ``theta1_m`` of curve 1 (paper 001, Remark 9: the feature
term on the parameter space).  The energy gets ``lam * sum_m FM_m(phi(theta0_m), theta1_m)``
(paper 001, eq. 20-21) and, in the symmetric form (sec. 2.4), also
``lam * sum_m FM_m(phi^{-1}(theta1_m), theta0_m)``.

Penalties ``FM`` (decomposable, Remarks 15-17), as ``penalty=``:

``"squared"`` (default)
    ``(x - target)^2``; smooth, used by the DP and by the gradient refinement.
``"abs"``
    ``|x - target|``.
``"window"``
    0 inside the hard windows ``|x - target| <= d_m``, ``+inf`` outside (needs ``windows``).
callable ``f(x, target) -> penalty``
    Any decomposable, non-negative penalty, vectorised over numpy arrays (``x`` and
    ``target`` broadcast; ``+inf`` allowed).  Calling Python per DP edge would kill the
    speed, so the DP tabulates ``f`` for every landmark on a uniform table of
    ``x in [0, 1]`` (:data:`TABLE_SIZE` points) and interpolates it linearly; the returned
    ``landmark_cost`` re-evaluates ``f`` exactly.  The refinement differentiates ``f``
    by central differences.

Hard windows ``windows=d`` (a scalar or one ``d_m`` per pair) can be combined with any
penalty: ``|phi(theta0_m) - theta1_m| <= d_m`` is then never violated by the DP (edges that
break it cost ``+inf``) nor by the refinement (its line search rejects such steps).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from elastic_motion._validation import as_float_array, check_finite

#: Number of intervals of the table on which a callable penalty is sampled for the DP.
TABLE_SIZE = 4096

Penalty = str | Callable[[np.ndarray, np.ndarray], np.ndarray]

#: Rounding slack (parameter units) when a window is checked on a warp the DP built edge by
#: edge: a window ``d_m = 0`` (an exact hard constraint) is met by an edge through the
#: landmark node up to the rounding of ``phi`` on the linear piece (``1e-12``, far above
#: the 1e-16 of one rounding, far below any window a user means).
WINDOW_SLACK = 1e-12

_KINDS = {"squared": 0, "abs": 1, "window": 2}
#: The named penalties (a callable is the other kind).
PENALTIES = tuple(_KINDS)


@dataclass(frozen=True)
class Landmarks:
    """Feature-point pairs ``(theta0_m, theta1_m)`` in parameter space ``[0, 1]``.

    Parameters
    ----------
    theta0 : array_like, shape (M,)
        Parameters on curve 0 (the domain of ``phi``).
    theta1 : array_like, shape (M,)
        Matching parameters on curve 1 (the range of ``phi``).

    Raises
    ------
    ValueError
        Parameters outside ``[0, 1]``, NaN, mismatched lengths, or two pairs that cross
        (``theta0_a < theta0_b`` but ``theta1_a > theta1_b``, or the same ``theta0`` with two
        ``theta1``): no increasing warp can meet both, the message names the two pairs.
    """

    theta0: np.ndarray
    theta1: np.ndarray

    def __post_init__(self) -> None:
        a = as_float_array(self.theta0, "landmarks.theta0").reshape(-1)
        b = as_float_array(self.theta1, "landmarks.theta1").reshape(-1)
        if a.shape != b.shape:
            raise ValueError(
                f"landmarks: theta0 and theta1 must have the same length; got {a.shape[0]} and {b.shape[0]}"
            )
        for arr, name in ((a, "theta0"), (b, "theta1")):
            check_finite(arr, f"landmarks.{name}")
            bad = np.flatnonzero((arr < 0.0) | (arr > 1.0))
            if bad.size:
                m = int(bad[0])
                raise ValueError(
                    f"landmarks.{name}: parameters must lie in [0, 1]; pair {m} has {name} = {arr[m]!r}"
                )
        _check_order(a, b)
        a.setflags(write=False)
        b.setflags(write=False)
        object.__setattr__(self, "theta0", a)
        object.__setattr__(self, "theta1", b)

    @classmethod
    def from_pairs(cls, pairs: Any) -> Landmarks:
        """Build from an array of pairs of shape ``(M, 2)``: columns theta0, theta1."""
        arr = as_float_array(pairs, "landmarks")
        if arr.ndim != 2 or arr.shape[1] != 2:
            raise ValueError(
                f"landmarks: expected pairs (theta0, theta1) of shape (M, 2); got shape {arr.shape}"
            )
        return cls(arr[:, 0], arr[:, 1])

    def __len__(self) -> int:
        return int(self.theta0.shape[0])

    def swapped(self) -> Landmarks:
        """The same pairs seen from curve 1: ``(theta1_m, theta0_m)``."""
        return Landmarks(self.theta1.copy(), self.theta0.copy())


def _check_order(a: np.ndarray, b: np.ndarray) -> None:
    """Raise if two pairs cannot both be met by a non-decreasing warp."""
    m = a.shape[0]
    if m < 2:
        return
    order = np.lexsort((b, a))
    sa, sb = a[order], b[order]
    # same theta0 with different theta1: phi is a function
    same = np.flatnonzero((np.diff(sa) == 0.0) & (np.diff(sb) != 0.0))
    if same.size:
        i, j = int(order[same[0]]), int(order[same[0] + 1])
        raise ValueError(
            f"landmarks: pairs {i} ({a[i]!r} -> {b[i]!r}) and {j} ({a[j]!r} -> {b[j]!r}) "
            f"map the same theta0 to two theta1: no warp can meet both"
        )
    # crossing: theta0 increases but theta1 decreases
    run_max = np.maximum.accumulate(sb)
    drop = np.flatnonzero(sb[1:] < run_max[:-1])
    if drop.size:
        q = int(drop[0]) + 1
        p = int(np.flatnonzero(sb[:q] > sb[q])[0])
        i, j = int(order[p]), int(order[q])
        raise ValueError(
            f"landmarks: pairs {i} ({a[i]!r} -> {b[i]!r}) and {j} ({a[j]!r} -> {b[j]!r}) "
            f"cross: theta0 increases but theta1 decreases, so no increasing warp can meet both"
        )


def as_landmarks(landmarks: Landmarks | Any | None) -> Landmarks | None:
    """Accept ``None``, a :class:`Landmarks` or pairs of shape ``(M, 2)``."""
    if landmarks is None:
        return None
    if isinstance(landmarks, Landmarks):
        return landmarks
    return Landmarks.from_pairs(landmarks)


@dataclass(frozen=True)
class PenaltySpec:
    """Validated landmark penalty: kind code for the numba kernels, weight, windows."""

    name: str
    kind: int  # 0 squared, 1 abs, 2 none (window only), 3 tabulated callable
    func: Callable[[np.ndarray, np.ndarray], np.ndarray] | None
    lam: float
    windows: np.ndarray  # (M,), +inf where no window

    def values(self, x: np.ndarray, target: np.ndarray) -> np.ndarray:
        """Penalty ``FM(x, target)`` (without ``lam``, without windows), shape of ``x``."""
        r = x - target
        if self.kind == 0:
            return r * r
        if self.kind == 1:
            return np.abs(r)
        if self.kind == 2:
            return np.zeros_like(r)
        assert self.func is not None
        return np.asarray(self.func(x, target), dtype=np.float64) * np.ones_like(r)

    def derivative(self, x: np.ndarray, target: np.ndarray) -> np.ndarray:
        """``d FM / d x`` (central differences for a callable)."""
        r = x - target
        if self.kind == 0:
            return 2.0 * r
        if self.kind == 1:
            return np.sign(r)
        if self.kind == 2:
            return np.zeros_like(r)
        h = 1e-6
        return (self.values(x + h, target) - self.values(x - h, target)) / (2.0 * h)

    def table(self, target: np.ndarray) -> np.ndarray:
        """Tabulated penalty, shape ``(M, TABLE_SIZE + 1)``, for ``pen_kind = 3``."""
        if self.kind != 3:
            return np.zeros((0, 2))
        xs = np.linspace(0.0, 1.0, TABLE_SIZE + 1)
        return np.ascontiguousarray(self.values(xs[None, :], target[:, None]))

    def cost(self, vertices: np.ndarray, landmarks: Landmarks, symmetric: bool) -> float:
        """Exact landmark term ``lam * sum_m FM(phi(theta0_m), theta1_m)`` of the warp with
        vertices ``(K, 2)`` (``+inf`` when a window is violated by more than
        :data:`WINDOW_SLACK`); with ``symmetric`` also ``FM(phi^{-1}(theta1_m), theta0_m)``."""
        x, y = vertices[:, 0], vertices[:, 1]
        fx = np.interp(landmarks.theta0, x, y)
        r = fx - landmarks.theta1
        if (np.abs(r) > self.windows + WINDOW_SLACK).any():
            return float("inf")
        total = float(self.values(fx, landmarks.theta1).sum())
        if symmetric:
            gx = np.interp(landmarks.theta1, y, x)
            r = gx - landmarks.theta0
            if (np.abs(r) > self.windows + WINDOW_SLACK).any():
                return float("inf")
            total += float(self.values(gx, landmarks.theta0).sum())
        return self.lam * total


def make_penalty(penalty: Penalty, lam: float, windows: Any, n_landmarks: int) -> PenaltySpec:
    """Validate ``penalty``, ``lam`` and ``windows`` for ``n_landmarks`` pairs."""
    lam = float(lam)
    if not np.isfinite(lam) or lam < 0.0:
        raise ValueError(f"lam: expected a finite weight >= 0; got {lam!r}")
    if windows is None:
        w = np.full(n_landmarks, np.inf)
    else:
        w = as_float_array(windows, "windows")
        if w.ndim == 0:
            w = np.full(n_landmarks, float(w))
        if w.shape != (n_landmarks,):
            raise ValueError(
                f"windows: expected a scalar or one bound per landmark pair, shape "
                f"({n_landmarks},); got shape {w.shape}"
            )
        if np.isnan(w).any() or (w < 0.0).any():
            raise ValueError(f"windows: expected bounds d_m >= 0; got {w.tolist()}")
    if callable(penalty):
        probe = np.asarray(penalty(np.array([0.0, 0.5, 1.0]), np.array([0.5, 0.5, 0.5])))
        if probe.shape != (3,):
            raise ValueError(
                "penalty: a callable penalty must be vectorised, f(x, target) -> array of the "
                f"broadcast shape; f on 3 points returned shape {probe.shape}"
            )
        if np.isnan(probe).any() or (probe < 0.0).any():
            raise ValueError("penalty: a callable penalty must return values >= 0 (or +inf)")
        return PenaltySpec("callable", 3, penalty, lam, w)
    if penalty not in _KINDS:
        raise ValueError(
            f"penalty: expected 'squared', 'abs', 'window' or a callable f(x, target); got {penalty!r}"
        )
    if penalty == "window" and windows is None:
        raise ValueError("penalty='window' needs the hard bounds: pass windows=d (scalar or (M,))")
    return PenaltySpec(str(penalty), _KINDS[str(penalty)], None, lam, w)


def landmark_cost(
    vertices: np.ndarray,
    landmarks: Landmarks | Any | None,
    *,
    lam: float = 1.0,
    penalty: Penalty = "squared",
    windows: Any = None,
    symmetric: bool = False,
) -> float:
    """Exact landmark term ``lam * sum_m FM(phi(theta0_m), theta1_m)`` of a warp.

    Parameters
    ----------
    vertices : ndarray, shape (K, 2)
        Vertices ``(x_k, phi(x_k))`` of a piecewise linear warp.
    landmarks, lam, penalty, windows, symmetric
        As in :func:`elastic_motion.warp.optimal_warp`.

    Returns
    -------
    float
        The term (``+inf`` if a hard window is violated); with ``symmetric=True`` it also
        holds ``lam * sum_m FM(phi^{-1}(theta1_m), theta0_m)`` (paper 001, sec. 2.4).
    """
    lm = as_landmarks(landmarks)
    if lm is None or len(lm) == 0:
        return 0.0
    spec = make_penalty(penalty, lam, windows, len(lm))
    return spec.cost(np.asarray(vertices, dtype=np.float64), lm, symmetric)
