"""The command line of issue 16: blend --contacts / --weight-curve / --cycles / --loop, the
blendspace command, landmarks paired by phase; reports and bad input."""

from __future__ import annotations

import json

import pytest
from blend_testlib import walker

from elastic_motion.cli import main
from elastic_motion.motion import read_bvh, write_bvh


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("cli16")
    out = {}
    for name, kw in {
        "a": {"duration": 1.5},
        "b": {"duration": 1.8, "freq": 1.2, "speed": 1.3, "phase": 0.3},
        "c": {"duration": 1.6, "freq": 1.1, "speed": 1.6},
    }.items():
        out[name] = str(write_bvh(walker(name=name, **kw), d / f"{name}.bvh"))
    return out


def run(capsys, *argv):
    code = main([str(x) for x in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_blend_reports_the_cleanup_and_weight_curve(files, capsys, tmp_path):
    out, rep = tmp_path / "ab.bvh", tmp_path / "ab.json"
    code, _, err = run(
        capsys, "blend", files["a"], files["b"], "-o", out, "--weight-curve", "0:0,1:1", "--json", rep, "-q",
        "--no-metrics",
    )  # fmt: skip
    assert code == 0, err
    report = json.loads(rep.read_text())
    assert "cleanup" in report and "cycles" in report and report["weights"] == pytest.approx([0.5, 0.5])
    assert report["weight_curve"] == [[0.0, 0.0], [1.0, 1.0]]  # the curve, not only its mean
    assert any("weight curve" in n for n in report["notes"])
    assert read_bvh(out).n_frames > 10
    code, text, err = run(
        capsys, "blend", files["a"], files["b"], "-o", tmp_path / "ab2.bvh", "--weight-curve",
        "0:0,0.5:0.2,1:1", "--no-metrics",
    )  # fmt: skip
    assert code == 0, err
    assert "by normalised time: 0:0, 0.5:0.2, 1:1 (mean 0.35)" in text and "weights " not in text
    code, _, err = run(
        capsys, "blend", files["a"], files["b"], "-o", tmp_path / "off.bvh", "--contacts", "off", "--json",
        tmp_path / "off.json", "-q", "--no-metrics",
    )  # fmt: skip
    assert code == 0, err
    assert json.loads((tmp_path / "off.json").read_text())["cleanup"] is None


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--weight-curve", "0:0,1:2"], "--weight-curve: expected weights s in [0, 1]"),
        (["--weight-curve", "0.2:0,1:1"], "--weight-curve: expected a curve defined on [0, 1]"),
        (["--weight-curve", "0:0,1:1", "--weight", "0.3"], "--weight-curve: expected --weight-curve or"),
    ],
)
def test_blend_bad_options(files, capsys, tmp_path, args, message):
    code, _, err = run(capsys, "blend", files["a"], files["b"], "-o", tmp_path / "x.bvh", "-q", *args)
    assert code == 2 and message in err


def test_blend_cycles_fall_back_with_a_note(files, capsys, tmp_path):
    rep = tmp_path / "cyc.json"
    code, _, err = run(
        capsys, "blend", files["a"], files["b"], "-o", tmp_path / "cyc.bvh", "--cycles", "--json", rep, "-q",
        "--no-metrics",
    )  # fmt: skip
    assert code == 0, err
    report = json.loads(rep.read_text())
    assert report["cycles"]["matched_cycles"] == 0 and "fall back" in report["cycles"]["why"]


def test_blendspace_command(files, capsys, tmp_path):
    out, rep = tmp_path / "bs.bvh", tmp_path / "bs.json"
    code, _, err = run(
        capsys, "blendspace", files["a"], files["b"], files["c"], "--at", "1.2", "-o", out, "--json", rep,
        "--contacts", "off",
    )  # fmt: skip
    assert code == 0, err
    report = json.loads(rep.read_text())
    assert report["blendspace"]["param"] == "speed_m_s" and len(report["blendspace"]["params"]) == 3
    assert report["at"] == 1.2 and sum(w > 0 for w in report["weights"]) <= 2
    code, _, err = run(
        capsys, "blendspace", files["a"], files["b"], files["c"], "--at", "9", "-o", tmp_path / "y.bvh"
    )
    assert code == 2 and "--at: expected a parameter in" in err
    code, _, err = run(capsys, "blendspace", files["a"], files["b"], "--at", "1", "-o", tmp_path / "z.bvh")
    assert code == 2 and "at least three" in err
    code, _, err = run(
        capsys, "blendspace", files["a"], files["b"], files["c"], "--params", "1,1,2", "--at", "1", "-o",
        tmp_path / "w.bvh",
    )  # fmt: skip
    assert code == 2 and "--params: expected different parameters" in err


