"""Time-varying weights: a transition from A into B (``weight_curve``)."""

from __future__ import annotations

import numpy as np
import pytest
from blend_testlib import walker

from elastic_motion.apps.blend import NOTE_WEIGHT_CURVE, blend_motions, parse_weight_curve
from elastic_motion.apps.blend.sampling import sample_rotations
from elastic_motion.errors import OptionError
from elastic_motion.groups import SO3
from elastic_motion.motion import forward_kinematics

SO3G = SO3()


@pytest.fixture(scope="module")
def pair():
    a = walker(duration=2.0, freq=1.0, amp=0.5, speed=1.0, name="A")
    b = walker(duration=2.6, freq=1.3, amp=0.7, speed=1.4, phase=0.4, name="B")
    return a, b


def _angle(r0, r1):
    return np.linalg.norm(SO3G.log(np.swapaxes(r0, -1, -2) @ r1), axis=-1)


def test_constant_weight_curves_give_the_inputs(pair):
    a, b = pair
    res = blend_motions([a, b], weight_curve="0:0,1:0", warp="dp", contacts="off")
    assert res.motion.n_frames == a.n_frames
    assert _angle(res.motion.rotations[:, :10], a.rotations[:, :10]).max() < 1e-6
    np.testing.assert_allclose(
        forward_kinematics(res.motion), forward_kinematics(res.prepared.motions[0]), atol=1e-6
    )
    res = blend_motions([a, b], weight_curve=[[0.0, 1.0], [1.0, 1.0]], warp="dp", contacts="off")
    assert res.motion.n_frames == b.n_frames
    pb = res.prepared.motions[1]
    assert _angle(res.motion.rotations[:, 1:10], pb.rotations[:, 1:10]).max() < 1e-6


def test_transition_starts_like_a_ends_like_b_and_runs_on_the_blended_clock(pair):
    a, b = pair
    res = blend_motions([a, b], weight_curve="0:0,1:1", warp="dp", contacts="off")
    pa, pb = res.prepared.motions
    m = res.motion
    # the SRV blend starts on A's pose; the pose anchoring moves it by its slow correction
    # (0.003 rad here); unanchored, the start is A's exactly
    assert _angle(m.rotations[0, 1:10], pa.rotations[0, 1:10]).max() < 0.005
    plain = blend_motions([a, b], weight_curve="0:0,1:1", warp="dp", contacts="off", anchor=False)
    assert _angle(plain.motion.rotations[0, 1:10], pa.rotations[0, 1:10]).max() < 1e-9
    # the last frame: s(u) ~ 1, B's pose at the matched time, up to the SRV blend's drift
    # (integrated velocities, not frame-wise poses: 0.008 rad unanchored, 0.004 anchored)
    u = res.timing[-1]
    tb = np.interp(u, res.warps[1][:, 0], res.warps[1][:, 1]) * pb.duration
    want = sample_rotations(pb, np.arange(1, 10), np.array([tb]))[0]
    assert u > 0.98 and _angle(m.rotations[-1, 1:10], want).max() < 1.0 * (1 - u) + 0.01  # |A - B| < 1 rad
    # dT/du = (1 - u) dA + u dB phi'(u): with phi the identity, T(1) = (dA + dB) / 2
    ident = blend_motions([a, b], weight_curve="0:0,1:1", warp="none", contacts="off")
    assert ident.motion.duration == pytest.approx((a.duration + b.duration) / 2, abs=1.5 / a.fps)
    # the root moves forward all the way (velocities blended, no jump)
    z = forward_kinematics(m)[:, 0, 2]
    assert (np.diff(z) > 0).all() and np.abs(np.diff(z, 2)).max() < 0.02
    (note,) = (n for n in res.notes if n.kind == NOTE_WEIGHT_CURVE)
    assert "weight curve" in str(note) and note.data["knots"] == [[0.0, 0.0], [1.0, 1.0]]


@pytest.mark.parametrize(
    ("value", "match"),
    [
        ("0:0,0.5:1.2,1:1", "in \\[0, 1\\]"),
        ("0:0,0.8:1", "defined on \\[0, 1\\]"),
        ("0.1:0,1:1", "defined on \\[0, 1\\]"),
        ("0:0,0.6:1,0.5:0.5,1:1", "increasing"),
        ("0:0", "two"),
        ("zero to one", "knots"),
    ],
)
def test_bad_weight_curves_are_explained(value, match):
    with pytest.raises(OptionError, match=match):
        parse_weight_curve(value)


def test_weight_curve_needs_two_motions_and_no_weights(pair):
    a, b = pair
    with pytest.raises(OptionError, match="not both"):
        blend_motions([a, b], 0.5, weight_curve="0:0,1:1")
    with pytest.raises(OptionError, match="two motions"):
        blend_motions([a, b, a], weight_curve="0:0,1:1")
