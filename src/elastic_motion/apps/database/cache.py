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

import functools
import io
import json
import os
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from elastic_motion._io import atomic_write_bytes
from elastic_motion.apps.database.preparation import PreparedMotion, prepare_motion, restrict_to_common_joints
from elastic_motion.apps.database.settings import FORMAT_VERSION, READABLE_FORMATS, DatabaseSettings
from elastic_motion.apps.progress import Progress
from elastic_motion.curves import srv_transform
from elastic_motion.errors import OptionError, ParseError
from elastic_motion.motion import Motion, group_weights, to_euler_curve, to_lie_curve

__all__ = ["SRVCache", "build_srv_cache", "srv_arrays"]


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
        Per motion: frames, fps, duration (s), joints, notes.
    group_joints : list of list of str
        Joint names of each group.
    group_weights : list of (list of float, float)
        Lie inner-product weights ``(joint weights (J,), translation weight (1/m^2))`` of
        each group.
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
        }
        buf = io.BytesIO()
        np.savez(buf, meta=np.array(json.dumps(meta)), **arrays)
        atomic_write_bytes(Path(path), buf.getvalue())

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> SRVCache:
        """Read a cache written by :meth:`save` (this release's format or format 1).

        Raises
        ------
        OptionError
            A cache of an unknown format (written by a newer release).
        """
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            fmt = meta.get("format")
            if fmt not in READABLE_FORMATS:
                raise OptionError(
                    "srv_cache",
                    f"{os.fspath(path)}: expected a cache of format {list(READABLE_FORMATS)}; got format "
                    f"{fmt!r} (written by another release: delete the folder's files or recompute with "
                    "overwrite=True / --overwrite)",
                )
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


def srv_arrays(
    prepared: PreparedMotion, representations: Sequence[str], weights: tuple[np.ndarray, float] | None
) -> dict[str, np.ndarray]:
    """SRV arrays of one prepared motion.

    Parameters
    ----------
    prepared : PreparedMotion
        ``n + 1`` frames.
    representations : sequence of {"lie", "euler"}
    weights : (ndarray of shape (J,), float) or None
        Lie inner-product weights (joints, translation); None: the motion's own defaults.

    Returns
    -------
    dict of str -> ndarray, shape (n, D)
        C-contiguous float64.
    """
    out = {}
    m = prepared.motion
    for r in representations:
        if r == "lie":
            jw, tw = weights if weights is not None else (None, None)
            curve = to_lie_curve(m, jw, translation_weight=tw)
        else:
            curve = to_euler_curve(m)
        out[r] = np.ascontiguousarray(srv_transform(curve).q)
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
            joints=select,
            drop_fingers=settings.drop_fingers,
            align_heading=settings.align_heading,
            motion=motion,
        )
    except (ParseError, ValueError, KeyError, OSError) as exc:
        reason = exc.args[0] if isinstance(exc, KeyError) and exc.args else str(exc)
        return {"path": path, "reason": f"{type(exc).__name__}: {reason}"}


#: ``mapper(fn, items)``: ``fn`` applied to each item, results in order (e.g. on worker processes).
Mapper = Callable[[Callable[[Any], Any], Sequence[Any]], Iterable[Any]]


def build_srv_cache(
    files: Sequence[str | os.PathLike[str]],
    settings: DatabaseSettings,
    *,
    ignored: Sequence[str | os.PathLike[str]] = (),
    motions: Sequence[Motion] | None = None,
    progress: Progress | None = None,
    mapper: Mapper | None = None,
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
    mapper : callable, optional
        ``mapper(fn, files)`` yields ``fn(file)`` for each file in order: where the files are
        read and prepared (e.g. a local cluster's workers, :meth:`Engine.map`); default: here,
        one after another. Not used with ``motions``. The result does not depend on it.

    Returns
    -------
    SRVCache

    Raises
    ------
    OptionError
        If ``settings.joints == "common"`` and the readable motions share no root joint, or
        ``motions`` does not match ``files``.
    """
    files = [os.fspath(f) for f in files]
    if motions is not None and len(motions) != len(files):
        raise OptionError("motions", f"expected one motion per file ({len(files)}); got {len(motions)}")
    prepared: list[PreparedMotion] = []
    skipped: list[dict[str, str]] = []
    if motions is not None:
        results: Iterable[Any] = (_prepare_one(f, settings, m) for f, m in zip(files, motions, strict=True))
    elif mapper is not None:
        results = mapper(functools.partial(_prepare_one, settings=settings), files)
    else:
        results = (_prepare_one(f, settings) for f in files)
    for k, res in enumerate(results):
        if isinstance(res, PreparedMotion):
            prepared.append(res)
        else:
            skipped.append(res)
        if progress is not None:
            progress("read", k + 1, len(files))
    if settings.joints == "common":
        prepared = restrict_to_common_joints(prepared)
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
        arrs = srv_arrays(p, settings.representations, weights[int(g)])
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
