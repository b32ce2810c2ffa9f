"""Issue 30: a loop's safe default window, its refusal, the whip around the seam and the
report of the joints it leaves free."""

from __future__ import annotations

import json

import numpy as np
import pytest

from elastic_motion.apps.loop import LoopRefused, loop_motion
from elastic_motion.apps.loop.window import WINDOW_CHOICE
from elastic_motion.apps.metrics import seam_metrics
from elastic_motion.vocabulary import WINDOW_MODES


def test_the_default_window_is_the_safe_one():
    from elastic_motion.apps.loop import LoopOptions

    assert LoopOptions().window == "safe" and WINDOW_MODES[0] == "safe"
    assert LoopOptions().change_bound == 0.15 and LoopOptions().force is False


@pytest.mark.mocap
def test_a_clip_that_closes_with_little_change_loops_whole(mocap_dir):
    res = loop_motion(mocap_dir / "deepmimic/humanoid3d_walk.txt")
    assert res.window is None and res.change_m <= 0.15
    note = res.notes[0]
    assert note.kind == WINDOW_CHOICE and "the whole clip" in str(note)
    assert note.data["whole_change_m"] == pytest.approx(res.change_m, abs=0.02)


@pytest.mark.mocap
def test_a_clip_that_does_not_repeat_loops_its_best_cycle_and_says_why(mocap_dir):
    """CMU 09_11 closed whole moves a joint by 0.7 m: the default loops its best cycle and the
    first note says so, with the whole clip's number."""
    res = loop_motion(mocap_dir / "cmu/bvh/09_11.bvh")
    assert res.window is not None and res.change_m <= 0.15
    note = res.notes[0]
    assert note.kind == WINDOW_CHOICE and note.data["whole_change_m"] > 0.5
    assert f"frames {res.window.start}..{res.window.stop - 1}" in str(note)
    assert res.feet_after.skid_count <= res.feet_before.skid_count


@pytest.mark.mocap
def test_a_loop_that_rewrites_its_clip_is_refused_unless_forced(mocap_dir, tmp_path, capsys):
    path = mocap_dir / "cmu/bvh/09_11.bvh"
    with pytest.raises(LoopRefused) as err:
        loop_motion(path, window=None)
    message = str(err.value)
    assert message.startswith(
        "force: not given, so the loop of the whole clip is refused: it moves a joint by up to 0.7"
    )
    assert "--window auto" in message and "--force" in message
    assert err.value.result is not None and err.value.result.change_m > 0.5
    forced = loop_motion(path, window=None, force=True)
    assert forced.change_m == pytest.approx(err.value.result.change_m)
    # the command line: exit 2 with the message, 0 with --force
    from elastic_motion.cli import main

    out = tmp_path / "loop.bvh"
    assert main(["loop", str(path), "-o", str(out), "--window", "whole", "-q"]) == 2
    assert "refused" in capsys.readouterr().err and not out.exists()
    assert main(["loop", str(path), "-o", str(out), "--window", "whole", "--force", "-q"]) == 0
    assert out.exists()


@pytest.mark.mocap
def test_the_first_line_says_which_window_and_why(mocap_dir, tmp_path, capsys):
    from elastic_motion.cli import main

    out, rep = tmp_path / "loop.bvh", tmp_path / "loop.json"
    assert main(["loop", str(mocap_dir / "cmu/bvh/09_11.bvh"), "-o", str(out), "--json", str(rep), "-q"]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first.startswith("window: frames ") and "the whole clip's loop would change it" in first
    report = json.loads(rep.read_text())
    assert report["change_m"] <= 0.15 and report["notes"][0] == first
    assert set(report["free_joints_seam_deg"]) == set(report["free_joints"])


@pytest.mark.mocap
def test_an_auto_window_of_a_walk_walks(mocap_dir):
    """A walk's auto window carries the walk: its root moves at least a quarter of the clip's
    median speed (a near-standing lead-in closes with millimetres of change)."""
    for rel in ("cmu/bvh/131_01.bvh", "cmu/bvh/07_01.bvh"):
        res = loop_motion(mocap_dir / rel, window="auto", force=True, contacts="report")
        m = res.prepared.motions[0]
        floor = np.delete(m.root_translation, 1, axis=1)
        speed = np.linalg.norm(np.gradient(floor, axis=0), axis=1) * m.fps
        w = res.window
        assert speed[w.start : w.stop].mean() >= 0.25 * np.median(speed)


def test_the_whip_around_the_seam_is_measured():
    """A cycle closed by bending its last frames: the jump at the seam frame is small, the
    acceleration just before it is many times the clip's own."""
    from loop_testlib import chain_skeleton

    from elastic_motion.motion import Motion
    from elastic_motion.motion.rotations import euler_to_matrix

    f, fps = 61, 30.0
    t = np.arange(f) / fps
    angles = np.zeros((f, 4, 3))
    angles[:, 1, 2] = 0.5 * np.sin(2 * np.pi * t / 2.0)  # a smooth hip swing, one period
    smooth = Motion(chain_skeleton(), fps, np.zeros((f, 3)) + [0, 0.9, 0], euler_to_matrix(angles, "ZYX"))
    whip = angles.copy()
    whip[-4:, 2, 2] += np.array([0.0, 0.3, -0.3, 0.0])  # a knee that snaps in the last frames
    whipped = smooth.replace(rotations=euler_to_matrix(whip, "ZYX"))
    calm = seam_metrics(smooth, original=smooth)
    snap = seam_metrics(whipped, original=smooth)
    assert calm.seam_acceleration_ratio < 2.0
    assert snap.seam_acceleration_ratio > 5.0 and snap.seam_acceleration_point in (
        "knee",
        "foot",
        "foot end site",
    )
    assert snap.seam_velocity_jump_ratio < snap.seam_acceleration_ratio
