"""Acclaim ASF (skeleton) + AMC (motion) reader, with the CMU database's conventions.

The Acclaim model and how it maps onto :class:`~.skeleton.Skeleton`
--------------------------------------------------------------------
Each ASF bone ``b`` has a unit ``direction`` d_b (in the world frame of the rest pose;
normalised on reading, as files round it to six digits) and a ``length`` l_b, an ``axis``
a_b (Euler angles: the orientation ``C_b`` of the bone's local frame in the rest pose) and
``dof`` (the rotation channels of the AMC lines).
The bone's global orientation is ``W_b = W_p C_p^-1 C_b M_b`` with ``M_b`` the AMC rotation,
and the bone runs from its parent's end to ``end_b = start_b + W_b C_b^-1 d_b l_b``.

Here every bone becomes a joint at the bone's *start*, with a local frame equal to the
world frame in the rest pose (``G_b = W_b C_b^-1``), so that

* local rotation ``R_b = C_b M_b C_b^-1`` (the AMC rotation expressed in rest-world axes),
* offset of a joint = its parent bone's vector ``d_p l_p`` (0 for the root's children),
* a bone without children ends in an End Site at ``d_b l_b``.

Positions are then exactly those of the Acclaim model and bone lengths are constant by
construction. The root joint has ``R_root = C_root M_root C_root^-1`` (``C_root`` from the
root ``orientation``, ``axis`` order) and translation = the AMC ``TX TY TZ`` values.

Euler conventions: angle lists ``rx ry rz`` (AMC ``dof`` values, the root's ``order``
rotations, an ``axis`` line with its order string) are rotations about the fixed axes
applied in the listed order, i.e. ``M = Rz @ Ry @ Rx`` for ``rx ry rz`` -- the convention
of CMU's own viewer. Angles are degrees unless ``:units angle rad`` / ``:RADIANS``.

Units: ASF ``:units length L`` means one file unit is ``1/L`` inch; CMU's ``0.45`` gives
0.0564 m per unit (``Motion.metres_per_unit``). AMC files carry no frame rate: ``fps`` is
a parameter, 120 by default (CMU's capture rate). Every frame block is kept.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from elastic_motion import limits as _limits
from elastic_motion._io import read_text
from elastic_motion.errors import ParseError
from elastic_motion.motion.joint_limits import JointLimits
from elastic_motion.motion.rotations import euler_to_matrix
from elastic_motion.motion.skeleton import Motion, Skeleton

__all__ = ["AsfSkeleton", "asf_joint_limits", "read_amc", "read_asf", "read_asf_amc", "read_joint_limits"]

_NUMBER = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?", re.ASCII)
_ROT_DOF = {"rx": "X", "ry": "Y", "rz": "Z"}
_ROOT_ORDER = {"TX", "TY", "TZ", "RX", "RY", "RZ"}
_BVH_ROOT_CHANNELS = ("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")
_BVH_JOINT_CHANNELS = ("Zrotation", "Yrotation", "Xrotation")


@dataclass(frozen=True, eq=False)
class AsfSkeleton:
    """An ASF file as read: the joint skeleton plus what an AMC reader needs.

    Attributes
    ----------
    skeleton : Skeleton
        Joint 0 is ``root``, then one joint per bone (depth-first from ``:hierarchy``).
    dof : list of tuple of str
        Per joint, the AMC value names in order (root: its ``order`` tokens, e.g.
        ``("TX", "TY", "TZ", "RX", "RY", "RZ")``; bones: e.g. ``("rx", "rz")``).
    axis : ndarray, shape (J, 3, 3)
        Rest-pose frame ``C_b`` of each bone (root: its ``orientation``).
    limits : list of list of tuple of float
        Per joint, the ``limits`` pairs of its dofs (empty when not given), in
        ``angle_unit``; as :class:`~.joint_limits.JointLimits` (radians) from
        :func:`asf_joint_limits` / :func:`read_joint_limits` (kept by ``loop``).
    angle_unit : {"deg", "rad"}
    metres_per_unit : float or None
    path : str
    """

    skeleton: Skeleton
    dof: list[tuple[str, ...]]
    axis: np.ndarray
    limits: list[list[tuple[float, float]]]
    angle_unit: str
    metres_per_unit: float | None
    path: str


def _num(path: str, line: int, tok: str, what: str) -> float:
    if not _NUMBER.fullmatch(tok):
        raise ParseError(path, line, f"expected {what} (a number), found {tok!r}")
    value = float(tok)
    if not math.isfinite(value):
        raise ParseError(path, line, f"expected {what} (a finite number), found {tok!r}")
    return value


def _extrinsic(angles: np.ndarray, axes: str) -> np.ndarray:
    """Rotation applying ``angles[..., k]`` about fixed axis ``axes[k]`` in listed order.

    ``axes`` has 0 to 3 distinct letters; missing axes get angle 0. Fixed-axis order
    ``a, b, c`` equals intrinsic order ``c, b, a``: ``R = R_c @ R_b @ R_a``.
    """
    full = axes + "".join(a for a in "XYZ" if a not in axes)
    ang = np.zeros(angles.shape[:-1] + (3,))
    ang[..., : len(axes)] = angles
    return euler_to_matrix(ang[..., ::-1], full[::-1])


def _split_sections(path: str, lines: list[str]) -> dict[str, tuple[int, list[tuple[int, list[str]]]]]:
    """Map ``:keyword`` -> (its line, [(line number, tokens) of the lines below it])."""
    sections: dict[str, tuple[int, list[tuple[int, list[str]]]]] = {}
    current: list[tuple[int, list[str]]] | None = None
    for i, raw in enumerate(lines, start=1):
        s = raw.strip()
        if not s or s.startswith("#"):
            continue
        if s.startswith(":"):
            toks = s.split()
            key = toks[0][1:].lower()
            if key in sections and key != "documentation":
                raise ParseError(path, i, f"section ':{key}' appears twice")
            current = []
            sections[key] = (i, current)
            if len(toks) > 1:
                current.append((i, toks[1:]))
            continue
        if current is None:
            raise ParseError(path, i, f"expected a ':section' keyword (e.g. ':version'), found {s[:40]!r}")
        current.append((i, s.split()))
    return sections


def _parse_limits(path: str, items: list[tuple[int, str]], n: int, bone: str) -> list[tuple[float, float]]:
    text = " ".join(t for _, t in items)
    line = items[0][0] if items else None
    pairs = re.findall(r"\(\s*([^\s()]+)\s+([^\s()]+)\s*\)", text)
    if len(pairs) != n or re.sub(r"\(\s*[^\s()]+\s+[^\s()]+\s*\)", "", text).strip():
        raise ParseError(
            path,
            line,
            f"expected {n} limits '(min max)' for bone {bone!r} (one per dof), found {text[:60]!r}",
        )
    out = []
    for lo, hi in pairs:
        vals = []
        for tok in (lo, hi):
            t = tok.lower().lstrip("+")
            if t in ("inf", "-inf"):
                vals.append(float(t))
            else:
                if not _NUMBER.fullmatch(tok):
                    raise ParseError(path, line, f"expected a limit (a number or inf), found {tok!r}")
                vals.append(float(tok))
        out.append((vals[0], vals[1]))
    return out


def read_asf(path: str | os.PathLike[str]) -> AsfSkeleton:
    """Read an ASF skeleton file.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    AsfSkeleton

    Raises
    ------
    ParseError
        Missing sections, a bone without name/direction/length, unknown bones or cycles
        in ``:hierarchy``, non-numeric values.
    """
    p = os.fspath(path)
    text = read_text(path).replace("\r\n", "\n").replace("\r", "\n")
    lines = text.split("\n")
    sections = _split_sections(p, lines)
    for key in ("root", "bonedata", "hierarchy"):
        if key not in sections:
            raise ParseError(p, len(lines), f"expected a ':{key}' section, found none")

    # -- units ---------------------------------------------------------------------------------
    angle_unit = "deg"
    metres_per_unit: float | None = 0.0254 / 0.45  # CMU default when :units is absent
    if "units" in sections:
        for ln, toks in sections["units"][1]:
            if len(toks) < 2:
                raise ParseError(p, ln, f"expected 'name value' in :units, found {' '.join(toks)!r}")
            key = toks[0].lower()
            if key == "angle":
                unit = toks[1].lower()
                if unit not in ("deg", "rad"):
                    raise ParseError(p, ln, f"expected 'angle deg' or 'angle rad', found {toks[1]!r}")
                angle_unit = unit
            elif key == "length":
                length = _num(p, ln, toks[1], "the length unit")
                if length <= 0:
                    raise ParseError(p, ln, f"expected a positive length unit, found {toks[1]!r}")
                metres_per_unit = 0.0254 / length
    to_rad = math.pi / 180.0 if angle_unit == "deg" else 1.0

    # -- root -------------------------------------------------------------------------------------
    root_line, root_items = sections["root"]
    root = {toks[0].lower(): (ln, toks[1:]) for ln, toks in root_items}
    if "order" not in root:
        raise ParseError(p, root_line, "expected an 'order' line in :root (e.g. 'order TX TY TZ RX RY RZ')")
    ln, order = root["order"]
    order = [t.upper() for t in order]
    if not order or any(t not in _ROOT_ORDER for t in order) or len(set(order)) != len(order):
        raise ParseError(p, ln, f"expected distinct tokens from TX TY TZ RX RY RZ in 'order', found {order}")
    root_axis_order = "XYZ"
    if "axis" in root:
        ln, toks = root["axis"]
        if len(toks) != 1 or sorted(toks[0].upper()) != ["X", "Y", "Z"]:
            raise ParseError(p, ln, f"expected a root axis order like 'XYZ', found {' '.join(toks)!r}")
        root_axis_order = toks[0].upper()
    root_orient = np.zeros(3)
    if "orientation" in root:
        ln, toks = root["orientation"]
        if len(toks) != 3:
            raise ParseError(p, ln, f"expected 3 orientation angles, found {len(toks)}")
        vals = [_num(p, ln, t, "an orientation angle") * to_rad for t in toks]
        root_orient = np.array([vals["XYZ".index(a)] for a in root_axis_order])
    if "position" in root:
        ln, toks = root["position"]
        if len(toks) != 3:
            raise ParseError(p, ln, f"expected 3 position values, found {len(toks)}")
        for t in toks:
            _num(p, ln, t, "a position value")

    # -- bones -----------------------------------------------------------------------------------
    bones: dict[str, dict] = {}
    bone_order: list[str] = []
    current: dict | None = None
    limits_items: list[tuple[int, str]] = []

    def finish(bone: dict, end_line: int) -> None:
        for key in ("name", "direction", "length"):
            if key not in bone:
                raise ParseError(p, end_line, f"bone starting on line {bone['line']} has no '{key}'")
        if limits_items:
            bone["limits"] = _parse_limits(p, limits_items, len(bone.get("dof", ())), bone["name"])
        if bone["name"] in bones or bone["name"] == "root":
            raise ParseError(p, bone["line"], f"bone name {bone['name']!r} is used twice")
        bones[bone["name"]] = bone
        bone_order.append(bone["name"])

    for ln, toks in sections["bonedata"][1]:
        key = toks[0].lower()
        if key == "begin":
            if current is not None:
                raise ParseError(p, ln, "expected 'end' before the next 'begin'")
            current = {"line": ln}
            limits_items = []
            continue
        if current is None:
            raise ParseError(p, ln, f"expected 'begin' to open a bone, found {toks[0]!r}")
        if key == "end":
            finish(current, ln)
            current = None
            continue
        if toks[0].startswith("(") and limits_items:  # continuation of a limits block
            limits_items.append((ln, " ".join(toks)))
            continue
        args = toks[1:]
        if key == "name":
            if len(args) != 1:
                raise ParseError(p, ln, f"expected one bone name, found {args}")
            current["name"] = args[0]
        elif key == "direction":
            if len(args) != 3:
                raise ParseError(p, ln, f"expected 3 direction values, found {len(args)}")
            d = np.array([_num(p, ln, t, "a direction value") for t in args])
            big = float(np.abs(d).max())
            if big > 0:  # scaled first: the norm of a direction of 1e200 would overflow
                d = d / big
                d = d / float(np.linalg.norm(d))
            current["direction"] = d
        elif key == "length":
            if len(args) != 1:
                raise ParseError(p, ln, f"expected one length value, found {len(args)}")
            current["length"] = _num(p, ln, args[0], "the bone length")
        elif key == "axis":
            if len(args) != 4 or sorted(args[3].upper()) != ["X", "Y", "Z"]:
                raise ParseError(
                    p, ln, f"expected 'axis a1 a2 a3 ORDER' (e.g. '0 0 20 XYZ'), found {' '.join(args)!r}"
                )
            angles = np.array([_num(p, ln, t, "an axis angle") for t in args[:3]]) * to_rad
            current["axis"] = _extrinsic(angles, args[3].upper())
        elif key == "dof":
            dof = tuple(t.lower() for t in args)
            for t in dof:
                if t not in _ROT_DOF:
                    raise ParseError(
                        p,
                        ln,
                        f"expected rotation dofs (rx, ry, rz), found {t!r} "
                        "(translation and length dofs are not supported)",
                    )
            if len(set(dof)) != len(dof):
                raise ParseError(p, ln, f"repeated dof in {list(dof)}")
            current["dof"] = dof
        elif key == "limits":
            limits_items = [(ln, " ".join(args))]
        elif key == "id":
            if len(args) != 1:
                raise ParseError(p, ln, f"expected one id, found {args}")
        # bodymass, cofmass and other keys carry nothing we use: skipped.
    if current is not None:
        raise ParseError(p, len(lines), f"bone starting on line {current['line']} has no 'end'")

    # -- hierarchy -------------------------------------------------------------------------------
    children: dict[str, list[str]] = {"root": []}
    parent_of: dict[str, str] = {}
    h_line, h_items = sections["hierarchy"]
    opened = False
    for ln, toks in h_items:
        key = toks[0].lower()
        if key == "begin":
            opened = True
            continue
        if key == "end":
            break
        if not opened:
            raise ParseError(p, ln, f"expected 'begin' in :hierarchy, found {toks[0]!r}")
        parent, kids = toks[0], toks[1:]
        for name in [parent, *kids]:
            if name != "root" and name not in bones:
                raise ParseError(p, ln, f"unknown bone {name!r} in :hierarchy (not in :bonedata)")
        for kid in kids:
            if kid == "root" or kid in parent_of:
                raise ParseError(p, ln, f"bone {kid!r} has more than one parent in :hierarchy")
            parent_of[kid] = parent
            children.setdefault(parent, []).append(kid)
    order_names = ["root"]
    stack = list(reversed(children.get("root", [])))
    while stack:
        name = stack.pop()
        order_names.append(name)
        stack.extend(reversed(children.get(name, [])))
    missing = [b for b in bone_order if b not in parent_of]
    if missing:
        raise ParseError(p, h_line, f"bone {missing[0]!r} is not attached to the skeleton in :hierarchy")
    if len(order_names) != len(bone_order) + 1:  # a cycle detached from the root
        lost = [b for b in bone_order if b not in set(order_names)]
        raise ParseError(p, h_line, f"bone {lost[0]!r} is not connected to the root (cycle in :hierarchy)")

    index = {n: k for k, n in enumerate(order_names)}
    n = len(order_names)
    _limits.check_clip(p, h_line, joints=n)
    parents = np.full(n, -1)
    offsets = np.zeros((n, 3))
    axis = np.empty((n, 3, 3))
    axis[0] = _extrinsic(root_orient, root_axis_order)
    dof: list[tuple[str, ...]] = [tuple(order)]
    limits: list[list[tuple[float, float]]] = [[]]
    es_parents, es_offsets = [], []
    for k, name in enumerate(order_names[1:], start=1):
        bone = bones[name]
        par = parent_of[name]
        parents[k] = index[par]
        if par != "root":
            pb = bones[par]
            offsets[k] = pb["direction"] * pb["length"]
        axis[k] = bone.get("axis", np.eye(3))
        dof.append(bone.get("dof", ()))
        limits.append(bone.get("limits", []))
        if not children.get(name):
            es_parents.append(k)
            es_offsets.append(bone["direction"] * bone["length"])
    skeleton = Skeleton(
        names=order_names,
        parents=parents,
        offsets=offsets,
        channels=[_BVH_ROOT_CHANNELS] + [_BVH_JOINT_CHANNELS] * (n - 1),
        end_site_parents=es_parents,
        end_site_offsets=np.array(es_offsets).reshape(-1, 3),
    )
    return AsfSkeleton(skeleton, dof, axis, limits, angle_unit, metres_per_unit, p)


def read_amc(
    asf: AsfSkeleton,
    path: str | os.PathLike[str],
    *,
    fps: float = 120.0,
    up_axis: str = "y",
) -> Motion:
    """Read an AMC motion file for an already-read ASF skeleton.

    Parameters
    ----------
    asf : AsfSkeleton
        From :func:`read_asf`.
    path : str or os.PathLike
    fps : float, default 120
        AMC files do not store their frame rate; CMU captured at 120 Hz.
    up_axis : {"x", "y", "z"}, default "y"

    Returns
    -------
    Motion
        One frame per frame block of the file (all kept, including the last).

    Raises
    ------
    ParseError
        Unknown bone, wrong number of values for a bone, a bone missing from or repeated
        in a frame, non-numeric values, non-consecutive frame numbers, zero frames.
    """
    p = os.fspath(path)
    fps = float(fps)
    if not (math.isfinite(fps) and fps > 0):
        raise ValueError(f"fps: expected a positive frame rate; got {fps!r}")
    _limits.check_option("fps", "a frame rate (fps) of", fps, "max_fps")
    _limits.check_option("fps", "a frame rate (fps) of", fps, "min_fps", at_least=True)
    text = read_text(path).replace("\r\n", "\n").replace("\r", "\n")
    lines = text.split("\n")
    sk = asf.skeleton
    index = {name: k for k, name in enumerate(sk.names)}
    n_vals = [len(d) for d in asf.dof]
    needed = [k for k in range(sk.n_joints) if n_vals[k] > 0]
    to_rad = math.pi / 180.0 if asf.angle_unit == "deg" else 1.0

    frames: list[list[np.ndarray | None]] = []
    frame_lines: list[int] = []
    current: list[np.ndarray | None] | None = None
    last_number: int | None = None

    def close_frame() -> None:
        if current is None:
            return
        for k in needed:
            if current[k] is None:
                raise ParseError(
                    p, frame_lines[-1], f"frame {last_number} has no line for bone {sk.names[k]!r}"
                )

    for i, raw in enumerate(lines, start=1):
        s = raw.strip()
        if not s or s.startswith("#"):
            continue
        if s.startswith(":"):
            word = s.split()[0].upper()
            if current is not None:
                raise ParseError(p, i, f"expected bone values or a frame number, found {word!r}")
            if word == ":RADIANS":
                to_rad = 1.0
            elif word == ":DEGREES":
                to_rad = math.pi / 180.0
            continue
        toks = s.split()
        if len(toks) == 1 and toks[0].isascii() and toks[0].isdigit():
            if len(toks[0]) > 18:  # int() of thousands of digits is refused (and no clip is that long)
                raise ParseError(
                    p, i, f"expected a frame number, found {toks[0][:20]!r}... ({len(toks[0])} digits)"
                )
            number = int(toks[0])
            if last_number is not None and number != last_number + 1:
                raise ParseError(p, i, f"expected frame number {last_number + 1}, found {number}")
            close_frame()
            last_number = number
            current = [None] * sk.n_joints
            frames.append(current)
            frame_lines.append(i)
            continue
        name = toks[0]
        if current is None:
            raise ParseError(p, i, f"expected a frame number before the first bone line, found {name!r}")
        if name not in index:
            raise ParseError(p, i, f"unknown bone {name!r} (not in the ASF skeleton {asf.path})")
        k = index[name]
        if current[k] is not None:
            raise ParseError(p, i, f"bone {name!r} appears twice in frame {last_number}")
        vals = toks[1:]
        if len(vals) != n_vals[k]:
            dof = " ".join(asf.dof[k]) or "none"
            raise ParseError(
                p, i, f"expected {n_vals[k]} values for bone {name!r} (dof {dof}), found {len(vals)}"
            )
        current[k] = np.array([_num(p, i, t, f"a value for bone {name!r}") for t in vals])
    if not frames:
        raise ParseError(p, len(lines), "expected at least one frame, found none")
    close_frame()

    f, j = len(frames), sk.n_joints
    _limits.check_clip(p, len(lines), frames=f, duration=f / fps, joints=j)
    # Gather per-joint value arrays (F, n_vals[k]).
    values = [np.array([fr[k] for fr in frames]) if n_vals[k] else np.zeros((f, 0)) for k in range(j)]
    rotations = np.empty((f, j, 3, 3))
    # Root: translation and rotation channels as listed in `order`.
    root_order = asf.dof[0]
    root_translation = np.zeros((f, 3))
    rot_axes = ""
    rot_cols = []
    for c, tok in enumerate(root_order):
        if tok.startswith("T"):
            root_translation[:, "XYZ".index(tok[1])] = values[0][:, c]
        else:
            rot_axes += tok[1]
            rot_cols.append(c)
    m_root = _extrinsic(values[0][:, rot_cols] * to_rad, rot_axes)
    c0 = asf.axis[0]
    rotations[:, 0] = c0 @ m_root @ c0.T
    for k in range(1, j):
        axes = "".join(_ROT_DOF[d] for d in asf.dof[k])
        m = _extrinsic(values[k] * to_rad, axes)
        ck = asf.axis[k]
        rotations[:, k] = ck @ m @ ck.T
    return Motion(
        skeleton=sk,
        fps=fps,
        root_translation=root_translation,
        rotations=rotations,
        joint_translations=None,
        metres_per_unit=asf.metres_per_unit,
        up_axis=up_axis,
        source=(asf.path, p),
        name=Path(p).stem,
    )


def read_asf_amc(
    asf_path: str | os.PathLike[str],
    amc_path: str | os.PathLike[str],
    *,
    fps: float = 120.0,
    up_axis: str = "y",
) -> Motion:
    """Read an ASF skeleton and an AMC motion into a :class:`Motion`.

    Parameters
    ----------
    asf_path, amc_path : str or os.PathLike
    fps : float, default 120
        Frame rate of the AMC file (not stored in the format; CMU is 120 Hz).
    up_axis : {"x", "y", "z"}, default "y"
        CMU data are Y-up.

    Returns
    -------
    Motion
        31 joints for CMU skeletons (root + 30 bones), ``metres_per_unit`` from
        ``:units length`` (0.0564 for CMU), every AMC frame.
    """
    return read_amc(read_asf(asf_path), amc_path, fps=fps, up_axis=up_axis)


def asf_joint_limits(asf: AsfSkeleton) -> JointLimits:
    """The ``limits`` of an ASF skeleton's bones as :class:`~.joint_limits.JointLimits`.

    Bones with rotation dofs and a ``limits`` block are kept (the root's ``order`` channels
    are not limited); a dof with ``(-inf inf)`` is unlimited. Bounds are converted from the
    ASF angle unit to radians; the dof angles are those of the AMC reader
    (``R = C M C^T``, :func:`elastic_motion.motion.joint_limits.dof_angles`).
    """
    to_rad = math.pi / 180.0 if asf.angle_unit == "deg" else 1.0
    joints, axes, frames, lower, upper = [], [], [], [], []
    for k in range(1, asf.skeleton.n_joints):
        lim, dof = asf.limits[k], asf.dof[k]
        if not lim or not dof or len(lim) != len(dof):
            continue
        pairs = np.array(lim, dtype=np.float64) * to_rad
        if not np.isfinite(pairs).any():
            continue
        joints.append(asf.skeleton.names[k])
        axes.append("".join(_ROT_DOF[d] for d in dof))
        frames.append(asf.axis[k])
        lower.append(np.minimum(pairs[:, 0], pairs[:, 1]))
        upper.append(np.maximum(pairs[:, 0], pairs[:, 1]))
    return JointLimits(
        tuple(joints), tuple(axes), np.array(frames).reshape(-1, 3, 3), tuple(lower), tuple(upper), asf.path
    )


def read_joint_limits(source: Motion | str | os.PathLike[str]) -> JointLimits | None:
    """The joint limits of an ASF file, or of the ASF a motion was read from.

    Parameters
    ----------
    source : Motion or path
        A ``.asf`` path, or a motion whose ``source`` starts with one (what
        :func:`read_asf_amc` returns, kept by the preparation step).

    Returns
    -------
    JointLimits or None
        ``None`` when the motion was not read from an ASF file or the file has no limits.
    """
    if isinstance(source, Motion):
        if not source.source or not str(source.source[0]).lower().endswith(".asf"):
            return None
        source = source.source[0]
    lim = asf_joint_limits(read_asf(source))
    return lim if lim.joints else None
