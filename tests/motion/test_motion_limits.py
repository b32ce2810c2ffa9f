"""Resource limits in the readers (issue 14): each signature of the hostile-input report.

A small file must never ask for unbounded memory: declared frame counts, frame rates,
durations and resampled sizes are checked against :mod:`elastic_motion.limits` before
anything is allocated, and the error names the file, the line, the value and the limit.
Readers open only regular files.
"""

from __future__ import annotations

import json
import os
import re
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from elastic_motion import limits
from elastic_motion._io import read_text
from elastic_motion.errors import OptionError, ParseError
from elastic_motion.motion import read_amc, read_asf, read_bvh, read_deepmimic
from elastic_motion.motion.deepmimic import DEEPMIMIC_JOINTS

BVH_HEAD = (
    "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
    "Yrotation\n  JOINT Leg\n  {\n    OFFSET 0 -40 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n"
    "    End Site\n    {\n      OFFSET 0 -5 0\n    }\n  }\n}\nMOTION\n"
)
ROW = "0 90 0 0 0 0 10 0 0\n"


def _bvh(tmp_path: Path, frames: str, frame_time: str = "0.0333333", rows: int = 3) -> Path:
    p = tmp_path / "clip.bvh"
    p.write_text(BVH_HEAD + f"Frames: {frames}\nFrame Time: {frame_time}\n" + ROW * rows)
    return p


def _dm(tmp_path: Path, durations: list[float], name: str = "clip.txt") -> Path:
    joints = [v for _, _, rev in DEEPMIMIC_JOINTS[1:] for v in ([0.3] if rev else [1.0, 0.0, 0.0, 0.0])]
    frames = [[d, 0.0, 0.9, 0.1 * k, 1.0, 0.0, 0.0, 0.0, *joints] for k, d in enumerate(durations)]
    p = tmp_path / name
    p.write_text(json.dumps({"Loop": "none", "Frames": frames}))
    return p


# ------------------------------------------------------------------------------------------
# BVH
# ------------------------------------------------------------------------------------------


def test_huge_declared_frame_count_is_refused_before_allocating(tmp_path: Path) -> None:
    p = _bvh(tmp_path, "1000000000000000")
    tracemalloc.start()
    t0 = time.perf_counter()
    with pytest.raises(
        ParseError, match=r"clip\.bvh:17: .*at most 1000000 \(limit max_frames.*1000000000000000"
    ):
        read_bvh(p)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert time.perf_counter() - t0 < 2.0 and peak < 50e6


def test_frame_count_within_the_limit_but_beyond_the_file_allocates_nothing(tmp_path: Path) -> None:
    """999,999 frames declared, 3 present: the count is checked against the lines, not allocated."""
    p = _bvh(tmp_path, "999999")
    tracemalloc.start()
    with pytest.raises(ParseError, match="expected 999999 frames"):
        read_bvh(p)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 20e6  # 999,999 x 9 values would be 72 MB


def test_frame_count_in_scientific_notation_names_file_and_line(tmp_path: Path) -> None:
    with pytest.raises(ParseError, match=r"clip\.bvh:17: expected the number of frames .*'1e20'"):
        read_bvh(_bvh(tmp_path, "1e20"))


def test_a_frame_count_of_thousands_of_digits_is_quick(tmp_path: Path) -> None:
    t0 = time.perf_counter()
    with pytest.raises(ParseError, match="max_frames"):
        read_bvh(_bvh(tmp_path, "9" * 100_000))
    assert time.perf_counter() - t0 < 1.0


@pytest.mark.parametrize(
    ("frame_time", "limit"), [("1e-9", "max_fps"), ("1e307", "min_fps"), ("1e-307", "max_fps")]
)
def test_frame_rates_outside_the_range_are_refused(tmp_path: Path, frame_time: str, limit: str) -> None:
    with pytest.raises(ParseError, match=rf"clip\.bvh:18: .*limit {limit}"):
        read_bvh(_bvh(tmp_path, "3", frame_time))


