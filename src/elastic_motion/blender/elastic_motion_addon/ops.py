"""The add-on's preferences, properties, operators and panel (needs ``bpy``)."""

from __future__ import annotations

import builtins
import contextlib
import json
import os
import shutil
import tempfile
import textwrap

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty

from . import runner

ADDON = __package__
REPORT_TEXT = "elastic-motion report"

_WARPS = [
    ("dp", "DP", "optimal time warp by dynamic programming on a grid (the default)"),
    ("dp+refine", "DP + refine", "the DP warp refined off the grid by gradient descent"),
    ("none", "none", "no time warp (frame by frame in curve parameter)"),
]


def _default_executable():
    return shutil.which("elastic-motion") or "elastic-motion"


class EMPreferences(bpy.types.AddonPreferences):
    bl_idname = ADDON

    executable: StringProperty(
        name="elastic-motion command",
        description="Path of the elastic-motion command of the environment where it is installed "
        "(`which elastic-motion` there)",
        subtype="FILE_PATH",
        default=_default_executable(),
    )
    timeout: IntProperty(
        name="Time limit (s)", description="Stop a run after this many seconds", default=600, min=10
    )
    keep_files: BoolProperty(
        name="Keep files",
        description="Keep the exported and written BVH files and the reports, in a new private "
        "folder of the system's temporary folder for each run (named in the run's status)",
        default=False,
    )

    def draw(self, context):
        col = self.layout.column()
        col.prop(self, "executable")
        col.prop(self, "timeout")
        col.prop(self, "keep_files")


class EMSettings(bpy.types.PropertyGroup):
    weight: FloatProperty(
        name="Weight", description="s: the result is (1-s) A + s B", default=0.5, min=0.0, max=1.0
    )
    warp: EnumProperty(name="Warp", items=_WARPS, default="dp")
    landmarks: StringProperty(
        name="Landmarks", description="'auto', or pairs in seconds 'a1:b1,a2:b2' (empty: none)", default=""
    )
    cleanup: BoolProperty(name="Clean-up", description="Plant the feet again after blending", default=True)
    window: EnumProperty(
        name="Window",
        items=[
            ("safe", "safe", "the whole action when it loops with little change, else its best cycle"),
            ("whole", "whole clip", "loop the whole action"),
            ("auto", "best cycle", "the cycle that loops best"),
        ],
        default="safe",
    )
    force: BoolProperty(
        name="Force",
        description="Loop even when looping changes the action more than the command allows",
        default=False,
    )
    contacts: BoolProperty(name="Contacts", description="Keep the feet planted while looping", default=True)
    root: EnumProperty(
        name="Root",
        items=[
            ("travel", "travel", "keep one cycle's displacement and turn"),
            ("inplace", "in place", "come back"),
        ],
        default="travel",
    )
    extra: StringProperty(name="More options", description="More command-line options, as typed", default="")
    last_report: StringProperty(name="Last report", default="")
    last_status: StringProperty(name="Last status", default="")


# ------------------------------------------------------------------------------------------
# Helpers
# ------------------------------------------------------------------------------------------


def _prefs(context):
    return context.preferences.addons[ADDON].preferences


@contextlib.contextmanager
def _open_without_u():
    """Blender 3.4's BVH importer opens files with mode 'rU', which Python 3.11 removed."""
    original = builtins.open

    def patched(file, mode="r", *args, **kwargs):
        if isinstance(mode, str):
            mode = mode.replace("U", "")
        return original(file, mode, *args, **kwargs)

    builtins.open = patched
    try:
        yield
    finally:
        builtins.open = original


def _armatures(context):
    """Active armature first, then the other selected ones (each with an action)."""
    act = context.active_object
    sel = [o for o in context.selected_objects if o.type == "ARMATURE"]
    if act is not None and act.type == "ARMATURE":
        sel = [act] + [o for o in sel if o != act]
    return [o for o in sel if o.animation_data is not None and o.animation_data.action is not None]


def _select_only(context, obj):
    for o in context.view_layer.objects:
        o.select_set(False)
    obj.select_set(True)
    context.view_layer.objects.active = obj


