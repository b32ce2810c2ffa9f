"""Agglomerative clustering of the motions of a distance matrix: :func:`cluster_motions`
(``elastic-motion cluster``) -> :class:`Clustering`, with its dendrogram (:meth:`Clustering.plot`).

The clustering itself is :func:`elastic_motion.apps.statistics.cluster` (``+inf`` between
skeleton groups is replaced by twice the largest finite distance, so those groups join last).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from elastic_motion.apps.database.classify import Labels, labels_of
from elastic_motion.apps.database.matrix import MatrixResult
from elastic_motion.apps.database.results import DistanceMatrix, distance_matrix_of
from elastic_motion.apps.plots_database import plot_dendrogram
from elastic_motion.apps.report import jsonable
from elastic_motion.apps.statistics import ClusterResult, Linkage, cluster

__all__ = ["Clustering", "cluster_motions"]


@dataclass(frozen=True, eq=False)
class Clustering:
    """The hierarchical clustering of the motions of one distance matrix.

    Attributes
    ----------
    representation : {"lie", "euler"}
        The stored key of the matrix's curve representation.
    result : ClusterResult
        The SciPy linkage matrix ``(M - 1, 4)``, the flat clusters when asked, the linkage
        method and the motion names.
    leaf_labels : list of str, optional
        A label per motion (``"?"`` where none), colouring the dendrogram's leaves.
    """

    representation: str
    result: ClusterResult
    leaf_labels: list[str] | None = None

    @property
    def names(self) -> list[str]:
        """The motions, in matrix order."""
        return self.result.names

    @property
    def clusters(self) -> dict[str, int] | None:
        """Motion name -> its flat cluster (1-based), when a number of clusters was asked."""
        if self.result.labels is None:
            return None
        return dict(zip(self.result.names, np.asarray(self.result.labels).tolist(), strict=True))

    def summary(self) -> dict[str, Any]:
        """JSON-ready: the linkage method, the representation, the linkage matrix and the flat
        clusters when asked (what ``elastic-motion cluster --json`` reports)."""
        out: dict[str, Any] = {
            "linkage_method": self.result.method,
            "representation": self.representation,
            "linkage": self.result.linkage.tolist(),
        }
        if self.result.labels is not None:
            out["clusters"] = self.clusters
        return jsonable(out)

    def plot(self, path: str | os.PathLike[str], *, title: str | None = None) -> Path:
        """Write the dendrogram as a PNG (leaves coloured by :attr:`leaf_labels`); its path.

        ``title`` defaults to ``"<representation> elastic distance"``."""
        title = f"{self.representation} elastic distance" if title is None else title
        return plot_dendrogram(self.result, path, title=title, colors=self.leaf_labels)


def cluster_motions(
    matrix: str | os.PathLike[str] | DistanceMatrix | MatrixResult,
    *,
    method: str | None = None,
    linkage: Linkage = "average",
    n_clusters: int | None = None,
    labels: Labels | None = None,
) -> Clustering:
    """Hierarchical clustering of the motions of a distance matrix.

    The Python face of ``elastic-motion cluster``.

    Parameters
    ----------
    matrix : path, DistanceMatrix or MatrixResult
        A matrix output folder, its result, or a matrix read back.
    method : {"lie", "euler-elastic"}, optional
        The representation read from a folder (default ``"lie"``); for a ``DistanceMatrix``, if
        given, its own.
    linkage : {"average", "complete", "single", "weighted"}, default "average"
        Distance between clusters (:data:`elastic_motion.apps.statistics.Linkage`).
    n_clusters : int, optional
        Cut the tree into this many flat clusters.
    labels : str, path, mapping or sequence, optional
        Labels colouring the dendrogram's leaves: a rule (``"bandai-content"``, ``"cmu"``...),
        a CSV file, a mapping name -> label, or one label per motion.

    Returns
    -------
    Clustering

    Raises
    ------
    OptionError
        An unknown linkage, ``n_clusters`` outside ``1..M``, an unknown label rule; a
        representation the run did not compute.
    """
    m = distance_matrix_of(matrix, method)
    res = cluster(m.distances, m.names, method=linkage, n_clusters=n_clusters)
    leaves = None if labels is None else [lab or "?" for lab in labels_of(m.names, labels)]
    return Clustering(m.representation, res, leaves)
