"""The events of one or two motions and their landmark pairs, as ``elastic-motion landmarks``
reports them: :func:`detect_landmarks` is that command as a Python function.

One motion: its events (:func:`elastic_motion.apps.landmarks.detect_events`). Two motions:
both prepared together with their common joints, as ``blend`` and ``align`` prepare them, the
events of each, and the pairs ``landmarks="auto"`` meets: the same planning step
(:func:`elastic_motion.apps.align.align_motions` with ``landmarks="auto"``), the same curves
and warp options, so that the pairs are exactly those of ``blend --landmarks auto`` with the
same ``method`` and ``warp``. The report of the command (``--json PAIRS.json``) is
:meth:`LandmarkReport.summary` under the shared report header; ``--landmarks PAIRS.json``
then gives the warp ``auto`` gives.

:func:`prior_warp` and :func:`auto_landmarks` are the pairing by phase of two prepared
motions with the warp without landmarks as the prior, found here (the prior is an
alignment, so this module sits above :mod:`elastic_motion.apps.align`, which uses
:mod:`elastic_motion.apps.landmarks`).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from elastic_motion.apps.align import AlignResult, CurveMethod, align_motions
from elastic_motion.apps.landmarks import (
    DEFAULT_PAIR_KINDS,
    Event,
    PhasePairing,
    detect_events,
    phase_landmarks,
)
from elastic_motion.apps.prepare import PreparedMotions, PrepareOptions, Source, prepare_motions
from elastic_motion.motion import Motion
from elastic_motion.warp import WarpOptions

__all__ = ["LandmarkReport", "auto_landmarks", "detect_landmarks", "prior_warp"]


@dataclass(frozen=True, eq=False)
class LandmarkReport:
    """What :func:`detect_landmarks` found.

    Attributes
    ----------
    sources : tuple of str
        The inputs as given (a path's text, a ``Motion``'s name), one per motion.
    kinds : tuple of str
        The event kinds detected.
    events : tuple of tuple of Event
        The events of each motion, sorted by time (seconds from its first frame kept).
    prepared : PreparedMotions
        The motions as the events were detected on (two: their common joints).
    alignment : AlignResult or None
        Two motions: the alignment with ``landmarks="auto"`` whose planning step paired the
        events (its ``landmarks``, ``landmark_weight`` and ``landmark_pairing``); None for one.
    pair_kinds : tuple of str or None
        Two motions: the kinds paired by phase.
    method : str or None
        Two motions: the curves of the warp without landmarks the pairing starts from.
    """

    sources: tuple[str, ...]
    kinds: tuple[str, ...]
    events: tuple[tuple[Event, ...], ...]
    prepared: PreparedMotions = field(repr=False)
    alignment: AlignResult | None = field(default=None, repr=False)
    pair_kinds: tuple[str, ...] | None = None
    method: str | None = None

    @property
    def motions(self) -> tuple[Motion, ...]:
        """The prepared motions."""
        return self.prepared.motions

    @property
    def pairs(self) -> list[tuple[float, float]]:
        """The landmark pairs ``(tA, tB)`` in seconds (``tB`` where the warp is pinned); empty
        for one motion."""
        return [] if self.alignment is None else [tuple(p) for p in self.alignment.landmarks]

    @property
    def landmark_weight(self) -> float | None:
        """The relative weight ``landmarks="auto"`` meets the pairs with (None for one motion
        or without pairs)."""
        return None if self.alignment is None else self.alignment.landmark_weight

    @property
    def pairing(self) -> PhasePairing | None:
        """Two motions: the pairing by phase, with every pair's and every skipped event's reason."""
        return None if self.alignment is None else self.alignment.landmark_pairing

    @property
    def notes(self) -> tuple[Any, ...]:
        """What the preparation (and, for two motions, the alignment) noted."""
        prepared = self.prepared if self.alignment is None else self.alignment.prepared
        return tuple(prepared.notes)

    def summary(self) -> dict[str, Any]:
        """The fields of the ``landmarks`` command's report (besides the shared header):
        ``events`` per motion; for two motions ``pairs_s``, ``landmark_weight``, ``pairs``
        (each pinned pair and why), ``skipped``, ``pairing`` (the rule), ``units`` and
        ``method``. A file of it is read back by ``--landmarks`` (and
        :func:`elastic_motion.apps.landmark_files.read_landmark_file`)."""
        out: dict[str, Any] = {
            "events": [
                {
                    "file": source,
                    "duration_s": m.duration,
                    "fps": m.fps,
                    "events": [dataclasses.asdict(e) for e in ev],
                }
                for source, m, ev in zip(self.sources, self.motions, self.events, strict=True)
            ]
        }
        pairing = self.pairing
        if self.alignment is None or pairing is None:
            return out
        out["pairs_s"] = [list(p) for p in self.alignment.landmarks]
        out["landmark_weight"] = self.alignment.landmark_weight
        out["pairs"] = [dict(d) for d in pairing.details]
        out["skipped"] = [dict(d) for d in pairing.skipped]
        out["pairing"] = pairing.summary()["rule"]
        out["units"] = "seconds"
        out["method"] = self.method
        return out


def _source_name(source: Source) -> str:
    return source.name if isinstance(source, Motion) else os.fspath(source)


def detect_landmarks(
    a: Source,
    b: Source | None = None,
    *,
    kinds: Sequence[str] | None = None,
    pair_kinds: Sequence[str] | None = None,
    max_pairs: int | None = None,
    method: CurveMethod = "lie",
    warp: str | WarpOptions | None = None,
    prepare: PrepareOptions | None = None,
) -> LandmarkReport:
    """The events of one motion, or of two and their landmark pairs (module docstring).

    ``em.detect_landmarks("a.bvh", "b.bvh")`` is ``elastic-motion landmarks a.bvh b.bvh``:
    the same events, pairs, weight and reasons.

    Parameters
    ----------
    a, b : path or Motion
        One motion, or two to pair (prepared together with their common joints).
    kinds : sequence of str, optional
        Event kinds to detect (:data:`elastic_motion.apps.landmarks.EVENT_KINDS`); default
        :data:`~elastic_motion.apps.landmarks.DEFAULT_PAIR_KINDS` (knee crossings, heel
        strikes and toe-offs).
    pair_kinds : sequence of str, optional
        Two motions: the kinds paired by phase, as ``landmark_kinds`` of ``blend`` and
        ``align`` (default ``DEFAULT_PAIR_KINDS``).
    max_pairs : int, optional
        Two motions: at most this many pairs per kind.
    method : {"lie", "euler-elastic", "euler-linear"}
        Two motions: the curves of the warp without landmarks the pairing starts from, as
        the blend's or alignment's ``method``.
    warp : str or WarpOptions, optional
        Two motions: how that warp is found (default ``WarpOptions()``).
    prepare : PrepareOptions, optional
        The preparation step (default ``PrepareOptions()``; two motions keep their common
        joints).

    Returns
    -------
    LandmarkReport

    Raises
    ------
    ValueError
        An unknown event kind; a skeleton without the joints a kind needs.
    """
    sources = [a] if b is None else [a, b]
    options = PrepareOptions() if prepare is None else prepare
    prep = prepare_motions(sources, options.replace(joints="common") if b is not None else options)
    kinds = tuple(kinds) if kinds else DEFAULT_PAIR_KINDS
    events = tuple(tuple(detect_events(m, kinds)) for m in prep.motions)
    names = tuple(_source_name(s) for s in sources)
    if b is None:
        return LandmarkReport(names, kinds, events, prep)
    pk = tuple(pair_kinds) if pair_kinds else DEFAULT_PAIR_KINDS
    # the pairs blend/align --landmarks auto would meet: the same planning step, same curves
    res = align_motions(
        prep, method=method, warp=warp, landmarks="auto", landmark_kinds=list(pk), max_pairs=max_pairs
    )
    return LandmarkReport(names, kinds, events, prep, res, pk, method)


def prior_warp(a: Motion, b: Motion) -> np.ndarray:
    """The warp without landmarks of two prepared motions (Lie curves, the default
    :class:`~elastic_motion.warp.WarpOptions`, as ``blend`` and ``align`` find it), vertices
    ``(V, 2)``."""
    res = align_motions(a, b, method="lie", prepare=PrepareOptions(joints="common", drop_tpose=False))
    return np.asarray(res.vertices)


def auto_landmarks(
    a: Motion,
    b: Motion,
    kinds: Sequence[str] = DEFAULT_PAIR_KINDS,
    *,
    max_pairs: int | None = None,
    prior: np.ndarray | None = None,
) -> list[tuple[float, float]]:
    """Landmark pairs ``(time in a, time in b)`` in seconds, events paired by phase.

    Detects ``kinds`` on both motions and pairs them by phase
    (:func:`elastic_motion.apps.landmarks.phase_landmarks`: the warp without landmarks,
    ``prior``, default :func:`prior_warp`, predicts where each event of A falls in B).
    Events at the very first or last frame are dropped (the warp fixes its ends anyway).

    Returns
    -------
    list of (float, float)
        Possibly empty (e.g. a motion without knee crossings or contacts).
    """
    if prior is None:
        prior = prior_warp(a, b)
    return phase_landmarks(a, b, kinds, prior=prior, max_pairs=max_pairs).times
