"""A loop with kept contacts on every frame: the planted joints put on their rows' targets by
IK, the body raised where it went under the floor (:func:`plant_and_lift`).

Lengths in metres unless said otherwise; the seam frames never change.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np

from elastic_motion.apps.cleanup import cleanup_footskate, find_arms, find_legs
from elastic_motion.apps.loop.contact_rows import row_plants
from elastic_motion.motion import Motion, forward_kinematics, lift_out_of_floor
from elastic_motion.motion.contacts import Contacts

__all__ = ["FLOOR_TOLERANCE", "floor_per_frame", "plant_and_lift"]

_AXES = "xyz"
#: How far (metres) a kept-contacts loop may go under the floor where the input itself does
#: (the floor is a robust estimate, the 2nd percentile of the lowest point: the input goes
#: under it on a few frames); deeper, the body is raised there (not on the seam frames).
FLOOR_TOLERANCE = 0.01


def floor_per_frame(motion: Motion, found: Contacts) -> np.ndarray:
    """Per frame ``(F,)``, the height (metres) a kept-contacts loop may not go under: the
    floor, or the input's own lowest point there if lower, but never more than
    :data:`FLOOR_TOLERANCE` under the floor."""
    unit = motion.metres_per_unit if motion.metres_per_unit is not None else 1.0
    heights = forward_kinematics(motion, end_sites=True)[..., _AXES.index(motion.up_axis)]
    lowest_in = heights.min(axis=1) * unit
    floor = found.floor_heights()  # a floor that is not level, frame by frame
    return np.minimum(floor, np.maximum(lowest_in, floor - FLOOR_TOLERANCE))


def plant_and_lift(
    motion: Motion,
    out: Motion,
    found: Contacts,
    kept_contacts: Contacts,
    lift_from: Mapping[str, int],
    c1: bool,
    *,
    smooth: float = 0.0,
) -> tuple[Motion, dict | None, float]:
    """The loop ``out`` of ``motion`` with its kept contacts planted on every frame and its
    body out of the floor; the seam frames (and their neighbours for a C1 seam, whose
    velocities must match too) untouched.

    Between the grid's frames the interpolated correction lets planted feet drift (by its
    curvature: cm on a clip changed by decimetres), and a polished solve misses them by up to
    :data:`~elastic_motion.apps.loop.kept_contacts.POLISH_MISS`: leg and arm IK put them on
    the rows' targets (:func:`~elastic_motion.apps.loop.contact_rows.row_plants`), eased in
    and out of the contacts like a blend's clean-up. On a grid the IK runs twice: its change
    smoothed over the grid's spacing, then exactly. The drift is zero on the grid's frames
    and up to a millimetre between them, which a straight stance leg can only take up by
    bending its knee by degrees (1 mm of a 0.9 m leg is 5 deg): in one exact pass the knee
    flickered between straight and bent at the grid's rate (CMU 131_01's auto window, a
    120 fps clip on a 30 fps grid: 0.1 and 5.2 deg on alternate frames); the smoothed pass
    bends it on every frame, and the exact one then turns it by little. Kept feet push the
    change into the other frames: where that puts a hand or the head under the floor (or
    under the input's own lowest point there, down to :data:`FLOOR_TOLERANCE` under it), the
    body is raised there.

    Parameters
    ----------
    motion : Motion
        The prepared clip (the rows' targets).
    out : Motion
        Its loop, on the same frames.
    found : Contacts
        The clip's contacts (the floor).
    kept_contacts : Contacts
        Those kept (:func:`~elastic_motion.apps.loop.contact_grid.fine_contacts`).
    lift_from : mapping of str to int
        Contacts lifted early: the frame their height rows stop at.
    c1 : bool
        A C1 seam.
    smooth : float, default 0
        Seconds, the standard deviation of the Gaussian the IK's change is smoothed with
        (:func:`~elastic_motion.apps.cleanup.cleanup_footskate`): the grid's spacing when
        the clip was closed on a grid.

    Returns
    -------
    Motion
        The loop, planted and lifted.
    planted_by_ik : dict or None
        ``skating_before_m_s``, ``skating_after_m_s``, ``max_position_change_m`` of the IK
        (None when it changed nothing).
    lifted_max_m : float
        How far the body was raised at most.
    """
    f = motion.n_frames
    seam = (0, 1, f - 2, f - 1) if c1 and f > 4 else (0, f - 1)
    unit = motion.metres_per_unit if motion.metres_per_unit is not None else 1.0
    plants = row_plants(motion, kept_contacts, out, lift_from, c1=c1)
    # only the plants here: a leg raised by IK to clear a floor the loop went decimetres under
    # bends its knee by as much; the body is raised instead, below
    no_floor = dataclasses.replace(kept_contacts, floor=-math.inf)
    limbs = find_legs(out)[0] + find_arms(out, kept_contacts.joints)  # a cartwheel's hands too
    kw = {"plants": plants, "fixed": seam, "knee_hinge": False, "legs": limbs}
    ik = cleanup_footskate(out, no_floor, smooth=smooth, **kw)
    planted_by_ik = None
    if ik.applied:
        planted = ik.motion
        after = ik.skating_after
        if smooth > 0:
            # the smoothed change bends a straight stance knee a little on every frame; exact
            # plants from there need only small turns (no singularity at a straight knee)
            exact = cleanup_footskate(planted, no_floor, smooth=0.0, **kw)
            planted, after = (exact.motion, exact.skating_after) if exact.applied else (planted, after)
        moved = forward_kinematics(planted, end_sites=True) - forward_kinematics(out, end_sites=True)
        out = planted
        planted_by_ik = {
            "skating_before_m_s": ik.skating_before.mean_speed,
            "skating_after_m_s": after.mean_speed,
            "max_position_change_m": float(np.linalg.norm(moved, axis=-1).max()) * unit,
        }
    out, lift = lift_out_of_floor(out, floor_per_frame(motion, found) / unit, fixed=seam)
    return out, planted_by_ik, float(lift.max() * unit)
