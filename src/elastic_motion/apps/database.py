"""All-pairs elastic distances over a motion database: SRV cache, tiles, storage, resume, engines.

Conventions
-----------
* **Motions -> SRV arrays.** Every readable input file is read once and prepared
  (:func:`prepare_motion`: drop a leading T-pose, fold a static root into its child, convert
  to metres, drop finger joints, remove the heading and floor position at frame 0, select
  joints), then resampled to ``n_samples + 1`` frames uniformly in time (geodesic
  interpolation of rotations) and transformed to SRV arrays ``q`` of shape
  ``(n_samples, D)`` on the uniform grid ``linspace(0, 1, n_samples + 1)`` (each clip's
  duration is normalised to 1). Two representations:

  - ``"lie"``: the curve in ``R^3 x SO(3)^J`` (:func:`elastic_motion.motion.to_lie_curve`),
    ``D = 3 + 3 J``, with the inner-product weights of a skeleton group *shared by all its
    motions* (mean of the per-motion defaults, so that two motions are compared in one metric);
  - ``"euler"``: continuous Euler angles in ``R^(3 + 3 J)``
    (:func:`elastic_motion.motion.to_euler_curve`), root position in metres, angles in
    radians, unweighted (the baseline of paper 001).

  The arrays are computed once per motion and stored in ``srv_cache.npz`` next to the output.
* **Pair distance** (:func:`pair_distance`). ``warp="dp"``: the elastic distance
  ``min_phi ||q_i - q_j * phi||_L2`` by :func:`elastic_motion.warp.optimal_warp` (dynamic
  programming on the grid nodes), ``warp="none"``: the distance of parametrised curves
  ``||q_i - q_j||_L2`` (paper 000, eq. 4). Only ``i < j`` is computed and mirrored, always
  with the lower index as ``q0`` (the curve warped is ``q_j``). For the DP on a common
  uniform grid with a slope set symmetric in ``(a, b)`` (the default) swapping the curves
  gives the same minimum up to rounding (the inverse of a grid path is a grid path and
  ``||q0 - q1 * phi|| = ||q1 - q0 * phi^-1||``); the one-direction rule makes the result
  independent of the engine and the tiling, bit for bit. Diagonal: 0. Motions of
  different skeleton groups are not compared: their entry is ``+inf``.
* **Output folder** (all writes atomic: temporary file + ``os.replace``)::

      names.csv              index,name,path,group,frames,fps,duration,joints
      distances_lie.npy      (M, M) float64, NaN = not computed yet (np.load(..., mmap_mode="r"))
      distances_euler.npy
      tiles/<repr>_<I>_<J>.npy   one finished tile (rows of block I x columns of block J)
      srv_cache.npz          SRV arrays q_<repr>_<k> (n_samples, D), group ids, settings
      manifest.json          settings + inputs (the identity of the run), tiles done, runs
      report.json            inputs, skipped files with reasons, skeleton groups, engine,
                             timings, "complete": true/false

  Tile files are the ground truth: on resume every tile file already on disk is kept (never
  recomputed) and the matrices are rebuilt from them, so an interruption at any point loses
  at most the tiles in flight and duplicates none.
* **Engines**: ``"serial"`` (in-process loop), ``"local"`` (a Dask ``LocalCluster`` of
  ``n_workers`` single-threaded processes started here), ``"dask"`` (an existing Dask
  scheduler at ``scheduler``). Tiles are Dask tasks that receive their SRV arrays with the
  task (no shared file system needed); the driver gathers them ``as_completed`` with a
  bounded number in flight and writes them. Same function, same inputs: every engine gives
  bit-identical matrices.

Numerical code here prints nothing; progress goes to an optional ``progress(stage, done,
total)`` callback.
"""

from __future__ import annotations

import contextlib
import csv
import io
import itertools
import json
import logging
import math
import os
import platform
import re
import time
import uuid
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from elastic_motion._io import atomic_write_bytes
from elastic_motion.curves import srv_transform
from elastic_motion.errors import ParseError

__all__ = [
    "REPRESENTATIONS",
    "ClusterUnavailableError",
    "DatabaseSettings",
    "DistanceMatrix",
    "MatrixResult",
    "PairSpec",
    "PreparedMotion",
    "SRVCache",
    "build_srv_cache",
    "compute_matrix",
    "compute_tile",
    "distance_matrix",
    "find_motion_files",
    "group_weights",
    "load_matrix",
    "pair_distance",
    "prepare_motion",
    "query_distances",
    "single_threaded_blas",
    "tile_blocks",
]

#: Curve representations a matrix can hold.
REPRESENTATIONS = ("lie", "euler")

#: File extensions collected from a folder (``.txt`` / ``.json`` only when they look like a
#: DeepMimic clip, i.e. start with ``{``).
MOTION_EXTENSIONS = (".bvh", ".amc", ".txt", ".json")

Progress = Callable[[str, int, int], None]

_CACHE_NAME = "srv_cache.npz"
_MANIFEST = "manifest.json"
_REPORT = "report.json"
_NAMES = "names.csv"
_TILES = "tiles"
_FORMAT_VERSION = 1


class ClusterUnavailableError(RuntimeError):
    """The Dask scheduler could not be reached (or Dask is not installed)."""


# --------------------------------------------------------------------------------------------
# Settings
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class PairSpec:
    """How one pair distance is computed (see :func:`pair_distance`).

    Attributes
    ----------
    warp : {"dp", "none"}
        ``"dp"``: elastic distance (optimal warp by dynamic programming); ``"none"``: L2
        distance of the SRV arrays without reparametrisation.
    neighbourhood : int
        DP slopes: all coprime ``(a, b)`` with ``1 <= a, b <= neighbourhood``.
    coarse_to_fine : bool
        Banded coarse-to-fine DP (faster on long grids, not exact; see ``docs/warp.md``).
    """

    warp: Literal["dp", "none"] = "dp"
    neighbourhood: int = 6
    coarse_to_fine: bool = False

    def __post_init__(self) -> None:
        if self.warp not in ("dp", "none"):
            raise ValueError(f"warp: expected 'dp' or 'none'; got {self.warp!r}")
        if not (isinstance(self.neighbourhood, int) and self.neighbourhood >= 1):
            raise ValueError(f"neighbourhood: expected an integer >= 1; got {self.neighbourhood!r}")


