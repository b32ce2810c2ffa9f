"""The Blender add-on: packing, its command lines (no Blender needed), and a headless run in
Debian's Blender 3.4 (skipped when ``blender`` is not on PATH): the add-on installs and
registers, Blend and Loop run on two imported CMU clips and leave a new action with the
report's frame count, and failing runs (a bad option, a wrong command path) come back as
Blender error reports with the command's message."""

from __future__ import annotations

import json
import os
import re
import shutil
import stat
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import pytest
from blender_testlib import check_stands_where_the_input_stood

from elastic_motion.blender import ADDON_NAME, COMMAND_FILE, addon_files, pack_addon
from elastic_motion.cli import main
from elastic_motion.cli_commands.blender_addon import running_command

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "src" / "elastic_motion" / "blender"))
from elastic_motion_addon import runner

BLENDER = shutil.which("blender")
CLI = shutil.which("elastic-motion")


def test_pack_addon_zip(tmp_path, capsys):
    code = main(["blender-addon", "-o", str(tmp_path / "addon.zip")])
    assert code == 0
    printed = capsys.readouterr().out
    exe = running_command()
    assert exe is not None and os.path.isabs(exe)  # the console script beside this interpreter
    assert f"'elastic-motion command' preference is set to: {exe}" in printed
    with zipfile.ZipFile(tmp_path / "addon.zip") as zf:
        names = sorted(zf.namelist())
        assert names == sorted(
            [f"{ADDON_NAME}/{p.name}" for p in addon_files()] + [f"{ADDON_NAME}/{COMMAND_FILE}"]
        )
        init = zf.read(f"{ADDON_NAME}/__init__.py").decode()
        assert json.loads(zf.read(f"{ADDON_NAME}/{COMMAND_FILE}")) == {"command": exe}
    assert "bl_info" in init and "def register" in init
    # the same bytes twice (fixed dates): reproducible
    pack_addon(tmp_path / "again.zip", command=exe)
    assert (tmp_path / "again.zip").read_bytes() == (tmp_path / "addon.zip").read_bytes()
    assert main(["blender-addon", "-o", str(tmp_path / "addon.tar")]) == 2


def test_running_command_is_an_absolute_path(tmp_path, monkeypatch):
    """The add-on's default command: the console script that runs (``sys.argv[0]``, made
    absolute: started as ``./venv/bin/elastic-motion``), else the one beside the interpreter
    (``python -m``, or a test runner), else the one on PATH; never a bare name."""
    venv = tmp_path / "venv" / "bin"
    venv.mkdir(parents=True)
    script = venv / "elastic-motion"
    script.write_text("#!/bin/sh\n")
    script.chmod(0o755)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("PATH", "/nonexistent")
    assert running_command("venv/bin/elastic-motion", "/usr/bin/python3") == str(script)
    # not the command (pytest, python -m): the script beside the venv's interpreter (a link
    # to the system's python, kept as it is: resolving it would leave the venv)
    (venv / "python").symlink_to(sys.executable)
    assert running_command("/usr/lib/python3/pytest", str(venv / "python")) == str(script)
    assert running_command("/usr/lib/python3/pytest", "/nonexistent/python") is None
    monkeypatch.setenv("PATH", str(venv))
    assert running_command("/usr/lib/python3/pytest", "/nonexistent/python") == str(script)


def test_addon_uses_no_numpy():
    for f in addon_files():
        text = f.read_text()
        for mod in ("numpy", "numba", "scipy", "elastic_motion."):
            assert f"import {mod}" not in text and f"from {mod}" not in text, (f.name, mod)


HELP = """usage: elastic-motion blend [-h] -o OUTPUT [--weight WEIGHT] [--warp {none,dp,dp+refine}]
                            [--contacts {auto,off}] [--skeleton {blend,first}]
  --window WINDOW       the cycle
"""
LOOP_HELP = """usage: elastic-motion loop [-h] -o OUTPUT [--window {whole,auto}]
                           [--contacts {keep,report,off}]
"""
SAFE_LOOP_HELP = """usage: elastic-motion loop [-h] -o OUTPUT [--window {safe,whole,auto}] [--force]
                           [--contacts {keep,report,off}]
"""


