"""Seamless loops of motions (paper 000, sec. 5.4) with the loop convention of game engines.

A loop is a pipeline of stages, each a function in a module named for its job, with one
options object (:class:`LoopOptions`) passed down:

1. **prepare** (:func:`elastic_motion.apps.prepare.prepare_motions`): T-pose frame, trim,
   static root folded, metres, Y-up, so a path and a ``Motion`` give the same loop as the
   command line;
2. **window** (:mod:`.window`, :mod:`.window_candidates`): the whole clip, given frames, or
   the best cycle;
3. **close** (:mod:`.close`): the clip's curve projected onto the closed curves (the loop
   convention of :mod:`elastic_motion.motion.looping`), with its contacts kept when asked
   (:mod:`.kept_contacts`, :mod:`.contact_rows`, :mod:`.contact_grid`, :mod:`.planting`)
   and its joint limits (:mod:`.limits`);
4. **seam metrics** (:mod:`.measure`): the seam before and after, skating during contacts;
5. **policy notes** (:mod:`.notes`): what a user should know, as :class:`~elastic_motion.notes.Note`
   (the first says which frames loop and why);
6. **result** (:class:`LoopResult`); with ``seam="auto"`` the seam stage
   (:mod:`.seam_choice`) closes C1 too when the C0 seam hitches, and takes the better;
7. **refusal** (:mod:`.refusal`): a loop that changes its clip by more than ``change_bound``
   or adds skids is an error unless ``force``.

Units of the metrics: angles in degrees, positions in metres when the motion's
``metres_per_unit`` is known (else in its length unit), times in seconds.
"""

from __future__ import annotations

from typing import Any

from elastic_motion._options import with_overrides
from elastic_motion.apps.loop.close import ClipCloser, closed_joints
from elastic_motion.apps.loop.kept_contacts import KeptContacts
from elastic_motion.apps.loop.limits import LoopLimits, joint_limit_report, limits_plan
from elastic_motion.apps.loop.measure import measure_loop
from elastic_motion.apps.loop.notes import policy_notes, prepare_notes
from elastic_motion.apps.loop.options import LoopOptions, Seam, Solver
from elastic_motion.apps.loop.refusal import LoopRefused, check_loop
from elastic_motion.apps.loop.result import LoopResult
from elastic_motion.apps.loop.seam_choice import c1_options, choose_seam, hitches
from elastic_motion.apps.loop.window import CycleWindow, loop_window
from elastic_motion.apps.prepare import PreparedMotions, Source, output_motion, prepare_motions
from elastic_motion.apps.progress import Progress
from elastic_motion.errors import OptionError
from elastic_motion.motion import Motion
from elastic_motion.motion.looping import check_loop_motion, repeat_motion

__all__ = [
    "CycleWindow",
    "KeptContacts",
    "LoopLimits",
    "LoopOptions",
    "LoopRefused",
    "LoopResult",
    "Seam",
    "Solver",
    "joint_limit_report",
    "loop_motion",
    "loop_prepared",
    "repeat_loop",
]


