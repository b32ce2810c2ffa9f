"""Argument checks shared by every layer: one place that words the error messages.

Each check raises ``ValueError`` naming the argument, what was expected and what came,
e.g. ``"t: expected a strictly increasing array; t[3] = 0.2 <= t[2] = 0.25"``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def as_float_array(x: object, name: str) -> np.ndarray:
    """Return ``x`` as a float64 array; ``ValueError`` naming ``name`` when impossible."""
    try:
        arr = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected an array of real numbers; got {type(x).__name__}") from exc
    return arr


def check_finite(arr: np.ndarray, name: str) -> None:
    """Raise ``ValueError`` if ``arr`` has NaN or infinite entries, saying where the first is."""
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ValueError(
            f"{name}: expected finite values; found {arr[idx]} at index {idx} "
            f"({int(bad.sum())} non-finite entries in all)"
        )


def check_trailing_shape(arr: np.ndarray, shape: Sequence[int], name: str, what: str = "") -> None:
    """Require ``arr.shape[-len(shape):] == shape``."""
    shape = tuple(shape)
    k = len(shape)
    if arr.ndim < k or tuple(arr.shape[arr.ndim - k :]) != shape:
        label = f" ({what})" if what else ""
        raise ValueError(
            f"{name}: expected an array of shape (..., {', '.join(map(str, shape))}){label}; "
            f"got shape {arr.shape}"
        )


def check_parameters(t: object, name: str = "t", n_points: int | None = None) -> np.ndarray:
    """Validate a curve parameter grid: strictly increasing, ``t[0] = 0``, ``t[-1] = 1``.

    Parameters
    ----------
    t : array_like, shape (n+1,)
    name : str
        Argument name used in error messages.
    n_points : int, optional
        Required length.

    Returns
    -------
    ndarray, shape (n+1,), float64
    """
    arr = as_float_array(t, name)
    if arr.ndim != 1:
        raise ValueError(f"{name}: expected a 1-D array of parameters; got shape {arr.shape}")
    if n_points is not None and arr.shape[0] != n_points:
        raise ValueError(f"{name}: expected {n_points} parameters (one per sample); got {arr.shape[0]}")
    if arr.shape[0] < 2:
        raise ValueError(f"{name}: expected at least 2 parameters; got {arr.shape[0]}")
    check_finite(arr, name)
    steps = np.diff(arr)
    if (steps <= 0).any():
        i = int(np.argmax(steps <= 0)) + 1
        raise ValueError(
            f"{name}: expected strictly increasing parameters; "
            f"{name}[{i}] = {arr[i]!r} <= {name}[{i - 1}] = {arr[i - 1]!r}"
        )
    if arr[0] != 0.0 or arr[-1] != 1.0:
        raise ValueError(
            f"{name}: expected parameters from 0 to 1 (t[0] = 0, t[-1] = 1); "
            f"got t[0] = {arr[0]!r}, t[-1] = {arr[-1]!r}"
        )
    return arr
