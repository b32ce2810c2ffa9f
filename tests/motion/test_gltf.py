"""glTF 2.0 read and write (elastic_motion.motion.gltf): round trips, foreign layouts, bad files."""

from __future__ import annotations

import struct
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

pytest.importorskip("pygltflib")

from elastic_motion.cli import main
from elastic_motion.errors import ParseError
from elastic_motion.motion import (
    forward_kinematics,
    read_bvh,
    read_gltf,
    read_motion,
    select_frames,
    set_up_axis,
    to_metres,
    write_bvh,
    write_gltf,
    write_motion,
)

sys.path.insert(0, str(Path(__file__).parent))
from gltf_testlib import buffer_bytes, load_json, save_json, set_buffer, size_of, synthetic_motion


def _same(a, b, tol=1e-9):
    """Rotations, root translation, joint translations and skeleton of two motions agree."""
    assert a.n_frames == b.n_frames and a.skeleton.names == b.skeleton.names
    assert np.abs(a.rotations - b.rotations).max() <= tol
    assert np.abs(a.root_translation - b.root_translation).max() <= tol
    assert np.abs(a.local_translations() - b.local_translations()).max() <= tol
    assert a.skeleton.channels == b.skeleton.channels
    assert np.abs(a.skeleton.offsets - b.skeleton.offsets).max() <= tol
    assert np.array_equal(a.skeleton.end_site_parents, b.skeleton.end_site_parents)
    assert np.abs(a.skeleton.end_site_offsets - b.skeleton.end_site_offsets).max() <= tol
    assert a.fps == pytest.approx(b.fps, rel=1e-12)


@pytest.fixture(scope="module")
def synth():
    return synthetic_motion()


@pytest.mark.parametrize("ext", [".glb", ".gltf"])
@pytest.mark.parametrize("up", ["y", "z"])
def test_synthetic_bvh_gltf_bvh_round_trip_is_exact(tmp_path, ext, up):
    m = synthetic_motion(up_axis=up)
    bvh = write_bvh(m, tmp_path / "in.bvh", decimals=12)
    src = read_bvh(bvh, units="cm", up_axis=up)
    out = write_gltf(src, tmp_path / f"x{ext}")
    back = read_gltf(out)
    assert back.metres_per_unit == 1.0 and back.up_axis == "y" and back.source == (str(out),)
    _same(back, set_up_axis(to_metres(src), "y"))
    again = read_bvh(write_bvh(back, tmp_path / "again.bvh", decimals=12), units="m")
    _same(again, set_up_axis(to_metres(src), "y"))


def test_cmu_bvh_gltf_bvh_round_trip_is_exact(tmp_path, mocap_dir):
    src = select_frames(read_motion(mocap_dir / "cmu" / "bvh" / "01_01.bvh"), slice(0, 600))
    back = read_gltf(write_gltf(src, tmp_path / "walk.glb"))
    _same(back, to_metres(src))
    again = read_bvh(write_motion(back, tmp_path / "walk.bvh"), units="m")
    assert again.skeleton.channels == src.skeleton.channels
    assert np.abs(again.rotations - src.rotations).max() < 1e-9
    # positions: BVH's 8 decimals of metres
    assert np.abs(again.root_translation - to_metres(src).root_translation).max() <= 6e-9


def test_positions_from_the_standard_channels_equal_forward_kinematics(tmp_path, synth):
    """Without our extras (what any other program's file is like): float32 keys, 1e-5 of the size."""
    doc = load_json(write_gltf(synth, tmp_path / "a.gltf"))
    del doc["skins"][0]["extras"]
    back = read_gltf(save_json(doc, tmp_path / "b.gltf"))
    want = forward_kinematics(to_metres(synth))
    assert back.n_frames == synth.n_frames and back.fps == pytest.approx(synth.fps, rel=1e-6)
    err = np.abs(forward_kinematics(back) - want).max()
    assert 0 < err < 1e-5 * size_of(to_metres(synth))
    assert back.joint_translations is not None and back.skeleton.has_position_channels[4]