def test_duration_limit(tmp_path: Path) -> None:
    with pytest.raises(ParseError, match="max_duration"):
        read_bvh(_bvh(tmp_path, "20000", "5"))  # 20,000 frames at 0.2 fps: 27.8 h > 24 h, before the frames


def test_limits_can_be_raised(tmp_path: Path) -> None:
    p = _bvh(tmp_path, "3", "1e-5")  # 100,000 fps
    with pytest.raises(ParseError, match="max_fps"):
        read_bvh(p)
    with limits.override(max_fps=1e6):
        assert read_bvh(p).fps == pytest.approx(1e5)
    with pytest.raises(ParseError, match="max_fps"):  # restored after the block
        read_bvh(p)


def test_limits_from_the_environment() -> None:
    lim = limits._from_env("max_frames=5e6, max_fps=2e4")
    assert lim.max_frames == 5_000_000 and isinstance(lim.max_frames, int) and lim.max_fps == 2e4
    with pytest.raises(ValueError, match="ELASTIC_MOTION_LIMITS"):
        limits._from_env("max_frame=5")
    with pytest.raises(ValueError, match="positive finite"):
        limits._from_env("max_fps=nan")


def test_too_many_joints_are_refused_early(tmp_path: Path) -> None:
    depth = 3000
    nest = "".join(
        f"JOINT j{k}\n{{\nOFFSET 0 1 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n" for k in range(depth)
    )
    p = tmp_path / "deep.bvh"
    p.write_text(BVH_HEAD.replace("  JOINT Leg", nest + "}\n" * depth + "  JOINT Leg", 1) + "Frames: 1\n")
    t0 = time.perf_counter()
    with pytest.raises(ParseError, match="max_joints"):
        read_bvh(p)
    assert time.perf_counter() - t0 < 2.0


# ------------------------------------------------------------------------------------------
# DeepMimic
# ------------------------------------------------------------------------------------------


def test_one_long_frame_duration_is_not_resampled_to_millions_of_frames(tmp_path: Path) -> None:
    p = _dm(tmp_path, [1 / 30] * 3 + [1e4] + [1 / 30] * 3)
    tracemalloc.start()
    with pytest.raises(ParseError, match=r"max_resample_growth.*got 300\d\d\d"):
        read_deepmimic(p)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 20e6
    hold = _dm(tmp_path, [1 / 30] * 3 + [100.0] + [1 / 30] * 3, "hold.txt")  # 3006 frames from 7
    with pytest.raises(ParseError, match="max_resample_growth"):
        read_deepmimic(hold)
    with limits.override(max_resample_growth=1000):  # the user can ask for it
        assert read_deepmimic(hold).n_frames == 3006


@pytest.mark.parametrize(("duration", "limit"), [(1e6, "max_duration"), (1.797e308, "max_duration")])
def test_enormous_durations_are_parse_errors_not_overflow(
    tmp_path: Path, duration: float, limit: str
) -> None:
    with pytest.raises(ParseError, match=limit):
        read_deepmimic(_dm(tmp_path, [1 / 30] * 3 + [duration] + [1 / 30] * 3))


def test_tiny_durations_are_refused_by_the_frame_rate_limit(tmp_path: Path) -> None:
    with pytest.raises(ParseError, match="max_fps"):
        read_deepmimic(_dm(tmp_path, [1e-300] * 5))


def test_integer_of_thousands_of_digits_is_a_parse_error(tmp_path: Path) -> None:
    p = _dm(tmp_path, [1 / 30] * 4)
    p.write_text(re.sub(r"0\.9", "9" * 5000, p.read_text(), count=1))
    with pytest.raises(ParseError):
        read_deepmimic(p)


def test_quaternion_with_a_1e308_component_is_normalised_without_overflow(tmp_path: Path) -> None:
    p = _dm(tmp_path, [1 / 30] * 4)
    data = json.loads(p.read_text())
    data["Frames"][1][4:8] = [1.0, 0.0, 1e308, 0.0]  # the root: 180 degrees about y
    p.write_text(json.dumps(data))
    m = read_deepmimic(p)
    assert np.isfinite(m.rotations).all()
    np.testing.assert_allclose(m.rotations[1, 0], np.diag([-1.0, 1.0, -1.0]), atol=1e-12)


