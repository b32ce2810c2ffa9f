"""Written BVH files load in Blender's importer, with the joints where our forward kinematics
puts them. Runs Blender headless; skipped when ``blender`` is not on PATH (Debian: ``apt
install blender``).

Blender 3.4's importer opens the file with mode ``'rU'``, which Python 3.11 removed: the
script wraps ``builtins.open`` to drop the ``U`` before calling ``bpy.ops.import_anim.bvh``
(``docs/motion.md``, "Blender").

Round trip through Blender (import, then ``bpy.ops.export_anim.bvh``, all defaults): the
importer bakes its axis conversion (``axis_forward="-Z", axis_up="Y"``: ``(x, y, z) -> (x,
-z, y)``) into the armature (``transform_apply``), and the exporter writes armature space, so
the exported file is **Z-up**: offsets, rotations relative to that Z-up rest pose, positions
with 6 decimals. ``global_scale`` is 1 both ways, so lengths keep our unit (a metre file
comes back in metres). The exporter writes the scene's frame range (250 frames unless
told): the script passes ``frame_end``.
"""

from __future__ import annotations

import json
import shutil
import subprocess

import numpy as np
import pytest
from blend_testlib import walker

from elastic_motion.apps.blend import blend_motions
from elastic_motion.motion import (
    detect_up_axis,
    drop_tpose,
    forward_kinematics,
    read_bvh,
    read_motion,
    select_frames,
    set_up_axis,
    to_metres,
    trim,
    write_bvh,
)

BLENDER = shutil.which("blender")
pytestmark = pytest.mark.skipif(BLENDER is None, reason="blender is not installed")

SCRIPT = r"""
import builtins, json, sys
import bpy

_open = builtins.open


def _open_without_u(file, mode="r", *args, **kwargs):
    if isinstance(mode, str):
        mode = mode.replace("U", "")
    return _open(file, mode, *args, **kwargs)


builtins.open = _open_without_u
argv = sys.argv[sys.argv.index("--") + 1 :]
path, frames = argv[0], [int(f) for f in argv[1].split(",")]
result = bpy.ops.import_anim.bvh(
    filepath=path, global_scale=1.0, axis_forward="-Z", axis_up="Y",
    update_scene_fps=True, update_scene_duration=True,
)
arms = [o for o in bpy.data.objects if o.type == "ARMATURE"]
arm = arms[-1]
act = arm.animation_data.action
out = {"result": sorted(result), "armatures": len(arms), "bones": len(arm.data.bones),
       "roots": [b.name for b in arm.data.bones if b.parent is None],
       "frame_range": list(act.frame_range), "fps": bpy.context.scene.render.fps, "positions": {}}
for f in frames:
    bpy.context.scene.frame_set(f + 1)
    out["positions"][f] = {b.name: list(arm.matrix_world @ b.head) for b in arm.pose.bones}
print("EMRESULT " + json.dumps(out))
"""