def test_rest_rotations_and_a_scaled_armature_above_the_root(tmp_path, synth):
    """Nodes with rest rotations (Blender's bones) and an armature node (rotation, scale 0.01,
    translation) above the root: world positions kept, rest pose = identity rotations."""
    doc = load_json(write_gltf(synth, tmp_path / "a.gltf"))
    rng = np.random.default_rng(3)
    rest = Rotation.random(len(doc["nodes"]), random_state=4)
    for node, q in zip(doc["nodes"], rest.as_quat(), strict=True):
        node["rotation"] = q.tolist()  # every joint has a rotation channel: the animation is unchanged
    arm = Rotation.from_rotvec(rng.normal(size=3))
    shift = np.array([1.0, -2.0, 0.5])
    doc["nodes"].append(
        {
            "name": "Armature",
            "children": [0],
            "rotation": arm.as_quat().tolist(),
            "scale": [0.01] * 3,
            "translation": shift.tolist(),
        }
    )
    doc["scenes"][0]["nodes"] = [len(doc["nodes"]) - 1]
    back = read_gltf(save_json(doc, tmp_path / "b.gltf"))
    metres = to_metres(synth)
    want = shift + 0.01 * forward_kinematics(metres) @ arm.as_matrix().T
    assert np.abs(forward_kinematics(back) - want).max() < 1e-5 * 0.01 * size_of(metres)
    # the rest pose (identity rotations) is the file's rest pose: offsets are its rest bones
    parents = synth.skeleton.parents
    rest_world = [arm * rest[0]]  # rest world rotation of each node
    for k in range(1, len(parents)):
        rest_world.append(rest_world[parents[k]] * rest[k])
    k = back.skeleton.index("LShin")
    expected = 0.01 * rest_world[parents[k]].apply(np.array(metres.skeleton.offsets[k]))
    assert np.abs(back.skeleton.offsets[k] - expected).max() < 1e-12


def test_step_and_cubic_spline_samplers(tmp_path, synth):
    doc = load_json(write_gltf(synth, tmp_path / "a.gltf"))
    del doc["skins"][0]["extras"]
    anim = doc["animations"][0]
    root_t = next(c for c in anim["channels"] if c["target"] == {"node": 0, "path": "translation"})
    head_r = next(c for c in anim["channels"] if c["target"] == {"node": 2, "path": "rotation"})
    anim["samplers"][root_t["sampler"]]["interpolation"] = "STEP"
    # the head's rotation as a cubic spline: in-tangent, value, out-tangent per key
    data = bytearray(buffer_bytes(doc))
    q = Rotation.from_matrix(to_metres(synth).rotations[:, 2]).as_quat()
    for f in range(1, len(q)):  # continuous signs, as a writer would store them
        q[f] *= np.sign(np.dot(q[f], q[f - 1])) or 1.0
    tangents = np.gradient(q, axis=0) * synth.fps * 3 + np.random.default_rng(5).normal(0, 2, q.shape)
    triples = np.stack([tangents, q, tangents], axis=1).reshape(-1, 4).astype("<f4")
    doc["bufferViews"].append({"buffer": 0, "byteOffset": len(data), "byteLength": triples.nbytes})
    data += triples.tobytes()
    doc["accessors"].append(
        {
            "bufferView": len(doc["bufferViews"]) - 1,
            "componentType": 5126,
            "count": len(triples),
            "type": "VEC4",
        }
    )
    sampler = anim["samplers"][head_r["sampler"]]
    sampler.update(interpolation="CUBICSPLINE", output=len(doc["accessors"]) - 1)
    set_buffer(doc, bytes(data))
    back = read_gltf(save_json(doc, tmp_path / "b.gltf"), fps=2 * synth.fps)
    metres = to_metres(synth)
    assert back.n_frames == 2 * synth.n_frames - 1
    # STEP: the root is at each key's position (a float32 key time just after the sample's
    # time included) and holds it until the next key
    assert np.abs(back.root_translation[0::2] - metres.root_translation).max() < 1e-6
    assert np.abs(back.root_translation[1::2] - metres.root_translation[:-1]).max() < 1e-6
    # CUBICSPLINE: Hermite between the keys, the specification's formula at the half step
    dt = 1 / synth.fps
    mid = 0.5 * q[:-1] + 0.125 * dt * tangents[:-1] + 0.5 * q[1:] - 0.125 * dt * tangents[1:]
    got = Rotation.from_matrix(back.rotations[1::2, 2])
    angle = (got.inv() * Rotation.from_quat(mid)).magnitude()  # radians
    assert angle.max() < 1e-6
    assert (
        Rotation.from_matrix(back.rotations[0::2, 2]).inv() * Rotation.from_quat(q)
    ).magnitude().max() < 1e-6