def test_landmarks_command_pairs_by_phase(files, capsys, tmp_path):
    rep = tmp_path / "lm.json"
    code, _, err = run(
        capsys, "landmarks", files["a"], files["b"], "--landmark-kinds", "left_knee_passes", "--json", rep
    )
    assert code == 0, err
    report = json.loads(rep.read_text())
    assert "phase" in report["pairing"] and all("offset_s" in p for p in report["pairs"])
    assert len(report["pairs_s"]) == len(report["pairs"])


@pytest.mark.mocap
def test_contact_height_sets_the_contacts_of_blend_and_loop(mocap_dir, capsys, tmp_path):
    """--contact-height is the height within which a joint counts as planted (twice it to
    leave), for blend and loop alike; a height outside (0, 0.2] m is refused."""

    def contact_frames(report: dict) -> int:
        joints = report["joints"]
        return sum(b - a for runs in joints.values() for a, b in runs["frames"])

    a, b = (str(mocap_dir / f"bandai/dataset-1_walk_{s}_001.bvh") for s in ("normal", "tired"))
    counts = {}
    for key, extra in (("default", ()), ("low", ("--contact-height", "0.012"))):
        rep = tmp_path / f"{key}.json"
        argv = ("blend", a, b, "-o", tmp_path / f"{key}.bvh", "--no-metrics", "-q")
        assert run(capsys, *argv, "--json", rep, *extra)[0] == 0
        blended = contact_frames(json.loads(rep.read_text())["cleanup"]["contacts"])
        rep = tmp_path / f"loop_{key}.json"
        argv = ("loop", a, "-o", tmp_path / f"loop_{key}.bvh", "-q", "--json", rep, *extra)
        assert run(capsys, *argv)[0] == 0
        counts[key] = (blended, contact_frames(json.loads(rep.read_text())["contacts"]))
    assert counts["default"][0] > counts["low"][0] and counts["default"][1] > counts["low"][1]
    code, _, err = run(capsys, "blend", a, b, "-o", tmp_path / "x.bvh", "--contact-height", "0")
    assert code == 2 and "--contact-height: expected a height in metres in (0, 0.2]" in err


def test_blend_cli_choices_are_the_options_types():
    """The choices of `blend` and `blendspace` are read from the API's Literal types: what the
    command line offers is what the Python options accept."""
    from typing import get_args

    from elastic_motion.apps.align import CurveMethod
    from elastic_motion.apps.blend_options import SkeletonMode
    from elastic_motion.cli import build_parser
    from elastic_motion.motion.contacts import ContactPolicy
    from elastic_motion.motion.representations import Method

    sub = next(a for a in build_parser()._actions if a.dest == "command").choices
    want = {
        "blend": {"--method": CurveMethod, "--skeleton": SkeletonMode, "--contacts": ContactPolicy},
        "blendspace": {"--method": Method, "--contacts": ContactPolicy},
    }
    for command, flags in want.items():
        actions = {a.option_strings[0]: a for a in sub[command]._actions if a.option_strings}
        for flag, literal in flags.items():
            assert tuple(actions[flag].choices) == get_args(literal), (command, flag)
    assert sub["blend"].get_default("contacts") == "keep"


def test_blend_contacts_auto_still_parses_and_report_measures(files, capsys, tmp_path):
    """`--contacts auto` (the old name) is `keep`; `report` writes the blend of `off` and
    reports its skating; an unknown policy is refused with the choices."""
    outs = {}
    for policy in ("auto", "keep", "report", "off"):
        rep = tmp_path / f"{policy}.json"
        code, _, err = run(
            capsys, "blend", files["a"], files["b"], "-o", tmp_path / f"{policy}.bvh", "--contacts", policy,
            "--contact-height", "0.2", "--json", rep, "-q", "--no-metrics",
        )  # fmt: skip
        assert code == 0, err
        outs[policy] = ((tmp_path / f"{policy}.bvh").read_bytes(), json.loads(rep.read_text()))
    assert outs["auto"][0] == outs["keep"][0] and outs["auto"][1]["cleanup"]["applied"] is True
    assert outs["report"][0] == outs["off"][0] != outs["keep"][0]
    assert outs["report"][1]["cleanup"]["applied"] is False and outs["off"][1]["cleanup"] is None
    with pytest.raises(SystemExit) as exit_:
        main(["blend", files["a"], files["b"], "-o", str(tmp_path / "x.bvh"), "--contacts", "on"])
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and "--contacts: expected one of 'keep', 'report', 'off'; got 'on'" in err
