"""Up-axis detection on exports as Blender writes them: Z-up, in full and in place.

Blender's BVH exporter writes armature space: the importer's axis conversion ``(x, y, z) ->
(x, -z, y)`` is baked into the rest pose (offsets), the local rotations are relative to that
Z-up rest pose, and the root carries the world motion (``tests/apps/test_blender_import.py``).
:func:`blender_export` builds the same file from a Y-up clip without Blender: every offset,
local rotation and translation turned by that rotation (positions turn with it). An
**in-place** export keeps the body over one spot: the hips held at their mean horizontal
position (whatever joint carries the travel: the root, or Bandai's hips below a static
``joint_Root``), their height kept, so the planted feet slide back as on a treadmill.
``tests/apps/test_blender_upaxis.py`` checks the same on Blender's own exports.

No mocap is committed: the real clips come from the shared folder (``mocap_dir``).
"""

from __future__ import annotations

import pytest
from motion_testlib import blender_export, deepmimic_files, in_place
from test_motion_upaxis import TURNS, human, turned

from elastic_motion.motion import (
    Motion,
    detect_up_axis,
    drop_tpose,
    read_bvh,
    read_motion,
    select_frames,
    write_bvh,
)


def _read_back(m: Motion, tmp_path, name: str) -> Motion:
    """What ``info`` shows: the file read with the up axis detected."""
    return read_bvh(write_bvh(m, tmp_path / f"{name}.bvh"))


def test_synthetic_walk_in_place_is_detected(tmp_path):
    """The synthetic walker in place, Y-up and Blender's Z-up: in the world frame its feet
    slide (no still contact along up) while its side stays still (balanced along x, as a
    body lying on its side): judged against the world, +x and -x tied with up (margin
    0.07, ambiguous, read as y)."""
    walk = human()
    for m, want in ((in_place(walk, "y"), "+y"), (in_place(blender_export(walk), "z"), "+z")):
        est = detect_up_axis(m)
        assert est.direction == want and not est.ambiguous, est.reason
        assert est.confidence > 0.5, est.reason
        assert _read_back(m, tmp_path, want[1]).up_axis == want[1]


@pytest.mark.mocap
def test_blender_style_exports_of_shared_clips_are_read_z_up(mocap_dir, tmp_path):
    """Full and in-place Z-up exports, and in-place Y-up, of a CMU walk, Bandai walks (the
    old-style walk in place over 1.5 s was read y: margin 0.14-0.26), a DeepMimic walk and
    crawl (in place, its body horizontal and nothing travelling: +z leads by 0.18 only,
    confirmed by its upright rest pose)."""
    cmu = drop_tpose(read_bvh(mocap_dir / "cmu" / "bvh" / "107_02_30hz.bvh"))
    old = read_bvh(mocap_dir / "bandai" / "dataset-1_walk_old_001.bvh")
    clips = {
        "cmu_107_02": cmu,
        "bandai_old": old,
        "bandai_old_1.5s": select_frames(old, slice(132, 177)),
        "bandai_old_1.5s_b": select_frames(old, slice(110, 155)),
        "deepmimic_walk": read_motion(next(p for p in deepmimic_files(mocap_dir) if "walk.txt" in p.name)),
        "deepmimic_crawl": read_motion(next(p for p in deepmimic_files(mocap_dir) if "crawl" in p.name)),
    }
    seen = []
    for name, m in clips.items():
        assert m.up_axis == "y", name
        z = blender_export(m)
        for kind, x, want in (
            ("full_z", z, "z"),
            ("in_place_z", in_place(z, "z"), "z"),
            ("in_place_y", in_place(m, "y"), "y"),
        ):
            back = _read_back(x, tmp_path, f"{name}_{kind}")
            est = detect_up_axis(back)
            seen.append((name, kind, back.up_axis, round(est.confidence, 2)))
            assert back.up_axis == want and not est.fallback, (name, kind, est.reason)
    assert len(seen) == 18


def test_the_rest_pose_confirms_a_narrow_lead():
    """Below ``min_margin`` the best direction is taken when the rest pose (head above feet)
    stands along it, and only then."""
    walk = human()
    z = blender_export(walk)  # rest pose turned too: it stands along +z
    est = detect_up_axis(z, min_margin=10.0)
    assert est.direction == "+z" and not est.ambiguous and est.up_axis == "z", est.reason
    assert est.evidence["rest_pose_confirms"] and "as the rest pose stands" in est.reason
    est = detect_up_axis(turned(walk, TURNS["+z"]), min_margin=10.0)  # rest pose along +y, motion +z
    assert est.ambiguous and not est.evidence["rest_pose_confirms"] and est.up_axis == "y", est.reason