def test_uneven_keys_are_resampled_to_a_uniform_rate(tmp_path, synth):
    doc = load_json(write_gltf(synth, tmp_path / "a.gltf"))
    del doc["skins"][0]["extras"]
    data = bytearray(buffer_bytes(doc))
    acc = doc["accessors"][doc["animations"][0]["samplers"][0]["input"]]
    view = doc["bufferViews"][acc["bufferView"]]
    times = np.frombuffer(
        bytes(data[view["byteOffset"] : view["byteOffset"] + view["byteLength"]]), "<f4"
    ).copy()
    times[10:] += 0.5 / synth.fps  # one step of 1.5 frames: every channel keeps its values
    data[view["byteOffset"] : view["byteOffset"] + view["byteLength"]] = times.tobytes()
    acc["max"] = [float(times[-1])]
    set_buffer(doc, bytes(data))
    back = read_gltf(save_json(doc, tmp_path / "b.gltf"))
    assert back.fps == pytest.approx(synth.fps, rel=1e-4)
    assert np.allclose(np.arange(back.n_frames) / back.fps, np.arange(back.n_frames) / synth.fps, atol=1e-6)
    assert back.n_frames == synth.n_frames  # the last key is half a frame later: no new frame
    metres = to_metres(synth)
    assert np.abs(back.root_translation[:10] - metres.root_translation[:10]).max() < 1e-6
    # frame 11 lies half way between keys 10 and 11 (shifted): a linear blend of their positions
    half = 0.5 * (metres.root_translation[10] + metres.root_translation[11])
    assert np.abs(back.root_translation[11] - half).max() < 1e-5


def test_cli_blend_reads_and_writes_gltf(tmp_path, synth, capsys):
    """A glTF input and a BVH input blended into a glTF output (the command line's dispatch)."""
    a = write_gltf(synthetic_motion(slide=False), tmp_path / "a.gltf")
    b = write_bvh(synthetic_motion(seed=1, slide=False), tmp_path / "b.bvh")
    out = tmp_path / "ab.glb"
    assert main(["blend", str(a), str(b), "-o", str(out), "--warp", "none", "--units", "cm"]) == 0
    # the head's two BVH rotation channels cannot hold the blend; glTF's quaternions can
    said = "".join(capsys.readouterr())
    assert "fewer than three rotation channels" not in said and "glTF's unit" not in said
    # a unit asked for the output does not apply to glTF (metres by its specification): said
    cm = ["--units-out", "cm"]
    assert main(["blend", str(a), str(b), "-o", str(tmp_path / "c.glb"), "--warp", "none", *cm]) == 0
    assert "written in metres, glTF's unit by its specification (a BVH would be in cm)" in "".join(
        capsys.readouterr()
    )
    assert (
        main(["blend", str(a), str(b), "-o", str(tmp_path / "ab.bvh"), "--warp", "none", "--units", "cm"])
        == 0
    )
    assert "fewer than three rotation channels" in "".join(capsys.readouterr())
    m = read_motion(out)
    assert m.n_joints == synth.n_joints and m.metres_per_unit == 1.0 and m.n_frames > 30
    assert main(["info", str(out)]) == 0
    assert "ab" in capsys.readouterr().out
    wrong = tmp_path / "ab.fbx"
    assert main(["blend", str(a), str(b), "-o", str(wrong), "--warp", "none"]) != 0
    assert ".gltf" in capsys.readouterr().err


