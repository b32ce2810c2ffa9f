"""Every command that reads motion files takes ``--up`` and ``--units`` (issue 31: ``view``,
``matrix`` and ``search`` had neither, so a Z-up Blender export could not be named Z-up
there).

The test walks every sub-parser of the real parser: a command is either in :data:`NO_MOTIONS`
(it reads no motion file, with the reason) or has both options, ``--up`` with the API's axes.
A new command falls in neither and fails until it gets them. What the options change is
tested in ``tests/apps/test_cli_up_units_behaviour.py``.
"""

from __future__ import annotations

import argparse

from elastic_motion.cli import build_parser, subcommand_parsers
from elastic_motion.vocabulary import UP_AXES

#: Commands that read no motion file themselves.
NO_MOTIONS = {
    "demo": "reads the DeepMimic clips of pybullet, a format with a fixed up axis and unit",
    "blender-addon": "writes the Blender add-on; reads nothing",
    "classify": "reads a matrix folder (its motions were read by `matrix`, with its --up/--units)",
    "cluster": "reads a matrix folder (its motions were read by `matrix`, with its --up/--units)",
}


def _options(sub: argparse.ArgumentParser) -> dict[str, argparse.Action]:
    return {s: a for a in sub._actions for s in a.option_strings}


def test_every_command_that_reads_motions_takes_up_and_units():
    parsers = subcommand_parsers(build_parser())
    assert set(NO_MOTIONS) <= set(parsers), sorted(set(NO_MOTIONS) - set(parsers))
    missing = {}
    for name, sub in parsers.items():
        opts = _options(sub)
        if name in NO_MOTIONS:
            reads = "--up" in opts or "--units" in opts
            assert not reads, f"{name} reads motions now: drop it from NO_MOTIONS"
            continue
        lacks = [o for o in ("--up", "--units") if o not in opts]
        if lacks:
            missing[name] = lacks
            continue
        assert tuple(opts["--up"].choices) == tuple(UP_AXES), name
        assert opts["--up"].default is None and opts["--units"].default is None, name  # None: detect, guess
    assert not missing, f"commands that read motions without --up/--units: {missing}"
    # the commands of the issue, and the database ones, are among them
    for name in ("view", "matrix", "search", "index", "mean", "pca", "info", "render", "loop", "blend"):
        assert name not in NO_MOTIONS and name in parsers
