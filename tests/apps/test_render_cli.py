"""``elastic-motion render`` and ``demo`` on the command line: help texts, options per kind."""

from __future__ import annotations

import pytest
from blend_testlib import walker

from elastic_motion.cli import build_parser, main, subcommand_parsers
from elastic_motion.motion import write_bvh

#: Options added by the shared helpers of ``cli_commands/_common.py`` (not defined here).
_SHARED = {"help", "trim", "keep_first_frame", "units", "up", "units_out", "json", "quiet"}


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    path = tmp_path_factory.mktemp("render_cli") / "walk.bvh"
    write_bvh(walker(duration=1.0), path)
    return str(path)


@pytest.mark.parametrize("command", ["render", "demo"])
def test_help_gives_every_default_and_unit(command):
    sub = subcommand_parsers(build_parser())[command]
    assert sub._option_string_actions["-o"] is sub._option_string_actions["--output"]
    for action in sub._actions:
        if action.dest in _SHARED or not action.option_strings:
            continue
        text = " ".join((action.help or "").split())
        assert "(default: " in text or "(required" in text, f"{action.option_strings}: {text!r}"
    if command == "render":
        helps = {a.dest: " ".join((a.help or "").split()) for a in sub._actions}
        assert "frames per second" in helps["fps"] and "pixels" in helps["size"]
        for dest in ("seconds", "trail", "landmarks"):
            assert "seconds" in helps[dest], dest


def test_options_of_another_kind_are_refused(clip, tmp_path, capsys):
    code = main(["render", clip, "-o", str(tmp_path / "x.gif"), "--repeat", "2", "-q"])
    assert code == 2
    assert "--repeat: only used with --kind seam" in capsys.readouterr().err
    code = main(["render", clip, "-o", str(tmp_path / "x.png"), "--fps", "10", "-q"])
    assert code == 2
    assert "--fps: only used with --kind animation" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_seam_joints(clip, tmp_path, capsys):
    out = tmp_path / "seam.png"
    args = ["render", clip, "-o", str(out), "--kind", "seam", "--repeat", "2", "-q"]
    assert main([*args, "--joints", "Head,LeftFoot"]) == 0
    assert out.stat().st_size > 5000
    assert main([*args, "--joints", "NoSuchJoint"]) == 2
    assert "NoSuchJoint" in capsys.readouterr().err


def test_parser_defaults_do_not_leak_into_other_kinds():
    """Kind-specific options default to None so that ``run`` can tell what the user set."""
    sub = subcommand_parsers(build_parser())["render"]
    args = sub.parse_args(["a.bvh", "-o", "x.gif"])
    for dest in ("fps", "size", "seconds", "trail", "joint", "frame", "repeat", "root", "method"):
        assert getattr(args, dest) is None, dest
