"""Degenerate but readable inputs through the commands (issue 32): a clip that does not move, a
3-frame clip, one joint, zero-length bones, a skeleton without feet, positions far beyond any
capture. Each command exits 0 with a summary that says what it could not measure ("n/a", never
"nan" or a ratio of rounding noise), or 2 with a message; no raw numpy warning on the way."""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import re
import warnings

import numpy as np
from loop_testlib import chain_skeleton

from elastic_motion.apps.loop import loop_motion
from elastic_motion.apps.loop.seam_choice import SEAM_C0_KEPT, choose_seam
from elastic_motion.apps.metrics import ContactSkating
from elastic_motion.cli import main
from elastic_motion.cli_commands._common import fmt_float
from elastic_motion.groups import SO3
from elastic_motion.motion import Motion, Skeleton, drop_tpose, read_motion, select_frames, write_bvh
from elastic_motion.notes import of_kind

#: A figure a summary must never print: NaN, or a ratio of rounding noise (1e+295x).
ABSURD = re.compile(r"\bnan\b|\binf\b|e\+\d{2,}", re.IGNORECASE)


def _clip(names=("root", "hip", "knee", "foot"), frames=40, still=False, far=None) -> Motion:
    """A walking leg chain (metres, Y up); ``still``: every frame the first; ``far``: the root
    that far away (metres) on odd frames."""
    t = np.linspace(0.0, 1.0, frames)
    rv = np.zeros((frames, 4, 3))
    rv[:, 1] = np.outer(np.sin(1.7 * np.pi * t), [0.8, 0.0, 0.1])
    rv[:, 2] = np.outer(1 - np.cos(1.7 * np.pi * t), [0.6, 0.0, 0.0])
    root = np.stack([2.0 * t, 0.9 + 0.05 * np.sin(3 * t), 0.3 * t], 1)
    if still:
        rv[:], root[:] = rv[0], root[0]
    if far is not None:
        root[1::2, 0] = far
    return Motion(chain_skeleton(names), 30.0, root, SO3().exp(rv), metres_per_unit=1.0, name="clip")


def _run(argv: list[str]) -> tuple[int, str, list[str]]:
    """``main(argv)`` in this process: exit code, stdout + stderr, the warnings raised."""
    out = io.StringIO()
    with (
        warnings.catch_warnings(record=True) as caught,
        contextlib.redirect_stdout(out),
        contextlib.redirect_stderr(out),
    ):
        warnings.simplefilter("always")
        rc = main(argv)
    return (
        rc,
        out.getvalue(),
        [f"{w.category.__name__}: {w.message} ({w.filename}:{w.lineno})" for w in caught],
    )


def _degenerate_files(folder):
    one = Skeleton(
        ["root"],
        [-1],
        [[0.0, 0.0, 0.0]],
        [("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")],
    )
    walk = _clip()
    zero = walk.replace(skeleton=dataclasses.replace(walk.skeleton, offsets=np.zeros((4, 3))))
    cases = {
        "still": _clip(still=True),
        "three_frames": select_frames(walk, np.arange(3)),
        "one_joint": Motion(one, 30.0, walk.root_translation, walk.rotations[:, :1], metres_per_unit=1.0),
        "zero_bones": zero,
        "root_far": _clip(far=1e300),  # finite, so readable: the commands refuse it
        "offset_far": walk.replace(
            skeleton=dataclasses.replace(walk.skeleton, offsets=walk.skeleton.offsets * [1, 1e300, 1])
        ),
    }
    return {k: write_bvh(m, folder / f"{k}.bvh") for k, m in cases.items()}