# ------------------------------------------------------------------------------------------
# ASF/AMC and files that are not regular files
# ------------------------------------------------------------------------------------------


def test_amc_frame_rate_limits(tmp_path: Path, mocap_dir: Path) -> None:
    asf = read_asf(mocap_dir / "cmu" / "asfamc" / "02.asf")
    amc = mocap_dir / "cmu" / "asfamc" / "02_01.amc"
    for fps in (1e9, 1e-9):
        with pytest.raises(OptionError, match="fps"):
            read_amc(asf, amc, fps=fps)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
@pytest.mark.parametrize("reader", [read_bvh, read_deepmimic, read_asf])
def test_a_fifo_is_refused_at_once(tmp_path: Path, reader) -> None:
    fifo = tmp_path / "x.bvh"
    os.mkfifo(fifo)
    t0 = time.perf_counter()
    with pytest.raises(ParseError, match=r"x\.bvh: expected a regular file, found a FIFO"):
        reader(fifo)
    assert time.perf_counter() - t0 < 1.0


def test_links_and_folders_are_parse_errors(tmp_path: Path) -> None:
    (tmp_path / "dir.bvh").mkdir()
    (tmp_path / "dangling.bvh").symlink_to(tmp_path / "missing.bvh")
    (tmp_path / "a.bvh").symlink_to(tmp_path / "b.bvh")
    (tmp_path / "b.bvh").symlink_to(tmp_path / "a.bvh")
    for name, what in [
        ("dir.bvh", "found a directory"),
        ("dangling.bvh", "target does not exist"),
        ("a.bvh", "points to itself"),
    ]:
        with pytest.raises(ParseError, match=what):
            read_bvh(tmp_path / name)


def test_read_text_allocates_about_the_file_size(tmp_path: Path) -> None:
    p = tmp_path / "small.bvh"
    p.write_text("x" * 1000)
    tracemalloc.start()
    assert read_text(p) == "x" * 1000
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 1e6  # not the 4 GB file-size limit


def test_file_size_limit(tmp_path: Path) -> None:
    p = _bvh(tmp_path, "3")
    with limits.override(max_file_bytes=100), pytest.raises(ParseError, match="max_file_bytes"):
        read_bvh(p)


# ------------------------------------------------------------------------------------------
# Found by the long fuzz run (benchmarks/fuzz_readers.py)
# ------------------------------------------------------------------------------------------


def test_a_duration_too_small_to_advance_the_clock_is_a_parse_error(tmp_path: Path) -> None:
    """5e-324 s after 0.1 s adds nothing: the resampling's times would not increase."""
    with pytest.raises(ParseError, match="advances the time in frame 3"):
        read_deepmimic(_dm(tmp_path, [1 / 30] * 3 + [5e-324] + [1 / 30] * 3))


def test_amc_frame_number_of_thousands_of_digits_is_a_parse_error(tmp_path: Path, mocap_dir: Path) -> None:
    src = (mocap_dir / "cmu" / "asfamc" / "02_01.amc").read_text()
    amc = tmp_path / "x.amc"
    amc.write_text(re.sub(r"(?m)^2$", "9" * 5000, src, count=1))
    with pytest.raises(ParseError, match=r"x\.amc:\d+: expected a frame number.*5000 digits"):
        read_amc(read_asf(mocap_dir / "cmu" / "asfamc" / "02.asf"), amc)


def test_a_long_digit_run_is_rejected_in_linear_time(tmp_path: Path) -> None:
    """The number pattern had nested quantifiers (``\\d+\\.?\\d*``): quadratic backtracking on a
    long digit run that does not end a number (a 30 s hang in the fuzz run)."""
    p = tmp_path / "digits.bvh"
    p.write_text(BVH_HEAD.replace("OFFSET 0 -40 0", "OFFSET 0 " + "9" * 40_000 + "x 0", 1) + "Frames: 1\n")
    t0 = time.perf_counter()
    with pytest.raises(ParseError, match="expected an OFFSET value"):
        read_bvh(p)
    assert time.perf_counter() - t0 < 1.0