@dataclass(frozen=True)
class DatabaseSettings:
    """Everything that determines the numbers of a distance matrix.

    Attributes
    ----------
    n_samples : int
        Cells of the common grid: each motion is resampled to ``n_samples + 1`` frames.
    representations : tuple of {"lie", "euler"}
    pair : PairSpec
    joints : "all", "common" or tuple of str
        ``"all"``: every joint of each file; motions with different joint names form
        separate groups (entries between groups are ``+inf``). ``"common"``: the joints
        every readable motion has (one group). A tuple: exactly these joints (files
        lacking one are skipped with the reason).
    drop_fingers : bool
        Remove finger/thumb/hand-index joints (CMU's 180-degree flips).
    align_heading : bool
        Remove the yaw and floor position of the root at frame 0 before comparing.
    tile_size : int
        Motions per tile side (a tile holds up to ``tile_size**2`` pairs).
    """

    n_samples: int = 64
    representations: tuple[str, ...] = REPRESENTATIONS
    pair: PairSpec = field(default_factory=PairSpec)
    joints: str | tuple[str, ...] = "all"
    drop_fingers: bool = True
    align_heading: bool = True
    tile_size: int = 32

    def __post_init__(self) -> None:
        if not (isinstance(self.n_samples, int) and self.n_samples >= 2):
            raise ValueError(f"n_samples: expected an integer >= 2; got {self.n_samples!r}")
        reps = tuple(self.representations)
        bad = [r for r in reps if r not in REPRESENTATIONS]
        if not reps or bad or len(set(reps)) != len(reps):
            raise ValueError(f"representations: expected distinct entries of {REPRESENTATIONS}; got {reps!r}")
        object.__setattr__(self, "representations", reps)
        if isinstance(self.joints, str):
            if self.joints not in ("all", "common"):
                raise ValueError(
                    f"joints: expected 'all', 'common' or a list of joint names; got {self.joints!r}"
                )
        else:
            names = tuple(str(n) for n in self.joints)
            if not names:
                raise ValueError("joints: expected at least one joint name")
            object.__setattr__(self, "joints", names)
        if not (isinstance(self.tile_size, int) and self.tile_size >= 1):
            raise ValueError(f"tile_size: expected an integer >= 1; got {self.tile_size!r}")

    def to_json(self) -> dict[str, Any]:
        """Plain-JSON form (lists for tuples)."""
        d = asdict(self)
        d["representations"] = list(self.representations)
        d["joints"] = self.joints if isinstance(self.joints, str) else list(self.joints)
        return d

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> DatabaseSettings:
        d = dict(d)
        d["pair"] = PairSpec(**d["pair"])
        d["representations"] = tuple(d["representations"])
        if not isinstance(d["joints"], str):
            d["joints"] = tuple(d["joints"])
        return cls(**d)


# --------------------------------------------------------------------------------------------
# Pair distance and tiles (run on workers)
# --------------------------------------------------------------------------------------------


def pair_distance(q0: np.ndarray, q1: np.ndarray, spec: PairSpec = PairSpec()) -> float:
    """Distance of two SRV arrays on the same uniform grid.

    Parameters
    ----------
    q0, q1 : ndarray, shape (n, D)
        Cell values on ``linspace(0, 1, n + 1)`` (orthonormal coordinates).
    spec : PairSpec

    Returns
    -------
    float
        ``warp="dp"``: ``optimal_warp(q0, q1).distance`` = ``min_phi ||q0 - q1 * phi||``
        over the DP's piecewise linear warps; ``warp="none"``: ``||q0 - q1||_L2``
        (``sqrt(mean_i |q0_i - q1_i|^2)``). The DP value never exceeds the ``"none"`` one
        (the identity is a DP path).
    """
    if spec.warp == "none":
        d = q0 - q1
        return float(math.sqrt(np.einsum("ij,ij->", d, d) / q0.shape[0]))
    from elastic_motion.warp import optimal_warp

    return float(
        optimal_warp(q0, q1, neighbourhood=spec.neighbourhood, coarse_to_fine=spec.coarse_to_fine).distance
    )


def compute_tile(
    rows: np.ndarray,
    cols: np.ndarray,
    q_rows: Sequence[np.ndarray],
    q_cols: Sequence[np.ndarray],
    g_rows: np.ndarray,
    g_cols: np.ndarray,
    spec: PairSpec,
    numba_threads: int | None = None,
) -> np.ndarray:
    """Distances of one tile: motions ``rows`` against motions ``cols``.

    Parameters
    ----------
    rows, cols : ndarray of int, shapes (a,), (b,)
        Global motion indices.
    q_rows, q_cols : sequences of ndarray, shapes (n, D_k)
        SRV arrays of those motions.
    g_rows, g_cols : ndarray of int, shapes (a,), (b,)
        Skeleton group of each motion.
    spec : PairSpec
    numba_threads : int, optional
        Threads of numba's parallel DP inside this call (1 on single-threaded Dask
        workers, so two workers do not oversubscribe two cores). Results do not depend on it.

    Returns
    -------
    ndarray, shape (a, b), float64
        ``d(rows[r], cols[c])`` where ``rows[r] < cols[c]`` and the groups agree; 0 on the
        diagonal; ``+inf`` across groups; NaN where ``rows[r] > cols[c]`` (the mirrored
        entry is computed by the tile holding the pair with the lower index first).
    """
    if numba_threads is not None:
        import numba

        numba.set_num_threads(max(1, min(int(numba_threads), numba.config.NUMBA_NUM_THREADS)))
    # one memory layout everywhere (arrays received from a Dask scheduler are read-only and
    # unaligned): the same compiled kernel runs in every engine, and it is the fast one
    q_rows = [np.require(q, np.float64, ["C", "A", "W"]) for q in q_rows]
    q_cols = [np.require(q, np.float64, ["C", "A", "W"]) for q in q_cols]
    out = np.full((len(rows), len(cols)), np.nan)
    with single_threaded_blas():
        for a, i in enumerate(rows):
            for b, j in enumerate(cols):
                if i == j:
                    out[a, b] = 0.0
                elif i < j:
                    out[a, b] = (
                        pair_distance(q_rows[a], q_cols[b], spec) if g_rows[a] == g_cols[b] else np.inf
                    )
    return out


def single_threaded_blas() -> contextlib.AbstractContextManager:
    """Limit BLAS to one thread while tiles run, when ``threadpoolctl`` is installed.

    The DP solver makes one small matrix product per pair (the Gram matrix ``q0 q1^T``); a
    multi-threaded OpenBLAS spins its threads after each product and starves numba's own
    threads: measured 4-5x slower pairs at N = 200 on 2 cores. One thread also makes the
    product's summation order the same in every process (Dask workers are started with
    ``OPENBLAS_NUM_THREADS=1``), which keeps serial and cluster results bit-identical.
    """
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - optional dependency
        return contextlib.nullcontext()
    return threadpool_limits(1, user_api="blas")


