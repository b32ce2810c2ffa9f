"""What a closing solver returns: :class:`ClosingResult`, filled from a :class:`SolverLog`."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from elastic_motion.curves import DiscreteCurve, SRVFunction

__all__ = ["ClosingResult", "SolverLog"]


@dataclass(frozen=True, eq=False)
class ClosingResult:
    """Outcome of every closing solver (:func:`~elastic_motion.closing.close_curve`,
    :func:`~elastic_motion.closing.project_closed`, :func:`~elastic_motion.closing.project_closed_rd`).

    Attributes
    ----------
    curve : DiscreteCurve
        The closed curve, same grid and first sample as the input.
    srv : SRVFunction
        The SRV function the solver computed (``q`` of shape ``(n, dim)``, orthonormal
        coordinates): every number measured through it equals the solver's. It is not
        re-read from ``curve``: a step of a closed copy that ends past ``pi`` stays as the
        solver took it, and with ``keep_free`` the free coordinates of ``curve`` are the
        original samples while ``srv`` holds the solver's values for them.
    gap, gap_initial : float
        Weighted norm of the closing residual after / before (``sqrt(2 Phi_0)``).
    velocity_gap, velocity_gap_initial : float
        Norm of the seam velocity mismatch ``(xi_{n-1} - Ad_r xi_0) / n`` on the closed
        blocks (computed whether or not ``c1`` was asked for).
    history : ndarray, shape (iterations+1,)
        ``gap`` after each iteration (non-increasing when ``c1=False``).
    velocity_history : ndarray, shape (iterations+1,)
    objective_history : ndarray, shape (iterations+1,)
        The minimised ``Phi`` (strictly decreasing: every accepted step decreases it).
    steps : ndarray, shape (iterations,)
        Accepted line-search step sizes.
    iterations : int
    converged : bool
        Whether the tolerance was reached.
    message : str
    time : float
        Wall-clock seconds spent in the solver.
    method, gradient : str
        The options used.
    rotation_gaps : ndarray, shape (m,)
        Final residual angle (radians, unweighted) of each ``SO(3)`` copy in algebra order
        (0 for free copies; the swing angle for copies closed up to an axis).
    translation_gaps : ndarray, shape (e,)
        Final absolute residual of each Euclidean coordinate (0 for free ones).
    change : float or None
        ``||q - q_orig||_L2`` (``sqrt(sum_i h_i |q_i - q_orig_i|^2)``, orthonormal
        coordinates) between ``srv`` and the input's SRV function.
    kkt_residual : float or None
        For the constrained projection (:func:`elastic_motion.closing.project_closed`):
        the relative first-order optimality residual at the result, else ``None``.
    multipliers : ndarray or None
        Lagrange multipliers of the closing conditions (constrained projection only).
    """

    curve: DiscreteCurve
    srv: SRVFunction
    gap: float
    gap_initial: float
    velocity_gap: float
    velocity_gap_initial: float
    history: np.ndarray
    velocity_history: np.ndarray
    objective_history: np.ndarray
    steps: np.ndarray
    iterations: int
    converged: bool
    message: str
    time: float
    method: str
    gradient: str
    rotation_gaps: np.ndarray
    translation_gaps: np.ndarray
    change: float | None = None
    kkt_residual: float | None = None
    multipliers: np.ndarray | None = None


@dataclass(eq=False)
class SolverLog:
    """The iterations of one closing run, as :class:`ClosingResult` reports them.

    Each list starts with the value before the first iteration; :meth:`record` appends one
    accepted step. ``started`` is the ``time.perf_counter()`` of the call's start.
    """

    gaps: list[float]
    velocity_gaps: list[float]
    objective: Any  # list of float (an ndarray once a solver fills it at the end)
    started: float
    steps: list[float] = field(default_factory=list)
    converged: bool = False
    message: str = ""

    @property
    def iterations(self) -> int:
        """Accepted steps so far."""
        return len(self.steps)

    def record(self, *, step: float, gap: float, velocity_gap: float, objective: float | None) -> None:
        """One accepted step: its size and the gaps (and objective, unless None) after it."""
        self.steps.append(step)
        self.gaps.append(gap)
        self.velocity_gaps.append(velocity_gap)
        if objective is not None:
            self.objective.append(objective)

    def summary(self) -> dict[str, Any]:
        """The fields of :class:`ClosingResult` this log holds (the time measured now)."""
        return {
            "gap": self.gaps[-1],
            "gap_initial": self.gaps[0],
            "velocity_gap": self.velocity_gaps[-1],
            "velocity_gap_initial": self.velocity_gaps[0],
            "history": np.asarray(self.gaps),
            "velocity_history": np.asarray(self.velocity_gaps),
            "objective_history": np.asarray(self.objective),
            "steps": np.asarray(self.steps),
            "iterations": self.iterations,
            "converged": self.converged,
            "message": self.message,
            "time": time.perf_counter() - self.started,
        }
