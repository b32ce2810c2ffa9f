"""The add-on's preferences, properties, operators and panel (needs ``bpy``)."""

from __future__ import annotations

import json
import os
import shutil
import tempfile
import textwrap

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty
from bpy_extras.io_utils import ImportHelper, orientation_helper

from . import runner, transfer

ADDON = __package__
REPORT_TEXT = "elastic-motion report"

_WARPS = [
    ("dp", "DP", "optimal time warp by dynamic programming on a grid (the default)"),
    ("dp+refine", "DP + refine", "the DP warp refined off the grid by gradient descent"),
    ("none", "none", "no time warp (frame by frame in curve parameter)"),
]


# Written into the zip by ``elastic-motion blender-addon``: the absolute path of the command
# that packed it (Blender often runs without the user's environment on its PATH).
COMMAND_FILE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "command.json")


def _default_executable():
    """The command recorded in the zip, else the one on Blender's PATH, else the bare name."""
    try:
        with open(COMMAND_FILE, encoding="utf-8") as fh:
            recorded = json.load(fh).get("command")
        if isinstance(recorded, str) and recorded:
            return recorded
    except (OSError, ValueError, AttributeError):
        pass
    found = shutil.which("elastic-motion")
    return os.path.abspath(found) if found else "elastic-motion"


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


def _armatures(context):
    """Active armature first, then the other selected ones (each with an action)."""
    act = context.active_object
    sel = [o for o in context.selected_objects if o.type == "ARMATURE"]
    if act is not None and act.type == "ARMATURE":
        sel = [act] + [o for o in sel if o != act]
    return [o for o in sel if o.animation_data is not None and o.animation_data.action is not None]


def _selection(context):
    """The selected objects and the active one, to restore after a run."""
    return list(context.selected_objects), context.view_layer.objects.active


def _restore(context, selection):
    selected, active = selection
    for o in context.view_layer.objects:
        o.select_set(o in selected)
    context.view_layer.objects.active = active


def _export(context, obj, path, floor_m=None):
    """Export ``obj``'s action (world space, metres, Z-up: :func:`transfer.export_bvh`, on the
    floor ``floor_m`` when given). Returns the export's figures and warnings (its size, a
    lift)."""
    start, end = (round(v) for v in obj.animation_data.action.frame_range)
    info = transfer.export_bvh(context, obj, path, start, end, floor_m=floor_m)
    k = transfer.metres_per_unit(context.scene)
    h = info["size_m"]
    warnings = []
    if not runner.PLAUSIBLE_SIZE_M[0] <= h <= runner.PLAUSIBLE_SIZE_M[1]:
        warnings.append(
            f"{obj.name} is {h:.3g} m across at this scene's Unit Scale ({k:g} m per unit): elastic-motion "
            "measures contacts and seams in metres; import the clip at its real size (BVH import Scale "
            "0.01 for a file in centimetres)"
        )
    if abs(info["lift_m"]) > runner.FLOOR_NOTE_M:
        warnings.append(
            f"{obj.name}'s motion was moved {info['lift_m']:+.3g} m vertically onto the first armature's "
            "floor for the command (it places B like A across the floor, heights kept)"
        )
    return info, warnings


def _export_pair(context, arms, work):
    """Export A and B (B on A's floor); their paths and the warnings."""
    a, b = (os.path.join(work, f"{k}.bvh") for k in ("A", "B"))
    info, warnings = _export(context, arms[0], a)
    _, more = _export(context, arms[1], b, floor_m=info["floor_m"])
    return a, b, warnings + more


