"""Leave-one-out k-NN classification of the motions of a distance matrix:
:func:`classify_motions` (``elastic-motion classify``) -> :class:`Classification`.

Labels come from a rule on the motions' names or a CSV file
(:func:`elastic_motion.apps.statistics.motion_labels`), a mapping name -> label, or one label
per motion; each labelled motion is classified by the majority of its ``k`` nearest other
labelled motions (:func:`elastic_motion.apps.statistics.knn_evaluate`).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from elastic_motion.apps.database.matrix import MatrixResult
from elastic_motion.apps.database.results import DistanceMatrix, distance_matrix_of
from elastic_motion.apps.report import jsonable
from elastic_motion.apps.statistics import KnnEvaluation, knn_evaluate, motion_labels
from elastic_motion.errors import OptionError

__all__ = ["Classification", "Labels", "classify_motions", "labels_of"]

#: Labels of the motions of a matrix: a rule of :data:`elastic_motion.apps.statistics.LABEL_RULES`
#: or a CSV file (``name,label``), a mapping name -> label, or one label per motion (None or
#: ``""``: unlabelled).
Labels = str | os.PathLike[str] | Mapping[str, str] | Sequence[str | None]


@dataclass(frozen=True, eq=False)
class Classification:
    """Leave-one-out k-NN classification of the motions of one distance matrix.

    Attributes
    ----------
    representation : {"lie", "euler"}
        The stored key of the matrix's curve representation.
    names : list of str
        The motions, in matrix order (length ``M``).
    labels : list of (str or None)
        Their labels (None: unlabelled, neither evaluated nor a neighbour).
    evaluation : KnnEvaluation
        Accuracy, predictions, per-class counts and confusion.
    """

    representation: str
    names: list[str]
    labels: list[str | None]
    evaluation: KnnEvaluation

    @property
    def accuracy(self) -> float:
        """Fraction of the evaluated motions classified correctly (NaN when none)."""
        return self.evaluation.accuracy

    @property
    def predictions(self) -> dict[str, str | None]:
        """Motion name -> predicted label (None: not evaluated)."""
        return dict(zip(self.names, self.evaluation.predictions, strict=True))

    def summary(self) -> dict[str, Any]:
        """JSON-ready: accuracy, motions evaluated, ``k``, ``(correct, evaluated)`` per class and
        the predictions (one entry of ``elastic-motion classify --json``'s ``results``)."""
        ev = self.evaluation
        return jsonable(
            {
                "accuracy": ev.accuracy,
                "evaluated": ev.n_evaluated,
                "k": ev.k,
                "per_class": ev.per_class,
                "predictions": self.predictions,
            }
        )


def labels_of(names: Sequence[str], labels: Labels) -> list[str | None]:
    """One label per name from ``labels`` (:data:`Labels`; None where it gives none).

    Raises
    ------
    OptionError
        An unknown rule or a missing file; a sequence of another length than ``names``.
    """
    if isinstance(labels, str | os.PathLike):
        return motion_labels(names, labels)
    if isinstance(labels, Mapping):
        return [labels.get(n) for n in names]
    out = list(labels)
    if len(out) != len(names):
        raise OptionError("labels", f"expected {len(names)} labels (one per motion); got {len(out)}")
    return out


def _check_labelled(labels: list[str | None], given: Labels) -> None:
    """At least two motions must get a label, or there is nothing to classify."""
    n = sum(lab is not None for lab in labels)
    if n < 2:
        rule = f"{os.fspath(given)}: " if isinstance(given, str | os.PathLike) else ""
        raise OptionError(
            "labels",
            f"{rule}expected labels for at least 2 motions of the matrix; got {n} of {len(labels)} (a rule "
            "labels its own files: bandai-* the Bandai names, cmu the CMU trial numbers; a CSV by name)",
        )


def classify_motions(
    matrix: str | os.PathLike[str] | DistanceMatrix | MatrixResult,
    labels: Labels,
    *,
    k: int = 1,
    method: str | None = None,
) -> Classification:
    """Leave-one-out k-NN classification of the motions of a distance matrix.

    The Python face of ``elastic-motion classify`` (one representation per call).

    Parameters
    ----------
    matrix : path, DistanceMatrix or MatrixResult
        A matrix output folder (:func:`~elastic_motion.apps.database.compute_matrix`), its
        result, or a matrix read back (:func:`~elastic_motion.apps.database.load_matrix`).
    labels : str, path, mapping or sequence
        :data:`Labels`: ``"bandai-content"``, ``"bandai-style"``, ``"cmu"``, a CSV file, a
        mapping name -> label or one label per motion.
    k : int, default 1
        Neighbours that vote.
    method : {"lie", "euler-elastic"}, optional
        The representation read from a folder (default ``"lie"``; ``"euler"`` accepted); for a
        ``DistanceMatrix``, if given, its own.

    Returns
    -------
    Classification

    Raises
    ------
    OptionError
        As :func:`labels_of`; fewer than two labelled motions; ``k < 1``; a representation the
        run did not compute.
    """
    m = distance_matrix_of(matrix, method)
    lab = labels_of(m.names, labels)
    _check_labelled(lab, labels)
    return Classification(m.representation, list(m.names), lab, knn_evaluate(m.distances, lab, k))