def test_runner_reads_options_from_help():
    assert runner.option_choices(HELP, "--contacts") == ["auto", "off"]
    assert (
        runner.option_choices(HELP, "--window") == ["WINDOW"] or runner.option_choices(HELP, "--window") == []
    )
    assert runner.option_choices(HELP, "--no-contacts") is None
    assert runner.option_choices(HELP, "--warp") == ["none", "dp", "dp+refine"]
    args, warn = runner.blend_args(
        "a.bvh",
        "b.bvh",
        "o.bvh",
        "r.json",
        weight=0.3,
        warp="dp",
        landmarks="auto",
        cleanup=False,
        help_text=HELP,
    )
    assert args[args.index("--contacts") + 1] == "off" and not warn
    assert args[args.index("--weight") + 1] == "0.3" and args[args.index("--skeleton") + 1] == "first"
    args, warn = runner.blend_args(
        "a", "b", "o", "r", weight=0.5, warp="dp", landmarks="", cleanup=False, help_text="usage: blend"
    )
    assert "--contacts" not in args and warn  # an older CLI: said, not passed
    args, warn = runner.loop_args(
        "i", "o", "r", root="inplace", window="auto", contacts=False, help_text=LOOP_HELP
    )
    assert args[args.index("--window") + 1] == "auto" and args[args.index("--contacts") + 1] == "off"
    assert args[args.index("--root") + 1] == "inplace" and not warn
    # the panel's "Keep the feet planted": the loop keeps the contacts (it passed 'report',
    # which only measures them)
    args, warn = runner.loop_args(
        "i", "o", "r", root="travel", window="whole", contacts=True, help_text=LOOP_HELP
    )
    assert args[args.index("--contacts") + 1] == "keep" and not warn
    # the safe window (the panel's default) and --force, on a command that has them; an older
    # command loops the whole clip and says it has no safe window
    args, warn = runner.loop_args(
        "i", "o", "r", root="travel", window="safe", contacts=True, force=True, help_text=SAFE_LOOP_HELP
    )
    assert args[args.index("--window") + 1] == "safe" and "--force" in args and not warn
    args, warn = runner.loop_args(
        "i", "o", "r", root="travel", window="safe", contacts=True, force=True, help_text=LOOP_HELP
    )
    assert "--window" not in args and "--force" not in args
    assert any("safe" in w for w in warn) and any("--force" in w for w in warn)
    settings = runner.LoopSettings(root="inplace", window="auto", contacts=False)
    assert runner.loop_args("i", "o", "r", settings, help_text=SAFE_LOOP_HELP) == runner.loop_args(
        "i", "o", "r", root="inplace", window="auto", contacts=False, help_text=SAFE_LOOP_HELP
    )
    with pytest.raises(TypeError, match="windw"):
        runner.loop_args("i", "o", "r", windw="auto", help_text=SAFE_LOOP_HELP)
    # the blend settings as one object: the same command line as the keywords
    settings = runner.BlendSettings(weight=0.3, warp="dp", landmarks="auto", cleanup=False)
    assert runner.blend_args(
        "a.bvh", "b.bvh", "o.bvh", "r.json", settings, help_text=HELP
    ) == runner.blend_args(
        "a.bvh",
        "b.bvh",
        "o.bvh",
        "r.json",
        weight=0.3,
        warp="dp",
        landmarks="auto",
        cleanup=False,
        help_text=HELP,
    )
    args, _ = runner.blend_args(
        "a", "b", "o", "r", settings, weight=0.7, help_text=HELP
    )  # a keyword overrides
    assert args[args.index("--weight") + 1] == "0.7" and args[args.index("--warp") + 1] == "dp"
    with pytest.raises(TypeError, match="unknown settings"):
        runner.blend_args("a", "b", "o", "r", wieght=0.3, help_text=HELP)


