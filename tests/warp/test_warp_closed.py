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
    assert res.diagnostics.seeds_tried < 130  # two searches: seeds on q1's and on q0's breaks


def test_closed_with_shift_between_nodes_and_warp():
    q, t = outline(200, fingers=4)
    q0, t0 = shift_seed(q, t, 0.6123)
    res = optimal_warp(q0, q, t0=t0, closed=True, method="dp+refine")
    assert abs(res.seed_shift - 0.6123) < 2.0 / 200
    assert res.distance < 0.2 * optimal_warp(q0, q, t0=t0).distance


def hand_srv(n: int, fingers, rot: float) -> np.ndarray:
    """SRV of a hand outline (palm + Gaussian finger bumps), uniform in arc length, start at
    arc fraction ``rot`` (as ``examples/warp_2d.py`` builds them)."""
    m = 8000
    s = np.arange(m + 1) / m
    a = 2 * np.pi * s
    r = 1.0 + 0.15 * np.cos(2 * a)
    for pos, length, width in fingers:
        d = (s - pos + 0.5) % 1.0 - 0.5
        r = r + length * np.exp(-0.5 * (d / width) ** 2)
    xy = np.column_stack([r * np.cos(a), 0.8 * r * np.sin(a)])
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))])
    u = (np.arange(n + 1) / n + rot) % 1.0
    u[-1] = u[0]
    c = np.column_stack([np.interp(u, arc / arc[-1], xy[:, 0]), np.interp(u, arc / arc[-1], xy[:, 1])])
    v = np.diff(c, axis=0) * n
    return v / np.sqrt(np.linalg.norm(v, axis=1))[:, None]


def test_seed_search_on_both_curves_is_symmetric():
    """Issue 13: with seeds on one curve's cells only, d(a, b) = 0.9365 but d(b, a) = 0.9283."""
    fa = [
        (0.07, 0.75, 0.022),
        (0.19, 1.05, 0.014),
        (0.25, 1.15, 0.014),
        (0.31, 1.05, 0.014),
        (0.37, 0.8, 0.013),
    ]
    fb = [
        (0.01, 0.85, 0.022),
        (0.16, 1.1, 0.014),
        (0.235, 1.0, 0.014),
        (0.32, 1.15, 0.014),
        (0.40, 0.7, 0.013),
    ]
    qa, qb = hand_srv(100, fa, 0.0), hand_srv(100, fb, 0.13)
    one_ab = optimal_warp(qa, qb, closed=True, method="dp", seeds="q1")
    one_ba = optimal_warp(qb, qa, closed=True, method="dp", seeds="q1")
    assert one_ab.distance > 1.005 * one_ba.distance  # the old asymmetry
    ab = optimal_warp(qa, qb, closed=True, method="dp")
    ba = optimal_warp(qb, qa, closed=True, method="dp")
    assert ab.distance == pytest.approx(ba.distance, rel=1e-9)
    assert ab.distance == pytest.approx(one_ba.distance, rel=1e-9)
    assert ab.diagnostics.seed_from == "q0"
    qs, ts = shift_seed(qb, np.linspace(0, 1, 101), ab.seed_shift)
    assert warp_energy(qa, qs, ab.vertices, None, ts) == pytest.approx(ab.energy, rel=1e-9)
    with pytest.raises(ValueError, match="seeds"):
        optimal_warp(qa, qb, closed=True, seeds="q0")
