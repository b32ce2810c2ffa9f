"""Motions in and out: skeletons, BVH / ASF+AMC / DeepMimic / glTF 2.0 files, forward kinematics, and
the two curve representations (``R^3 x SO(3)^J`` and Euler angles in ``R^d``).

Conventions (details in :mod:`.skeleton` and ``docs/motion.md``): local joint rotations are
matrices ``(F, J, 3, 3)`` acting on column vectors, ``global = parent_global @ local``;
joint 0 is the root; root translation ``(F, 3)`` in the file's length unit
(``Motion.metres_per_unit`` converts); up axis in ``Motion.up_axis`` (BVH: detected from the
motion, :func:`detect_up_axis`; the other formats are Y-up, and glTF metres); Euler angles are
intrinsic in channel order; quaternions are **(w, x, y, z)**.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from elastic_motion.errors import ParseError
from elastic_motion.motion.asfamc import read_amc, read_asf, read_asf_amc
from elastic_motion.motion.axes import UpAxisEstimate, detect_up_axis, is_lying_down, up_axis_warning
from elastic_motion.motion.bvh import guess_units, read_bvh, rotation_channel_fit, write_bvh
from elastic_motion.motion.deepmimic import deepmimic_skeleton, read_deepmimic, read_urdf_skeleton
from elastic_motion.motion.edit import (
    align_heading,
    drop_joints,
    drop_tpose,
    finger_joints,
    frames_read_at_times,
    has_reference_root,
    has_tpose_first_frame,
    heading_angle,
    lift_out_of_floor,
    merge_root,
    place_like,
    place_on_floor,
    resample,
    resample_at_times,
    select_frames,
    select_joints,
    set_up_axis,
    smooth_motion,
    to_metres,
    trim,
)
from elastic_motion.motion.gltf import GLTF_EXTENSIONS, read_gltf, write_gltf
from elastic_motion.motion.info import format_info, motion_info
from elastic_motion.motion.kinematics import forward_kinematics, global_rotations
from elastic_motion.motion.representations import (
    EULER,
    LIE,
    METHODS,
    Representation,
    default_joint_weights,
    default_translation_weight,
    from_euler_curve,
    from_lie_curve,
    group_weights,
    lie_group_for,
    representation,
    skeleton_diameter,
    to_euler_curve,
    to_lie_curve,
    unwrap_euler,
)
from elastic_motion.motion.skeleton import UNITS, Motion, Skeleton

__all__ = [
    "EULER",
    "GLTF_EXTENSIONS",
    "LIE",
    "METHODS",
    "UNITS",
    "Motion",
    "ParseError",
    "Representation",
    "Skeleton",
    "UpAxisEstimate",
    "align_heading",
    "convert_to_bvh",
    "deepmimic_skeleton",
    "default_joint_weights",
    "default_translation_weight",
    "detect_up_axis",
    "drop_joints",
    "drop_tpose",
    "find_asf",
    "finger_joints",
    "format_info",
    "forward_kinematics",
    "frames_read_at_times",
    "from_euler_curve",
    "from_lie_curve",
    "global_rotations",
    "group_weights",
    "guess_units",
    "has_reference_root",
    "has_tpose_first_frame",
    "heading_angle",
    "is_lying_down",
    "lie_group_for",
    "lift_out_of_floor",
    "merge_root",
    "motion_info",
    "place_like",
    "place_on_floor",
    "read_amc",
    "read_asf",
    "read_asf_amc",
    "read_bvh",
    "read_deepmimic",
    "read_gltf",
    "read_motion",
    "read_urdf_skeleton",
    "representation",
    "resample",
    "resample_at_times",
    "rotation_channel_fit",
    "select_frames",
    "select_joints",
    "set_up_axis",
    "skeleton_diameter",
    "smooth_motion",
    "to_euler_curve",
    "to_lie_curve",
    "to_metres",
    "trim",
    "unwrap_euler",
    "up_axis_warning",
    "write_bvh",
    "write_gltf",
    "write_motion",
]


def find_asf(amc_path: str | os.PathLike[str]) -> Path:
    """The ASF file that goes with an AMC file, from the same folder.

    The ``.asf`` whose name (without extension) is the longest prefix of the AMC's name
    wins (``02_01.amc`` -> ``02.asf``, ``charleston1.amc`` -> ``charleston.asf``); failing
    that, the folder's only ``.asf``.

    Raises
    ------
    ValueError
        If no ASF, or several equally good ones, are found (pass ``asf=`` explicitly).
    """
    amc = Path(amc_path)
    folder = amc.parent
    try:
        candidates = sorted(p for p in folder.iterdir() if p.suffix.lower() == ".asf" and p.is_file())
    except OSError as exc:
        raise ValueError(f"{str(amc)!r}: cannot list its folder to find its .asf skeleton: {exc}") from exc
    stem = amc.stem.lower()
    prefixed = [p for p in candidates if stem.startswith(p.stem.lower())]
    if prefixed:
        best = max(len(p.stem) for p in prefixed)
        top = [p for p in prefixed if len(p.stem) == best]
        if len(top) == 1:
            return top[0]
    elif len(candidates) == 1:
        return candidates[0]
    raise ValueError(
        f"{str(amc)!r}: expected one .asf skeleton file beside it, or one whose name starts its "
        f"name (as 02.asf for 02_01.amc); found {[p.name for p in candidates] or 'none'} (in Python, "
        "read_motion(amc, asf=PATH) names it)"
    )


def convert_to_bvh(
    path: str | os.PathLike[str], out: str | os.PathLike[str], *, euler_orders: str | None = None, **kw
) -> Path:
    """Read any supported motion file (:func:`read_motion`) and write it as BVH.

    Parameters
    ----------
    path : str or os.PathLike
        Input (``.bvh``, ``.amc``, DeepMimic ``.txt``/``.json``, ``.gltf``/``.glb``); ``**kw``
        go to its reader.
    out : str or os.PathLike
        Output BVH path; never one of the inputs.
    euler_orders : str, optional
        Rotation channel order for every joint (default: the reader's layout, ``ZYX`` for
        ASF/AMC and DeepMimic).

    Returns
    -------
    pathlib.Path
        ``out``.
    """
    return write_bvh(read_motion(path, **kw), out, euler_orders=euler_orders)


def read_motion(path: str | os.PathLike[str], **kw) -> Motion:
    """Read a motion file, choosing the reader by extension.

    Parameters
    ----------
    path : str or os.PathLike
        ``.bvh`` (:func:`read_bvh`); ``.amc`` (:func:`read_asf_amc`, the skeleton from
        ``asf=`` or :func:`find_asf`); ``.txt`` / ``.json`` DeepMimic clips
        (:func:`read_deepmimic`); ``.gltf`` / ``.glb`` glTF 2.0 (:func:`read_gltf`, needs the
        ``gltf`` extra).
    **kw
        Passed to the reader (``units=``, ``up_axis=`` for BVH; ``asf=``, ``fps=`` for
        AMC; ``urdf=``, ``skeleton=`` for DeepMimic; ``skin=``, ``animation=``, ``fps=``
        for glTF).

    Returns
    -------
    Motion

    Raises
    ------
    ParseError
        From the reader, for malformed files.
    ValueError
        For an unsupported extension, or an ``.asf`` given alone.
    """
    p = Path(path)
    ext = p.suffix.lower()
    if ext == ".bvh":
        return read_bvh(p, **kw)
    if ext == ".amc":
        asf = kw.pop("asf", None)
        return read_asf_amc(asf if asf is not None else find_asf(p), p, **kw)
    if ext == ".asf":
        amc = kw.pop("amc", None)
        if amc is None:
            raise ValueError(
                f"{p}: expected a motion file; got an ASF skeleton without motion: give an .amc file "
                "beside it (in Python also read_motion(asf_path, amc=amc_path))"
            )
        return read_asf_amc(p, amc, **kw)
    if ext in (".txt", ".json"):
        return read_deepmimic(p, **kw)
    if ext in GLTF_EXTENSIONS:
        return read_gltf(p, **kw)
    raise ValueError(
        f"path: unsupported motion file extension {p.suffix!r} for {str(p)!r}; expected "
        ".bvh, .amc (+ .asf), a DeepMimic .txt/.json or a glTF .gltf/.glb"
    )


def write_motion(
    motion: Motion, path: str | os.PathLike[str], *, protected: Sequence[str | os.PathLike[str]] = ()
) -> Path:
    """Write a motion file, choosing the writer by extension: ``.bvh`` (:func:`write_bvh`, the
    skeleton's channels), ``.gltf`` / ``.glb`` (:func:`write_gltf`).

    Parameters
    ----------
    motion : Motion
    path : str or os.PathLike
        Destination, written atomically; never one of ``motion.source`` or ``protected``.
    protected : sequence of paths, optional
        Further files that must not be overwritten (the inputs of a computed motion).

    Returns
    -------
    pathlib.Path

    Raises
    ------
    ValueError
        For another extension, or a path that is an input.
    """
    ext = Path(path).suffix.lower()
    if ext == ".bvh":
        return write_bvh(motion, path, protected=protected)
    if ext in GLTF_EXTENSIONS:
        return write_gltf(motion, path, protected=list(protected))
    raise ValueError(f"path: expected a .bvh, .gltf or .glb file name; got {os.fspath(path)!r}")
