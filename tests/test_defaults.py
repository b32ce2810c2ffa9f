"""The light homes of the command line's words and numbers (:mod:`elastic_motion.vocabulary`,
:mod:`elastic_motion.defaults`): the API's types and defaults *are* theirs, the flags default to
the API's defaults, and the two modules load nothing else."""

from __future__ import annotations

import argparse
import subprocess
import sys

import pytest

from elastic_motion import defaults, vocabulary
from elastic_motion.apps import align, blend_options, landmark_files, landmarks, render, statistics
from elastic_motion.apps.database import MeanOptions, engines, settings
from elastic_motion.apps.database.settings import DEFAULT_WARP
from elastic_motion.apps.loop import LoopOptions
from elastic_motion.apps.loop import options as loop_options
from elastic_motion.apps.viewer import ViewerOptions
from elastic_motion.apps.viewer import options as viewer_options
from elastic_motion.cli import build_parser, subcommand_parsers
from elastic_motion.motion import contacts, edit, looping, representations
from elastic_motion.motion.contacts import ContactOptions
from elastic_motion.warp import WarpOptions
from elastic_motion.warp import options as warp_options

# ------------------------------------------------------------------------------------------
# One home: the API's names are the vocabulary's objects
# ------------------------------------------------------------------------------------------

#: (module, name there, name in elastic_motion.vocabulary)
REEXPORTS = [
    (representations, "Method", "Method"),
    (representations, "METHODS", "METHODS"),
    (align, "CurveMethod", "CurveMethod"),
    (align, "METHODS", "CURVE_METHODS"),
    (warp_options, "WarpMethod", "WarpMethod"),
    (warp_options, "WARP_METHODS", "WARP_METHODS"),
    (edit, "INTERPOLATIONS", "INTERPOLATIONS"),
    (landmark_files, "TimeUnit", "TimeUnit"),
    (landmark_files, "TIME_UNITS", "TIME_UNITS"),
    (landmarks, "EVENT_KINDS", "EVENT_KINDS"),
    (landmarks, "GAIT_KINDS", "GAIT_KINDS"),
    (landmarks, "DEFAULT_PAIR_KINDS", "DEFAULT_PAIR_KINDS"),
    (contacts, "ContactPolicy", "ContactPolicy"),
    (contacts, "CONTACT_POLICIES", "CONTACT_POLICIES"),
    (looping, "RootMode", "RootMode"),
    (looping, "ROOT_MODES", "ROOT_MODES"),
    (loop_options, "Seam", "Seam"),
    (loop_options, "SEAMS", "SEAMS"),
    (loop_options, "Solver", "Solver"),
    (loop_options, "SOLVERS", "SOLVERS"),
    (loop_options, "LimitPolicy", "LimitPolicy"),
    (loop_options, "LIMIT_POLICIES", "LIMIT_POLICIES"),
    (loop_options, "WindowMode", "WindowMode"),
    (loop_options, "WINDOW_MODES", "WINDOW_MODES"),
    (blend_options, "SkeletonMode", "SkeletonMode"),
    (blend_options, "SKELETON_MODES", "SKELETON_MODES"),
    (statistics, "Linkage", "Linkage"),
    (statistics, "LINKAGES", "LINKAGES"),
    (engines, "EngineName", "EngineName"),
    (engines, "ENGINES", "ENGINES"),
    (settings, "JOINT_SELECTIONS", "JOINT_SELECTIONS"),
    (render, "RenderKind", "RenderKind"),
    (render, "KINDS", "RENDER_KINDS"),
    (render, "RotationFrame", "RotationFrame"),
    (render, "FRAMES", "ROTATION_FRAMES"),
    (viewer_options, "Layout", "Layout"),
    (viewer_options, "LAYOUTS", "LAYOUTS"),
    (viewer_options, "ContactMarks", "ContactMarks"),
    (viewer_options, "CONTACT_MARKS", "CONTACT_MARKS"),
]


@pytest.mark.parametrize(("module", "name", "home"), REEXPORTS, ids=lambda x: getattr(x, "__name__", x))
def test_the_apis_vocabulary_is_the_vocabulary_modules(module, name, home):
    assert getattr(module, name) is getattr(vocabulary, home)


def test_every_value_tuple_lists_its_literal():
    for name in vocabulary.__all__:
        values = getattr(vocabulary, name)
        if isinstance(values, tuple) and name.isupper() and name not in ("GAIT_KINDS", "DEFAULT_PAIR_KINDS"):
            assert values and all(isinstance(v, str) for v in values), name
    assert set(vocabulary.DEFAULT_PAIR_KINDS) <= set(vocabulary.EVENT_KINDS)
    assert set(vocabulary.GAIT_KINDS) <= set(vocabulary.EVENT_KINDS)


def test_aliases_name_words_of_their_vocabulary():
    assert set(vocabulary.METHOD_ALIASES.values()) <= set(vocabulary.METHODS)
    assert set(vocabulary.CONTACT_POLICY_ALIASES.values()) <= set(vocabulary.CONTACT_POLICIES)
    assert set(vocabulary.CONTACT_MARK_ALIASES.values()) <= set(vocabulary.CONTACT_MARKS)
    assert representations.representation("euler").name == "euler-elastic"
    assert contacts.contact_policy("auto") == "keep" and contacts.contact_policy("none") == "off"
    assert viewer_options.contact_marks("none") == "off"


