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
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

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
#: Smallest ``:units length`` L whose unit, 1/L inch, is a finite number of metres.
_MIN_LENGTH_UNIT = 0.0254 / sys.float_info.max


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


def _read_lines(path: str | os.PathLike[str]) -> list[str]:
    """The file's lines, whatever its line ends (CRLF, CR or LF)."""
    return read_text(path).replace("\r\n", "\n").replace("\r", "\n").split("\n")


# ------------------------------------------------------------------------------------------
# ASF: the sections, one step each
# ------------------------------------------------------------------------------------------
_Items = list[tuple[int, list[str]]]


def _asf_units(p: str, items: _Items) -> tuple[str, float | None]:
    """``:units``: the angle unit (``"deg"``, ``"rad"``) and metres per length unit."""
    angle_unit = "deg"
    metres_per_unit: float | None = 0.0254 / 0.45  # CMU default when :units is absent
    for ln, toks in items:
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
            if not math.isfinite(metres_per_unit):  # 1e-320: 1/L inch overflows
                raise ParseError(
                    p,
                    ln,
                    f"expected a length unit of at least {_MIN_LENGTH_UNIT:.3g} "
                    f"(1/L inch must be a finite length), found {toks[1]!r}",
                )
    return angle_unit, metres_per_unit


def _asf_root(p: str, section: tuple[int, _Items], to_rad: float) -> tuple[tuple[str, ...], np.ndarray]:
    """``:root``: the AMC value names of the root (its ``order``) and its rest frame ``(3, 3)``
    (``orientation`` about the fixed axes of ``axis``)."""
    root_line, root_items = section
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
    return tuple(order), _extrinsic(root_orient, root_axis_order)


def _bone_name(p: str, ln: int, args: list[str], to_rad: float) -> str:
    if len(args) != 1:
        raise ParseError(p, ln, f"expected one bone name, found {args}")
    return args[0]


def _bone_direction(p: str, ln: int, args: list[str], to_rad: float) -> np.ndarray:
    """The unit direction ``(3,)`` (files round it to six digits)."""
    if len(args) != 3:
        raise ParseError(p, ln, f"expected 3 direction values, found {len(args)}")
    d = np.array([_num(p, ln, t, "a direction value") for t in args])
    big = float(np.abs(d).max())
    if big > 0:  # scaled first: the norm of a direction of 1e200 would overflow
        d = d / big
        d = d / float(np.linalg.norm(d))
    return d


def _bone_length(p: str, ln: int, args: list[str], to_rad: float) -> float:
    if len(args) != 1:
        raise ParseError(p, ln, f"expected one length value, found {len(args)}")
    return _num(p, ln, args[0], "the bone length")


def _bone_axis(p: str, ln: int, args: list[str], to_rad: float) -> np.ndarray:
    """The bone's rest frame ``C_b`` ``(3, 3)`` from ``axis a1 a2 a3 ORDER``."""
    if len(args) != 4 or sorted(args[3].upper()) != ["X", "Y", "Z"]:
        raise ParseError(
            p, ln, f"expected 'axis a1 a2 a3 ORDER' (e.g. '0 0 20 XYZ'), found {' '.join(args)!r}"
        )
    angles = np.array([_num(p, ln, t, "an axis angle") for t in args[:3]]) * to_rad
    return _extrinsic(angles, args[3].upper())


def _bone_dof(p: str, ln: int, args: list[str], to_rad: float) -> tuple[str, ...]:
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
    return dof


def _bone_id(p: str, ln: int, args: list[str], to_rad: float) -> None:
    if len(args) != 1:
        raise ParseError(p, ln, f"expected one id, found {args}")


#: The ``:bonedata`` keys read (each checked; ``id`` is checked and dropped). ``limits`` has
#: its own block; ``bodymass``, ``cofmass`` and other keys carry nothing we use: skipped.
_BONE_FIELDS = {
    "name": _bone_name,
    "direction": _bone_direction,
    "length": _bone_length,
    "axis": _bone_axis,
    "dof": _bone_dof,
    "id": _bone_id,
}


