"""One options object for a loop, passed unchanged through every stage (:class:`LoopOptions`).

:func:`elastic_motion.apps.loop.loop_motion` takes a :class:`LoopOptions` and, for a
notebook's convenience, keyword overrides of its fields (``em.loop(m, root="inplace")``,
:func:`elastic_motion._options.with_overrides`). Every knob is here once, with its unit and
default; the stages read it from this object, never from a re-listed keyword.

The preparation options (``prepare``) are a field too: a loop has one input, and the
preparation step is its first stage, so one object says everything a loop was made with
(``loop_motion(path, LoopOptions(prepare=PrepareOptions(drop_tpose=False), seam="c1"))``).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable
from dataclasses import dataclass, replace
from typing import Any

from elastic_motion import defaults
from elastic_motion.apps.limit_stage import check_limits_option
from elastic_motion.apps.prepare import PrepareOptions
from elastic_motion.errors import OptionError
from elastic_motion.motion.contacts import ContactOptions, ContactPolicy, contact_policy
from elastic_motion.motion.joint_limits import JointLimits
from elastic_motion.motion.looping import RootMode, check_root
from elastic_motion.motion.representations import Method, representation
from elastic_motion.vocabulary import (
    LIMIT_POLICIES,
    SEAMS,
    SOLVERS,
    WINDOW_MODES,
    LimitPolicy,
    Seam,
    Solver,
    WindowMode,
)

__all__ = [
    "LIMIT_POLICIES",
    "SEAMS",
    "SOLVERS",
    "WINDOW_MODES",
    "LimitPolicy",
    "LoopOptions",
    "Seam",
    "Solver",
    "WindowMode",
]

# What closes at the seam (Seam), the closing solvers (Solver), what the loop does with joint
# limits (LimitPolicy) and which frames loop by name (WindowMode; a (start, stop) pair of
# frames is the third way, LoopOptions.window), with their values: elastic_motion.vocabulary.


@dataclass(frozen=True)
class LoopOptions:
    """How to loop a motion (:func:`elastic_motion.apps.loop.loop_motion`).

    Attributes
    ----------
    root : {"travel", "inplace"}, default "travel"
        Loop convention (:mod:`elastic_motion.motion.looping`): keep the floor-plane
        displacement and heading change of one cycle, or close them too.
    seam : {"auto", "c0", "c1"}, default "auto"
        ``"c1"``: also match the velocities at the seam (C1; module
        :mod:`elastic_motion.closing.kkt`, the C1 rows). ``"c0"``: the poses only (paper
        000's closing). ``"auto"``: C0, unless its seam has a hitch (the velocity jump more
        than :data:`~elastic_motion.apps.loop.notes.HITCH_RATIO` times the clip's own quick
        changes); then the same window is closed C1 too and the C1 loop is taken when it is
        smoother and converged, skates at most 1.1 times as fast, changes the clip at most
        1.5 times as much (mean, + 5 mm) and whips no limb the C0 loop did not; a note says
        which seam was taken and why (:mod:`elastic_motion.apps.loop.seam_choice`).
    method : {"lie", "euler-elastic"}, default "lie"
        Close the Lie curve (the method) or the Euler-angle curve (the baseline);
        ``"euler"`` is accepted for ``"euler-elastic"``
        (:func:`elastic_motion.motion.representations.representation`).
    solver : {"kkt", "gauss-newton", "gradient"}, default "kkt"
        ``"kkt"``: the closed curve nearest the input in SRV L2
        (:func:`elastic_motion.closing.project_closed`, to a KKT point; ``tol`` is
        capped at 1e-9). ``"gauss-newton"`` / ``"gradient"``: the closing flows of
        :func:`~elastic_motion.closing.close_curve` (the Euler C0 baseline then uses the
        Newton projection of paper 001, Thm. 2).
    tol : float, default 1e-6
        Stop when the seam gap (weighted norm of the closing residual: radians for joint
        rotations, weighted metres for the root) is below this.
    max_iter : int, default 100
        Iterations of the closing solver at most.
    free_joints : "fingers", None or tuple of str, default "fingers"
        Joints left free (their rotations keep their samples): the finger and thumb joints
        (whose CMU data flips by 180 degrees between frames), none, or the named ones.
    prepare : PrepareOptions or None, default None
        The preparation step (:mod:`elastic_motion.apps.prepare`; None: its defaults). Must
        be None when the input is already prepared (a ``PreparedMotions``).
    joint_weights : tuple of float, shape (J,), or None, default None
        Per-joint weights of the curve's inner product (default: those of
        :func:`elastic_motion.motion.to_lie_curve`); the Euler curve takes the same.
    translation_weight : float or None, default None
        Weight of the root translation, 1 / length^2 (default: as ``joint_weights``).
    window : "safe", None, "auto" or (start, stop), default "safe"
        ``"safe"``: the whole clip when its loop changes it by at most ``change_bound``, else
        the best cycle (``"auto"``); the first note says which and why. ``None``: the whole
        clip (``"whole"`` is accepted for it). ``"auto"``: the window ``[start, stop)`` of
        frames whose loop changes the motion least (:mod:`elastic_motion.apps.loop.window`;
        the whole clip is closed too, for the report). ``(start, stop)``: the given frames
        (at least 3).
    min_length : float or None, default None
        Shortest window for ``"auto"`` (and ``"safe"`` when it looks for one), seconds
        (default: 90 % of the clip's period, or half the clip when it does not repeat).
    candidates : int, default 5
        Windows closed exactly by ``"auto"`` (the best of the cheap pose/velocity match).
    contacts : {"keep", "report", "off"} or None, default None
        None: ``"keep"`` with ``method="lie"`` and ``solver="kkt"``, else ``"report"``
        (:attr:`contact_mode`). ``"keep"``: the input's contacts are constraints of the same
        projection (:mod:`elastic_motion.apps.loop.kept_contacts`; needs ``method="lie"``
        and ``solver="kkt"``); ``"report"``: detect the input's contacts and measure
        skating and depth below the floor of input and loop during them; ``"off"``: skip.
        The names of :func:`elastic_motion.motion.contacts.contact_policy` are accepted.
    contact_options : ContactOptions or None, default None
        Thresholds of contact detection; heights are measured from one floor height
        whatever its ``follow_floor`` (a loop is periodic).
    contact_step : float, default 1/30
        Seconds. With ``contacts="keep"``: a clip whose contacts need more rows than
        :data:`elastic_motion.apps.loop.contact_rows.ROW_BUDGET` is closed on a grid of its
        frames at most this far apart (:func:`~elastic_motion.apps.loop.contact_grid.grid_step`);
        0: every frame always.
    joint_limits : {"report", "keep", "off"}, JointLimits or path, default "report"
        Limits of the joints' DOF angles: those of the ASF file the clip was read from
        (nothing happens when there are none), or the given ones, or those of the given ASF
        file (kept; :func:`elastic_motion.apps.limit_stage.check_limits_option`). ``"keep"``: the loop
        stays within every limit the input respects (:mod:`elastic_motion.apps.loop.limits`;
        needs ``method="lie"`` and ``solver="kkt"``, otherwise reported only, with a note);
        ``"report"``: only measured. ``"keep"`` adds solves with the limits' rows (with kept
        contacts on their grid): 1.5-1.65 times the time of the loop reported only on the CMU
        ASF clips (``benchmarks/loop_limits.py``, issue 33).
    limit_tol : float, default 0.5
        Degrees: beyond a limit means by more than this, at a limit within it (the loop
        between two pinned frames may bulge past the limit by a fraction of a degree).
    change_bound : float, default 0.15
        Metres: the most the loop may move a joint or end site relative to the root
        (:attr:`~elastic_motion.apps.metrics.SeamMetrics.deviation_relative_max_m`) without
        ``force``; ``window="safe"`` keeps the whole clip only within it.
    force : bool, default False
        Keep a loop that changes its clip by more than ``change_bound``, or whose feet skid
        more than the input's (:mod:`elastic_motion.apps.loop.refusal`); without it such a
        loop is refused (:class:`~elastic_motion.apps.loop.refusal.LoopRefused`, with the
        numbers and a window that closes with less change).
    """

    root: RootMode = defaults.LOOP_ROOT
    seam: Seam = defaults.LOOP_SEAM
    method: Method = defaults.LOOP_METHOD
    solver: Solver = defaults.LOOP_SOLVER
    tol: float = defaults.LOOP_TOL
    max_iter: int = defaults.LOOP_MAX_ITER
    free_joints: str | tuple[str, ...] | None = defaults.LOOP_FREE_JOINTS
    prepare: PrepareOptions | None = None
    joint_weights: tuple[float, ...] | None = None
    translation_weight: float | None = None
    window: str | tuple[int, int] | None = defaults.LOOP_WINDOW
    min_length: float | None = None
    candidates: int = 5
    contacts: ContactPolicy | None = None
    contact_options: ContactOptions | None = None
    contact_step: float = 1.0 / 30.0
    joint_limits: LimitPolicy | JointLimits = defaults.LOOP_JOINT_LIMITS
    limit_tol: float = 0.5
    change_bound: float = defaults.LOOP_CHANGE_BOUND
    force: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "method", representation(self.method).name)
        if self.solver not in SOLVERS:
            raise OptionError("solver", f"expected one of {list(SOLVERS)}; got {self.solver!r}")
        self._check_contacts()
        self._check_limits()
        self._check_solver_numbers()
        object.__setattr__(self, "window", _window(self.window))
        self._check_min_length()
        check_root(self.root)
        if not (_finite(self.change_bound) and self.change_bound > 0):
            raise OptionError(
                "change_bound", f"expected a positive number of metres; got {self.change_bound!r}"
            )
        if not isinstance(self.force, bool):
            raise OptionError("force", f"expected True or False; got {self.force!r}")
        if self.seam not in SEAMS:
            raise OptionError("seam", f"expected one of {list(SEAMS)}; got {self.seam!r}")
        object.__setattr__(self, "free_joints", _free_joints(self.free_joints))
        if self.joint_weights is not None:
            object.__setattr__(self, "joint_weights", tuple(float(w) for w in self.joint_weights))
        if self.prepare is not None and not isinstance(self.prepare, PrepareOptions):
            got = type(self.prepare).__name__
            raise OptionError("prepare", f"expected PrepareOptions or None; got {got}")

    def _check_refusal(self) -> None:
        bound = self.change_bound
        if not (_finite(bound) and bound > 0):
            raise OptionError("change_bound", f"expected a positive number of metres; got {bound!r}")
        if not isinstance(self.force, bool):
            raise OptionError("force", f"expected True or False; got {self.force!r}")

    def _check_solver_numbers(self) -> None:
        tol, it, c = self.tol, self.max_iter, self.candidates
        if not (_finite(tol) and tol >= 0):
            raise OptionError("tol", f"expected a non-negative number; got {tol!r}")
        if isinstance(it, bool) or not isinstance(it, numbers.Integral) or it < 0:
            raise OptionError("max_iter", f"expected a non-negative integer; got {it!r}")
        if not (_finite(c) and int(c) == c and c >= 1):
            raise OptionError("candidates", f"expected a positive integer; got {c!r}")
        object.__setattr__(self, "candidates", int(c))
        tw = self.translation_weight
        if tw is not None and not (_finite(tw) and tw > 0):
            raise OptionError("translation_weight", f"expected a positive number or None; got {tw!r}")

    def _check_contacts(self) -> None:
        if self.contacts is not None:
            object.__setattr__(self, "contacts", contact_policy(self.contacts))
        step = self.contact_step
        if not (_finite(step) and step >= 0):
            raise OptionError("contact_step", f"expected a non-negative number of seconds; got {step!r}")
        if self.contacts == "keep" and not self.solves_kkt_on_lie:
            got = f"method={self.method!r}, solver={self.solver!r}"
            raise OptionError("contacts", f"'keep' needs method='lie' and solver='kkt'; got {got}")

    def _check_limits(self) -> None:
        object.__setattr__(self, "joint_limits", check_limits_option(self.joint_limits))
        tol = self.limit_tol
        if not (_finite(tol) and tol >= 0):
            raise OptionError("limit_tol", f"expected a non-negative number of degrees; got {tol!r}")

    def _check_min_length(self) -> None:
        # it bounds the sub-clips the auto window chooses from: silently ignored otherwise
        if self.min_length is not None and self.window not in ("auto", "safe"):
            what = f"window={self.window!r}"
            if self.window is None:
                what = "the whole clip (window=None, --window whole)"
            raise OptionError(
                "min_length", f"expected only with window='auto' (--window auto); got it with {what}"
            )

    @property
    def solves_kkt_on_lie(self) -> bool:
        """Whether the Lie curve is closed by the KKT projection (what kept contacts and kept
        joint limits need: they are rows of that projection)."""
        return representation(self.method).is_lie and self.solver == "kkt"

    @property
    def contact_mode(self) -> ContactPolicy:
        """``contacts``, or its default when None: ``"keep"`` with the Lie curve and the KKT
        solver, else ``"report"``."""
        if self.contacts is not None:
            return self.contacts
        return "keep" if self.solves_kkt_on_lie else "report"

    @property
    def detection(self) -> ContactOptions:
        """The contact options a loop detects contacts with: ``contact_options`` with heights
        from one floor height (a loop is periodic: closing it puts the end at the start's
        height, so a floor that rises under the clip is not the loop's; held above it, CMU
        07_01's whole loop gave way and went 3.8 cm under it)."""
        return replace(self.contact_options or ContactOptions(), follow_floor=False)

    @property
    def is_c1(self) -> bool:
        """Whether the seam is closed C1 (the closing stages run with ``"c0"`` or ``"c1"``;
        ``"auto"`` is resolved before them, by the seam stage)."""
        return self.seam == "c1"

    def replace(self, **changes: Any) -> LoopOptions:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)