def test_without_pygltflib_the_error_names_the_extra(tmp_path, synth, monkeypatch):
    path = write_gltf(synth, tmp_path / "a.glb")
    monkeypatch.setitem(sys.modules, "pygltflib", None)
    with pytest.raises(ModuleNotFoundError, match=r"elastic-motion\[gltf\]"):
        read_gltf(path)
    with pytest.raises(ModuleNotFoundError, match=r"elastic-motion\[gltf\]"):
        write_gltf(synth, tmp_path / "b.glb")


# -- bad files -----------------------------------------------------------------------------------------


def _no_skin(doc):
    del doc["skins"]


def _two_skins(doc):
    doc["skins"].append(dict(doc["skins"][0], name="other"))


def _morph_only(doc):
    doc["animations"][0]["channels"] = [{"sampler": 0, "target": {"node": 0, "path": "weights"}}]


def _no_animation(doc):
    del doc["animations"]


def _missing_buffer(doc):
    doc["buffers"][0]["uri"] = "walk_data.bin"


def _absolute_buffer(doc):
    doc["buffers"][0]["uri"] = "/etc/passwd"


def _huge_accessor(doc):
    acc = doc["accessors"][doc["animations"][0]["samplers"][0]["output"]]
    acc["count"] = 10**12


def _view_past_buffer(doc):
    acc = doc["accessors"][doc["animations"][0]["samplers"][0]["input"]]
    doc["bufferViews"][acc["bufferView"]]["byteLength"] = 10**12


def _zero_quaternion(doc):
    """One rotation key (x, y, z, w) = 0: no rotation at all (found by the mutation fuzzer: the
    slerp between two such keys divided 0 by 0)."""
    anim = doc["animations"][0]
    ch = next(c for c in anim["channels"] if c["target"]["path"] == "rotation")
    acc = doc["accessors"][anim["samplers"][ch["sampler"]]["output"]]
    view = doc["bufferViews"][acc["bufferView"]]
    data = bytearray(buffer_bytes(doc))
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0) + 16  # key 1
    data[start : start + 16] = bytes(16)
    set_buffer(doc, bytes(data))


def _integer_times(doc):
    doc["accessors"][doc["animations"][0]["samplers"][0]["input"]]["componentType"] = 5123


def _sparse(doc):
    acc = doc["accessors"][doc["animations"][0]["samplers"][0]["output"]]
    acc["sparse"] = {
        "count": 1,
        "indices": {"bufferView": 0, "componentType": 5125},
        "values": {"bufferView": 0},
    }


def _interpolation(doc):
    doc["animations"][0]["samplers"][0]["interpolation"] = "BEZIER"


def _glTF1(doc):
    doc["asset"]["version"] = "1.0"


def _asset_not_an_object(doc):
    doc["asset"] = 5


def _boolean_target_nodes(doc):
    for ch in doc["animations"][0]["channels"]:
        ch["target"]["node"] = True  # JSON true, not the node 1


def _joints_not_a_list(doc):
    doc["skins"][0]["joints"] = 5


