"""Motions between an armature and BVH files: the export the command reads, Blender's BVH import
with its ``'rU'`` bug worked around, and the result carried back onto the same armature
(needs ``bpy`` and ``mathutils``; no numpy).

:func:`export_bvh` writes the armature's action as the world sees it, lengths in metres
(Blender units times the scene's Unit Scale), Z-up (Blender's world): the rest pose in the
armature's own axes (scaled by the object's scale, so that two armatures of one rig give
the same skeleton wherever they stand), the object's placement and turn in the root's
channels, one rotation triple per bone and position channels on the root and on **every
bone that carries a translation** (the hips under a static root, as in the Bandai rigs;
Blender's own exporter with ``root_transform_only`` drops them, without it writes noisy
positions on every bone). The command is told so explicitly (``--up z --units m``,
:func:`elastic_motion_addon.runner.input_args`). It keeps the skeleton and turns the root
to Y-up; its result comes back through Blender's importer (``-Z`` forward, ``Y`` up: the
exact inverse of the command's ``z -> y`` quarter turn), scaled to scene units, and
:func:`bake_onto` carries it bone by bone onto the armature: every bone's head where the
result puts it, its rotation the result's rotation from the rest pose applied to the
armature's own rest orientation (so a rig whose bones have other rolls than Blender's
importer gives them keeps its skinning right). Bones the result lacks (a static root the
command folded into the hips) keep their pose of the input's first frame.
"""

from __future__ import annotations

import contextlib
import math

import bpy
from mathutils import Matrix, Vector

# A bone whose translation from its parent differs from its rest offset by more than this
# share of the skeleton's size carries a translation (below: float32 noise of the matrices).
TRANSLATION_TOLERANCE = 1e-4


def metres_per_unit(scene) -> float:
    """Metres per Blender unit: the scene's Unit Scale (1 by default)."""
    return float(scene.unit_settings.scale_length) or 1.0


def _tree(arm):
    """Bones parents first (depth first, in the armature's order, as Blender's exporter)."""
    out = []

    def visit(bone):
        out.append(bone)
        for child in bone.children:
            visit(child)

    for bone in arm.bones:
        if bone.parent is None:
            visit(bone)
    return out


def _rotation(m):
    """The rotation of a 4x4 or 3x3 matrix (scale removed), as a 3x3."""
    return m.to_3x3().normalized()


def _sample(context, obj, bones, frames):
    """Per frame, per bone: (rotation from the rest pose, head), in armature space; the lowest
    world height of a bone's head or tail over the frames (Blender units)."""
    scene = context.scene
    mw = obj.matrix_world
    rest_t = {b.name: _rotation(b.matrix_local).transposed() for b in bones}
    samples = []
    lowest = math.inf
    for f in frames:
        scene.frame_set(f)
        frame = {}
        for b in bones:
            pb = obj.pose.bones[b.name]
            pm = pb.matrix
            frame[b.name] = (_rotation(pm) @ rest_t[b.name], pm.to_translation())
            lowest = min(lowest, (mw @ pb.head).z, (mw @ pb.tail).z)
        samples.append(frame)
    return samples, lowest


def _locals(bones, samples, world, k):
    """Per frame, per bone: the BVH channels' content, (rotation relative to the parent's,
    translation from the parent's head in the parent's posed frame), in metres. The rest pose
    is the armature's (its own axes, scaled by the object's scale), the root's rotation and
    position are in the world (``world``: the object's matrix): the rest pose does not depend
    on where the object stands (two armatures of one rig export the same skeleton)."""
    obj_rot = _rotation(world)
    scale = k * sum(world.to_scale()) / 3.0
    out = []
    for frame in samples:
        loc = {}
        for b in bones:
            g, p = frame[b.name]
            if b.parent is None:
                loc[b.name] = (obj_rot @ g, (world @ p) * k)
            else:
                gp, pp = frame[b.parent.name]
                gpt = gp.transposed()
                loc[b.name] = (gpt @ g, (gpt @ (p - pp)) * scale)
        out.append(loc)
    return out


def _numbers(values):
    """Numbers as the file writes them (9 significant digits: below float32's noise)."""
    return " ".join(f"{v:.9g}" for v in values)


