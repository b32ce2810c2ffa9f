"""Our glTF files in other programs' loaders: Blender's importer (headless) and three.js'
``GLTFLoader`` (node). Joint world positions at a few frames equal our forward kinematics to
1e-5 of the skeleton size. And Blender's export of what it imported (a foreign layout: bones
with rest rotations, a translation key on every bone) reads back here as the same motion.
One launch of each program for the module (module fixtures).

Skipped without ``blender`` on PATH; without ``node`` or three.js. three.js is looked for in
``$ELASTIC_MOTION_THREE_DIR`` (default ``~/.cache/elastic-motion-test-node``), outside the
repository; get it with ``npm install --prefix ~/.cache/elastic-motion-test-node three``.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pygltflib")

from elastic_motion.motion import (
    forward_kinematics,
    read_gltf,
    read_motion,
    select_frames,
    to_metres,
    write_gltf,
)

sys.path.insert(0, str(Path(__file__).parent))
from gltf_testlib import size_of, synthetic_motion

CHECK_FRAMES = (0, 7, 23)

BLENDER_SCRIPT = r"""
import json, sys
argv = sys.argv[sys.argv.index("--") + 1:]
jobs, out, shim = json.loads(argv[0]), argv[1], argv[2]
try:
    import numpy  # the glTF importer needs it; Debian's Blender may lack it
except ImportError:
    sys.path.insert(0, shim)
import bpy
results = []
for path, fps, frames in jobs:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.context.scene.render.fps = fps  # keys land on whole frames: Blender frame f = our frame f
    bpy.ops.import_scene.gltf(filepath=path)
    arm = next(o for o in bpy.context.scene.objects if o.type == "ARMATURE")
    res = {"names": [b.name for b in arm.pose.bones], "frames": []}
    for f in frames:
        bpy.context.scene.frame_set(f)
        res["frames"].append([list(arm.matrix_world @ b.head) for b in arm.pose.bones])
    # and Blender's own export of it: bones with rest rotations, keys on every bone
    bpy.ops.export_scene.gltf(filepath=path + ".blender.glb", export_format="GLB", export_animations=True)
    results.append(res)