def _import_action(context, target, path, name):
    """Import the result ``path`` (Y-up, metres) and carry its motion onto ``target`` as a new
    action from the first frame of its current one (when every bone lands where the result
    puts it), else keep the imported armature. Returns (action, object holding it, message)."""
    scene = context.scene
    old = target.animation_data.action
    start = round(old.frame_range[0]) if old is not None else 1
    result, imported = transfer.load_bvh(
        context,
        path,
        global_scale=1.0 / transfer.metres_per_unit(scene),
        frame_start=max(start, 1),
        update_scene_fps=False,
        update_scene_duration=False,
        use_fps_scale=False,
    )
    if "FINISHED" not in result or imported is None:
        raise RuntimeError(f"Blender could not import the result {path}")
    imported_action = imported.animation_data.action
    frame = scene.frame_current
    saved = transfer.save_pose(target)
    try:
        action = transfer.bake_onto(context, target, imported, name, start)
    except Exception:
        target.animation_data.action = old
        transfer.restore_pose(target, saved)
        bpy.data.objects.remove(imported, do_unlink=True)
        raise
    a_start, a_end = (round(v) for v in action.frame_range)
    size = max(max(imported.dimensions), 1e-6)
    worst = 0.0
    for f in sorted({a_start, (a_start + a_end) // 2, a_end}):
        scene.frame_set(f)
        for pb in target.pose.bones:
            other = imported.pose.bones.get(pb.name)
            if other is not None:
                worst = max(
                    worst, ((target.matrix_world @ pb.head) - (imported.matrix_world @ other.head)).length
                )
    scene.frame_set(frame)
    if worst <= 1e-3 * size:
        action.use_fake_user = True
        bpy.data.objects.remove(imported, do_unlink=True)
        bpy.data.actions.remove(imported_action)
        return action, target, f"new action {action.name!r} on {target.name}"
    target.animation_data.action = old
    transfer.restore_pose(target, saved)
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
        command reads into the folder ``work`` and makes its command line (the options that
        say what the exported files are, :func:`runner.input_args`, are added here).
        """
        prefs = _prefs(context)
        work, temporary = self._work_dir(context)
        selection = _selection(context)
        try:
            help_text = runner.command_help(prefs.executable, command)
            args, warnings, out, rep = build(work, help_text)
            extra, more = runner.input_args(help_text)
            args = runner.insert_options(args, extra)
            res = runner.run_cli(prefs.executable, args, report_path=rep, timeout=prefs.timeout)
            if not res.ok:
                return self._fail(context, res.message, self._kept(work, temporary))
            _, _, msg = _import_action(context, target, out, action_name)
        except runner.CliNotFound as exc:
            return self._fail(context, str(exc), self._kept(work, temporary))
        except RuntimeError as exc:
            return self._fail(context, str(exc), self._kept(work, temporary))
        finally:
            _restore(context, selection)
            if temporary:
                shutil.rmtree(work, ignore_errors=True)
        for w in [*warnings, *more]:
            self.report({"WARNING"}, w)
        _show_report(context, res.report, msg + self._kept(work, temporary))
        self.report({"INFO"}, runner.status_line(command, msg, res.report))
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
            a, b, warnings = _export_pair(context, arms, work)
            out, rep = os.path.join(work, "blend.bvh"), os.path.join(work, "blend.json")
            settings = runner.BlendSettings(
                weight=s.weight, warp=s.warp, landmarks=s.landmarks, cleanup=s.cleanup
            )
            args, more = runner.blend_args(
                a, b, out, rep, settings, help_text=help_text, extra=s.extra.split()
            )
            return args, warnings + more, out, rep

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
            warnings = _export(context, arms[0], inp)[1]
            out, rep = os.path.join(work, "loop.bvh"), os.path.join(work, "loop.json")
            settings = runner.LoopSettings(root=s.root, window=s.window, contacts=s.contacts, force=s.force)
            args, more = runner.loop_args(inp, out, rep, settings, help_text=help_text, extra=s.extra.split())
            return args, warnings + more, out, rep

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
        selection = _selection(context)
        try:
            a, b, warnings = _export_pair(context, arms, work)
            extra, more = runner.input_args(runner.command_help(prefs.executable, "distance"), writes=False)
            args = runner.insert_options(runner.distance_args(a, b, warp=s.warp), extra)
            res = runner.run_cli(prefs.executable, args, timeout=prefs.timeout)
            if not res.ok:
                return self._fail(context, res.message, self._kept(work, temporary))
        except runner.CliNotFound as exc:
            return self._fail(context, str(exc), self._kept(work, temporary))
        except RuntimeError as exc:
            return self._fail(context, str(exc), self._kept(work, temporary))
        finally:
            _restore(context, selection)
            if temporary:
                shutil.rmtree(work, ignore_errors=True)
        for w in [*warnings, *more]:
            self.report({"WARNING"}, w)
        lines = runner.report_lines(res.report)
        status = (lines[0] if lines else "distance computed") + self._kept(work, temporary)
        _show_report(context, res.report, status)
        self.report({"INFO"}, "elastic-motion " + (lines[0] if lines else "distance computed"))
        return {"FINISHED"}


@orientation_helper(axis_forward="-Z", axis_up="Y")
class EM_OT_import_bvh(bpy.types.Operator, ImportHelper):
    """Import a BVH file as an armature with its action (Blender's importer; works on Blender
    builds whose own BVH import fails with "invalid mode: 'rU'", such as Debian's 3.4.1)"""

    bl_idname = "elastic_motion.import_bvh"
    bl_label = "Import BVH (elastic-motion)"
    bl_options = {"REGISTER", "UNDO"}  # noqa: RUF012 - Blender reads a set

    filename_ext = ".bvh"
    filter_glob: StringProperty(default="*.bvh", options={"HIDDEN"})
    global_scale: FloatProperty(
        name="Scale",
        description="Scale the BVH by this value (0.01 for a file in centimetres, 0.056444 for CMU units)",
        min=1e-6,
        max=1e6,
        soft_min=0.001,
        soft_max=100.0,
        default=1.0,
    )
    frame_start: IntProperty(name="Start Frame", description="Starting frame for the animation", default=1)
    update_scene_fps: BoolProperty(
        name="Update Scene FPS", description="Set the scene's frame rate to the file's", default=True
    )
    update_scene_duration: BoolProperty(
        name="Update Scene Duration", description="Extend the scene's duration to the file's", default=True
    )
    rotate_mode: EnumProperty(
        name="Rotation",
        items=[
            ("NATIVE", "Euler (Native)", "the rotation order of the file"),
            ("QUATERNION", "Quaternion", "convert rotations to quaternions"),
            ("XYZ", "Euler (XYZ)", "convert rotations to Euler XYZ"),
        ],
        default="NATIVE",
    )

    def execute(self, context):
        try:
            result, arm = transfer.load_bvh(
                context,
                self.filepath,
                report=self.report,
                axis_forward=self.axis_forward,
                axis_up=self.axis_up,
                global_scale=self.global_scale,
                frame_start=self.frame_start,
                update_scene_fps=self.update_scene_fps,
                update_scene_duration=self.update_scene_duration,
                rotate_mode=self.rotate_mode,
            )
        except (OSError, ValueError, IndexError, RuntimeError) as exc:
            self.report({"ERROR"}, f"elastic-motion: could not import {self.filepath}: {exc}")
            return {"CANCELLED"}
        if arm is not None:
            self.report({"INFO"}, f"elastic-motion: imported {arm.name} ({len(arm.data.bones)} bones)")
        return result


def _import_menu(self, context):
    self.layout.operator(EM_OT_import_bvh.bl_idname, text="Motion Capture (.bvh, elastic-motion)")


class EM_PT_panel(bpy.types.Panel):
    bl_label = "elastic-motion"
    bl_idname = "EM_PT_panel"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "elastic-motion"

    def draw(self, context):
        s = context.scene.elastic_motion
        layout = self.layout
        layout.operator(EM_OT_import_bvh.bl_idname, text="Import BVH", icon="IMPORT")
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


_CLASSES = (
    EMPreferences,
    EMSettings,
    EM_OT_blend,
    EM_OT_loop,
    EM_OT_distance,
    EM_OT_import_bvh,
    EM_PT_panel,
)


def register():
    for cls in _CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.elastic_motion = PointerProperty(type=EMSettings)
    bpy.types.TOPBAR_MT_file_import.append(_import_menu)


def unregister():
    bpy.types.TOPBAR_MT_file_import.remove(_import_menu)
    del bpy.types.Scene.elastic_motion
    for cls in reversed(_CLASSES):
        bpy.utils.unregister_class(cls)
