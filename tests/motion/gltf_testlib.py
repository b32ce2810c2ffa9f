"""Motions and glTF documents built for the glTF tests (no data files needed)."""

from __future__ import annotations

import base64
import json
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from elastic_motion.motion import Motion, Skeleton


def synthetic_motion(
    frames: int = 40,
    fps: float = 29.97,
    *,
    up_axis: str = "y",
    seed: int = 0,
    metres_per_unit: float = 0.01,
    slide: bool = True,
) -> Motion:
    """A 7-joint figure in centimetres: hips (6 channels), a spine, two legs, a head with an end
    site, a joint with position channels (as the Bandai files; it slides along them with
    ``slide``), smooth random rotations."""
    rng = np.random.default_rng(seed)
    names = ["Hips", "Spine", "Head", "LThigh", "LShin", "RThigh", "RShin"]
    parents = [-1, 0, 1, 2 - 2, 3, 0, 5]
    offsets = [[0, 90, 0], [0, 20, 1], [0, 30, 0], [10, -5, 0], [0, -42, 1], [-10, -5, 0], [0, -42, 1]]
    rot = ("Zrotation", "Xrotation", "Yrotation")
    pos = ("Xposition", "Yposition", "Zposition")
    channels = [
        pos + rot,
        rot,
        ("Yrotation", "Xrotation"),
        rot,
        pos + ("Xrotation", "Yrotation", "Zrotation"),
        rot,
        rot,
    ]
    sk = Skeleton(names, parents, offsets, channels, [2, 4, 6], [[0, 15, 0], [0, -40, 5], [0, -40, 5]])
    t = np.arange(frames) / fps
    rv = np.sin(t[:, None, None] * rng.uniform(1, 4, (1, 7, 3)) + rng.uniform(0, 6, (1, 7, 3)))
    rv *= rng.uniform(0.2, 1.2, (1, 7, 3))
    rv[:, 2, 2] = 0  # the head: two channels (Y, X) hold its rotations exactly
    rv[:, 2] = Rotation.from_euler("YXZ", rv[:, 2]).as_rotvec()
    rotations = Rotation.from_rotvec(rv.reshape(-1, 3)).as_matrix().reshape(frames, 7, 3, 3)
    root = np.stack([np.linspace(0, 150, frames), 90 + 3 * np.sin(5 * t), 20 * np.sin(t)], axis=1)
    jt = np.zeros((frames, 7, 3))
    jt[:, 4] = np.array([0, -42, 1]) + np.stack(
        [np.zeros(frames), 2 * np.sin(3 * t) * slide, np.zeros(frames)], axis=1
    )
    m = Motion(sk, fps, root, rotations, joint_translations=jt, metres_per_unit=metres_per_unit, name="synth")
    if up_axis != "y":
        from elastic_motion.motion import set_up_axis

        m = set_up_axis(m, up_axis)
    return m


def load_json(path: Path) -> dict:
    """The JSON of a ``.gltf`` file."""
    return json.loads(Path(path).read_text())


def save_json(doc: dict, path: Path) -> Path:
    Path(path).write_text(json.dumps(doc))
    return Path(path)


def buffer_bytes(doc: dict) -> bytes:
    """The bytes of the (data URI) buffer 0 of a ``.gltf`` written by write_gltf."""
    return base64.b64decode(doc["buffers"][0]["uri"].split(",", 1)[1])


def set_buffer(doc: dict, data: bytes) -> None:
    doc["buffers"][0] = {
        "byteLength": len(data),
        "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode(),
    }


def size_of(motion: Motion) -> float:
    """Skeleton size: the largest extent of the joints in the first frame (file units)."""
    from elastic_motion.motion import forward_kinematics

    p = forward_kinematics(motion)[0]
    return float(np.ptp(p, axis=0).max())