def distance_matrix(
    q: Sequence[np.ndarray],
    spec: PairSpec = PairSpec(),
    groups: Sequence[int] | None = None,
    *,
    progress: Progress | None = None,
) -> np.ndarray:
    """All-pairs distances of in-memory SRV arrays, serially (no files, no resume).

    Same rule as the tiled runs (``i < j`` computed with ``q[i]`` as ``q0``, mirrored; ``+inf``
    across ``groups``), so the result equals theirs bit for bit.

    Parameters
    ----------
    q : sequence of ndarray, shapes (n, D_k)
    spec : PairSpec
    groups : sequence of int, optional
        Skeleton group per entry (default: all one group).

    Returns
    -------
    ndarray, shape (M, M)
    """
    m = len(q)
    g = np.zeros(m, dtype=np.int64) if groups is None else np.asarray(groups, dtype=np.int64)
    out = np.zeros((m, m))
    for i in range(m):
        idx = np.arange(i, m)
        row = compute_tile(np.array([i]), idx, [q[i]], [q[j] for j in idx], g[[i]], g[idx], spec)
        out[i, i:] = row[0]
        out[i:, i] = row[0]
        if progress is not None:
            progress("pairs", i + 1, m)
    return out


def tile_blocks(n_motions: int, tile_size: int) -> list[tuple[int, int]]:
    """Upper-triangle block pairs ``(I, J)``, ``I <= J``, of an ``n_motions`` square split in
    blocks of ``tile_size``; block ``I`` holds motions ``I*tile_size .. (I+1)*tile_size - 1``."""
    nb = -(-n_motions // tile_size)
    return [(i, j) for i in range(nb) for j in range(i, nb)]


def _block(i: int, tile_size: int, n: int) -> np.ndarray:
    return np.arange(i * tile_size, min((i + 1) * tile_size, n))


# --------------------------------------------------------------------------------------------
# Reading and preparing motions
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class PreparedMotion:
    """A motion read, cleaned and resampled, ready for its curves.

    Attributes
    ----------
    path : str
    motion : elastic_motion.motion.Motion
        Resampled to ``n_samples + 1`` frames uniformly over the clip's duration.
    original_frames : int
        Frames after cleaning, before resampling.
    duration : float
        Seconds.
    notes : tuple of str
        What the cleaning did (``"dropped T-pose frame"``, ``"merged static root"``...).
    """

    path: str
    motion: Any
    original_frames: int
    duration: float
    notes: tuple[str, ...] = ()

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(self.motion.skeleton.names)


def _looks_like_motion(path: Path) -> bool:
    if path.suffix.lower() not in (".txt", ".json"):
        return True
    try:
        with open(path, "rb") as fh:
            head = fh.read(256).lstrip()
    except OSError:
        return True  # let the reader report it
    return head.startswith(b"{")


def find_motion_files(
    inputs: Sequence[str | os.PathLike[str]], *, recursive: bool = False
) -> tuple[list[Path], list[Path]]:
    """Expand files and folders into motion files.

    Parameters
    ----------
    inputs : sequence of paths
        Files are taken as given (whatever their extension; an unreadable one is reported
        later); folders contribute their ``.bvh``, ``.amc``, and DeepMimic ``.txt`` /
        ``.json`` files (text files not starting with ``{`` are ignored), sorted by name.
    recursive : bool
        Descend into sub-folders.

    Returns
    -------
    files : list of Path
        Absolute paths, duplicates removed, in input order.
    ignored : list of Path
        Files of a folder that are not motions (e.g. ``content_label.txt``).

    Notes
    -----
    A given file that does not exist is kept: reading it fails later and it is listed as
    skipped, like any unreadable file (one bad path never aborts a run).
    """
    files: list[Path] = []
    ignored: list[Path] = []
    seen: set[Path] = set()
    for item in inputs:
        p = Path(item)
        if p.is_dir():
            pattern = "**/*" if recursive else "*"
            cands = sorted(
                c for c in p.glob(pattern) if c.is_file() and c.suffix.lower() in MOTION_EXTENSIONS
            )
        else:
            cands = [p]
        for c in cands:
            c = c.resolve()
            if c in seen:
                continue
            seen.add(c)
            if p.is_dir() and not _looks_like_motion(c):
                ignored.append(c)
            else:
                files.append(c)
    return files, ignored


def prepare_motion(
    path: str | os.PathLike[str],
    n_samples: int,
    *,
    joints: str | Sequence[str] = "all",
    drop_fingers: bool = True,
    align_heading: bool = True,
    motion: Any = None,
) -> PreparedMotion:
    """Read a motion file and bring it to the common form of a database.

    Steps: read (:func:`elastic_motion.motion.read_motion`); drop frame 0 if it is a T-pose;
    fold a root whose only child has position channels into that child (Bandai files);
    convert lengths to metres when the unit is known; drop finger joints; remove heading and
    floor position at frame 0; keep ``joints`` (a list); resample to ``n_samples + 1`` frames
    uniformly in time.

    Parameters
    ----------
    path : path
    n_samples : int
    joints : "all", "common" or sequence of str
        ``"all"`` and ``"common"`` keep every joint here (``"common"`` is applied later by
        :func:`build_srv_cache`); a sequence keeps those joints (``KeyError`` if missing).
    drop_fingers, align_heading : bool
    motion : Motion, optional
        Use this motion instead of reading ``path`` (``path`` then only names it).

    Returns
    -------
    PreparedMotion

    Raises
    ------
    ParseError
        Malformed file.
    ValueError
        Fewer than 2 frames, unsupported extension, missing joints.
    """
    from elastic_motion import motion as mm

    notes: list[str] = []
    m = mm.read_motion(path) if motion is None else motion
    if m.n_frames >= 3 and mm.has_tpose_first_frame(m):
        m = mm.drop_tpose(m)
        notes.append("dropped T-pose frame 0")
    if m.n_frames < 2:
        raise ValueError(f"{os.fspath(path)}: expected at least 2 frames; got {m.n_frames}")
    if mm.has_reference_root(m):
        m = mm.merge_root(m)
        notes.append(f"merged root {m.skeleton.names[0]!r} into its child")
    if m.metres_per_unit is not None:
        m = mm.to_metres(m)
    if drop_fingers:
        fingers = mm.finger_joints(m.skeleton)
        if fingers:
            m = mm.drop_joints(m, fingers)
            notes.append(f"dropped {len(fingers)} finger joints")
    if align_heading:
        m = mm.align_heading(m)
    if not isinstance(joints, str):
        m = mm.select_joints(m, _closed_joint_set(m.skeleton, joints))
    original = m.n_frames
    duration = m.duration
    target = np.linspace(0.0, duration, n_samples + 1)
    m = mm.resample_at_times(m, m.times, target, fps=n_samples / duration)
    return PreparedMotion(os.fspath(path), m, original, duration, tuple(notes))


def _closed_joint_set(skeleton: Any, names: Iterable[str]) -> list[str]:
    """``names`` (all must exist) in skeleton order; joints whose parent is missing are
    dropped with their subtree so the result is a valid sub-skeleton."""
    wanted = set(names)
    missing = [n for n in wanted if n not in skeleton.names]
    if missing:
        raise KeyError(f"joints: {sorted(missing)} not in the skeleton")
    keep: list[str] = []
    kept: set[int] = set()
    for k, n in enumerate(skeleton.names):
        p = int(skeleton.parents[k])
        if n in wanted and (k == 0 or p in kept):
            keep.append(n)
            kept.add(k)
    return keep


# --------------------------------------------------------------------------------------------
# SRV cache
# --------------------------------------------------------------------------------------------


@dataclass(eq=False)
class SRVCache:
    """SRV arrays of the readable motions of a database (one entry per motion).

    Attributes
    ----------
    names : list of str
        Unique display names (file stem; parent folder added on a clash).
    paths : list of str
    groups : ndarray of int, shape (M,)
        Skeleton group of each motion (motions are sorted by group, then input order).
    q : dict of str -> list of ndarray
        ``q[repr][k]`` of shape ``(n_samples, D_group)``.
    info : list of dict
        Per motion: frames, fps, duration, joints, notes.
    group_joints : list of list of str
        Joint names of each group.
    group_weights : list of (list of float, float)
        Lie inner-product weights ``(joint weights (J,), translation weight)`` of each group.
    skipped : list of dict
        ``{"path", "reason"}`` for unreadable or unusable files.
    ignored : list of str
        Folder entries that are not motion files.
    settings : DatabaseSettings
    """

    names: list[str]
    paths: list[str]
    groups: np.ndarray
    q: dict[str, list[np.ndarray]]
    info: list[dict[str, Any]]
    group_joints: list[list[str]]
    group_weights: list[tuple[list[float], float]]
    skipped: list[dict[str, str]]
    ignored: list[str]
    settings: DatabaseSettings

    def __len__(self) -> int:
        return len(self.names)

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the cache atomically as an ``.npz`` file (arrays ``q_<repr>_<k>`` + JSON meta)."""
        arrays = {f"q_{r}_{k}": a for r, lst in self.q.items() for k, a in enumerate(lst)}
        meta = {
            "format": _FORMAT_VERSION,
            "names": self.names,
            "paths": self.paths,
            "groups": self.groups.tolist(),
            "info": self.info,
            "group_joints": self.group_joints,
            "group_weights": self.group_weights,
            "skipped": self.skipped,
            "ignored": self.ignored,
            "settings": self.settings.to_json(),
        }
        buf = io.BytesIO()
        np.savez(buf, meta=np.array(json.dumps(meta)), **arrays)
        atomic_write_bytes(Path(path), buf.getvalue())

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> SRVCache:
        """Read a cache written by :meth:`save`."""
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            settings = DatabaseSettings.from_json(meta["settings"])
            n = len(meta["names"])
            q = {r: [z[f"q_{r}_{k}"] for k in range(n)] for r in settings.representations}
        return cls(
            names=meta["names"],
            paths=meta["paths"],
            groups=np.asarray(meta["groups"], dtype=np.int64),
            q=q,
            info=meta["info"],
            group_joints=meta["group_joints"],
            group_weights=[(list(w), float(t)) for w, t in meta["group_weights"]],
            skipped=meta["skipped"],
            ignored=meta["ignored"],
            settings=settings,
        )


def _unique_names(paths: Sequence[str]) -> list[str]:
    stems = [Path(p).stem for p in paths]
    out = []
    for p, s in zip(paths, stems, strict=True):
        out.append(s if stems.count(s) == 1 else f"{Path(p).parent.name}/{s}")
    # still clashing (same folder name): fall back to the full path
    return [n if out.count(n) == 1 else p for n, p in zip(out, paths, strict=True)]


def _srv_arrays(
    prepared: PreparedMotion, reps: Sequence[str], weights: tuple[np.ndarray, float] | None
) -> dict[str, np.ndarray]:
    from elastic_motion import motion as mm

    out = {}
    m = prepared.motion
    for r in reps:
        if r == "lie":
            jw, tw = weights if weights is not None else (None, None)
            curve = mm.to_lie_curve(m, jw, translation_weight=tw)
        else:
            curve = mm.to_euler_curve(m)
        out[r] = np.ascontiguousarray(srv_transform(curve).q)
    return out


def group_weights(motions: Sequence[Any]) -> tuple[np.ndarray, float]:
    """Inner-product weights shared by a skeleton group: the means of the per-motion defaults
    (:func:`elastic_motion.motion.default_joint_weights`, :func:`default_translation_weight`)."""
    from elastic_motion import motion as mm

    jw = np.mean([mm.default_joint_weights(m.skeleton) for m in motions], axis=0)
    tw = float(np.mean([mm.default_translation_weight(m.skeleton) for m in motions]))
    return jw, tw


def build_srv_cache(
    files: Sequence[str | os.PathLike[str]],
    settings: DatabaseSettings,
    *,
    ignored: Sequence[str | os.PathLike[str]] = (),
    motions: Sequence[Any] | None = None,
    progress: Progress | None = None,
) -> SRVCache:
    """Read and prepare every file, group by skeleton, compute the SRV arrays.

    Unreadable or unusable files are skipped and listed (``skipped``) with the reason; the
    run never aborts for one file.

    Parameters
    ----------
    files : sequence of paths
    settings : DatabaseSettings
    ignored : sequence of paths
        Recorded as ignored (not motions).
    motions : sequence of Motion, optional
        Already-read motions, one per entry of ``files`` (which then only name them), e.g.
        segments cut from longer clips.
    progress : callable, optional
        ``progress("read", done, total)``.

    Returns
    -------
    SRVCache

    Raises
    ------
    ValueError
        If ``settings.joints == "common"`` and the readable motions share no root joint.
    """
    files = [os.fspath(f) for f in files]
    if motions is not None and len(motions) != len(files):
        raise ValueError(f"motions: expected one motion per file ({len(files)}); got {len(motions)}")
    prepared: list[PreparedMotion] = []
    skipped: list[dict[str, str]] = []
    select = settings.joints if not isinstance(settings.joints, str) else "all"
    for k, f in enumerate(files):
        try:
            prepared.append(
                prepare_motion(
                    f,
                    settings.n_samples,
                    joints=select,
                    drop_fingers=settings.drop_fingers,
                    align_heading=settings.align_heading,
                    motion=None if motions is None else motions[k],
                )
            )
        except (ParseError, ValueError, KeyError, OSError) as exc:
            reason = exc.args[0] if isinstance(exc, KeyError) and exc.args else str(exc)
            skipped.append({"path": f, "reason": f"{type(exc).__name__}: {reason}"})
        if progress is not None:
            progress("read", k + 1, len(files))
    if settings.joints == "common" and prepared:
        common = set(prepared[0].joint_names)
        for p in prepared[1:]:
            common &= set(p.joint_names)
        roots = {p.joint_names[0] for p in prepared}
        if len(roots) != 1 or not common:
            raise ValueError(
                "joints='common': the readable motions share no common root joint "
                f"(roots: {sorted(roots)}); compare them in separate runs or with joints='all'"
            )
        from elastic_motion import motion as mm

        again = []
        for p in prepared:
            keep = _closed_joint_set(p.motion.skeleton, common)
            again.append(
                PreparedMotion(
                    p.path, mm.select_joints(p.motion, keep), p.original_frames, p.duration, p.notes
                )
            )
        prepared = again
    # groups by joint names, in order of first appearance; motions sorted by group
    keys: dict[tuple[str, ...], int] = {}
    for p in prepared:
        keys.setdefault(p.joint_names, len(keys))
    order = sorted(range(len(prepared)), key=lambda i: (keys[prepared[i].joint_names], i))
    prepared = [prepared[i] for i in order]
    group_of = np.array([keys[p.joint_names] for p in prepared], dtype=np.int64)
    weights = {}
    for g in keys.values():
        weights[g] = group_weights([p.motion for p, gg in zip(prepared, group_of, strict=True) if gg == g])
    q: dict[str, list[np.ndarray]] = {r: [] for r in settings.representations}
    info = []
    for p, g in zip(prepared, group_of, strict=True):
        arrs = _srv_arrays(p, settings.representations, weights[int(g)])
        for r in settings.representations:
            q[r].append(arrs[r])
        info.append(
            {
                "frames": p.original_frames,
                "fps": round(float((p.original_frames - 1) / p.duration), 6) if p.duration > 0 else None,
                "duration": p.duration,
                "joints": p.motion.n_joints,
                "notes": list(p.notes),
            }
        )
    paths = [p.path for p in prepared]
    return SRVCache(
        names=_unique_names(paths),
        paths=paths,
        groups=group_of,
        q=q,
        info=info,
        group_joints=[list(k) for k in keys],
        group_weights=[(weights[g][0].tolist(), weights[g][1]) for g in range(len(keys))],
        skipped=skipped,
        ignored=[os.fspath(i) for i in ignored],
        settings=settings,
    )


# --------------------------------------------------------------------------------------------
# Atomic file helpers
# --------------------------------------------------------------------------------------------


def _atomic_write_json(dest: Path, obj: Any) -> None:
    atomic_write_bytes(
        dest, (json.dumps(obj, indent=1, allow_nan=False, default=_json_default) + "\n").encode()
    )


def _json_default(o: Any) -> Any:
    if isinstance(o, np.integer):
        return int(o)
    if isinstance(o, np.floating):
        return float(o)
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def _save_npy_atomic(dest: Path, arr: np.ndarray) -> None:
    buf = io.BytesIO()
    np.save(buf, arr)
    atomic_write_bytes(dest, buf.getvalue())


_TILE_RE = re.compile(r"^(lie|euler)_(\d+)_(\d+)\.npy$")


def _tile_name(rep: str, i: int, j: int) -> str:
    return f"{rep}_{i}_{j}.npy"


# --------------------------------------------------------------------------------------------
# Engines
# --------------------------------------------------------------------------------------------


@dataclass
class _Task:
    key: str
    rep: str
    bi: int
    bj: int
    rows: np.ndarray
    cols: np.ndarray


class _SerialEngine:
    name = "serial"
    n_workers = 1

    def share(self, arrays: list[np.ndarray]) -> list[Any]:
        """Handles of the SRV arrays that tasks receive (here: the arrays themselves)."""
        return arrays

    def run(
        self, tasks: list[_Task], args_of: Callable[[_Task], tuple]
    ) -> Iterator[tuple[_Task, np.ndarray, float]]:
        for t in tasks:
            t0 = time.perf_counter()
            res = compute_tile(*args_of(t))
            yield t, res, time.perf_counter() - t0

    def close(self) -> None:
        pass


def _warm_up() -> None:
    """Load (or compile) the DP kernels in this process, for writable and for read-only arrays
    (arrays received from the scheduler are read-only: another numba specialisation)."""
    q = np.zeros((4, 2))
    q[:, 0] = 1.0
    r = q[::-1].copy()
    pair_distance(q, r, PairSpec("dp", 2))
    q.setflags(write=False)
    r.setflags(write=False)
    pair_distance(q, r, PairSpec("dp", 2))


def _timed_tile(*args: Any) -> tuple[np.ndarray, float]:
    t0 = time.perf_counter()
    res = compute_tile(*args, numba_threads=1)
    return res, time.perf_counter() - t0


class _DaskEngine:
    def __init__(self, name: str, scheduler: str | None, n_workers: int, timeout: float) -> None:
        try:
            from distributed import Client, LocalCluster
        except ImportError as exc:  # pragma: no cover - depends on the environment
            raise ClusterUnavailableError(
                f"engine {name!r} needs Dask distributed: pip install 'elastic-motion[cluster]' "
                "(or pip install 'dask[distributed]')"
            ) from exc
        self.name = name
        self.cluster = None
        if name == "local":
            self.cluster = LocalCluster(
                n_workers=n_workers,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=logging.CRITICAL,  # task errors still reach the driver as exceptions
            )
            self.client = Client(self.cluster)
        else:
            if not scheduler:
                raise ValueError("scheduler: engine 'dask' needs a scheduler address (e.g. tcp://host:8786)")
            try:
                self.client = Client(scheduler, timeout=timeout)
            except (OSError, TimeoutError) as exc:
                raise ClusterUnavailableError(
                    f"could not reach the Dask scheduler at {scheduler!r} within {timeout:g} s ({exc}). "
                    "Check the address and that `dask scheduler` is running there, or use --engine local"
                ) from exc
        info = self.client.scheduler_info()
        self.n_workers = max(1, len(info.get("workers", {})))
        self.scheduler = self.client.scheduler.address
        # load the compiled kernels on every worker once, before any tile is timed
        self.client.run(_warm_up)

    def share(self, arrays: list[np.ndarray]) -> list[Any]:
        """Scatter the SRV arrays once; tasks get futures, so each array travels to a worker at
        most once instead of once per tile (no shared file system needed)."""
        return self.client.scatter(arrays, hash=False)

    def run(
        self, tasks: list[_Task], args_of: Callable[[_Task], tuple]
    ) -> Iterator[tuple[_Task, np.ndarray, float]]:
        from distributed import as_completed

        window = max(2, 4 * self.n_workers)  # tasks in flight: bounded memory on the driver
        pending = iter(tasks)
        task_of: dict[str, _Task] = {}

        def submit(t: _Task):
            fut = self.client.submit(
                _timed_tile, *args_of(t), key=f"elastic-tile-{t.key}-{uuid.uuid4().hex}", pure=False
            )
            task_of[fut.key] = t
            return fut

        ac = as_completed([submit(t) for t in itertools.islice(pending, window)])
        for fut in ac:
            res, secs = fut.result()
            task = task_of.pop(fut.key)
            fut.release()
            nxt = next(pending, None)
            if nxt is not None:
                ac.add(submit(nxt))
            yield task, res, secs

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self.client.close()
        if self.cluster is not None:
            with contextlib.suppress(Exception):
                self.cluster.close()


def _open_engine(engine: str, scheduler: str | None, n_workers: int, timeout: float):
    if engine == "serial":
        return _SerialEngine()
    if engine in ("local", "dask"):
        return _DaskEngine(engine, scheduler, n_workers, timeout)
    raise ValueError(f"engine: expected 'serial', 'local' or 'dask'; got {engine!r}")


# --------------------------------------------------------------------------------------------
# The matrix run
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class MatrixResult:
    """Outcome of :func:`compute_matrix`.

    Attributes
    ----------
    out_dir : Path
    names : list of str
    distances : dict of str -> ndarray, shape (M, M)
        Read-only memory maps of ``distances_<repr>.npy``.
    report : dict
        The content of ``report.json``.
    """

    out_dir: Path
    names: list[str]
    distances: dict[str, np.ndarray]
    report: dict[str, Any]

    @property
    def complete(self) -> bool:
        return bool(self.report.get("complete"))


def _identity(settings: DatabaseSettings, files: Sequence[Path]) -> dict[str, Any]:
    return {
        "format": _FORMAT_VERSION,
        "settings": settings.to_json(),
        "inputs": [os.fspath(f) for f in files],
    }


def _write_names(out: Path, cache: SRVCache) -> None:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["index", "name", "path", "group", "frames", "fps", "duration", "joints"])
    for k, (n, p, g, inf) in enumerate(zip(cache.names, cache.paths, cache.groups, cache.info, strict=True)):
        w.writerow([k, n, p, int(g), inf["frames"], inf["fps"], f"{inf['duration']:.6g}", inf["joints"]])
    atomic_write_bytes(out / _NAMES, buf.getvalue().encode())


def _clean_outputs(out: Path) -> None:
    for name in (_MANIFEST, _REPORT, _NAMES, _CACHE_NAME, *[f"distances_{r}.npy" for r in REPRESENTATIONS]):
        with contextlib.suppress(FileNotFoundError):
            (out / name).unlink()
    tiles = out / _TILES
    if tiles.is_dir():
        for f in tiles.iterdir():
            if _TILE_RE.match(f.name) or f.name.endswith(".tmp"):
                f.unlink()
        with contextlib.suppress(OSError):
            tiles.rmdir()


def compute_matrix(
    inputs: Sequence[str | os.PathLike[str]],
    out_dir: str | os.PathLike[str],
    settings: DatabaseSettings | None = None,
    *,
    engine: Literal["serial", "local", "dask"] = "serial",
    scheduler: str | None = None,
    n_workers: int = 2,
    connect_timeout: float = 10.0,
    recursive: bool = False,
    overwrite: bool = False,
    progress: Progress | None = None,
) -> MatrixResult:
    """All-pairs distances of the motions in ``inputs``, written tile by tile to ``out_dir``.

    Parameters
    ----------
    inputs : sequence of paths
        Motion files and/or folders (see :func:`find_motion_files`).
    out_dir : path
        Output folder (created). If it holds a run with the same settings and inputs, that
        run is resumed: finished tiles are kept, the rest computed. A different run there is
        an error unless ``overwrite=True`` (which deletes this module's files only).
    settings : DatabaseSettings, optional
    engine : {"serial", "local", "dask"}
    scheduler : str, optional
        Address of the Dask scheduler for ``engine="dask"``.
    n_workers : int
        Worker processes of the ``"local"`` cluster.
    connect_timeout : float
        Seconds to wait for the scheduler (``"dask"``).
    recursive : bool
        Search folders recursively.
    overwrite : bool
    progress : callable, optional
        ``progress(stage, done, total)`` with stages ``"read"`` and ``"tiles"``; called after
        each tile is safely on disk.

    Returns
    -------
    MatrixResult

    Raises
    ------
    ClusterUnavailableError
        The scheduler cannot be reached (checked before anything is written).
    ValueError
        Bad settings, no readable motion, or ``out_dir`` holding another run.
    """
    settings = settings or DatabaseSettings()
    out = Path(out_dir)
    files, ignored = find_motion_files(inputs, recursive=recursive)
    if any(out.resolve() == f or (out.resolve() in f.parents and f.name in _our_names()) for f in files):
        raise ValueError(f"out_dir: {os.fspath(out)!r} would overwrite an input file; choose another folder")
    ident = _identity(settings, files)
    manifest_path = out / _MANIFEST
    if manifest_path.exists():
        old = json.loads(manifest_path.read_text())
        if old.get("identity") != ident:
            if not overwrite:
                raise ValueError(
                    f"out_dir: {os.fspath(out)!r} holds a run with other settings or inputs "
                    f"({_identity_diff(old.get('identity'), ident)}); choose another folder or overwrite it"
                )
            _clean_outputs(out)
    elif overwrite and out.exists():
        _clean_outputs(out)
    # connect before writing anything: an unreachable scheduler leaves no output behind
    eng = _open_engine(engine, scheduler, n_workers, connect_timeout)
    try:
        return _run(out, files, ignored, settings, ident, eng, progress)
    finally:
        eng.close()


def _our_names() -> set[str]:
    return {_MANIFEST, _REPORT, _NAMES, _CACHE_NAME, *[f"distances_{r}.npy" for r in REPRESENTATIONS]}


def _identity_diff(old: dict | None, new: dict) -> str:
    if not old:
        return "unreadable manifest"
    diffs = []
    if old.get("inputs") != new["inputs"]:
        diffs.append("inputs differ")
    so, sn = old.get("settings", {}), new["settings"]
    diffs += [f"{k}: {so.get(k)!r} -> {sn[k]!r}" for k in sn if so.get(k) != sn[k]]
    return "; ".join(diffs) or "format differs"


def _run(
    out: Path,
    files: list[Path],
    ignored: list[Path],
    settings: DatabaseSettings,
    ident: dict[str, Any],
    eng: Any,
    progress: Progress | None,
) -> MatrixResult:
    started = time.time()
    out.mkdir(parents=True, exist_ok=True)
    (out / _TILES).mkdir(exist_ok=True)
    manifest_path = out / _MANIFEST
    manifest = json.loads(manifest_path.read_text()) if manifest_path.exists() else None
    cache_path = out / _CACHE_NAME
    t_read = time.perf_counter()
    cache = None
    if manifest is not None and cache_path.exists():
        with contextlib.suppress(Exception):
            cache = SRVCache.load(cache_path)
    cache_reused = cache is not None
    if cache is None:
        cache = build_srv_cache(files, settings, ignored=ignored, progress=progress)
        if len(cache) == 0:
            raise ValueError(
                "inputs: no readable motion; skipped: "
                + "; ".join(f"{s['path']}: {s['reason']}" for s in cache.skipped[:5])
            )
        cache.save(cache_path)
    t_read = time.perf_counter() - t_read
    _write_names(out, cache)
    m = len(cache)
    ts = settings.tile_size
    blocks = tile_blocks(m, ts)
    if manifest is None:
        manifest = {
            "identity": ident,
            "n_motions": m,
            "tile_size": ts,
            "n_blocks": -(-m // ts),
            "tiles": {},
            "runs": [],
        }
    run_id = len(manifest["runs"]) + 1
    # adopt tile files on disk (ground truth): also those finished after the last manifest write
    on_disk = {f.name for f in (out / _TILES).iterdir() if _TILE_RE.match(f.name)}
    recovered = 0
    for name in sorted(on_disk):
        key = name[:-4]
        if key not in manifest["tiles"]:
            manifest["tiles"][key] = {"run": run_id, "recovered": True}
            recovered += 1
    for key in list(manifest["tiles"]):
        if key + ".npy" not in on_disk:  # listed but file gone: recompute
            del manifest["tiles"][key]
    run_info = {
        "run": run_id,
        "engine": eng.name,
        "workers": eng.n_workers,
        "scheduler": getattr(eng, "scheduler", None),
        "started": time.strftime("%Y-%m-%dT%H:%M:%S%z", time.localtime(started)),
        "tiles_before": len(manifest["tiles"]),
        "tiles_recovered": recovered,
        "tiles_computed": 0,
        "pairs_computed": 0,
    }
    manifest["runs"].append(run_info)
    _atomic_write_json(manifest_path, manifest)

    report = _report(cache, settings, eng, files, complete=False)
    report["runs"] = manifest["runs"]
    _atomic_write_json(out / _REPORT, report)

    # matrices: rebuilt from the tiles on disk
    mats = {}
    for r in settings.representations:
        mm = np.lib.format.open_memmap(out / f"distances_{r}.npy", mode="w+", dtype=np.float64, shape=(m, m))
        mm[:] = np.nan
        mats[r] = mm
    for key in manifest["tiles"]:
        r, bi, bj = _parse_key(key)
        _place(mats[r], np.load(out / _TILES / (key + ".npy")), _block(bi, ts, m), _block(bj, ts, m))

    todo = []
    for r in settings.representations:
        for bi, bj in blocks:
            key = f"{r}_{bi}_{bj}"
            if key not in manifest["tiles"]:
                todo.append(_Task(key, r, bi, bj, _block(bi, ts, m), _block(bj, ts, m)))
    total = len(blocks) * len(settings.representations)
    done = total - len(todo)
    if progress is not None:
        progress("tiles", done, total)

    spec = settings.pair
    groups = cache.groups

    handles: dict[str, list[Any]] = {}

    def args_of(t: _Task) -> tuple:
        if t.rep not in handles:
            handles[t.rep] = eng.share(cache.q[t.rep])
        qs = handles[t.rep]
        return (
            t.rows,
            t.cols,
            [qs[i] for i in t.rows],
            [qs[j] for j in t.cols],
            groups[t.rows],
            groups[t.cols],
            spec,
        )

    t_tiles = time.perf_counter()
    tile_seconds = 0.0
    last_manifest = time.monotonic()
    for task, res, secs in eng.run(todo, args_of):
        _save_npy_atomic(out / _TILES / (task.key + ".npy"), res)
        _place(mats[task.rep], res, task.rows, task.cols)
        n_pairs = _pairs_in(task.rows, task.cols, groups)
        manifest["tiles"][task.key] = {"run": run_id, "seconds": round(secs, 4), "pairs": n_pairs}
        run_info["tiles_computed"] += 1
        run_info["pairs_computed"] += n_pairs
        tile_seconds += secs
        done += 1
        if time.monotonic() - last_manifest > 2.0 or done == total:
            _atomic_write_json(manifest_path, manifest)
            last_manifest = time.monotonic()
        if progress is not None:
            progress("tiles", done, total)
    wall = time.perf_counter() - t_tiles
    for mm in mats.values():
        mm.flush()
    complete = all(
        f"{r}_{bi}_{bj}" in manifest["tiles"] for r in settings.representations for bi, bj in blocks
    )
    if complete:
        for r, mm in mats.items():
            if np.isnan(mm).any():  # every tile present, so this is a bug, not an interruption
                raise RuntimeError(f"distances_{r}.npy: NaN left after all tiles were written")
    run_info["seconds_tiles"] = round(wall, 3)
    run_info["seconds_tile_work"] = round(tile_seconds, 3)
    run_info["seconds_read"] = round(t_read, 3)
    run_info["cache_reused"] = cache_reused
    run_info["pairs_per_second"] = (
        round(run_info["pairs_computed"] / wall, 3) if wall > 0 and run_info["pairs_computed"] else None
    )
    _atomic_write_json(manifest_path, manifest)
    report = _report(cache, settings, eng, files, complete=complete)
    report["runs"] = manifest["runs"]
    report["timings"] = {
        "read_seconds": round(t_read, 3),
        "tiles_seconds": round(wall, 3),
        "pairs_computed": run_info["pairs_computed"],
        "pairs_per_second": run_info["pairs_per_second"],
    }
    _atomic_write_json(out / _REPORT, report)
    del mats
    dists = {r: np.load(out / f"distances_{r}.npy", mmap_mode="r") for r in settings.representations}
    return MatrixResult(out, cache.names, dists, report)


def _parse_key(key: str) -> tuple[str, int, int]:
    r, bi, bj = key.rsplit("_", 2)
    return r, int(bi), int(bj)


def _pairs_in(rows: np.ndarray, cols: np.ndarray, groups: np.ndarray) -> int:
    i = rows[:, None]
    j = cols[None, :]
    return int(((i < j) & (groups[i] == groups[j])).sum())


def _place(mat: np.ndarray, tile: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> None:
    """Write a tile's upper-triangle entries and their mirror into ``mat``."""
    a, b = np.nonzero(rows[:, None] <= cols[None, :])
    i, j = rows[a], cols[b]
    mat[i, j] = tile[a, b]
    mat[j, i] = tile[a, b]


def _comparison_note(settings: DatabaseSettings, groups: list[dict[str, Any]]) -> str:
    if settings.joints == "common" and groups:
        joints = groups[0]["joints"]
        note = f"joints='common': all motions compared on the {len(joints)} joints they share"
        if len(joints) < 5:
            note += f" (only {joints}: the skeletons have little in common, distances mean little)"
        return note
    if len(groups) <= 1:
        return "one skeleton group"
    return (
        f"{len(groups)} skeleton groups: distances between groups are +inf "
        "(use joints='common' to compare them on their shared joints)"
    )


def _report(
    cache: SRVCache, settings: DatabaseSettings, eng: Any, files: Sequence[Path], *, complete: bool
) -> dict[str, Any]:
    groups = []
    for g, joints in enumerate(cache.group_joints):
        members = [n for n, gg in zip(cache.names, cache.groups, strict=True) if gg == g]
        groups.append({"group": g, "joints": joints, "n_joints": len(joints), "motions": members})
    return {
        "complete": complete,
        "n_inputs": len(files),
        "n_motions": len(cache),
        "settings": settings.to_json(),
        "skipped": cache.skipped,
        "ignored": cache.ignored,
        "groups": groups,
        "comparison": _comparison_note(settings, groups),
        "joints_mode": settings.joints if isinstance(settings.joints, str) else "list",
        "engine": eng.name,
        "workers": eng.n_workers,
        "scheduler": getattr(eng, "scheduler", None),
        "host": platform.node(),
        "files": {
            "names": _NAMES,
            "distances": {r: f"distances_{r}.npy" for r in settings.representations},
            "srv_cache": _CACHE_NAME,
            "tiles": _TILES + "/",
        },
    }


# --------------------------------------------------------------------------------------------
# Reading results, querying
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class DistanceMatrix:
    """A matrix read back from an output folder.

    Attributes
    ----------
    distances : ndarray, shape (M, M)
    names : list of str
    paths : list of str
    groups : ndarray of int, shape (M,)
    representation : str
    report : dict
    """

    distances: np.ndarray
    names: list[str]
    paths: list[str]
    groups: np.ndarray
    representation: str
    report: dict[str, Any]


def load_matrix(
    out_dir: str | os.PathLike[str], representation: str = "lie", *, require_complete: bool = True
) -> DistanceMatrix:
    """Read ``distances_<representation>.npy``, ``names.csv`` and ``report.json`` of a run.

    Raises
    ------
    FileNotFoundError
        If the folder holds no such matrix.
    ValueError
        If the run is not complete and ``require_complete`` (resume it first).
    """
    out = Path(out_dir)
    path = out / f"distances_{representation}.npy"
    if not path.exists():
        raise FileNotFoundError(
            f"{os.fspath(path)!r}: no {representation} distance matrix in {os.fspath(out)!r}"
        )
    report = json.loads((out / _REPORT).read_text()) if (out / _REPORT).exists() else {}
    if require_complete and not report.get("complete"):
        raise ValueError(
            f"{os.fspath(out)!r}: the run is not complete (report.json complete=false); resume it with the "
            "same matrix command first"
        )
    with open(out / _NAMES, newline="") as fh:
        rows = list(csv.DictReader(fh))
    d = np.load(path)
    return DistanceMatrix(
        distances=d,
        names=[r["name"] for r in rows],
        paths=[r["path"] for r in rows],
        groups=np.array([int(r["group"]) for r in rows], dtype=np.int64),
        representation=representation,
        report=report,
    )


def query_distances(
    query: str | os.PathLike[str],
    database: str | os.PathLike[str] | Sequence[str | os.PathLike[str]],
    representation: str = "lie",
    settings: DatabaseSettings | None = None,
    *,
    progress: Progress | None = None,
) -> tuple[list[str], list[str], np.ndarray, dict[str, Any]]:
    """Distances from one motion to every motion of a database.

    Parameters
    ----------
    query : path
        A motion file.
    database : path or sequence of paths
        A matrix output folder (its ``srv_cache.npz`` and settings are used; nothing is
        written to it), or motion files / folders (read now, nothing cached).
    representation : {"lie", "euler"}
    settings : DatabaseSettings, optional
        For a database of files (default :class:`DatabaseSettings`).

    Returns
    -------
    names, paths : list of str
    distances : ndarray, shape (M,)
        ``+inf`` for motions whose skeleton differs from the query's (after joint selection).
    info : dict
        ``{"skipped": [...], "settings": {...}}``.

    Raises
    ------
    ValueError
        Unreadable query, or a representation the database does not hold.
    """
    db = [database] if isinstance(database, str | os.PathLike) else list(database)
    if len(db) == 1 and (Path(db[0]) / _CACHE_NAME).exists():
        cache = SRVCache.load(Path(db[0]) / _CACHE_NAME)
    else:
        settings = settings or DatabaseSettings(representations=(representation,))
        files, ignored = find_motion_files(db)
        cache = build_srv_cache(files, settings, ignored=ignored, progress=progress)
    settings = cache.settings
    if representation not in settings.representations:
        raise ValueError(
            f"representation: the database holds {list(settings.representations)}; got {representation!r}"
        )
    select: str | Sequence[str] = "all"
    if settings.joints == "common" and cache.group_joints:
        select = cache.group_joints[0]
    elif not isinstance(settings.joints, str):
        select = settings.joints
    p = prepare_motion(
        query,
        settings.n_samples,
        joints=select,
        drop_fingers=settings.drop_fingers,
        align_heading=settings.align_heading,
    )
    names = p.joint_names
    try:
        g = [tuple(j) for j in cache.group_joints].index(names)
    except ValueError:
        g = -1
    members = [k for k in range(len(cache)) if cache.groups[k] == g]
    if g >= 0:  # the query is measured in its group's shared metric
        jw, tw = cache.group_weights[g]
        weights = (np.asarray(jw), float(tw))
    else:
        weights = group_weights([p.motion])
    qq = _srv_arrays(p, [representation], weights)[representation]
    out = np.full(len(cache), np.inf)
    spec = settings.pair
    for n, k in enumerate(members):
        out[k] = pair_distance(qq, cache.q[representation][k], spec)
        if progress is not None:
            progress("query", n + 1, len(members))
    return (
        cache.names,
        cache.paths,
        out,
        {"skipped": cache.skipped, "settings": settings.to_json(), "group": g},
    )


def remove_run(out_dir: str | os.PathLike[str]) -> None:
    """Delete the files this module wrote in ``out_dir`` (never anything else)."""
    _clean_outputs(Path(out_dir))
    with contextlib.suppress(OSError):
        Path(out_dir).rmdir()