def test_the_light_homes_import_nothing_but_typing():
    code = (
        "import sys\nbefore = set(sys.modules)\n"
        "import elastic_motion.vocabulary, elastic_motion.defaults\n"
        "print('\\n'.join(sorted(set(sys.modules) - before)))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    new = set(out.stdout.split())
    assert {m for m in new if m.startswith("elastic_motion")} == {
        "elastic_motion",
        "elastic_motion._version",
        "elastic_motion.vocabulary",
        "elastic_motion.defaults",
    }
    assert not {"numpy", "numba", "scipy"} & new


# ------------------------------------------------------------------------------------------
# The defaults: the options classes' are the module's, and the flags default to them
# ------------------------------------------------------------------------------------------


def test_the_options_classes_take_their_defaults_from_the_module():
    w = WarpOptions()
    assert (w.method, w.neighbourhood, w.sample_fps, w.sample_smoothing, w.landmark_weight) == (
        defaults.DEFAULT_METHOD,
        defaults.DEFAULT_MAX_STEP,
        defaults.DEFAULT_SAMPLE_FPS,
        defaults.DEFAULT_SAMPLE_SMOOTHING,
        defaults.DEFAULT_LANDMARK_WEIGHT,
    )
    assert DEFAULT_WARP.method == defaults.MEAN_WARP_METHOD == statistics.MEAN_WARP.method
    assert DEFAULT_WARP.sample_smoothing == defaults.DEFAULT_SAMPLE_SMOOTHING  # distance's low-pass
    assert MeanOptions().warp.method == defaults.MEAN_WARP_METHOD
    assert align.AUTO_LANDMARK_WEIGHT == defaults.AUTO_LANDMARK_WEIGHT
    c = ContactOptions()
    assert (c.height_enter, c.speed_enter) == (defaults.CONTACT_HEIGHT_ENTER, defaults.CONTACT_SPEED_ENTER)
    v = ViewerOptions()
    assert (v.layout, v.max_frames, v.max_fps, v.contacts, v.title) == (
        defaults.VIEWER_LAYOUT,
        defaults.VIEWER_MAX_FRAMES,
        defaults.VIEWER_MAX_FPS,
        defaults.VIEWER_CONTACTS,
        defaults.VIEWER_TITLE,
    )


def test_the_loop_constants_are_loop_options_defaults():
    """LoopOptions spells its defaults; ``defaults.LOOP_*`` repeat them for the command line."""
    o = LoopOptions()
    assert (o.root, o.seam, o.method, o.solver, o.tol, o.max_iter, o.free_joints, o.joint_limits) == (
        defaults.LOOP_ROOT,
        defaults.LOOP_SEAM,
        defaults.LOOP_METHOD,
        defaults.LOOP_SOLVER,
        defaults.LOOP_TOL,
        defaults.LOOP_MAX_ITER,
        defaults.LOOP_FREE_JOINTS,
        defaults.LOOP_JOINT_LIMITS,
    )


def _actions(command: str) -> dict[str, argparse.Action]:
    parser = subcommand_parsers(build_parser())[command]
    return {s: a for a in parser._actions for s in a.option_strings if s.startswith("--")}


def test_the_flags_default_to_the_apis_defaults():
    loop = _actions("loop")
    fields = {
        "--root": "root",
        "--seam": "seam",
        "--method": "method",
        "--solver": "solver",
        "--tol": "tol",
        "--max-iter": "max_iter",
        "--free-joints": "free_joints",
        "--contacts": "contacts",
        "--joint-limits": "joint_limits",
    }
    for flag, field in fields.items():
        assert loop[flag].default == getattr(LoopOptions(), field), flag
    w = WarpOptions()
    for command in ("blend", "align", "distance", "landmarks"):
        a = _actions(command)
        assert a["--warp"].default == w.method, command
        assert a["--neighbourhood"].default == w.neighbourhood, command
        assert a["--sample-fps"].default == w.sample_fps, command
        assert a["--sample-smoothing"].default == w.sample_smoothing, command
        if command != "distance":  # no landmarks there
            assert f"(default: {w.landmark_weight:g};" in a["--landmark-weight"].help, command
    for command in ("matrix", "search", "mean", "index", "pca"):
        help_ = {flag: a.help for flag, a in _actions(command).items()}
        assert help_["--warp"].endswith(f"(default: {DEFAULT_WARP.method})"), command
        assert help_["--neighbourhood"].endswith(f"(default: {DEFAULT_WARP.neighbourhood})"), command
    for command in ("matrix", "search", "index"):  # the database's low-pass, distance's flag
        a = _actions(command)["--sample-smoothing"]
        assert a.help.endswith(f"(default: {DEFAULT_WARP.sample_smoothing:g})"), command
    c = ContactOptions()
    for command in ("blend", "loop"):
        text = _actions(command)["--contact-height"].help
        assert f"{c.speed_enter:g} m/s" in text and f"(default: {c.height_enter:g})" in text, command
    view, v = _actions("view"), ViewerOptions()
    for flag, field in {
        "--layout": "layout",
        "--contacts": "contacts",
        "--max-frames": "max_frames",
        "--max-fps": "max_fps",
        "--title": "title",
    }.items():
        assert view[flag].default == getattr(v, field), flag
