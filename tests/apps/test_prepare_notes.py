"""The preparation's notes: one kind per step, its numbers as data, the texts as they were."""

from __future__ import annotations

import json

import pytest
from blend_testlib import walker

from elastic_motion.apps.prepare import (
    FINGERS_NOT_CURVES,
    JOINTS_DROPPED,
    PLACED,
    RESAMPLED,
    TRIMMED,
    UNITS_TO_METRES,
    UP_AXIS_ROTATED,
    PrepareOptions,
    load_motion,
    prepare_motions,
)
from elastic_motion.motion import drop_joints, resample, set_up_axis, write_bvh
from elastic_motion.notes import Note


def test_set_steps_write_their_kinds_in_order():
    a = walker(name="A")
    b = walker(duration=2.6, freq=1.3, amp=0.7, speed=1.4, phase=0.4, yaw=0.7, name="B")
    b = resample(drop_joints(b, ["LeftHand"]), 60.0)
    prep = prepare_motions([a, b], PrepareOptions(joints="common"))
    assert [n.kind for n in prep.notes] == [JOINTS_DROPPED, RESAMPLED, PLACED]
    assert all(isinstance(n, Note) for n in prep.notes)
    dropped, resampled, placed = prep.notes
    assert str(dropped) == "A: dropped 2 joints not shared by all inputs: ['LeftHand', 'LeftHandIndex1']"
    assert dropped.data == {"input": "A", "joints": ["LeftHand", "LeftHandIndex1"]}
    assert str(resampled) == "B: resampled from 60 to 30 fps (the rate of A)"
    assert resampled.data == {"input": "B", "like": "A", "from_fps": 60.0, "to_fps": 30.0}
    assert str(placed) == f"B: placed like A ({placed.data['how']})" and placed.data["like"] == "A"


def test_per_input_steps_write_their_kinds(tmp_path):
    path = write_bvh(set_up_axis(walker(name="w"), "z"), tmp_path / "w.bvh")
    opts = PrepareOptions(units="cm", up="z", check_up_axis=False)
    prep = prepare_motions([path], opts.replace(trim=(0.5, None)))
    assert [n.kind for n in prep.notes] == [TRIMMED, UNITS_TO_METRES, UP_AXIS_ROTATED, FINGERS_NOT_CURVES]
    trim, units, up, fingers = prep.notes
    assert fingers.data == {"joints": ["LeftHandIndex1"]} and str(fingers).endswith("['LeftHandIndex1']")
    assert str(trim) == "w: kept 0.5-2 s (46 frames)"
    assert trim.data == {"input": "w", "start_s": 0.5, "stop_s": pytest.approx(2.0), "frames": 46}
    assert units.data == {"input": "w", "unit": "cm", "metres_per_unit": 0.01}
    assert str(up) == "w: rotated from z-up to y-up" and up.data["from"] == "z"
    # the input's report holds the same notes, and its summary lists their texts
    (report,) = prep.inputs
    assert report.notes == prep.notes[:3]  # the set's notes come after
    assert report.summary()["notes"] == [str(n) for n in report.notes]
    assert json.loads(json.dumps(report.summary()))["notes"] == [str(n) for n in report.notes]
    _, alone = load_motion(path, opts, trim=(0.5, None))
    assert alone == report
