"""Shared data lists and independent reference code for the motion tests.

The reference implementations here are deliberately naive and structured differently from
the library (recursive descent over text tokens, per-frame loops, scipy ``Rotation``), so
that an agreement between the two is evidence, not a tautology.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

CMU_BVH = [
    "01_01.bvh",
    "07_01.bvh",
    "08_02.bvh",
    "09_11.bvh",
    "107_02_30hz.bvh",
    "108_01_30hz.bvh",
    "131_01.bvh",
    "131_02.bvh",
    "131_03.bvh",
    "49_08.bvh",
    "55_01.bvh",
]
#: Files whose frame 0 is a T-pose (README of the shared data).
TPOSE_FIRST = {"01_01", "07_01", "08_02", "09_11", "49_08", "55_01", "107_02_30hz", "108_01_30hz"}
ASF_AMC = [
    ("02.asf", "02_01.amc"),
    ("backflip.asf", "backflip.amc"),
    ("charleston.asf", "charleston1.amc"),
    ("charleston.asf", "charleston2.amc"),
]


def bandai_files(mocap: Path) -> list[Path]:
    return sorted((mocap / "bandai").glob("*.bvh"))


def deepmimic_files(mocap: Path) -> list[Path]:
    d = mocap / "deepmimic"
    return sorted(d.glob("humanoid3d_*.txt")) + sorted((d / "walker").glob("*.txt"))


class NaiveBvh:
    """A BVH file parsed by recursive descent over its tokens, FK by per-frame loops."""

    def __init__(self, path: Path) -> None:
        text = path.read_text()
        head, _, motion = re.split(r"^\s*(MOTION)\s*$", text, maxsplit=1, flags=re.M)
        self.tokens = head.split()
        self.pos = 1  # skip HIERARCHY
        self.joints: list[dict] = []
        self._joint(None)
        lines = [ln for ln in motion.splitlines() if ln.strip()]
        self.frames = int(lines[0].split(":")[1])
        self.frame_time = float(lines[1].split(":")[1])
        self.values = np.array([[float(v) for v in ln.split()] for ln in lines[2:]])

    def _take(self) -> str:
        tok = self.tokens[self.pos]
        self.pos += 1
        return tok

    def _joint(self, parent: dict | None) -> None:
        kind = self._take()  # ROOT / JOINT
        assert kind in ("ROOT", "JOINT")
        joint = {"name": self._take(), "parent": parent, "children": [], "sites": []}
        self.joints.append(joint)
        if parent is not None:
            parent["children"].append(joint)
        assert self._take() == "{"
        while True:
            tok = self.tokens[self.pos]
            if tok == "OFFSET":
                self.pos += 1
                joint["offset"] = np.array([float(self._take()) for _ in range(3)])
            elif tok == "CHANNELS":
                self.pos += 1
                joint["channels"] = [self._take() for _ in range(int(self._take()))]
            elif tok == "JOINT":
                self._joint(joint)
            elif tok == "End":
                self.pos += 3  # End Site {
                assert self._take() == "OFFSET"
                joint["sites"].append(np.array([float(self._take()) for _ in range(3)]))
                assert self._take() == "}"
            else:
                assert self._take() == "}"
                return

    def positions(self, frame: int) -> dict[str, np.ndarray]:
        """World positions of every joint at ``frame`` (a per-frame recursion)."""
        out: dict[str, np.ndarray] = {}
        col = 0
        local: dict[str, tuple[np.ndarray, Rotation]] = {}
        for joint in self.joints:  # file order = column order
            t = joint["offset"].copy()
            axes, angles = "", []
            for ch in joint["channels"]:
                v = self.values[frame, col]
                col += 1
                if ch.endswith("position"):
                    t["XYZ".index(ch[0])] = v
                else:
                    axes += ch[0]
                    angles.append(v)
            rot = Rotation.from_euler(axes, angles, degrees=True) if axes else Rotation.identity()
            local[joint["name"]] = (t, rot)

        def walk(joint: dict, pos: np.ndarray, rot: Rotation) -> None:
            t, r = local[joint["name"]]
            p = pos + rot.apply(t)
            out[joint["name"]] = p
            for child in joint["children"]:
                walk(child, p, rot * r)

        walk(self.joints[0], np.zeros(3), Rotation.identity())
        return out


def geodesic_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation angle in degrees between matrices ``a`` and ``b`` (any leading shape)."""
    rel = np.swapaxes(a, -1, -2) @ b
    cos = np.clip((np.trace(rel, axis1=-2, axis2=-1) - 1.0) / 2.0, -1.0, 1.0)
    # arccos loses precision near 0: use the skew part there.
    skew = np.stack(
        [rel[..., 2, 1] - rel[..., 1, 2], rel[..., 0, 2] - rel[..., 2, 0], rel[..., 1, 0] - rel[..., 0, 1]],
        -1,
    )
    sin = 0.5 * np.linalg.norm(skew, axis=-1)
    return np.degrees(np.arctan2(sin, cos))


# ------------------------------------------------------------------------------------------
# Simulated Blender exports (the up-axis tests and benchmarks/upaxis_exports.py)
# ------------------------------------------------------------------------------------------

#: Blender's import: Y-up to Z-up, (x, y, z) -> (x, -z, y).
Y_TO_Z = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])


def blender_export(m, rot: np.ndarray = Y_TO_Z):
    """``m`` (Y-up Motion) as Blender exports it: Z-up armature space (offsets turned too)."""
    import dataclasses

    sk = m.skeleton
    turned = dataclasses.replace(sk, offsets=sk.offsets @ rot.T, end_site_offsets=sk.end_site_offsets @ rot.T)
    jt = None if m.joint_translations is None else m.joint_translations @ rot.T
    return m.replace(
        skeleton=turned,
        rotations=np.einsum("ij,fnjk,lk->fnil", rot, m.rotations, rot),
        root_translation=m.root_translation @ rot.T,
        joint_translations=jt,
        up_axis="z" if rot is Y_TO_Z else m.up_axis,
    )


def in_place(m, up: str):
    """The hips (the first joint with several children) held at their mean position across
    ``up``, their height kept: the whole body shifted by the root."""
    from elastic_motion.motion import forward_kinematics

    sk = m.skeleton
    hips = 0
    while len(sk.children(hips)) == 1:
        hips = sk.children(hips)[0]
    path = forward_kinematics(m)[:, hips]
    drift = path - path.mean(axis=0)
    drift[:, "xyz".index(up)] = 0.0
    return m.replace(root_translation=m.root_translation - drift)
