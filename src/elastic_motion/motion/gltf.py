"""glTF 2.0 skeletal animation (``.gltf`` / ``.glb``) in and out.

glTF is the open interchange format Blender, three.js, Unity, Unreal and Godot all load. It
needs the optional ``pygltflib`` (``pip install "elastic-motion[gltf]"``), imported only when
a glTF file is read or written.

Reading (:func:`read_gltf`)
---------------------------
One skin is the skeleton: its joints, plus the nodes between them and their lowest common
ancestor (the root), are the joints, in node order when parents come first (else
depth-first). One animation gives the motion: its ``rotation`` and ``translation`` channels on
those nodes, sampled (``LINEAR``: slerp for rotations, ``STEP``, ``CUBICSPLINE``: Hermite, as
the specification says) on a uniform grid from the first key to the last, at the rate of the
keys (``1 /`` the median step, :func:`.bvh.snap_fps`) or ``fps=``. A channel is held at its
first / last value outside its keys; a node without a channel keeps its rest transform.

The rest pose is the nodes' own transforms. As in BVH, our rest pose has identity rotations
and offsets in the rest pose's world axes: with ``G_j`` the rest world rotation of node ``j``
and ``Q_j(t)`` its animated local rotation, the Motion's local rotation is
``G_parent Q_j(t) G_j^T`` and its offset ``G_parent T_j``, which gives the file's world
positions of every joint exactly. Nodes above the root add their (static) transform to the
root; a uniform scale there (an armature scaled by 0.01) scales all lengths. A joint whose
translation is animated away from its rest value keeps it per frame (position channels, as in
the Bandai BVH files).

glTF lengths are metres and +Y is up (the specification): the Motion has
``metres_per_unit = 1`` and ``up_axis = "y"``.

Writing (:func:`write_gltf`)
----------------------------
Every joint is a node (rest translation: its offset; the root's: its first frame position),
one skin lists them with their inverse bind matrices (the rest pose), and one animation holds
a ``LINEAR`` rotation channel per joint and a translation channel for the root and each joint
with position channels, one key per frame. The skin is used by no mesh (Blender and three.js
load it as an armature / bones). A motion in another unit is written in metres, another up
axis is turned to +Y (:func:`.edit.to_metres`, :func:`.edit.set_up_axis`); a motion of unknown
unit is written as it is. ``.glb`` is one binary file, ``.gltf`` one JSON file with its buffer
inside (a ``data:`` URI).

glTF keys are 32-bit floats (7 digits). So that a motion written and read back here is the
same to 1e-9 (and a BVH -> glTF -> BVH conversion loses nothing), the skin's ``extras``
(``"elastic_motion"``) also keep the BVH channel layout, the end sites, the frame rate and the
float64 rotations and translations; the reader uses them only when the standard channels
agree with them to float32 precision (a file edited by another program is read from its
channels).

Bad files give a :class:`~elastic_motion.errors.ParseError` naming the file and what was
expected: no skin, several skins (pick one with ``skin=``), an animation of morph weights
only, a missing or external buffer that does not exist, an accessor beyond its buffer view or
buffer (checked before anything is allocated), integer data where floats are expected, sparse
accessors.
"""

from __future__ import annotations

import base64
import json
import math
import os
import struct
import urllib.parse
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from elastic_motion import limits
from elastic_motion._io import atomic_write_bytes, atomic_write_text, read_bytes
from elastic_motion.errors import ParseError
from elastic_motion.motion.bvh import snap_fps
from elastic_motion.motion.edit import set_up_axis, to_metres
from elastic_motion.motion.rotations import matrix_to_quaternion, quaternion_slerp, quaternion_to_matrix
from elastic_motion.motion.skeleton import Motion, Skeleton

__all__ = ["GLTF_EXTENSIONS", "read_gltf", "write_gltf"]

#: File extensions of glTF 2.0 (JSON and binary).
GLTF_EXTENSIONS: tuple[str, ...] = (".gltf", ".glb")

_EXTRA = "elastic_motion"
_FLOAT = 5126
#: Normalised integer component types a rotation may use (glTF 2.0, animation samplers).
_NORMALISED = {5120: ("<i1", 127.0), 5121: ("<u1", 255.0), 5122: ("<i2", 32767.0), 5123: ("<u2", 65535.0)}
_COMPONENTS = {"SCALAR": 1, "VEC3": 3, "VEC4": 4, "MAT4": 16}
_INTERPOLATIONS = ("LINEAR", "STEP", "CUBICSPLINE")
_ROT_CHANNELS = ("Zrotation", "Yrotation", "Xrotation")
_POS_CHANNELS = ("Xposition", "Yposition", "Zposition")


def _pygltflib() -> Any:
    try:
        import pygltflib
    except ImportError as exc:
        raise ModuleNotFoundError(
            'glTF files need pygltflib: pip install "elastic-motion[gltf]" (or pip install pygltflib)',
            name="pygltflib",
        ) from exc
    return pygltflib


# -- reading: the container and its buffers --------------------------------------------------------


