"""2-D blend spaces (issue 33): motions placed by speed x turning rate, a Delaunay
triangulation, barycentric weights corrected until the blend's measured parameters meet the
point asked; DeepMimic walks, turning walks and run."""

from __future__ import annotations

import numpy as np
import pytest
from blend_testlib import walker

from elastic_motion.apps.blendspace import motion_turning_rate
from elastic_motion.apps.blendspace2d import NOTE_HIT, blendspace_2d
from elastic_motion.cli import main
from elastic_motion.errors import OptionError
from elastic_motion.motion.edit import axis_rotation

CLIPS = (
    "humanoid3d_walk.txt",
    "walker/turn_left0.txt",
    "walker/turn_left1.txt",
    "walker/turn_right0.txt",
    "walker/turn_right1.txt",
    "humanoid3d_run.txt",
)


@pytest.fixture(scope="module")
def clips(mocap_dir):
    return [str(mocap_dir / "deepmimic" / c) for c in CLIPS]


@pytest.fixture(scope="module")
def space(clips):
    return blendspace_2d(clips, ("speed", "turn"), contacts="off")


def test_turning_rate_is_the_root_heading_change_per_second():
    m = walker(duration=2.0)
    yaw = np.radians(30.0) * np.arange(m.n_frames) / m.fps  # 30 deg/s to the left, about +y
    rot = m.rotations.copy()
    rot[:, 0] = axis_rotation(yaw, "Y") @ rot[:, 0]
    assert motion_turning_rate(m.replace(rotations=rot)) == pytest.approx(30.0, rel=1e-9)
    rot[:, 0] = axis_rotation(-4.0 * yaw, "Y") @ m.rotations[:, 0]  # -120 deg/s: past 180 deg, unwrapped
    assert motion_turning_rate(m.replace(rotations=rot)) == pytest.approx(-120.0, rel=1e-9)


def test_deepmimic_turns_are_placed_left_and_right(space):
    x = dict(zip(space.prepared.labels, space.params.tolist(), strict=True))
    assert x["turn_left0"][1] > 15 and x["turn_left1"][1] > 30
    assert x["turn_right0"][1] < -30 and x["turn_right1"][1] < -30
    assert abs(x["humanoid3d_walk"][1]) < 10 and x["humanoid3d_run"][0] > 3
    # every triangle's weights: a motion's own point is that motion alone
    for k, p in enumerate(space.params):
        w = space.weights(p)
        assert w[k] == pytest.approx(1.0) and w.sum() == pytest.approx(1.0)


@pytest.mark.parametrize("p", [(2.0, -20.0), (1.5, 0.0)])
def test_a_point_is_hit_within_5_percent_of_the_range(space, p):
    plain = space.measure(space._blend(space.weights(p)).motion)
    plain_miss = np.abs((plain - p) / space.scale).max()
    res = space.at(p)
    (hit,) = (n for n in res.notes if n.kind == NOTE_HIT)
    measured = space.measure(res.motion)
    miss = np.abs((measured - p) / space.scale).max()
    assert miss == pytest.approx(hit.data["miss"]) and miss < 0.05
    assert plain_miss > 0.05  # the barycentric weights alone miss: the correction is needed
    assert res.weights.sum() == pytest.approx(1.0) and (res.weights >= 0).all()
    assert np.count_nonzero(res.weights) <= 3  # one triangle


def test_a_point_near_the_hulls_edge_is_hit_by_steps_to_the_hull(clips):
    """(3 m/s, -20 deg/s), default options (contacts kept): the corrections' steps leave the
    hull near the run -- sharp right turn edge; halving them stopped at a 5.6 % miss, the
    hull's nearest point reaches it."""
    p = (3.0, -20.0)
    space = blendspace_2d(clips, ("speed", "turn"))
    res = space.at(p)
    measured = space.measure(res.motion)
    assert np.abs((measured - p) / space.scale).max() < 0.05


def test_outside_the_hull_and_bad_points_are_refused(space, clips):
    with pytest.raises(OptionError, match=r"^at: expected a point inside the convex hull.*got \(3\.5, 40\)"):
        space.weights((3.5, 40.0))
    with pytest.raises(OptionError, match=r"^at: expected two finite numbers"):
        space.weights((1.0,))
    with pytest.raises(OptionError, match="span the plane"):
        blendspace_2d(clips[:3], [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]])
    with pytest.raises(OptionError, match="two of \\['speed', 'turn'\\]"):
        blendspace_2d(clips[:3], ("speed", "style"))


def test_given_points_give_barycentric_weights(clips):
    sp = blendspace_2d(clips[:3], [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], contacts="off")
    np.testing.assert_allclose(sp.weights((0.2, 0.3)), [0.5, 0.2, 0.3], atol=1e-12)
    res = sp.at((0.2, 0.3))
    np.testing.assert_allclose(res.weights, [0.5, 0.2, 0.3], atol=1e-12)  # not measured: no correction


def test_cli_two_parameters(clips, tmp_path, capsys):
    out = tmp_path / "bs.bvh"
    argv = ["blendspace", *clips, "--params", "speed,turn", "--at", "2,-20", "-o", str(out)]
    argv += ["--contacts", "off"]
    assert main(argv) == 0, capsys.readouterr().err
    text = capsys.readouterr().out
    assert "speed_m_s x turn_deg_s at 2,-20" in text and "measured (" in text and out.exists()
    argv[argv.index("--at") + 1] = "2"
    assert main(argv) == 2
    assert "--at: expected two numbers X,Y" in capsys.readouterr().err
