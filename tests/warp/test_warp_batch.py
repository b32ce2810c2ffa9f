"""The batched DP (``dp_energies``): the same DP as ``optimal_warp(method="dp")``, many pairs."""

from __future__ import annotations

import numba
import numpy as np
import pytest
from warp_testlib import all_paths

from elastic_motion.curves import srv_transform
from elastic_motion.warp import coprime_steps, optimal_warp, warp_energy
from elastic_motion.warp.solver import dp_energies


def _reference(q0, q1, pairs, neighbourhood):
    return np.array(
        [optimal_warp(q0[a], q1[b], method="dp", neighbourhood=neighbourhood).energy for a, b in pairs]
    )


@pytest.mark.parametrize(
    ("n0", "n1", "m", "d"), [(12, 12, 10, 3), (9, 14, 4, 5), (15, 8, 6, 2), (3, 3, 10, 1), (20, 20, 1, 4)]
)
def test_equals_optimal_warp_on_random_curves(n0, n1, m, d):
    rng = np.random.default_rng(n0 * 100 + n1 * 10 + m)
    q0 = rng.normal(size=(4, n0, d))
    q1 = rng.normal(size=(3, n1, d))
    q1[1] = np.cumsum(rng.normal(size=(n1, d)), axis=0) / 3  # smooth: paths away from the diagonal
    pairs = np.array([(a, b) for a in range(4) for b in range(3)])
    got = dp_energies(q0, q1, pairs, neighbourhood=m)
    np.testing.assert_allclose(got, _reference(q0, q1, pairs, m), rtol=1e-12, atol=1e-14)


def test_equals_brute_force_over_lattice_paths():
    rng = np.random.default_rng(3)
    q0, q1 = rng.normal(size=(1, 7, 3)), rng.normal(size=(1, 6, 3))
    t0, t1 = np.linspace(0, 1, 8), np.linspace(0, 1, 7)
    best = min(
        warp_energy(q0[0], q1[0], np.column_stack([t0[[p[0] for p in path]], t1[[p[1] for p in path]]]))
        for path in all_paths(7, 6, coprime_steps(3))
    )
    assert dp_energies(q0, q1, [[0, 0]], neighbourhood=3)[0] == pytest.approx(best, rel=1e-12)


def test_identical_curves_have_energy_zero_and_shifted_copies_are_found():
    rng = np.random.default_rng(4)
    q = np.cumsum(rng.normal(size=(40, 6)), axis=0)
    q2 = np.stack([q, q])
    assert dp_energies(q2, q2, [[0, 1], [1, 0]]).tolist() == [0.0, 0.0]


@pytest.mark.mocap
def test_equals_optimal_warp_on_cmu_windows(mocap_dir):
    motion = pytest.importorskip("elastic_motion.motion")
    clip = motion.drop_tpose(motion.read_motion(mocap_dir / "cmu" / "bvh" / "07_01.bvh"))
    n = 48
    qs = []
    for start in (0, 37, 90, 150):
        w = motion.select_frames(clip, slice(start, start + 100))
        target = np.linspace(w.times[0], w.times[-1], n + 1)
        w = motion.resample_at_times(w, w.times, target, fps=w.fps)
        qs.append(srv_transform(motion.to_lie_curve(w)).q)
    q = np.stack(qs)
    pairs = np.array([(a, b) for a in range(4) for b in range(4) if a != b])
    got = dp_energies(q, q, pairs)
    np.testing.assert_allclose(got, _reference(q, q, pairs, 10), rtol=1e-12)
    assert (got > 0).all()


def test_threads_and_batching_do_not_change_the_bits():
    rng = np.random.default_rng(5)
    q = rng.normal(size=(6, 16, 4))
    pairs = np.array([(a, b) for a in range(6) for b in range(6)])
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = dp_energies(q, q, pairs)
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        many = dp_energies(q, q, pairs)
    finally:
        numba.set_num_threads(before)
    assert one.tobytes() == many.tobytes()
    part = dp_energies(q[[2, 4]], q[[1, 5]], [[0, 0], [1, 1]])
    assert part.tobytes() == many[[2 * 6 + 1, 4 * 6 + 5]].tobytes()


def test_curves_of_very_different_lengths_use_the_refined_grid():
    rng = np.random.default_rng(6)
    q0, q1 = rng.normal(size=(1, 4, 2)), rng.normal(size=(1, 30, 2))
    got = dp_energies(q0, q1, [[0, 0]], neighbourhood=2)
    assert got[0] == pytest.approx(_reference(q0, q1, [(0, 0)], 2)[0], rel=1e-12)


def test_bad_input_is_named():
    q = np.zeros((2, 5, 3))
    with pytest.raises(ValueError, match="q1: expected the dimension D = 3"):
        dp_energies(q, np.zeros((2, 5, 4)), [[0, 0]])
    with pytest.raises(ValueError, match=r"pairs\[:, 1\]: expected indices in \[0, 2\)"):
        dp_energies(q, q, [[0, 2]])
    with pytest.raises(ValueError, match="pairs: expected integer indices"):
        dp_energies(q, q, [[0.0, 1.0]])
    bad = q.copy()
    bad[1, 2, 0] = np.nan
    with pytest.raises(ValueError, match="q0: expected finite values"):
        dp_energies(bad, q, [[0, 0]])
    with pytest.raises(ValueError, match=r"q0: expected SRV arrays of one shape"):
        dp_energies(np.zeros((5, 3)), q, [[0, 0]])
    assert dp_energies(q, q, np.zeros((0, 2), dtype=int)).shape == (0,)