def _split_glb(path: str, data: bytes) -> tuple[str, bytes | None]:
    """The JSON text and the BIN chunk (or None) of a ``.glb`` file, every length checked."""
    if len(data) < 20:
        raise ParseError(
            path, None, f"expected a GLB header and a JSON chunk (20+ bytes); got {len(data)} bytes"
        )
    _, version, length = struct.unpack_from("<4sII", data, 0)
    if version != 2:
        raise ParseError(path, None, f"expected GLB version 2 (glTF 2.0); got version {version}")
    if length > len(data):
        raise ParseError(
            path, None, f"expected {length} bytes (the GLB header's length); the file has {len(data)}"
        )
    chunks: list[tuple[bytes, bytes]] = []
    pos = 12
    while pos + 8 <= length:
        size, kind = struct.unpack_from("<I4s", data, pos)
        if pos + 8 + size > length:
            raise ParseError(
                path,
                None,
                f"expected a GLB chunk of {size} bytes at byte {pos}; only {length - pos - 8} remain",
            )
        chunks.append((kind, data[pos + 8 : pos + 8 + size]))
        pos += 8 + size + (-size % 4)
    if not chunks or chunks[0][0] != b"JSON":
        raise ParseError(path, None, "expected a JSON chunk first in the GLB file")
    binary = next((c for k, c in chunks[1:] if k == b"BIN\x00"), None)
    try:
        return chunks[0][1].decode("utf-8"), binary
    except UnicodeDecodeError as exc:
        raise ParseError(path, None, f"expected UTF-8 JSON in the GLB's JSON chunk ({exc})") from None


def _load_document(path: str) -> tuple[Any, bytes | None]:
    """The parsed glTF document (pygltflib ``GLTF2``) and the GLB's BIN chunk."""
    pygltflib = _pygltflib()
    data = read_bytes(path)
    binary = None
    if data[:4] == b"glTF":
        text, binary = _split_glb(path, data)
    else:
        try:
            text = data.decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            raise ParseError(path, None, f"expected glTF JSON (UTF-8) or a binary .glb; {exc}") from None
    try:
        raw = json.loads(text)
    except (ValueError, RecursionError) as exc:  # JSONDecodeError, or an integer of > 4300 digits
        line = getattr(exc, "lineno", None)
        raise ParseError(path, line, f"expected glTF 2.0 JSON ({exc})") from None
    asset = raw.get("asset") if isinstance(raw, dict) else None
    if not isinstance(asset, dict) or not str(asset.get("version", "")).startswith("2"):
        raise ParseError(
            path, None, 'expected a glTF 2.0 document (an object with "asset": {"version": "2.0"})'
        )
    try:
        with warnings.catch_warnings():  # dataclasses-json warns of each missing field: checked on use
            warnings.simplefilter("ignore")
            doc = pygltflib.GLTF2.from_dict(raw, infer_missing=True)
    except Exception as exc:  # dataclasses-json raises whatever the types make it raise
        raise ParseError(
            path, None, f"expected glTF 2.0 JSON with the specification's types ({exc})"
        ) from None
    return doc, binary


def _int(path: str, value: Any, what: str, size: int | None = None) -> int:
    """``value`` as a non-negative int (an index below ``size`` when given), else ParseError."""
    if (
        isinstance(value, bool)
        or not isinstance(value, int)
        or value < 0
        or (size is not None and value >= size)
    ):
        bound = f" below {size}" if size is not None else ""
        raise ParseError(path, None, f"expected {what} to be an integer >= 0{bound}; got {value!r}")
    return value