def _export(context, obj, path):
    act = obj.animation_data.action
    start, end = (round(v) for v in act.frame_range)
    _select_only(context, obj)
    res = bpy.ops.export_anim.bvh(
        filepath=path, frame_start=start, frame_end=end, global_scale=1.0, root_transform_only=True
    )
    if "FINISHED" not in res:
        raise RuntimeError(f"could not export the action of {obj.name} to BVH")
    return start, end


def _bake_onto(context, target, source, name):
    """A new action on ``target`` that puts each bone where ``source``'s bone of the same name is
    (world space), frame by frame: the result's rest pose may differ from the target's (the
    command writes Y-up files), the pose is carried by the bones' world matrices."""
    scene = context.scene
    start, end = (round(v) for v in source.animation_data.action.frame_range)
    action = bpy.data.actions.new(name)
    target.animation_data.action = action
    to_target = target.matrix_world.inverted() @ source.matrix_world
    bones = [pb for pb in target.pose.bones if source.pose.bones.get(pb.name) is not None]
    prev = {}
    for f in range(start, end + 1):
        scene.frame_set(f)
        pose = {pb.name: to_target @ source.pose.bones[pb.name].matrix for pb in bones}
        for pb in bones:  # parents before children (pose.bones is in hierarchy order)
            rest = pb.bone.matrix_local
            m = pose[pb.name]
            if pb.parent is not None and pb.parent.name in pose:
                rest = pb.parent.bone.matrix_local.inverted() @ rest
                m = pose[pb.parent.name].inverted() @ m
            loc, rot, _ = (rest.inverted() @ m).decompose()
            pb.location = loc
            if pb.rotation_mode == "QUATERNION":
                if pb.name in prev:
                    rot.make_compatible(prev[pb.name])
                prev[pb.name] = rot
                pb.rotation_quaternion = rot
                pb.keyframe_insert("rotation_quaternion", frame=f, group=pb.name)
            elif pb.rotation_mode == "AXIS_ANGLE":
                axis, angle = rot.to_axis_angle()
                pb.rotation_axis_angle = (angle, *axis)
                pb.keyframe_insert("rotation_axis_angle", frame=f, group=pb.name)
            else:
                e = (
                    rot.to_euler(pb.rotation_mode, prev[pb.name])
                    if pb.name in prev
                    else rot.to_euler(pb.rotation_mode)
                )
                prev[pb.name] = e
                pb.rotation_euler = e
                pb.keyframe_insert("rotation_euler", frame=f, group=pb.name)
            pb.keyframe_insert("location", frame=f, group=pb.name)
    return action