def test_degenerate_inputs_through_the_commands_give_no_numpy_warning(tmp_path):
    files = _degenerate_files(tmp_path)
    for name, f in files.items():
        f = str(f)
        for argv in (
            ["info", f],
            [
                "loop",
                f,
                "-o",
                str(tmp_path / f"{name}.loop.bvh"),
                "--force",
                "--window",
                "whole",
                "--units",
                "m",
            ],
            ["blend", f, f, "-o", str(tmp_path / f"{name}.blend.bvh"), "--units", "m"],
            ["distance", f, f, "--units", "m"],
        ):
            rc, text, caught = _run(argv)
            what = f"{argv[0]} {name}: {text[-300:]}"
            assert not caught, (what, caught)
            assert rc in (0, 2), what
            assert "Traceback" not in text and "Warning" not in text, what
            if rc == 2:
                assert "expected" in text, what  # a message that teaches
            else:
                assert not ABSURD.search(text), what
        if name.endswith("_far"):  # refused by the preparation, naming the file and what is far
            assert rc == 2 and f"{name}: expected offsets and positions within 1e+06 m" in text, text


def test_loop_summary_of_a_clip_that_does_not_move(tmp_path, mocap_dir):
    """A CMU pose held for 40 frames: its seam ratios were rounding noise over the smallest
    float (acceleration 3.6e+295x); now 0, and the summary says nothing moves there. Its feet
    never swing: the report's null clearances say why."""
    m = drop_tpose(read_motion(mocap_dir / "cmu/bvh/08_02.bvh"))
    still = select_frames(m, np.full(40, 10))
    src = write_bvh(still, tmp_path / "still.bvh")
    rc, text, caught = _run(
        ["loop", str(src), "-o", str(tmp_path / "out.bvh"), "--force", "--json", str(tmp_path / "r.json")]
    )
    assert rc == 0 and not caught, (text, caught)
    assert not ABSURD.search(text), text
    assert "around the seam (0.3 s each side): n/a, no point moves there" in text
    rep = json.loads((tmp_path / "r.json").read_text())
    after = rep["seam_after"]
    assert (
        after["seam_acceleration_ratio"]
        == after["seam_speed_ratio"]
        == after["seam_velocity_jump_ratio"]
        == 0
    )
    feet = rep["feet_before"]
    assert feet["swing_clearance_m"] and all(v is None for v in feet["swing_clearance_m"].values())
    assert "never swings" in feet["swing_clearance_null"]


def test_summaries_without_feet_say_n_a(tmp_path):
    names = ("root", "hip", "knee", "shin")  # no foot, toe or ankle
    a = write_bvh(_clip(names), tmp_path / "a.bvh")
    b = write_bvh(_clip(names, frames=50), tmp_path / "b.bvh")
    rc, text, _ = _run(["loop", str(a), "-o", str(tmp_path / "l.bvh"), "--force", "--units", "m"])
    assert rc == 0, text
    assert "feet: n/a, no joint named foot, toe or ankle to measure" in text
    assert "skids 0 -> 0" not in text
    rc, text, _ = _run(["blend", str(a), str(b), "-o", str(tmp_path / "bl.bvh"), "--units", "m"])
    assert rc == 0, text
    assert "foot sliding and feet: n/a, no joint named foot, toe or ankle to measure" in text
    assert "foot sliding (m/s)" not in text


def test_seam_choice_when_the_c0_loop_does_not_skate():
    """C1 skating where C0 does not (0 m/s) is a reason to keep C0, said without dividing by 0."""
    c0 = loop_motion(_clip(), seam="c0", contacts="off", window=None, force=True)
    none = ContactSkating(0.0, 0.0, {}, 0, 0.0, 0.0)
    some = ContactSkating(0.2, 0.3, {"foot": 0.2}, 10, 0.0, 0.0)
    smoother = dataclasses.replace(
        c0.seam_after, seam_velocity_jump_ratio=c0.seam_after.seam_velocity_jump_ratio / 2
    )
    c0 = dataclasses.replace(c0, skating_after=none)
    c1 = dataclasses.replace(c0, seam="c1", seam_after=smoother, skating_after=some)
    kept = choose_seam(c0, c1)
    (why,) = of_kind(kept.notes, SEAM_C0_KEPT)
    assert "it skates where the C0 loop does not (0.2 against 0 m/s)" in str(why)


def test_fmt_float_says_n_a_for_nan():
    assert fmt_float(float("nan")) == "n/a" and fmt_float(np.float64("nan")) == "n/a"
    assert fmt_float(0.12345) == "0.123" and fmt_float(None) == "None"
