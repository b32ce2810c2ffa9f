"""Tests of the landmark file reader (apps.landmark_files): the formats, times in frames, and
errors that name the file and line."""

from __future__ import annotations

import json

import pytest

from elastic_motion.apps.landmark_files import LandmarkFile, landmark_time, read_landmark_file
from elastic_motion.errors import ParseError
from elastic_motion.warp import WarpOptions


def test_text_file_with_comments_units_and_suffixes(tmp_path):
    f = tmp_path / "pairs.txt"
    f.write_text("# A B\n0.5 0.7\n\n30f, 1.2s  # frames of A at 60 fps\n2:90\n")
    lm = read_landmark_file(f, units="seconds", fps=(60.0, 30.0))
    assert lm.pairs == ((0.5, 0.7), (0.5, 1.2), (2.0, 90.0))
    framed = read_landmark_file(f, units="frames", fps=(60.0, 30.0))
    assert framed.pairs == ((0.5 / 60, 0.7 / 30), (0.5, 1.2), (2.0 / 60, 3.0))
    assert lm.landmark_weight is None and lm.inputs is None


def test_json_files_and_the_recorded_weight(tmp_path):
    f = tmp_path / "p.json"
    f.write_text(json.dumps({"units": "frames", "pairs": [[60, 30], ["1s", 45]]}))
    assert read_landmark_file(f, fps=(120.0, 30.0)).pairs == ((0.5, 1.0), (1.0, 1.5))
    report = {"pairs_s": [[0.1, 0.2]], "landmark_weight": 1000, "inputs": ["x/a.bvh", "b.bvh"]}
    f.write_text(json.dumps(report))
    lm = read_landmark_file(f, inputs=["a.bvh", "y/b.bvh"])  # compared by file name
    assert lm.pairs == ((0.1, 0.2),) and lm.landmark_weight == 1000.0 and lm.inputs == ("x/a.bvh", "b.bvh")
    assert lm.warp_options().landmark_weight == 1000.0
    assert lm.warp_options("dp").method == "dp" and lm.warp_options("dp").landmark_weight == 1000.0
    own = WarpOptions(method="dp", sample_fps=60.0, landmark_weight=5.0)
    assert lm.warp_options(own) == own.replace(landmark_weight=1000.0)
    plain = LandmarkFile("x", ((0.1, 0.2),))
    assert plain.warp_options(own) is own  # no recorded weight: the options as given
    with pytest.raises(ParseError, match="other files"):
        read_landmark_file(f, inputs=["c.bvh", "b.bvh"])


@pytest.mark.parametrize(
    ("text", "line", "match"),
    [
        ("0.1 0.2\n0.3\n", 2, "expected two times"),
        ("0.1 0.2\n0.3 x\n", 2, "expected a time"),
        ("0.1 nan\n", 1, "finite"),
        ("10f 0.2\n", 1, "frame rates"),
        ('{"pairs": [[1, 2]], "units": "hours"}', None, "'units'"),
        ('{"pairs_s": [[0.1, 0.2]], "landmark_weight": true}', None, "landmark_weight"),
        ('{"pairs_s": [[0.1]]}', None, "pairs_s"),
        ('{"other": 1}', None, "expected a JSON object"),
    ],
)
def test_bad_files_name_the_file_and_line(tmp_path, text, line, match):
    f = tmp_path / "bad.txt"
    f.write_text(text)
    with pytest.raises(ParseError, match=match) as info:
        read_landmark_file(f)
    assert info.value.path == str(f) and info.value.line == line


def test_bad_arguments_are_named(tmp_path):
    f = tmp_path / "p.txt"
    f.write_text("1 2\n")
    for fps in ((0.0, 30.0), (30.0,), (30.0, float("nan")), (True, 30.0)):
        with pytest.raises(ValueError, match="fps: expected the frame rates"):
            read_landmark_file(f, fps=fps)
    with pytest.raises(ValueError, match="units"):
        read_landmark_file(f, units="hours")
    with pytest.raises(ParseError, match=r"missing\.txt"):
        read_landmark_file(tmp_path / "missing.txt")


def test_landmark_time():
    assert landmark_time("1.5", "seconds", None) == 1.5
    assert landmark_time("30", "frames", 60.0) == 0.5
    assert landmark_time("2S", "frames", 60.0) == 2.0
    with pytest.raises(ValueError, match="frame rates"):
        landmark_time("3f", "seconds", None)


def test_parse_landmarks_reads_the_command_lines_text(tmp_path):
    """``parse_landmarks``: the one reading of ``--landmarks`` (auto, none, a file, inline pairs)."""
    from elastic_motion.apps.landmark_files import TIME_UNITS, LandmarkFile, parse_landmarks
    from elastic_motion.errors import OptionError

    assert TIME_UNITS == ("seconds", "frames")
    assert parse_landmarks(None) is None and parse_landmarks("none") is None
    assert parse_landmarks("auto") == "auto"
    assert parse_landmarks("0.5:0.7, 1.4:1.9") == [(0.5, 0.7), (1.4, 1.9)]
    assert parse_landmarks("15:30,2s:60f", units="frames", fps=(30.0, 60.0)) == [(0.5, 0.5), (2.0, 1.0)]
    f = tmp_path / "pairs.txt"
    f.write_text("0.5 0.7\n")
    lf = parse_landmarks(str(f))
    assert isinstance(lf, LandmarkFile) and lf.pairs == ((0.5, 0.7),)
    for text, why in (("banana", "no such file"), ("1:2:3", "'tA:tB' pairs"), ("x:1", "expected a time")):
        with pytest.raises(OptionError, match=f"^landmarks: .*{why}"):
            parse_landmarks(text)
