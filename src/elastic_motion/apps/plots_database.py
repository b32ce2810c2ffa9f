"""Plots for motion databases: dendrogram, distance matrix heat map, Karcher mean energy.

Every function writes one PNG (matplotlib's Agg backend, no window) and returns its path.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from elastic_motion._io import atomic_path
from elastic_motion.apps.statistics import ClusterResult

__all__ = ["plot_dendrogram", "plot_distance_matrix", "plot_energies"]


def _figure(width: float, height: float):
    """A new figure of ``width`` x ``height`` inches, and pyplot (non-interactive backend)."""
    # matplotlib is imported on the first plot: it takes a second, and the apps that import
    # this module (the database's clustering) run without plotting
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt, plt.figure(figsize=(width, height))


def _save(plt, fig, path: str | os.PathLike[str], dpi: int) -> Path:
    out = Path(path)
    try:
        with atomic_path(out) as tmp:
            fig.savefig(tmp, dpi=dpi, bbox_inches="tight")
    finally:
        plt.close(fig)
    return out


def plot_dendrogram(
    result: ClusterResult,
    path: str | os.PathLike[str],
    *,
    title: str = "",
    colors: Sequence[str] | None = None,
    dpi: int = 120,
) -> Path:
    """Dendrogram of a clustering, leaves labelled with the motion names.

    Parameters
    ----------
    result : ClusterResult
    path : path
        PNG to write (atomically).
    title : str
    colors : sequence of str, optional
        A category per leaf (e.g. the motion class): leaf labels are coloured by category.
    dpi : int
    """
    from scipy.cluster.hierarchy import dendrogram  # 0.5 s to import: only a dendrogram needs it

    m = len(result.names)
    plt, fig = _figure(8.0, max(3.0, 0.28 * m + 1.0))
    ax = fig.add_subplot(1, 1, 1)
    # links in one grey: colour is kept for the leaf labels (the classes)
    dendrogram(
        result.linkage,
        labels=list(result.names),
        orientation="left",
        ax=ax,
        leaf_font_size=8,
        link_color_func=lambda _k: "0.35",
    )
    if colors is not None:
        cats = sorted(set(colors))
        cmap = plt.get_cmap("tab10")
        color_of = {c: cmap(i % 10) for i, c in enumerate(cats)}
        index = {n: i for i, n in enumerate(result.names)}
        for lab in ax.get_yticklabels():
            lab.set_color(color_of[colors[index[lab.get_text()]]])
        handles = [plt.Line2D([], [], color=color_of[c], marker="s", ls="", label=c) for c in cats]
        ax.legend(handles=handles, loc="upper left", fontsize=8, title="class")
    ax.set_xlabel(f"elastic distance ({result.method} linkage)")
    if title:
        ax.set_title(title)
    return _save(plt, fig, path, dpi)


def plot_distance_matrix(
    distances: np.ndarray,
    names: Sequence[str],
    path: str | os.PathLike[str],
    *,
    title: str = "",
    dpi: int = 120,
) -> Path:
    """Heat map of a distance matrix (``+inf`` shown blank)."""
    d = np.array(distances, dtype=np.float64)
    d[~np.isfinite(d)] = np.nan
    m = d.shape[0]
    plt, fig = _figure(max(4.0, 0.25 * m + 2.0), max(3.5, 0.25 * m + 1.5))
    ax = fig.add_subplot(1, 1, 1)
    im = ax.imshow(d, cmap="viridis")
    ax.set_xticks(range(m), names, rotation=90, fontsize=6)
    ax.set_yticks(range(m), names, fontsize=6)
    fig.colorbar(im, ax=ax, label="distance")
    if title:
        ax.set_title(title)
    return _save(plt, fig, path, dpi)


def plot_energies(
    energies: Sequence[float], path: str | os.PathLike[str], *, title: str = "", dpi: int = 120
) -> Path:
    """Karcher mean energy per iteration."""
    plt, fig = _figure(4.5, 3.0)
    ax = fig.add_subplot(1, 1, 1)
    ax.plot(np.arange(1, len(energies) + 1), energies, "o-")
    ax.set_xlabel("iteration")
    ax.set_ylabel("mean squared elastic distance")
    if title:
        ax.set_title(title)
    return _save(plt, fig, path, dpi)


def plot_variance_explained(
    explained: Sequence[float], path: str | os.PathLike[str], *, title: str = "", dpi: int = 120
) -> Path:
    """Share of the variance per principal mode (bars) and cumulative (line), in percent."""
    plt, fig = _figure(4.5, 3.0)
    ax = fig.add_subplot(1, 1, 1)
    e = 100 * np.asarray(explained, dtype=float)
    k = np.arange(1, len(e) + 1)
    ax.bar(k, e, color="#4c72b0", label="mode")
    ax.plot(k, np.cumsum(e), "o-", color="#dd8452", label="cumulative")
    ax.set_xlabel("mode")
    ax.set_ylabel("variance explained (%)")
    ax.set_ylim(0, 100)
    ax.legend(loc="center right")
    if title:
        ax.set_title(title)
    return _save(plt, fig, path, dpi)
