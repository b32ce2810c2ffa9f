"""Synthetic motions for the blend / landmarks / render / CLI tests (no data files needed).

A small biped walks along +z (Y up, metres). Its left hip angle about x is
``-amp sin(2 pi f t + phase)`` and the right one ``+amp sin(2 pi f t + phase)``, so the left
knee is ahead of the right one when the sine is positive and passes it (moving forward)
where the sine crosses 0 upwards: at ``t = k / f`` for ``k >= 1`` when ``phase = 0``.
``LeftHandIndex1`` is a finger joint (blended frame by frame, not on the curves).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from elastic_motion.motion import Motion, Skeleton
from elastic_motion.motion.rotations import axis_rotation

NAMES = (
    "Hips",
    "LeftUpLeg",
    "LeftLeg",
    "LeftFoot",
    "RightUpLeg",
    "RightLeg",
    "RightFoot",
    "Spine",
    "Head",
    "LeftHand",
    "LeftHandIndex1",
)
PARENTS = (-1, 0, 1, 2, 0, 4, 5, 0, 7, 7, 9)
OFFSETS = np.array(
    [
        [0.0, 0.0, 0.0],
        [0.1, -0.05, 0.0],
        [0.0, -0.42, 0.0],
        [0.0, -0.42, 0.0],
        [-0.1, -0.05, 0.0],
        [0.0, -0.42, 0.0],
        [0.0, -0.42, 0.0],
        [0.0, 0.2, 0.0],
        [0.0, 0.35, 0.0],
        [0.25, 0.25, 0.0],
        [0.05, 0.0, 0.0],
    ]
)


def skeleton(scale: float = 1.0, names: tuple[str, ...] = NAMES) -> Skeleton:
    root = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
    rot = ("Zrotation", "Xrotation", "Yrotation")
    return Skeleton(
        names=names,
        parents=PARENTS[: len(names)],
        offsets=OFFSETS[: len(names)] * scale,
        channels=[root] + [rot] * (len(names) - 1),
        end_site_parents=[3, 6, 8],
        end_site_offsets=np.array([[0.0, -0.05, 0.12], [0.0, -0.05, 0.12], [0.0, 0.1, 0.0]]) * scale,
    )


def walker(
    duration: float = 2.0,
    fps: float = 30.0,
    freq: float = 1.0,
    amp: float = 0.5,
    speed: float = 1.0,
    phase: float = 0.0,
    scale: float = 1.0,
    yaw: float = 0.0,
    name: str = "walker",
) -> Motion:
    """A walking biped (module docstring); ``yaw`` turns the whole clip about +y (radians)."""
    sk = skeleton(scale)
    n = round(duration * fps) + 1
    t = np.arange(n) / fps
    w = 2 * np.pi * freq * t + phase
    rot = np.tile(np.eye(3), (n, sk.n_joints, 1, 1))
    rot[:, 1] = axis_rotation(-amp * np.sin(w), "X")
    rot[:, 4] = axis_rotation(amp * np.sin(w), "X")
    rot[:, 2] = axis_rotation(0.6 * np.maximum(np.sin(w + 0.5), 0.0), "X")  # knees bend in swing
    rot[:, 5] = axis_rotation(0.6 * np.maximum(-np.sin(w + 0.5), 0.0), "X")
    rot[:, 7] = axis_rotation(0.05 * np.sin(2 * w), "Y")
    rot[:, 9] = axis_rotation(0.3 * np.sin(w), "Z")
    rot[:, 10] = axis_rotation(0.2 * np.sin(3 * w), "Z")
    root_rot = axis_rotation(np.full(n, yaw), "Y")
    rot[:, 0] = root_rot
    pos = np.zeros((n, 3))
    pos[:, 1] = 0.95 * scale
    pos[:, 2] = speed * t
    pos = pos @ axis_rotation(np.array(yaw), "Y").T
    return Motion(sk, fps, pos, rot, metres_per_unit=1.0, name=name)


def count_foot_quality(monkeypatch: Any, *modules: Any) -> list:
    """Counts the calls of ``foot_quality`` made through each of ``modules`` (their name bound
    to the metrics' function): returns the list of motions measured, in order (the objects
    themselves: an id of a freed motion may be reused)."""
    import elastic_motion.apps.metrics.blend as metrics_module

    measured: list = []
    real = metrics_module.foot_quality

    def counted(motion, *args, **kwargs):
        measured.append(motion)
        return real(motion, *args, **kwargs)

    for module in modules:
        monkeypatch.setattr(module, "foot_quality", counted)
    return measured
