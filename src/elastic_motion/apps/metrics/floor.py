"""What an animator sees at floor level, measured on one motion by itself.

:func:`foot_quality` measures a motion the same way whether it is an input or an output: its
own contacts (:func:`elastic_motion.motion.contacts.detect_contacts`, the same options), the
skating over them, the *skids* (a foot sliding along the floor, contact or not), how far
anything goes below the floor and how high each foot swings. Comparing an output with its
inputs then compares like with like: no figure is taken only where the output is expected to
be good (an output's skating over contacts carried from its inputs misses the frames where
its feet slide but the inputs' contacts do not say "planted").

Conventions
-----------
* **Leg length** ``L`` (:func:`leg_length`): hip to sole, the thigh and shin bones (hip ->
  knee -> ankle, found by name) and the ankle's height above the sole, taken as a tenth of
  them (:data:`ANKLE_HEIGHT_RATIO`: rigs disagree on the foot's rest pose, so it is not
  read off the toes); the mean of the legs, about 0.9 m for an adult. Without legs, half the
  skeleton's diameter along its bones.
* **Skid** (:data:`SKID_HEIGHT`, :data:`SKID_SPEED`, :data:`SKID_DURATION`): a run of at least
  0.1 s of frames in which a foot point (a foot joint,
  :func:`~elastic_motion.apps.metrics.feet.foot_joints`, or the end site of one: the tip of
  a toe, what drags first) stays within ``0.02 L`` of the floor and moves horizontally
  faster than ``0.3 L`` per second.
  A planted foot does not move; a swinging foot is well above the floor; a foot low *and*
  fast is a foot sliding along the floor. Its *slid distance* is the horizontal path over
  the run.
* **Swing clearance** of a foot joint: over each of its swings (the frames between two of its
  own contacts), the lowest height in the middle half of the swing; the joint's clearance is
  the lowest over its swings (NaN without a complete swing). An end site's swings are its
  joint's. A swing that passes close to the
  floor is where a skid begins.
* **Floor**: the motion's own (the contacts' floor, frame by frame when it is not level), or
  the one given (``floor=``, metres: e.g. the inputs' floor for an output placed like them).
* Speeds are central differences in m/s (one-sided at the ends); heights and lengths in
  metres (the motion's own unit when ``metres_per_unit`` is unknown).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from elastic_motion.apps.landmarks import find_leg_joints
from elastic_motion.apps.metrics.feet import ContactSkating, contact_skating, foot_joints, metres
from elastic_motion.motion import Motion, Skeleton, forward_kinematics, skeleton_diameter
from elastic_motion.motion.contacts import ContactOptions, Contacts, detect_contacts, mask_runs

__all__ = [
    "ANKLE_HEIGHT_RATIO",
    "SKID_DURATION",
    "SKID_HEIGHT",
    "SKID_SPEED",
    "FootQuality",
    "Skid",
    "find_skids",
    "foot_points",
    "foot_quality",
    "leg_length",
]

_AXES = "xyz"

#: Hip to sole over thigh plus shin: the ankle stands about a tenth of the leg above the sole
#: (7-8 cm of an adult's 80 cm; CMU 107_02: 0.79 m of thigh and shin, 0.87 m hip to sole).
ANKLE_HEIGHT_RATIO = 1.1
#: Leg lengths: a foot joint this close to the floor is at floor level (0.02 L: 1.8 cm for a
#: 0.9 m leg, below a swing's usual 3-10 cm clearance and above a planted toe's 0-1 cm).
SKID_HEIGHT = 0.02
#: Leg lengths per second: faster than this at floor level is sliding (0.3 L/s: 0.27 m/s for a
#: 0.9 m leg, above the 0.05-0.2 m/s a planted foot of real capture jitters at).
SKID_SPEED = 0.3
#: Seconds: a skid lasts at least this long (a toe lifting off is low and fast for a frame or
#: two; 0.1 s is three frames at 30 fps, twelve at 120).
SKID_DURATION = 0.1


@dataclass(frozen=True)
class Skid:
    """A foot sliding along the floor (module docstring).

    Attributes
    ----------
    joint : str
    start, stop : int
        Frames ``[start, stop)``.
    distance_m : float
        Horizontal path over the run (m).
    height_max_m : float
        Highest point of the joint above the floor during the run (m).
    speed_mean_m_s : float
        Mean horizontal speed over the run (m/s).
    """

    joint: str
    start: int
    stop: int
    distance_m: float
    height_max_m: float
    speed_mean_m_s: float

    def summary(self) -> dict[str, Any]:
        """JSON-ready fields."""
        return {
            "joint": self.joint,
            "frames": [self.start, self.stop],
            "distance_m": self.distance_m,
            "height_max_m": self.height_max_m,
            "speed_mean_m_s": self.speed_mean_m_s,
        }


#: Why a swing clearance is null in a report (NaN in :attr:`FootQuality.swing_clearance_m`).
_NO_SWING = (
    "a foot point whose clearance is null never swings (no 4 frames or more in the air between contacts)"
)


@dataclass(frozen=True, eq=False)
class FootQuality:
    """A motion's feet and floor, measured on the motion itself (:func:`foot_quality`).

    Attributes
    ----------
    contacts : Contacts
        The motion's own contacts (the options given).
    skating : ContactSkating
        Skating over those contacts; its ``below_floor`` is measured from the floor used.
    skids : tuple of Skid
        In time order.
    below_floor_m : float
        How far the lowest joint or end site goes below the floor (m, >= 0).
    swing_clearance_m : dict of str to float
        Per foot joint, its lowest mid-swing height (m; NaN without a complete swing: None in
        :meth:`summary`, whose ``swing_clearance_null`` then says why).
    leg_length_m : float
    floor_m : float
        The floor height used (its mean over the frames when not level).
    fps : float
    """

    contacts: Contacts
    skating: ContactSkating
    skids: tuple[Skid, ...]
    below_floor_m: float
    swing_clearance_m: dict[str, float]
    leg_length_m: float
    floor_m: float
    fps: float

    @property
    def has_feet(self) -> bool:
        """Whether the motion has foot points to measure (:func:`foot_points`); without, the
        skating, skids and clearances are empty or 0 and say nothing about its feet."""
        return bool(self.swing_clearance_m)

    @property
    def skid_count(self) -> int:
        """How many skids."""
        return len(self.skids)

    @property
    def slid_m(self) -> float:
        """Their summed slid distance (m)."""
        return float(sum(s.distance_m for s in self.skids))

    def summary(self) -> dict[str, Any]:
        """JSON-ready: the headline numbers, then the skids and the per-joint clearances."""
        return {
            "skating_m_s": self.skating.mean_speed,
            "skid_count": self.skid_count,
            "slid_m": self.slid_m,
            "below_floor_m": self.below_floor_m,
            "leg_length_m": self.leg_length_m,
            "floor_m": self.floor_m,
            "swing_clearance_m": {k: (None if np.isnan(v) else v) for k, v in self.swing_clearance_m.items()},
            **(
                {"swing_clearance_null": _NO_SWING}
                if any(map(np.isnan, self.swing_clearance_m.values()))
                else {}
            ),
            "skids": [s.summary() for s in self.skids],
            "contacts": self.contacts.all_intervals(),
        }


def leg_length(skeleton: Skeleton | Motion) -> float:
    """Hip to sole (module docstring), in the skeleton's length unit."""
    sk = skeleton.skeleton if isinstance(skeleton, Motion) else skeleton
    legs = find_leg_joints(sk)
    lengths = []
    for side in ("left", "right"):
        p = legs.side(side)
        if p["hip"] is None or p["knee"] is None or p["ankle"] is None:
            continue
        knee, ankle = sk.index(p["knee"]), sk.index(p["ankle"])
        if sk.parents[ankle] != knee or sk.names[sk.parents[knee]] != p["hip"]:
            continue
        thigh, shin = float(np.linalg.norm(sk.offsets[knee])), float(np.linalg.norm(sk.offsets[ankle]))
        if thigh <= 0 or shin <= 0:
            continue
        lengths.append(ANKLE_HEIGHT_RATIO * (thigh + shin))
    if lengths:
        return float(np.mean(lengths))
    return 0.5 * skeleton_diameter(sk)


