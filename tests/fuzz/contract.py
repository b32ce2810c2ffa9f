"""The fuzzing contract, one home for both generators (``mutations.py``, ``grammar.py``), the
pytest modules and ``benchmarks/fuzz_readers.py``.

A case is a file (and, for an AMC, its ASF). :func:`run_checked` reads it and classifies:

* ``"parse_error"``: the reader raised the project's ``ParseError`` -- fine;
* ``"escaped"``: anything else came out of the reader (another exception, a Motion with a
  NaN) -- the contract broken;
* an accepted file is then **written back** (``write_bvh``, the motion's own channels) and
  **read back** (``read_bvh``), and must be the same motion (:func:`compare_motions`): same
  frame count, frame rate, joint names and parents, the same channel layout for a BVH
  source, the same End Sites per joint, and forward-kinematics joint positions equal to
  :data:`POSITION_RTOL` of the skeleton's size. ``"ok"`` when it is; ``"writeback_failed"``
  when ``write_bvh`` refuses it, the written file does not read, or the motion differs.

Memory: :func:`reset_peak_rss` / :func:`peak_rss_mb` measure one case's peak resident set
growth on Linux (``/proc/self/clear_refs`` and ``VmHWM``); :func:`can_measure_rss` says
whether they work here.
"""

from __future__ import annotations

import contextlib
import math
import os
import tempfile
import time
import traceback
import warnings
from collections import Counter
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from mutations import check_result, read_case

from elastic_motion.errors import ParseError

#: Digits after the point ``write_bvh`` is asked for: its values then round-trip to 5e-13
#: (degrees and length units), well inside :data:`POSITION_RTOL`.
WRITE_DECIMALS = 12
#: Joint positions read back must equal the first reading's to this fraction of the
#: skeleton's size (its rest-pose span or posed extent, at least 1e-3 units).
POSITION_RTOL = 1e-9

STATUSES = ("ok", "parse_error", "escaped", "writeback_failed")
#: What a grammar case adds: a valid file refused, an invalid one accepted.
VERDICTS = (*STATUSES, "valid_refused", "invalid_accepted")
#: The verdicts that break the contract.
FAILURES = ("escaped", "writeback_failed", "valid_refused", "invalid_accepted")


@dataclass(frozen=True)
class Outcome:
    """What one case did: a status of :data:`STATUSES`, its detail (the error), and the first
    warning raised while reading or writing back (``""`` for none)."""

    status: str
    detail: str = ""
    warning: str = ""

    @property
    def accepted(self) -> bool:
        """The reader returned a motion (whatever the write-back did)."""
        return self.status not in ("parse_error", "escaped")


def verdict(outcome: Outcome, expect: str = "any") -> str:
    """The case's verdict: its status, or ``"valid_refused"`` / ``"invalid_accepted"`` when the
    grammar said the file is valid (``expect == "ok"``) or invalid (``"error"``) and the reader
    did the opposite. An escape stays an escape."""
    if outcome.status == "escaped":
        return "escaped"
    if expect == "ok" and not outcome.accepted:
        return "valid_refused"
    if expect == "error" and outcome.accepted:
        return "invalid_accepted"
    return outcome.status


