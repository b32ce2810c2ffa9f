"""The words of the options: every ``Literal`` type the Python API and the command line share.

One home for each vocabulary: the type (``Method``, ``ContactPolicy``, ``Seam``...) and the
tuple of its values (``METHODS``, ``CONTACT_POLICIES``, ``SEAMS``...), in order. The options
classes annotate their fields with these types, and their modules re-export them under the
names they always had (``elastic_motion.motion.representations.Method`` *is*
:data:`Method`); the command line reads its ``choices=`` from here.

This module imports nothing but :mod:`typing`: the command line builds its parser from it
without loading numpy, numba or scipy (``elastic-motion --help`` in a fraction of a second),
and the apps that check a value against a vocabulary import it at no cost. Code that *does*
something with a word (:func:`elastic_motion.motion.representations.representation`,
:func:`elastic_motion.motion.contacts.contact_policy`, ...) stays beside the numerics.
"""

from __future__ import annotations

from typing import Literal, get_args

__all__ = [
    "CONTACT_MARKS",
    "CONTACT_MARK_ALIASES",
    "CONTACT_POLICIES",
    "CONTACT_POLICY_ALIASES",
    "CONTACT_WARP_MODES",
    "CURVE_METHODS",
    "DEFAULT_PAIR_KINDS",
    "ENGINES",
    "EVENT_KINDS",
    "GAIT_KINDS",
    "INTERPOLATIONS",
    "JOINT_SELECTIONS",
    "LAYOUTS",
    "LIMIT_POLICIES",
    "LINKAGES",
    "METHODS",
    "METHOD_ALIASES",
    "MOTION_EXTENSIONS",
    "OUTPUT_MOTION_EXTENSIONS",
    "RENDER_KINDS",
    "ROOT_MODES",
    "ROTATION_FRAMES",
    "SEAMS",
    "SKELETON_MODES",
    "SOLVERS",
    "TIME_UNITS",
    "UP_AXES",
    "WARP_METHODS",
    "WINDOW_MODES",
    "ContactMarks",
    "ContactPolicy",
    "ContactWarpMode",
    "CurveMethod",
    "EngineName",
    "EventKind",
    "Interpolation",
    "JointSelection",
    "Layout",
    "LimitPolicy",
    "Linkage",
    "Method",
    "RenderKind",
    "RootMode",
    "RotationFrame",
    "Seam",
    "SkeletonMode",
    "Solver",
    "TimeUnit",
    "UpAxis",
    "WarpMethod",
    "WindowMode",
]

# ------------------------------------------------------------------------------------------
# Curves and warps
# ------------------------------------------------------------------------------------------

#: The curve a motion becomes (:mod:`elastic_motion.motion.representations`): the Lie group
#: curve (the method, paper 000) or continuous Euler angles (the baseline of paper 001).
Method = Literal["lie", "euler-elastic"]
#: The values of :data:`Method`.
METHODS: tuple[str, ...] = get_args(Method)
#: Other names accepted for a :data:`Method`: ``"euler"`` (the key of stored files).
METHOD_ALIASES = {"euler": "euler-elastic"}

#: Blend / alignment methods (:mod:`elastic_motion.apps.align`): the two representations
#: (:data:`METHODS`) and ``"euler-linear"``, Euler curves interpolated frame by frame (paper
#: 001 Fig. 5 (a)).
CurveMethod = Literal["lie", "euler-elastic", "euler-linear"]
#: The values of :data:`CurveMethod`.
CURVE_METHODS: tuple[str, ...] = get_args(CurveMethod)

#: Warp methods (:class:`elastic_motion.warp.WarpOptions`): none (identity), dynamic
#: programming, DP then gradient refinement off the grid.
WarpMethod = Literal["none", "dp", "dp+refine"]
#: The values of :data:`WarpMethod`.
WARP_METHODS: tuple[str, ...] = get_args(WarpMethod)

#: How a motion is sampled between its frames (:func:`elastic_motion.motion.edit.resample_at_times`):
#: geodesic interpolation of the rotations, or cubic splines.
Interpolation = Literal["geodesic", "cubic"]
#: The values of :data:`Interpolation`.
INTERPOLATIONS: tuple[str, ...] = get_args(Interpolation)

# ------------------------------------------------------------------------------------------
# Landmarks
# ------------------------------------------------------------------------------------------

#: The unit of a landmark time without a suffix (:mod:`elastic_motion.apps.landmark_files`).
TimeUnit = Literal["seconds", "frames"]
#: The values of :data:`TimeUnit`.
TIME_UNITS: tuple[str, ...] = get_args(TimeUnit)

