"""Closed curves: the seed (start point) is optimised with the warp, coarse to fine."""

from __future__ import annotations

import numpy as np
import pytest

from elastic_motion.warp import optimal_warp, shift_seed, warp_energy


def outline(n: int, fingers: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """SRV of a closed hand-like outline (a star with round finger tips), n cells."""
    s = np.linspace(0, 1, n + 1)
    a = 2 * np.pi * s
    r = 1.0 + 0.35 * np.cos(fingers * a) ** 2 * (np.cos(fingers * a) > 0) + 0.1 * np.sin(a)
    c = np.column_stack([r * np.cos(a), r * np.sin(a)])
    v = np.diff(c, axis=0) * n
    return v / np.sqrt(np.linalg.norm(v, axis=1))[:, None], s


def test_recovers_seed_shift_and_warp():
    q, t = outline(256)
    q1 = q
    q0, t0 = shift_seed(q, t, 0.3)  # q0(s) = q1(s + 0.3)
    res = optimal_warp(q0, q1, t0=t0, closed=True)
    assert res.seed_shift == pytest.approx(0.3, abs=1.5 / 256)
    # energy of the found (shift, warp) is tiny compared with the unshifted problem
    plain = optimal_warp(q0, q1, t0=t0)
    assert res.energy < 1e-3 * plain.energy
    qs, ts = shift_seed(q1, t, res.seed_shift)
    assert warp_energy(q0, qs, res.vertices, t0, ts) == pytest.approx(res.energy, rel=1e-9)
    assert res.diagnostics.seeds_tried < 100


def test_closed_with_shift_between_nodes_and_warp():
    q, t = outline(200, fingers=4)
    q0, t0 = shift_seed(q, t, 0.6123)
    res = optimal_warp(q0, q, t0=t0, closed=True, method="dp+refine")
    assert abs(res.seed_shift - 0.6123) < 2.0 / 200
    assert res.distance < 0.2 * optimal_warp(q0, q, t0=t0).distance
