"""Errors name what the user gave -- the file, the option -- never an internal argument (issue 32).

Before: ``values: expected at least 2 samples`` for a ``--sample-fps`` too low for a clip,
``weight: expected positive finite weights`` when no weight was given (a skeleton too large
to weigh), ``motion: ...`` for a file, ``asf: ... pass asf=PATH`` and ``(give units=...)``
to a command line that has no such argument.
"""

from __future__ import annotations

import numpy as np
import pytest
from blend_testlib import walker

from elastic_motion.cli import main
from elastic_motion.motion import Motion, Skeleton, write_bvh


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("messages")
    a = walker(duration=2.0, name="a")
    sk = a.skeleton
    big = 1e160
    huge = Skeleton(
        sk.names, sk.parents, sk.offsets * big, sk.channels, sk.end_site_parents, sk.end_site_offsets * big
    )
    unnamed = Skeleton(
        [f"n{k}" for k in range(sk.n_joints)],
        sk.parents,
        sk.offsets,
        sk.channels,
        sk.end_site_parents,
        sk.end_site_offsets,
    )
    moving = list(sk.channels)
    moving[8] = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
    head = Skeleton(sk.names, sk.parents, sk.offsets, moving, sk.end_site_parents, sk.end_site_offsets)
    jt = np.tile(sk.offsets, (a.n_frames, 1, 1))
    jt[:, 8, 1] += 0.05 * np.sin(np.arange(a.n_frames))
    zero = Skeleton(
        sk.names, sk.parents, 0 * sk.offsets, sk.channels, sk.end_site_parents, 0 * sk.end_site_offsets
    )
    out = {
        "a": write_bvh(a, d / "a.bvh"),
        "b": write_bvh(walker(duration=2.4, freq=1.25, name="b"), d / "b.bvh"),
        "huge": write_bvh(
            a.replace(skeleton=huge, root_translation=a.root_translation * big), d / "huge.bvh"
        ),
        "unnamed": write_bvh(a.replace(skeleton=unnamed), d / "unnamed.bvh"),
        "head": write_bvh(
            Motion(head, a.fps, a.root_translation, a.rotations, joint_translations=jt, metres_per_unit=1.0),
            d / "head.bvh",
        ),
        "zero": write_bvh(a.replace(skeleton=zero), d / "zero.bvh"),
    }
    amc = d / "amc"
    amc.mkdir()
    for name in ("02.asf", "03.asf", "x.amc"):
        (amc / name).write_text("")
    out["amc"] = amc / "x.amc"
    out["dir"] = d
    return {k: str(v) for k, v in out.items()}


def _error(capsys, *argv) -> str:
    code = main([str(x) for x in argv])
    err = capsys.readouterr().err
    assert code == 2, err
    return err.strip().splitlines()[-1]


def test_a_sample_rate_too_low_for_a_clip_names_the_option_and_the_clip(files, capsys):
    out = f"{files['dir']}/o.bvh"
    for argv in (
        ["blend", files["a"], files["b"], "-o", out, "--sample-fps", "0.1", "-q"],
        ["distance", files["a"], files["b"], "--sample-fps", "0.4", "--warp", "none"],
    ):
        err = _error(capsys, *argv)
        assert "error: --sample-fps: a: expected a rate giving at least 2 samples" in err, err
        assert "values:" not in err


def test_a_skeleton_too_large_to_weigh_names_the_file_not_a_weight(files, capsys):
    out = f"{files['dir']}/o.bvh"
    for argv in (
        ["blend", files["a"], files["huge"], "-o", out, "-q"],
        ["loop", files["huge"], "-o", out, "-q"],
    ):
        err = _error(capsys, *argv)
        # refused right after reading (prepare's extent check), named by its file
        assert "error: huge: expected offsets and positions within 1e+06 m of the origin" in err, err
        assert "weight:" not in err and "weights:" not in err


@pytest.mark.parametrize(
    ("argv", "named", "internal"),
    [
        (["landmarks", "{unnamed}", "{unnamed}"], "error: unnamed: cannot detect knee crossings", "motion:"),
        (["loop", "{head}", "-o", "{dir}/o.bvh", "-q"], "error: head: joint 'Head' moves", "motion:"),
        (["info", "{amc}"], "x.amc': expected one .asf skeleton file beside it", "asf:"),
        (["blend", "{a}", "{zero}", "-o", "{dir}/o.bvh", "-q"], "(give it: --units on the", "units=..."),
    ],
)
def test_file_errors_name_the_file(files, capsys, argv, named, internal):
    err = _error(capsys, *(a.format(**files) for a in argv))
    assert named in err and internal not in err, err


def test_weights_of_a_skeleton_too_large_name_the_motion():
    """In Python, without the CLI's extent check, the weights refuse it naming the motion."""
    from elastic_motion.motion.representations import group_weights

    a = walker(duration=1.0, name="a")
    sk = a.skeleton
    huge = Skeleton(
        sk.names, sk.parents, sk.offsets * 1e160, sk.channels, sk.end_site_parents, sk.end_site_offsets
    )
    with pytest.raises(ValueError, match=r"^huge: expected a skeleton of usual size; its offsets reach"):
        group_weights([a.replace(skeleton=huge, name="huge")])
