"""Blender's own BVH exports of shared clips are read Z-up: in full, with
``root_transform_only`` and in place. One Blender launch for the module (headless);
skipped when ``blender`` is not on PATH or the shared data is absent.

Blender always writes Z-up armature space (``tests/apps/test_blender_import.py``). In place:
the bone that carries the travel (the root, or Bandai's hips below a static
``joint_Root``) is held at its mean horizontal position in armature space, its height
kept, and keyed on every frame, as an animator exports a walk cycle. The Bandai old-style
walk is exported over frames 111-155 (1.5 s): in place it was read y (ambiguous, margin
0.22) while the feet were judged still against the world.
"""

from __future__ import annotations

import json
import shutil
import subprocess

import pytest

from elastic_motion.motion import detect_up_axis, read_bvh

BLENDER = shutil.which("blender")
pytestmark = [pytest.mark.skipif(BLENDER is None, reason="blender is not installed"), pytest.mark.mocap]

SCRIPT = r"""
import builtins, json, sys
import bpy

_open = builtins.open


def _open_without_u(file, mode="r", *args, **kwargs):
    if isinstance(mode, str):
        mode = mode.replace("U", "")
    return _open(file, mode, *args, **kwargs)


builtins.open = _open_without_u  # Blender 3.4's importer opens with 'rU'
argv = sys.argv[sys.argv.index("--") + 1 :]
outdir, jobs = argv[0], json.loads(argv[1])
done = []
for name, src, f0, f1 in jobs:
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o, do_unlink=True)
    bpy.ops.import_anim.bvh(filepath=src, update_scene_fps=True, update_scene_duration=True)
    arm = [o for o in bpy.data.objects if o.type == "ARMATURE"][-1]
    bpy.context.view_layer.objects.active = arm
    arm.select_set(True)
    scene = bpy.context.scene
    bpy.ops.export_anim.bvh(filepath=f"{outdir}/{name}_full.bvh", frame_start=f0, frame_end=f1)
    bpy.ops.export_anim.bvh(filepath=f"{outdir}/{name}_root_only.bvh", frame_start=f0, frame_end=f1,
                            root_transform_only=True)
    act = arm.animation_data.action
    moving = [b for b in arm.pose.bones
              if any(fc.data_path == f'pose.bones["{b.name}"].location' for fc in act.fcurves)]
    heads = {}
    for f in range(f0, f1 + 1):
        scene.frame_set(f)
        heads[f] = {b.name: b.matrix.translation.copy() for b in moving}
    def travel(b):
        start = heads[f0][b.name]
        return max(abs(h[b.name].x - start.x) + abs(h[b.name].y - start.y) for h in heads.values())
    most = max(travel(b) for b in moving)  # the shallowest bone that travels
    carrier = min((b for b in moving if travel(b) > 0.5 * most), key=lambda b: len(b.parent_recursive))
    mean_x = sum(heads[f][carrier.name].x for f in heads) / len(heads)
    mean_y = sum(heads[f][carrier.name].y for f in heads) / len(heads)
    for f in range(f0, f1 + 1):
        scene.frame_set(f)
        m = carrier.matrix.copy()
        m.translation.x, m.translation.y = mean_x, mean_y
        carrier.matrix = m
        carrier.keyframe_insert("location", frame=f)
    bpy.ops.export_anim.bvh(filepath=f"{outdir}/{name}_in_place.bvh", frame_start=f0, frame_end=f1)
    done.append([name, carrier.name])
print("EMRESULT " + json.dumps(done))
"""


@pytest.fixture(scope="module")
def exports(mocap_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("blender_upaxis")
    jobs = [
        ["bandai_old", str(mocap_dir / "bandai" / "dataset-1_walk_old_001.bvh"), 111, 155],
        ["bandai_normal", str(mocap_dir / "bandai" / "dataset-1_walk_normal_001.bvh"), 1, 195],
        ["cmu_107_02", str(mocap_dir / "cmu" / "bvh" / "107_02_30hz.bvh"), 2, 200],
    ]
    script = out / "export.py"
    script.write_text(SCRIPT)
    proc = subprocess.run(
        [BLENDER, "-b", "--factory-startup", "--python", str(script), "--", str(out), json.dumps(jobs)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    line = next((ln for ln in proc.stdout.splitlines() if ln.startswith("EMRESULT ")), None)
    assert line is not None, f"blender failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}"
    return out, dict(json.loads(line[len("EMRESULT ") :]))


def test_blender_exports_are_read_z_up(exports):
    out, carriers = exports
    assert carriers == {"bandai_old": "Hips", "bandai_normal": "Hips", "cmu_107_02": "Hips"}
    files = sorted(out.glob("*.bvh"))
    assert len(files) == 9
    for path in files:
        m = read_bvh(path)  # what `info` shows
        est = detect_up_axis(m)
        assert m.up_axis == "z" and est.direction == "+z" and not est.fallback, (path.name, est.reason)
