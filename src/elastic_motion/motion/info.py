"""A summary of a motion for people and scripts (``elastic-motion info``)."""

from __future__ import annotations

from typing import Any

from elastic_motion.motion.skeleton import Motion

__all__ = ["format_info", "motion_info"]


def motion_info(motion: Motion) -> dict[str, Any]:
    """Facts about a motion as a JSON-serialisable dict.

    Returns
    -------
    dict
        ``name``, ``source`` (list of paths), ``frames``, ``fps``, ``duration_s``,
        ``joints`` (count), ``end_sites``, ``channels_per_frame``, ``units``,
        ``metres_per_unit`` (or ``None``), ``up_axis``, and ``skeleton``: one entry per
        joint with ``name``, ``parent`` (name or ``None``), ``channels`` (list) and
        ``euler_order`` (intrinsic, three axes).
    """
    sk = motion.skeleton
    orders = sk.euler_orders
    return {
        "name": motion.name,
        "source": list(motion.source),
        "frames": motion.n_frames,
        "fps": motion.fps,
        "duration_s": motion.duration,
        "joints": sk.n_joints,
        "end_sites": int(sk.end_site_parents.size),
        "channels_per_frame": sk.n_channels,
        "units": motion.units,
        "metres_per_unit": motion.metres_per_unit,
        "up_axis": motion.up_axis,
        "skeleton": [
            {
                "name": name,
                "parent": sk.names[p] if p >= 0 else None,
                "channels": list(sk.channels[k]),
                "euler_order": orders[k],
            }
            for k, (name, p) in enumerate(zip(sk.names, sk.parents.tolist(), strict=True))
        ],
    }


def format_info(info: dict[str, Any]) -> str:
    """Human-readable text of :func:`motion_info`'s dict."""
    mpu = info["metres_per_unit"]
    units = info["units"] if mpu is None else f"{info['units']} ({mpu:.6g} m per unit)"
    lines = [
        f"name:       {info['name']}",
        f"source:     {', '.join(info['source']) or '-'}",
        f"frames:     {info['frames']}",
        f"fps:        {info['fps']:g}",
        f"duration:   {info['duration_s']:.3f} s",
        f"joints:     {info['joints']} (+ {info['end_sites']} end sites)",
        f"channels:   {info['channels_per_frame']} per frame",
        f"units:      {units}",
        f"up axis:    {info['up_axis']}",
        "",
        f"{'joint':<24} {'parent':<24} {'order':<5}  channels",
    ]
    for j in info["skeleton"]:
        chans = " ".join(j["channels"]) or "(none)"
        lines.append(f"{j['name']:<24} {j['parent'] or '-':<24} {j['euler_order']:<5}  {chans}")
    return "\n".join(lines)
