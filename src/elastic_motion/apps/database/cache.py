"""The SRV cache: every readable motion prepared once, grouped by skeleton, as SRV arrays.

Curve representations (each clip's duration normalised to 1, grid ``linspace(0, 1, n + 1)``
with ``n = n_samples``, SRV arrays ``q`` of shape ``(n, D)``, cell-valued):

- ``"lie"``: the curve in ``R^3 x SO(3)^J`` (:func:`elastic_motion.motion.to_lie_curve`),
  ``D = 3 + 3 J``, with the inner-product weights of a skeleton group *shared by all its
  motions* (:func:`elastic_motion.motion.group_weights`: mean of the per-motion defaults,
  so that two motions are compared in one metric);
- ``"euler"``: continuous Euler angles in ``R^(3 + 3 J)``
  (:func:`elastic_motion.motion.to_euler_curve`), root position in metres, angles in
  radians, unweighted (the baseline of paper 001).

Stored as ``srv_cache.npz``: arrays ``q_<repr>_<k>`` and a JSON ``meta`` entry (names, paths,
groups, per-motion info, group joints and weights, skipped files, settings).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, BinaryIO, Protocol

import numpy as np

from elastic_motion._io import atomic_write_bytes, open_regular
from elastic_motion.apps.database.preparation import (
    PreparedMotion,
    balanced_pose_weight,
    common_joint_names,
    pose_arrays,
    prepare_motion,
    restrict_prepared,
    with_pose_term,
)
from elastic_motion.apps.database.settings import FORMAT_VERSION, READABLE_FORMATS, DatabaseSettings
from elastic_motion.apps.prepare import rest_pose_like
from elastic_motion.apps.progress import Progress
from elastic_motion.curves import srv_transform
from elastic_motion.errors import OptionError, ParseError
from elastic_motion.motion import Motion, Skeleton, default_joint_weights, default_translation_weight
from elastic_motion.motion.representations import mean_weights, representation

__all__ = [
    "FilesNotSeenError",
    "HereStages",
    "SRVCache",
    "Stages",
    "build_srv_cache",
    "file_fingerprint",
    "prepare_chunk",
    "srv_arrays",
    "srv_chunk",
    "summarise_chunk",
]


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
    q : dict of str -> sequence of ndarray
        ``q[repr][k]`` of shape ``(n_samples, D_group)``: lists in memory, or the rows of an
        index read when used (:func:`~elastic_motion.apps.database.load_index`).
    info : list of dict
        Per motion: frames, fps, duration (s), joints, notes.
    group_joints : list of list of str
        Joint names of each group.
    group_weights : list of (list of float, float)
        Lie inner-product weights ``(joint weights (J,), translation weight (1/m^2))`` of
        each group.
    pose_weights : dict of str -> list of float
        With ``settings.pose_weight``: the weight ``lam`` of the pose term of each group per
        representation (the arrays of ``q`` are then ``[SRV | sqrt(lam) pose]``,
        :func:`~elastic_motion.apps.database.preparation.with_pose_term`); empty otherwise.
    skipped : list of dict
        ``{"path", "reason"}`` for unreadable or unusable files.
    ignored : list of str
        Folder entries that are not motion files.
    settings : DatabaseSettings
    real_paths : list of str
        Each motion's file with links and ``..`` resolved (``os.path.realpath``) when the cache
        was built: whether an entry is a query's own file is one comparison (the query's path
        resolved once), never a resolution per entry; empty in a cache written before they were
        stored.
    """

    names: list[str]
    paths: list[str]
    groups: np.ndarray
    q: dict[str, Sequence[np.ndarray]]
    info: list[dict[str, Any]]
    group_joints: list[list[str]]
    group_weights: list[tuple[list[float], float]]
    skipped: list[dict[str, str]]
    ignored: list[str]
    settings: DatabaseSettings
    pose_weights: dict[str, list[float]] = field(default_factory=dict)
    group_rest: list[dict[str, Any]] = field(default_factory=list)
    real_paths: list[str] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.names)

    def meta(self) -> dict[str, Any]:
        """Everything but the SRV arrays, JSON-ready (the ``meta`` entry of :meth:`to_bytes`;
        :meth:`from_meta` reads it back)."""
        return {
            "format": FORMAT_VERSION,
            "names": self.names,
            "paths": self.paths,
            "groups": self.groups.tolist(),
            "info": self.info,
            "group_joints": self.group_joints,
            "group_weights": self.group_weights,
            "skipped": self.skipped,
            "ignored": self.ignored,
            "settings": self.settings.to_json(),
            **({"pose_weights": self.pose_weights} if self.pose_weights else {}),
            **({"group_rest": self.group_rest} if self.group_rest else {}),
            **({"real_paths": self.real_paths} if self.real_paths else {}),
        }

    def to_bytes(self) -> bytes:
        """The cache as the bytes of an ``.npz`` file (arrays ``q_<repr>_<k>`` + JSON :meth:`meta`)."""
        arrays = {f"q_{r}_{k}": a for r, lst in self.q.items() for k, a in enumerate(lst)}
        buf = io.BytesIO()
        np.savez(buf, meta=np.array(json.dumps(self.meta())), **arrays)
        return buf.getvalue()

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the cache atomically as an ``.npz`` file (:meth:`to_bytes`)."""
        atomic_write_bytes(Path(path), self.to_bytes())

    @classmethod
    def load(cls, path: str | os.PathLike[str] | BinaryIO) -> SRVCache:
        """Read a cache written by :meth:`save` (this release's format or format 1).

        Only a regular file is opened (:func:`elastic_motion._io.open_regular`: a FIFO is
        refused, never waited on), no pickle is read, and every SRV array is checked: float64,
        ``(n_samples, D)`` with one ``D`` per skeleton group, finite.

        Parameters
        ----------
        path : path or binary file
            The ``.npz`` file, or the file already opened (e.g. by
            :func:`~elastic_motion.apps.database.verified.open_verified`).

        Raises
        ------
        OptionError
            A cache of an unknown format (written by a newer release), or damaged.
        ParseError
            ``path`` is not a regular file.
        """
        name = str(getattr(path, "name", "srv_cache.npz")) if hasattr(path, "read") else os.fspath(path)
        with contextlib.ExitStack() as stack:
            fh = path if hasattr(path, "read") else stack.enter_context(open_regular(path))
            z = stack.enter_context(np.load(fh, allow_pickle=False))
            meta = json.loads(str(z["meta"]))
            fmt = meta.get("format")
            if fmt not in READABLE_FORMATS:
                raise OptionError(
                    "srv_cache",
                    f"{name}: expected a cache of format {list(READABLE_FORMATS)}; got format "
                    f"{fmt!r} (written by another release: delete the folder's files or recompute with "
                    "overwrite=True / --overwrite)",
                )
            settings = DatabaseSettings.from_json(meta["settings"], fmt)
            n = len(meta["names"])
            q = {r: [z[f"q_{r}_{k}"] for k in range(n)] for r in settings.representations}
        _check_arrays(
            name, q, np.asarray(meta["groups"], dtype=np.int64), len(meta["group_joints"]), settings
        )
        return cls.from_meta(name, meta, q)

    @classmethod
    def from_meta(cls, name: str, meta: dict[str, Any], q: dict[str, Sequence[np.ndarray]]) -> SRVCache:
        """The cache of the JSON ``meta`` of :meth:`meta` and the SRV arrays ``q`` (checked by
        the caller: :meth:`load` checks every array, an index each row it reads).

        Raises
        ------
        OptionError
            Pose weights missing for ``settings.pose_weight`` (a damaged cache; ``name`` in the message).
        KeyError, TypeError, ValueError
            ``meta`` lacking an entry or holding one of another type.
        """
        settings = DatabaseSettings.from_json(meta["settings"], meta.get("format", FORMAT_VERSION))
        groups = np.asarray(meta["groups"], dtype=np.int64)
        pose_weights = {r: [float(x) for x in v] for r, v in meta.get("pose_weights", {}).items()}
        n_groups = len(meta["group_joints"])
        if settings.pose_weight and any(
            len(pose_weights.get(r, ())) != n_groups for r in settings.representations
        ):
            raise OptionError(
                "srv_cache",
                f"{name}: expected one pose weight per representation "
                f"{list(settings.representations)} and skeleton group ({n_groups}) for pose_weight="
                f"{settings.pose_weight!r}; got {pose_weights} (a damaged cache: recompute with "
                "overwrite=True / --overwrite)",
            )
        return cls(
            names=meta["names"],
            paths=meta["paths"],
            groups=groups,
            q=q,
            info=meta["info"],
            group_joints=meta["group_joints"],
            group_weights=[(list(w), float(t)) for w, t in meta["group_weights"]],
            skipped=meta["skipped"],
            ignored=meta["ignored"],
            settings=settings,
            pose_weights=pose_weights,
            group_rest=list(meta.get("group_rest", [])),
            real_paths=[str(p) for p in meta.get("real_paths", [])],
        )

    def group_rest_skeleton(self, group: int, like: Skeleton) -> tuple[Skeleton, str] | None:
        """The rest pose of skeleton group ``group`` (its first motion's) as a skeleton with the
        joints and channels of ``like`` (a motion of that group), and its motion's name; None
        for a cache written before rest poses were stored."""
        if not 0 <= group < len(self.group_rest):
            return None
        r = self.group_rest[group]
        sk = Skeleton(
            like.names,
            r["parents"],
            np.asarray(r["offsets"], dtype=np.float64).reshape(-1, 3),
            like.channels,
            r["end_site_parents"],
            np.asarray(r["end_site_offsets"], dtype=np.float64).reshape(-1, 3),
        )
        return sk, r["name"]


def _check_arrays(
    name: str, q: dict[str, list[np.ndarray]], groups: np.ndarray, n_groups: int, settings: DatabaseSettings
) -> None:
    """``OptionError`` unless every SRV array of a loaded cache is what :func:`build_srv_cache`
    makes: float64, ``(n_samples, D)`` with one ``D`` per representation and group, finite."""
    n = len(groups)
    problem = None
    if n and not (groups.ndim == 1 and 0 <= groups.min() and groups.max() < n_groups):
        problem = f"group ids {groups.tolist()[:10]} for {n_groups} groups"
    for r, arrays in q.items():
        if len(arrays) != n and problem is None:
            problem = f"{len(arrays)} motions and {n} group ids"
        dims: dict[int, int] = {}
        for k, a in enumerate(arrays):
            if problem is not None:
                break
            d = dims.setdefault(int(groups[k]), a.shape[-1] if a.ndim == 2 else -1)
            if a.dtype != np.float64 or a.shape != (settings.n_samples, d):
                problem = f"q_{r}_{k} is {a.shape} {a.dtype}, expected ({settings.n_samples}, {d}) float64"
            elif not np.isfinite(a).all():
                problem = f"q_{r}_{k} holds NaN or infinite values"
    if problem is not None:
        raise OptionError(
            "srv_cache",
            f"{name}: expected the SRV arrays of a cache; got {problem} (a damaged cache: recompute "
            "with overwrite=True / --overwrite)",
        )


def _rest_json(sk: Skeleton, name: str) -> dict[str, Any]:
    """A skeleton group's rest pose in the cache's JSON meta."""
    return {
        "name": name,
        "parents": [int(x) for x in sk.parents],
        "offsets": np.asarray(sk.offsets, dtype=np.float64).tolist(),
        "end_site_parents": [int(x) for x in sk.end_site_parents],
        "end_site_offsets": np.asarray(sk.end_site_offsets, dtype=np.float64).tolist(),
    }


def _unique_names(paths: Sequence[str]) -> list[str]:
    stems = [Path(p).stem for p in paths]
    out = []
    for p, s in zip(paths, stems, strict=True):
        out.append(s if stems.count(s) == 1 else f"{Path(p).parent.name}/{s}")
    # still clashing (same folder name): fall back to the full path
    return [n if out.count(n) == 1 else p for n, p in zip(out, paths, strict=True)]


def srv_arrays(
    prepared: PreparedMotion,
    representations: Sequence[str],
    weights: tuple[np.ndarray, float] | None,
    *,
    pose: bool = False,
) -> dict[str, np.ndarray]:
    """SRV arrays of one prepared motion.

    Parameters
    ----------
    prepared : PreparedMotion
        ``n + 1`` frames.
    representations : sequence of str or Representation
        Keys (``"lie"``, ``"euler"``) or names of :mod:`elastic_motion.motion.representations`;
        the arrays are keyed as given.
    weights : (ndarray of shape (J,), float) or None
        Lie inner-product weights (joints, translation); None: the motion's own defaults.
    pose : bool, default False
        Also ``"pose"``: :func:`~elastic_motion.apps.database.preparation.pose_arrays` with
        the same joint weights (the pose term of ``DatabaseSettings.pose_weight``, unweighted).

    Returns
    -------
    dict of str -> ndarray, shape (n, D)
        C-contiguous float64.
    """
    out = {}
    m = prepared.motion
    sk = m.skeleton
    jw, tw = weights if weights is not None else (default_joint_weights(sk), default_translation_weight(sk))
    for r in representations:
        curve = representation(r).to_curve(m, jw, tw)
        out[r] = np.ascontiguousarray(srv_transform(curve).q)
    if pose:
        out["pose"] = pose_arrays(m, jw)
    return out


def _prepare_one(
    path: str, settings: DatabaseSettings, motion: Motion | None = None
) -> PreparedMotion | dict[str, str]:
    """One file prepared as the database does, or ``{"path", "reason"}`` when it is unusable.

    A module-level function of picklable arguments: engines may run it in worker processes.
    """
    select = settings.joints if settings.joints == "map" or not isinstance(settings.joints, str) else "all"
    try:
        return prepare_motion(
            path,
            settings.n_samples,
            smoothing=settings.warp.sample_smoothing,
            joints=select,
            drop_fingers=settings.drop_fingers,
            align_heading=settings.align_heading,
            motion=motion,
            options=settings.read_options(),
        )
    except (ParseError, ValueError, KeyError, OSError) as exc:
        reason = exc.args[0] if isinstance(exc, KeyError) and exc.args else str(exc)
        return {"path": path, "reason": f"{type(exc).__name__}: {reason}"}


# --------------------------------------------------------------------------------------------
# The preparation in stages, here or on workers
# --------------------------------------------------------------------------------------------
#
# build_srv_cache runs in three stages over chunks of files; the prepared motions (about
# 120 kB each) stay where they were prepared, only small summaries and the SRV arrays travel:
#
# 1. prepare_chunk: read and prepare each file (where the chunk runs);
#    summarise_chunk: per motion its joint names and its default inner-product weights;
# 2. (joints='common' only) the driver intersects the joint names, _restrict_chunk applies them,
#    summarised again;
# 3. the driver groups the motions by joint names and takes each group's weights (means of the
#    per-motion defaults, in input order: what group_weights computes); srv_chunk computes the
#    SRV arrays where the motions are and sends them back (the cache keeps them).


class FilesNotSeenError(RuntimeError):
    """A worker does not see an input file as the driver does (missing, other size or time)."""


def file_fingerprint(path: str) -> tuple[int, int] | None:
    """``(size, mtime_ns)`` of the file at ``path`` (links followed); None when it cannot be stat'ed.

    What a worker compares before it reads a file for the driver (:class:`FilesNotSeenError`)."""
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return None
    return st.st_size, st.st_mtime_ns


#: One file of a chunk: ``(path, already-read motion or None, fingerprint to check or None)``.
ChunkItem = tuple[str, Motion | None, tuple[int, int] | None]


def prepare_chunk(
    items: list[ChunkItem], settings: DatabaseSettings
) -> list[PreparedMotion | dict[str, str]]:
    """:func:`_prepare_one` of each item; an unexpected error names the file (as a note)."""
    out: list[PreparedMotion | dict[str, str]] = []
    for path, motion, seen in items:
        if seen is not None and file_fingerprint(path) != seen:
            raise FilesNotSeenError(
                f"{path}: expected the file the driver sees (size, mtime_ns) = {seen}; got "
                f"{file_fingerprint(path)} on this worker"
            )
        try:
            out.append(_prepare_one(path, settings, motion))
        except Exception as exc:
            exc.add_note(f"while preparing {path} for a database")
            raise
    return out


def summarise_chunk(prepared: list[PreparedMotion | dict[str, str]]) -> list[dict[str, Any]]:
    """Per item: ``{"skipped": {"path", "reason"}}`` or ``{"names", "jw", "tw", "skeleton"}``
    (joint names, default joint weights ``(J,)`` and translation weight of its skeleton, and
    the skeleton)."""
    out: list[dict[str, Any]] = []
    for p in prepared:
        if isinstance(p, PreparedMotion):
            sk = p.motion.skeleton
            out.append(
                {
                    "names": p.joint_names,
                    "jw": default_joint_weights(sk),
                    "tw": default_translation_weight(sk),
                    "skeleton": sk,
                }
            )
        else:
            out.append({"skipped": p})
    return out


def _rest_chunk(
    prepared: list[PreparedMotion | dict[str, str]], refs: list[tuple[Skeleton, str] | None]
) -> list[PreparedMotion | dict[str, str]]:
    """Each motion in its skeleton group's rest frames (:func:`~elastic_motion.apps.prepare.rest_pose_like`:
    re-expressed only when its rest pose is another conversion's), a note when it was."""
    out: list[PreparedMotion | dict[str, str]] = []
    for p, ref in zip(prepared, refs, strict=True):
        if isinstance(p, PreparedMotion) and ref is not None:
            motion, notes = rest_pose_like(ref[0], p.motion, ref[1], Path(p.path).stem)
            p = replace(p, motion=motion, notes=(*p.notes, *notes)) if notes else p
        out.append(p)
    return out


def _restrict_chunk(
    prepared: list[PreparedMotion | dict[str, str]], common: frozenset[str]
) -> list[PreparedMotion | dict[str, str]]:
    return [restrict_prepared(p, common) if isinstance(p, PreparedMotion) else p for p in prepared]


def _motion_info(p: PreparedMotion) -> dict[str, Any]:
    return {
        "frames": p.original_frames,
        "fps": round(float((p.original_frames - 1) / p.duration), 6) if p.duration > 0 else None,
        "duration": p.duration,
        "joints": p.motion.n_joints,
        "notes": list(p.notes),
    }


def srv_chunk(
    prepared: list[PreparedMotion | dict[str, str]],
    weights: list[tuple[np.ndarray, float] | None],
    representations: tuple[str, ...],
    pose: bool = False,
) -> list[tuple[dict[str, np.ndarray], dict[str, Any]] | None]:
    """Per item: its SRV arrays (:func:`srv_arrays` with its group's ``weights``, and its pose
    array when ``pose``) and its info; None for a skipped file. An error names the file (as a note)."""
    out: list[tuple[dict[str, np.ndarray], dict[str, Any]] | None] = []
    for p, w in zip(prepared, weights, strict=True):
        if not isinstance(p, PreparedMotion):
            out.append(None)
            continue
        try:
            out.append((srv_arrays(p, representations, w, pose=pose), _motion_info(p)))
        except Exception as exc:
            exc.add_note(f"while computing the SRV of {p.path} for a database")
            raise
    return out


class Stages(Protocol):
    """Where the stages of :func:`build_srv_cache` run: ``fn`` applied to chunks, the results
    kept where they were computed (handles) until gathered or released.

    :class:`HereStages` runs them in this process; a Dask engine on its workers
    (:meth:`elastic_motion.apps.database.engines.DaskEngine.stages`). The result does not depend on it.
    """

    #: Files per chunk (one task each).
    chunk_size: int

    def submit(self, fn: Callable[..., Any], args: Sequence[tuple]) -> list[Any]:
        """Handles of ``fn(*a)`` for each ``a`` of ``args``."""
        ...

    def then(
        self, fn: Callable[..., Any], handles: Sequence[Any], args: Sequence[tuple] | None = None
    ) -> list[Any]:
        """Handles of ``fn(value_k, *args[k])`` for each handle ``k``, run where its value is."""
        ...

    def gather(self, handles: Sequence[Any], on_done: Callable[[int], None] | None = None) -> list[Any]:
        """The values of ``handles`` in order; ``on_done(k)`` as each is ready."""
        ...

    def release(self, handles: Sequence[Any]) -> None:
        """Forget the values of ``handles``."""
        ...


class _Deferred:
    """A value computed on first use, here: ``fn(*args)`` with deferred arguments resolved."""

    __slots__ = ("args", "done", "fn", "value")

    def __init__(self, fn: Callable[..., Any], args: tuple) -> None:
        self.fn, self.args, self.done, self.value = fn, args, False, None

    def get(self) -> Any:
        if not self.done:
            self.value = self.fn(*(a.get() if isinstance(a, _Deferred) else a for a in self.args))
            self.done, self.fn, self.args = True, None, ()
        return self.value


class HereStages:
    """The stages of :func:`build_srv_cache` in this process, one file per chunk, each computed
    when first gathered (so progress follows the files)."""

    chunk_size = 1

    def submit(self, fn: Callable[..., Any], args: Sequence[tuple]) -> list[Any]:
        return [_Deferred(fn, tuple(a)) for a in args]

    def then(
        self, fn: Callable[..., Any], handles: Sequence[Any], args: Sequence[tuple] | None = None
    ) -> list[Any]:
        args = args if args is not None else [()] * len(handles)
        return [_Deferred(fn, (h, *a)) for h, a in zip(handles, args, strict=True)]

    def gather(self, handles: Sequence[Any], on_done: Callable[[int], None] | None = None) -> list[Any]:
        out = []
        for k, h in enumerate(handles):
            out.append(h.get())
            if on_done is not None:
                on_done(k)
        return out

    def release(self, handles: Sequence[Any]) -> None:
        """Nothing to do: a value goes with the last handle that refers to it (as a Dask
        future's, it outlives ``release`` while a later stage still needs it)."""


def build_srv_cache(
    files: Sequence[str | os.PathLike[str]],
    settings: DatabaseSettings,
    *,
    ignored: Sequence[str | os.PathLike[str]] = (),
    motions: Sequence[Motion] | None = None,
    progress: Progress | None = None,
    stages: Stages | None = None,
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
        segments cut from longer clips. Prepared here whatever ``stages``.
    progress : callable, optional
        ``progress("read", done, total)`` as files are read and prepared.
    stages : Stages, optional
        Where the files are read, prepared and their SRV computed (chunks of files as tasks,
        the prepared motions kept there; module comment above): e.g. a Dask engine's workers
        (:meth:`elastic_motion.apps.database.engines.DaskEngine.stages`), which must see the
        driver's files (each checks :func:`file_fingerprint`, else :class:`FilesNotSeenError`).
        Default :class:`HereStages`: here, one file after another. The result does not depend on it.

    Returns
    -------
    SRVCache

    Raises
    ------
    OptionError
        If ``settings.joints == "common"`` and the readable motions share no root joint, or
        ``motions`` does not match ``files``.
    FilesNotSeenError
        ``stages`` whose workers do not see a file as this process does.
    """
    files = [os.fspath(f) for f in files]
    if motions is not None and len(motions) != len(files):
        raise OptionError("motions", f"expected one motion per file ({len(files)}); got {len(motions)}")
    if stages is None or motions is not None:
        stages = HereStages()
        items: list[ChunkItem] = [
            (f, None if motions is None else motions[k], None) for k, f in enumerate(files)
        ]
    else:
        items = [(f, None, file_fingerprint(f)) for f in files]
    size = max(1, int(stages.chunk_size))
    chunks = [items[k : k + size] for k in range(0, len(items), size)]
    done = [0]

    def read(k: int) -> None:
        done[0] += len(chunks[k])
        if progress is not None:
            progress("read", done[0], len(files))

    prepared = stages.submit(prepare_chunk, [(c, settings) for c in chunks])
    try:
        summary = [s for c in stages.gather(stages.then(summarise_chunk, prepared), read) for s in c]
        usable = [k for k, s in enumerate(summary) if "names" in s]
        if settings.joints == "common" and usable:
            common = common_joint_names([summary[k]["names"] for k in usable])
            restricted = stages.then(_restrict_chunk, prepared, [(common,)] * len(prepared))
            stages.release(prepared)
            prepared = restricted
            summary = [s for c in stages.gather(stages.then(summarise_chunk, prepared)) for s in c]
        groups = _SkeletonGroups.of(summary, usable, files)
        refs = groups.rest_references(summary, files, len(items))
        if any(r is not None for r in refs):
            moved = stages.then(
                _rest_chunk, prepared, [(refs[k : k + size],) for k in range(0, len(items), size)]
            )
            stages.release(prepared)
            prepared = moved
        item_weights = [
            groups.weights[groups.of_item[k]] if k in groups.of_item else None for k in range(len(items))
        ]
        srv_args = [
            (item_weights[k : k + size], tuple(settings.representations), bool(settings.pose_weight))
            for k in range(0, len(items), size)
        ]
        srv = stages.then(srv_chunk, prepared, srv_args)
        arrays = [a for c in stages.gather(srv) for a in c]
        stages.release(srv)
    finally:
        stages.release(prepared)
    return _assembled_cache(files, ignored, summary, groups, arrays, settings)


@dataclass(eq=False)
class _SkeletonGroups:
    """The usable motions of :func:`build_srv_cache` grouped by joint names (step 3 of the comment
    above), from the summaries of :func:`summarise_chunk`.

    Attributes
    ----------
    keys : dict of tuple of str -> int
        Joint names -> group, groups numbered in order of first appearance.
    first_of : dict of tuple of str -> int
        Joint names -> the item of the group's first motion, whose rest pose the group takes.
    of_item : dict of int -> int
        Usable item -> its group.
    order : list of int
        The usable items sorted by group, then input order (the order of the cache).
    weights : dict of int -> (ndarray of shape (J,), float)
        Group -> its Lie inner-product weights: the means of its motions' defaults, in the
        cache's order (:func:`elastic_motion.motion.group_weights` of the group's motions).
    rest : list of dict
        Per group its rest pose in the cache's JSON meta (its first motion's skeleton).
    """

    keys: dict[tuple[str, ...], int]
    first_of: dict[tuple[str, ...], int]
    of_item: dict[int, int]
    order: list[int]
    weights: dict[int, tuple[np.ndarray, float]]
    rest: list[dict[str, Any]]

    @classmethod
    def of(cls, summary: list[dict[str, Any]], usable: list[int], files: list[str]) -> _SkeletonGroups:
        """The groups of the items ``usable`` of ``summary`` (``files``: the items' paths)."""
        keys: dict[tuple[str, ...], int] = {}
        first_of: dict[tuple[str, ...], int] = {}
        for k in usable:
            key = tuple(summary[k]["names"])
            if key not in keys:
                keys[key], first_of[key] = len(keys), k
        of_item = {k: keys[tuple(summary[k]["names"])] for k in usable}
        order = sorted(usable, key=lambda k: (of_item[k], k))
        weights: dict[int, tuple[np.ndarray, float]] = {}
        for g in keys.values():  # = motion.group_weights of the group's motions, in this order
            members = [summary[k] for k in order if of_item[k] == g]
            weights[g] = mean_weights([s["jw"] for s in members], [s["tw"] for s in members])
        rest = [
            _rest_json(summary[first_of[key]]["skeleton"], Path(files[first_of[key]]).stem) for key in keys
        ]
        return cls(keys, first_of, of_item, order, weights, rest)

    def rest_references(
        self, summary: list[dict[str, Any]], files: list[str], n_items: int
    ) -> list[tuple[Skeleton, str] | None]:
        """Per item the rest pose (skeleton, motion name) of its group's first motion when it is
        not that motion itself, else None: one rest pose per group, so that another conversion
        of the same skeleton is re-expressed in it (its rotations would mean other poses:
        distances, means and the pose term compared conversions instead of motions)."""
        refs: list[tuple[Skeleton, str] | None] = [None] * n_items
        for k in self.of_item:
            f = self.first_of[tuple(summary[k]["names"])]
            if f != k:
                refs[k] = (summary[f]["skeleton"], Path(files[f]).stem)
        return refs


def _assembled_cache(
    files: list[str],
    ignored: Sequence[str | os.PathLike[str]],
    summary: list[dict[str, Any]],
    groups: _SkeletonGroups,
    arrays: list[tuple[dict[str, np.ndarray], dict[str, Any]] | None],
    settings: DatabaseSettings,
) -> SRVCache:
    """The cache of the SRV ``arrays`` of each item (:func:`srv_chunk`), in the groups' order,
    with the pose term appended when ``settings.pose_weight`` asks for it."""
    order = groups.order
    n_groups = len(groups.keys)
    q: dict[str, list[np.ndarray]] = {r: [arrays[k][0][r] for k in order] for r in settings.representations}
    group_ids = np.array([groups.of_item[k] for k in order], dtype=np.int64)
    pose_weights: dict[str, list[float]] = {}
    if settings.pose_weight:
        poses = [arrays[k][0]["pose"] for k in order]
        pose_weights = {r: _pose_weights(q[r], poses, group_ids, n_groups, settings) for r in q}
        q = {
            r: [
                with_pose_term(a, b, pose_weights[r][g])
                for a, b, g in zip(q[r], poses, group_ids, strict=True)
            ]
            for r in q
        }
    paths = [files[k] for k in order]
    return SRVCache(
        real_paths=[os.path.realpath(p) for p in paths],
        names=_unique_names(paths),
        paths=paths,
        groups=group_ids,
        q=q,
        info=[arrays[k][1] for k in order],
        group_joints=[list(k) for k in groups.keys],
        group_weights=[(groups.weights[g][0].tolist(), groups.weights[g][1]) for g in range(n_groups)],
        group_rest=groups.rest,
        skipped=[s["skipped"] for s in summary if "skipped" in s],
        ignored=[os.fspath(i) for i in ignored],
        settings=settings,
        pose_weights=pose_weights,
    )


def _pose_weights(
    srvs: list[np.ndarray],
    poses: list[np.ndarray],
    groups: np.ndarray,
    n_groups: int,
    settings: DatabaseSettings,
) -> list[float]:
    """The pose term's weight per skeleton group: ``settings.pose_weight``, or with
    ``"balanced"`` :func:`~elastic_motion.apps.database.preparation.balanced_pose_weight` of
    the group's motions (a group of one motion: 1, nothing to balance it against)."""
    if settings.pose_weight != "balanced":
        return [float(settings.pose_weight)] * n_groups
    out = []
    for g in range(n_groups):
        idx = np.flatnonzero(groups == g)
        out.append(
            balanced_pose_weight([srvs[k] for k in idx], [poses[k] for k in idx]) if len(idx) > 1 else 1.0
        )
    return out
