"""The motion sub-commands end to end: outputs, JSON reports, and bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest
from blend_testlib import walker

from elastic_motion.cli import main
from elastic_motion.motion import drop_joints, read_bvh, resample, write_bvh
from elastic_motion.warp import WarpOptions


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("cli")
    a = walker(duration=2.0, freq=1.0, name="a")
    b = walker(duration=2.4, freq=1.25, amp=0.65, speed=1.3, phase=0.3, yaw=0.5, name="b")
    c = walker(duration=1.8, freq=1.1, amp=0.55, name="c")
    paths = {
        "a": write_bvh(a, d / "a.bvh"),
        "b": write_bvh(b, d / "b.bvh"),
        "c": write_bvh(c, d / "c.bvh"),
        "b60": write_bvh(resample(b, 60.0), d / "b60.bvh"),
        "nohand": write_bvh(drop_joints(b, ["LeftHand"]), d / "nohand.bvh"),
    }
    bad = d / "bad.bvh"
    text = paths["a"].read_text().splitlines()
    text[-1] = " ".join(text[-1].split()[:-1])  # one value short on the last frame
    bad.write_text("\n".join(text) + "\n")
    paths["bad"] = bad
    paths["dir"] = d
    return {k: str(v) for k, v in paths.items()}


def run(capsys, *argv):
    code = main([str(x) for x in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_blend_writes_bvh_and_report(files, capsys, tmp_path):
    out, rep = tmp_path / "ab.bvh", tmp_path / "ab.json"
    code, stdout, err = run(
        capsys, "blend", files["a"], files["b"], "-o", out, "--weight", "0.3", "--json", rep, "-q"
    )
    assert code == 0, err
    assert "wrote" in stdout and "foot sliding" in stdout
    m = read_bvh(out, units="m")
    assert m.n_joints == 11
    r = json.loads(rep.read_text())
    assert r["command"] == "blend" and r["inputs"] == [files["a"], files["b"]] and r["outputs"] == [str(out)]
    assert (
        r["method"] == "lie"
        and r["warp"] == WarpOptions().method
        and r["weights"] == pytest.approx([0.7, 0.3])
    )
    assert r["frames"] == m.n_frames and r["fps"] == 30.0
    met = r["metrics"]
    assert {"foot_sliding", "bone_length_error", "distances"} <= set(met)
    assert len(met["distances"]["result_to_inputs"]) == 2
    assert "mean_speed_m_s" in met["foot_sliding"]["result"]
    assert any("placed like a" in n for n in r["notes"])


def test_blend_json_on_stdout(files, capsys, tmp_path):
    code, stdout, _ = run(
        capsys,
        "blend",
        files["a"],
        files["b"],
        "-o",
        tmp_path / "x.bvh",
        "--method",
        "euler-linear",
        "--warp",
        "none",
        "--no-metrics",
        "--json",
    )
    assert code == 0
    r = json.loads(stdout)
    assert r["method"] == "euler-linear" and r["metrics"] is None


def test_blend_refuses_to_overwrite_an_input(files, capsys):
    before = open(files["a"]).read()
    code, _, err = run(capsys, "blend", files["a"], files["b"], "-o", files["a"])
    assert code == 2
    assert "refusing to overwrite an input" in err and files["a"] in err
    assert open(files["a"]).read() == before


def test_blend_weight_outside_needs_extrapolate(files, capsys, tmp_path):
    code, _, err = run(capsys, "blend", files["a"], files["b"], "-o", tmp_path / "x.bvh", "--weight", "1.4")
    assert code == 2 and "--extrapolate" in err
    code, _, err = run(
        capsys,
        "blend",
        files["a"],
        files["b"],
        "-o",
        tmp_path / "x.bvh",
        "--weight",
        "1.4",
        "--extrapolate",
        "--no-metrics",
    )
    assert code == 0, err


def test_blend_different_skeletons(files, capsys, tmp_path):
    code, _, err = run(capsys, "blend", files["a"], files["nohand"], "-o", tmp_path / "x.bvh")
    assert code == 2
    assert "only in a: ['LeftHand', 'LeftHandIndex1']" in err and "--joints common" in err
    code, stdout, err = run(
        capsys,
        "blend",
        files["a"],
        files["nohand"],
        "-o",
        tmp_path / "x.bvh",
        "--joints",
        "common",
        "--no-metrics",
    )
    assert code == 0, err
    assert "joints not shared by all inputs" in stdout
    assert "LeftHand" not in read_bvh(tmp_path / "x.bvh").skeleton.names


def test_blend_different_fps_says_so(files, capsys, tmp_path):
    code, stdout, err = run(
        capsys, "blend", files["a"], files["b60"], "-o", tmp_path / "x.bvh", "--no-metrics"
    )
    assert code == 0, err
    assert "resampled from 60 to 30 fps" in stdout


def test_blend_landmarks_in_all_forms(files, capsys, tmp_path):
    out = tmp_path / "x.bvh"
    base = ["blend", files["a"], files["b"], "-o", out, "--no-metrics", "--json"]
    code, stdout, err = run(capsys, *base, "--landmarks", "0.5:0.6,1.5:1.7")
    assert code == 0, err
    assert json.loads(stdout)["landmarks_s"] == [[0.5, 0.6], [1.5, 1.7]]
    code, stdout, _ = run(capsys, *base, "--landmarks", "15:18", "--landmark-units", "frames")
    assert json.loads(stdout)["landmarks_s"] == [[0.5, 0.6]]
    code, stdout, _ = run(capsys, *base, "--landmarks", "0.5s:18f")
    assert json.loads(stdout)["landmarks_s"] == [[0.5, 0.6]]
    lm = tmp_path / "lm.txt"
    lm.write_text("# tA tB\n0.5 0.6\n1.5,1.7\n")
    code, stdout, _ = run(capsys, *base, "--landmarks", lm)
    assert json.loads(stdout)["landmarks_s"] == [[0.5, 0.6], [1.5, 1.7]]
    code, stdout, _ = run(capsys, *base, "--landmarks", "auto")
    assert code == 0 and len(json.loads(stdout)["landmarks_s"]) >= 1
    code, _, err = run(capsys, *base, "--landmarks", "0.5:9.0")
    assert code == 2 and "outside its duration" in err
    code, _, err = run(capsys, *base, "--landmarks", "banana")
    assert code == 2 and "expected 'auto'" in err


def test_landmarks_command_and_pairs_file(files, capsys, tmp_path):
    code, stdout, _ = run(capsys, "landmarks", files["a"])
    assert code == 0 and "left_knee_passes" in stdout
    pairs = tmp_path / "pairs.json"
    code, stdout, _ = run(capsys, "landmarks", files["a"], files["b"], "--json", pairs)
    assert code == 0 and "pairs" in stdout
    r = json.loads(pairs.read_text())
    assert r["units"] == "seconds" and len(r["pairs_s"]) >= 1
    assert len(r["events"]) == 2
    code, stdout, err = run(
        capsys,
        "blend",
        files["a"],
        files["b"],
        "-o",
        tmp_path / "x.bvh",
        "--landmarks",
        pairs,
        "--no-metrics",
        "--json",
    )
    assert code == 0, err
    np.testing.assert_allclose(json.loads(stdout)["landmarks_s"], r["pairs_s"])
    # the file gives the blend --landmarks auto makes: the same pairs, met with the same weight
    assert r["landmark_weight"] == 1000.0
    code, _, err = run(
        capsys, "blend", files["a"], files["b"], "-o", tmp_path / "auto.bvh", "--landmarks", "auto",
        "--no-metrics",
    )  # fmt: skip
    assert code == 0, err
    assert (tmp_path / "auto.bvh").read_bytes() == (tmp_path / "x.bvh").read_bytes()
    # a weight given to `landmarks` is recorded and met, as `--landmarks auto` meets it
    heavy = tmp_path / "heavy.json"
    assert (
        run(capsys, "landmarks", files["a"], files["b"], "--landmark-weight", "3000", "--json", heavy)[0] == 0
    )
    assert json.loads(heavy.read_text())["landmark_weight"] == 3000.0
    for name, how in (("h_file.bvh", heavy), ("h_auto.bvh", "auto")):
        argv = ("blend", files["a"], files["b"], "-o", tmp_path / name, "--landmarks", how, "--no-metrics")
        assert run(capsys, *argv, *(("--landmark-weight", "3000") if how == "auto" else ()))[0] == 0
    assert (tmp_path / "h_file.bvh").read_bytes() == (tmp_path / "h_auto.bvh").read_bytes()
    # the notebook's way: em.read_landmarks and em.blend give the command's bytes, its weight
    import elastic_motion as em

    lm = em.read_landmarks(heavy, inputs=[files["a"], files["b"]])
    assert lm.landmark_weight == 3000.0 and len(lm.pairs) == len(r["pairs_s"])
    res = em.blend([files["a"], files["b"]], landmarks=lm)
    em.write(res, tmp_path / "h_api.bvh")
    assert (tmp_path / "h_api.bvh").read_bytes() == (tmp_path / "h_file.bvh").read_bytes()
    assert any("relative weight it records (3000)" in str(n) for n in res.notes)
    with pytest.raises(ValueError, match="the other way round"):
        em.read_landmarks(heavy, inputs=[files["b"], files["a"]])
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"pairs_s": r["pairs_s"], "landmark_weight": True}))
    code, _, err = run(capsys, "align", files["a"], files["b"], "--landmarks", bad)
    assert code == 2 and "'landmark_weight' must be a finite number >= 0; got True" in err
    bad.write_text(json.dumps({"pairs_s": r["pairs_s"], "landmark_weight": -1}))
    code, _, err = run(capsys, "align", files["a"], files["b"], "--landmarks", bad)
    assert code == 2 and "bad.json: 'landmark_weight' must be a finite number >= 0; got -1" in err
    # the pairs of (a, b) are refused for (b, a): they would pin the wrong clips' times
    code, _, err = run(
        capsys, "blend", files["b"], files["a"], "-o", tmp_path / "y.bvh", "--landmarks", pairs
    )
    assert code == 2 and "the same files the other way round" in err and not (tmp_path / "y.bvh").exists()
    code, _, err = run(capsys, "align", files["b"], files["a"], "--landmarks", pairs)
    assert code == 2 and "expected landmarks of b.bvh and a.bvh, in that order" in err


def test_landmarks_command_equals_detect_landmarks(files, capsys, tmp_path):
    """The notebook's ``detect_landmarks`` gives the command's events, pairs, weight and reasons."""
    from elastic_motion.apps.landmark_detection import detect_landmarks

    kinds = ["left_knee_passes", "left_toe_off"]
    options = ["--method", "euler-elastic", "--max-pairs", "1", "--warp", "dp", "--kinds", ",".join(kinds)]
    for argv, kw in (
        ([files["a"]], {}),
        ([files["a"], files["b"]], {}),
        (
            [files["a"], files["b"], *options],
            dict(method="euler-elastic", max_pairs=1, warp="dp", kinds=kinds),
        ),
        (
            [files["a"], files["b"], "--landmark-kinds", "left_knee_passes"],
            dict(pair_kinds=["left_knee_passes"]),
        ),
    ):
        code, stdout, err = run(capsys, "landmarks", *argv, "--json")
        assert code == 0, err
        cli = json.loads(stdout)
        inputs = [a for a in argv if a in (files["a"], files["b"])]
        res = detect_landmarks(*inputs, **kw)
        api = json.loads(json.dumps(res.summary()))
        assert api == {k: cli[k] for k in api}  # every field of the report, the same numbers
        assert set(cli) - set(api) == {"command", "version", "created", "inputs", "outputs", "notes"}
        assert cli["notes"] == [str(n) for n in res.notes]
        if len(inputs) == 2:
            assert [list(p) for p in res.pairs] == cli["pairs_s"] and res.landmark_weight == cli[
                "landmark_weight"
            ]


def test_render_command_equals_render_motions(files, capsys, tmp_path):
    """The notebook's ``render_motions`` draws the command's picture, byte for byte."""
    from elastic_motion.apps.render_files import render_motions

    cases = (
        (["-o", "feet.png"], {}),
        (["-o", "seam.png", "--kind", "seam", "--repeat", "2", "--labels", "x"], dict(kind="seam", repeat=2)),
        (
            ["-o", "warp.png", "--kind", "warp", "--landmarks", "0.5:0.6"],
            dict(kind="warp", landmarks="0.5:0.6"),
        ),
        (["-o", "anim.gif", "--size", "48x48", "--fps", "5"], dict(panel_size=(48, 48), fps=5.0)),
    )
    for argv, kw in cases:
        inputs = [files["a"]] if "seam.png" in argv else [files["a"], files["b"]]
        name = argv[1]
        cli_out, api_out = tmp_path / f"cli_{name}", tmp_path / f"api_{name}"
        args = [*inputs, *argv[2:], "-o", cli_out, "-q", "--json", tmp_path / f"{name}.json"]
        code, _, err = run(capsys, "render", *args)
        assert code == 0, err
        labels = ["x"] if "--labels" in argv else None
        res = render_motions(inputs, api_out, labels=labels, **kw)
        assert api_out.read_bytes() == cli_out.read_bytes(), name
        report = json.loads((tmp_path / f"{name}.json").read_text())
        assert report["kind"] == res.kind and report["labels"] == list(res.labels)
        assert report["notes"] == [str(n) for n in res.notes]
    with pytest.raises(ValueError, match="expected 2 labels; got 1"):
        render_motions([files["a"], files["b"]], tmp_path / "x.png", labels=["one"])
    with pytest.raises(ValueError, match="expected 'tA:tB' pairs"):
        render_motions([files["a"], files["b"]], tmp_path / "x.png", kind="warp", landmarks="1:2:3")


def test_multiway_blend(files, capsys, tmp_path):
    code, stdout, err = run(
        capsys,
        "blend",
        files["a"],
        files["b"],
        files["c"],
        "-o",
        tmp_path / "abc.bvh",
        "--weights",
        "0.5",
        "0.3",
        "0.2",
        "--no-metrics",
        "--json",
    )
    assert code == 0, err
    assert json.loads(stdout)["weights"] == pytest.approx([0.5, 0.3, 0.2])
    code, _, err = run(
        capsys, "blend", files["a"], files["b"], files["c"], "-o", tmp_path / "abc.bvh", "--weight", "0.5"
    )
    assert code == 2 and "--weights" in err


def test_loop_with_preview(files, capsys, tmp_path):
    out = tmp_path / "loop.bvh"
    code, stdout, err = run(
        capsys, "loop", files["a"], "-o", out, "--repeat", "3", "--json", tmp_path / "l.json"
    )
    assert code == 0, err
    preview = tmp_path / "loop.repeat3.bvh"
    a = read_bvh(files["a"])
    assert read_bvh(out).n_frames == a.n_frames
    assert read_bvh(preview).n_frames == 3 * (a.n_frames - 1) + 1
    r = json.loads((tmp_path / "l.json").read_text())
    assert r["outputs"] == [str(out), str(preview)]
    assert r["seam_after"]["seam_angle_max_deg"] <= r["seam_before"]["seam_angle_max_deg"] + 1e-9
    assert "seam:" in stdout
    code, _, err = run(capsys, "loop", files["a"], "-o", files["a"])
    assert code == 2 and "refusing" in err


def test_align_distance_render(files, capsys, tmp_path):
    code, stdout, err = run(capsys, "align", files["a"], files["b"], "--plot", tmp_path / "w.png", "--json")
    assert code == 0, err
    r = json.loads(stdout)
    assert r["distance"] <= r["distance_unwarped"] + 1e-9
    assert r["warp_vertices_s"][0] == [0.0, 0.0]
    assert (tmp_path / "w.png").stat().st_size > 5000
    code, stdout, _ = run(capsys, "distance", files["a"], files["b"], files["c"], "--json")
    d = np.array(json.loads(stdout)["distances"])
    assert d.shape == (3, 3) and np.allclose(d, d.T) and (np.diag(d) == 0).all()
    code, stdout, _ = run(capsys, "distance", files["a"], files["b"])
    assert code == 0 and "elastic distances" in stdout
    code, _, err = run(
        capsys, "render", files["a"], files["b"], "-o", tmp_path / "ab.gif", "--size", "64x64", "--fps", "5"
    )
    assert code == 0, err
    code, _, _ = run(capsys, "render", files["a"], "-o", tmp_path / "ab.png")
    assert code == 0 and (tmp_path / "ab.png").exists()
    code, _, err = run(capsys, "render", files["a"], "-o", files["a"])
    assert code == 2 and "refusing" in err


def test_bad_files(files, capsys, tmp_path):
    code, _, err = run(capsys, "blend", files["a"], str(tmp_path / "missing.bvh"), "-o", tmp_path / "x.bvh")
    assert code == 2 and "no such file" in err
    code, _, err = run(capsys, "blend", files["a"], files["bad"], "-o", tmp_path / "x.bvh")
    assert code == 2 and "bad.bvh:" in err and "expected" in err
    code, _, err = run(capsys, "blend", files["a"], files["b"], "-o", tmp_path / "x.txt")
    assert code == 2 and ".bvh" in err
    code, _, err = run(capsys, "blend", files["a"], files["b"], "-o", tmp_path / "nodir" / "x.bvh")
    assert code == 2 and "does not exist" in err


def test_trim(files, capsys, tmp_path):
    from elastic_motion.motion import read_bvh

    def blend(*trim):
        return run(capsys, "blend", files["a"], files["b"], "-o", tmp_path / "x.bvh", "--trim", *trim)

    code, stdout, err = blend("0.5:1.5", ":", "--no-metrics")
    assert code == 0, err
    assert "a: kept 0.5-1.5 s (31 frames)" in stdout
    # an open range ends where the clip does (the note once gave the trimmed length instead)
    code, stdout, err = blend("0.5:", ":", "--no-metrics")
    assert code == 0, err
    assert f"a: kept 0.5-{read_bvh(files['a']).duration:g} s (" in stdout
    code, _, err = blend("0.5", ":")
    assert code == 2 and "START:STOP" in err


def test_distance_cubic_interpolation_cli_equals_api_and_resolves_sub_frame_shifts(files, capsys, tmp_path):
    """``distance --interpolation cubic --sample-fps 120`` is ``distance_table(...,
    interpolation="cubic")``; a clip against itself played half a frame later measures far
    closer than with the default geodesic sampling (whose DP works on the clip's own grid)."""
    from elastic_motion.apps.distance import distance_table
    from elastic_motion.motion import read_bvh
    from elastic_motion.motion.edit import resample_at_times
    from elastic_motion.warp import WarpOptions

    b = read_bvh(files["b"])
    half = resample_at_times(b, b.times, np.clip(b.times + 0.5 / b.fps, 0.0, b.duration), fps=b.fps)
    shifted = write_bvh(half, tmp_path / "b_half.bvh")
    argv = ("distance", files["a"], files["b"], shifted, "--json")
    code, stdout, err = run(capsys, *argv, "--interpolation", "cubic", "--sample-fps", "120")
    assert code == 0, err
    cli = np.array(json.loads(stdout)["distances"])
    api = distance_table(
        [files["a"], files["b"], shifted], warp=WarpOptions(sample_fps=120.0), interpolation="cubic"
    ).matrix
    np.testing.assert_allclose(cli, api, rtol=1e-12)
    code, stdout, _ = run(capsys, *argv)
    default = np.array(json.loads(stdout)["distances"])
    assert cli[1, 2] < 0.5 * default[1, 2] and cli[1, 2] < 0.2 * cli[0, 1]
    with pytest.raises(SystemExit) as exc:
        run(capsys, *argv, "--interpolation", "spline")
    assert exc.value.code == 2 and "--interpolation" in capsys.readouterr().err
    with pytest.raises(Exception, match="interpolation"):
        distance_table([files["a"], files["b"]], interpolation="spline")
    with pytest.raises(Exception, match=r"sample_fps: .*max_frames"):
        distance_table([files["a"], files["b"]], warp=WarpOptions(sample_fps=1e9), interpolation="cubic")
    from elastic_motion import limits

    with limits.override(max_dp_nodes=100), pytest.raises(Exception, match=r"sample_fps: .*241 x 289 nodes"):
        distance_table([files["a"], files["b"]], warp=WarpOptions(sample_fps=120.0), interpolation="cubic")


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (
            ["loop", "{a}", "-o", "{tmp}/l.bvh", "--tol", "-1"],
            "--tol: expected a number >= 0; got '-1'",
        ),
        (["info", "{a}", "--fps", "0"], "--fps: expected a number > 0; got '0'"),
        (["landmarks", "{a}", "--kinds", "foo"], "--kinds: expected some of left_knee_passes"),
        (["landmarks", "{a}", "{b}", "--landmark-kinds", "foo"], "--landmark-kinds: expected some of"),
    ],
)
def test_bad_options_are_named_as_typed(files, capsys, tmp_path, argv, message):
    """An option's error names the flag the user typed (not the Python argument or another
    command's flag)."""
    argv = [str(x).format(a=files["a"], b=files["b"], tmp=tmp_path) for x in argv]
    try:
        code, _, err = run(capsys, *argv)
    except SystemExit as exc:  # argparse's own error exit
        code, err = exc.code, capsys.readouterr().err
    assert code == 2 and message in err, err


def test_an_asf_without_motion_is_named(tmp_path, capsys):
    asf = tmp_path / "s.asf"
    asf.write_text(":version 1.10\n:name s\n")
    code, _, err = run(capsys, "info", asf)
    assert code == 2 and f"{asf}: expected a motion file; got an ASF skeleton without motion" in err