def _import_action(context, target, path, name):
    """Import ``path`` and carry its motion onto ``target`` as a new action (when every bone
    lands where the result puts it), else keep the imported armature.
    Returns (action, object holding it, message)."""
    before = set(bpy.data.objects)
    with _open_without_u():
        res = bpy.ops.import_anim.bvh(
            filepath=path,
            global_scale=1.0,
            axis_forward="-Z",
            axis_up="Y",
            frame_start=1,
            update_scene_fps=False,
            update_scene_duration=False,
            use_fps_scale=False,
        )
    new = [o for o in bpy.data.objects if o not in before and o.type == "ARMATURE"]
    if "FINISHED" not in res or not new:
        raise RuntimeError(f"Blender could not import the result {path}")
    imported = new[0]
    imported_action = imported.animation_data.action
    old = target.animation_data.action
    scene = context.scene
    frame = scene.frame_current
    action = _bake_onto(context, target, imported, name)
    start, end = (round(v) for v in action.frame_range)
    size = max(max(imported.dimensions), 1e-6)
    worst = 0.0
    for f in sorted({start, (start + end) // 2, end}):
        scene.frame_set(f)
        for pb in target.pose.bones:
            other = imported.pose.bones.get(pb.name)
            if other is None:
                worst = float("inf")
                break
            a = target.matrix_world @ pb.head
            b = imported.matrix_world @ other.head
            worst = max(worst, (a - b).length)
    scene.frame_set(frame)
    if worst <= 1e-3 * size:
        action.use_fake_user = True
        bpy.data.objects.remove(imported, do_unlink=True)
        bpy.data.actions.remove(imported_action)
        return action, target, f"new action {action.name!r} on {target.name}"
    target.animation_data.action = old
    bpy.data.actions.remove(action)
    imported.name = name
    imported_action.name = name
    return (
        imported_action,
        imported,
        (
            f"imported as a new armature {imported.name!r}: its bones do not fit {target.name}'s "
            f"(joints up to {worst:.3g} apart), so the action stays on it"
        ),
    )


def _show_report(context, report, status):
    settings = context.scene.elastic_motion
    text = json.dumps(report, indent=2) if report else ""
    settings.last_report = "\n".join(runner.report_lines(report))
    settings.last_status = status
    block = bpy.data.texts.get(REPORT_TEXT) or bpy.data.texts.new(REPORT_TEXT)
    block.clear()
    block.write(text)


class _Run:
    """Shared body of the operators: temp folder, the run, errors as reports."""

    def _work_dir(self, context):
        """A new folder for this run's files and whether it is removed after the run.

        Always a fresh ``mkdtemp`` (mode 0700, unpredictable name, created by this run, so no
        other user can read it, plant a link in it or swap it), also when the preferences keep
        the files: each run then keeps its own folder, named in the report (:meth:`_kept`).
        """
        keep = _prefs(context).keep_files
        return tempfile.mkdtemp(prefix="elastic_motion_kept_" if keep else "elastic_motion_"), not keep

    def _kept(self, work, temporary):
        """Tell where the files are when they are kept; the note for the status line."""
        if temporary:
            return ""
        self.report({"INFO"}, f"elastic-motion: files kept in {work}")
        return f" (files kept in {work})"

    def _fail(self, context, message, note=""):
        context.scene.elastic_motion.last_status = "error: " + message + note
        self.report({"ERROR"}, "elastic-motion: " + message + note)
        return {"CANCELLED"}

    def _run_and_import(self, context, command, build, target, action_name):
        """Run ``elastic-motion COMMAND`` and import its result as a new action on ``target``.

        ``build(work, help_text) -> (args, warnings, out_path, report_path)`` exports what the
        command reads into the folder ``work`` and makes its command line.
        """
        prefs = _prefs(context)
        work, temporary = self._work_dir(context)
        try:
            args, warnings, out, rep = build(work, runner.command_help(prefs.executable, command))
            res = runner.run_cli(prefs.executable, args, report_path=rep, timeout=prefs.timeout)
            if not res.ok:
                return self._fail(context, res.message, self._kept(work, temporary))
            _, _, msg = _import_action(context, target, out, action_name)
        except runner.CliNotFound as exc:
            return self._fail(context, str(exc), self._kept(work, temporary))
        except RuntimeError as exc:
            return self._fail(context, str(exc), self._kept(work, temporary))
        finally:
            if temporary:
                shutil.rmtree(work, ignore_errors=True)
        for w in warnings:
            self.report({"WARNING"}, w)
        _show_report(context, res.report, msg + self._kept(work, temporary))
        self.report({"INFO"}, msg)
        return {"FINISHED"}


class EM_OT_blend(bpy.types.Operator, _Run):
    """Blend the actions of the active armature (A) and one other selected armature (B)"""

    bl_idname = "elastic_motion.blend"
    bl_label = "Blend"
    bl_options = {"REGISTER", "UNDO"}  # noqa: RUF012 - Blender reads a set

    def execute(self, context):
        arms = _armatures(context)
        if len(arms) != 2:
            return self._fail(context, f"select two armatures with actions (A active); got {len(arms)}")
        s = context.scene.elastic_motion

        def build(work, help_text):
            a, b = (os.path.join(work, f"{k}.bvh") for k in ("A", "B"))
            _export(context, arms[0], a)
            _export(context, arms[1], b)
            out, rep = os.path.join(work, "blend.bvh"), os.path.join(work, "blend.json")
            settings = runner.BlendSettings(
                weight=s.weight, warp=s.warp, landmarks=s.landmarks, cleanup=s.cleanup
            )
            args, warnings = runner.blend_args(
                a, b, out, rep, settings, help_text=help_text, extra=s.extra.split()
            )
            return args, warnings, out, rep

        name = f"{arms[0].animation_data.action.name} x {arms[1].animation_data.action.name} {s.weight:g}"
        return self._run_and_import(context, "blend", build, arms[0], name)


class EM_OT_loop(bpy.types.Operator, _Run):
    """Make the active armature's action loop seamlessly"""

    bl_idname = "elastic_motion.loop"
    bl_label = "Loop"
    bl_options = {"REGISTER", "UNDO"}  # noqa: RUF012 - Blender reads a set

    def execute(self, context):
        arms = _armatures(context)
        if not arms:
            return self._fail(context, "select an armature with an action")
        s = context.scene.elastic_motion

        def build(work, help_text):
            inp = os.path.join(work, "input.bvh")
            _export(context, arms[0], inp)
            out, rep = os.path.join(work, "loop.bvh"), os.path.join(work, "loop.json")
            args, warnings = runner.loop_args(
                inp,
                out,
                rep,
                root=s.root,
                window=s.window,
                contacts=s.contacts,
                help_text=help_text,
                force=s.force,
                extra=s.extra.split(),
            )
            return args, warnings, out, rep

        return self._run_and_import(
            context, "loop", build, arms[0], f"{arms[0].animation_data.action.name} loop"
        )


class EM_OT_distance(bpy.types.Operator, _Run):
    """Elastic distance between the actions of two selected armatures"""

    bl_idname = "elastic_motion.distance"
    bl_label = "Distance"

    def execute(self, context):
        arms = _armatures(context)
        if len(arms) != 2:
            return self._fail(context, f"select two armatures with actions; got {len(arms)}")
        s = context.scene.elastic_motion
        prefs = _prefs(context)
        work, temporary = self._work_dir(context)
        try:
            a, b = (os.path.join(work, f"{k}.bvh") for k in ("A", "B"))
            _export(context, arms[0], a)
            _export(context, arms[1], b)
            res = runner.run_cli(
                prefs.executable, runner.distance_args(a, b, warp=s.warp), timeout=prefs.timeout
            )
            if not res.ok:
                return self._fail(context, res.message, self._kept(work, temporary))
        except runner.CliNotFound as exc:
            return self._fail(context, str(exc), self._kept(work, temporary))
        except RuntimeError as exc:
            return self._fail(context, str(exc), self._kept(work, temporary))
        finally:
            if temporary:
                shutil.rmtree(work, ignore_errors=True)
        lines = runner.report_lines(res.report)
        status = (lines[0] if lines else "distance computed") + self._kept(work, temporary)
        _show_report(context, res.report, status)
        self.report({"INFO"}, lines[0] if lines else "distance computed")
        return {"FINISHED"}


class EM_PT_panel(bpy.types.Panel):
    bl_label = "elastic-motion"
    bl_idname = "EM_PT_panel"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "elastic-motion"

    def draw(self, context):
        s = context.scene.elastic_motion
        layout = self.layout
        box = layout.box()
        box.label(text="Blend: A active, B selected")
        box.prop(s, "weight")
        box.prop(s, "warp")
        box.label(text="Landmarks (auto, a:b,...):")
        box.prop(s, "landmarks", text="")
        box.prop(s, "cleanup")
        box.operator(EM_OT_blend.bl_idname)
        box = layout.box()
        box.label(text="Loop (active armature)")
        box.prop(s, "window", text="Cycle")
        box.prop(s, "force")
        box.prop(s, "contacts")
        box.prop(s, "root", expand=True)
        box.operator(EM_OT_loop.bl_idname)
        box = layout.box()
        box.label(text="Compare two armatures")
        box.operator(EM_OT_distance.bl_idname)
        layout.label(text="More command-line options:")
        layout.prop(s, "extra", text="")
        if s.last_status or s.last_report:
            box = layout.box()
            box.label(text="Last run")
            for line in [s.last_status, *s.last_report.splitlines()]:
                for part in textwrap.wrap(line, 28, subsequent_indent="  "):
                    box.label(text=part)


_CLASSES = (EMPreferences, EMSettings, EM_OT_blend, EM_OT_loop, EM_OT_distance, EM_PT_panel)


def register():
    for cls in _CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.elastic_motion = PointerProperty(type=EMSettings)


def unregister():
    del bpy.types.Scene.elastic_motion
    for cls in reversed(_CLASSES):
        bpy.utils.unregister_class(cls)
