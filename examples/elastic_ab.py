"""How the elastic match changes with the metric G^{a,b} (paper 001, eq. 4).

Open plane curves (paper 001's open pair of Fig. 3: three maxima and minima vs two) matched
for several ratios ``a / b`` through the ``F_{a,b}`` transform (Bauer, Bruveris, Marsland &
Michor 2014; Kurtek & Needham 2018; :mod:`elastic_motion.elastic_metrics`): ``a`` weighs
bending (the normal part of the derivative of a deformation), ``b`` stretching (the
tangential part).  Small ``a / b``: bending is cheap, the match keeps arc length; large
``a / b``: stretching is cheap, the match aligns the turning.  ``a = 1, b = 1/2`` is the SRVT.

Usage::

    python examples/elastic_ab.py [--out docs/images]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from elastic_motion.elastic_metrics import elastic_ab_distance, elastic_ab_geodesic

RATIOS = [(0.25, 1.0), (1.0, 1.0), (1.0, 0.5), (2.0, 0.5), (4.0, 0.5)]  # (a, b)


def curves(n: int = 300) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, 1.0, n + 1)
    return (
        np.column_stack([t, 0.10 * np.sin(6 * np.pi * t)]),
        np.column_stack([t, 0.12 * np.sin(4 * np.pi * t)]),
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "docs" / "images")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    c0, c1 = curves()
    fig = plt.figure(figsize=(12, 2.0 * len(RATIOS)))
    gs = fig.add_gridspec(len(RATIOS), 2, width_ratios=[1, 4])
    t_out = np.linspace(0, 1, 601)
    for row, (a, b) in enumerate(RATIOS):
        res = elastic_ab_distance(c0, c1, a, b)
        ax = fig.add_subplot(gs[row, 0])
        ax.plot(res.warp.vertices[:, 0], res.warp.vertices[:, 1], "C0")
        ax.plot([0, 1], [0, 1], "k:", lw=0.8)
        ax.set_aspect("equal")
        ax.set_title(f"a/b = {a / b:g}: phi", fontsize=9)
        ax2 = fig.add_subplot(gs[row, 1])
        for k, s in enumerate(np.linspace(0, 1, 5)):
            xy = elastic_ab_geodesic(res, s, t_out)
            ax2.plot(xy[:, 0] + 1.25 * k, xy[:, 1] - xy[:, 1].mean(), color=plt.cm.viridis(s))
        ax2.set_aspect("equal")
        ax2.axis("off")
        ax2.set_title(f"a = {a:g}, b = {b:g}: distance {res.distance:.4f}, geodesic s = 0 ... 1", fontsize=9)
        print(f"a = {a:g}, b = {b:g}, a/b = {a / b:g}: distance {res.distance:.4f}")
    fig.suptitle("Elastic match under G^{a,b} (F_{a,b} transform): warp and geodesic")
    fig.tight_layout()
    path = args.out / "elastic_ab.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    print(f"figure: {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
