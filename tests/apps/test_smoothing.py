"""The low-pass before a motion's curve is sampled (``WarpOptions.sample_smoothing``,
``motion_curves(..., smoothing=)``): the option, its path, and what it is for on real data."""

from __future__ import annotations

import numpy as np
import pytest

from elastic_motion.apps.align import motion_curves
from elastic_motion.apps.distance import distance_table
from elastic_motion.apps.prepare import prepare_motions
from elastic_motion.errors import OptionError
from elastic_motion.motion import drop_tpose, read_motion, resample, select_frames, to_lie_curve
from elastic_motion.motion.edit import smooth_motion
from elastic_motion.warp import WarpOptions
from elastic_motion.warp.options import DEFAULT_SAMPLE_SMOOTHING


@pytest.fixture(scope="module")
def walk(mocap_dir):
    """CMU 07_01, a 120 Hz walk (2.6 s)."""
    return drop_tpose(read_motion(mocap_dir / "cmu" / "bvh" / "07_01.bvh"))


def test_warp_options_field_is_validated_and_round_trips():
    assert WarpOptions().sample_smoothing == DEFAULT_SAMPLE_SMOOTHING == 1 / 60  # seconds
    opts = WarpOptions(method="dp", sample_smoothing=0)
    assert opts.sample_smoothing == 0.0 and isinstance(opts.sample_smoothing, float)
    assert WarpOptions.from_json(opts.to_json()) == opts
    old = {k: v for k, v in WarpOptions().to_json().items() if k != "sample_smoothing"}
    assert WarpOptions.from_json(old).sample_smoothing == 1 / 60  # settings written before the field
    for bad in (-0.1, float("nan"), float("inf"), True, "0.5"):
        with pytest.raises(OptionError, match="sample_smoothing"):
            WarpOptions(sample_smoothing=bad)


def test_motion_curves_smooth_before_sampling_and_only_then(walk):
    prep = prepare_motions([walk])
    m = prep.curve_motion(0)
    lie = dict(translation_weight=prep.translation_weight)
    expect = to_lie_curve(resample(smooth_motion(m, 0.5 / 30.0), 30.0), prep.joint_weights, **lie).values
    (got,) = motion_curves(prep, "lie", fps=30.0)  # the default: 1/60 s
    np.testing.assert_allclose(got.values, expect, atol=1e-12)
    (raw,) = motion_curves(prep, "lie", fps=30.0, smoothing=0.0)
    np.testing.assert_allclose(raw.values, to_lie_curve(resample(m, 30.0), prep.joint_weights, **lie).values)
    assert np.abs(raw.values - got.values).max() > 1e-3  # it did something
    # sigma in seconds, whatever the rate
    (c15,) = motion_curves(prep, "lie", fps=15.0, smoothing=0.05)
    e15 = to_lie_curve(resample(smooth_motion(m, 0.05), 15.0), prep.joint_weights, **lie).values
    np.testing.assert_allclose(c15.values, e15, atol=1e-12)
    # the full-rate curves (the ones a blend is made of) are never smoothed
    (full,) = motion_curves(prep, "lie")
    np.testing.assert_allclose(full.values, to_lie_curve(m, prep.joint_weights, **lie).values)


def test_half_frame_shift_noise_drops_with_the_default_smoothing(walk):
    """A (120 Hz) against itself played two source frames later: half a frame of the 30 fps
    curves, i.e. sampled at other instants (0 in the continuum but for the 1/60 s cut at each
    end). Without the low-pass the distance is 1.71 (a whole-frame shift, which samples the
    same instants, gives 0.65: the ends); with it 1.12. On 07_01, 08_02 and 09_11 the
    smoothed distance is 0.61-0.71 times the raw one."""
    a0, a1 = select_frames(walk, slice(0, -2)), select_frames(walk, slice(2, None))
    raw = distance_table([a0, a1], warp=WarpOptions(method="dp", sample_smoothing=0.0)).matrix[0, 1]
    smooth = distance_table([a0, a1], warp=WarpOptions(method="dp")).matrix[0, 1]
    assert raw > 1.5
    assert smooth < 0.75 * raw


def test_distance_no_longer_grows_with_the_sampling_rate(walk, mocap_dir):
    """CMU 07_01 against 08_02 (both 120 Hz) sampled at 30 and at 120 fps: without the
    low-pass the frame-to-frame noise adds to the SRV norm at the higher rate (DP: 3.95 ->
    4.65, +18 %); with 1/60 s, 3.66 -> 3.64 (-0.6 %)."""
    b = drop_tpose(read_motion(mocap_dir / "cmu" / "bvh" / "08_02.bvh"))
    prep = prepare_motions([walk, b])

    def d(fps: float, sigma: float) -> float:
        w = WarpOptions(method="dp", sample_fps=fps, sample_smoothing=sigma)
        return float(distance_table(prep, warp=w).matrix[0, 1])

    assert d(120.0, 0.0) > 1.1 * d(30.0, 0.0)
    assert d(120.0, 1 / 60) == pytest.approx(d(30.0, 1 / 60), rel=0.04)
