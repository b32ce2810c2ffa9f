"""``elastic-motion info`` and the motion summary."""

from __future__ import annotations

import json

import pytest

from elastic_motion.cli import main
from elastic_motion.motion import format_info, motion_info, read_motion


def test_info_json_matches_the_file(mocap_dir, capsys):
    path = mocap_dir / "cmu" / "bvh" / "107_02_30hz.bvh"
    assert main(["info", str(path), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["frames"] == 173 and info["fps"] == 30.0 and info["joints"] == 31
    assert info["duration_s"] == pytest.approx(172 / 30)
    assert info["units"] == "cmu" and info["up_axis"] == "y" and info["channels_per_frame"] == 96
    assert info["skeleton"][0] == {
        "name": "Hips",
        "parent": None,
        "channels": ["Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation"],
        "euler_order": "ZYX",
    }
    assert info["skeleton"][1]["parent"] == "Hips"


def test_info_text_for_amc_and_deepmimic(mocap_dir, capsys):
    amc = mocap_dir / "cmu" / "asfamc" / "backflip.amc"
    assert main(["info", str(amc), "--fps", "60"]) == 0
    out = capsys.readouterr().out
    assert "frames:     247" in out and "fps:        60" in out and "cmu (0.0564444 m per unit)" in out
    assert main(["info", str(mocap_dir / "deepmimic" / "humanoid3d_spin.txt")]) == 0
    out = capsys.readouterr().out
    assert "fps:        24" in out and "right_knee" in out and "joints:     15 (+ 3 end sites)" in out


def test_info_on_a_bad_file_exits_2_naming_file_and_line(tmp_path, capsys):
    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT a\n{\nOFFSET 0 0\n}\n")
    assert main(["info", str(bad)]) == 2
    err = capsys.readouterr().err
    assert f"{bad}:5: expected an OFFSET value (a number), found '}}'" in err


def test_motion_info_round_trips_through_json(mocap_dir):
    m = read_motion(mocap_dir / "bandai" / "dataset-1_walk_normal_002.bvh")
    info = motion_info(m)
    assert json.loads(json.dumps(info)) == info
    assert info["units"] == "cm" and info["metres_per_unit"] == 0.01
    assert "Zrotation Xrotation Yrotation" in format_info(info)
