"""Benchmark of issue 33's general elastic metric ``G^{a,b}`` for curves in ``R^3``.

The cone construction of Bauer, Charon, Klassen, Kurtek, Needham & Pierron (2024)
(:func:`elastic_motion.elastic_metrics.elastic_ab_distance_rd`, module docstring of
:mod:`elastic_motion.elastic_metrics`): two space curves (a helix of two turns and a wavy
rising curve) sampled at ``N`` cells, matched for several ``(a, b)``.

Rows: ``a``, ``b``, ``N``; the exact cone distance at the solver's warp (the solver runs on
an SVD factorisation of the cone's cross term: it minimises the exact energy); the cone
distance at the warp of the *chordal* ``L^2`` distance of the ``R^{d+1}`` transform
(``a <= 2b``; at ``a > 2b`` the SRV warp), what one would get by running the SRV solver on
the transform directly; the time of one call (best of 3 after a warm-up); and, at the
smallest ``N``, the **warp gap**: how much lower a local descent (scipy L-BFGS-B,
finite-difference gradients, on the warp's heights at c0's break points) takes the exact
distance from the solver's warp.

Writes ``benchmarks/results/elastic_ab_rd.json`` and the figure
``docs/images/elastic_ab_rd.png`` (the geodesic between the two curves for ``(a, b) = (1, 1)``
and ``(1/2, 2)`` next to the SRV one, ``(1, 1/2)``).

Usage::

    python benchmarks/elastic_ab_rd.py [--sizes 50 100 200] [--out ...] [--figure ...]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

from _common import REPO, RESULTS, machine_info, timed_best, write_json
from elastic_motion.elastic_metrics import (
    ab_cone_transform,
    cone_warp_distance,
    elastic_ab_distance,
    elastic_ab_geodesic,
)
from elastic_motion.warp import optimal_warp

AB = [(1.0, 0.5), (1.0, 1.0), (0.5, 2.0), (2.0, 0.5), (0.25, 1.0)]
FIGURE = REPO / "docs" / "images" / "elastic_ab_rd.png"


def curves(n: int) -> tuple[np.ndarray, np.ndarray]:
    """A helix (two turns) and a wavy rising space curve, ``(n+1, 3)`` each."""
    t = np.linspace(0.0, 1.0, n + 1)
    c0 = np.column_stack([0.3 * np.cos(4 * np.pi * t), 0.3 * np.sin(4 * np.pi * t), t])
    c1 = np.column_stack([0.25 * np.sin(3 * np.pi * t), 0.2 * np.cos(np.pi * t) ** 2, 0.9 * t**1.3])
    return c0, c1


def warp_gap(c0: np.ndarray, c1: np.ndarray, a: float, b: float, vertices: np.ndarray) -> tuple[float, float]:
    """The exact cone distance after a local descent on the warp's heights at c0's break
    points, from the solver's warp; returns (distance, seconds)."""
    u = np.linspace(0.0, 1.0, len(c0))
    v = np.interp(u, vertices[:, 0], vertices[:, 1])
    z0 = np.log(np.maximum(np.diff(v), 1e-9))

    def energy(z: np.ndarray) -> float:
        w = np.exp(np.clip(z - z.max(), -20.0, 0.0))  # increments > 0: an increasing warp
        heights = np.minimum(np.concatenate([[0.0], np.cumsum(w) / w.sum()]), 1.0)
        heights[-1] = 1.0
        return cone_warp_distance(c0, c1, a, b, np.column_stack([u, heights])) ** 2

    t0 = time.perf_counter()
    res = minimize(energy, z0, method="L-BFGS-B", options={"maxiter": 60, "eps": 1e-7})
    return float(np.sqrt(min(res.fun, energy(z0)))), time.perf_counter() - t0


def chordal_warp(c0: np.ndarray, c1: np.ndarray, a: float, b: float) -> np.ndarray:
    """The warp of the chordal L^2 distance of the R^(d+1) transform (a > 2b: of the SRVT)."""
    a1, b1 = (a, b) if a <= 2 * b else (1.0, 0.5)
    return optimal_warp(ab_cone_transform(c0, a1, b1)[0], ab_cone_transform(c1, a1, b1)[0]).vertices


def rows_for(sizes: list[int]) -> list[dict]:
    rows = []
    for n in sizes:
        c0, c1 = curves(n)
        for a, b in AB:
            secs, r = timed_best(lambda a=a, b=b, c0=c0, c1=c1: elastic_ab_distance(c0, c1, a, b), 3)
            row = {"a": a, "b": b, "N": n, "distance": r.distance, "time_s": secs}
            row["at_chordal_warp"] = cone_warp_distance(c0, c1, a, b, chordal_warp(c0, c1, a, b))
            if n == min(sizes):
                polished, ps = warp_gap(c0, c1, a, b, r.warp.vertices)
                row.update(polished=polished, gap=1.0 - polished / r.distance, polish_s=ps)
            rows.append(row)
    return rows


def figure(path: Path) -> dict:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    c0, c1 = curves(200)
    pairs = [(1.0, 0.5), (1.0, 1.0), (0.5, 2.0)]
    fig = plt.figure(figsize=(13, 4.6))
    out = {}
    results = [elastic_ab_distance(c0, c1, a, b) for a, b in pairs]
    paths = [
        [elastic_ab_geodesic(r, s) + [0.9 * j, 0.0, 0.0] for j, s in enumerate(np.linspace(0, 1, 6))]
        for r in results
    ]
    allpts = np.vstack([g for p in paths for g in p])
    lo, hi = allpts.min(axis=0), allpts.max(axis=0)
    for k, ((a, b), r, curves_s) in enumerate(zip(pairs, results, paths, strict=True)):
        ax = fig.add_subplot(1, len(pairs), k + 1, projection="3d")
        for g, s in zip(curves_s, np.linspace(0, 1, 6), strict=True):  # each on its own break points
            ax.plot(*g.T, color=plt.cm.viridis(s), lw=1.6)
        ax.set_xlim(lo[0], hi[0])  # the same box in every panel
        ax.set_ylim(lo[1], hi[1])
        ax.set_zlim(lo[2], hi[2])
        label = "SRV" if a == 2 * b else f"a/b = {a / b:g}"
        ax.set_title(f"a = {a:g}, b = {b:g} ({label}): d = {r.distance:.3f}", fontsize=10)
        ax.view_init(elev=18, azim=-70)
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_zticks([])
        out[f"{a:g},{b:g}"] = r.distance
    fig.suptitle("G^{a,b} geodesics in R^3 (s = 0 ... 1, left to right): helix -> wavy curve", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.94))
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=90)
    tmp.replace(path)
    plt.close(fig)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[50, 100, 200])
    ap.add_argument("--out", default=str(RESULTS / "elastic_ab_rd.json"))
    ap.add_argument("--figure", default=str(FIGURE))
    args = ap.parse_args()
    rows = rows_for(args.sizes)
    print("| a | b | N | distance | at the chordal warp | s | after local descent | warp gap % |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        extra = f"{r['polished']:.4f} | {100 * r['gap']:.2f}" if "gap" in r else "- | -"
        print(
            f"| {r['a']:g} | {r['b']:g} | {r['N']} | {r['distance']:.4f} | {r['at_chordal_warp']:.4f} "
            f"| {r['time_s']:.3f} | {extra} |"
        )
    fig = figure(Path(args.figure))
    write_json(args.out, {"machine": machine_info(), "rows": rows, "figure_distances": fig})
    print(f"wrote {args.out} and {args.figure}")


if __name__ == "__main__":
    main()