def _hierarchy(bone, offsets, moving, tail, depth=0):
    """The ``HIERARCHY`` lines of ``bone`` and its children (``tail(bone)``: its end site)."""
    ind = "\t" * depth
    pos = "Xposition Yposition Zposition " if bone.name in moving else ""
    lines = [
        f"{ind}{'JOINT' if depth else 'ROOT'} {bone.name}",
        ind + "{",
        ind + "\tOFFSET " + _numbers(offsets[bone.name]),
        f"{ind}\tCHANNELS {6 if pos else 3} {pos}Zrotation Xrotation Yrotation",
    ]
    for child in bone.children:
        lines += _hierarchy(child, offsets, moving, tail, depth + 1)
    if not bone.children:
        lines += [ind + "\tEnd Site", ind + "\t{", ind + "\t\tOFFSET " + _numbers(tail(bone))]
        lines.append(ind + "\t}")
    lines.append(ind + "}")
    return lines


def export_bvh(context, obj, path, frame_start, frame_end, floor_m=None):
    """Write ``obj``'s animation over ``frame_start..frame_end`` to ``path`` as a Z-up BVH in
    metres, as the world sees it (see the module docstring).

    ``floor_m``: lift (or lower) the motion so that its lowest point (a bone's head or tail
    over the frames) is at this world height (m); default: as it is.

    Returns
    -------
    dict
        ``size_m`` (the rest pose's largest extent, m: a standing or T-pose rest's height or
        span; Bandai's rest lies along x), ``floor_m`` (the lowest point
        of the motion, m, as written), ``lift_m`` (the shift ``floor_m`` asked for),
        ``translated`` (the bones written with position channels), ``frames``.
    """
    arm = obj.data
    if len([b for b in arm.bones if b.parent is None]) != 1:
        raise RuntimeError(
            f"{obj.name}: expected an armature with one top bone (BVH has one root); "
            f"got {sum(b.parent is None for b in arm.bones)}"
        )
    scene = context.scene
    k = metres_per_unit(scene)
    mw = obj.matrix_world
    scale = k * sum(mw.to_scale()) / 3.0
    bones = _tree(arm)
    offsets = {b.name: (b.head_local - b.parent.head_local) * scale for b in bones if b.parent}
    offsets[bones[0].name] = (mw @ bones[0].head_local) * k
    world = [(mw @ b.head_local) * k for b in bones] + [(mw @ b.tail_local) * k for b in bones]
    size = max(max(p[i] for p in world) - min(p[i] for p in world) for i in range(3)) or 1.0
    frame_now = scene.frame_current
    try:
        samples, lowest = _sample(context, obj, bones, range(frame_start, frame_end + 1))
    finally:
        scene.frame_set(frame_now)
    local = _locals(bones, samples, mw, k)
    lowest *= k
    lift = 0.0 if floor_m is None else floor_m - lowest
    if lift:
        root = bones[0].name
        offsets[root] = offsets[root] + Vector((0.0, 0.0, lift))
        for fr in local:
            fr[root] = (fr[root][0], fr[root][1] + Vector((0.0, 0.0, lift)))
    tol = TRANSLATION_TOLERANCE * size
    moving = {bones[0].name} | {
        b.name for b in bones[1:] if any((fr[b.name][1] - offsets[b.name]).length > tol for fr in local)
    }
    lines = [
        "HIERARCHY",
        *_hierarchy(bones[0], offsets, moving, lambda b: (b.tail_local - b.head_local) * scale),
    ]
    lines += [
        "MOTION",
        f"Frames: {len(local)}",
        "Frame Time: " + _numbers([scene.render.fps_base / scene.render.fps]),
    ]
    prev = {}
    for fr in local:
        values = []
        for b in bones:
            rot, t = fr[b.name]
            if b.name in moving:
                values += list(t)
            e = rot.to_euler("YXZ", prev[b.name]) if b.name in prev else rot.to_euler("YXZ")
            prev[b.name] = e
            values += [math.degrees(e.z), math.degrees(e.x), math.degrees(e.y)]
        lines.append(_numbers(values))
    with open(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write("\n".join(lines) + "\n")
    return {
        "size_m": size,
        "floor_m": lowest + lift,
        "lift_m": lift,
        "translated": [b.name for b in bones if b.name in moving],
        "frames": len(local),
    }


# ------------------------------------------------------------------------------------------
# Import
# ------------------------------------------------------------------------------------------


@contextlib.contextmanager
def _importer_without_ru():
    """Blender's ``io_anim_bvh.import_bvh`` with ``open`` that drops the mode's ``U``.

    Blender 3.4's importer opens the file with ``open(path, 'rU')``; Python 3.11 removed the
    ``U`` mode (``ValueError: invalid mode: 'rU'``), so Debian's Blender 3.4.1 (system
    Python 3.11) cannot import any BVH from its own menu. The name ``open`` is shadowed in
    the importer's module only (not ``builtins``), for the duration of the call; harmless
    where the importer is fixed.
    """
    from io_anim_bvh import import_bvh

    def open_without_u(file, mode="r", *args, **kwargs):
        if isinstance(mode, str):
            mode = mode.replace("U", "")
        return open(file, mode, *args, **kwargs)

    import_bvh.open = open_without_u
    try:
        yield import_bvh
    finally:
        del import_bvh.open


def load_bvh(context, path, *, report=print, axis_forward="-Z", axis_up="Y", **options):
    """Import ``path`` with Blender's BVH importer (its ``load``; ``options`` are its keywords:
    ``global_scale``, ``frame_start``, ``rotate_mode``, ``use_fps_scale``, ``update_scene_fps``,
    ``update_scene_duration``, ``use_cyclic``, ``target``), the ``'rU'`` bug worked around.

    Returns
    -------
    (set, object or None)
        The importer's result and the new armature.
    """
    from bpy_extras.io_utils import axis_conversion

    matrix = axis_conversion(from_forward=axis_forward, from_up=axis_up).to_4x4()
    before = set(bpy.data.objects)
    with _importer_without_ru() as importer:
        result = importer.load(context, path, global_matrix=matrix, report=report, **options)
    new = [o for o in bpy.data.objects if o not in before and o.type == "ARMATURE"]
    return result, (new[0] if new else None)


# ------------------------------------------------------------------------------------------
# The result onto the armature
# ------------------------------------------------------------------------------------------


def _fixed_poses(target, frame, names, scene):
    """``matrix_basis`` of the bones ``names`` at ``frame`` of the target's current action."""
    scene.frame_set(frame)
    return {n: target.pose.bones[n].matrix_basis.copy() for n in names}


def _pose_frames(scene, target, source, fixed, frames, file_axes):
    """Per frame: each target bone's ``matrix_basis`` that puts it where the source bone of the
    same name is (head) and turns it as the source turns from the rest pose.

    The result file's rest pose is the target armature's own (what :func:`export_bvh` wrote,
    the command keeps the skeleton and turns the root only); Blender's importer turned it by
    ``file_axes`` (the file's axes in Blender's world). So the file's global rotation of a
    joint is ``C^T D C`` with ``D`` the source bone's world rotation from its rest and ``C``
    the axis conversion, and the target bone's world rotation is ``D C`` times its
    armature-space rest (the object's own rotation is in the file's root)."""
    from bpy_extras.io_utils import axis_conversion

    conv = axis_conversion(from_forward=file_axes[0], from_up=file_axes[1]).to_3x3()
    mt, ms = target.matrix_world, source.matrix_world
    mt_inv = mt.inverted()
    obj_rot_t = _rotation(mt).transposed()
    bones = _tree(target.data)
    rest = {b.name: b.matrix_local for b in bones}
    rest_rel = {
        b.name: (rest[b.parent.name].inverted() @ rest[b.name]) if b.parent else rest[b.name] for b in bones
    }
    turn = {}
    for b in bones:
        sb = source.data.bones.get(b.name)
        if sb is not None:
            turn[b.name] = _rotation(ms @ sb.matrix_local).transposed() @ conv @ _rotation(b.matrix_local)
    out = []
    for f in frames:
        scene.frame_set(f)
        posed, basis = {}, {}
        for b in bones:
            parent = posed[b.parent.name] if b.parent else Matrix.Identity(4)
            if b.name in turn:
                sm = ms @ source.pose.bones[b.name].matrix
                rot = obj_rot_t @ _rotation(sm) @ turn[b.name]
                posed[b.name] = Matrix.Translation(mt_inv @ sm.to_translation()) @ rot.to_4x4()
                basis[b.name] = (parent @ rest_rel[b.name]).inverted() @ posed[b.name]
            else:
                basis[b.name] = fixed[b.name]
                posed[b.name] = parent @ rest_rel[b.name] @ basis[b.name]
        out.append(basis)
    return out


def _key(action, bone, prop, frames, values, interpolation="LINEAR"):
    """F-curves ``pose.bones[bone].prop[i]`` with one key per frame (``values``: per frame a
    sequence)."""
    path = f'pose.bones["{bpy.utils.escape_identifier(bone)}"].{prop}'
    for i in range(len(values[0])):
        fc = action.fcurves.new(path, index=i, action_group=bone)
        kps = fc.keyframe_points
        kps.add(len(frames))
        kps.foreach_set(
            "co", [c for f, v in zip(frames, values, strict=True) for c in (float(f), float(v[i]))]
        )
        for kp in kps:
            kp.interpolation = interpolation
        fc.update()


def _rotation_values(pb, rots):
    """The rotations ``rots`` (quaternions, per frame) in ``pb``'s rotation mode, continuous;
    the property name."""
    mode = pb.rotation_mode
    if mode == "QUATERNION":
        out = [rots[0]]
        for q in rots[1:]:
            q = q.copy()
            q.make_compatible(out[-1])
            out.append(q)
        return "rotation_quaternion", [tuple(q) for q in out]
    if mode == "AXIS_ANGLE":
        vals = []
        for q in rots:
            axis, angle = q.to_axis_angle()
            vals.append((angle, *axis))
        return "rotation_axis_angle", vals
    out = [rots[0].to_euler(mode)]
    for q in rots[1:]:
        out.append(q.to_euler(mode, out[-1]))
    return "rotation_euler", [tuple(e) for e in out]


def _keyed(action, name, prop):
    path = f'pose.bones["{bpy.utils.escape_identifier(name)}"].{prop}'
    return action is not None and any(fc.data_path == path for fc in action.fcurves)


def save_pose(target):
    """Every pose bone's ``matrix_basis`` (what an action switch leaves behind on the bones it
    does not key), for :func:`restore_pose`."""
    return {pb.name: pb.matrix_basis.copy() for pb in target.pose.bones}


def restore_pose(target, saved):
    for pb in target.pose.bones:
        if pb.name in saved:
            pb.matrix_basis = saved[pb.name]


def bake_onto(context, target, source, name, frame_start, file_axes=("-Z", "Y")):
    """A new action ``name`` on ``target`` that carries ``source``'s animation (see the module
    docstring); keys from ``frame_start``. ``file_axes``: the axis conversion the result was
    imported with (forward, up).

    Locations are keyed on the bones that carry a translation in the result (position
    channels: location curves on ``source``) and on the bones the result lacks when their
    pose has one; a bone whose previous action keyed a property the new one does not gets
    it keyed at rest, once (so that switching actions leaves no stale pose)."""
    scene = context.scene
    src_start, src_end = (round(v) for v in source.animation_data.action.frame_range)
    old = target.animation_data.action
    old_start = round(old.frame_range[0]) if old is not None else frame_start
    missing = [b.name for b in target.data.bones if source.data.bones.get(b.name) is None]
    fixed = _fixed_poses(target, old_start, missing, scene)
    bases = _pose_frames(scene, target, source, fixed, range(src_start, src_end + 1), file_axes)
    action = bpy.data.actions.new(name)
    target.animation_data.action = action
    keys = [frame_start + i for i in range(len(bases))]
    src_action = source.animation_data.action
    for pb in target.pose.bones:
        n = pb.name
        if n in fixed:
            moves = fixed[n].to_translation().length > 0.0
        else:
            moves = _keyed(src_action, n, "location")
        if moves:
            _key(action, n, "location", keys, [tuple(b[n].to_translation()) for b in bases])
        elif _keyed(old, n, "location"):
            _key(action, n, "location", keys[:1], [(0.0, 0.0, 0.0)])
        prop, values = _rotation_values(pb, [b[n].to_quaternion() for b in bases])
        _key(action, n, prop, keys, values)
        if n in fixed and (fixed[n].to_scale() - Vector((1.0, 1.0, 1.0))).length > 1e-9:
            _key(action, n, "scale", keys[:1], [tuple(fixed[n].to_scale())])
        elif _keyed(old, n, "scale"):
            _key(action, n, "scale", keys[:1], [(1.0, 1.0, 1.0)])
        pb.location, pb.scale = (0.0, 0.0, 0.0), (1.0, 1.0, 1.0)  # unkeyed: at rest
    return action