def foot_points(motion: Motion) -> tuple[list[int], list[str], list[str]]:
    """The foot points of a motion: its foot joints, then the end sites hanging from them.

    Returns
    -------
    points : list of int
        Indices into :func:`~elastic_motion.motion.forward_kinematics` ``(..., end_sites=True)``
        (joints first, then end sites).
    names : list of str
        A joint's name, or ``"<joint> end site"``.
    joints : list of str
        The joint each point belongs to.
    """
    sk = motion.skeleton
    feet = foot_joints(motion)
    ends = [i for i, p in enumerate(sk.end_site_parents) if p in feet]
    points = feet + [sk.n_joints + i for i in ends]
    joints = [sk.names[j] for j in feet] + [sk.names[sk.end_site_parents[i]] for i in ends]
    names = [sk.names[j] for j in feet] + [f"{sk.names[sk.end_site_parents[i]]} end site" for i in ends]
    return points, names, joints


def _speeds(p: np.ndarray, fps: float, up: int) -> np.ndarray:
    """Horizontal speeds ``(F, K)`` of points ``p (F, K, 3)``: central differences, one-sided
    at the ends."""
    flat = p.copy()
    flat[..., up] = 0.0
    if flat.shape[0] < 2:
        return np.zeros(flat.shape[:2])
    v = np.gradient(flat, axis=0) * fps
    return np.linalg.norm(v, axis=-1)


