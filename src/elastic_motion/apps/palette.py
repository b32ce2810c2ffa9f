"""The colours of every picture of a motion: the stills and videos of
:mod:`elastic_motion.apps.render`, the 3D viewer (:mod:`elastic_motion.apps.viewer`) and the
legend of the demo's page (:mod:`elastic_motion.apps.demo`), in one place so that a colour
means the same thing everywhere and the legend explains what is drawn.

Conventions
-----------
* **Sides**: left limbs blue (:data:`LEFT`), right limbs orange (:data:`RIGHT`), as in
  paper 001 Fig. 5-6 (blue and orange foot trajectories); the rest (spine, neck, head) grey
  (:data:`CENTRE`). The side of a joint comes from its name (:func:`joint_side`).
* Colours are CSS hex strings (``"#rrggbb"``), which matplotlib, plotly and HTML all read.
"""

from __future__ import annotations

import re

import numpy as np

from elastic_motion.motion import Motion

__all__ = [
    "CENTRE",
    "CLIP_COLOURS",
    "CURVES",
    "FLOOR",
    "GHOST",
    "LEFT",
    "PLANTED",
    "RIGHT",
    "TRACE",
    "UNIFORM",
    "WARP",
    "bone_colours",
    "joint_side",
    "side_colour",
]

#: Left limbs, the left foot's trajectory (matplotlib's blue).
LEFT = "#1f77b4"
#: Right limbs, the right foot's trajectory (matplotlib's orange).
RIGHT = "#ff7f0e"
#: Bones of neither side: spine, neck and head.
CENTRE = "#555555"
#: The few whole-body poses drawn behind the foot trajectories.
GHOST = "#b0b0b0"
#: The optimal time warp in the warp plot.
WARP = "#d62728"
#: The identity warp (no warp), dashed, in the warp plot.
UNIFORM = "#999999"
#: The floor band of the animations.
FLOOR = "#eeeeee"
#: Planted joints and footprints in the viewer.
PLANTED = "#d62728"
#: The traced joints of the seam plot, in order.
TRACE = ("#2ca02c", "#9467bd", "#8c564b", "#e377c2")
#: The curves on the sphere (SO(3) plots), in order: input A, input B, the result, ...
CURVES = ("#1f77b4", "#ff7f0e", "#d62728", "#2ca02c", "#9467bd", "#8c564b")
#: The centre lines of the viewer's clips, in order (limbs keep the side colours).
CLIP_COLOURS = ("#444444", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22", "#7f7f7f")

#: Lower-case ASF part names that follow a one-letter side prefix (CMU ``lfemur``, ``rhand``).
_ASF_PARTS = ("hipjoint femur tibia foot toes clavicle humerus radius wrist hand fingers thumb").split()


def joint_side(name: str) -> str:
    """``"L"``, ``"R"`` or ``""``: the side of a joint from its name.

    A ``Left``/``left`` prefix or a ``_l``/``.l``/``left`` suffix (any case), a capital ``L``
    followed by a capital or ``_`` (``LHipJoint``), or an ASF ``l``/``r`` prefix before a
    known part (``lfemur``); likewise for right. A namespace (``mixamorig:``) is ignored.
    """
    raw = name.rsplit(":", 1)[-1]
    low = raw.lower()
    if low.startswith("left") or low.endswith(("_l", ".l", "left")) or re.match(r"^L[A-Z_]", raw):
        return "L"
    if low.startswith("right") or low.endswith(("_r", ".r", "right")) or re.match(r"^R[A-Z_]", raw):
        return "R"
    if low[:1] in ("l", "r") and low[1:] in _ASF_PARTS:
        return low[0].upper()
    return ""


def side_colour(side: str) -> str:
    """The colour of a side (:func:`joint_side`): :data:`LEFT`, :data:`RIGHT` or :data:`CENTRE`."""
    return LEFT if side == "L" else RIGHT if side == "R" else CENTRE


def bone_colours(motion: Motion) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """The bones of a skeleton as segments between forward-kinematics points, and their colours.

    Parameters
    ----------
    motion : Motion

    Returns
    -------
    start, end : ndarray of int, shape (J - 1 + E,)
        Indices into the points of ``forward_kinematics(motion, end_sites=True)`` (joints,
        then end sites): one bone per non-root joint (from its parent), then one per end
        site.
    colours : list of str
        The colour of each bone: the side colour of the joint it moves (an end site's: its
        parent's).
    """
    sk = motion.skeleton
    a, b, colours = [], [], []
    for j in range(1, sk.n_joints):
        a.append(int(sk.parents[j]))
        b.append(j)
        colours.append(side_colour(joint_side(sk.names[j])))
    for e, p in enumerate(sk.end_site_parents):
        a.append(int(p))
        b.append(sk.n_joints + e)
        colours.append(side_colour(joint_side(sk.names[int(p)])))
    return np.array(a, dtype=int), np.array(b, dtype=int), colours