def _import(tmp_path, bvh, frames):
    script = tmp_path / "import_bvh.py"
    script.write_text(SCRIPT)
    proc = subprocess.run(
        [
            BLENDER,
            "-b",
            "--factory-startup",
            "--python",
            str(script),
            "--",
            str(bvh),
            ",".join(map(str, frames)),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    line = next((ln for ln in proc.stdout.splitlines() if ln.startswith("EMRESULT ")), None)
    assert line is not None, f"blender failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}"
    return json.loads(line[len("EMRESULT ") :])


def _check(tmp_path, motion, name):
    path = write_bvh(motion, tmp_path / f"{name}.bvh")
    back = read_bvh(path)
    frames = [0, back.n_frames // 2, back.n_frames - 1]
    out = _import(tmp_path, path, frames)
    assert out["result"] == ["FINISHED"] and out["armatures"] == 1
    assert out["bones"] == back.n_joints
    assert out["roots"] == [back.skeleton.names[0]]  # single root: three.js's BVHLoader reads it too
    assert out["frame_range"] == [1.0, float(back.n_frames)]
    assert out["fps"] == round(back.fps)
    # Blender converts Y-up to Z-up: (x, y, z) -> (x, -z, y)
    p = forward_kinematics(back)
    size = np.ptp(p.reshape(-1, 3), axis=0).max()
    for f in frames:
        for bone, v in out["positions"][str(f)].items():
            q = p[f, back.skeleton.index(bone)]
            assert np.allclose(v, [q[0], -q[2], q[1]], atol=1e-5 * size), (name, f, bone)


def test_synthetic_blend_in_blender(tmp_path):
    a = walker(duration=1.5, name="a")
    b = walker(duration=1.8, freq=1.3, amp=0.7, yaw=0.4, name="b")
    _check(tmp_path, blend_motions([a, b], 0.5, metrics=False).motion, "synthetic")


@pytest.mark.mocap
def test_cmu_blend_in_blender(tmp_path, mocap_dir):
    a = trim(drop_tpose(read_motion(mocap_dir / "cmu/bvh/107_02_30hz.bvh")), 1.0, 3.4)
    b = trim(drop_tpose(read_motion(mocap_dir / "cmu/bvh/108_01_30hz.bvh")), 1.3, 4.8)
    _check(tmp_path, blend_motions([a, b], 0.5, metrics=False).motion, "cmu")


@pytest.mark.mocap
def test_deepmimic_loop_in_blender(tmp_path, mocap_dir):
    from elastic_motion.apps.loop import loop_motion

    m = read_motion(mocap_dir / "deepmimic/humanoid3d_cartwheel.txt")
    _check(tmp_path, loop_motion(m, window=None, force=True).motion, "deepmimic")  # the whole clip


# ------------------------------------------------------------------------------------------
# Blender's export read back: detected Z-up, metres, same joints
# ------------------------------------------------------------------------------------------
EXPORT_SCRIPT = r"""
import builtins, json, sys
import bpy

_open = builtins.open


def _open_without_u(file, mode="r", *args, **kwargs):
    if isinstance(mode, str):
        mode = mode.replace("U", "")
    return _open(file, mode, *args, **kwargs)


builtins.open = _open_without_u
argv = sys.argv[sys.argv.index("--") + 1 :]
src, out, n_frames = argv[0], argv[1], int(argv[2])
imported = bpy.ops.import_anim.bvh(filepath=src, update_scene_fps=True)  # global_scale 1, -Z forward, Y up
arm = [o for o in bpy.data.objects if o.type == "ARMATURE"][-1]
bpy.context.view_layer.objects.active = arm
arm.select_set(True)
exported = bpy.ops.export_anim.bvh(filepath=out, frame_start=1, frame_end=n_frames)  # global_scale 1
print("EMRESULT " + json.dumps({"result": sorted(imported) + sorted(exported),
                                "matrix_world": [list(r) for r in arm.matrix_world]}))
"""


def _blender_round_trip(tmp_path, motion, name):
    src = write_bvh(motion, tmp_path / f"{name}.bvh")
    out = tmp_path / f"{name}_blender.bvh"
    script = tmp_path / "export_bvh.py"
    script.write_text(EXPORT_SCRIPT)
    proc = subprocess.run(
        [BLENDER, "-b", "--factory-startup", "--python", str(script), "--", str(src), str(out)]
        + [str(motion.n_frames)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    line = next((ln for ln in proc.stdout.splitlines() if ln.startswith("EMRESULT ")), None)
    assert line is not None and out.exists(), f"blender failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}"
    info = json.loads(line[len("EMRESULT ") :])
    assert info["result"] == ["FINISHED", "FINISHED"]
    assert np.allclose(info["matrix_world"], np.eye(4))  # the axis conversion is in the armature
    return read_bvh(src), out


def _check_blender_export(tmp_path, motion, name):
    """Blender's export of our metre file: read Z-up in metres; Y-up again, the joints where
    ours are (1e-4 m; measured about 2e-6 m, the exporter's 6 decimals)."""
    ours, out = _blender_round_trip(tmp_path, motion, name)
    back = read_bvh(out)  # default: detect the up axis, guess the unit
    est = detect_up_axis(back)
    assert back.up_axis == "z" and est.direction == "+z" and not est.fallback, est.reason
    assert back.units == "m"  # global_scale 1: our metres stay metres; guess_units finds them
    assert back.n_frames == ours.n_frames and back.fps == ours.fps
    assert back.skeleton.names == ours.skeleton.names
    p_ours = forward_kinematics(ours, end_sites=True)
    p_back = forward_kinematics(set_up_axis(back, "y"), end_sites=True)
    j = ours.n_joints
    err = np.linalg.norm(p_back[:, :j] - p_ours[:, :j], axis=-1)
    assert err.max() < 1e-4, (name, ours.skeleton.names[int(err.max(axis=0).argmax())], err.max())
    # End sites of our file come back in order under the same joints (Blender adds one to a
    # leaf joint that had none).
    sites_back = list(back.skeleton.end_site_parents)
    for e, parent in enumerate(ours.skeleton.end_site_parents):
        k = sites_back.index(parent)
        sites_back[k] = -1
        assert np.linalg.norm(p_back[:, j + k] - p_ours[:, j + e], axis=-1).max() < 1e-4, (name, e)


def test_synthetic_walk_exported_by_blender(tmp_path):
    _check_blender_export(tmp_path, walker(duration=1.0, name="walk"), "walk")


@pytest.mark.mocap
def test_cmu_walk_exported_by_blender(tmp_path, mocap_dir):
    m = drop_tpose(read_bvh(mocap_dir / "cmu/bvh/07_01.bvh"))
    _check_blender_export(tmp_path, to_metres(select_frames(m, slice(0, 120, 3))), "cmu07")