json.dump(results, open(out, "w"))
"""

THREE_SCRIPT = r"""
import fs from 'node:fs';
const [dir, jobsJson] = process.argv.slice(2);
const THREE = await import(dir + '/node_modules/three/build/three.module.js');
const { GLTFLoader } = await import(dir + '/node_modules/three/examples/jsm/loaders/GLTFLoader.js');
const results = [];
for (const [path, times] of JSON.parse(jobsJson)) {
  const buf = fs.readFileSync(path);
  const data = buf.buffer.slice(buf.byteOffset, buf.byteOffset + buf.byteLength);
  const gltf = await new GLTFLoader().parseAsync(data, '');
  const bones = [];
  gltf.scene.traverse((o) => { if (o.isBone) bones.push(o); });
  const mixer = new THREE.AnimationMixer(gltf.scene);
  mixer.clipAction(gltf.animations[0]).play();
  const res = { names: bones.map((b) => b.name), frames: [] };
  for (const t of times) {
    mixer.setTime(t);
    gltf.scene.updateMatrixWorld(true);
    res.frames.push(bones.map((b) => b.getWorldPosition(new THREE.Vector3()).toArray()));
  }
  results.push(res);
}
process.stdout.write(JSON.stringify(results));
"""


@pytest.fixture(scope="module")
def written(tmp_path_factory, request):
    """Our .glb files and the motions written: a synthetic figure (a joint sliding on
    position channels) and, when the shared data is there, a CMU walk."""
    folder = tmp_path_factory.mktemp("gltf_loaders")
    motions = [synthetic_motion(frames=30, fps=30.0)]
    try:
        cmu = request.getfixturevalue("mocap_dir") / "cmu" / "bvh" / "01_01.bvh"
    except pytest.skip.Exception:  # no shared data: the synthetic figure only
        cmu = None
    if cmu is not None and cmu.is_file():
        motions.append(select_frames(read_motion(cmu), slice(100, 160)))
    # compared with our forward kinematics of the motion written (in metres, as glTF is)
    return [(write_gltf(m, folder / f"clip{k}.glb"), to_metres(m)) for k, m in enumerate(motions)]


def _compare(motion, names, frames, positions, to_y_up=lambda p: p):
    idx = [motion.skeleton.index(n) for n in names]
    want = forward_kinematics(motion)[list(frames)][:, idx]
    got = to_y_up(np.array(positions))
    err = np.abs(got - want).max()
    assert err <= 1e-5 * size_of(motion), f"{motion.name}: {err:.3g} m"
    return err


@pytest.fixture(scope="module")
def blender_results(written, tmp_path_factory):
    blender = shutil.which("blender")
    if blender is None:
        pytest.skip("blender not on PATH")
    folder = tmp_path_factory.mktemp("blender")
    shim = folder / "numpy_shim"  # this Python's numpy, for a Blender without one (same 3.x)
    shim.mkdir()
    numpy_dir = Path(np.__file__).parent
    for name in (numpy_dir.name, f"{numpy_dir.name}.libs"):
        if (numpy_dir.parent / name).exists():
            (shim / name).symlink_to(numpy_dir.parent / name)
    jobs = [[str(p), int(m.fps), list(CHECK_FRAMES)] for p, m in written]
    out = folder / "out.json"
    cmd = [
        blender,
        "-b",
        "--factory-startup",
        "--python-expr",
        BLENDER_SCRIPT,
        "--",
        json.dumps(jobs),
        str(out),
        str(shim),
    ]
    run = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    if not out.is_file():
        if "No module named 'numpy'" in run.stdout + run.stderr:
            pytest.skip("Blender's Python has no numpy (its glTF importer needs it)")
        pytest.fail(f"Blender import failed:\n{run.stdout[-3000:]}\n{run.stderr[-3000:]}")
    return json.loads(out.read_text())


@pytest.fixture(scope="module")
def three_results(written, tmp_path_factory):
    node = shutil.which("node")
    three = Path(
        os.environ.get("ELASTIC_MOTION_THREE_DIR", Path.home() / ".cache" / "elastic-motion-test-node")
    )
    if node is None:
        pytest.skip("node not on PATH")
    if not (three / "node_modules" / "three" / "examples" / "jsm" / "loaders" / "GLTFLoader.js").is_file():
        pytest.skip(f"three.js not in {three} (npm install --prefix {three} three)")
    script = tmp_path_factory.mktemp("three") / "load.mjs"
    script.write_text(THREE_SCRIPT)
    jobs = [[str(p), [f / m.fps for f in CHECK_FRAMES]] for p, m in written]
    run = subprocess.run(
        [node, str(script), str(three), json.dumps(jobs)], capture_output=True, text=True, timeout=120
    )
    assert run.returncode == 0, run.stderr[-3000:]
    return json.loads(run.stdout)


def test_blender_imports_our_gltf_with_our_joint_positions(written, blender_results):
    def z_up_to_y_up(p):  # Blender's importer: glTF (x, y, z) -> Blender (x, -z, y)
        return np.stack([p[..., 0], p[..., 2], -p[..., 1]], axis=-1)

    for (_, motion), res in zip(written, blender_results, strict=True):
        assert sorted(res["names"]) == sorted(motion.skeleton.names)
        _compare(motion, res["names"], CHECK_FRAMES, res["frames"], z_up_to_y_up)


def test_blender_export_reads_back_as_the_motion(written, blender_results):
    for path, motion in written:
        back = read_gltf(f"{path}.blender.glb")
        assert back.fps == motion.fps and back.n_frames == motion.n_frames
        idx = [back.skeleton.index(n) for n in motion.skeleton.names]
        err = np.abs(forward_kinematics(back)[:, idx] - forward_kinematics(motion)).max()
        assert err <= 1e-5 * size_of(motion), f"{motion.name}: {err:.3g} m"
        # position channels only where the motion has them (Blender keys every bone's translation)
        moving = {
            n for n, h in zip(back.skeleton.names, back.skeleton.has_position_channels, strict=True) if h
        }
        sliding = {"Hips"} | ({"LShin"} if "LShin" in motion.skeleton.names else set())
        assert moving == sliding


def test_three_js_loads_our_gltf_with_our_joint_positions(written, three_results):
    for (_, motion), res in zip(written, three_results, strict=True):
        assert sorted(res["names"]) == sorted(motion.skeleton.names)
        _compare(motion, res["names"], CHECK_FRAMES, res["frames"])