def test_runner_says_what_the_exported_files_are():
    """Blender's world is Z-up and the add-on writes metres: said to the command (before the
    panel's More options, which still override), not left to its guesses; an older command
    without the options gets a warning."""
    help_text = "usage: elastic-motion loop [--units UNIT] [--up {x,y,z}] [--units-out UNIT]"
    assert runner.input_args(help_text) == (["--up", "z", "--units", "m", "--units-out", "m"], [])
    assert runner.input_args(help_text, writes=False) == (["--up", "z", "--units", "m"], [])
    args, warnings = runner.input_args("usage: elastic-motion loop [--units-out UNIT]")
    assert args == ["--units-out", "m"] and "--up, --units" in warnings[0]
    line = runner.insert_options(["loop", "in.bvh", "-o", "o.bvh", "--up", "y"], ["--up", "z"])
    assert line == ["loop", "--up", "z", "in.bvh", "-o", "o.bvh", "--up", "y"]
    report = {"command": "loop", "frames": 91, "fps": 30.0, "notes": ["window: the whole clip"]}
    report["seam_after"] = {"seam_angle_max_deg": 1e-9, "seam_position_max_m": 2e-12}
    status = runner.status_line("loop", "new action 'walk loop' on walk", report)
    assert status == (
        "elastic-motion loop: new action 'walk loop' on walk; loop: 91 frames at 30.0 fps; "
        "seam after: 1e-09 deg, 2e-12 m"
    )


def test_runner_errors():
    err = "usage: ...\nelastic-motion loop: error: --max-iter: expected an integer; got 'abc'\n"
    assert runner.error_message(err, 2) == "--max-iter: expected an integer; got 'abc'"
    with pytest.raises(runner.CliNotFound, match="Preferences > Add-ons > elastic-motion"):
        runner.run_cli("/nonexistent/elastic-motion", ["loop"])


@pytest.mark.skipif(CLI is None, reason="the elastic-motion command is not on PATH")
def test_runner_runs_the_cli(tmp_path):
    res = runner.run_cli(CLI, ["loop", str(tmp_path / "missing.bvh"), "-o", str(tmp_path / "o.bvh")])
    assert not res.ok and res.code == 2 and "missing.bvh" in res.message


# ------------------------------------------------------------------------------------------
# Headless Blender
# ------------------------------------------------------------------------------------------

