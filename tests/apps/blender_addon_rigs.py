"""Run inside Blender (``blender -b --factory-startup --python THIS -- SPEC.json``): install the
add-on, import each scenario's clips as an animator would (Blender's BVH importer at the
scale that makes the character its real size), run the add-on's Blend and Loop on them and
measure the results against the inputs, in the world and in metres:

* ``start``: the hips' world position at the first frame (m);
* ``travel``: the hips' horizontal displacement from the first to the last frame (m);
* ``tilt``: the mean over frames of the angle between the hips -> head vector and world up (deg);
* ``floor``: the median over frames of the lowest bone head or tail (m).

Prints one line ``EMRESULT {json}``. Used by ``tests/apps/test_blender_addon_rigs.py``
(:func:`measure` also by ``test_blender_addon.py``'s script); it also measures an older
add-on (it imports the inputs itself and finds the result on the armature or on a new
one)."""

import builtins
import json
import math
import sys
import time
import traceback

import addon_utils  # noqa: F401 - loads Blender's add-on machinery
import bpy

_OPEN = builtins.open


def _open_without_u(file, mode="r", *args, **kwargs):
    if isinstance(mode, str):
        mode = mode.replace("U", "")
    return _OPEN(file, mode, *args, **kwargs)


def load(path, scale):
    """Blender's own importer (Y-up file, -Z forward: the defaults), 'rU' worked around."""
    builtins.open = _open_without_u
    try:
        before = set(bpy.data.objects)
        bpy.ops.import_anim.bvh(filepath=path, global_scale=scale, update_scene_fps=True)
    finally:
        builtins.open = _OPEN
    return next(o for o in bpy.data.objects if o not in before and o.type == "ARMATURE")


def select(active, *others):
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    for o in (active, *others):
        o.select_set(True)
    bpy.context.view_layer.objects.active = active


def measure(arm, hips, head):
    """The figures of the action on ``arm`` (see the module docstring)."""
    scene = bpy.context.scene
    k = scene.unit_settings.scale_length
    start, end = (round(v) for v in arm.animation_data.action.frame_range)
    mw = arm.matrix_world
    hips_path, tilts, lows = [], [], []
    for f in range(start, end + 1):
        scene.frame_set(f)
        h = mw @ arm.pose.bones[hips].head
        top = mw @ arm.pose.bones[head].head
        hips_path.append([k * v for v in h])
        v = top - h
        tilts.append(math.degrees(math.acos(max(-1.0, min(1.0, v.z / max(v.length, 1e-12))))))
        lows.append(k * min(min((mw @ pb.head).z, (mw @ pb.tail).z) for pb in arm.pose.bones))
    lows.sort()
    travel = math.hypot(hips_path[-1][0] - hips_path[0][0], hips_path[-1][1] - hips_path[0][1])
    return {
        "frames": end - start + 1,
        "start": hips_path[0],
        "travel": travel,
        "tilt": sum(tilts) / len(tilts),
        "floor": lows[len(lows) // 2],
    }


def run_op(op, log):
    n = len(log)
    try:
        result = sorted(op())
        return result, ""
    except RuntimeError as exc:  # an operator that reported an error
        return ["ERROR"], str(exc)
    finally:
        del log[n:]


def result_holder(target, before_objects, old_action):
    new = [o for o in bpy.data.objects if o not in before_objects and o.type == "ARMATURE"]
    if new:
        return new[0]
    if target.animation_data.action is not old_action:
        return target
    return None


def scenario(spec, settings):
    scale = spec["scale"]
    arms = [load(p, scale) for p in spec["files"]]
    if spec.get("place"):  # the first armature moved and turned in the world
        x, y, z, turn_deg = spec["place"]
        arms[0].location = (x, y, z)
        arms[0].rotation_euler[2] += math.radians(turn_deg)
        bpy.context.view_layer.update()
    hips, head = spec["hips"], spec["head"]
    out = {"inputs": [measure(a, hips, head) for a in arms]}
    a = arms[0]
    old = a.animation_data.action
    for op_name in spec["ops"]:
        a.animation_data.action = old
        if op_name == "blend":
            select(a, arms[1])
            op = bpy.ops.elastic_motion.blend
        else:
            select(a)
            settings.window = spec.get("window", "safe")
            settings.force = spec.get("force", False)
            settings.contacts = spec.get("contacts", True)
            op = bpy.ops.elastic_motion.loop
        before = set(bpy.data.objects)
        t0 = time.time()
        status = run_op(op, [])
        res = {"status": status, "last_status": settings.last_status, "panel": settings.last_report}
        res["seconds"] = time.time() - t0
        holder = result_holder(a, before, old)
        res["on_target"] = holder is a
        if holder is not None and status[0] == ["FINISHED"]:
            res["measure"] = measure(holder, hips, head)
            if holder is not a:
                bpy.data.objects.remove(holder, do_unlink=True)
        out[op_name] = res
    for arm in arms:
        bpy.data.objects.remove(arm, do_unlink=True)
    return out


def main():
    argv = sys.argv[sys.argv.index("--") + 1 :]
    with _OPEN(argv[0], encoding="utf-8") as fh:
        spec = json.load(fh)
    out = {}
    try:
        bpy.ops.preferences.addon_install(filepath=spec["zip"])
        bpy.ops.preferences.addon_enable(module="elastic_motion_addon")
        prefs = bpy.context.preferences.addons["elastic_motion_addon"].preferences
        out["default_executable"] = prefs.executable
        if spec.get("exe"):
            prefs.executable = spec["exe"]
        settings = bpy.context.scene.elastic_motion
        for sc in spec["scenarios"]:
            out[sc["name"]] = scenario(sc, settings)
        if spec.get("import_file"):
            out["import"] = check_import(spec["import_file"])
    except Exception:
        out["exception"] = traceback.format_exc()
    print("EMRESULT " + json.dumps(out))


def check_import(path):
    """The add-on's own BVH import (no 'rU' patch here): an armature with an action."""
    if "import_bvh" not in dir(bpy.ops.elastic_motion):
        return {"status": ["MISSING"]}
    before = set(bpy.data.objects)
    try:
        status = sorted(bpy.ops.elastic_motion.import_bvh(filepath=path, global_scale=0.01))
    except RuntimeError as exc:
        return {"status": ["ERROR"], "message": str(exc)}
    new = [o for o in bpy.data.objects if o not in before and o.type == "ARMATURE"]
    arm = new[0] if new else None
    action = arm.animation_data.action if arm and arm.animation_data else None
    return {
        "status": status,
        "bones": len(arm.data.bones) if arm else 0,
        "frames": round(action.frame_range[1] - action.frame_range[0]) + 1 if action else 0,
        "in_import_menu": any(
            getattr(f, "__module__", "").startswith("elastic_motion_addon")
            for f in getattr(bpy.types.TOPBAR_MT_file_import.draw, "_draw_funcs", ())
        ),
        "blender_own_import": blender_own_import(path),
    }


def blender_own_import(path):
    """Blender's own BVH import, unpatched: "FINISHED", or its error (Debian's 3.4.1: 'rU')."""
    try:
        return " ".join(sorted(bpy.ops.import_anim.bvh(filepath=path)))
    except Exception as exc:  # what the menu would show
        return f"{type(exc).__name__}: {exc}"


if __name__ == "__main__":
    main()
