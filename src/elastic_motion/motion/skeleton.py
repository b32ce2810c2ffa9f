"""The data model: :class:`Skeleton` (the hierarchy) and :class:`Motion` (a clip on it).

Conventions
-----------
* **Joints** are numbered ``0 .. J-1`` in topological order: ``parents[j] < j``, joint 0
  is the root (``parents[0] = -1``). In a BVH file this is the file order of ``ROOT`` and
  ``JOINT`` blocks. End sites are not joints; they are stored apart (parent joint + offset).
* **Rotations** are matrices ``(3, 3)`` acting on column vectors. ``Motion.rotations[f, j]``
  is joint ``j``'s rotation relative to its parent, and forward kinematics composes
  ``global[j] = global[parents[j]] @ rotations[:, j]`` (root: its own rotation),
  ``position[j] = position[parents[j]] + global[parents[j]] @ translation[j]``.
* **Translations**: a joint's local translation is its ``offset`` (rest-pose vector from the
  parent joint, in the parent's frame), except for joints with position channels, whose
  translation is read from the channels each frame and *replaces* the offset (the axes
  without a channel keep the offset's value). The root's translation is
  ``Motion.root_translation``; other joints with position channels (e.g. the Bandai files,
  six channels on every joint) keep theirs in ``Motion.joint_translations``.
* **Channels** (per joint) are BVH channel names, e.g. ``("Xposition", "Yposition",
  "Zposition", "Zrotation", "Yrotation", "Xrotation")``. The rotation channels, in order,
  give the joint's **intrinsic Euler order** (``"ZYX"`` means ``R = Rz @ Ry @ Rx``); a joint
  with fewer than three rotation channels gets the missing axes appended in ``X, Y, Z``
  order (:attr:`Skeleton.euler_orders`), so every joint has a full three-angle order.
* **Units**: lengths are in the file's units; ``Motion.metres_per_unit`` converts them
  (``None`` if unknown). Angles in files are degrees (BVH, AMC by default) or radians
  (DeepMimic); inside a Motion there are only rotation matrices.
* **Up axis**: ``Motion.up_axis`` is ``"x"``, ``"y"`` or ``"z"`` (positive direction). All the
  formats read here are Y-up.
* **Quaternions**, wherever they appear (DeepMimic files), are **(w, x, y, z)**.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "POSITION_CHANNELS",
    "ROTATION_CHANNELS",
    "UNITS",
    "Motion",
    "Skeleton",
]

#: BVH channel names, keyed to the axis they move.
POSITION_CHANNELS = {"Xposition": 0, "Yposition": 1, "Zposition": 2}
ROTATION_CHANNELS = {"Xrotation": "X", "Yrotation": "Y", "Zrotation": "Z"}

#: Named length units and their size in metres. ``"cmu"`` is the unit of the CMU database
#: (ASF ``:units length 0.45``: one unit is 1/0.45 inch = 0.05644 m); the cgspeed BVH
#: conversions of CMU keep it.
UNITS = {
    "m": 1.0,
    "cm": 0.01,
    "mm": 0.001,
    "inch": 0.0254,
    "cmu": 0.0254 / 0.45,
}


def _ro(arr: np.ndarray) -> np.ndarray:
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class Skeleton:
    """A joint hierarchy with rest offsets and a per-joint channel layout.

    Parameters
    ----------
    names : sequence of str, length J
        Unique joint names; joint 0 is the root.
    parents : array_like of int, shape (J,)
        Parent index of each joint, ``-1`` for the root; ``parents[j] < j``.
    offsets : array_like, shape (J, 3)
        Rest-pose translation of each joint from its parent, in the parent's frame
        (file length units). The root's offset is used only when it has no position
        channels.
    channels : sequence of sequence of str, length J
        BVH channel names of each joint in file order (0 to 6 of them, no repeats).
    end_site_parents : array_like of int, shape (E,), optional
        Joint each end site hangs from.
    end_site_offsets : array_like, shape (E, 3), optional
        Offset of each end site from its joint, in the joint's frame.

    Raises
    ------
    ValueError
        For inconsistent lengths, a parent that does not precede its child, repeated
        names, unknown or repeated channels.
    """

    names: tuple[str, ...]
    parents: np.ndarray
    offsets: np.ndarray
    channels: tuple[tuple[str, ...], ...]
    end_site_parents: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    end_site_offsets: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    def __post_init__(self) -> None:
        names = tuple(str(n) for n in self.names)
        n = len(names)
        if n == 0:
            raise ValueError("names: expected at least one joint (the root); got none")
        parents = np.array(self.parents, dtype=np.int64).reshape(-1)
        offsets = np.array(self.offsets, dtype=np.float64)
        channels = tuple(tuple(str(c) for c in ch) for ch in self.channels)
        es_parents = np.array(self.end_site_parents, dtype=np.int64).reshape(-1)
        es_offsets = np.array(self.end_site_offsets, dtype=np.float64).reshape(-1, 3)
        if parents.shape != (n,):
            raise ValueError(f"parents: expected shape ({n},) (one per joint); got {parents.shape}")
        if offsets.shape != (n, 3):
            raise ValueError(f"offsets: expected shape ({n}, 3); got {offsets.shape}")
        if len(channels) != n:
            raise ValueError(f"channels: expected {n} channel lists (one per joint); got {len(channels)}")
        if parents[0] != -1:
            raise ValueError(f"parents: expected parents[0] = -1 (joint 0 is the root); got {parents[0]}")
        idx = np.arange(n)
        bad = (parents[1:] < 0) | (parents[1:] >= idx[1:])
        if bad.any():
            j = int(np.argmax(bad)) + 1
            raise ValueError(
                f"parents: expected 0 <= parents[j] < j for j >= 1 (topological order); "
                f"parents[{j}] = {parents[j]}"
            )
        if len(set(names)) != n:
            seen: set[str] = set()
            dup = next(x for x in names if x in seen or seen.add(x))
            raise ValueError(f"names: expected unique joint names; {dup!r} appears twice")
        for j, ch in enumerate(channels):
            for c in ch:
                if c not in POSITION_CHANNELS and c not in ROTATION_CHANNELS:
                    raise ValueError(
                        f"channels[{j}] ({names[j]}): unknown channel {c!r}; expected one of "
                        f"{sorted(POSITION_CHANNELS) + sorted(ROTATION_CHANNELS)}"
                    )
            if len(set(ch)) != len(ch):
                raise ValueError(f"channels[{j}] ({names[j]}): repeated channel in {list(ch)}")
        if not np.isfinite(offsets).all():
            raise ValueError("offsets: expected finite values")
        if es_parents.shape[0] != es_offsets.shape[0]:
            raise ValueError(
                f"end_site_offsets: expected {es_parents.shape[0]} rows (one per end site); "
                f"got {es_offsets.shape[0]}"
            )
        if es_parents.size and ((es_parents < 0) | (es_parents >= n)).any():
            raise ValueError(f"end_site_parents: expected joint indices in [0, {n}); got {es_parents}")
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "parents", _ro(parents))
        object.__setattr__(self, "offsets", _ro(offsets))
        object.__setattr__(self, "channels", channels)
        object.__setattr__(self, "end_site_parents", _ro(es_parents))
        object.__setattr__(self, "end_site_offsets", _ro(es_offsets))

    # -- sizes and lookups ---------------------------------------------------------------------
    @property
    def n_joints(self) -> int:
        """``J``, the number of joints (end sites excluded)."""
        return len(self.names)

    @property
    def n_channels(self) -> int:
        """Total number of channels, i.e. values per frame in a BVH file."""
        return sum(len(c) for c in self.channels)

    def index(self, name: str) -> int:
        """Index of the joint called ``name``; ``KeyError`` listing the names if absent."""
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"no joint named {name!r}; joints are {list(self.names)}") from None

    def children(self, j: int) -> list[int]:
        """Indices of the joints whose parent is ``j``."""
        return [int(c) for c in np.flatnonzero(self.parents == j)]

    def subtree(self, j: int) -> list[int]:
        """``j`` and all its descendants, in index order."""
        inside = np.zeros(self.n_joints, dtype=bool)
        inside[j] = True
        for k in range(j + 1, self.n_joints):
            inside[k] = inside[self.parents[k]]
        return [int(k) for k in np.flatnonzero(inside)]

    # -- channel layout --------------------------------------------------------------------------
    @property
    def euler_orders(self) -> tuple[str, ...]:
        """Intrinsic Euler order of each joint: its rotation channels in file order,
        completed with the missing axes in ``X, Y, Z`` order (``"Z"`` -> ``"ZXY"``)."""
        out = []
        for ch in self.channels:
            axes = "".join(ROTATION_CHANNELS[c] for c in ch if c in ROTATION_CHANNELS)
            out.append(axes + "".join(a for a in "XYZ" if a not in axes))
        return tuple(out)

    @property
    def has_position_channels(self) -> np.ndarray:
        """Boolean mask ``(J,)``: joints with at least one position channel."""
        return np.array([any(c in POSITION_CHANNELS for c in ch) for ch in self.channels])

    @property
    def bone_lengths(self) -> np.ndarray:
        """``(J,)`` lengths of the rest offsets (the root's is its offset's norm)."""
        return np.linalg.norm(self.offsets, axis=-1)

    def __repr__(self) -> str:
        return (
            f"Skeleton({self.n_joints} joints, {self.n_channels} channels, "
            f"{self.end_site_parents.size} end sites, root={self.names[0]!r})"
        )


def _check_axis(up_axis: str) -> str:
    if up_axis not in ("x", "y", "z"):
        raise ValueError(f"up_axis: expected 'x', 'y' or 'z'; got {up_axis!r}")
    return up_axis


@dataclass(frozen=True, eq=False)
class Motion:
    """A clip: a skeleton, a frame rate and per-frame root translation and joint rotations.

    Parameters
    ----------
    skeleton : Skeleton
    fps : float
        Frames per second (> 0).
    root_translation : array_like, shape (F, 3)
        Root position per frame, file length units, in the world frame.
    rotations : array_like, shape (F, J, 3, 3)
        Local joint rotation matrices (joint 0: the root's orientation in the world).
    joint_translations : array_like, shape (F, J, 3), optional
        Per-frame local translations of joints with position channels (other than the
        root); rows of the other joints are ignored. ``None`` when no such joint exists.
    metres_per_unit : float, optional
        Size of one length unit in metres (``None``: unknown).
    up_axis : {"x", "y", "z"}, default "y"
    source : tuple of str, default ()
        Files the motion was read from (writers refuse to overwrite them).
    name : str, default ""

    Notes
    -----
    Arrays are converted to float64 and not copied when they already are; the
    functions of this package never modify a Motion's arrays in place, and neither
    should callers (derive a new Motion with :meth:`replace`).
    """

    skeleton: Skeleton
    fps: float
    root_translation: np.ndarray
    rotations: np.ndarray
    joint_translations: np.ndarray | None = None
    metres_per_unit: float | None = None
    up_axis: str = "y"
    source: tuple[str, ...] = ()
    name: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.skeleton, Skeleton):
            raise ValueError(f"skeleton: expected a Skeleton; got {type(self.skeleton).__name__}")
        j = self.skeleton.n_joints
        fps = float(self.fps)
        if not (math.isfinite(fps) and fps > 0):
            raise ValueError(f"fps: expected a positive finite frame rate; got {self.fps!r}")
        rot = np.ascontiguousarray(self.rotations, dtype=np.float64)
        if rot.ndim != 4 or rot.shape[1:] != (j, 3, 3):
            raise ValueError(f"rotations: expected shape (F, {j}, 3, 3); got {rot.shape}")
        f = rot.shape[0]
        if f == 0:
            raise ValueError("rotations: expected at least one frame; got 0")
        root = np.ascontiguousarray(self.root_translation, dtype=np.float64)
        if root.shape != (f, 3):
            raise ValueError(f"root_translation: expected shape ({f}, 3); got {root.shape}")
        jt = self.joint_translations
        if jt is not None:
            jt = np.ascontiguousarray(jt, dtype=np.float64)
            if jt.shape != (f, j, 3):
                raise ValueError(f"joint_translations: expected shape ({f}, {j}, 3); got {jt.shape}")
        mpu = self.metres_per_unit
        if mpu is not None:
            mpu = float(mpu)
            if not (math.isfinite(mpu) and mpu > 0):
                raise ValueError(
                    f"metres_per_unit: expected a positive number or None; got {self.metres_per_unit!r}"
                )
        object.__setattr__(self, "fps", fps)
        object.__setattr__(self, "rotations", rot)
        object.__setattr__(self, "root_translation", root)
        object.__setattr__(self, "joint_translations", jt)
        object.__setattr__(self, "metres_per_unit", mpu)
        object.__setattr__(self, "up_axis", _check_axis(self.up_axis))
        object.__setattr__(self, "source", tuple(str(s) for s in self.source))

    # -- sizes ---------------------------------------------------------------------------------
    @property
    def n_frames(self) -> int:
        """``F``, the number of frames."""
        return self.rotations.shape[0]

    @property
    def n_joints(self) -> int:
        """``J``, the number of joints."""
        return self.skeleton.n_joints

    @property
    def frame_time(self) -> float:
        """Seconds between frames, ``1 / fps``."""
        return 1.0 / self.fps

    @property
    def duration(self) -> float:
        """Seconds from the first to the last frame, ``(F - 1) / fps``."""
        return (self.n_frames - 1) / self.fps

    @property
    def times(self) -> np.ndarray:
        """``(F,)`` time of each frame in seconds, starting at 0."""
        return np.arange(self.n_frames) / self.fps

    @property
    def units(self) -> str:
        """Name of the length unit (``"m"``, ``"cm"``, ``"cmu"``, ...) or
        ``"<x> m"`` for another size, ``"unknown"`` when not known."""
        if self.metres_per_unit is None:
            return "unknown"
        for name, size in UNITS.items():
            if math.isclose(size, self.metres_per_unit, rel_tol=1e-6):
                return name
        return f"{self.metres_per_unit:.6g} m"

    def local_translations(self) -> np.ndarray:
        """Per-frame local translation of every joint.

        Returns
        -------
        ndarray, shape (F, J, 3)
            Row 0 is ``root_translation``; joints with position channels take the values
            of ``joint_translations``; the others their skeleton offset.
        """
        f, j = self.n_frames, self.n_joints
        out = np.empty((f, j, 3))
        out[:] = self.skeleton.offsets
        out[:, 0] = self.root_translation
        if self.joint_translations is not None:
            mask = self.skeleton.has_position_channels.copy()
            mask[0] = False
            out[:, mask] = self.joint_translations[:, mask]
        return out

    def replace(self, **changes: object) -> Motion:
        """A copy with the given fields replaced (``dataclasses.replace``)."""
        return dataclasses.replace(self, **changes)

    def __repr__(self) -> str:
        label = f"{self.name!r}, " if self.name else ""
        return (
            f"Motion({label}{self.n_frames} frames at {self.fps:g} fps, "
            f"{self.n_joints} joints, units={self.units}, up={self.up_axis})"
        )


def joint_mask(skeleton: Skeleton, names: Sequence[str]) -> np.ndarray:
    """Boolean mask ``(J,)`` of the joints in ``names``; ``KeyError`` for an unknown name."""
    mask = np.zeros(skeleton.n_joints, dtype=bool)
    for n in names:
        mask[skeleton.index(n)] = True
    return mask