class _BoneData:
    """``:bonedata``, one line at a time: ``begin``, a bone's fields and ``limits``, ``end``.

    ``bones`` maps each name to its fields (``line``, ``name``, ``direction``, ``length`` and,
    when given, ``axis``, ``dof``, ``limits``), in file order.
    """

    def __init__(self, path: str, to_rad: float) -> None:
        self.path = path
        self.to_rad = to_rad
        self.bones: dict[str, dict[str, Any]] = {}
        self.current: dict[str, Any] | None = None
        self.limit_items: list[tuple[int, str]] = []

    def read(self, items: _Items, last_line: int) -> dict[str, dict[str, Any]]:
        for ln, toks in items:
            self.line(ln, toks)
        if self.current is not None:
            raise ParseError(
                self.path, last_line, f"bone starting on line {self.current['line']} has no 'end'"
            )
        return self.bones

    def line(self, ln: int, toks: list[str]) -> None:
        key = toks[0].lower()
        if key == "begin":
            if self.current is not None:
                raise ParseError(self.path, ln, "expected 'end' before the next 'begin'")
            self.current = {"line": ln}
            self.limit_items = []
            return
        if self.current is None:
            raise ParseError(self.path, ln, f"expected 'begin' to open a bone, found {toks[0]!r}")
        if key == "end":
            self.finish(self.current, ln)
            self.current = None
        elif toks[0].startswith("(") and self.limit_items:  # continuation of a limits block
            self.limit_items.append((ln, " ".join(toks)))
        elif key == "limits":
            self.limit_items = [(ln, " ".join(toks[1:]))]
        elif key in _BONE_FIELDS:
            value = _BONE_FIELDS[key](self.path, ln, toks[1:], self.to_rad)
            if key != "id":
                self.current[key] = value

    def finish(self, bone: dict[str, Any], end_line: int) -> None:
        for key in ("name", "direction", "length"):
            if key not in bone:
                raise ParseError(self.path, end_line, f"bone starting on line {bone['line']} has no '{key}'")
        if self.limit_items:
            bone["limits"] = _parse_limits(
                self.path, self.limit_items, len(bone.get("dof", ())), bone["name"]
            )
        if bone["name"] in self.bones or bone["name"] == "root":
            raise ParseError(self.path, bone["line"], f"bone name {bone['name']!r} is used twice")
        self.bones[bone["name"]] = bone


@dataclass(frozen=True)
class _Tree:
    """The bones' tree of ``:hierarchy``: ``order`` lists ``root`` then the bones depth-first."""

    order: list[str]
    parent_of: dict[str, str]
    children: dict[str, list[str]]


def _hierarchy_links(
    p: str, items: _Items, bones: dict[str, Any]
) -> tuple[dict[str, list[str]], dict[str, str]]:
    """The ``parent child child ...`` lines of ``:hierarchy``: children and parent of each name."""
    children: dict[str, list[str]] = {"root": []}
    parent_of: dict[str, str] = {}
    opened = False
    for ln, toks in items:
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
    return children, parent_of


def _asf_hierarchy(p: str, section: tuple[int, _Items], bones: dict[str, Any]) -> _Tree:
    """``:hierarchy``: every bone attached once, all connected to the root."""
    h_line, h_items = section
    children, parent_of = _hierarchy_links(p, h_items, bones)
    order_names = ["root"]
    stack = list(reversed(children.get("root", [])))
    while stack:
        name = stack.pop()
        order_names.append(name)
        stack.extend(reversed(children.get(name, [])))
    missing = [b for b in bones if b not in parent_of]
    if missing:
        raise ParseError(p, h_line, f"bone {missing[0]!r} is not attached to the skeleton in :hierarchy")
    if len(order_names) != len(bones) + 1:  # a cycle detached from the root
        lost = [b for b in bones if b not in set(order_names)]
        raise ParseError(p, h_line, f"bone {lost[0]!r} is not connected to the root (cycle in :hierarchy)")
    return _Tree(order_names, parent_of, children)