SCRIPT = r"""
import builtins, json, sys, traceback
import addon_utils, bpy

argv = sys.argv[sys.argv.index("--") + 1 :]
zip_path, exe, a_path, b_path, tests_dir = argv
sys.path.insert(0, tests_dir)
from blender_addon_rigs import measure  # hips start and travel, tilt, floor (m, deg)

out = {}
_open = builtins.open


def _open_without_u(file, mode="r", *args, **kwargs):
    if isinstance(mode, str):
        mode = mode.replace("U", "")
    return _open(file, mode, *args, **kwargs)


def load(path):
    builtins.open = _open_without_u
    try:
        before = set(bpy.data.objects)
        # at the character's real size (CMU units to metres): the add-on passes --units m
        bpy.ops.import_anim.bvh(filepath=path, global_scale=0.056444, update_scene_fps=True)
    finally:
        builtins.open = _open
    return [o for o in bpy.data.objects if o not in before and o.type == "ARMATURE"][0]


def select(active, *others):
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    for o in (active, *others):
        o.select_set(True)
    bpy.context.view_layer.objects.active = active


def run(op):
    try:
        return sorted(op()), ""
    except RuntimeError as exc:  # an operator that reported an error
        return ["ERROR"], str(exc)


def frames(action):
    s, e = action.frame_range
    return int(round(e - s)) + 1


try:
    bpy.ops.preferences.addon_install(filepath=zip_path)
    bpy.ops.preferences.addon_enable(module="elastic_motion_addon")
    out["registered"] = hasattr(bpy.types.Scene, "elastic_motion")
    out["registered"] = out["registered"] and hasattr(bpy.ops.elastic_motion, "blend")
    prefs = bpy.context.preferences.addons["elastic_motion_addon"].preferences
    prefs.executable = exe
    settings = bpy.context.scene.elastic_motion
    a, b = load(a_path), load(b_path)
    out["input_frames"] = [frames(a.animation_data.action), frames(b.animation_data.action)]
    out["input_measures"] = [measure(a, "Hips", "Head"), measure(b, "Hips", "Head")]
    old = a.animation_data.action.name

    select(a, b)
    settings.weight = 0.5
    out["blend"] = run(bpy.ops.elastic_motion.blend)
    rep = json.loads(bpy.data.texts["elastic-motion report"].as_string())
    out["blend_action"] = [a.animation_data.action.name, frames(a.animation_data.action), rep["frames"], old]
    out["blend_status"] = settings.last_status
    out["blend_measure"] = measure(a, "Hips", "Head")
    out["panel_lines"] = settings.last_report.splitlines()

    a.animation_data.action = bpy.data.actions[old]
    select(a)
    n_actions = len(bpy.data.actions)
    out["loop_refused"] = run(bpy.ops.elastic_motion.loop)  # the panel's defaults: the safe window
    out["loop_refused_new_actions"] = len(bpy.data.actions) - n_actions
    settings.force = True
    out["loop"] = run(bpy.ops.elastic_motion.loop)
    settings.force = False
    rep = json.loads(bpy.data.texts["elastic-motion report"].as_string())
    out["loop_action"] = [a.animation_data.action.name, frames(a.animation_data.action), rep["frames"]]
    out["loop_status"] = settings.last_status
    out["loop_measure"] = measure(a, "Hips", "Head")

    select(a, b)
    out["distance"] = run(bpy.ops.elastic_motion.distance)
    out["distance_status"] = settings.last_status
    prefs.keep_files = True  # each run keeps its files in a new private folder it names
    out["kept"] = []
    for _ in range(2):
        select(a, b)
        out["kept"].append([run(bpy.ops.elastic_motion.distance), settings.last_status])
    prefs.keep_files = False

    a.animation_data.action = bpy.data.actions[old]
    select(a)
    settings.extra = "--max-iter abc"
    n_actions = len(bpy.data.actions)
    out["bad_option"] = run(bpy.ops.elastic_motion.loop)
    out["bad_option_new_actions"] = len(bpy.data.actions) - n_actions
    settings.extra = ""
    prefs.executable = "/nonexistent/bin/elastic-motion"
    out["bad_path"] = run(bpy.ops.elastic_motion.loop)
except Exception:
    out["exception"] = traceback.format_exc()
print("EMRESULT " + json.dumps(out))
"""


@pytest.fixture(scope="module")
def blender_run(tmp_path_factory, request):
    if BLENDER is None or CLI is None:
        pytest.skip("blender or the elastic-motion command is not installed")
    mocap_dir = request.getfixturevalue("mocap_dir")
    from elastic_motion.motion import drop_tpose, read_bvh, trim, write_bvh

    tmp = tmp_path_factory.mktemp("blender_addon")
    # two short CMU walks over obstacles (30 Hz, CMU units), as an animator imports them
    a = trim(drop_tpose(read_bvh(mocap_dir / "cmu/bvh/107_02_30hz.bvh")), 1.0, 3.4)
    b = trim(drop_tpose(read_bvh(mocap_dir / "cmu/bvh/108_01_30hz.bvh")), 1.3, 4.8)
    pa, pb = write_bvh(a, tmp / "A_107_02.bvh"), write_bvh(b, tmp / "B_108_01.bvh")
    zip_path = pack_addon(tmp / "addon.zip")
    script = tmp / "run_addon.py"
    script.write_text(SCRIPT)
    env = dict(os.environ)
    env["BLENDER_USER_SCRIPTS"] = str(tmp / "user_scripts")  # the add-on installs here, not in ~
    env["BLENDER_USER_CONFIG"] = str(tmp / "user_config")
    proc = subprocess.run(
        [
            BLENDER,
            "-b",
            "--factory-startup",
            "--python",
            str(script),
            "--",
            str(zip_path),
            CLI,
            str(pa),
            str(pb),
            str(Path(__file__).parent),
        ],
        capture_output=True,
        text=True,
        timeout=540,
        env=env,
    )
    line = next((ln for ln in proc.stdout.splitlines() if ln.startswith("EMRESULT ")), None)
    assert line is not None, f"blender failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    out = json.loads(line[len("EMRESULT ") :])
    assert "exception" not in out, out["exception"]
    return out


