"""Default values of the options objects, in a module that imports nothing.

The options classes take their field defaults from here (``WarpOptions.neighbourhood`` is
:data:`DEFAULT_MAX_STEP`), and the command line shows the same numbers in ``--help`` without
loading the numerical stack (numpy, numba, scipy): both doors agree, and the parser is built
from this module and :mod:`elastic_motion.vocabulary` alone.
"""

from __future__ import annotations

__all__ = [
    "AUTO_LANDMARK_WEIGHT",
    "CONTACT_HEIGHT_ENTER",
    "CONTACT_SPEED_ENTER",
    "DEFAULT_LANDMARK_WEIGHT",
    "DEFAULT_MAX_STEP",
    "DEFAULT_METHOD",
    "DEFAULT_REFINE_MAX_ITER",
    "DEFAULT_REFINE_TOL",
    "DEFAULT_REFINE_WINDOW",
    "DEFAULT_SAMPLE_FPS",
    "DEFAULT_SAMPLE_SMOOTHING",
    "LOOP_CHANGE_BOUND",
    "LOOP_FREE_JOINTS",
    "LOOP_JOINT_LIMITS",
    "LOOP_MAX_ITER",
    "LOOP_METHOD",
    "LOOP_ROOT",
    "LOOP_SEAM",
    "LOOP_SOLVER",
    "LOOP_TOL",
    "LOOP_WINDOW",
    "MEAN_WARP_METHOD",
    "VIEWER_CONTACTS",
    "VIEWER_LAYOUT",
    "VIEWER_MAX_FPS",
    "VIEWER_MAX_FRAMES",
    "VIEWER_TITLE",
]

# ------------------------------------------------------------------------------------------
# The time warp (elastic_motion.warp.WarpOptions)
# ------------------------------------------------------------------------------------------

#: Default DP neighbourhood: coprime slopes ``(a, b)`` with ``a, b <= 10`` (fdasrsf's 63).
DEFAULT_MAX_STEP = 10
#: Default relative landmark weight (:mod:`elastic_motion.warp.options`: with the squared
#: penalty, missing a landmark by 5 % of the clip costs a quarter of the two curves' squared
#: SRV norms).
DEFAULT_LANDMARK_WEIGHT = 100.0
#: Default frame rate (at most) of the curves a warp between motions is computed on.
DEFAULT_SAMPLE_FPS = 30.0
#: Default low-pass before sampling a motion's curve: Gaussian standard deviation in seconds
#: (1/60 s: half a frame at the default 30 fps, -3 dB at 8 Hz; 0: none). Measured in
#: ``docs/applications.md``, "Smoothing before the SRV".
DEFAULT_SAMPLE_SMOOTHING = 1.0 / 60.0
#: Default solver (of ``WarpSolverOptions`` and ``WarpOptions``): the DP alone has slopes in
#: ``[1/m, m]`` and does not reach the elastic distance when the best warp is steeper or
#: flatter, whatever the grid; the refinement off the grid does (``docs/warp.md``, "Default
#: method").
DEFAULT_METHOD = "dp+refine"
#: The refinement's stopping rule (``WarpSolverOptions.tol``, ``max_iter``;
#: ``warp.refine.RefineOptions``): it stops when the energy decreased by less than
#: ``DEFAULT_REFINE_TOL`` (relative) per iteration over the last ``DEFAULT_REFINE_WINDOW``
#: iterations, or after ``DEFAULT_REFINE_MAX_ITER`` iterations.
DEFAULT_REFINE_TOL = 1e-7
DEFAULT_REFINE_WINDOW = 20
DEFAULT_REFINE_MAX_ITER = 1000
#: The warp method of a Karcher mean and of a database (``apps.statistics.MEAN_WARP``,
#: ``apps.database.DEFAULT_WARP``): the DP alone on the grid, under which each iteration's
#: energy is non-increasing (the previous warp is a path of the next DP; the refinement off
#: the grid gives closer warps but loses that), and the batched DP that keeps the exact
#: search's speed target (with the refinement it was 1.5x brute-force DTW, not 3x: issue 34,
#: ``apps.database.settings.DEFAULT_WARP``).
MEAN_WARP_METHOD = "dp"
#: Relative landmark weight at least used for automatic landmarks
#: (:func:`elastic_motion.apps.align.plan_landmarks`): pairs found by phase around the warp
#: without landmarks are trusted, so the warp meets them closely.
AUTO_LANDMARK_WEIGHT = 1000.0

# ------------------------------------------------------------------------------------------
# Contacts (elastic_motion.motion.contacts.ContactOptions)
# ------------------------------------------------------------------------------------------

#: A joint is planted within this height (metres) of its ground height, and leaves above
#: ``height_exit`` (twice it by default).
CONTACT_HEIGHT_ENTER = 0.03
#: A joint is planted when slower than this (m/s), and leaves above ``speed_exit``.
CONTACT_SPEED_ENTER = 0.4

# ------------------------------------------------------------------------------------------
# Loops (elastic_motion.apps.loop.LoopOptions)
# ------------------------------------------------------------------------------------------

#: ``LoopOptions.root``: the character keeps one cycle's displacement and turn.
LOOP_ROOT = "travel"
#: ``LoopOptions.seam``: C0 unless its seam hitches.
LOOP_SEAM = "auto"
#: ``LoopOptions.method``: the Lie group curve is closed.
LOOP_METHOD = "lie"
#: ``LoopOptions.solver``: the closed curve nearest the input.
LOOP_SOLVER = "kkt"
#: ``LoopOptions.tol``: the seam gap the closing stops at (radians for joint rotations).
LOOP_TOL = 1e-6
#: ``LoopOptions.max_iter``: iterations of the closing solver at most.
LOOP_MAX_ITER = 100
#: ``LoopOptions.free_joints``: the finger and thumb joints are left free.
LOOP_FREE_JOINTS = "fingers"
#: ``LoopOptions.joint_limits``: joint limits are measured, not enforced.
LOOP_JOINT_LIMITS = "report"
#: Which frames a loop closes by default: the whole clip when that changes it by at most
#: :data:`LOOP_CHANGE_BOUND`, else the best cycle (``LoopOptions.window``).
LOOP_WINDOW = "safe"
#: Metres: the most a loop may change its clip (the largest root-relative move of a joint or
#: end site) without ``force``; also what ``window="safe"`` keeps the whole clip within. A
#: walk's or run's cycle closes within 4-12 cm (CMU 07_01, 09_11, 49_08, 55_01 auto windows);
#: clips that do not repeat move by 30-120 cm when closed whole.
LOOP_CHANGE_BOUND = 0.15

# ------------------------------------------------------------------------------------------
# The viewer (elastic_motion.apps.viewer.ViewerOptions)
# ------------------------------------------------------------------------------------------

#: Initial layout of the clips: side by side.
VIEWER_LAYOUT = "side"
#: At most this many frames of a clip are shown (decimated, said on the page).
VIEWER_MAX_FRAMES = 2000
#: At most this many frames per second are shown.
VIEWER_MAX_FPS = 30.0
#: Contacts marked: those the reports give.
VIEWER_CONTACTS = "report"
#: Title of the page.
VIEWER_TITLE = "elastic-motion viewer"