def _joint_skeleton(tree: _Tree, bones: dict[str, Any], root_axis: np.ndarray) -> tuple[Skeleton, np.ndarray]:
    """The joint skeleton (module docstring) and the rest frames ``C_b`` ``(J, 3, 3)``."""
    index = {n: k for k, n in enumerate(tree.order)}
    n = len(tree.order)
    parents = np.full(n, -1)
    offsets = np.zeros((n, 3))
    axis = np.empty((n, 3, 3))
    axis[0] = root_axis
    es_parents, es_offsets = [], []
    for k, name in enumerate(tree.order[1:], start=1):
        bone = bones[name]
        par = tree.parent_of[name]
        parents[k] = index[par]
        if par != "root":
            pb = bones[par]
            offsets[k] = pb["direction"] * pb["length"]
        axis[k] = bone.get("axis", np.eye(3))
        if not tree.children.get(name):
            es_parents.append(k)
            es_offsets.append(bone["direction"] * bone["length"])
    skeleton = Skeleton(
        names=tree.order,
        parents=parents,
        offsets=offsets,
        channels=[_BVH_ROOT_CHANNELS] + [_BVH_JOINT_CHANNELS] * (n - 1),
        end_site_parents=es_parents,
        end_site_offsets=np.array(es_offsets).reshape(-1, 3),
    )
    return skeleton, axis


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
    lines = _read_lines(path)
    sections = _split_sections(p, lines)
    for key in ("root", "bonedata", "hierarchy"):
        if key not in sections:
            raise ParseError(p, len(lines), f"expected a ':{key}' section, found none")
    angle_unit, metres_per_unit = _asf_units(p, sections["units"][1] if "units" in sections else [])
    to_rad = math.pi / 180.0 if angle_unit == "deg" else 1.0
    root_order, root_axis = _asf_root(p, sections["root"], to_rad)
    bones = _BoneData(p, to_rad).read(sections["bonedata"][1], len(lines))
    tree = _asf_hierarchy(p, sections["hierarchy"], bones)
    _limits.check_clip(p, sections["hierarchy"][0], joints=len(tree.order))
    skeleton, axis = _joint_skeleton(tree, bones, root_axis)
    dof: list[tuple[str, ...]] = [root_order] + [bones[name].get("dof", ()) for name in tree.order[1:]]
    limits: list[list[tuple[float, float]]] = [[]] + [
        bones[name].get("limits", []) for name in tree.order[1:]
    ]
    return AsfSkeleton(skeleton, dof, axis, limits, angle_unit, metres_per_unit, p)


