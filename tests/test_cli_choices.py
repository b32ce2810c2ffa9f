"""Every choice list of the command line is the API's (issue 28): a ``choices=`` re-typed in a
command module drifts from what the Python API accepts (seven copies of ``("lie",
"euler-elastic")``, one of them ``"euler "``).

The test walks every sub-parser of the real parser, collects every argparse action with
``choices`` and checks it against :data:`API` (the types of the Python API). An action with
choices not in the table fails: a new re-typed tuple cannot sneak in.
"""

from __future__ import annotations

import argparse

import pytest

from elastic_motion._options import choices
from elastic_motion.apps.align import METHODS as CURVE_METHODS
from elastic_motion.apps.blend_options import SKELETON_MODES
from elastic_motion.apps.database.engines import ENGINES
from elastic_motion.apps.landmark_files import TIME_UNITS
from elastic_motion.apps.loop.options import SEAMS, SOLVERS, WINDOW_MODES
from elastic_motion.apps.render import FRAMES, KINDS
from elastic_motion.apps.statistics import LINKAGES
from elastic_motion.apps.viewer.options import CONTACT_MARKS, LAYOUTS
from elastic_motion.cli import build_parser, subcommand_parsers
from elastic_motion.cli_commands.view import PlotlyPlacement
from elastic_motion.motion.contacts import CONTACT_POLICIES
from elastic_motion.motion.edit import INTERPOLATIONS
from elastic_motion.motion.looping import ROOT_MODES
from elastic_motion.motion.representations import METHODS
from elastic_motion.vocabulary import CONTACT_WARP_MODES, UP_AXES
from elastic_motion.warp.options import WarpMethod

WARP = choices(WarpMethod)

#: (command, option) -> the API's allowed values the option's choices must be.
API: dict[tuple[str, str], tuple[str, ...]] = {
    # --warp: every command with a time warp (WarpOptions.method)
    **{
        (cmd, "--warp"): WARP
        for cmd in ("blend", "landmarks", "align", "distance", "matrix", "search", "mean", "index", "pca")
    },
    # --landmark-units: landmark times without a suffix (apps.landmark_files)
    ("blend", "--landmark-units"): TIME_UNITS,
    ("align", "--landmark-units"): TIME_UNITS,
    # --method: the curves of a warp (motion.representations; blend also has euler-linear)
    ("landmarks", "--method"): METHODS,
    ("align", "--method"): METHODS,
    ("distance", "--method"): METHODS,
    ("render", "--method"): METHODS,
    ("blend", "--method"): CURVE_METHODS,  # BlendOptions.method (euler-linear too)
    ("loop", "--method"): METHODS,  # LoopOptions.method
    ("blendspace", "--method"): METHODS,
    # render (apps.render, motion.looping)
    ("render", "--kind"): KINDS,
    ("render", "--frame"): FRAMES,
    ("render", "--root"): ROOT_MODES,
    # view (apps.viewer.options); --plotlyjs is the command's own (no Python equivalent)
    ("view", "--layout"): LAYOUTS,
    ("view", "--contacts"): CONTACT_MARKS,
    ("view", "--plotlyjs"): choices(PlotlyPlacement),
    # distance, database
    ("distance", "--interpolation"): INTERPOLATIONS,
    ("matrix", "--engine"): ENGINES,
    # loop (apps.loop.options.LoopOptions)
    ("loop", "--root"): ROOT_MODES,
    ("loop", "--seam"): SEAMS,
    ("loop", "--window"): WINDOW_MODES,
    ("loop", "--solver"): SOLVERS,
    ("loop", "--contacts"): CONTACT_POLICIES,
    # blend and blend spaces (apps.blend_options.BlendOptions): one contacts vocabulary
    ("blend", "--skeleton"): SKELETON_MODES,
    ("blend", "--contacts"): CONTACT_POLICIES,
    ("blend", "--contact-warp"): CONTACT_WARP_MODES,
    ("blendspace", "--contacts"): CONTACT_POLICIES,
    # cluster (apps.statistics)
    ("cluster", "--linkage"): LINKAGES,
    # --up: every command that reads motions (PrepareOptions.up)
    **{
        (cmd, "--up"): UP_AXES
        for cmd in (
            "blend",
            "landmarks",
            "loop",
            "align",
            "distance",
            "render",
            "blendspace",
            "info",
            "view",
            "matrix",
            "search",
            "index",
            "mean",
            "pca",
        )
    },
}


def _flag(action: argparse.Action) -> str:
    """The option's long name (``--method``), or its destination for a positional."""
    longs = [s for s in action.option_strings if s.startswith("--")]
    return longs[0] if longs else (action.option_strings or [action.dest])[0]


def _choice_actions() -> dict[tuple[str, str], argparse.Action]:
    """Every action with ``choices`` of every sub-command, deprecated aliases left out (they
    take their new option's choices: checked by :func:`test_aliases_take_their_options_choices`)."""
    out = {}
    for name, sub in subcommand_parsers(build_parser()).items():
        for action in sub._actions:
            if action.choices is None or isinstance(action, argparse._SubParsersAction):
                continue
            if hasattr(action, "target"):  # a deprecated alias
                continue
            out[(name, _flag(action))] = action
    return out


def test_every_choice_list_is_the_apis():
    actions = _choice_actions()
    table = API
    missing = sorted(set(actions) - set(table))
    assert not missing, (
        "options with choices that no API type gives (read them from the API's Literal with "
        f"elastic_motion._options.choices and add them to API): {missing}"
    )
    wrong = {
        key: (tuple(a.choices), tuple(table[key]))
        for key, a in actions.items()
        if tuple(a.choices) != tuple(table[key])
    }
    assert not wrong, f"choices differ from the API's (option: (CLI, API)): {wrong}"
    stale = sorted(set(table) - set(actions))
    assert not stale, f"table entries for options that have no choices any more: {stale}"


def test_aliases_take_their_options_choices():
    for name, sub in subcommand_parsers(build_parser()).items():
        for action in sub._actions:
            target = getattr(action, "target", None)
            if target is not None and action.choices is not None:
                assert tuple(action.choices) == tuple(target.choices), (name, action.option_strings)


@pytest.mark.parametrize("retyped", [("lie", "euler"), ("lie", "euler-elastic", "euler-linear")])
def test_a_retyped_list_fails(monkeypatch, retyped):
    """The check fails when a command re-types a list differently (here ``render --method``)."""
    from elastic_motion.cli_commands import render

    monkeypatch.setattr(render, "METHODS", retyped)
    actions = _choice_actions()
    assert tuple(actions[("render", "--method")].choices) == retyped
    with pytest.raises(AssertionError, match="choices differ"):
        test_every_choice_list_is_the_apis()


def test_a_new_choice_list_without_an_api_type_fails(monkeypatch):
    """An option with choices that is in neither table fails the check."""
    from elastic_motion.cli_commands import view

    register = view.register

    def register_with_a_new_option(subparsers):
        register(subparsers)
        subparsers.choices["view"].add_argument("--colour", choices=("red", "blue"))

    monkeypatch.setattr(view, "register", register_with_a_new_option)
    with pytest.raises(AssertionError, match=r"\('view', '--colour'\)"):
        test_every_choice_list_is_the_apis()
