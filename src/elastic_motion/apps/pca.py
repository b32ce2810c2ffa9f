"""A statistical model of a set of motions: principal components in the SRV tangent space.

:func:`motion_pca` (``elastic-motion pca FILES -o DIR``):

1. the files are prepared as for a database (:func:`elastic_motion.apps.database.prepare_motion`,
   ``n_samples + 1`` frames, one skeleton), turned into Lie curves in one metric (or Euler
   curves) and SRV arrays ``q_k`` of shape ``(n, D)``;
2. their Karcher mean with the warps re-centred (:func:`elastic_motion.apps.statistics.karcher_mean`,
   ``recenter=True``: the mean warp is the identity) aligns them: ``a_k = (q_k * phi_k)``
   projected on the grid;
3. the tangent vectors ``v_k = a_k - mu`` (``mu = sum_k a_k / K``), flattened with the weight
   ``sqrt(1/n)`` so that the Euclidean inner product is the ``L^2`` one, are decomposed by an
   SVD: ``V = U S E^T``; mode ``i`` is the row ``e_i`` of ``E^T`` (unit ``L^2`` norm), its
   standard deviation ``sigma_i = s_i / sqrt(K - 1)``, its share of the variance
   ``s_i^2 / sum s^2``;
4. a point of the model ``mu + sum_i z_i sigma_i e_i`` becomes a curve by the inverse SRV
   transform from the mean's start point, then a motion on the first file's skeleton
   (``from_lie_curve``), lasting the mean duration, resampled to the output frame rate.

The SRV space of a Lie group curve is a vector space (paper 000: the SRVT is a bijection onto
it, given the start point), so the model is linear there, as fdasrsf's shape PCA is for
curves in ``R^n``, and every sample is a valid curve of the group.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from elastic_motion import motion as mm
from elastic_motion._options import with_overrides
from elastic_motion.apps.database.mean import MeanOptions
from elastic_motion.apps.database.preparation import database_curves, prepare_same_skeleton
from elastic_motion.apps.progress import Progress
from elastic_motion.apps.report import jsonable
from elastic_motion.apps.statistics import karcher_mean
from elastic_motion.curves import SRVFunction, inverse_srv_transform, reparametrize_srv, srv_transform
from elastic_motion.errors import OptionError
from elastic_motion.motion import Motion, write_bvh
from elastic_motion.motion.representations import representation

__all__ = ["MotionPCA", "motion_pca", "write_modes"]


@dataclass(frozen=True, eq=False)
class MotionPCA:
    """A linear model of aligned motions in SRV space (module docstring).

    Attributes
    ----------
    mean_srv : ndarray, shape (n, D)
        ``mu``, the average of the aligned SRV arrays.
    modes : ndarray, shape (r, n, D)
        Principal directions, unit ``L^2`` norm (``sum_{i, d} e[i, d]^2 / n = 1``), ``r <= K - 1``.
    sigmas : ndarray, shape (r,)
        Standard deviations along the modes (SRV norm units), decreasing.
    explained : ndarray, shape (r,)
        Share of the total variance of each mode (sums to 1 over all modes).
    scores : ndarray, shape (K, r)
        Coordinates ``<v_k, e_i>`` of each input.
    warps : list of ndarray
        The re-centred warps of the inputs onto the mean (mean warp: the identity).
    inputs : tuple of str
    method : {"lie", "euler-elastic"}
    n_samples : int
    duration : float
        Seconds of the motions made from the model (mean duration of the inputs).
    fps : float
        Frame rate of those motions.
    karcher_energies : ndarray
        Energy per Karcher iteration.
    notes : dict of str -> tuple of str
    """

    mean_srv: np.ndarray
    modes: np.ndarray
    sigmas: np.ndarray
    explained: np.ndarray
    scores: np.ndarray
    warps: list[np.ndarray]
    inputs: tuple[str, ...]
    method: str
    n_samples: int
    duration: float
    fps: float
    karcher_energies: np.ndarray
    notes: dict[str, tuple[str, ...]] = field(default_factory=dict)
    _start: Any = None
    _group: Any = None
    _like: Motion | None = None

    @property
    def n_modes(self) -> int:
        """Modes of the model (``r``)."""
        return len(self.sigmas)

    def srv_at(self, z: Sequence[float]) -> np.ndarray:
        """The SRV array ``mu + sum_i z_i sigma_i e_i`` (``z`` in standard deviations), shape (n, D)."""
        z = np.asarray(z, dtype=np.float64)
        if z.ndim != 1 or len(z) > self.n_modes:
            raise OptionError("z", f"expected at most {self.n_modes} coordinates; got shape {z.shape}")
        r = len(z)
        return self.mean_srv + np.einsum("i,i,ind->nd", z, self.sigmas[:r], self.modes[:r])

    def motion_at(self, z: Sequence[float], *, name: str = "") -> Motion:
        """The motion of the model at ``z`` (standard deviations along the first ``len(z)`` modes)."""
        q = self.srv_at(z)
        t = np.linspace(0.0, 1.0, self.n_samples + 1)
        curve = inverse_srv_transform(SRVFunction(q, t, self._start, self._group))
        like = self._like
        assert like is not None
        m = representation(self.method).from_curve(
            curve, like, fps=self.n_samples / self.duration if self.duration > 0 else like.fps
        )
        if self.duration > 0 and self.fps > 0:
            m = mm.resample(m, self.fps)
        return m.replace(name=name or "pca sample")

    def mean_motion(self) -> Motion:
        """The motion of the mean (``z = 0``)."""
        return self.motion_at([], name="pca mean")

    def sample(self, n: int = 1, *, n_modes: int | None = None, seed: int | None = None) -> list[Motion]:
        """``n`` new motions with ``z_i ~ N(0, 1)`` on the first ``n_modes`` modes (default all)."""
        r = self.n_modes if n_modes is None else min(int(n_modes), self.n_modes)
        rng = np.random.default_rng(seed)
        return [self.motion_at(rng.standard_normal(r), name=f"pca sample {k}") for k in range(n)]

    def summary(self) -> dict[str, Any]:
        """JSON-ready: inputs, variance explained, sigmas, scores, Karcher energies."""
        return jsonable(
            {
                "inputs": self.inputs,
                "method": self.method,
                "n_samples": self.n_samples,
                "n_modes": self.n_modes,
                "sigmas": self.sigmas,
                "explained": self.explained,
                "cumulative_explained": np.cumsum(self.explained),
                "scores": dict(zip(self.inputs, self.scores.tolist(), strict=True)),
                "duration": self.duration,
                "fps": self.fps,
                "karcher_energies": self.karcher_energies,
                "notes": self.notes,
            }
        )


def motion_pca(
    files: Sequence[str | os.PathLike[str]],
    options: MeanOptions | None = None,
    *,
    progress: Progress | None = None,
    **overrides: Any,
) -> MotionPCA:
    """Principal component analysis of motions aligned by their Karcher mean (module docstring).

    Parameters
    ----------
    files : sequence of paths
        At least two motion files of one skeleton (or ``joints="common"``).
    options : MeanOptions, optional
        How the motions are prepared and aligned (:class:`~elastic_motion.apps.database.MeanOptions`:
        ``n_samples``, ``method``, ``joints``, ``drop_fingers``, ``align_heading``, ``warp``
        (``"none"`` gives the PCA of the unaligned SRVs), ``max_iter`` and ``tol`` of the Karcher
        mean, ``fps`` of the motions made: default the first file's).
    progress : callable, optional
        ``progress("mean", iteration, max_iter)``.
    **overrides
        Fields of :class:`~elastic_motion.apps.database.MeanOptions` (``n_samples=32``, ``warp="none"``...).

    Returns
    -------
    MotionPCA

    Raises
    ------
    OptionError
        Fewer than two files, different skeletons, a bad option.
    """
    opts = with_overrides(MeanOptions, options, overrides)
    files = [os.fspath(f) for f in files]
    if len(files) < 2:
        raise OptionError("files", f"expected at least two motion files; got {len(files)}")
    n_samples = opts.n_samples
    prepared = prepare_same_skeleton(
        files,
        n_samples,
        joints=opts.joints,
        drop_fingers=opts.drop_fingers,
        align_heading=opts.align_heading,
        options=opts.read_options(),
    )
    curves = database_curves(prepared, opts.method)
    km = karcher_mean(
        curves,
        n_samples=n_samples,
        warp=opts.warp,
        max_iter=opts.max_iter,
        tol=opts.tol,
        progress=progress,
        recenter=True,
    )
    t = np.linspace(0.0, 1.0, n_samples + 1)
    srvs = [srv_transform(c) for c in curves]
    aligned = np.stack([reparametrize_srv(s, v).on_grid(t).q for s, v in zip(srvs, km.warps, strict=True)])
    kk, n, d = aligned.shape
    mu = aligned.mean(axis=0)
    v = (aligned - mu).reshape(kk, n * d) / np.sqrt(n)
    _, sv, vt = np.linalg.svd(v, full_matrices=False)
    r = max(1, min(kk - 1, int(np.sum(sv > sv[0] * 1e-10)) if sv[0] > 0 else 1))
    total = float(np.sum(sv**2))
    p0 = prepared[0]
    return MotionPCA(
        mean_srv=mu,
        modes=(vt[:r] * np.sqrt(n)).reshape(r, n, d),  # unit L2 norm: sum e^2 / n = 1
        sigmas=sv[:r] / np.sqrt(kk - 1),
        explained=sv[:r] ** 2 / total if total > 0 else np.zeros(r),
        scores=v @ vt[:r].T,
        warps=km.warps,
        inputs=tuple(files),
        method=opts.method,
        n_samples=n_samples,
        duration=float(np.mean([p.duration for p in prepared])),
        fps=float(opts.fps) if opts.fps is not None else (p0.original_frames - 1) / p0.duration,
        karcher_energies=km.energies,
        notes={p.path: p.notes for p in prepared},
        _start=km.mean.values[0],
        _group=km.mean.group,
        _like=p0.motion,
    )


def write_modes(
    model: MotionPCA,
    out_dir: str | os.PathLike[str],
    *,
    n_modes: int = 3,
    spread: float = 2.0,
    protected: Sequence[str | os.PathLike[str]] = (),
) -> list[Path]:
    """Write the mean and ``mean +- spread sigma`` along the first modes as BVH files.

    Files: ``mean.bvh``, ``mode<i>_minus<spread>sd.bvh``, ``mode<i>_plus<spread>sd.bvh``
    (``i`` from 1) in ``out_dir`` (created).

    Returns
    -------
    list of Path
        The files written, in that order.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    tag = f"{spread:g}".replace(".", "p")
    paths = [write_bvh(model.mean_motion(), out / "mean.bvh", protected=protected)]
    for i in range(min(n_modes, model.n_modes)):
        for sign, word in ((-1.0, "minus"), (1.0, "plus")):
            z = np.zeros(i + 1)
            z[i] = sign * spread
            m = model.motion_at(z, name=f"mode {i + 1} {'+' if sign > 0 else '-'}{spread:g} sd")
            paths.append(write_bvh(m, out / f"mode{i + 1}_{word}{tag}sd.bvh", protected=protected))
    return [Path(p) for p in paths]