# ------------------------------------------------------------------------------------------
# AMC: frame blocks of bone lines
# ------------------------------------------------------------------------------------------
class _AmcFrames:
    """The frame blocks of an AMC file, one line at a time (:func:`read_amc`).

    ``frames[f][k]`` holds the values of joint ``k`` in frame ``f`` (None until its line);
    ``to_rad`` follows ``:RADIANS`` / ``:DEGREES`` (the ASF's angle unit by default).
    """

    def __init__(self, path: str, asf: AsfSkeleton) -> None:
        self.path = path
        self.asf = asf
        self.index = {name: k for k, name in enumerate(asf.skeleton.names)}
        self.n_vals = [len(d) for d in asf.dof]
        self.needed = [k for k in range(asf.skeleton.n_joints) if self.n_vals[k] > 0]
        self.to_rad = math.pi / 180.0 if asf.angle_unit == "deg" else 1.0
        self.frames: list[list[np.ndarray | None]] = []
        self.frame_lines: list[int] = []
        self.current: list[np.ndarray | None] | None = None
        self.last_number: int | None = None

    def read(self, lines: list[str]) -> list[list[np.ndarray | None]]:
        for i, raw in enumerate(lines, start=1):
            s = raw.strip()
            if not s or s.startswith("#"):
                continue
            if s.startswith(":"):
                self.keyword(i, s.split()[0].upper())
                continue
            toks = s.split()
            if len(toks) == 1 and toks[0].isascii() and toks[0].isdigit():
                self.frame_number(i, toks[0])
            else:
                self.bone_line(i, toks)
        if not self.frames:
            raise ParseError(self.path, len(lines), "expected at least one frame, found none")
        self.close_frame()
        return self.frames  # type: ignore[return-value]

    def keyword(self, i: int, word: str) -> None:
        if self.current is not None:
            raise ParseError(self.path, i, f"expected bone values or a frame number, found {word!r}")
        if word == ":RADIANS":
            self.to_rad = 1.0
        elif word == ":DEGREES":
            self.to_rad = math.pi / 180.0

    def frame_number(self, i: int, tok: str) -> None:
        if len(tok) > 18:  # int() of thousands of digits is refused (and no clip is that long)
            raise ParseError(
                self.path, i, f"expected a frame number, found {tok[:20]!r}... ({len(tok)} digits)"
            )
        number = int(tok)
        if self.last_number is not None and number != self.last_number + 1:
            raise ParseError(self.path, i, f"expected frame number {self.last_number + 1}, found {number}")
        self.close_frame()
        self.last_number = number
        self.current = [None] * self.asf.skeleton.n_joints
        self.frames.append(self.current)
        self.frame_lines.append(i)

    def close_frame(self) -> None:
        if self.current is None:
            return
        for k in self.needed:
            if self.current[k] is None:
                raise ParseError(
                    self.path,
                    self.frame_lines[-1],
                    f"frame {self.last_number} has no line for bone {self.asf.skeleton.names[k]!r}",
                )

    def bone_line(self, i: int, toks: list[str]) -> None:
        name = toks[0]
        if self.current is None:
            raise ParseError(
                self.path, i, f"expected a frame number before the first bone line, found {name!r}"
            )
        if name not in self.index:
            raise ParseError(self.path, i, f"unknown bone {name!r} (not in the ASF skeleton {self.asf.path})")
        k = self.index[name]
        if self.current[k] is not None:
            raise ParseError(self.path, i, f"bone {name!r} appears twice in frame {self.last_number}")
        vals = toks[1:]
        if len(vals) != self.n_vals[k]:
            dof = " ".join(self.asf.dof[k]) or "none"
            raise ParseError(
                self.path,
                i,
                f"expected {self.n_vals[k]} values for bone {name!r} (dof {dof}), found {len(vals)}",
            )
        self.current[k] = np.array([_num(self.path, i, t, f"a value for bone {name!r}") for t in vals])


def _amc_pose(
    asf: AsfSkeleton, frames: list[list[np.ndarray]], to_rad: float
) -> tuple[np.ndarray, np.ndarray]:
    """Root translation ``(F, 3)`` and local rotations ``(F, J, 3, 3)`` (``R_b = C_b M_b C_b^T``)
    of the frames' values."""
    f, j = len(frames), asf.skeleton.n_joints
    n_vals = [len(d) for d in asf.dof]
    # Gather per-joint value arrays (F, n_vals[k]).
    values = [np.array([fr[k] for fr in frames]) if n_vals[k] else np.zeros((f, 0)) for k in range(j)]
    rotations = np.empty((f, j, 3, 3))
    # Root: translation and rotation channels as listed in `order`.
    root_translation = np.zeros((f, 3))
    rot_axes = ""
    rot_cols = []
    for c, tok in enumerate(asf.dof[0]):
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
    return root_translation, rotations


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
    lines = _read_lines(path)
    reader = _AmcFrames(p, asf)
    frames = reader.read(lines)
    f, j = len(frames), asf.skeleton.n_joints
    _limits.check_clip(p, len(lines), frames=f, duration=f / fps, joints=j)
    root_translation, rotations = _amc_pose(asf, frames, reader.to_rad)
    return Motion(
        skeleton=asf.skeleton,
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
