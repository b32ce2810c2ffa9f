"""One way in: the Python API (``import elastic_motion as em``) and the command line run the
same preparation and give the same numbers and the same files, on real clips."""

from __future__ import annotations

import json

import numpy as np
import pytest
from blend_testlib import walker

import elastic_motion as em
from elastic_motion.apps.prepare import (
    UP_AXIS_WARNING,
    PrepareOptions,
    load_motion,
    output_motion,
    prepare_motions,
)
from elastic_motion.cli import main
from elastic_motion.errors import OptionError
from elastic_motion.motion import forward_kinematics, read_bvh, read_motion, set_up_axis, write_bvh
from elastic_motion.notes import of_kind


def run(capsys, *argv):
    code = main([str(x) for x in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture(scope="module")
def cmu(mocap_dir):
    d = mocap_dir / "cmu" / "bvh"
    return str(d / "107_02_30hz.bvh"), str(d / "108_01_30hz.bvh")


# ------------------------------------------------------------------------------- both doors


@pytest.mark.mocap
def test_blend_same_numbers_and_file_from_both_doors(cmu, capsys, tmp_path):
    """The measured bug: the API gave 7.25 and the CLI 5.84 on these files (only the CLI
    dropped the T-pose frame)."""
    cli_out, rep = tmp_path / "cli.bvh", tmp_path / "cli.json"
    code, _, err = run(capsys, "blend", *cmu, "-o", cli_out, "--json", rep, "-q")
    assert code == 0, err
    report = json.loads(rep.read_text())

    res = em.blend(list(cmu), 0.5, metrics=True)
    api_out = em.write(res, tmp_path / "api.bvh")
    # the same preparation ...
    assert [p["tpose_dropped"] for p in report["preparation"]] == [True, True]
    assert all(r.tpose_dropped for r in res.prepared.inputs)
    # ... the same distances (the warp's and the metrics')
    api_d = res.metrics.distances_between_inputs[0, 1]
    assert report["metrics"]["distances"]["between_inputs"][0][1] == pytest.approx(api_d, rel=1e-12)
    assert report["metrics"]["distances"]["result_to_inputs"] == pytest.approx(
        res.metrics.distances_to_inputs.tolist(), rel=1e-12
    )
    assert report["notes"] == [str(n) for n in res.notes]
    assert 5.5 < api_d < 6.2  # the T-pose-free distance of these two walks, not 7.25
    # ... and the same file, byte for byte
    assert api_out.read_bytes() == cli_out.read_bytes()


@pytest.mark.mocap
def test_blend_without_anchoring_from_both_doors(cmu, capsys, tmp_path):
    """``--no-anchor`` is ``anchor=False``: the same file, and not the anchored one."""
    cli_out, rep = tmp_path / "cli.bvh", tmp_path / "cli.json"
    argv = ("blend", *cmu, "-o", cli_out, "--no-anchor", "--no-metrics", "--json", rep, "-q")
    code, _, err = run(capsys, *argv)
    assert code == 0, err
    assert json.loads(rep.read_text())["pose_anchor_deg"] is None
    api_out = em.write(em.blend(list(cmu), 0.5, anchor=False), tmp_path / "api.bvh")
    assert api_out.read_bytes() == cli_out.read_bytes()
    anchored = em.write(em.blend(list(cmu), 0.5), tmp_path / "anchored.bvh")
    assert anchored.read_bytes() != cli_out.read_bytes()


@pytest.mark.mocap
def test_paths_and_motions_give_the_same_blend(cmu):
    by_path = em.blend(list(cmu), 0.5)
    by_motion = em.blend([read_motion(p) for p in cmu], 0.5)
    np.testing.assert_array_equal(by_path.motion.rotations, by_motion.motion.rotations)
    np.testing.assert_array_equal(by_path.motion.root_translation, by_motion.motion.root_translation)


@pytest.mark.mocap
def test_distance_same_numbers_from_both_doors(mocap_dir, capsys):
    files = [str(mocap_dir / "cmu" / "bvh" / f) for f in ("07_01.bvh", "08_02.bvh", "09_11.bvh")]
    code, out, err = run(capsys, "distance", *files, "--json", "-q")
    assert code == 0, err
    report = json.loads(out)
    table = em.distances(files)
    np.testing.assert_allclose(report["distances"], table.matrix, rtol=1e-12)
    # two files: the weights are shared by the two only (means of the inputs' defaults)
    code, out, err = run(capsys, "distance", *files[:2], "--json", "-q")
    assert code == 0, err
    assert em.distance(files[0], files[1]) == pytest.approx(json.loads(out)["distances"][0][1], rel=1e-12)


@pytest.mark.mocap
def test_loop_of_a_bandai_walk_from_both_doors(mocap_dir, capsys, tmp_path):
    """The Bandai walk's static root is folded by the one preparation step for loop too
    (it failed with "use merge_root first")."""
    walk = str(mocap_dir / "bandai" / "dataset-1_walk_normal_001.bvh")
    out, rep = tmp_path / "loop.bvh", tmp_path / "loop.json"
    code, _, err = run(capsys, "loop", walk, "-o", out, "--json", rep, "-q")
    assert code == 0, err
    report = json.loads(rep.read_text())
    assert report["preparation"][0]["static_root_folded"] == "joint_Root"
    res = em.loop(walk)
    assert res.seam_after.seam_angle_max_deg < 1e-3
    assert report["seam_after"]["seam_angle_max_deg"] == pytest.approx(res.seam_after.seam_angle_max_deg)
    assert report["closing"]["gap"] == pytest.approx(res.closing.gap, rel=1e-9)
    assert em.write(res, tmp_path / "api.bvh").read_bytes() == out.read_bytes()


# ------------------------------------------------------------------------------------ units


@pytest.mark.mocap
def test_blend_and_loop_write_the_same_unit(cmu, capsys, tmp_path):
    """One rule: outputs are in the first input's unit (blend wrote metres and loop the input
    unit: 17.7x apart in one Blender scene)."""
    code, _, err = run(capsys, "blend", *cmu, "-o", tmp_path / "b.bvh", "-q", "--no-metrics")
    assert code == 0, err
    code, _, err = run(capsys, "loop", cmu[0], "-o", tmp_path / "l.bvh", "-q", "--repeat", "2")
    assert code == 0, err
    # the notebook's preview is the command's, in the same unit (em.repeat of a Motion in
    # metres wrote metres beside a loop in the input's unit)
    res = em.loop(cmu[0])
    preview = em.write(em.repeat(res, 2), tmp_path / "api.repeat2.bvh")
    assert preview.read_bytes() == (tmp_path / "l.repeat2.bvh").read_bytes()
    src = read_bvh(cmu[0])
    b, lp = read_bvh(tmp_path / "b.bvh"), read_bvh(tmp_path / "l.bvh")
    hip = lambda m: np.median(forward_kinematics(m)[:, 0, 1])  # noqa: E731 - root height, file units
    assert src.metres_per_unit == pytest.approx(0.0254 / 0.45)
    for m in (b, lp, read_bvh(preview)):
        assert hip(m) == pytest.approx(hip(src), rel=0.1)  # the same scale as the input
    # --units-out m: the same motion in metres
    code, _, err = run(capsys, "loop", cmu[0], "-o", tmp_path / "lm.bvh", "-q", "--units-out", "m")
    assert code == 0, err
    lm = read_bvh(tmp_path / "lm.bvh", units="m")
    np.testing.assert_allclose(
        forward_kinematics(lm), forward_kinematics(lp) * src.metres_per_unit, atol=1e-6
    )


def test_output_motion_scales_every_length():
    m = walker(duration=1.0, name="w")  # metres
    cm = output_motion(m, 0.01)
    assert cm.metres_per_unit == 0.01
    np.testing.assert_allclose(forward_kinematics(cm), 100 * forward_kinematics(m), rtol=1e-12)
    np.testing.assert_allclose(cm.skeleton.end_site_offsets, 100 * m.skeleton.end_site_offsets)
    assert output_motion(m, None) is m


# ------------------------------------------------------------------------------ preparation


def test_preparation_reports_what_it_did(tmp_path):
    m = walker(duration=2.0, name="w")
    tpose = m.rotations.copy()
    tpose[0] = np.eye(3)  # a T-pose frame 0
    tpose[0, 0] = m.rotations[0, 0] @ np.array([[0, 0, 1.0], [0, 1, 0], [-1.0, 0, 0]])
    path = write_bvh(m.replace(rotations=tpose), tmp_path / "w.bvh")
    motion, rep = load_motion(path, PrepareOptions(units="m"), trim=(0.5, 1.5))
    assert rep.tpose_dropped and rep.frames_read == m.n_frames
    assert rep.trim_s == (0.5, 1.5) and motion.n_frames == rep.frames_kept == 31
    assert rep.unit_in == "m" and rep.up_axis_in == "y" and rep.source == str(path)
    kept, _ = load_motion(path, PrepareOptions(units="m", drop_tpose=False))
    assert kept.n_frames == m.n_frames


def test_z_up_input_is_brought_to_y_up():
    m = walker(duration=1.0, name="w")
    z = set_up_axis(m, "z")
    prepared, rep = load_motion(z)
    assert rep.up_axis_in == "z" and prepared.up_axis == "y"
    np.testing.assert_allclose(forward_kinematics(prepared), forward_kinematics(m), atol=1e-12)


def test_bad_options_name_the_option_and_file(tmp_path, capsys):
    a = write_bvh(walker(duration=2.0, name="a"), tmp_path / "a.bvh")
    b = write_bvh(walker(duration=2.4, freq=1.2, name="b"), tmp_path / "b.bvh")
    with pytest.raises(OptionError, match=r"^trim: expected START < STOP in seconds; got 5:1$"):
        PrepareOptions(trim=(5.0, 1.0))
    with pytest.raises(OptionError, match=r"^trim: a: expected START within the clip's 0-2 s; got 3:4$"):
        prepare_motions([a, b], PrepareOptions(trim=(3.0, 4.0)))
    with pytest.raises(OptionError, match=r"units: expected one of"):
        PrepareOptions(units="furlong")
    code, _, err = run(capsys, "blend", a, b, "-o", tmp_path / "x.bvh", "--trim", "5:1")
    assert code == 2
    assert err.strip() == "elastic-motion blend: error: --trim: expected START < STOP in seconds; got 5:1"
    code, _, err = run(capsys, "blend", a, b, "-o", tmp_path / "x.bvh", "--trim", "3:4", ":")
    assert code == 2 and "error: --trim: a: expected START within the clip's 0-2 s; got 3:4" in err


@pytest.mark.mocap
def test_joints_common_refuses_less_than_a_body(mocap_dir, capsys, tmp_path):
    """CMU 131_01 and a Bandai walk share only the hips from the root on: a 1-joint "blend"
    was written with exit code 0."""
    a = mocap_dir / "cmu" / "bvh" / "131_01.bvh"
    b = mocap_dir / "bandai" / "dataset-1_walk_normal_001.bvh"
    code, _, err = run(capsys, "blend", a, b, "-o", tmp_path / "x.bvh", "--joints", "common")
    assert code == 2
    assert "--joints: expected the common joints to hold at least half of each input's body" in err
    assert "['Hips']" in err and "131_01 keeps 1 of its" in err
    assert not (tmp_path / "x.bvh").exists()
    # two CMU skeletons of the same conversion share everything: accepted
    c = mocap_dir / "cmu" / "bvh" / "131_02.bvh"
    prep = prepare_motions([a, c], PrepareOptions(joints="common"))
    assert len(prep.motions[0].skeleton.names) >= 20


def test_prepared_motions_are_taken_as_they_are():
    a, b = walker(duration=2.0, name="a"), walker(duration=2.3, freq=1.2, name="b")
    prep = em.prepare([a, b])
    assert em.prepare(prep) is prep
    r1, r2 = em.blend(prep, 0.5), em.blend([a, b], 0.5)
    np.testing.assert_array_equal(r1.motion.rotations, r2.motion.rotations)
    with pytest.raises(OptionError, match="already prepared"):
        em.prepare(prep, PrepareOptions())


def test_warp_options_one_object():
    with pytest.raises(OptionError, match=r"^neighbourhood: expected an integer >= 1"):
        em.WarpOptions(neighbourhood=0)
    with pytest.raises(OptionError, match=r"^landmark_weight: expected a finite weight >= 0"):
        em.WarpOptions(landmark_weight=-1.0)
    opts = em.WarpOptions(landmark_weight=2.0)
    assert opts.absolute_landmark_weight(3.0, 4.0) == pytest.approx(14.0)
    assert em.WarpOptions.from_json(opts.to_json()) == opts
    a, b = walker(duration=2.0, name="a"), walker(duration=2.0, freq=1.25, name="b")
    coarse = em.align(a, b, warp=em.WarpOptions(method="dp", neighbourhood=1))  # slope 1: the identity
    np.testing.assert_allclose(coarse.vertices[:, 0], coarse.vertices[:, 1])
    assert coarse.distance == pytest.approx(coarse.distance_unwarped, rel=1e-12)
    assert em.align(a, b, warp="dp").distance < 0.9 * coarse.distance


def test_to_json_is_the_report_body():
    a, b = walker(duration=2.0, name="a"), walker(duration=2.4, freq=1.25, name="b")
    res = em.blend([a, b], 0.5)
    body = json.loads(em.to_json(res))
    assert body["metrics"] is None and body["warp_options"] == em.WarpOptions().to_json()
    assert body["frames"] == res.motion.n_frames


@pytest.mark.parametrize("page", ["docs/api.md", "README.md"])
def test_the_documented_examples_run(page, tmp_path, monkeypatch):
    """The Python examples of docs/api.md and the README run as they stand (they need
    pybullet's DeepMimic clips)."""
    import re
    from pathlib import Path

    pytest.importorskip("pybullet_data")
    text = (Path(__file__).resolve().parents[2] / page).read_text(encoding="utf-8")
    code = re.findall(r"```python\n(.*?)```", text, re.S)[0]
    monkeypatch.chdir(tmp_path)
    exec(compile(code, page, "exec"), {})
    assert read_bvh(tmp_path / "walk_run.bvh").n_frames > 10


@pytest.mark.mocap
def test_a_z_up_file_lands_upright(mocap_dir, tmp_path, capsys):
    """A Blender-style Z-up BVH was read as Y-up (the character lay on the floor) and blending
    it with its own source exited 0 without a word."""
    src = mocap_dir / "cmu" / "bvh" / "07_01.bvh"
    m = read_motion(src)
    zfile = write_bvh(set_up_axis(m, "z"), tmp_path / "07_01_zup.bvh")
    prep = prepare_motions([src, zfile], PrepareOptions(align=False))
    assert prep.inputs[1].up_axis_in == "z"
    np.testing.assert_allclose(
        forward_kinematics(prep.motions[1]), forward_kinematics(prep.motions[0]), atol=1e-6
    )
    assert em.distance(src, zfile, warp="none") < 1e-6
    # forcing the wrong axis is warned about, in the report and on the command line
    forced = prepare_motions([zfile], PrepareOptions(up="y"))
    (warning,) = of_kind(forced.notes, UP_AXIS_WARNING)
    assert str(warning).startswith("warning:") and "+z-up" in warning.data["warning"]
    # (--force: the point is the warning, not whether the lying figure loops within the bound)
    code, out, _ = run(capsys, "loop", zfile, "-o", tmp_path / "l.bvh", "--up", "y", "-q", "--force")
    assert code == 0 and "warning:" in out


@pytest.mark.mocap
def test_a_bvh_file_is_labelled_by_one_up_axis_detection(mocap_dir, tmp_path, monkeypatch):
    """The preparation reads a BVH file's up axis once (it was detected when read and again
    by the check, the larger part of reading a file); the labels and the warning are those of
    read_motion and up_axis_warning."""
    import elastic_motion.apps.prepare as prepare_module
    import elastic_motion.motion.axes as axes
    import elastic_motion.motion.bvh as bvh

    src = mocap_dir / "cmu" / "bvh" / "49_08.bvh"  # cartwheels: lying down, a warning
    zfile = write_bvh(set_up_axis(read_motion(src), "z"), tmp_path / "49_08_zup.bvh")
    expected = [(read_motion(f).up_axis, axes.up_axis_warning(read_motion(f))) for f in (src, zfile)]
    assert expected[0][1]  # 49_08 warns: the check below is not skipped
    calls = []
    real = axes.detect_up_axis

    def counting(motion, **kw):
        calls.append(motion.name)
        return real(motion, **kw)

    for module in (axes, bvh, prepare_module):
        monkeypatch.setattr(module, "detect_up_axis", counting)
    for f, (label, warning) in zip((src, zfile), expected, strict=True):
        calls.clear()
        _, prep = load_motion(f, PrepareOptions(align=False))
        assert len(calls) == 1
        assert prep.up_axis_in == label
        if warning:  # the same warning, under the preparation's label
            assert any(warning.split(": ", 1)[1] in str(n) for n in prep.notes)


def test_the_package_face_is_lazy_and_complete():
    """``import elastic_motion`` loads no numerical stack (the CLI starts fast); every name of
    ``elastic_motion.api.__all__`` is reachable as ``em.NAME``; submodules import as usual."""
    import subprocess
    import sys

    code = "import sys, elastic_motion; assert 'numba' not in sys.modules and 'scipy' not in sys.modules"
    assert subprocess.run([sys.executable, "-c", code], check=False).returncode == 0
    from elastic_motion import api

    for name in api.__all__:
        assert getattr(em, name) is getattr(api, name)
        assert name in dir(em)
    with pytest.raises(AttributeError, match="no attribute 'blendd'"):
        em.blendd  # noqa: B018
