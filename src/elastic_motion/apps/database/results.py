"""Reading a finished matrix back: :func:`load_matrix` -> :class:`DistanceMatrix`; a matrix
given as a folder, a run or itself: :func:`distance_matrix_of`."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from elastic_motion._io import open_regular
from elastic_motion.apps.database import storage
from elastic_motion.apps.database.matrix import MatrixResult
from elastic_motion.errors import OptionError
from elastic_motion.motion import representations

__all__ = ["DistanceMatrix", "distance_matrix_of", "load_matrix"]


@dataclass(frozen=True, eq=False)
class DistanceMatrix:
    """A matrix read back from an output folder.

    Attributes
    ----------
    distances : ndarray, shape (M, M), float64
        Symmetric, zero diagonal, ``+inf`` between skeleton groups, NaN where not computed
        (only with ``require_complete=False``). Units of the representation's SRV norm.
    names : list of str
        Motion names, in matrix order (``names.csv``).
    paths : list of str
    groups : ndarray of int, shape (M,)
        Skeleton group of each motion.
    representation : {"lie", "euler"}
    report : dict
        The content of ``report.json`` (empty if the folder has none).
    """

    distances: np.ndarray
    names: list[str]
    paths: list[str]
    groups: np.ndarray
    representation: str
    report: dict[str, Any]


def load_matrix(
    out_dir: str | os.PathLike[str],
    method: str = "lie",
    *,
    require_complete: bool = True,
    representation: str | None = None,
) -> DistanceMatrix:
    """Read ``distances_<representation>.npy``, ``names.csv`` and ``report.json`` of a run.

    Parameters
    ----------
    out_dir : path
        Output folder of :func:`compute_matrix` (``elastic-motion matrix``).
    method : {"lie", "euler-elastic"}, default "lie"
        The curve representation (``"euler"`` is accepted for ``"euler-elastic"``).
    require_complete : bool, default True
        Refuse a run that is not complete.
    representation : str, optional
        The name of ``method`` in earlier releases; overrides it.

    Returns
    -------
    DistanceMatrix

    Raises
    ------
    FileNotFoundError
        If the folder holds no matrix run.
    OptionError
        An unknown representation, or one the run did not compute (naming those it did);
        a run that is not complete while ``require_complete`` (resume it first).
    """
    out = Path(out_dir)
    option = "representation" if representation is not None else "method"
    rep = representations.representation(representation if representation is not None else method, option)
    path = out / storage.matrix_name(rep.key)
    if not path.exists():
        held = [r.name for r in storage.REPRESENTATIONS if (out / storage.matrix_name(r.key)).exists()]
        if held:
            raise OptionError(
                option,
                f"{os.fspath(out)}: expected one of the representations this run computed {held}; "
                f"got {rep.name!r}",
            )
        name = storage.matrix_name(rep.key)
        raise FileNotFoundError(
            f"{os.fspath(out)}: expected the output folder of a matrix run ({name}, {storage.NAMES}, "
            f"{storage.REPORT}); got no {name}"
        )
    report = storage.read_json(out / storage.REPORT) if (out / storage.REPORT).exists() else {}
    if require_complete and not report.get("complete"):
        raise OptionError(
            "out_dir",
            f"{os.fspath(out)}: expected a complete run; got report.json complete=false (resume it with "
            "the same matrix command first)",
        )
    rows = storage.read_names(out)
    with open_regular(path) as fh:  # never a FIFO (it would block)
        d = np.load(fh, allow_pickle=False)
    return DistanceMatrix(
        distances=d,
        names=[r["name"] for r in rows],
        paths=[r["path"] for r in rows],
        groups=np.array([int(r["group"]) for r in rows], dtype=np.int64),
        representation=rep.key,
        report=report,
    )


def distance_matrix_of(
    matrix: str | os.PathLike[str] | DistanceMatrix | MatrixResult, method: str | None = None
) -> DistanceMatrix:
    """The :class:`DistanceMatrix` of ``matrix``: read from a matrix folder (or the folder of a
    :class:`~elastic_motion.apps.database.MatrixResult`) in the representation ``method``
    (default ``"lie"``), or ``matrix`` itself.

    Raises
    ------
    OptionError
        ``method`` other than the representation of a given ``DistanceMatrix``; as
        :func:`load_matrix` for a folder.
    """
    if isinstance(matrix, DistanceMatrix):
        if method is not None and representations.representation(method).key != matrix.representation:
            held = representations.representation(matrix.representation).name
            raise OptionError("method", f"expected the matrix's representation {held!r}; got {method!r}")
        return matrix
    folder = matrix.out_dir if isinstance(matrix, MatrixResult) else matrix
    return load_matrix(folder, "lie" if method is None else method)
