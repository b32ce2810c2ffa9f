"""The shared records and vocabularies of the apps: notes, options with overrides, the
representation, the contact policy."""

from __future__ import annotations

import dataclasses
import json
from typing import Literal

import numpy as np
import pytest

from elastic_motion._options import choices, options_from_json, with_overrides
from elastic_motion.apps.report import jsonable
from elastic_motion.errors import OptionError
from elastic_motion.motion import EULER, LIE, METHODS, Motion, Skeleton, representation
from elastic_motion.motion.contacts import CONTACT_POLICIES, contact_policy
from elastic_motion.notes import Note, first_of_kind, note_texts, of_kind
from elastic_motion.warp import WarpOptions


def test_note_reads_as_its_text_and_code_reads_its_kind():
    n = Note("loop.hitch", "a hitch at the seam: 2.1x", {"ratio": 2.1})
    assert str(n) == "a hitch at the seam: 2.1x"
    assert f"note: {n}" == "note: a hitch at the seam: 2.1x"
    assert n.kind == "loop.hitch" and n.data["ratio"] == 2.1
    notes = (Note("prepare.units", "lengths from cmu to metres"), n)
    assert note_texts(notes) == ["lengths from cmu to metres", "a hitch at the seam: 2.1x"]
    assert of_kind(notes, "loop.hitch") == [n]
    assert first_of_kind(notes, "loop.whip") is None
    # a report lists the texts
    assert json.loads(json.dumps(jsonable({"notes": notes}))) == {"notes": note_texts(notes)}


def test_note_data_is_a_copy_and_equality_includes_kind():
    data = {"ratio": 1.0}
    n = Note("loop.hitch", "x", data)
    data["ratio"] = 5.0
    assert n.data["ratio"] == 1.0
    assert n == Note("loop.hitch", "x", {"ratio": 1.0})
    assert n != Note("loop.whip", "x", {"ratio": 1.0})
    assert len({n, Note("loop.hitch", "x", {"ratio": 1.0})}) == 1
    with pytest.raises(dataclasses.FrozenInstanceError):
        n.kind = "other"  # type: ignore[misc]
    with pytest.raises(ValueError, match="kind"):
        Note("", "text")


def test_with_overrides_changes_fields_and_names_unknown_ones():
    base = WarpOptions(method="dp")
    assert with_overrides(WarpOptions, base, {}) is base
    assert with_overrides(WarpOptions, None, {"neighbourhood": 4}) == WarpOptions(neighbourhood=4)
    assert with_overrides(WarpOptions, base, {"neighbourhood": 4}) == WarpOptions(
        method="dp", neighbourhood=4
    )
    with pytest.raises(OptionError) as err:
        with_overrides(WarpOptions, None, {"neighborhood": 4})
    assert err.value.option == "neighborhood" and "neighbourhood" in str(err.value)
    with pytest.raises(OptionError, match="expected a WarpOptions; got dict"):
        with_overrides(WarpOptions, {"method": "dp"}, {})  # type: ignore[arg-type]
    # the options validate themselves
    with pytest.raises(OptionError, match="neighbourhood"):
        with_overrides(WarpOptions, None, {"neighbourhood": 0})


def test_options_from_json_round_trip_and_unknown_keys():
    o = WarpOptions(method="dp", sample_fps=60.0)
    assert options_from_json(WarpOptions, o.to_json(), argument="warp") == o
    with pytest.raises(OptionError, match=r"unknown fields \['fps'\]"):
        options_from_json(WarpOptions, {"fps": 3}, argument="warp")


def test_choices_reads_a_literal():
    assert choices(Literal["a", "b"]) == ("a", "b")
    with pytest.raises(TypeError):
        choices(int)


def test_representation_home_accepts_euler_and_names_the_argument():
    assert METHODS == ("lie", "euler-elastic")
    assert representation("lie") is LIE and LIE.is_lie
    assert representation("euler-elastic") is EULER and representation("euler") is EULER
    assert representation(EULER) is EULER
    assert EULER.key == "euler" and LIE.key == "lie" and str(EULER) == "euler-elastic"
    with pytest.raises(OptionError) as err:
        representation("quaternion", "--method")
    assert err.value.option == "--method" and "euler-elastic" in str(err.value)


def _small_motion() -> Motion:
    sk = Skeleton(
        names=("root", "hip", "knee"),
        parents=[-1, 0, 1],
        offsets=[[0, 0, 0], [0.1, -0.1, 0], [0, -0.4, 0]],
        channels=(
            ("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation"),
            ("Zrotation", "Yrotation", "Xrotation"),
            ("Zrotation", "Yrotation", "Xrotation"),
        ),
    )
    t = np.linspace(0.0, 1.0, 12)
    angles = np.stack([0.4 * np.sin(2 * t + k) for k in range(9)], axis=1).reshape(12, 3, 3)
    from elastic_motion.motion.rotations import euler_to_matrix

    rot = euler_to_matrix(angles, "ZYX")
    root = np.stack([t, 0.9 + 0.01 * np.sin(6 * t), 0.2 * t], axis=1)
    return Motion(sk, 30.0, root, rot)


def test_representation_round_trips_a_motion():
    tiny_motion = _small_motion()
    for rep in (LIE, EULER):
        back = rep.from_curve(rep.to_curve(tiny_motion), tiny_motion)
        assert back.n_frames == tiny_motion.n_frames
        assert abs(back.rotations - tiny_motion.rotations).max() < 1e-9
        assert abs(back.root_translation - tiny_motion.root_translation).max() < 1e-12


def test_contact_policy_one_vocabulary():
    assert CONTACT_POLICIES == ("keep", "report", "off")
    assert contact_policy("auto") == "keep" and contact_policy("none") == "off"
    assert contact_policy(None) == "off" and contact_policy("report") == "report"
    with pytest.raises(OptionError) as err:
        contact_policy("plant", "--contacts")
    assert err.value.option == "--contacts"