def _finite(x: object) -> bool:
    """Whether ``x`` is a finite real number (not a bool)."""
    return isinstance(x, numbers.Real) and not isinstance(x, bool) and math.isfinite(x)


#: The errors of a bad ``window`` and ``free_joints`` (what they accept).
_WINDOW_ERROR = "expected 'safe', 'auto', None or (start, stop) frames; got {!r}"
_FREE_ERROR = "expected 'fingers', None or a list of joint names; got {!r}"


def _window(window: object) -> str | tuple[int, int] | None:
    """``window`` as stored: None (``"whole"`` too), ``"safe"``, ``"auto"`` or ``(start, stop)``."""
    if window is None or (isinstance(window, str) and window == "whole"):
        return None
    if isinstance(window, str):
        if window not in ("auto", "safe"):
            raise OptionError("window", _WINDOW_ERROR.format(window))
        return window
    try:
        start, stop = (int(v) for v in window)  # type: ignore[union-attr]
    except (TypeError, ValueError):
        raise OptionError("window", _WINDOW_ERROR.format(window)) from None
    return start, stop


def _free_joints(free: object) -> str | tuple[str, ...] | None:
    """``free_joints`` as stored: ``"fingers"``, None or a tuple of names (checked against the
    skeleton when the clip is known: :func:`elastic_motion.apps.loop.close.closed_joints`)."""
    if free is None:
        return None
    if isinstance(free, str):
        if free != "fingers":
            raise OptionError("free_joints", _FREE_ERROR.format(free))
        return free
    names = tuple(free) if isinstance(free, Iterable) else None
    if names is None or not all(isinstance(n, str) for n in names):
        raise OptionError("free_joints", _FREE_ERROR.format(free))
    return names
