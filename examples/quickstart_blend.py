"""Quickstart: blend two curves along the SRV geodesic, in R^2 and in SO(3).

Writes ``quickstart_blend.png`` (into ``--out``, default ``elastic-motion-output/``) with
two panels:

* left: two planar curves and the curves at ``s = 1/4, 1/2, 3/4`` of the geodesic between
  them in SRV space (paper 000, eq. 20);
* right: two curves in SO(3), drawn as the path of the vector ``(1, 0, 0)`` they rotate on
  the unit sphere (as in paper 000, Fig. 2), and their blends.

It also prints the distances ``d_P`` along the path, which split as ``s : 1 - s`` because
the path is a straight line in SRV space.

Usage: ``python examples/quickstart_blend.py [--out DIR]``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from elastic_motion.curves import DiscreteCurve, blend, curve_distance
from elastic_motion.groups import SO3, Euclidean


def planar_curves(n: int = 200) -> tuple[DiscreteCurve, DiscreteCurve]:
    t = np.linspace(0, 1, n)
    wave = np.column_stack([t, 0.25 * np.sin(3 * np.pi * t)])  # three extrema
    bump = np.column_stack([t, 0.35 * np.sin(2 * np.pi * t**1.5)])  # two extrema, late
    return DiscreteCurve(wave, Euclidean(2)), DiscreteCurve(bump + [0.0, 0.6], Euclidean(2))


def rotation_curves(n: int = 200) -> tuple[DiscreteCurve, DiscreteCurve]:
    g = SO3()
    t = np.linspace(0, 1, n)[:, None]
    a = g.exp(np.column_stack([0.3 * np.sin(2 * np.pi * t[:, 0]), 0 * t[:, 0], 2.5 * t[:, 0]]))
    b = g.exp(np.column_stack([0.8 * t[:, 0], 0.6 * np.sin(np.pi * t[:, 0]), 2.0 * t[:, 0] ** 2]))
    return DiscreteCurve(a, g), DiscreteCurve(b, g)


def main() -> None:
    parser = argparse.ArgumentParser(description="Blend two curves along the SRV geodesic.")
    parser.add_argument("--out", type=Path, default=Path("elastic-motion-output"))
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)

    weights = [0.25, 0.5, 0.75]
    fig = plt.figure(figsize=(11, 5))

    ax = fig.add_subplot(1, 2, 1)
    c0, c1 = planar_curves()
    d = curve_distance(c0, c1)
    ax.plot(*c0.values.T, "C0", lw=2.5, label="c0 (s = 0)")
    ax.plot(*c1.values.T, "C1", lw=2.5, label="c1 (s = 1)")
    print(f"R^2: d_P(c0, c1) = {d:.4f}")
    for s in weights:
        cs = blend(c0, c1, s, t_out=c0.t)
        ax.plot(*cs.values.T, "k", lw=1, alpha=0.4 + 0.5 * s)
        print(f"  s = {s:.2f}: d_P(c0, c_s) = {curve_distance(c0, cs):.4f} (s d = {s * d:.4f})")
    ax.set_title("R^2: SRV geodesic from c0 to c1")
    ax.set_aspect("equal")
    ax.legend(loc="lower right")

    ax = fig.add_subplot(1, 2, 2, projection="3d")
    r0, r1 = rotation_curves()
    e1 = np.array([1.0, 0.0, 0.0])
    u, v = np.mgrid[0 : 2 * np.pi : 40j, 0 : np.pi : 20j]
    ax.plot_wireframe(np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v), color="0.85", lw=0.4)
    ax.plot(*(r0.values @ e1).T, "C0", lw=2.5, label="c0")
    ax.plot(*(r1.values @ e1).T, "C1", lw=2.5, label="c1")
    d = curve_distance(r0, r1)
    print(f"SO(3): d_P(c0, c1) = {d:.4f}")
    for s in weights:
        cs = blend(r0, r1, s, t_out=r0.t)
        ax.plot(*(cs.values @ e1).T, "r", lw=1.5, alpha=0.4 + 0.5 * s)
        print(f"  s = {s:.2f}: d_P(c0, c_s) = {curve_distance(r0, cs):.4f} (s d = {s * d:.4f})")
    ax.set_title("SO(3): path of R(t) e1 on the sphere")
    ax.legend(loc="upper left")
    ax.set_box_aspect((1, 1, 1))

    fig.tight_layout()
    path = args.out / "quickstart_blend.png"
    fig.savefig(path, dpi=110)
    print(f"wrote {path.resolve()}")


if __name__ == "__main__":
    main()