def find_skids(
    heights: np.ndarray,
    positions: np.ndarray,
    fps: float,
    leg: float,
    names: Sequence[str],
    up: int,
) -> list[Skid]:
    """The skids (module docstring) of joints with ``heights`` ``(F, K)`` above the floor and
    ``positions`` ``(F, K, 3)`` (both metres), ``leg`` the leg length (m)."""
    speed = _speeds(positions, fps, up)
    low_fast = (heights < SKID_HEIGHT * leg) & (speed > SKID_SPEED * leg)
    min_frames = max(2, int(np.ceil(SKID_DURATION * fps - 1e-9)))
    step = np.diff(positions, axis=0)
    step[..., up] = 0.0
    step_len = np.linalg.norm(step, axis=-1)  # (F-1, K)
    out = []
    for k, name in enumerate(names):
        for a, b in mask_runs(low_fast[:, k]):
            if b - a < min_frames:
                continue
            out.append(
                Skid(
                    joint=name,
                    start=a,
                    stop=b,
                    distance_m=float(step_len[a : b - 1, k].sum()),
                    height_max_m=float(heights[a:b, k].max()),
                    speed_mean_m_s=float(speed[a:b, k].mean()),
                )
            )
    return sorted(out, key=lambda s: (s.start, s.joint))


def _swing_clearance(
    heights: np.ndarray, contacts: Contacts, points: Sequence[str], joints: Sequence[str]
) -> dict[str, float]:
    """Per foot point (``points``, its joint ``joints``), the lowest mid-swing height (module
    docstring) of ``heights`` ``(F, K)``."""
    out = {}
    for k, (name, joint) in enumerate(zip(points, joints, strict=True)):
        lows = []
        if joint in contacts.joints:
            runs = contacts.intervals(joint)
            for (_, b), (c, _) in itertools.pairwise(runs):
                n = c - b
                if n < 4:
                    continue
                lows.append(float(heights[b + n // 4 : c - n // 4, k].min()))
        out[name] = min(lows) if lows else float("nan")
    return out


def foot_quality(
    motion: Motion, contact_options: ContactOptions | None = None, *, floor: float | None = None
) -> FootQuality:
    """Measure a motion's feet and floor on the motion itself (module docstring).

    Parameters
    ----------
    motion : Motion
        At least 2 frames; metres when ``metres_per_unit`` is known.
    contact_options : ContactOptions, optional
        Of the contact detection (default ``ContactOptions()``): measure inputs and outputs
        with the same options.
    floor : float, optional
        The floor's height (m) to measure heights from; default the motion's own.

    Returns
    -------
    FootQuality
    """
    contacts = detect_contacts(motion, contact_options or ContactOptions())
    scale, _ = metres(motion)
    up = _AXES.index(motion.up_axis)
    pos = forward_kinematics(motion, end_sites=True) * scale
    ground = np.full(motion.n_frames, float(floor)) if floor is not None else contacts.floor_heights()
    below = float(max(0.0, (ground - pos[..., up].min(axis=1)).max()))
    skating = contact_skating(motion, contacts)
    points, names, joints = foot_points(motion)
    p = pos[:, points]
    heights = p[..., up] - ground[:, None]
    leg = leg_length(motion) * scale
    return FootQuality(
        contacts=contacts,
        skating=skating,
        skids=tuple(find_skids(heights, p, motion.fps, leg, names, up)),
        below_floor_m=below,
        swing_clearance_m=_swing_clearance(heights, contacts, names, joints),
        leg_length_m=leg,
        floor_m=float(ground.mean()),
        fps=motion.fps,
    )
