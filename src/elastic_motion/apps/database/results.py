"""Reading a finished matrix back: :func:`load_matrix` -> :class:`DistanceMatrix`."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from elastic_motion.apps.database import storage
from elastic_motion.apps.database.settings import REPRESENTATIONS, canonical_method, public_method
from elastic_motion.errors import OptionError

__all__ = ["DistanceMatrix", "load_matrix"]


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
    representation = canonical_method(representation if representation is not None else method, option)
    path = out / storage.matrix_name(representation)
    if not path.exists():
        held = [public_method(r) for r in REPRESENTATIONS if (out / storage.matrix_name(r)).exists()]
        if held:
            raise OptionError(
                option,
                f"{os.fspath(out)}: expected one of the representations this run computed {held}; "
                f"got {public_method(representation)!r}",
            )
        name = storage.matrix_name(representation)
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
    d = np.load(path)
    return DistanceMatrix(
        distances=d,
        names=[r["name"] for r in rows],
        paths=[r["path"] for r in rows],
        groups=np.array([int(r["group"]) for r in rows], dtype=np.int64),
        representation=representation,
        report=report,
    )
