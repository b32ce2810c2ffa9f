"""The one preparation step: every app and the command line bring motions to common ground here.

Two entry points, both reporting what they did as named results:

* :func:`load_motion` -- one input (a path or a :class:`~elastic_motion.motion.Motion`) on
  its own: read it, drop a T-pose frame 0, trim, fold a static root, express lengths in
  metres, bring it to Y-up. Returns the motion and a :class:`MotionPreparation`.
* :func:`prepare_motions` -- a set of inputs made comparable: each loaded as above, then
  the same joints in the same order, one frame rate, each later motion placed like the
  first, and the shared inner-product weights. Returns :class:`PreparedMotions`.

Conventions
-----------
* **Order of the per-input steps** (each that changes something writes a note: its text in
  ``MotionPreparation.notes``, the :class:`~elastic_motion.notes.Note` with its kind, such as
  :data:`TPOSE_DROPPED`, in ``PreparedMotions.notes``):

  1. read (paths; a ``Motion`` is taken as it is); ``units`` forces the length unit of a
     BVH file (default: guessed from the skeleton's size), ``up`` forces the up axis of any
     input (default: a BVH file's is detected from the motion, :func:`elastic_motion.motion.
     detect_up_axis`; a label that looks wrong or a body lying down under it is warned about);
     a motion with an offset or a position farther than :data:`MAX_EXTENT_M` (1000 km) from
     the origin is refused here, before anything measures it;
  2. drop frame 0 when it is a T-pose (:func:`elastic_motion.motion.has_tpose_first_frame`),
     unless ``drop_tpose=False``;
  3. trim to ``trim = (start, stop)`` seconds, counted from the first frame kept by step 2;
  4. fold a root that is a static reference frame into its child (the Bandai files'
     ``joint_Root``; :func:`elastic_motion.motion.merge_root`);
  5. lengths to metres when the unit is known (:func:`elastic_motion.motion.to_metres`);
  6. rotate to Y-up (:func:`elastic_motion.motion.set_up_axis`): the library's convention
     and the BVH convention of Blender, Maya and MotionBuilder.

* **Set steps** (:func:`prepare_motions`): all or none of the units must be known; joints
  (``"all"``: the same joint set, reordered like the first; ``"common"``: the joints all
  share, refused when that leaves fewer than half of any input's body joints; or a list);
  rest poses: an input whose rest pose differs from the first's by more than 45 degrees on a
  bone (another conversion of the same skeleton) is re-expressed in the first's rest frames,
  the same motion in the world (:mod:`elastic_motion.motion.rest_pose`);
  frame rates resampled to the first motion's; placement (registration-curve style, see
  :func:`elastic_motion.motion.place_like`); the curve joints (all but fingers) and their shared weights.
* **Units of results and of written files**: apps work in metres; a result is written in
  the length unit of the first input (``units_out`` overrides: ``"m"``, ``"cm"``...; see
  :func:`output_motion`). Inputs of unknown unit stay in their own numbers throughout.
* **Errors** name the input and the option: :class:`elastic_motion.errors.OptionError`
  (``trim: 107_02.bvh: expected ...; got ...``), which the command line shows with the flag.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from elastic_motion.errors import OptionError
from elastic_motion.motion import (
    GLTF_EXTENSIONS,
    UNITS,
    Motion,
    Skeleton,
    UpAxisEstimate,
    detect_up_axis,
    finger_joints,
    group_weights,
    has_reference_root,
    has_tpose_first_frame,
    heading_angle,
    merge_root,
    place_like,
    read_motion,
    resample,
    rotation_channel_fit,
    select_frames,
    select_joints,
    set_up_axis,
    to_metres,
    up_axis_warning,
)
from elastic_motion.motion.rest_pose import change_rest_frames, rest_frames_towards, rest_pose_difference
from elastic_motion.notes import Note, note_texts
from elastic_motion.vocabulary import UP_AXES, UpAxis

__all__ = [
    "FACING_DIFFERS",
    "FINGERS_NOT_CURVES",
    "JOINTS_DROPPED",
    "JOINTS_REORDERED",
    "MAX_EXTENT_M",
    "OUTPUT_CHANNELS",
    "OUTPUT_GLTF_METRES",
    "PLACED",
    "RESAMPLED",
    "REST_POSE_CHANGED",
    "STATIC_ROOT_FOLDED",
    "TPOSE_DROPPED",
    "TRIMMED",
    "UNITS_TO_METRES",
    "UNITS_UNKNOWN",
    "UP_AXIS_ROTATED",
    "UP_AXIS_WARNING",
    "MotionPreparation",
    "PrepareOptions",
    "PreparedMotions",
    "closed_joint_set",
    "load_motion",
    "output_motion",
    "output_notes",
    "prepare_motions",
    "rest_pose_like",
    "unit_name",
]

TimeRange = tuple[float | None, float | None]
Source = str | os.PathLike[str] | Motion

#: ``joints="common"`` must keep at least this fraction of each input's body joints.
MIN_COMMON_FRACTION = 0.5

# Kinds of the preparation's notes (:mod:`elastic_motion.notes`). Every note's data holds
# ``input`` (the label of the input it is about; the first input's too as ``like`` for a
# set step that makes an input like the first) and the numbers of its text.
#: Per input: the up axis as read or forced looks wrong (data ``warning``).
UP_AXIS_WARNING = "prepare.up_axis_warning"
#: Per input: frame 0 was a T-pose and was dropped.
TPOSE_DROPPED = "prepare.tpose"
#: Per input: trimmed (data ``start_s``, ``stop_s``, ``frames`` kept).
TRIMMED = "prepare.trim"
#: Per input: a static reference root folded into its child (data ``root``, ``child``).
STATIC_ROOT_FOLDED = "prepare.static_root"
#: Per input: lengths from the file's unit to metres (data ``unit``, ``metres_per_unit``).
UNITS_TO_METRES = "prepare.units"
#: Per input: the length unit is unknown; lengths kept as they are.
UNITS_UNKNOWN = "prepare.units_unknown"
#: Per input: rotated to Y-up (data ``from``, the up axis before).
UP_AXIS_ROTATED = "prepare.up_axis"
#: Set: joints not shared by all inputs dropped from one (data ``joints``).
JOINTS_DROPPED = "prepare.joints"
#: Set: an input's joints put in the first input's order.
JOINTS_REORDERED = "prepare.joint_order"
#: Set: an input re-expressed in the first's rest frames (data ``bone``, ``angle_deg``,
#: ``after_deg``: the largest angle between their bones before and after).
REST_POSE_CHANGED = "prepare.rest_pose"
#: Set: an input resampled to the first's frame rate (data ``from_fps``, ``to_fps``).
RESAMPLED = "prepare.resample"
#: Set: an input placed like the first (data ``how``).
PLACED = "prepare.placement"
#: Set: an input faces otherwise than the first relative to its way of travel (data
#: ``apart_deg``).
FACING_DIFFERS = "prepare.facing"
#: Set: finger joints left out of the curves (data ``joints``).
FINGERS_NOT_CURVES = "prepare.finger_joints"
#: Output: joints whose rotation channels cannot hold the result's rotations, written as the
#: nearest ones they hold (data ``joints``: name -> largest angle between them, degrees).
OUTPUT_CHANNELS = "prepare.output_channels"
#: Output: a glTF file is written in metres, the format's unit, where a BVH would have been
#: written in the output unit (data ``unit_m``: that unit's size in metres).
OUTPUT_GLTF_METRES = "prepare.output_gltf_metres"


# ------------------------------------------------------------------------------------------
# Options and reports
# ------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class PrepareOptions:
    """How to prepare inputs (module docstring for the order of the steps).

    Attributes
    ----------
    drop_tpose : bool, default True
        Drop frame 0 when it is a T-pose.
    units : str or None, default None
        Length unit of BVH inputs (a key of :data:`elastic_motion.motion.UNITS`: ``m``,
        ``cm``, ``mm``, ``inch``, ``cmu``); default: guessed from the skeleton.
    up : {"x", "y", "z"} or None, default None
        Up axis of the inputs (:data:`elastic_motion.vocabulary.UpAxis`); default: as read
        (the reader's detection or convention).
    trim : tuple, default ()
        ``()`` keeps whole clips; one ``(start, stop)`` range in seconds (either may be
        None) for every input; or one range (or None) per input.
    fold_static_root : bool, default True
        Fold a static reference root into its child (Bandai files).
    joints : "all", "common" or tuple of str, default "all"
        Joint selection of :func:`prepare_motions`.
    align : bool, default True
        Place each later motion like the first (:func:`elastic_motion.motion.place_like`).
    units_out : str or None, default None
        Length unit of written results (a key of ``UNITS``); default: the first input's unit
        (inputs of unknown unit are written in their own numbers).
    check_up_axis : bool, default True
        Warn (a note starting with ``warning:``) when the up axis as read or forced looks
        wrong or the body lies down under it (:func:`elastic_motion.motion.up_axis_warning`).
    """

    drop_tpose: bool = True
    units: str | None = None
    up: UpAxis | None = None
    trim: tuple[Any, ...] = ()
    fold_static_root: bool = True
    joints: str | tuple[str, ...] = "all"
    align: bool = True
    units_out: str | None = None
    check_up_axis: bool = True

    def __post_init__(self) -> None:
        if self.units is not None and self.units not in UNITS:
            raise OptionError("units", f"expected one of {sorted(UNITS)}; got {self.units!r}")
        if self.units_out is not None and self.units_out not in UNITS:
            raise OptionError("units_out", f"expected one of {sorted(UNITS)}; got {self.units_out!r}")
        if self.up is not None and self.up not in UP_AXES:
            raise OptionError("up", f"expected one of {', '.join(UP_AXES)}; got {self.up!r}")
        joints = self.joints
        if isinstance(joints, str):
            if joints not in ("all", "common"):
                raise OptionError("joints", f"expected 'all', 'common' or joint names; got {joints!r}")
        else:
            names = tuple(str(n) for n in joints)
            if not names:
                raise OptionError("joints", "expected 'all', 'common' or at least one joint name; got none")
            object.__setattr__(self, "joints", names)
        object.__setattr__(self, "trim", _normalise_trim(self.trim))

    def trim_for(self, k: int, n_inputs: int) -> TimeRange | None:
        """The trim range of input ``k`` of ``n_inputs``."""
        if not self.trim:
            return None
        if _is_range(self.trim):
            return self.trim  # type: ignore[return-value]
        if len(self.trim) == 1:
            return self.trim[0]
        if len(self.trim) != n_inputs:
            raise OptionError(
                "trim",
                f"expected one range for all inputs or one per input ({n_inputs}); got {len(self.trim)}",
            )
        return self.trim[k]

    def replace(self, **changes: Any) -> PrepareOptions:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)


def _is_range(x: Any) -> bool:
    return (
        isinstance(x, tuple)
        and len(x) == 2
        and all(v is None or isinstance(v, int | float | np.floating | np.integer) for v in x)
    )


def _normalise_trim(trim: Any) -> tuple[Any, ...]:
    if trim is None:
        return ()
    trim = tuple(trim)
    if not trim:
        return ()
    if _is_range(trim):
        return _check_range(trim)
    out = []
    for item in trim:
        if item is None:
            out.append(None)
            continue
        item = tuple(item)
        if not _is_range(item):
            raise OptionError("trim", f"expected (start, stop) in seconds, or None; got {item!r}")
        out.append(_check_range(item))
    return tuple(out)


def _check_range(r: tuple[Any, Any]) -> TimeRange:
    start, stop = (None if v is None else float(v) for v in r)
    for v in (start, stop):
        if v is not None and not math.isfinite(v):
            raise OptionError("trim", f"expected finite times in seconds; got {start}:{stop}")
    if start is not None and stop is not None and not start < stop:
        raise OptionError("trim", f"expected START < STOP in seconds; got {start:g}:{stop:g}")
    return (start, stop)


@dataclass(frozen=True)
class MotionPreparation:
    """What :func:`load_motion` did to one input.

    Attributes
    ----------
    label : str
        The input's name in messages (file stem or ``Motion.name``).
    source : str or None
        The file read (None for a ``Motion`` given directly).
    frames_read, frames_kept : int
        Frame counts before and after steps 2-3.
    fps : float
        Frame rate (unchanged here).
    tpose_dropped : bool
    trim_s : tuple of (float or None) or None
        The trim range applied, seconds.
    unit_in : str or None
        The input's length unit (``"cm"``, ``"cmu"``, ``"0.01 m"``...), None when unknown.
    metres_per_unit_in : float or None
    up_axis_in : str
        The up axis as read (or forced).
    static_root_folded : str or None
        Name of the folded root joint.
    notes : tuple of Note
        One per step that changed something (also in :attr:`PreparedMotions.notes`, which lists
        them first).
    """

    label: str
    source: str | None
    frames_read: int
    frames_kept: int
    fps: float
    tpose_dropped: bool
    trim_s: TimeRange | None
    unit_in: str | None
    metres_per_unit_in: float | None
    up_axis_in: str
    static_root_folded: str | None
    notes: tuple[Note, ...] = ()

    def summary(self) -> dict[str, Any]:
        """JSON-ready: every field, the notes as their texts (what reports list)."""
        out = dataclasses.asdict(self)
        out["notes"] = note_texts(self.notes)
        return out


@dataclass(frozen=True, eq=False)
class PreparedMotions:
    """Motions brought to common ground (:func:`prepare_motions`).

    Attributes
    ----------
    motions : tuple of Motion
        Same joints in the same order, same frame rate, Y-up, metres when known; each later
        motion placed like the first.
    labels : tuple of str
        Names of the motions.
    curve_joints : tuple of str
        Joints carried by the curves (all but finger joints).
    joint_weights : ndarray, shape (len(curve_joints),)
        Lie inner-product weights of the curve joints, shared by all motions.
    translation_weight : float
        Lie inner-product weight of the root translation (1 / m^2 when units are known).
    notes : tuple of Note
        What was done (per-input steps first), kinds :data:`UP_AXIS_WARNING`,
        :data:`TPOSE_DROPPED`, :data:`TRIMMED`, :data:`STATIC_ROOT_FOLDED`,
        :data:`UNITS_TO_METRES`, :data:`UNITS_UNKNOWN`, :data:`UP_AXIS_ROTATED`, then
        :data:`JOINTS_DROPPED`, :data:`JOINTS_REORDERED`, :data:`REST_POSE_CHANGED`,
        :data:`RESAMPLED`, :data:`PLACED`, :data:`FACING_DIFFERS`, :data:`FINGERS_NOT_CURVES`;
        ``str(note)`` is the sentence.
    inputs : tuple of MotionPreparation
        The per-input reports.
    units_out : float or None
        Metres per unit of written results (:func:`output_motion`); None: as they are.
    """

    motions: tuple[Motion, ...]
    labels: tuple[str, ...]
    curve_joints: tuple[str, ...]
    joint_weights: np.ndarray
    translation_weight: float
    notes: tuple[Note, ...] = field(default=())
    inputs: tuple[MotionPreparation, ...] = field(default=())
    units_out: float | None = None

    @property
    def fps(self) -> float:
        """The common frame rate."""
        return self.motions[0].fps

    @property
    def extra_joints(self) -> tuple[str, ...]:
        """Joints not carried by the curves (finger joints)."""
        keep = set(self.curve_joints)
        return tuple(n for n in self.motions[0].skeleton.names if n not in keep)

    def curve_motion(self, k: int) -> Motion:
        """Motion ``k`` restricted to the curve joints."""
        m = self.motions[k]
        if len(self.curve_joints) == m.n_joints:
            return m
        return select_joints(m, self.curve_joints)

    def with_notes(self, *notes: Note) -> PreparedMotions:
        """A copy with more notes (an app's own, e.g. the landmark plan of an alignment)."""
        return replace(self, notes=(*self.notes, *notes))


def unit_name(metres_per_unit: float | None) -> str | None:
    """``0.01`` -> ``"cm"``; an unnamed size -> ``"0.0123 m"``; None -> None."""
    if metres_per_unit is None:
        return None
    for name, size in UNITS.items():
        if math.isclose(size, metres_per_unit, rel_tol=1e-6):
            return name
    return f"{metres_per_unit:.6g} m"


# ------------------------------------------------------------------------------------------
# One input
# ------------------------------------------------------------------------------------------


def _label_of(source: Source, label: str | None, k: int | None = None) -> str:
    if label is not None:
        return str(label)
    if isinstance(source, Motion):
        return source.name or (f"motion {k}" if k is not None else "motion")
    return Path(source).stem


def _read(
    source: Source, options: PrepareOptions, name: str
) -> tuple[Motion, str | None, UpAxisEstimate | None]:
    """The motion, its path (None for a Motion) and, for a BVH file labelled by detection,
    the up-axis estimate that labelled it (computed once, reused by the check); a motion
    beyond :data:`MAX_EXTENT_M` refused before anything measures it."""
    if isinstance(source, Motion):
        _check_extent(source, name)
        m = source
        if options.up is not None and m.up_axis != options.up:
            m = m.replace(up_axis=options.up)
        return m, None, None
    if not isinstance(source, str | os.PathLike):
        raise OptionError("motions", f"expected a path or a Motion; got {type(source).__name__}")
    path = Path(source)
    if not path.exists():
        raise OptionError("motions", f"{os.fspath(source)}: no such file")
    if path.is_dir():
        raise OptionError("motions", f"{os.fspath(source)}: expected a motion file; got a folder")
    kw: dict[str, Any] = {}
    ext = path.suffix.lower()
    estimate = None
    if ext == ".bvh":
        if options.units is not None:
            kw["units"] = options.units
        # the up axis given, or detected here as read_bvh would (once: the check reuses it)
        kw["up_axis"] = options.up or "y"
    m = read_motion(path, **kw)
    _check_extent(m, name)
    if ext == ".bvh" and options.up is None:
        estimate = detect_up_axis(m)
        if estimate.up_axis != m.up_axis:
            m = m.replace(up_axis=estimate.up_axis)
    if ext != ".bvh" and options.up is not None and m.up_axis != options.up:
        m = m.replace(up_axis=options.up)
    return m.replace(name=m.name or path.stem), os.fspath(source), estimate


def load_motion(
    source: Source,
    options: PrepareOptions | None = None,
    *,
    label: str | None = None,
    trim: TimeRange | None = None,
) -> tuple[Motion, MotionPreparation]:
    """Read one input and apply the per-input steps (module docstring).

    Parameters
    ----------
    source : path or Motion
        A ``.bvh``, ``.amc`` (its ``.asf`` found beside it) or DeepMimic file, or a Motion.
    options : PrepareOptions, optional
        Default ``PrepareOptions()``. ``options.trim`` is not used here (it is per set);
        pass ``trim``.
    label : str, optional
        Name in messages (default: file stem or ``Motion.name``).
    trim : (start, stop), optional
        Seconds from the first frame kept after the T-pose step.

    Returns
    -------
    motion : Motion
        Metres when the unit is known, Y-up, named ``label``.
    report : MotionPreparation

    Raises
    ------
    OptionError
        Missing file, a trim range holding no frame, fewer than 3 frames left, an offset or
        a position beyond :data:`MAX_EXTENT_M`.
    ParseError
        A malformed file (from the reader).
    """
    m, report, _ = _load(source, options or PrepareOptions(), label, trim)
    return m, report


def _load(
    source: Source, opts: PrepareOptions, label: str | None, trim: TimeRange | None
) -> tuple[Motion, MotionPreparation, list[Note]]:
    """:func:`load_motion`, with the notes of its steps."""
    name = _label_of(source, label)
    m, path, estimate = _read(source, opts, name)  # 1. read
    notes: list[Note] = []
    if opts.check_up_axis:
        _check_up_axis(m, name, estimate, notes)
    frames_read, mpu_in, up_in = m.n_frames, m.metres_per_unit, m.up_axis
    dropped = bool(opts.drop_tpose and has_tpose_first_frame(m))  # 2. T-pose
    if dropped:
        m = _drop_tpose(m, name, notes)
    rng = _check_range(tuple(trim)) if trim is not None else None  # 3. trim
    if rng is not None and rng != (None, None):
        m = _trim_step(m, rng, name, notes)
    if m.n_frames < 3:
        raise OptionError(
            "motions", f"{name}: expected at least 3 frames after preparation; got {m.n_frames}"
        )
    folded = None  # 4. static root
    if opts.fold_static_root and has_reference_root(m):
        folded = m.skeleton.names[0]
        m = _fold_static_root(m, name, notes)
    m = _to_metres(m, name, notes)  # 5. units
    m = _to_y_up(m, name, notes).replace(name=name)  # 6. up axis
    report = MotionPreparation(
        label=name,
        source=path,
        frames_read=frames_read,
        frames_kept=m.n_frames,
        fps=m.fps,
        tpose_dropped=dropped,
        trim_s=rng,
        unit_in=unit_name(mpu_in),
        metres_per_unit_in=mpu_in,
        up_axis_in=up_in,
        static_root_folded=folded,
        # texts while apps serialise reports with dataclasses.asdict; summary() lists texts
        notes=tuple(notes),
    )
    return m, report, notes


#: The farthest a joint offset or a position may be from the origin (metres; the file's own
#: unit when unknown): a thousand kilometres is no capture volume, and numbers far beyond it
#: overflow the squares of the distances and velocities every command measures (a root at
#: 1e300 made a loop's seam ratios NaN).
MAX_EXTENT_M = 1e6


def _check_extent(m: Motion, name: str) -> None:
    """Refuse a motion with an offset, root position or joint translation beyond
    :data:`MAX_EXTENT_M` (an OptionError naming the input, what and where)."""
    sk = m.skeleton
    ends = [f"{sk.names[p]} end site" for p in sk.end_site_parents]
    parts = [  # what, (frames, points, 3), the points' names, whether per frame
        ("a joint offset", sk.offsets[None], sk.names, False),
        ("an end site offset", sk.end_site_offsets[None], ends, False),
        ("the root position", m.root_translation[:, None], [sk.names[0]], True),
    ]
    if m.joint_translations is not None:
        parts.append(("a joint translation", m.joint_translations, sk.names, True))
    scale = m.metres_per_unit or 1.0
    unit = "m" if m.metres_per_unit is not None else "units"
    for what, raw, names, per_frame in parts:
        a = np.abs(raw)
        big = a.max(axis=-1) > MAX_EXTENT_M / scale
        if big.any():
            f, k = np.argwhere(big)[0]
            at = f"{names[k]}, frame {f}" if per_frame else names[k]
            raise OptionError(
                "motions",
                f"{name}: expected offsets and positions within {MAX_EXTENT_M:g} {unit} of the origin; "
                f"got {what} {float(a[f, k].max()) * scale:.3g} {unit} away ({at})",
            )


def _check_up_axis(m: Motion, name: str, estimate: UpAxisEstimate | None, notes: list[Note]) -> None:
    """Step 1's check: a note when the up axis as read or forced looks wrong."""
    # BVH files are labelled by detection when read; a label given by the user (--up, a
    # Motion built in code) or a format without detection is checked here
    warning = up_axis_warning(m.replace(name=name), estimate=estimate)
    if warning:
        notes.append(Note(UP_AXIS_WARNING, f"warning: {warning}", {"input": name, "warning": warning}))


def _drop_tpose(m: Motion, name: str, notes: list[Note]) -> Motion:
    """Step 2: ``m`` without its frame 0 (a T-pose), with its note."""
    notes.append(Note(TPOSE_DROPPED, f"{name}: dropped frame 0 (a T-pose)", {"input": name}))
    return select_frames(m, slice(1, None))


def _trim_step(m: Motion, rng: TimeRange, name: str, notes: list[Note]) -> Motion:
    """Step 3: ``m`` trimmed to ``rng`` (seconds), with its note."""
    end = m.duration  # the clip's own end, for an open range (the trimmed clip is shorter)
    m = _trim(m, rng, name)
    start_s = rng[0] if rng[0] is not None else 0
    stop_s = rng[1] if rng[1] is not None else end
    notes.append(
        Note(
            TRIMMED,
            f"{name}: kept {start_s:g}-{stop_s:g} s ({m.n_frames} frames)",
            {"input": name, "start_s": start_s, "stop_s": stop_s, "frames": m.n_frames},
        )
    )
    return m


def _fold_static_root(m: Motion, name: str, notes: list[Note]) -> Motion:
    """Step 4: ``m``'s static reference root folded into its child, with its note."""
    folded = m.skeleton.names[0]
    m = merge_root(m)
    notes.append(
        Note(
            STATIC_ROOT_FOLDED,
            f"{name}: folded the static root {folded!r} into its child {m.skeleton.names[0]!r}",
            {"input": name, "root": folded, "child": m.skeleton.names[0]},
        )
    )
    return m


def _to_metres(m: Motion, name: str, notes: list[Note]) -> Motion:
    """Step 5: lengths in metres when the unit is known (a note either way but for metres)."""
    if m.metres_per_unit is not None:
        if m.metres_per_unit != 1.0:
            unit = unit_name(m.metres_per_unit)
            notes.append(
                Note(
                    UNITS_TO_METRES,
                    f"{name}: lengths from {unit} to metres",
                    {"input": name, "unit": unit, "metres_per_unit": m.metres_per_unit},
                )
            )
        m = to_metres(m)
    else:
        notes.append(
            Note(UNITS_UNKNOWN, f"{name}: length unit unknown; lengths kept as in the file", {"input": name})
        )
    return m


def _to_y_up(m: Motion, name: str, notes: list[Note]) -> Motion:
    """Step 6: ``m`` rotated to Y-up, with its note."""
    if m.up_axis != "y":
        notes.append(
            Note(
                UP_AXIS_ROTATED,
                f"{name}: rotated from {m.up_axis}-up to y-up",
                {"input": name, "from": m.up_axis},
            )
        )
        m = set_up_axis(m, "y")
    return m


def _trim(m: Motion, rng: TimeRange, name: str) -> Motion:
    start, stop = rng
    d = m.duration
    lo = 0.0 if start is None else start
    hi = d if stop is None else stop
    if lo < -1e-9 or lo > d + 1e-9:
        raise OptionError(
            "trim", f"{name}: expected START within the clip's 0-{d:.4g} s; got {_fmt_range(rng)}"
        )
    t = m.times
    keep = (t >= lo - 1e-9) & (t <= hi + 1e-9)
    if keep.sum() < 3:
        raise OptionError(
            "trim",
            f"{name}: expected a range holding at least 3 frames of the clip's 0-{d:.4g} s; "
            f"got {_fmt_range(rng)} ({int(keep.sum())} frames)",
        )
    return select_frames(m, keep)


def _fmt_range(rng: TimeRange) -> str:
    a, b = rng
    return f"{'' if a is None else f'{a:g}'}:{'' if b is None else f'{b:g}'}"


# ------------------------------------------------------------------------------------------
# Joints
# ------------------------------------------------------------------------------------------


def closed_joint_set(skeleton: Skeleton, names: Sequence[str] | set[str]) -> list[str]:
    """Names of ``skeleton`` in ``names`` whose whole chain to the root is in ``names`` too,
    in skeleton order (a valid sub-skeleton: a joint whose parent is missing is dropped with
    its subtree)."""
    wanted = set(names)
    keep = np.zeros(skeleton.n_joints, dtype=bool)
    for j, n in enumerate(skeleton.names):
        keep[j] = n in wanted and (j == 0 or keep[skeleton.parents[j]])
    return [n for j, n in enumerate(skeleton.names) if keep[j]]


def _parent_names(m: Motion) -> dict[str, str | None]:
    sk = m.skeleton
    return {n: (sk.names[p] if p >= 0 else None) for n, p in zip(sk.names, sk.parents, strict=True)}


def _reorder(m: Motion, order: Sequence[str]) -> Motion:
    """Same joints in ``order`` (which must list parents before children)."""
    sk = m.skeleton
    if tuple(order) == sk.names:
        return m
    idx = np.array([sk.index(n) for n in order])
    pos = {n: i for i, n in enumerate(order)}
    parents = [-1] + [pos[sk.names[sk.parents[j]]] for j in idx[1:]]
    new_sk = Skeleton(
        names=list(order),
        parents=parents,
        offsets=sk.offsets[idx],
        channels=[sk.channels[j] for j in idx],
        end_site_parents=[pos[sk.names[p]] for p in sk.end_site_parents],
        end_site_offsets=sk.end_site_offsets,
    )
    jt = m.joint_translations
    return m.replace(
        skeleton=new_sk, rotations=m.rotations[:, idx], joint_translations=None if jt is None else jt[:, idx]
    )


def _describe_difference(a: Motion, b: Motion, la: str, lb: str) -> str:
    na, nb = set(a.skeleton.names), set(b.skeleton.names)
    only_a = [n for n in a.skeleton.names if n not in nb]
    only_b = [n for n in b.skeleton.names if n not in na]
    parts = []
    if only_a:
        parts.append(f"only in {la}: {only_a}")
    if only_b:
        parts.append(f"only in {lb}: {only_b}")
    if not parts:
        pa, pb = _parent_names(a), _parent_names(b)
        parts.append(f"joints with different parents: {[n for n in a.skeleton.names if pa[n] != pb[n]]}")
    return "; ".join(parts)


def _select_joints(
    ms: list[Motion], labels: list[str], joints: str | tuple[str, ...]
) -> tuple[list[Motion], list[Note]]:
    """Set step: the same joint set in every input (``joints`` of :class:`PrepareOptions`)."""
    if joints == "all":
        _check_same_skeleton(ms, labels)
        return ms, []
    if joints == "common":
        wanted = set(ms[0].skeleton.names)
        for m in ms[1:]:
            wanted &= set(m.skeleton.names)
    else:
        wanted = set(joints)
        for m, lab in zip(ms, labels, strict=True):
            missing = sorted(wanted - set(m.skeleton.names))
            if missing:
                raise OptionError("joints", f"{lab}: expected joints named {missing}; it has none of them")
    keep = closed_joint_set(ms[0].skeleton, wanted)
    if not keep:
        raise OptionError(
            "joints",
            f"expected inputs sharing the joints from the root on; the roots are "
            f"{[m.skeleton.names[0] for m in ms]}",
        )
    if joints == "common":
        _check_enough_joints(ms, labels, keep, wanted)
    notes: list[Note] = []
    for k, m in enumerate(ms):
        dropped = [n for n in m.skeleton.names if n not in keep]
        if dropped:
            notes.append(
                Note(
                    JOINTS_DROPPED,
                    f"{labels[k]}: dropped {len(dropped)} joints not shared by all inputs: {dropped}",
                    {"input": labels[k], "joints": dropped},
                )
            )
            ms[k] = select_joints(m, [n for n in m.skeleton.names if n in keep])
    pa = _parent_names(ms[0])
    for k in range(1, len(ms)):
        if set(ms[k].skeleton.names) != set(keep) or _parent_names(ms[k]) != pa:
            raise OptionError(
                "joints",
                f"expected the shared joints to form one skeleton; {labels[0]} and {labels[k]} still differ "
                f"({_describe_difference(ms[0], ms[k], labels[0], labels[k])})",
            )
    return ms, notes


def _check_same_skeleton(ms: list[Motion], labels: list[str]) -> None:
    """``joints="all"``: every input has the first's joints with the same parents."""
    names0, pa = set(ms[0].skeleton.names), _parent_names(ms[0])
    for k in range(1, len(ms)):
        if set(ms[k].skeleton.names) != names0 or _parent_names(ms[k]) != pa:
            shared = closed_joint_set(ms[0].skeleton, names0 & set(ms[k].skeleton.names))
            hint = (
                "joints='common' (CLI: --joints common) keeps the shared joints"
                if len(shared) >= MIN_COMMON_FRACTION * min(len(names0), ms[k].n_joints)
                else f"they share {len(shared)} joints from the root on: the skeletons name their "
                "joints differently (a CMU ASF file and a BVH conversion of it do); rename the joints "
                "of one to the other's names"
            )
            raise OptionError(
                "joints",
                f"expected the same skeleton in every input; {labels[0]} and {labels[k]} differ "
                f"({_describe_difference(ms[0], ms[k], labels[0], labels[k])}); {hint}",
            )


def _check_enough_joints(ms: list[Motion], labels: list[str], keep: list[str], shared: set[str]) -> None:
    """Refuse a common skeleton that keeps too little of a body to mean anything."""
    short = []
    for m, lab in zip(ms, labels, strict=True):
        fingers = set(finger_joints(m.skeleton))
        body = [n for n in m.skeleton.names if n not in fingers]
        kept = [n for n in keep if n not in fingers]
        if len(kept) < MIN_COMMON_FRACTION * len(body):
            short.append(f"{lab} keeps {len(kept)} of its {len(body)} body joints")
    if short:
        unreachable = sorted(shared - set(keep))
        raise OptionError(
            "joints",
            "expected the common joints to hold at least half of each input's body (a blend or distance "
            f"of a few joints is not a body); got {len(keep)} shared joints connected to the root {keep}"
            + (f" (also shared by name but cut off from the root: {unreachable})" if unreachable else "")
            + f": {'; '.join(short)}. The skeletons use different joint names; give joint names "
            "explicitly or convert one skeleton",
        )


# ------------------------------------------------------------------------------------------
# A set of inputs
# ------------------------------------------------------------------------------------------


def prepare_motions(
    sources: Sequence[Source],
    options: PrepareOptions | None = None,
    *,
    labels: Sequence[str] | None = None,
) -> PreparedMotions:
    """Load inputs and make them comparable: units, up axis, joints, frame rate, placement.

    Parameters
    ----------
    sources : sequence of path or Motion, or PreparedMotions
        At least one. Motions already prepared (a ``PreparedMotions``) are returned as they
        are, so an app can take the result of this function in place of its inputs.
    options : PrepareOptions, optional
        Default ``PrepareOptions()``.
    labels : sequence of str, optional
        Names used in messages and reports (default: file stems or ``Motion.name``).

    Returns
    -------
    PreparedMotions

    Raises
    ------
    OptionError
        Joint sets that differ (naming the joints), too few common joints, units known for
        some inputs only, a bad trim range, missing files.
    ParseError
        A malformed file.
    """
    if isinstance(sources, PreparedMotions):
        if options is not None:
            raise OptionError("prepare", "expected no options for motions that are already prepared")
        return sources
    opts = options or PrepareOptions()
    sources = list(sources)
    names = _input_labels(sources, labels)
    # per input: read, T-pose, trim, static root, units, up axis (load_motion's steps)
    ms, reports, notes = _load_each(sources, names, opts)
    _check_units_known(reports, names)
    # together: joints, rest pose, frame rate, placement, the curves' joints and weights
    ms, more = _select_joints(ms, names, opts.joints)
    notes += more
    for step in (_same_joint_order, _same_rest_pose, _same_frame_rate):
        ms, more = step(ms, names)
        notes += more
    if opts.align:
        ms, more = _placed_like_first(ms, names)
        notes += more
    notes += _facing_notes(ms, names)
    curve_joints, jw, tw, more = _curve_weights(ms)
    notes += more
    return PreparedMotions(
        motions=tuple(ms),
        labels=tuple(names),
        curve_joints=curve_joints,
        joint_weights=np.asarray(jw),
        translation_weight=float(tw),
        notes=tuple(notes),
        inputs=tuple(reports),
        units_out=UNITS[opts.units_out] if opts.units_out is not None else reports[0].metres_per_unit_in,
    )


def _input_labels(sources: list[Source], labels: Sequence[str] | None) -> list[str]:
    """The inputs' names (``labels``, or file stems and ``Motion.name``)."""
    if not sources:
        raise OptionError("motions", "expected at least one motion; got none")
    if labels is not None and len(labels) != len(sources):
        raise OptionError("labels", f"expected {len(sources)} labels; got {len(labels)}")
    return [_label_of(s, None if labels is None else labels[k], k) for k, s in enumerate(sources)]


def _load_each(
    sources: list[Source], names: list[str], opts: PrepareOptions
) -> tuple[list[Motion], list[MotionPreparation], list[Note]]:
    """Per-input steps (:func:`load_motion`) of every input: motions, reports, notes."""
    ms: list[Motion] = []
    reports: list[MotionPreparation] = []
    notes: list[Note] = []
    for k, src in enumerate(sources):
        m, rep, more = _load(src, opts, names[k], opts.trim_for(k, len(sources)))
        _check_finite(m, names[k])
        ms.append(m)
        reports.append(rep)
        notes += more
    return ms, reports, notes


def _check_units_known(reports: list[MotionPreparation], names: list[str]) -> None:
    """All or none of the inputs' length units must be known."""
    known = [r.metres_per_unit_in is not None for r in reports]
    if any(known) and not all(known):
        unknown = [lab for lab, kn in zip(names, known, strict=True) if not kn]
        raise OptionError(
            "units",
            f"expected the length unit of every input; unknown for {unknown} (give it: --units on the "
            "command line, units= in Python)",
        )


def _same_joint_order(ms: list[Motion], names: list[str]) -> tuple[list[Motion], list[Note]]:
    """Set step: every input's joints in the first's order."""
    notes: list[Note] = []
    order = ms[0].skeleton.names
    for k in range(1, len(ms)):
        if ms[k].skeleton.names != order:
            ms[k] = _reorder(ms[k], order)
            notes.append(
                Note(
                    JOINTS_REORDERED,
                    f"{names[k]}: joints reordered like {names[0]}",
                    {"input": names[k], "like": names[0]},
                )
            )
    return ms, notes


def _same_rest_pose(ms: list[Motion], names: list[str]) -> tuple[list[Motion], list[Note]]:
    """Set step: every input in the first's rest frames when their rest poses differ
    (:func:`rest_pose_like`)."""
    notes: list[Note] = []
    for k in range(1, len(ms)):
        ms[k], note = _rest_pose_note(ms[0].skeleton, ms[k], names[0], names[k])
        if note is not None:
            notes.append(note)
    return ms, notes


def _same_frame_rate(ms: list[Motion], names: list[str]) -> tuple[list[Motion], list[Note]]:
    """Set step: every input resampled to the first's frame rate."""
    notes: list[Note] = []
    fps = ms[0].fps
    for k in range(1, len(ms)):
        if not math.isclose(ms[k].fps, fps, rel_tol=1e-9):
            notes.append(
                Note(
                    RESAMPLED,
                    f"{names[k]}: resampled from {ms[k].fps:g} to {fps:g} fps (the rate of {names[0]})",
                    {"input": names[k], "like": names[0], "from_fps": ms[k].fps, "to_fps": fps},
                )
            )
            ms[k] = resample(ms[k], fps)
            if ms[k].n_frames < 3:
                raise OptionError("motions", f"{names[k]}: expected at least 3 frames at {fps:g} fps")
    return ms, notes


def _placed_like_first(ms: list[Motion], names: list[str]) -> tuple[list[Motion], list[Note]]:
    """Set step: every later input placed like the first (:func:`elastic_motion.motion.place_like`)."""
    notes: list[Note] = []
    for k in range(1, len(ms)):
        ms[k], how = place_like(ms[0], ms[k])
        notes.append(
            Note(
                PLACED,
                f"{names[k]}: placed like {names[0]} ({how})",
                {"input": names[k], "like": names[0], "how": how},
            )
        )
    return ms, notes


def _facing_notes(ms: list[Motion], names: list[str]) -> list[Note]:
    """Notes on inputs that face otherwise than the first relative to their way of travel."""
    notes: list[Note] = []
    facing = [_facing_from_travel(m) for m in ms]
    for k in range(1, len(ms)):
        if facing[0] is not None and facing[k] is not None:
            apart = abs(math.degrees(math.remainder(facing[k] - facing[0], 2 * math.pi)))
            if apart > _FACING_APART:
                notes.append(
                    Note(
                        FACING_DIFFERS,
                        f"{names[k]}: faces {apart:.0f} deg away from its way of travel compared with "
                        f"{names[0]} (one walks backwards or sideways?): a blend or a distance of the two "
                        "mixes the facings",
                        {"input": names[k], "like": names[0], "apart_deg": apart},
                    )
                )
    return notes


def _curve_weights(ms: list[Motion]) -> tuple[tuple[str, ...], np.ndarray, float, list[Note]]:
    """The curve joints (all but fingers), their shared Lie weights and the root translation's
    (:func:`elastic_motion.motion.group_weights`), and a note naming the finger joints."""
    fingers = set(finger_joints(ms[0].skeleton))
    curve_joints = tuple(n for n in ms[0].skeleton.names if n not in fingers)
    body = [select_joints(m, curve_joints) if fingers else m for m in ms]
    jw, tw = group_weights(body)
    notes: list[Note] = []
    if fingers:
        notes.append(
            Note(
                FINGERS_NOT_CURVES,
                "finger joints not part of the curves (a blend interpolates them frame by frame): "
                f"{sorted(fingers)}",
                {"joints": sorted(fingers)},
            )
        )
    return curve_joints, jw, tw, notes


#: Two inputs whose rest poses differ by more than this (degrees, on a bone of at least
#: :data:`_REST_BONE` metres) are not in the same rest frames: the same local rotation means
#: another pose. Files of one conversion differ by at most 26 degrees (CMU 107_02_30hz and
#: 108_01_30hz at the head: the subjects' proportions); 107_02_30hz and 07_01 (two
#: conversions) by 160 at the feet.
_REST_POSE_TOLERANCE = 45.0
#: Bones shorter than this (metres; 1.5 % of the summed bone lengths when the unit is
#: unknown) have no reliable direction (CMU's LHipJoint is a few micrometres long).
_REST_BONE = 0.05


def rest_pose_like(reference: Skeleton, m: Motion, label0: str, label: str) -> tuple[Motion, list[str]]:
    """``m`` re-expressed in ``reference``'s rest frames when their rest poses differ by more
    than :data:`_REST_POSE_TOLERANCE` (:mod:`elastic_motion.motion.rest_pose`: the same motion
    in the world), with a note naming both (``label0``: the reference's owner); ``m`` itself
    and no note otherwise. Both skeletons hold the same joints (prepared together, or of one
    skeleton group of a database). The note is its text (the database stores texts); its
    kind is :data:`REST_POSE_CHANGED`."""
    out, note = _rest_pose_note(reference, m, label0, label)
    return out, [] if note is None else [str(note)]


def _rest_pose_note(reference: Skeleton, m: Motion, label0: str, label: str) -> tuple[Motion, Note | None]:
    """:func:`rest_pose_like` with its note (kind :data:`REST_POSE_CHANGED`) or None."""
    if m.metres_per_unit is not None:
        shortest = _REST_BONE / m.metres_per_unit
    else:
        shortest = 0.015 * float(np.linalg.norm(m.skeleton.offsets, axis=1).sum())
    angle, bone = rest_pose_difference(reference, m.skeleton, min_length=shortest)
    if angle <= _REST_POSE_TOLERANCE:
        return m, None
    # the joints are the first's (selected and ordered before): every one has a frame there
    out = change_rest_frames(m, rest_frames_towards(m.skeleton, reference, min_length=shortest))
    after, _ = rest_pose_difference(reference, out.skeleton, min_length=shortest)
    return out, Note(
        REST_POSE_CHANGED,
        f"{label}: rest pose unlike {label0}'s (bone {bone} {angle:.0f} deg apart, another conversion): its "
        f"rotations re-expressed in {label0}'s rest frames, the same motion in the world (bones now within "
        f"{after:.0f} deg)",
        {"input": label, "like": label0, "bone": bone, "angle_deg": float(angle), "after_deg": float(after)},
    )


#: Two inputs that face more than this (degrees) differently relative to their own way of
#: travel (a walk forwards and one backwards: 180) get a note; a blend of them faces between
#: (a forward walk with a walk back blended into a crab walk, 50 degrees off its path).
_FACING_APART = 90.0
#: Frames moving slower than this (m/s, floor plane) have no way of travel.
_TRAVEL_SPEED = 0.2


def _facing_from_travel(m: Motion) -> float | None:
    """The circular mean (radians) of the root's heading minus its direction of travel over
    the frames it moves (:data:`_TRAVEL_SPEED`); None for a clip that barely travels."""
    up = "xyz".index(m.up_axis)
    p, q = (up + 1) % 3, (up + 2) % 3
    step = np.diff(m.root_translation, axis=0)
    speed = np.hypot(step[:, p], step[:, q]) * m.fps * (m.metres_per_unit or 1.0)
    moving = speed > _TRAVEL_SPEED
    if moving.sum() < 3:
        return None
    travel = np.arctan2(step[moving, q], step[moving, p])
    head = heading_angle(m.rotations[1:, 0][moving], up)
    d = head - travel
    return float(np.arctan2(np.sin(d).mean(), np.cos(d).mean()))


def _check_finite(m: Motion, name: str) -> None:
    for arr, what in ((m.rotations, "rotations"), (m.root_translation, "root_translation")):
        bad = ~np.isfinite(arr)
        if bad.any():
            idx = tuple(int(i) for i in np.argwhere(bad)[0])
            raise OptionError(
                "motions",
                f"{name}.{what}: expected finite values; found {arr[idx]} at index {idx} (frame {idx[0]}; "
                f"{int(bad.sum())} non-finite entries in all)",
            )


def output_notes(
    motion: Motion, path: str | os.PathLike[str] | None = None, metres_per_unit: float | None = None
) -> tuple[Note, ...]:
    """What writing ``motion`` to ``path`` changes, as notes.

    BVH (``path`` None or ``.bvh``): a joint with one or two rotation channels
    (``Xrotation Zrotation``) holds only the rotations of their family; a result (a blend, a
    loop) may leave it, and the writer then keeps the joint's channels and writes the nearest
    rotation they hold (:func:`elastic_motion.motion.rotation_channel_fit`). glTF (``.gltf``,
    ``.glb``): every rotation is a quaternion, but lengths are metres by the format's
    specification, so an output unit ``metres_per_unit`` other than 1 (the first input's, or
    ``units_out``) does not apply. Empty when nothing changes.
    """
    if path is not None and Path(path).suffix.lower() in GLTF_EXTENSIONS:
        if metres_per_unit is None or abs(metres_per_unit - 1.0) < 1e-12:
            return ()
        names = [k for k, v in UNITS.items() if abs(v - metres_per_unit) < 1e-12]
        unit = names[0] if names else f"{metres_per_unit:g} m"
        text = f"written in metres, glTF's unit by its specification (a BVH would be in {unit})"
        return (Note(OUTPUT_GLTF_METRES, text, {"unit_m": metres_per_unit}),)
    fit = rotation_channel_fit(motion)
    if not fit:
        return ()
    sk = motion.skeleton
    listed = ", ".join(
        f"{name} ({' '.join(c for c in sk.channels[sk.index(name)] if c.endswith('rotation')) or 'none'}) "
        f"{deg:.3g} deg"
        for name, deg in fit.items()
    )
    text = (
        f"{len(fit)} joint(s) with fewer than three rotation channels cannot hold the result's "
        f"rotations exactly; written with their own channels as the nearest rotations those hold, "
        f"at most this far from the result: {listed}"
    )
    return (Note(OUTPUT_CHANNELS, text, {"joints": dict(fit)}),)


def output_motion(motion: Motion, metres_per_unit: float | None) -> Motion:
    """``motion`` (metres, as every app returns) expressed in the output length unit.

    Parameters
    ----------
    motion : Motion
        ``metres_per_unit`` 1 (or None: unknown units are written as they are).
    metres_per_unit : float or None
        Size of the output unit in metres (:attr:`PreparedMotions.units_out`); None keeps
        the motion's numbers.
    """
    if metres_per_unit is None or motion.metres_per_unit is None:
        return motion
    if math.isclose(motion.metres_per_unit, metres_per_unit, rel_tol=1e-12):
        return motion
    # to_metres multiplies every length by metres_per_unit; declaring the current unit to be
    # (current size / target size) of a "metre" scales lengths into the target unit.
    scaled = to_metres(motion.replace(metres_per_unit=motion.metres_per_unit / metres_per_unit))
    return scaled.replace(metres_per_unit=float(metres_per_unit))
