"""A small leg chain for the loop tests (no data files needed): root, hip, knee, foot, Y up,
metres, ZYX rotation channels, a toe end site."""

from __future__ import annotations

from elastic_motion.motion import Skeleton


def chain_skeleton(names: tuple[str, ...] = ("root", "hip", "knee", "foot")) -> Skeleton:
    return Skeleton(
        names=names,
        parents=[-1, 0, 1, 2],
        offsets=[[0, 0, 0], [0.1, -0.1, 0], [0, -0.4, 0], [0, -0.4, 0]],
        channels=(
            ("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation"),
            ("Zrotation", "Yrotation", "Xrotation"),
            ("Zrotation", "Yrotation", "Xrotation"),
            ("Zrotation", "Yrotation", "Xrotation"),
        ),
        end_site_parents=[3],
        end_site_offsets=[[0, 0, 0.15]],
    )
