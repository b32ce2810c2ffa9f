"""Command-line hygiene: defaults in every --help, deprecated aliases, docs/cli.md up to date."""

from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

from elastic_motion.cli import build_parser, main, subcommand_parsers
from elastic_motion.cli_commands._argparse import (
    CliParser,
    DefaultsHelpFormatter,
    add_alias,
    format_default,
    mentions_default,
)

REPO = Path(__file__).resolve().parents[1]


def _gen_cli():
    spec = importlib.util.spec_from_file_location("gen_cli", REPO / "docs" / "gen_cli.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _printed_help(parser: argparse.ArgumentParser, action: argparse.Action) -> str:
    """The help of one option as ``--help`` prints it, without its invocation, unwrapped."""
    formatter = parser._get_formatter()
    text = formatter._format_action(action)
    text = text.split(formatter._format_action_invocation(action), 1)[1]
    return " ".join(text.split())


def _gives_default(text: str, default: object) -> bool:
    if mentions_default(text, default):
        return True
    squeezed = "".join(text.split())  # a long value may be broken across lines
    return "default" in squeezed and "".join(format_default(default).split()) in squeezed


# ------------------------------------------------------------------------------------------
# Every default in --help
# ------------------------------------------------------------------------------------------


def test_every_option_with_a_default_shows_it_in_help():
    parser = build_parser()
    subs = subcommand_parsers(parser)
    assert {"info", "blend", "loop", "matrix", "render", "demo"} <= set(subs)
    missing = []
    for name, sub in subs.items():
        assert isinstance(sub, CliParser) and sub.formatter_class is DefaultsHelpFormatter, name
        for action in sub._actions:
            default = action.default
            if default in (None, False, argparse.SUPPRESS) or action.help == argparse.SUPPRESS:
                continue
            if action.nargs == 0:  # a flag (store_true, --help): nothing to show
                continue
            text = _printed_help(sub, action)
            if not _gives_default(text, default):
                missing.append(f"{name} {'/'.join(action.option_strings) or action.dest}: {text!r}")
    assert not missing, "options whose --help does not give their default:\n" + "\n".join(missing)


def test_formatter_appends_the_default_once():
    p = CliParser(prog="elastic-motion test")
    p.add_argument("--weight", type=float, default=0.5, help="s in (1-s) A + s B")
    p.add_argument("--tol", type=float, default=1e-4, help="stop below this (default 1e-4)")
    p.add_argument("--kind", default="auto", help="what to draw; the default guesses")
    p.add_argument("--size", default="320x320", help="pixels, 5%% of the screen")
    p.add_argument("--names", nargs="+", default=["a", "b"], help="labels")
    p.add_argument("--out", default=None, help="output")
    p.add_argument("--fast", action="store_true", help="go fast")
    p.add_argument("--hidden", default=3, help=argparse.SUPPRESS)
    text = " ".join(p.format_help().split())
    assert "s in (1-s) A + s B (default: 0.5)" in text
    assert "stop below this (default 1e-4)" in text and "(default: 0.0001)" not in text
    assert "the default guesses (default: auto)" in text  # "default" alone does not give the value
    assert "pixels, 5% of the screen (default: 320x320)" in text
    assert "labels (default: a b)" in text
    assert "output (default" not in text and "go fast (default" not in text and "hidden" not in text
    assert format_default(30.0) == "30" and mentions_default("rate (default 10)", 10.0)


def test_formatter_keeps_indented_paragraphs():
    p = CliParser(prog="x", description="one two three " * 20, epilog="codes:\n  0  ok\n  2  bad input")
    text = p.format_help()
    assert "codes:\n  0  ok\n  2  bad input" in text
    assert max(len(line) for line in text.splitlines()) <= 100


# ------------------------------------------------------------------------------------------
# Deprecated aliases
# ------------------------------------------------------------------------------------------


def _parser() -> CliParser:
    p = CliParser(prog="elastic-motion matrix")
    p.add_argument("--method", choices=("lie", "euler"), default="lie", help="representation")
    p.add_argument("-o", "--output", required=True, help="output folder")
    p.add_argument("--no-align", action="store_true", help="keep the heading")
    p.add_argument("--kinds", nargs="+", default=["a"], help="kinds")
    add_alias(p, "--repr", "--method")
    add_alias(p, "--out", "--output", until="0.3")
    add_alias(p, "--no-align-heading", "--no-align")
    add_alias(p, "--kind-list", "--kinds", convert=lambda v: v.split(","), nargs=None)
    return p


def test_alias_works_hidden_and_notes_the_deprecation(capsys):
    p = _parser()
    args = p.parse_args(["--out", "db", "--repr", "euler", "--no-align-heading", "--kind-list", "x,y"])
    assert (args.output, args.method, args.no_align, args.kinds) == ("db", "euler", True, ["x", "y"])
    assert capsys.readouterr().err.splitlines() == [
        "elastic-motion matrix: note: --out is deprecated and will be removed in 0.3; use --output",
        "elastic-motion matrix: note: --repr is deprecated; use --method",
        "elastic-motion matrix: note: --no-align-heading is deprecated; use --no-align",
        "elastic-motion matrix: note: --kind-list is deprecated; use --kinds",
    ]
    args = p.parse_args(["-o", "db"])  # no alias: defaults, no note
    assert (args.method, args.no_align, args.kinds) == ("lie", False, ["a"])
    assert capsys.readouterr().err == ""
    text = p.format_help()
    assert "--repr" not in text and "--out " not in text and "--no-align-heading" not in text
    assert "--method" in text and "--output" in text


def test_alias_checks_values_like_the_new_option(capsys):
    p = _parser()
    with pytest.raises(SystemExit) as exc:
        p.parse_args(["-o", "db", "--repr", "spline"])
    assert exc.value.code == 2
    assert capsys.readouterr().err.splitlines()[-1] == (
        "elastic-motion matrix: error: --repr: expected one of 'lie', 'euler'; got 'spline'"
    )
    with pytest.raises(SystemExit):  # a required option is still required
        p.parse_args(["--repr", "lie"])
    assert (
        capsys.readouterr()
        .err.splitlines()[-1]
        .endswith("-o/--output: expected a value (required); got none")
    )
    assert p._option_string_actions["--output"].required
    with pytest.raises(ValueError, match="--nope"):
        add_alias(p, "--old", "--nope")


def test_alias_through_the_cli(monkeypatch, capsys, tmp_path):
    """A command registering an alias gets it in `elastic-motion CMD` (here `info --unit`)."""
    from elastic_motion.cli_commands import info

    register = info.register

    def register_with_alias(subparsers):
        register(subparsers)
        add_alias(subparsers.choices["info"], "--unit", "--units")

    seen = {}

    def run(args):
        seen["units"] = args.units
        return 0

    monkeypatch.setattr(info, "register", register_with_alias)
    monkeypatch.setattr(info, "run", run)
    assert main(["info", str(tmp_path / "a.bvh"), "--unit", "cm"]) == 0
    assert seen["units"] == "cm"
    assert capsys.readouterr().err == "elastic-motion info: note: --unit is deprecated; use --units\n"


# ------------------------------------------------------------------------------------------
# docs/cli.md matches --help
# ------------------------------------------------------------------------------------------


def test_docs_cli_md_matches_help():
    gen = _gen_cli()
    text = gen.CLI_MD.read_text(encoding="utf-8")
    recorded = gen.recorded_python(text)
    here = f"{sys.version_info.major}.{sys.version_info.minor}"
    if recorded != here:
        pytest.skip(
            f"docs/cli.md was generated with Python {recorded}; argparse formats differently in {here}"
        )
    assert gen.render(text) == text, "docs/cli.md is out of date: run python docs/gen_cli.py"
    assert "| 3 | environment" in text  # the exit codes are documented


def test_gen_cli_replaces_only_between_markers(tmp_path, monkeypatch):
    gen = _gen_cli()
    doc = tmp_path / "cli.md"
    begin = "<!-- BEGIN elastic-motion info --help (generated by docs/gen_cli.py; do not edit) -->"
    doc.write_text(f"# Prose\n\nkept\n\n{begin}\nstale\n<!-- END elastic-motion info --help -->\n\nafter\n")
    assert gen.main(["--check", "--file", str(doc)]) == 1
    assert gen.main(["--file", str(doc)]) == 0
    out = doc.read_text()
    assert out.startswith("# Prose\n\nkept\n\n") and "\n\nafter\n" in out and "stale" not in out
    assert "$ elastic-motion info --help\nusage: elastic-motion info" in out
    assert "## `blend`" in out  # commands without markers are appended
    assert gen.main(["--check", "--file", str(doc)]) == 0
    monkeypatch.setenv("COLUMNS", "40")  # the terminal's width does not matter
    assert gen.render(out) == out


# ------------------------------------------------------------------------------------------
# Start-up: building the parser loads no app and no numerics
# ------------------------------------------------------------------------------------------

#: What building the parser must not import: the apps that are heaviest to load, and the
#: numerical stack (``elastic-motion --help`` took 1.4 s with them, 0.3 s without).
NOT_AT_START = ("elastic_motion.apps.loop", "elastic_motion.apps.blend", "numba", "scipy", "numpy")


def _loaded_by(code: str) -> set[str]:
    """The modules of :data:`NOT_AT_START` that ``code`` loads, in a fresh interpreter."""
    probe = f"{code}\nimport sys\nprint('\\n'.join(m for m in {NOT_AT_START!r} if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    return set(out.stdout.split())


def test_building_the_parser_loads_no_app_and_no_numerics():
    """The parser is built from the vocabularies and defaults alone (elastic_motion.vocabulary,
    elastic_motion.defaults): each command imports its app inside ``run``."""
    assert _loaded_by("from elastic_motion.cli import build_parser; build_parser()") == set()


def test_the_probe_sees_a_heavy_import():
    """The check above would see an app or numba if the parser loaded them."""
    assert {"elastic_motion.apps.loop", "numba", "numpy"} <= _loaded_by("import elastic_motion.apps.loop")
