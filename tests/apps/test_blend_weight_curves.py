"""N motions with time-varying weights blended in SRV space (issue 33): ``weight_curve`` knots
``u:w1/.../wK`` or a CSV file, on the warps to the common (Karcher) template."""

from __future__ import annotations

import numpy as np
import pytest
from blend_testlib import walker

from elastic_motion.apps.blend import blend_motions
from elastic_motion.apps.blend_options import BlendOptions, parse_weight_curve
from elastic_motion.cli import main
from elastic_motion.curves import DiscreteCurve, weighted_blend
from elastic_motion.errors import OptionError
from elastic_motion.groups import Euclidean
from elastic_motion.motion import forward_kinematics, read_bvh, write_bvh

PLAIN = {"warp": "dp", "contacts": "off", "trim_ends": False}


@pytest.fixture(scope="module")
def three():
    return (
        walker(duration=1.5, name="a"),
        walker(duration=1.8, freq=1.2, amp=0.6, speed=1.3, phase=0.3, name="b"),
        walker(duration=1.6, freq=1.1, amp=0.4, speed=1.6, name="c"),
    )


@pytest.fixture(scope="module")
def constant(three):
    return blend_motions(list(three), [0.2, 0.3, 0.5], **PLAIN)


def test_constant_weight_curve_is_the_n_motion_blend(three, constant):
    res = blend_motions(list(three), weight_curve="0:0.2/0.3/0.5,0.4:0.2/0.3/0.5,1:0.2/0.3/0.5", **PLAIN)
    assert res.motion.n_frames == constant.motion.n_frames
    np.testing.assert_allclose(res.weights, [0.2, 0.3, 0.5], atol=1e-12)
    for a, b in zip(res.warps, constant.warps, strict=True):
        np.testing.assert_array_equal(a, b)  # the same template
    np.testing.assert_allclose(forward_kinematics(res.motion), forward_kinematics(constant.motion), atol=1e-9)


@pytest.mark.parametrize("k", [0, 2])
def test_a_unit_weight_gives_that_motion_on_the_template(three, k):
    keys = ",".join(f"{u}:" + "/".join("1" if i == k else "0" for i in range(3)) for u in (0, 1))
    res = blend_motions(list(three), weight_curve=keys, **PLAIN)
    pk = res.prepared.motions[k]
    # w = e_k: the clock is input k's own (T(u) = d_k phi_k(u)), so frame i is its frame i
    assert res.motion.n_frames == pk.n_frames
    np.testing.assert_allclose(forward_kinematics(res.motion), forward_kinematics(pk), atol=1e-6)


def test_weights_vary_in_srv_space():
    """``weighted_blend`` with knots integrates ``sum_k w_k(t) q_k(t)`` (R^1: ``c' = w c_1' + ...``)."""
    t = np.linspace(0.0, 1.0, 101)
    c0 = DiscreteCurve(np.column_stack([t]), Euclidean(1), t)
    c1 = DiscreteCurve(np.column_stack([3.0 * t + 1.0]), Euclidean(1), t)
    knots = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 1.0]])  # w_1(t) = t
    out = weighted_blend([c0, c1], knots)
    # q = (1 - t) * 1 + t * sqrt(3), c' = q |q|, from c(0) = 0
    fine = np.linspace(0.0, 1.0, 20001)
    q = (1.0 - fine) + fine * np.sqrt(3.0)
    want = np.trapezoid(q**2, fine)
    assert out.evaluate(np.array([1.0]))[0, 0] == pytest.approx(want, abs=2e-4)
    with pytest.raises(ValueError, match="summing to 1"):
        weighted_blend([c0, c1], np.array([[0.0, 0.5, 0.6], [1.0, 0.0, 1.0]]))


def test_a_changing_weight_curve_starts_on_the_first_input(three):
    res = blend_motions(list(three), weight_curve="0:1/0/0,0.5:0/1/0,1:0/0/1", anchor=False, **PLAIN)
    assert res.weights == pytest.approx([0.25, 0.5, 0.25])  # the means over u
    first = forward_kinematics(res.motion)[0]
    np.testing.assert_allclose(first, forward_kinematics(res.prepared.motions[0])[0], atol=1e-9)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("u,a,b,c\n0,1,0,0\n1,0,1\n", r":3: expected 4 numbers"),
        ("time,a,b\n0,1,0\n1,0,1\n", r":1: expected a header 'u,w1,...,wK'"),
        ("# weights\nu,a,b,c\n0,1,0,0\n0.5,0.5,0.6,0\n1,0,0,1\n", r"knot 1 \(u = 0.5\).*sum 1.1"),
        ("u,a,b,c\n0,1,0,0\n1,zero,0,1\n", r":3: expected 4 numbers"),
    ],
)
def test_bad_weight_files_say_where_and_what(tmp_path, text, match):
    p = tmp_path / "w.csv"
    p.write_text(text)
    with pytest.raises(OptionError, match=match) as err:
        BlendOptions(weight_curve=p)
    assert str(p) in str(err.value) and str(err.value).startswith("weight_curve: ")


def test_bad_keys_and_counts_are_explained(three):
    with pytest.raises(OptionError, match=r"u:w1/w2/.../wK"):
        parse_weight_curve("0:1/0,1:0/0/1")
    with pytest.raises(OptionError, match=r"w_k >= 0 summing to 1.*knot 0"):
        parse_weight_curve("0:0.5/0.4/0,1:0/0/1")
    thirds = parse_weight_curve("0:0.333333/0.333333/0.333334,1:0.3333333/0.3333333/0.3333333")
    np.testing.assert_allclose(thirds[:, 1:].sum(axis=1), 1.0, atol=1e-15)  # rounding: rescaled
    with pytest.raises(OptionError, match=r"one weight per motion \(3\); got knots 2 weights"):
        blend_motions(list(three), weight_curve="0:1/0,1:0/1")


def test_cli_blends_three_motions_with_a_weight_file(three, tmp_path, capsys):
    paths = [str(write_bvh(m, tmp_path / f"{m.name}.bvh")) for m in three]
    wf = tmp_path / "w.csv"
    wf.write_text("u,a,b,c\n0,1,0,0\n0.5,0,1,0\n1,0,0,1\n")
    out = tmp_path / "abc.bvh"
    code = main(
        ["blend", *paths, "-o", str(out), "--weight-curve", str(wf), "--no-metrics", "--contacts", "off"]
    )
    text = capsys.readouterr()
    assert code == 0, text.err
    assert "weights of a/b/c by normalised time: 0:1/0/0, 0.5:0/1/0, 1:0/0/1" in text.out
    assert read_bvh(out).n_frames > 10
    wf.write_text("u,a,b\n0,1,0\n1,0,1\n")
    assert main(["blend", *paths, "-o", str(tmp_path / "x.bvh"), "--weight-curve", str(wf), "-q"]) != 0
    assert "--weight-curve" in capsys.readouterr().err
