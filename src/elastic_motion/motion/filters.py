"""Filters along the frames of a motion's arrays: Gaussian, running percentile, maximum, minimum.

The numbers of ``scipy.ndimage`` (``gaussian_filter1d`` and ``percentile_filter`` with
``mode="nearest"``, ``maximum_filter1d`` / ``minimum_filter1d``; odd window sizes), to the
last bit, computed with numpy: ``scipy.ndimage`` takes about a third of
``import numpy, scipy.linalg, numba`` to import (its array-API wrappers and
``scipy.special``'s), which every command that smooths a motion paid at start-up (issue 34);
``tests/motion/test_filters.py`` holds them to scipy's.

* Beyond the ends the frames are extended by the end frame (``mode="nearest"``: what ends
  held means for a motion); a maximum or minimum over windows of odd size is the same with
  any extension that repeats frames of the window (scipy's default ``"reflect"``).
* The Gaussian sums as scipy's symmetric correlation does, in the same order: the centre
  frame times its weight, then from the outermost pair of frames inwards, each pair's sum
  times its weight.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["gaussian_frames", "max_frames", "min_frames", "percentile_frames"]


def _held(x: np.ndarray, r: int) -> np.ndarray:
    """``x`` ``(F, ...)`` extended by ``r`` frames at each end, the end frames held: ``(F + 2r, ...)``."""
    n = x.shape[0]
    return x[np.clip(np.arange(-r, n + r), 0, n - 1)]


def _windows(x: np.ndarray, size: int) -> np.ndarray:
    """The windows of odd ``size`` centred on each frame of ``x`` ``(F, ...)``, ends held:
    ``(F, ..., size)``."""
    return np.lib.stride_tricks.sliding_window_view(_held(x, size // 2), size, axis=0)


def _check_size(size: int) -> int:
    size = int(size)
    if size < 1 or size % 2 == 0:
        raise ValueError(f"size: expected an odd number of frames >= 1; got {size}")
    return size


def gaussian_frames(x: np.ndarray, sigma_frames: float, *, truncate: float = 4.0) -> np.ndarray:
    """``x`` ``(F, ...)`` through a Gaussian along its frames (axis 0), ends held.

    The sampled kernel ``exp(-k^2 / (2 s^2))``, ``|k| <= int(truncate s + 0.5)``, normalised
    to sum 1 (``s = sigma_frames``): ``scipy.ndimage.gaussian_filter1d(x, s, axis=0,
    mode="nearest", truncate=truncate)``, bit for bit (module docstring).

    Parameters
    ----------
    x : array_like, shape (F, ...)
    sigma_frames : float
        Standard deviation, frames; ``x`` itself (as an array) for ``sigma_frames <= 0`` or
        fewer than 2 frames.
    truncate : float, default 4
        Kernel half-width in standard deviations.

    Returns
    -------
    ndarray, shape (F, ...), float64

    Raises
    ------
    ValueError
        ``sigma_frames`` not finite.
    """
    if not math.isfinite(sigma_frames):
        raise ValueError(f"sigma_frames: expected a finite number of frames; got {sigma_frames!r}")
    x = np.asarray(x)
    if sigma_frames <= 0 or x.shape[0] < 2:
        return x
    x = np.asarray(x, dtype=np.float64)
    s = float(sigma_frames)
    r = int(truncate * s + 0.5)
    k = np.arange(-r, r + 1)
    phi = np.exp(-0.5 / (s * s) * k**2)
    w = phi / phi.sum()
    n = x.shape[0]
    ext = _held(x, r)
    out = ext[r : r + n] * w[r]
    pair = np.empty_like(out)  # in place: the same sums and products, no array per term
    for d in range(r, 0, -1):  # outermost pair first, as scipy sums
        np.add(ext[r - d : r - d + n], ext[r + d : r + d + n], out=pair)
        pair *= w[r - d]
        out += pair
    return out


def percentile_frames(x: np.ndarray, percentile: float, size: int) -> np.ndarray:
    """The running ``percentile`` of ``x`` ``(F, ...)`` over windows of ``size`` frames
    (odd) centred on each frame, ends held: the value of rank ``int(size * percentile / 100)``
    of each window (the largest for 100), as ``scipy.ndimage.percentile_filter(x, percentile,
    size=(size, 1, ...), mode="nearest")``.

    Parameters
    ----------
    x : array_like, shape (F, ...)
        Finite values.
    percentile : float
        In ``[0, 100]``.
    size : int
        Odd window length, frames.

    Returns
    -------
    ndarray, shape (F, ...)
    """
    size = _check_size(size)
    if not 0.0 <= percentile <= 100.0:
        raise ValueError(f"percentile: expected a value in [0, 100]; got {percentile!r}")
    rank = size - 1 if percentile == 100.0 else int(float(size) * percentile / 100.0)
    win = _windows(np.asarray(x), size)
    return np.partition(win, rank, axis=-1)[..., rank]


def max_frames(x: np.ndarray, size: int) -> np.ndarray:
    """The running maximum of ``x`` ``(F, ...)`` over windows of ``size`` frames (odd) centred
    on each frame (``scipy.ndimage.maximum_filter1d(x, size, axis=0)``)."""
    return _windows(np.asarray(x), _check_size(size)).max(axis=-1)


def min_frames(x: np.ndarray, size: int) -> np.ndarray:
    """The running minimum of ``x`` ``(F, ...)`` over windows of ``size`` frames (odd) centred
    on each frame (``scipy.ndimage.minimum_filter1d(x, size, axis=0)``)."""
    return _windows(np.asarray(x), _check_size(size)).min(axis=-1)