#: The axis a motion's up points along (``Motion.up_axis``, ``PrepareOptions.up``, ``--up``):
#: BVH files are y-up by convention, Blender's exports and ASF/AMC may be z-up.
UpAxis = Literal["x", "y", "z"]
#: The values of :data:`UpAxis`.
UP_AXES: tuple[str, ...] = get_args(UpAxis)

#: The event kinds :func:`elastic_motion.apps.landmarks.detect_events` knows.
EventKind = Literal[
    "left_knee_passes",
    "right_knee_passes",
    "left_foot_contact",
    "right_foot_contact",
    "left_heel_strike",
    "right_heel_strike",
    "left_toe_off",
    "right_toe_off",
]
#: The values of :data:`EventKind`.
EVENT_KINDS: tuple[str, ...] = get_args(EventKind)
#: Event kinds from the contacts (:func:`elastic_motion.apps.landmarks.contact_events`).
GAIT_KINDS = ("left_heel_strike", "right_heel_strike", "left_toe_off", "right_toe_off")
#: The default of ``landmarks="auto"``: foot strikes and toe-offs of both feet and the
#: paper's knee crossings (paper 001, sec. 4.2), all paired by phase.
DEFAULT_PAIR_KINDS = ("left_knee_passes", "right_knee_passes", *GAIT_KINDS)

# ------------------------------------------------------------------------------------------
# Contacts, loops and blends
# ------------------------------------------------------------------------------------------

#: What an app does with the contacts of its inputs (:mod:`elastic_motion.motion.contacts`),
#: one vocabulary for blend, loop, blend spaces and the viewer: ``"keep"`` plants them in the
#: output (a loop: constraints of its closing; a blend: the foot-skate clean-up), ``"report"``
#: only measures the output against them, ``"off"`` skips them.
ContactPolicy = Literal["keep", "report", "off"]
#: The values of :data:`ContactPolicy`.
CONTACT_POLICIES: tuple[str, ...] = get_args(ContactPolicy)
#: Other names accepted for a :data:`ContactPolicy`: ``"auto"`` (the blend's name before) for
#: ``"keep"``, ``"none"`` for ``"off"``.
CONTACT_POLICY_ALIASES = {"auto": "keep", "none": "off"}

#: The loop conventions (:mod:`elastic_motion.motion.looping`): the character travels on from
#: cycle to cycle, or comes back to where it started.
RootMode = Literal["travel", "inplace"]
#: The values of :data:`RootMode`.
ROOT_MODES: tuple[str, ...] = get_args(RootMode)

#: What closes at a loop's seam (:class:`elastic_motion.apps.loop.LoopOptions`): the poses
#: (``"c0"``, paper 000's closing), the velocities too (``"c1"``), or C0 unless its seam
#: hitches, then C1 when that is better (``"auto"``, :mod:`elastic_motion.apps.loop.seam_choice`).
Seam = Literal["auto", "c0", "c1"]
#: The values of :data:`Seam`.
SEAMS: tuple[str, ...] = get_args(Seam)
#: A loop's closing solver: ``"kkt"`` the closed curve nearest the input
#: (:func:`elastic_motion.closing.project_closed`), ``"gauss-newton"`` / ``"gradient"``
#: the flows of :func:`elastic_motion.closing.close_curve` (closed, nearest to first order).
Solver = Literal["kkt", "gauss-newton", "gradient"]
#: The values of :data:`Solver`.
SOLVERS: tuple[str, ...] = get_args(Solver)
#: What a loop does with joint limits (ASF ``limits``): keep them (an active set of the
#: projection, :mod:`elastic_motion.apps.loop.limits`), report them, or ignore them.
LimitPolicy = Literal["keep", "report", "off"]
#: The values of :data:`LimitPolicy`.
LIMIT_POLICIES: tuple[str, ...] = get_args(LimitPolicy)
#: When a blend of two warps B onto A with the contact-guided warp (heel strikes and toe-offs as
#: landmarks, :mod:`elastic_motion.apps.blend.contact_warp`): where it lowers the skid count
#: within 2 % of the distance, always, or never.
ContactWarpMode = Literal["auto", "on", "off"]
#: The values of :data:`ContactWarpMode`.
CONTACT_WARP_MODES: tuple[str, ...] = get_args(ContactWarpMode)
#: Which frames loop, by name: ``"safe"`` the whole clip when it closes with little change, else
#: the best cycle; ``"whole"`` the whole clip (``None`` in Python); ``"auto"`` the best cycle.
#: A ``(start, stop)`` pair of frames is the fourth way (``LoopOptions.window``).
WindowMode = Literal["safe", "whole", "auto"]
#: The values of :data:`WindowMode`.
WINDOW_MODES: tuple[str, ...] = get_args(WindowMode)