def _finite_span(points: np.ndarray) -> float:
    """Largest extent along an axis of ``points`` ``(..., N, 3)`` (finite ones), per set."""
    p = np.where(np.isfinite(points), points, np.nan)
    with np.errstate(invalid="ignore", over="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN slices
        ext = np.nanmax(p, axis=-2) - np.nanmin(p, axis=-2)
    ext = ext[np.isfinite(ext)]
    return float(ext.max()) if ext.size else 0.0


def _positions(motion) -> np.ndarray:
    """Joint positions ``(F, J, 3)`` with the root at the origin (its translation compared
    apart: a root far away would swamp the skeleton's digits)."""
    from elastic_motion.motion.kinematics import joint_positions_and_rotations

    t = motion.local_translations()
    t[:, 0] = 0.0
    with np.errstate(all="ignore"):
        return joint_positions_and_rotations(motion.skeleton.parents, t, motion.rotations)[0]


def _differ(a: np.ndarray, b: np.ndarray, tol: np.ndarray | float) -> tuple[int, ...] | None:
    """Index of the first entry where ``a`` and ``b`` differ by more than ``tol`` (or in
    finiteness), else None."""
    fa, fb = np.isfinite(a), np.isfinite(b)
    with np.errstate(invalid="ignore", over="ignore"):
        bad = (fa != fb) | (fa & fb & ~(np.abs(a - b) <= tol)) | (~fa & ~fb & (a != b) & ~np.isnan(a))
    if not bad.any():
        return None
    return tuple(int(i) for i in np.argwhere(bad)[0])


def compare_motions(a, b, *, same_channels: bool) -> str:
    """``""`` when ``b`` (written and read back) is the motion ``a``; else what differs."""
    sa, sb = a.skeleton, b.skeleton
    if a.n_frames != b.n_frames:
        return f"{a.n_frames} frames read back as {b.n_frames}"
    if not math.isclose(a.fps, b.fps, rel_tol=1e-12):
        return f"fps {a.fps!r} read back as {b.fps!r}"
    if sa.names != sb.names or not np.array_equal(sa.parents, sb.parents):
        names = [(x, y) for x, y in zip(sa.names, sb.names, strict=False) if x != y][:1]
        return f"{sa.n_joints} joints read back as {sb.n_joints}; first names that differ: {names}"
    if same_channels and sa.channels != sb.channels:
        k = next(k for k in range(sa.n_joints) if sa.channels[k] != sb.channels[k])
        return f"channels of {sa.names[k]!r}: {sa.channels[k]} written as {sb.channels[k]}"
    pa, pb = _positions(a), _positions(b)
    rest = np.concatenate([sa.offsets, sa.end_site_offsets])
    size = max(_finite_span(pa), float(np.abs(np.where(np.isfinite(rest), rest, 0)).max(initial=0)), 1e-3)
    tol = POSITION_RTOL * size
    where = _differ(pa, pb, tol)
    if where is not None:
        f, j, ax = where
        return (
            f"joint {sa.names[j]!r} frame {f} axis {ax}: position {pa[where]!r} read back as "
            f"{pb[where]!r} (tolerance {tol:.3g}, skeleton size {size:.3g})"
        )
    ra, rb = a.root_translation, b.root_translation
    where = _differ(ra, rb, tol + 4 * np.spacing(np.abs(np.where(np.isfinite(ra), ra, 0))))
    if where is not None:
        return f"root translation frame {where[0]}: {ra[where]!r} read back as {rb[where]!r}"
    for j in range(sa.n_joints):
        ea = sa.end_site_offsets[sa.end_site_parents == j]
        eb = sb.end_site_offsets[sb.end_site_parents == j]
        if ea.shape != eb.shape or _differ(ea, eb, 0.0) is not None:
            return f"End Sites of {sa.names[j]!r}: {ea.tolist()} read back as {eb.tolist()}"
    return ""


def write_back(motion, folder: Path, tag: str, *, same_channels: bool) -> Outcome:
    """Write ``motion`` as BVH in ``folder``, read it back and compare (module docstring)."""
    from elastic_motion.motion import read_bvh, write_bvh

    out = folder / f"{tag}_writeback.bvh"
    try:
        try:
            write_bvh(motion, out, decimals=WRITE_DECIMALS)
        except Exception as exc:
            return Outcome("writeback_failed", f"write_bvh: {type(exc).__name__}: {str(exc)[:300]}")
        try:
            back = read_bvh(out)
        except Exception as exc:  # a ParseError too: write_bvh wrote a file read_bvh refuses
            return Outcome("writeback_failed", f"read back: {type(exc).__name__}: {str(exc)[:300]}")
        diff = compare_motions(motion, back, same_channels=same_channels)
        return Outcome("writeback_failed", diff[:400]) if diff else Outcome("ok", "")
    finally:
        try:
            os.unlink(out)
        except OSError:
            pass


def run_checked(folder: Path, name: str, data: bytes, asf: bytes | None, tag: str) -> Outcome:
    """Write ``data`` as ``name`` (and ``asf`` as its skeleton) in ``folder``, read it, and
    write back an accepted motion; the outcome (module docstring)."""
    path = folder / f"{tag}_{name}"
    path.write_bytes(data)
    asf_path = None
    if asf is not None:
        asf_path = folder / f"{tag}_skeleton.asf"
        asf_path.write_bytes(asf)
    try:
        caught: list[str] = []
        with warnings.catch_warnings():
            warnings.simplefilter("always")
            warnings.showwarning = _first_warning(caught)
            out = _read_and_write_back(path, asf_path, folder, tag)
        return Outcome(out.status, out.detail, caught[0]) if caught else out
    finally:
        for p in (path, asf_path):
            if p is not None:
                try:
                    os.unlink(p)
                except OSError:
                    pass


def _first_warning(caught: list[str]) -> Callable[..., None]:
    """A ``warnings.showwarning`` that keeps the first warning in ``caught``, with the package
    functions it came through (``read_bvh > _motion_from_values > ... > guess_units (bvh.py:113)``)."""

    def show(message, category, filename, lineno, file=None, line=None) -> None:
        if caught:
            return
        ours = [f for f in traceback.extract_stack()[:-1] if f"{os.sep}elastic_motion{os.sep}" in f.filename]
        path = " > ".join(f.name for f in ours)
        where = f" in {path} ({Path(ours[-1].filename).name}:{ours[-1].lineno})" if ours else ""
        caught.append(f"{category.__name__}: {str(message)[:150]}{where}")

    return show


def _read_and_write_back(path: Path, asf_path: Path | None, folder: Path, tag: str) -> Outcome:
    from elastic_motion.motion import Motion

    try:
        motion = read_case(path, asf_path)
        check_result(motion)
    except ParseError as exc:
        return Outcome("parse_error", str(exc)[:200])
    except Exception as exc:  # the contract: nothing else escapes a reader
        return Outcome("escaped", f"{type(exc).__name__}: {str(exc)[:300]}")
    if not isinstance(motion, Motion):  # an ASF alone: a skeleton, no motion to write
        return Outcome("ok", "")
    return write_back(motion, folder, tag, same_channels=path.suffix.lower() == ".bvh")


@contextlib.contextmanager
def scratch_dir() -> Iterator[Path]:
    """A temporary folder, in memory (``/dev/shm``) where there is one: ``write_bvh`` syncs
    every file it writes, which on a disk costs more than the rest of a case."""
    shm = "/dev/shm"
    base = shm if os.path.isdir(shm) and os.access(shm, os.W_OK) else None
    with tempfile.TemporaryDirectory(prefix="em-fuzz-", dir=base) as d:
        yield Path(d)


# ------------------------------------------------------------------------------------------
# Peak memory of one case (Linux)
# ------------------------------------------------------------------------------------------


def _status_kb(field: str) -> int:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(field + ":"):
                return int(line.split()[1])
    raise OSError(f"no {field} in /proc/self/status")


def reset_peak_rss() -> int:
    """Reset the peak resident set size to the current one; the current one (kB)."""
    with open("/proc/self/clear_refs", "w") as fh:
        fh.write("5")
    return _status_kb("VmRSS")


def peak_rss_mb(base_kb: int) -> float:
    """Growth of the peak resident set size since :func:`reset_peak_rss` returned ``base_kb``."""
    return (_status_kb("VmHWM") - base_kb) * 1024 / 1e6


def can_measure_rss() -> bool:
    """Whether this system lets :func:`reset_peak_rss` work (Linux ``/proc``)."""
    try:
        reset_peak_rss()
        _status_kb("VmHWM")
        return True
    except OSError:
        return False


# ------------------------------------------------------------------------------------------
# Counting cases
# ------------------------------------------------------------------------------------------


@dataclass
class Tally:
    """Verdicts of a run of cases, with a few examples of each kind that is not plain,
    the slowest case (CPU seconds), the largest (peak MB) and the cases that warned."""

    n_examples: int = 5
    cases: int = 0
    counts: Counter = field(default_factory=Counter)
    examples: dict[str, list[dict]] = field(default_factory=dict)
    slowest: dict | None = None
    largest: dict | None = None
    warned: int = 0

    def add(self, verdict_: str, case: dict) -> None:
        """Count ``case`` (a dict with ``cpu_seconds``, ``peak_mb``, ``detail``, ``warning``...)."""
        self.cases += 1
        self.counts[verdict_] += 1
        if verdict_ not in ("ok", "parse_error"):
            self.examples.setdefault(verdict_, [])
            if len(self.examples[verdict_]) < self.n_examples:
                self.examples[verdict_].append(case)
        if case.get("warning"):
            self.warned += 1
            self.examples.setdefault("warning", [])
            if len(self.examples["warning"]) < self.n_examples:
                self.examples["warning"].append(case)
        if self.slowest is None or case["cpu_seconds"] > self.slowest["cpu_seconds"]:
            self.slowest = case
        if self.largest is None or case.get("peak_mb", 0.0) > self.largest.get("peak_mb", 0.0):
            self.largest = case

    def merge(self, other: Tally) -> None:
        self.cases += other.cases
        self.counts.update(other.counts)
        for k, v in other.examples.items():
            self.examples[k] = (self.examples.get(k, []) + v)[: self.n_examples]
        self.warned += other.warned
        for attr, key in (("slowest", "cpu_seconds"), ("largest", "peak_mb")):
            a, b = getattr(self, attr), getattr(other, attr)
            if a is None or (b is not None and b.get(key, 0.0) > a.get(key, 0.0)):
                setattr(self, attr, b)

    def failures(self) -> dict[str, list[dict]]:
        """Examples of the verdicts that break the contract (:data:`FAILURES`)."""
        return {k: self.examples.get(k, []) for k in FAILURES if self.counts.get(k)}


def measured(rss: bool, run: Callable[..., Outcome], *args) -> tuple[Outcome, dict]:
    """``run(*args)``, one case: its outcome and its measures (``seconds`` wall,
    ``cpu_seconds``, and ``peak_mb``, the growth of the peak resident set, when ``rss``)."""
    base = reset_peak_rss() if rss else 0
    t0, c0 = time.perf_counter(), time.process_time()
    out = run(*args)
    m = {"seconds": round(time.perf_counter() - t0, 4), "cpu_seconds": round(time.process_time() - c0, 4)}
    m["peak_mb"] = round(peak_rss_mb(base), 2) if rss else 0.0
    return out, m