def _floats(path: str, value: Any, n: int, what: str, default: tuple) -> np.ndarray:
    """``value`` as ``n`` finite floats (``default`` when None), else ParseError."""
    if value is None:
        return np.array(default, dtype=np.float64)
    try:
        out = np.array(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        out = np.zeros(0)
    if out.shape != (n,) or not np.isfinite(out).all():
        raise ParseError(path, None, f"expected {what} to be {n} finite numbers; got {value!r}")
    return out


@dataclass
class _Source:
    """The glTF file being read: its document and its buffers, loaded on first use."""

    path: str
    doc: Any
    binary: bytes | None
    buffers: dict[int, bytes] = field(default_factory=dict)
    files: list[str] = field(default_factory=list)

    def error(self, message: str) -> ParseError:
        return ParseError(self.path, None, message)

    def buffer(self, index: int) -> bytes:
        if index not in self.buffers:
            self.buffers[index] = self._load_buffer(index)
        return self.buffers[index]

    def _load_buffer(self, index: int) -> bytes:
        buf = self.doc.buffers[index]
        length = _int(self.path, buf.byteLength, f"buffers[{index}].byteLength")
        uri = buf.uri
        if uri is None:
            if self.binary is None:
                raise self.error(f"buffers[{index}]: expected a uri, or the BIN chunk of a .glb; got neither")
            data = self.binary
        elif not isinstance(uri, str):
            raise self.error(f"buffers[{index}].uri: expected a string; got {uri!r}")
        elif uri.startswith("data:"):
            head, _, body = uri.partition(",")
            if not head.endswith(";base64"):
                raise self.error(f"buffers[{index}]: expected a base64 data: URI; got {uri[:40]!r}")
            try:
                data = base64.b64decode(body, validate=True)
            except ValueError as exc:
                raise self.error(f"buffers[{index}]: expected base64 data in its data: URI ({exc})") from None
        else:
            data = self._external(index, uri)
        if len(data) < length:
            raise self.error(
                f"buffers[{index}]: expected {length} bytes (its byteLength); its data has {len(data)}"
            )
        return data

    def _external(self, index: int, uri: str) -> bytes:
        name = urllib.parse.unquote(uri)
        if ":" in name.split("/")[0] or os.path.isabs(name):
            raise self.error(f"buffers[{index}]: expected a file path relative to the glTF file; got {uri!r}")
        target = Path(self.path).parent / name
        if not target.is_file():
            raise self.error(f"buffers[{index}]: expected the buffer file {str(target)!r}; it does not exist")
        try:
            data = read_bytes(target)
        except ParseError as exc:
            raise self.error(f"buffers[{index}]: cannot read its file: {exc}") from None
        self.files.append(os.fspath(target))
        return data


def _accessor(
    src: _Source, index: Any, what: str, types: tuple[str, ...], normalised: bool = False
) -> np.ndarray:
    """Accessor ``index`` as float64 ``(count, components)``; every bound checked before the copy.

    ``normalised``: normalised integers are accepted (rotations, per the specification)."""
    doc = src.doc
    i = _int(src.path, index, f"the accessor of {what}", len(doc.accessors))
    acc = doc.accessors[i]
    where = f"accessors[{i}] ({what})"
    if acc.type not in types:
        raise src.error(f"{where}: expected type {' or '.join(types)}; got {acc.type!r}")
    if acc.sparse is not None:
        raise src.error(f"{where}: expected a plain accessor; got a sparse one (not supported)")
    if acc.componentType == _FLOAT:
        dtype, scale = "<f4", None
    elif normalised and acc.normalized and acc.componentType in _NORMALISED:
        dtype, scale = _NORMALISED[acc.componentType]
    else:
        raise src.error(
            f"{where}: expected float components (componentType {_FLOAT})"
            + (" or normalised integers" if normalised else "")
            + f"; got componentType {acc.componentType!r}"
        )
    if acc.bufferView is None:
        raise src.error(f"{where}: expected a bufferView (an accessor of zeros holds no animation)")
    count = _int(src.path, acc.count, f"{where}.count")
    if count == 0:
        raise src.error(f"{where}: expected at least one element; got count 0")
    width = _COMPONENTS[acc.type]
    itemsize = np.dtype(dtype).itemsize
    view, data = _view_bytes(src, acc.bufferView, where)
    stride = view.byteStride if view.byteStride is not None else width * itemsize
    stride = _int(src.path, stride, f"the byteStride of {where}")
    offset = _int(src.path, acc.byteOffset or 0, f"{where}.byteOffset")
    need = offset + stride * (count - 1) + width * itemsize
    if stride < width * itemsize or need > len(data):
        raise src.error(
            f"{where}: expected {count} elements of {width * itemsize} bytes (stride {stride}) from byte "
            f"{offset} to fit its bufferView of {len(data)} bytes; they need {need}"
        )
    raw = np.ndarray((count, width), dtype=dtype, buffer=data, offset=offset, strides=(stride, itemsize))
    out = raw.astype(np.float64)
    if scale is not None:
        out = np.maximum(out / scale, -1.0)
    if not np.isfinite(out).all():
        raise src.error(f"{where}: expected finite numbers; found NaN or infinity")
    return out


def _view_bytes(src: _Source, index: Any, where: str) -> tuple[Any, memoryview]:
    """The bufferView ``index`` and its bytes (checked to lie inside its buffer)."""
    doc = src.doc
    v = _int(src.path, index, f"the bufferView of {where}", len(doc.bufferViews))
    view = doc.bufferViews[v]
    b = _int(src.path, view.buffer, f"bufferViews[{v}].buffer", len(doc.buffers))
    start = _int(src.path, view.byteOffset or 0, f"bufferViews[{v}].byteOffset")
    length = _int(src.path, view.byteLength, f"bufferViews[{v}].byteLength")
    declared = _int(src.path, doc.buffers[b].byteLength, f"buffers[{b}].byteLength")
    if start + length > declared:
        raise src.error(
            f"bufferViews[{v}] ({where}): expected bytes {start}..{start + length} to lie inside "
            f"buffers[{b}] of {declared} bytes"
        )
    data = src.buffer(b)
    return view, memoryview(data)[start : start + length]


# -- reading: the skeleton ---------------------------------------------------------------------------


def _choose(src: _Source, items: list, wanted: Any, what: str, hint: str) -> int:
    """Index of the item named or numbered ``wanted``; the only one when ``wanted`` is None."""
    names = [getattr(x, "name", None) for x in items]
    if wanted is None:
        if len(items) == 1:
            return 0
        raise src.error(
            f"expected one {what}; found {len(items)} ({names}): pick one with {what}=NAME or INDEX ({hint})"
        )
    if isinstance(wanted, int) and not isinstance(wanted, bool) and 0 <= wanted < len(items):
        return wanted
    if wanted in names:
        return names.index(wanted)
    raise src.error(f"{what}={wanted!r}: expected an index below {len(items)} or one of {names}")


def _parents(src: _Source) -> list[int]:
    """Parent node of every node (-1 for none); ParseError for a node with two parents."""
    nodes = src.doc.nodes
    parent = [-1] * len(nodes)
    for n, node in enumerate(nodes):
        for c in node.children or []:
            c = _int(src.path, c, f"a child of nodes[{n}]", len(nodes))
            if parent[c] != -1 or c == n:
                raise src.error(f"nodes[{c}]: expected one parent node; it is a child of {parent[c]} and {n}")
            parent[c] = n
    return parent


def _chain(src: _Source, parent: list[int], n: int) -> list[int]:
    """``n`` and its ancestors, nearest first (a cycle is a ParseError)."""
    out = [n]
    while parent[out[-1]] != -1:
        out.append(parent[out[-1]])
        if len(out) > len(parent):
            raise src.error(f"nodes[{n}]: expected a tree of nodes; its ancestors form a cycle")
    return out


def _joint_nodes(src: _Source, skin_index: int, parent: list[int]) -> tuple[list[int], int]:
    """The skin's joints with the nodes between them and their common ancestor (the root)."""
    skin = src.doc.skins[skin_index]
    joints = [
        _int(src.path, j, f"a joint of skins[{skin_index}]", len(src.doc.nodes)) for j in skin.joints or []
    ]
    if not joints:
        raise src.error(f"skins[{skin_index}]: expected a list of joints; got none")
    chains = [_chain(src, parent, j) for j in joints]
    common = set(chains[0])
    for c in chains[1:]:
        common &= set(c)
    if not common:
        raise src.error(
            f"skins[{skin_index}]: expected its joints in one tree of nodes; they have no common ancestor"
        )
    root = next(n for n in chains[0] if n in common)
    included = {root}
    for c in chains:
        included.update(c[: c.index(root)])
    return sorted(included), root


def _order(included: list[int], parent: list[int], root: int, nodes: list) -> list[int]:
    """Joint order: node order when every parent comes first, else depth-first from the root."""
    if all(n == root or parent[n] < n for n in included):
        return [root, *[n for n in included if n != root]]
    inside = set(included)
    out, todo = [], [root]
    while todo:
        n = todo.pop()
        out.append(n)
        todo.extend(reversed([c for c in nodes[n].children or [] if c in inside]))
    return out


def _rest_transform(src: _Source, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Node ``n``'s rest (translation (3,), rotation matrix (3, 3), scale (3,))."""
    node = src.doc.nodes[n]
    if node.matrix is not None:
        m = _floats(src.path, node.matrix, 16, f"nodes[{n}].matrix", ()).reshape(4, 4).T
        scale = np.linalg.norm(m[:3, :3], axis=0)
        if not (scale > 0).all() or np.linalg.det(m[:3, :3]) <= 0:
            raise src.error(f"nodes[{n}].matrix: expected a rotation with positive scale; got {node.matrix}")
        return m[:3, 3].copy(), m[:3, :3] / scale, scale
    t = _floats(src.path, node.translation, 3, f"nodes[{n}].translation", (0.0, 0.0, 0.0))
    q = _floats(src.path, node.rotation, 4, f"nodes[{n}].rotation", (0.0, 0.0, 0.0, 1.0))
    s = _floats(src.path, node.scale, 3, f"nodes[{n}].scale", (1.0, 1.0, 1.0))
    if not np.linalg.norm(q) > 0:
        raise src.error(f"nodes[{n}].rotation: expected a non-zero quaternion; got {node.rotation}")
    return t, quaternion_to_matrix(np.roll(q, 1)), s


def _ancestor_transform(src: _Source, parent: list[int], root: int) -> tuple[np.ndarray, np.ndarray, float]:
    """World (rotation, translation, uniform scale) of the nodes above ``root`` (their rest pose)."""
    rot, shift, scale = np.eye(3), np.zeros(3), 1.0
    for n in _chain(src, parent, root)[1:]:  # nearest ancestor first: x -> T + s R x applied outwards
        t, r, s = _rest_transform(src, n)
        if np.ptp(s) > 1e-6 * s.max():
            raise src.error(
                f"nodes[{n}] (above the skeleton's root): expected a uniform scale; got {s.tolist()}"
            )
        rot, shift, scale = r @ rot, t + s[0] * (r @ shift), s[0] * scale
    return rot, shift, scale


# -- reading: the animation ----------------------------------------------------------------------------


@dataclass
class _Channel:
    node: int
    path: str  # "rotation" or "translation"
    times: np.ndarray  # (K,)
    values: np.ndarray  # (K, n) or (3K, n) for CUBICSPLINE
    interpolation: str


def _target_node(target: Any) -> int | None:
    """The node a channel's target names, None when it names none (or not as an integer)."""
    node = getattr(target, "node", None)
    return node if isinstance(node, int) and not isinstance(node, bool) else None


def _choose_animation(src: _Source, included: set[int], wanted: Any) -> int:
    """The animation to read: ``wanted``, else the first that moves the skeleton's nodes."""
    anims = src.doc.animations
    if not anims:
        raise src.error("expected an animation of the skin's joints; the file has no animations")
    if wanted is not None:
        return _choose(src, anims, wanted, "animation", "")
    paths: set[str] = set()
    for a, anim in enumerate(anims):
        for ch in anim.channels or []:
            target = ch.target
            if _target_node(target) in included and target.path in ("rotation", "translation"):
                return a
            paths.add(str(getattr(target, "path", None)))
    if paths == {"weights"}:
        raise src.error(
            "expected an animation of the skin's joints (rotation / translation channels); the "
            "animations move morph target weights only"
        )
    raise src.error(
        f"expected an animation with rotation or translation channels on the skin's joints; the "
        f"{len(anims)} animation(s) animate only {sorted(paths)} of other nodes"
    )


def _channels(src: _Source, a: int, included: set[int]) -> list[_Channel]:
    """The rotation / translation (and unit-scale) channels of animation ``a`` on ``included``."""
    anim = src.doc.animations[a]
    samplers = anim.samplers or []
    out = []
    for c, ch in enumerate(anim.channels or []):
        target = ch.target
        if _target_node(target) not in included or target.path not in ("rotation", "translation", "scale"):
            continue
        where = f"animations[{a}].channels[{c}]"
        sampler = samplers[_int(src.path, ch.sampler, f"{where}.sampler", len(samplers))]
        interp = sampler.interpolation or "LINEAR"
        if interp not in _INTERPOLATIONS:
            raise src.error(f"{where}: expected interpolation LINEAR, STEP or CUBICSPLINE; got {interp!r}")
        times = _accessor(src, sampler.input, f"{where} key times", ("SCALAR",))[:, 0]
        if not (np.diff(times) > 0).all():
            raise src.error(f"{where}: expected strictly increasing key times; got {times[:8].tolist()}...")
        kind = "VEC4" if target.path == "rotation" else "VEC3"
        values = _accessor(src, sampler.output, f"{where} {target.path}", (kind,), target.path == "rotation")
        expected = times.size * (3 if interp == "CUBICSPLINE" else 1)
        if values.shape[0] != expected:
            raise src.error(f"{where}: expected {expected} output values ({interp}); got {values.shape[0]}")
        if target.path == "scale":
            if np.abs(values - 1.0).max() > 1e-4:
                raise src.error(
                    f"{where}: expected unit scale on the skeleton's joints; got up to {values.max():g}"
                )
            continue
        if target.path == "rotation":  # the key values (CUBICSPLINE: not its tangents)
            keys = values[1::3] if interp == "CUBICSPLINE" else values
            norms = np.linalg.norm(keys, axis=1)
            if keys.size and not (norms > 1e-6).all():
                k = int(np.argmin(norms))
                raise src.error(
                    f"{where}: expected unit quaternions (x, y, z, w); key {k} is {keys[k].tolist()}"
                )
        out.append(_Channel(target.node, target.path, times, values, interp))
    return out


def _timeline(src: _Source, channels: list[_Channel], fps: float | None, n_joints: int) -> tuple:
    """``(times, fps)``: the uniform sampling times (s) from the first key to the last and their
    rate, checked against the limits."""
    keys = np.unique(np.concatenate([c.times for c in channels]))
    start, stop = float(keys[0]), float(keys[-1])
    if fps is None:
        steps = np.diff(keys)
        fps = snap_fps(float(np.median(steps))) if steps.size else 30.0
    limits.check_clip(src.path, None, fps=fps, duration=stop - start, joints=n_joints)
    n = math.floor((stop - start) * fps + 0.01) + 1  # keys stored as float32: 1e6 frames are 0.06 off
    lim = limits.current()
    grown = lim.max_resample_growth * keys.size + 1000
    if n > grown:
        raise src.error(
            limits.limit_message(
                f"a uniform sampling at {fps:g} fps of {keys.size} key times to give a number of frames",
                n,
                "max_resample_growth",
                f"{lim.max_resample_growth:g} x {keys.size} + 1000 = {grown:g}",
            )
        )
    limits.check_clip(src.path, None, frames=n, joints=n_joints)
    return start + np.arange(n) / fps, fps


def _sample(ch: _Channel, grid: np.ndarray) -> np.ndarray:
    """Channel values at the times ``grid``: ``(n, 3)`` translations or ``(n, 4)`` xyzw quaternions."""
    t, v = ch.times, ch.values
    rotation = ch.path == "rotation"
    k = t.size
    if ch.interpolation == "CUBICSPLINE":
        a_in, v, b_out = v[0::3], v[1::3], v[2::3]
    # a sample within 1e-4 of a step of a key is at that key (keys are float32, samples float64)
    tol = 1e-4 * (grid[1] - grid[0]) if grid.size > 1 else 0.0
    if k == 1:
        out = np.repeat(v[:1], grid.size, axis=0)
    elif ch.interpolation == "STEP":
        out = v[np.clip(np.searchsorted(t, grid + tol, side="right") - 1, 0, k - 1)]
    else:
        seg = np.clip(np.searchsorted(t, grid + tol, side="right") - 1, 0, k - 2)
        dt = t[seg + 1] - t[seg]
        u = np.clip((grid - t[seg]) / dt, 0.0, 1.0)
        if ch.interpolation == "CUBICSPLINE":
            u2, u3 = u * u, u * u * u
            h = [2 * u3 - 3 * u2 + 1, (u3 - 2 * u2 + u) * dt, -2 * u3 + 3 * u2, (u3 - u2) * dt]
            out = sum(
                w[:, None] * x
                for w, x in zip(h, (v[seg], b_out[seg], v[seg + 1], a_in[seg + 1]), strict=True)
            )
        elif rotation:
            out = quaternion_slerp(_unit(v[seg]), _unit(v[seg + 1]), u)
        else:
            out = v[seg] + u[:, None] * (v[seg + 1] - v[seg])
    return _unit(out) if rotation else out


def _unit(q: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(q, axis=-1, keepdims=True)
    return q / np.where(n > 0, n, 1.0)


# -- reading: the motion ----------------------------------------------------------------------------------


def _local_frames(src: _Source, order: list[int], channels: list[_Channel], grid: np.ndarray) -> tuple:
    """Per-frame local rotations ``(F, J, 3, 3)`` and translations ``(F, J, 3)`` of the nodes
    (rest values where no channel), the rest ones, and which joints have animated translations."""
    f, j = grid.size, len(order)
    at = {n: i for i, n in enumerate(order)}
    rest = [_rest_transform(src, n) for n in order]
    for i, (_, _, s) in enumerate(rest):
        if np.abs(s - 1.0).max() > 1e-4:
            raise src.error(f"nodes[{order[i]}] (a joint): expected unit scale; got {s.tolist()}")
    rest_t = np.array([r[0] for r in rest])
    rest_r = np.array([r[1] for r in rest])
    trans = np.repeat(rest_t[None], f, axis=0)
    rots = np.repeat(rest_r[None], f, axis=0)
    moved = np.zeros(j, dtype=bool)
    for ch in channels:
        values = _sample(ch, grid)
        i = at[ch.node]
        if ch.path == "rotation":
            if not (np.linalg.norm(values, axis=-1) > 0).all():
                raise src.error(f"nodes[{ch.node}]: expected non-zero rotation quaternions in its animation")
            rots[:, i] = quaternion_to_matrix(np.roll(values, 1, axis=-1))
        else:
            trans[:, i] = values
            moved[i] = True
    return rots, trans, rest_t, rest_r, moved


def _to_motion_frame(order: list[int], parent: list[int], frames: tuple, ancestors: tuple) -> tuple:
    """Rotations, translations and offsets in our convention (rest pose: identity rotations,
    offsets in the rest pose's world axes); the ancestors' transform folded into the root."""
    rots, trans, rest_t, rest_r, _ = frames
    a_rot, a_shift, a_scale = ancestors
    j = len(order)
    at = {n: i for i, n in enumerate(order)}
    par = np.array([-1] + [at[parent[n]] for n in order[1:]])
    trans = trans * a_scale
    rest_t = rest_t * a_scale
    rots = rots.copy()
    rots[:, 0] = a_rot @ rots[:, 0]
    trans[:, 0] = a_shift + trans[:, 0] @ a_rot.T
    rest_world = np.empty((j, 3, 3))
    rest_world[0] = a_rot @ rest_r[0]
    for i in range(1, j):
        rest_world[i] = rest_world[par[i]] @ rest_r[i]
    up = np.concatenate([np.eye(3)[None], rest_world[par[1:]]])  # rest world rotation of each parent
    local = up[None] @ rots @ np.swapaxes(rest_world, -1, -2)[None]
    offsets = np.einsum("jab,jb->ja", up, rest_t)
    trans_ours = np.einsum("jab,fjb->fja", up, trans)
    trans_ours[:, 0] = trans[:, 0]
    return par, local, trans_ours, offsets


def _layout(extra: dict, names: list[str], moving: np.ndarray) -> tuple[list, np.ndarray, np.ndarray]:
    """BVH channels per joint and end sites: the file's own (our ``extras``) when they fit."""
    j = len(names)
    channels = [
        (*_POS_CHANNELS, *_ROT_CHANNELS) if (i == 0 or moving[i]) else _ROT_CHANNELS for i in range(j)
    ]
    es_p, es_o = np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    try:
        saved = [tuple(str(c) for c in ch) for ch in extra.get("channels", [])]
        if len(saved) == j and all(
            bool(set(ch) & set(_POS_CHANNELS)) >= moving[i] for i, ch in enumerate(saved)
        ):
            Skeleton(names, [-1, *([0] * (j - 1))], np.zeros((j, 3)), saved)  # validates the channel names
            channels = saved
        p = np.array(extra.get("end_site_parents", []), dtype=np.int64).reshape(-1)
        o = np.array(extra.get("end_site_offsets", []), dtype=np.float64).reshape(-1, 3)
        if p.size == o.shape[0] and ((p >= 0) & (p < j)).all() and np.isfinite(o).all():
            es_p, es_o = p, o
    except (TypeError, ValueError, AttributeError):
        pass
    return channels, es_p, es_o


def _exact(
    src: _Source, extra: dict, channels: list[_Channel], order: list[int], moving: list[int]
) -> tuple | None:
    """The float64 rotations ``(F, J, 3, 3)`` and translations ``(F, len(moving), 3)`` our writer
    keeps in ``extras``: only for a file laid out as ours (node ``k`` is joint ``k``; the caller
    checks: identity rest rotations, nothing above the root) whose channels hold, key for key,
    the same values to float32 precision; else None."""
    spec = extra.get("exact")
    j = len(order)
    if not isinstance(spec, dict) or order != list(range(j)) or spec.get("translation_joints") != moving:
        return None
    f = spec.get("frames")
    try:
        _, data = _view_bytes(src, spec.get("bufferView"), "the exact values in the skin's extras")
    except ParseError:
        return None
    if not isinstance(f, int) or f < 1 or len(data) != 8 * f * (4 * j + 3 * len(moving)):
        return None
    values = np.frombuffer(data, dtype="<f8")
    quats = values[: f * j * 4].reshape(f, j, 4)  # (w, x, y, z)
    trans = values[f * j * 4 :].reshape(f, len(moving), 3)
    seen = set()
    for ch in channels:
        if ch.interpolation != "LINEAR" or ch.times.size != f:
            return None
        if ch.path == "rotation":
            want = np.roll(quats[:, ch.node], -1, axis=-1)
        elif ch.node in moving:
            want = trans[:, moving.index(ch.node)]
        else:
            return None
        if not np.abs(ch.values - want).max() <= 1e-6 * (1.0 + np.abs(want).max()):
            return None
        seen.add((ch.node, ch.path))
    if len(seen) != j + len(moving):
        return None
    return quaternion_to_matrix(quats), trans


def read_gltf(
    path: str | os.PathLike[str],
    *,
    skin: int | str | None = None,
    animation: int | str | None = None,
    fps: float | None = None,
) -> Motion:
    """Read the skeletal animation of a glTF 2.0 file (``.gltf`` or ``.glb``).

    Parameters
    ----------
    path : str or os.PathLike
    skin : int or str, optional
        Index or name of the skin to read; needed when the file has several.
    animation : int or str, optional
        Index or name of the animation; default the first that moves the skin's joints.
    fps : float, optional
        Frame rate of the uniform sampling; default the rate of the keys.

    Returns
    -------
    Motion
        Metres, Y up; per-frame rotations of every joint and the root's translation
        (module docstring for the rest pose).

    Raises
    ------
    ParseError
        For a file that is not glTF 2.0, has no skin or several (without ``skin=``), no
        animation of the skin's joints (only morph weights, say), a missing buffer, an
        accessor beyond its buffer or of integer type, a clip beyond the resource limits.
    ModuleNotFoundError
        Without pygltflib (``pip install "elastic-motion[gltf]"``).
    """
    p = os.fspath(path)
    doc, binary = _load_document(p)
    src = _Source(p, doc, binary)
    try:
        return _read(src, skin, animation, fps)
    except (TypeError, AttributeError, KeyError, IndexError) as exc:  # a value of the wrong JSON type
        raise src.error(
            f"expected glTF 2.0 objects with the specification's types ({type(exc).__name__}: {exc})"
        ) from None


def _read(src: _Source, skin: int | str | None, animation: int | str | None, fps: float | None) -> Motion:
    """:func:`read_gltf` on the parsed document."""
    p, doc = src.path, src.doc
    if not doc.skins:
        raise src.error(
            "expected a skin (a skeleton: skins[].joints); found none (meshes without a skeleton?)"
        )
    s = _choose(src, doc.skins, skin, "skin", "in Python: read_motion(path, skin=...)")
    parent = _parents(src)
    included, root = _joint_nodes(src, s, parent)
    a = _choose_animation(src, set(included), animation)
    order = _order(included, parent, root, doc.nodes)
    limits.check_clip(p, None, joints=len(order))
    channels = _channels(src, a, set(included))
    if not channels:
        raise src.error(
            f"animations[{a}]: expected rotation or translation channels on the skin's joints; got none"
        )
    extra = (doc.skins[s].extras or {}).get(_EXTRA, {}) if isinstance(doc.skins[s].extras, dict) else {}
    extra = extra if isinstance(extra, dict) else {}
    saved_fps = extra.get("fps")
    if fps is None and isinstance(saved_fps, int | float) and limits.current().min_fps <= saved_fps <= 1e6:
        fps = float(saved_fps)
    grid, fps = _timeline(src, channels, fps, len(order))
    frames = _local_frames(src, order, channels, grid)
    par, local, trans, offsets = _to_motion_frame(
        order, parent, frames, _ancestor_transform(src, parent, root)
    )
    # translated away from the rest value by more than float32 rounding (Blender keys every bone's)
    moved = frames[4] & (np.abs(trans - offsets[None]).max(axis=(0, 2)) > 1e-6 * (1 + np.abs(offsets).max()))
    moved[0] = False
    animated = [0, *[int(i) for i in np.flatnonzero(frames[4]) if i > 0]]
    plain = np.array_equal(frames[3], np.broadcast_to(np.eye(3), frames[3].shape)) and parent[root] == -1
    exact = _exact(src, extra, channels, order, animated) if plain else None
    if exact is not None and exact[0].shape[0] == local.shape[0]:
        local, trans[:, animated] = exact[0], exact[1]
        offsets[0] = _floats(p, extra.get("root_offset"), 3, "the root offset in extras", tuple(offsets[0]))
    names = _names(doc, order)
    channels_out, es_p, es_o = _layout(extra, names, moved)
    skeleton = Skeleton(names, par, offsets, channels_out, es_p, es_o)
    with_positions = skeleton.has_position_channels[1:].any()
    return Motion(
        skeleton=skeleton,
        fps=fps,
        root_translation=trans[:, 0],
        rotations=local,
        joint_translations=trans if with_positions else None,
        metres_per_unit=1.0,
        up_axis="y",
        source=(p, *src.files),
        name=Path(p).stem,
    )


def _names(doc: Any, order: list[int]) -> list[str]:
    """Joint names: the nodes' names, ``node<i>`` for a missing one, ``~2`` etc. for repeats."""
    out: list[str] = []
    seen: set[str] = set()
    for n in order:
        base = doc.nodes[n].name if isinstance(doc.nodes[n].name, str) and doc.nodes[n].name else f"node{n}"
        name, k = base, 2
        while name in seen:
            name, k = f"{base}~{k}", k + 1
        seen.add(name)
        out.append(name)
    return out


# -- writing --------------------------------------------------------------------------------------------


class _Blob:
    """The one buffer of a written file: its bytes, bufferViews and accessors (pygltflib objects)."""

    def __init__(self, pygltflib: Any) -> None:
        self.lib = pygltflib
        self.data = bytearray()
        self.views: list = []
        self.accessors: list = []

    def view(self, raw: bytes) -> int:
        self.data += b"\0" * (-len(self.data) % 8)
        self.views.append(self.lib.BufferView(buffer=0, byteOffset=len(self.data), byteLength=len(raw)))
        self.data += raw
        return len(self.views) - 1

    def accessor(self, values: np.ndarray, kind: str, bounds: bool = False) -> int:
        values = np.ascontiguousarray(values, dtype="<f4")
        acc = self.lib.Accessor(
            bufferView=self.view(values.tobytes()),
            componentType=_FLOAT,
            count=int(values.shape[0]),
            type=kind,
        )
        if bounds:
            flat = values.reshape(values.shape[0], -1)
            acc.min, acc.max = flat.min(axis=0).tolist(), flat.max(axis=0).tolist()
        self.accessors.append(acc)
        return len(self.accessors) - 1


def _continuous(q: np.ndarray) -> np.ndarray:
    """Quaternions ``(F, J, 4)`` with signs flipped so that consecutive ones are on the same side
    (players interpolate the stored components: ``q`` and ``-q`` are the same rotation)."""
    flips = np.sum(q[1:] * q[:-1], axis=-1) < 0
    sign = np.concatenate([np.ones((1, q.shape[1])), np.cumprod(np.where(flips, -1.0, 1.0), axis=0)])
    return q * sign[..., None]


def _written_motion(motion: Motion) -> Motion:
    """The motion as glTF stores it: metres (when the unit is known), +Y up."""
    if motion.metres_per_unit is not None and motion.metres_per_unit != 1.0:
        motion = to_metres(motion)
    return set_up_axis(motion, "y")


def _animation(
    lib: Any, blob: _Blob, motion: Motion, moving: list[int]
) -> tuple[Any, np.ndarray, np.ndarray]:
    """The animation (a LINEAR channel per joint rotation and moving joint's translation) and the
    float64 quaternions (x, y, z, w) and translations it holds."""
    j = motion.n_joints
    times = blob.accessor(motion.times[:, None], "SCALAR", bounds=True)
    q = _continuous(np.roll(matrix_to_quaternion(motion.rotations), -1, axis=-1))
    translations = motion.local_translations()[:, moving]
    anim = lib.Animation(name=motion.name or "motion")
    for k in range(j):
        anim.samplers.append(
            lib.AnimationSampler(input=times, output=blob.accessor(q[:, k], "VEC4"), interpolation="LINEAR")
        )
        target = lib.AnimationChannelTarget(node=k, path="rotation")
        anim.channels.append(lib.AnimationChannel(sampler=len(anim.samplers) - 1, target=target))
    for i, k in enumerate(moving):
        anim.samplers.append(
            lib.AnimationSampler(
                input=times, output=blob.accessor(translations[:, i], "VEC3"), interpolation="LINEAR"
            )
        )
        target = lib.AnimationChannelTarget(node=k, path="translation")
        anim.channels.append(lib.AnimationChannel(sampler=len(anim.samplers) - 1, target=target))
    return anim, q, translations


def _document(motion: Motion) -> tuple[Any, bytes]:
    """The pygltflib document of ``motion`` (already in metres, Y up) and its buffer's bytes."""
    lib = _pygltflib()
    sk = motion.skeleton
    j = sk.n_joints
    blob = _Blob(lib)
    rest = motion.local_translations()[0]
    moving = [
        0,
        *[
            int(k)
            for k in np.flatnonzero(sk.has_position_channels)
            if k > 0 and motion.joint_translations is not None
        ],
    ]
    nodes = [
        lib.Node(name=sk.names[k], translation=[float(v) for v in (rest[k] if k == 0 else sk.offsets[k])])
        for k in range(j)
    ]
    for k in range(1, j):
        nodes[int(sk.parents[k])].children.append(k)
    world = np.zeros((j, 3))  # rest pose: identity rotations
    for k in range(j):
        world[k] = np.array(nodes[k].translation) + (world[sk.parents[k]] if k else 0.0)
    ibm = np.repeat(np.eye(4)[None], j, axis=0)
    ibm[:, :3, 3] = -world
    ibm_acc = blob.accessor(np.swapaxes(ibm, 1, 2).reshape(j, 16), "MAT4")  # column-major
    anim, q, translations = _animation(lib, blob, motion, moving)
    exact = blob.view(
        np.concatenate([np.roll(q, 1, axis=-1).ravel(), translations.ravel()]).astype("<f8").tobytes()
    )
    extra = {
        "fps": motion.fps,
        "channels": [list(ch) for ch in sk.channels],
        "end_site_parents": sk.end_site_parents.tolist(),
        "end_site_offsets": sk.end_site_offsets.tolist(),
        "root_offset": sk.offsets[0].tolist(),
        "exact": {"bufferView": exact, "frames": motion.n_frames, "translation_joints": moving},
    }
    skin = lib.Skin(name=sk.names[0], joints=list(range(j)), skeleton=0, inverseBindMatrices=ibm_acc)
    skin.extras = {_EXTRA: extra}
    doc = lib.GLTF2(
        asset=lib.Asset(version="2.0", generator="elastic-motion"),
        scene=0,
        scenes=[lib.Scene(nodes=[0])],
        nodes=nodes,
        skins=[skin],
        animations=[anim],
        accessors=blob.accessors,
        bufferViews=blob.views,
        buffers=[lib.Buffer(byteLength=len(blob.data))],
    )
    return doc, bytes(blob.data)


def write_gltf(
    motion: Motion,
    path: str | os.PathLike[str],
    *,
    protected: list[str | os.PathLike[str]] | tuple = (),
) -> Path:
    """Write a motion as glTF 2.0 skeletal animation, atomically (module docstring).

    Parameters
    ----------
    motion : Motion
    path : str or os.PathLike
        ``.glb`` (binary) or ``.gltf`` (JSON, buffer inside); refused (``ValueError``) if it
        is one of ``motion.source`` or ``protected``.
    protected : sequence of paths, optional
        Further files that must not be overwritten.

    Returns
    -------
    pathlib.Path
        The written path.

    Raises
    ------
    ValueError
        For another extension, or a path that is an input.
    ModuleNotFoundError
        Without pygltflib (``pip install "elastic-motion[gltf]"``).
    """
    ext = Path(path).suffix.lower()
    if ext not in GLTF_EXTENSIONS:
        raise ValueError(f"path: expected a .gltf or .glb file name; got {os.fspath(path)!r}")
    doc, data = _document(_written_motion(motion))
    keep = [*motion.source, *protected]
    if ext == ".glb":
        doc.set_binary_blob(data)
        return atomic_write_bytes(path, b"".join(doc.save_to_bytes()), protected=keep)
    doc.buffers[0].uri = "data:application/octet-stream;base64," + base64.b64encode(data).decode("ascii")
    return atomic_write_text(path, doc.gltf_to_json(), protected=keep)