BAD = [
    (_no_skin, "expected a skin"),
    (_two_skins, "expected one skin; found 2"),
    (_morph_only, "morph target weights only"),
    (_no_animation, "no animations"),
    (_missing_buffer, "walk_data.bin"),
    (_absolute_buffer, "relative to the glTF file"),
    (_huge_accessor, "to fit its bufferView"),
    (_view_past_buffer, "to lie inside buffers[0]"),
    (_integer_times, "expected float components"),
    (_zero_quaternion, "expected unit quaternions"),
    (_sparse, "sparse"),
    (_interpolation, "LINEAR, STEP or CUBICSPLINE"),
    (_glTF1, "glTF 2.0"),
    (_asset_not_an_object, "glTF 2.0"),
    (_boolean_target_nodes, "expected an animation with rotation or translation channels"),
    (_joints_not_a_list, "specification's types"),
]


@pytest.mark.parametrize(("spoil", "expected"), BAD, ids=[f.__name__.strip("_") for f, _ in BAD])
def test_bad_gltf_names_the_file_and_what_was_expected(tmp_path, synth, spoil, expected):
    doc = load_json(write_gltf(synth, tmp_path / "walk.gltf"))
    spoil(doc)
    path = save_json(doc, tmp_path / "bad.gltf")
    with pytest.raises(ParseError) as info:
        read_motion(path)
    assert info.value.path == str(path) and str(path) in str(info.value)
    assert expected in str(info.value)


def test_several_skins_one_picked(tmp_path, synth):
    doc = load_json(write_gltf(synth, tmp_path / "walk.gltf"))
    _two_skins(doc)
    m = read_gltf(save_json(doc, tmp_path / "two.gltf"), skin="other")
    assert m.n_joints == synth.n_joints


@pytest.mark.parametrize("cut", ["header", "chunk", "json"])
def test_bad_glb_container(tmp_path, synth, cut):
    data = bytearray(write_gltf(synth, tmp_path / "walk.glb").read_bytes())
    if cut == "header":
        data = data[:16]
        expected = "expected a GLB header"
    elif cut == "chunk":
        struct.pack_into("<I", data, 12, 10**9)  # the JSON chunk's length
        expected = "expected a GLB chunk of 1000000000 bytes"
    else:
        data[20:24] = b"}}}}"
        expected = "expected glTF 2.0 JSON"
    path = tmp_path / "bad.glb"
    path.write_bytes(bytes(data))
    with pytest.raises(ParseError, match=expected) as info:
        read_gltf(path)
    assert info.value.path == str(path)


def test_an_integer_too_long_for_python_is_a_parse_error(tmp_path, synth):
    """Python's JSON refuses integers over 4,300 digits with a plain ValueError (found by the
    mutation fuzzer): it must end as a ParseError naming the file."""
    text = write_gltf(synth, tmp_path / "walk.gltf").read_text()
    path = tmp_path / "long.gltf"
    path.write_text(text.replace('"2.0"', '"2.0", "n": ' + "9" * 5000, 1))
    with pytest.raises(ParseError, match=r"expected glTF 2\.0 JSON") as info:
        read_gltf(path)
    assert info.value.path == str(path)


def test_external_buffer_is_read_and_protected(tmp_path, synth):
    doc = load_json(write_gltf(synth, tmp_path / "walk.gltf"))
    (tmp_path / "walk data.bin").write_bytes(buffer_bytes(doc))
    doc["buffers"][0]["uri"] = "walk%20data.bin"
    path = save_json(doc, tmp_path / "ext.gltf")
    m = read_gltf(path)
    assert m.source == (str(path), str(tmp_path / "walk data.bin"))
    assert np.abs(m.rotations - to_metres(synth).rotations).max() < 1e-12
    with pytest.raises(ValueError, match="refusing to overwrite"):
        write_motion(m, path)


def test_python_api_write_chooses_gltf_by_extension(tmp_path, synth):
    import elastic_motion as em

    out = em.write(synth, tmp_path / "w.glb")
    assert out.read_bytes()[:4] == b"glTF"
    _same(read_motion(out), to_metres(synth))
    with pytest.raises(ValueError, match=r"expected a \.bvh, \.gltf or \.glb"):
        em.write(synth, tmp_path / "w.fbx")
