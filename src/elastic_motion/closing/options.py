"""One options object for every closing solver: what to close, how, and how well.

:class:`ClosingOptions` is passed unchanged to :func:`~elastic_motion.closing.close_curve`
(the flows), :func:`~elastic_motion.closing.project_closed` (the nearest closed curve) and
:func:`~elastic_motion.closing.project_closed_rd` (paper 001's Newton projection in
``R^d``); each also takes its fields as keyword overrides
(``close_curve(curve, tol=1e-9)`` is ``close_curve(curve, ClosingOptions(method="gauss-newton",
tol=1e-9))``). A keyword a solver does not use is an error naming it; the fields of an options
object that a solver does not use are ignored (one object serves every solver, e.g. a loop's).

Options and data
----------------
Options are the knobs a caller sets once for every curve of one group: which coordinates
close (``factors``, the seam velocities with ``c1``), the names of the ``SO(3)`` copies for
error messages, the solver and its tolerances. Data stay arguments of the solvers: the curve,
the extra equality constraints of :func:`~elastic_motion.closing.project_closed` (built from one
curve's own frames, e.g. its foot contacts) and the ``progress`` callback (an observer of one
run, not a setting: an options object stays comparable and printable).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Literal

from elastic_motion._options import choices, with_overrides
from elastic_motion.errors import OptionError

__all__ = [
    "CLOSING_METHODS",
    "DEFAULT_MAX_ITER",
    "DEFAULT_TOL",
    "ClosingMethod",
    "ClosingOptions",
    "solver_options",
]

#: The closing solvers: ``"kkt"`` the closed curve nearest the input in SRV L2
#: (:func:`~elastic_motion.closing.project_closed`), ``"gauss-newton"`` / ``"gradient"`` the
#: flows of :func:`~elastic_motion.closing.close_curve` (closed, nearest to first order),
#: ``"newton"`` paper 001's Newton projection in ``R^d``
#: (:func:`~elastic_motion.closing.project_closed_rd`).
ClosingMethod = Literal["kkt", "gauss-newton", "gradient", "newton"]
CLOSING_METHODS = choices(ClosingMethod)
#: Default feasibility tolerance of each solver (weighted norm of the closing residual; with
#: unit weights radians for rotations).
DEFAULT_TOL = {"kkt": 1e-9, "gauss-newton": 1e-6, "gradient": 1e-6, "newton": 1e-10}
#: Default iteration limit of each solver.
DEFAULT_MAX_ITER = {"kkt": 200, "gauss-newton": 100, "gradient": 100, "newton": 50}
#: The fields each solver reads (the others are ignored; as keywords they are an error).
USED_FIELDS = {
    "kkt": frozenset(
        {"method", "factors", "c1", "c1_weight", "tol", "kkt_tol", "max_iter", "keep_free"}
        | {"cut_locus_tol", "rotation_names", "stall_iterations"}
    ),
    "flows": frozenset(
        {"method", "factors", "c1", "c1_weight", "tol", "max_iter", "keep_free", "cut_locus_tol"}
        | {"rotation_names", "gradient", "log_term", "step", "armijo", "max_backtracks"}
    ),
    "newton": frozenset({"method", "factors", "tol", "max_iter", "keep_free"}),
}

GRADIENTS = ("exact", "paper")
LOG_TERMS = ("general", "bi-invariant")


@dataclass(frozen=True, eq=False)
class ClosingOptions:
    """How to close a curve (compared by identity: ``factors`` may hold arrays).

    Attributes
    ----------
    method : {"kkt", "gauss-newton", "gradient", "newton"}, default "kkt"
        The solver (:data:`ClosingMethod`). Each solver function has its own default
        (``close_curve``: ``"gauss-newton"``; ``project_closed_rd``: ``"newton"``).
    factors : None, array_like or sequence, default None
        What to close (:func:`~elastic_motion.closing.closing_mask`; ``None``: everything).
    c1 : bool, default False
        Also match the seam velocities ``xi_{n-1} = Ad_r xi_0`` (beyond the paper; not for
        ``"newton"``).
    c1_weight : float, default 1
        Weight of the velocity residual (the flows' objective; for ``"kkt"`` the scale of
        the velocity rows, which changes only the conditioning). Positive.
    tol : float or None, default None
        Stop when the closing residual's weighted norm is ``<= tol`` (and the velocity
        mismatch's, with ``c1``); ``None``: the solver's :data:`DEFAULT_TOL` (``kkt`` 1e-9,
        flows 1e-6, ``newton`` 1e-10). Non-negative.
    kkt_tol : float, default 1e-8
        ``"kkt"``: and the relative KKT residual is ``<= kkt_tol``. Non-negative.
    max_iter : int or None, default None
        Iteration limit (accepted steps); ``None``: :data:`DEFAULT_MAX_ITER` (``kkt`` 200,
        flows 100, ``newton`` 50). A non-negative integer.
    keep_free : bool, default True
        Put the original samples back on the free Euclidean coordinates and free ``SO(3)``
        copies of the returned curve (they do not affect the gap).
    cut_locus_tol : float, default 1e-6
        Distance (radians) to ``pi`` at which a closed seam rotation is on log's cut locus.
    rotation_names : tuple of str or None, default None
        One name per ``SO(3)`` copy (e.g. joint names), for error messages.
    stall_iterations : int or None, default None
        ``"kkt"``: give up when the gap has not dropped by 20 % over this many iterations
        (after the first few); the message says the constraints look inconsistent.
    gradient : {"exact", "paper"}, default "exact"
        ``"gradient"`` flow: the exact discrete gradient or paper 000's eq. (17) (``O(h)``).
    log_term : {"general", "bi-invariant"}, default "general"
        ``"gradient"`` flow: Thm. 4.5's ``(dexp^{-1})^†`` or Cor. 4.8's simplification.
    step : float or None, default None
        ``"gradient"`` flow: first trial step of each line search (default: the minimiser of
        the linearised objective along the gradient). Positive.
    armijo : float, default 1e-4
        Flows: sufficient-decrease constant ``c`` in ``Phi(q + a d) <= Phi(q) + c a <grad, d>``,
        in ``(0, 1)``.
    max_backtracks : int, default 40
        Flows: halvings of the step before the line search gives up.
    """

    method: ClosingMethod = "kkt"
    factors: Any = None
    c1: bool = False
    c1_weight: float = 1.0
    tol: float | None = None
    kkt_tol: float = 1e-8
    max_iter: int | None = None
    keep_free: bool = True
    cut_locus_tol: float = 1e-6
    rotation_names: tuple[str, ...] | None = None
    stall_iterations: int | None = None
    gradient: Literal["exact", "paper"] = "exact"
    log_term: Literal["general", "bi-invariant"] = "general"
    step: float | None = None
    armijo: float = 1e-4
    max_backtracks: int = 40

    def __post_init__(self) -> None:
        _check_choice(self.method, CLOSING_METHODS, "method")
        _check_choice(self.gradient, GRADIENTS, "gradient")
        _check_choice(self.log_term, LOG_TERMS, "log_term")
        if self.tol is not None:
            object.__setattr__(self, "tol", _check_number(self.tol, "tol", allow_zero=True))
        _check_number(self.kkt_tol, "kkt_tol", allow_zero=True)
        if self.max_iter is not None:
            _check_count(self.max_iter, "max_iter")
        if self.stall_iterations is not None:
            _check_count(self.stall_iterations, "stall_iterations")
        _check_count(self.max_backtracks, "max_backtracks")
        object.__setattr__(self, "c1_weight", _check_number(self.c1_weight, "c1_weight"))
        cut = _check_number(self.cut_locus_tol, "cut_locus_tol", allow_zero=True)
        object.__setattr__(self, "cut_locus_tol", cut)
        if self.step is not None:
            object.__setattr__(self, "step", _check_number(self.step, "step"))
        if not 0 < self.armijo < 1:
            raise OptionError("armijo", f"expected a constant in (0, 1); got {self.armijo!r}")
        if self.rotation_names is not None:
            if isinstance(self.rotation_names, str):
                raise OptionError(
                    "rotation_names", f"expected one name per SO(3) copy; got {self.rotation_names!r}"
                )
            object.__setattr__(self, "rotation_names", tuple(self.rotation_names))
        object.__setattr__(self, "c1", bool(self.c1))
        object.__setattr__(self, "keep_free", bool(self.keep_free))

    @property
    def tolerance(self) -> float:
        """``tol``, or the default of the method (:data:`DEFAULT_TOL`)."""
        return DEFAULT_TOL[self.method] if self.tol is None else self.tol

    @property
    def iterations(self) -> int:
        """``max_iter``, or the default of the method (:data:`DEFAULT_MAX_ITER`)."""
        return DEFAULT_MAX_ITER[self.method] if self.max_iter is None else self.max_iter

    def replace(self, **changes: Any) -> ClosingOptions:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)


def solver_options(
    solver: str, default_method: str, options: ClosingOptions | None, overrides: dict[str, Any]
) -> ClosingOptions:
    """The options one solver runs with: ``options`` (default: ``default_method``'s) changed by
    ``overrides``, checked against the solver.

    Parameters
    ----------
    solver : {"kkt", "flows", "newton"}
        The solver function (:data:`USED_FIELDS`).
    default_method : str
        ``method`` when ``options`` is None.
    options : ClosingOptions or None
    overrides : dict
        Keyword overrides of the solver call.

    Raises
    ------
    OptionError
        An override that is not a field; a field the solver does not use, given as a keyword;
        a ``method`` the solver does not run.
    """
    base = ClosingOptions(method=default_method) if options is None else options  # type: ignore[arg-type]
    known = {f.name for f in dataclasses.fields(ClosingOptions)}
    unused = sorted((set(overrides) & known) - USED_FIELDS[solver])
    if unused:
        raise OptionError(
            unused[0], f"not an option of this solver ({solver}); it reads {sorted(USED_FIELDS[solver])}"
        )
    opts = with_overrides(ClosingOptions, base, overrides)
    runs = {"kkt": ("kkt",), "flows": ("gauss-newton", "gradient"), "newton": ("newton",)}[solver]
    if opts.method not in runs:
        raise OptionError(
            "method", f"expected one of {', '.join(map(repr, runs))} for this solver; got {opts.method!r}"
        )
    return opts


def _check_choice(value: str, allowed: tuple[str, ...], name: str) -> None:
    if value not in allowed:
        raise OptionError(name, f"expected one of {', '.join(map(repr, allowed))}; got {value!r}")


def _check_number(value: float, name: str, *, allow_zero: bool = False) -> float:
    v = float(value)
    if not math.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        raise OptionError(
            name, f"expected a {'non-negative' if allow_zero else 'positive'} number; got {value!r}"
        )
    return v


def _check_count(value: int, name: str) -> None:
    if int(value) != value or value < 0:
        raise OptionError(name, f"expected a non-negative integer; got {value!r}")
