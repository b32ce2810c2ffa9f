"""The symmetric floor measure (apps.metrics.floor): skids, swing clearance, leg length."""

from __future__ import annotations

import numpy as np
import pytest
from loop_testlib import chain_skeleton

from elastic_motion.apps.metrics.floor import (
    ANKLE_HEIGHT_RATIO,
    SKID_DURATION,
    find_skids,
    foot_quality,
    leg_length,
)
from elastic_motion.motion import Motion, Skeleton


def _leg() -> Skeleton:
    # hips 0.9 above the floor when the leg is straight: thigh 0.4, shin 0.4, the foot at the
    # floor and its toe tip forward (loop_testlib's chain, named like a left leg)
    return chain_skeleton(("Hips", "LeftUpLeg", "LeftLeg", "LeftFoot"))


def _walk(root_x: np.ndarray, root_y: np.ndarray, fps: float = 30.0) -> Motion:
    f = root_x.shape[0]
    rot = np.broadcast_to(np.eye(3), (f, 4, 3, 3)).copy()
    root = np.stack([root_x, root_y, np.zeros(f)], axis=1)
    return Motion(_leg(), fps, root, rot, metres_per_unit=1.0)


def test_leg_length_is_thigh_and_shin_and_the_ankle_height():
    assert leg_length(_leg()) == pytest.approx(ANKLE_HEIGHT_RATIO * 0.8)


def test_a_foot_sliding_at_floor_level_is_one_skid_with_its_distance():
    fps = 30.0
    n = 60
    x = np.zeros(n)
    y = np.full(n, 0.9)  # the toe tip on the floor (0.9 - 0.4 - 0.4 - 0.1 = 0)
    y[:20] += 0.0
    # planted for 20 frames, slides 0.3 m in 15 frames (0.6 m/s, > 0.3 L/s), planted again
    x[20:35] = np.linspace(0.0, 0.3, 16)[1:]
    x[35:] = 0.3
    q = foot_quality(_walk(x, y, fps))
    slides = [s for s in q.skids if s.joint == "LeftFoot end site"]
    assert len(slides) == 1
    assert slides[0].distance_m == pytest.approx(0.3, abs=0.05)
    assert q.skid_count >= 1 and q.slid_m >= 0.3 - 0.05


def test_a_foot_moving_above_the_floor_or_briefly_is_no_skid():
    fps = 30.0
    n = 60
    x = np.linspace(0.0, 1.2, n)  # 0.6 m/s all along
    # 5 cm up: on its own floor (the lowest point is the floor), above the given one
    assert foot_quality(_walk(x, np.full(n, 0.95), fps), floor=0.0).skid_count == 0
    assert {s.joint for s in foot_quality(_walk(x, np.full(n, 0.95), fps)).skids} == {
        "LeftFoot",
        "LeftFoot end site",
    }
    # low and fast for less than SKID_DURATION (at 60 fps: 2 steps move, 3 frames fast)
    fps = 60.0
    assert int(SKID_DURATION * fps) > 3
    xs = np.zeros(n)
    xs[30:] = 0.02
    xs[31:] = 0.04
    assert foot_quality(_walk(xs, np.full(n, 0.9), fps)).skid_count == 0
    xs[31 : 31 + int(SKID_DURATION * fps)] = np.linspace(0.04, 0.2, int(SKID_DURATION * fps))
    xs[31 + int(SKID_DURATION * fps) :] = 0.2
    assert foot_quality(_walk(xs, np.full(n, 0.9), fps)).skid_count >= 1


def test_find_skids_needs_both_low_and_fast():
    fps, leg = 30.0, 1.0
    n = 10
    p = np.zeros((n, 1, 3))
    p[:, 0, 0] = np.arange(n) * 0.05  # 1.5 m/s
    low = np.zeros((n, 1))
    assert len(find_skids(low, p, fps, leg, ["toe"], 1)) == 1
    assert find_skids(low + 0.05, p, fps, leg, ["toe"], 1) == []
    still = np.zeros((n, 1, 3))
    assert find_skids(low, still, fps, leg, ["toe"], 1) == []