#: Bone offsets of a blend (:class:`elastic_motion.apps.blend_options.BlendOptions`): the
#: weighted mean of the inputs' (``"blend"``) or the first input's.
SkeletonMode = Literal["blend", "first"]
#: The values of :data:`SkeletonMode`.
SKELETON_MODES: tuple[str, ...] = get_args(SkeletonMode)

# ------------------------------------------------------------------------------------------
# Databases and statistics
# ------------------------------------------------------------------------------------------

#: Where a matrix run computes its tiles (:mod:`elastic_motion.apps.database.engines`): this
#: process, a Dask ``LocalCluster`` started here, or a running Dask scheduler.
EngineName = Literal["serial", "local", "dask"]
#: The values of :data:`EngineName`.
ENGINES: tuple[str, ...] = get_args(EngineName)

#: The joint selections of a database by name (``DatabaseSettings.joints``; otherwise a list
#: of joint names): every joint, the joints all motions share, or a common body through
#: joint-name maps.
JointSelection = Literal["all", "common", "map"]
#: The values of :data:`JointSelection`.
JOINT_SELECTIONS: tuple[str, ...] = get_args(JointSelection)

#: How :func:`elastic_motion.apps.statistics.cluster` measures the distance between two
#: clusters: the mean of their pairs' distances (UPGMA), the largest, the smallest, or the
#: mean of the two clusters they merged (WPGMA). The linkages that assume Euclidean data
#: (Ward, centroid, median) are not offered.
Linkage = Literal["average", "complete", "single", "weighted"]
#: The values of :data:`Linkage`.
LINKAGES: tuple[str, ...] = get_args(Linkage)

# ------------------------------------------------------------------------------------------
# Pictures and the viewer
# ------------------------------------------------------------------------------------------

#: What :func:`elastic_motion.apps.render.render` draws: ``"auto"`` (an animation for a
#: video file, the foot trajectories for a still), or one picture.
RenderKind = Literal["auto", "animation", "feet", "warp", "seam", "sphere"]
#: The values of :data:`RenderKind`.
RENDER_KINDS: tuple[str, ...] = get_args(RenderKind)
#: The frame of a joint's rotation curve (:func:`elastic_motion.apps.render.joint_rotation_curve`):
#: relative to its parent, or to the world.
RotationFrame = Literal["local", "global"]
#: The values of :data:`RotationFrame`.
ROTATION_FRAMES: tuple[str, ...] = get_args(RotationFrame)

#: How the viewer places the clips at first (the page has a switch): side by side, or on
#: one spot.
Layout = Literal["side", "overlay"]
#: The values of :data:`Layout`.
LAYOUTS: tuple[str, ...] = get_args(Layout)
#: Which contacts the viewer marks: from the reports; from the reports, else detected on
#: the motion; none (the words of :data:`ContactPolicy` where they mean the same).
ContactMarks = Literal["report", "detect", "off"]
#: The values of :data:`ContactMarks`.
CONTACT_MARKS: tuple[str, ...] = get_args(ContactMarks)
#: Other names accepted for :data:`ContactMarks`: ``"none"`` (the viewer's word before the
#: vocabulary was shared) for ``"off"``.
CONTACT_MARK_ALIASES = {"none": "off"}

# ------------------------------------------------------------------------------------------
# Files
# ------------------------------------------------------------------------------------------

#: The extensions of motion files, lower case: BVH, AMC (its skeleton the ``.asf`` beside
#: it), DeepMimic ``.txt`` / ``.json`` and glTF 2.0 ``.gltf`` / ``.glb``
#: (:func:`elastic_motion.motion.read_motion` chooses its reader by them; a database collects
#: ``.txt`` / ``.json`` from a folder only when they look like a DeepMimic clip,
#: :func:`elastic_motion.apps.database.find_motion_files`).
MOTION_EXTENSIONS: tuple[str, ...] = (".bvh", ".amc", ".txt", ".json", ".gltf", ".glb")

#: The extensions a command's motion output may have (:func:`elastic_motion.motion.write_motion`
#: chooses the writer by them): BVH, glTF 2.0 JSON, glTF 2.0 binary.
OUTPUT_MOTION_EXTENSIONS: tuple[str, ...] = (".bvh", ".gltf", ".glb")