def loop_motion(
    motion: Source | PreparedMotions,
    options: LoopOptions | None = None,
    *,
    progress: Progress | None = None,
    **overrides: Any,
) -> LoopResult:
    """Make a motion loop seamlessly by closing its curve (paper 000, sec. 4 and 5.4).

    Parameters
    ----------
    motion : path or Motion, or PreparedMotions of one input
        At least 3 frames after preparation, finite.
    options : LoopOptions, optional
        How to loop (every option, its unit and default: :class:`LoopOptions`).
    progress : callable, optional
        ``progress(stage, done, total)`` (:mod:`elastic_motion.apps.progress`): the closing's
        iterations (``"closing"``, total unknown: 0) of the KKT solver.
    **overrides
        Fields of ``options`` to change: ``loop_motion(m, root="inplace", seam="c1")``.

    Returns
    -------
    LoopResult

    Raises
    ------
    OptionError
        An unknown or bad option (naming it); fewer than 3 frames; NaN/inf in the motion; a
        closed joint whose seam rotation is at log's cut locus (angle pi: the error names the
        joint; leave it free with ``free_joints`` to loop anyway); a ``min_length`` longer
        than the clip. :class:`~elastic_motion.apps.loop.refusal.LoopRefused` (an
        ``OptionError``): the loop changes the clip by more than ``change_bound`` or adds
        skids, without ``force``.
    """
    options = with_overrides(LoopOptions, options, overrides)
    prepared = _prepare(motion, options)
    if options.seam != "auto":
        return check_loop(loop_prepared(prepared, options, progress), options)
    c0 = loop_prepared(prepared, options.replace(seam="c0"), progress)
    if not hitches(c0):
        return check_loop(c0, options)
    return check_loop(choose_seam(c0, loop_prepared(prepared, c1_options(c0, options), progress)), options)


def loop_prepared(
    prepared: PreparedMotions, options: LoopOptions, progress: Progress | None = None
) -> LoopResult:
    """The stages of one loop of a prepared clip, its seam ``"c0"`` or ``"c1"`` (module docstring)."""
    motion = check_loop_motion(prepared.motions[0])
    joints = closed_joints(motion, options.free_joints)
    limits = limits_plan(motion, options)
    close = ClipCloser(options, joints, limits.kept, progress)
    looped = loop_window(motion, options, close)
    clip, closed = looped.clip, looped.closed
    measures = measure_loop(clip, closed, options, joints)
    joint_limits = limits.measured(clip, closed.motion, closed.limits)
    limit_notes = [*limits.notes, *(joint_limits.notes() if joint_limits is not None else ())]
    notes = policy_notes(clip, closed, measures, limit_notes, options, whole=looped.window is None)
    return LoopResult(
        motion=closed.motion,
        original=clip,
        closing=closed.closing,
        method=options.method,
        root=options.root,
        seam=options.seam,
        closed_joints=joints.closed,
        free_joints=joints.free,
        heading_change=measures.heading_change,
        displacement=measures.displacement,
        seam_before=measures.seam_before,
        seam_after=measures.seam_after,
        prepared=prepared,
        notes=(*((looped.choice,) if looped.choice is not None else ()), *prepare_notes(prepared), *notes),
        window=looped.window,
        contacts=measures.contacts,
        skating_before=measures.skating_before,
        skating_after=measures.skating_after,
        contacts_kept=closed.kept,
        joint_limits=joint_limits,
        skating_on_treadmill=measures.skating_on_treadmill,
        change_m=measures.change_m,
        feet_before=measures.feet_before,
        feet_after=measures.feet_after,
    )


def _prepare(motion: Source | PreparedMotions, options: LoopOptions) -> PreparedMotions:
    """The prepare stage: one input through :func:`~elastic_motion.apps.prepare.prepare_motions`."""
    sources = motion if isinstance(motion, PreparedMotions) else [motion]
    prepared = prepare_motions(sources, options.prepare)
    if len(prepared.motions) != 1:
        raise OptionError("motion", f"expected one motion to loop; got {len(prepared.motions)}")
    return prepared


def repeat_loop(result: LoopResult, cycles: int = 3, root: str | None = None) -> Motion:
    """A loop played ``cycles`` times, as ``loop --repeat`` writes it.

    :func:`~elastic_motion.motion.looping.repeat_motion` of ``result.motion`` with the
    loop's own ``root`` mode unless one is given, expressed in the unit the loop itself is
    written in (the first input's, :attr:`PreparedMotions.units_out`), so that the preview and
    the loop line up when imported side by side.

    Returns
    -------
    Motion
        ``cycles (F - 1) + 1`` frames, in the output unit.
    """
    played = repeat_motion(result.motion, cycles, result.root if root is None else root)
    return output_motion(played, result.prepared.units_out)