@pytest.mark.mocap
def test_addon_registers(blender_run):
    assert blender_run["registered"]


@pytest.mark.mocap
def test_addon_blend_makes_a_new_action(blender_run):
    out = blender_run
    assert out["blend"] == [["FINISHED"], ""], out["blend"]
    name, n, report_frames, old = out["blend_action"]
    assert name != old and name.endswith("0.5"), out["blend_status"]
    assert n == report_frames  # the action has the frames the command wrote
    assert min(out["input_frames"]) <= n <= max(out["input_frames"]) + 1
    assert "new action" in out["blend_status"]  # on the armature itself (its rest pose fits)
    assert out["panel_lines"] and out["panel_lines"][0].startswith("blend:")


@pytest.mark.mocap
def test_addon_loop_makes_a_new_action(blender_run):
    out = blender_run
    # 2.4 s of a walk that is no cycle: closed whole it moves a joint by 0.2 m, and the panel's
    # default (the safe window) refuses it with the command's words and makes no action ...
    status, message = out["loop_refused"]
    assert status == ["ERROR"] and "refused" in message and "--force" in message, message
    assert out["loop_refused_new_actions"] == 0
    # ... which "Force" loops anyway
    assert out["loop"] == [["FINISHED"], ""], out["loop"]
    name, n, report_frames = out["loop_action"]
    assert name.endswith(" loop") and n == report_frames == out["input_frames"][0], out["loop_status"]
    assert "new action" in out["loop_status"]


@pytest.mark.mocap
@pytest.mark.parametrize("op", ["blend", "loop"])
def test_addon_result_stands_where_the_input_stood(blender_run, op):
    """CMU walks (the hips are the top bone), at their real size: the result starts where A
    did, travels as far, stands upright on A's floor (the bounds of
    ``test_blender_addon_rigs.py``, which checks the Bandai and DeepMimic rigs)."""
    check_stands_where_the_input_stood(blender_run[f"{op}_measure"], blender_run["input_measures"], op)


@pytest.mark.mocap
def test_addon_distance(blender_run):
    assert blender_run["distance"] == [["FINISHED"], ""]
    assert blender_run["distance_status"].startswith("distance: ")


@pytest.mark.mocap
def test_addon_reports_the_cli_errors(blender_run):
    status, message = blender_run["bad_option"]
    assert status == ["ERROR"]
    assert "--max-iter: expected an integer; got 'abc'" in message  # the command's own words
    assert "Traceback" not in message and blender_run["bad_option_new_actions"] == 0
    status, message = blender_run["bad_path"]
    assert status == ["ERROR"] and "/nonexistent/bin/elastic-motion" in message
    assert "Preferences > Add-ons > elastic-motion" in message  # where to set it


@pytest.mark.mocap
def test_addon_keeps_files_in_a_new_private_folder_it_names(blender_run):
    """Keep files: never a fixed folder of the system's temporary folder (another user could
    create it first, or link it elsewhere), but a new mkdtemp folder per run, named."""
    folders = []
    for result, status in blender_run["kept"]:
        assert result == [["FINISHED"], ""], result
        m = re.search(r" \(files kept in (.+)\)$", status)
        assert m is not None, status
        folders.append(Path(m.group(1)))
    assert folders[0] != folders[1] and Path(tempfile.gettempdir()) / "elastic_motion" not in folders
    for f in folders:
        st = os.lstat(f)
        assert stat.S_ISDIR(st.st_mode) and stat.S_IMODE(st.st_mode) == 0o700 and st.st_uid == os.getuid()
        assert sorted(p.name for p in f.iterdir()) == ["A.bvh", "B.bvh"]
        shutil.rmtree(f)
