"""Options and helpers shared by the database sub-commands (``matrix``, ``search``,
``classify``, ``mean``, ``cluster``, ``index``, ``pca``): the preparation and warp options,
``--method``, the settings they make, the error line and the report.

The allowed values are read from the API's types (:mod:`elastic_motion.vocabulary`):
``--method`` from :data:`~elastic_motion.vocabulary.Method`, ``--linkage`` from
:data:`~elastic_motion.vocabulary.Linkage`, ``--engine`` from
:data:`~elastic_motion.vocabulary.EngineName`, ``--joints`` from
:data:`~elastic_motion.vocabulary.JOINT_SELECTIONS`; the warp defaults to the database's
(:data:`elastic_motion.defaults.MEAN_WARP_METHOD`). This module loads no numpy (it is imported
when the parser is built); what makes the parsed flags into the apps' settings is in
:mod:`._database_running`, which a command imports inside its ``run``.
"""

from __future__ import annotations

import argparse

from elastic_motion._options import choices
from elastic_motion.cli_commands._argparse import EXIT_BAD_INPUT, add_alias, handle_error, print_error
from elastic_motion.cli_commands._common import (
    CommandError,
    add_sample_smoothing,
    add_up_units_options,
    add_warp_options,
    joints_arg,
)
from elastic_motion.defaults import MEAN_WARP_METHOD
from elastic_motion.errors import OptionError, ParseError
from elastic_motion.vocabulary import JOINT_SELECTIONS, EngineName, Linkage, Method

#: Curve representations (``--method``) of the database commands (``euler`` is accepted for
#: ``euler-elastic``, the name of the other commands).
METHODS = choices(Method)
#: Linkages of ``cluster --linkage``.
LINKAGES = choices(Linkage)
#: Engines of ``matrix --engine``.
ENGINES = choices(EngineName)
#: Removed in this release (shown in the deprecation notes of the old spellings).
ALIAS_UNTIL = "0.3"

#: Python argument names (``OptionError.option``) -> the flag that sets them; ``None``: the
#: message already starts with the file it concerns.
FLAGS: dict[str, str | None] = {
    "representation": "--method",
    "representations": "--method",
    "n_samples": "--samples",
    "joints": "--joints",
    "warp": "--warp",
    "neighbourhood": "--neighbourhood",
    "sample_smoothing": "--sample-smoothing",
    "tile_size": "--tile-size",
    "out_dir": "--output",
    "k": "-k",
    "n_clusters": "--clusters",
    "method": "--method",
    "linkage": "--linkage",
    "labels": "--labels",
    "scheduler": "--scheduler",
    "engine": "--engine",
    "inputs": "inputs",
    "pose_weight": "--pose-weight",
    "cyclic": "--cyclic",
    "takes": "DATABASE",
    "up": "--up",
    "units": "--units",
    "database": "DATABASE",
}

#: The settings fields (``DatabaseSettings``, flat: ``warp.<field>``) -> the flag that sets them.
FIELD_FLAGS = {
    "n_samples": "--samples",
    "joints": "--joints",
    "drop_fingers": "--keep-fingers",
    "align_heading": "--no-align",
    "warp.method": "--warp",
    "warp.sample_smoothing": "--sample-smoothing",
    "warp.neighbourhood": "--neighbourhood",
    "warp.coarse_to_fine": "--coarse-to-fine",
    "pose_weight": "--pose-weight",
    "cyclic": "--cyclic",
    "up": "--up",
    "units": "--units",
}


def alias(p: argparse.ArgumentParser, old: str, new: str) -> None:
    add_alias(p, old, new, until=ALIAS_UNTIL)


def add_preparation(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--samples",
        type=int,
        default=64,
        help="cells of the common time grid: each motion is resampled to SAMPLES + 1 frames uniformly "
        "over its duration (default: 64)",
    )
    p.add_argument(
        "--joints",
        default="all",
        help="'all' (every joint: matrix groups motions by skeleton, mean needs one skeleton), 'common' "
        "(the joints all motions share), 'map' (every skeleton on a 13-joint common body through joint-name "
        "maps: CMU BVH/ASF, Bandai, DeepMimic) or a comma-separated list of joint names (default: all)",
    )
    p.add_argument("--keep-fingers", action="store_true", help="keep finger/thumb joints (default: dropped)")
    p.add_argument(
        "--no-align",
        action="store_true",
        help="do not remove the heading and floor position of the root at frame 0 (default: removed)",
    )
    alias(p, "--no-align-heading", "--no-align")
    add_up_units_options(p)  # every file the command reads, a search's query included


def joints_option(value: str) -> str | tuple[str, ...]:
    """``--joints``' value: one of :data:`JOINT_SELECTIONS` or a tuple of joint names."""
    return joints_arg(value, JOINT_SELECTIONS)


def add_warp(p: argparse.ArgumentParser, *, mean: bool = False) -> None:
    """``--warp``, ``--neighbourhood``, ``--coarse-to-fine`` with the database's defaults (the
    DP alone: ``apps.database.settings.DEFAULT_WARP`` says why), and ``--sample-smoothing``
    (``distance``'s low-pass) unless ``mean`` (a Karcher mean's options have no low-pass)."""
    add_warp_options(p, method=MEAN_WARP_METHOD, sampling=False, coarse_to_fine=True)
    if not mean:
        add_sample_smoothing(  # distance's flag, the same low-pass (DatabaseSettings.warp.sample_smoothing)
            p, "each motion on the --samples grid, as distance does before sampling its curves", None
        )


def add_distance_terms(p: argparse.ArgumentParser) -> None:
    """``--pose-weight`` and ``--cyclic`` (``DatabaseSettings.pose_weight`` / ``cyclic``)."""
    p.add_argument(
        "--pose-weight",
        default=None,
        metavar="{balanced,W}",
        help="weight of a pose term beside the SRV (the joints' rotations, which the SRV does not see): "
        "'balanced' (as much mean squared pair distance as the SRV term over the database; no labels) or a "
        "number >= 0; 0: the SRV alone (default: 0)",
    )
    p.add_argument(
        "--cyclic",
        action="store_true",
        default=None,  # None: not given (a stored database's own setting is then no surprise)
        help="phase-free matching: the least distance over the cyclic shifts of either motion's cells "
        "(windows of periodic motions started at different phases; 2 x SAMPLES times the cost; needs --warp "
        "dp) (default: off)",
    )


def add_method(p: argparse.ArgumentParser, *, several: bool) -> None:
    """``--method`` (the curve representation), with the old spelling ``--repr``."""
    names = "{" + ",".join(METHODS) + "}"
    if several:
        p.add_argument(
            "--method",
            default="lie,euler",
            metavar=names + "[,...]",
            help="curve representations, comma-separated: lie (R^3 x SO(3)^J) and/or euler-elastic (Euler "
            "angles, radians; 'euler' also accepted) (default: lie,euler)",
        )
    else:
        p.add_argument(
            "--method",
            default="lie",
            metavar=names,
            help="curve representation: lie (R^3 x SO(3)^J) or euler-elastic (Euler angles, radians; 'euler' "
            "also accepted) (default: lie)",
        )
    alias(p, "--repr", "--method")


def defaults_unset(p: argparse.ArgumentParser) -> None:
    """Make the preparation, warp and distance-term flags of ``p`` default to None ("not given"),
    for a command that may read a stored database, which uses its own settings: only the
    flags given are then compared with them (:func:`._database_running.given_fields`).
    :func:`._database_running.database_settings` fills the others with
    :class:`~elastic_motion.apps.database.DatabaseSettings`' defaults, the values the help text
    shows."""
    p.set_defaults(
        samples=None,
        joints=None,
        keep_fingers=None,
        no_align=None,
        warp=None,
        neighbourhood=None,
        coarse_to_fine=None,
    )


def fail(command: str, exc: BaseException) -> int:
    """Print ``elastic-motion CMD: error: FILE-OR-OPTION: expected ...; got ...``; return the exit code.

    An :class:`~elastic_motion.errors.OptionError` is shown with the flag that sets the option.
    """
    if isinstance(exc, OptionError) and exc.option in FLAGS:
        flag = FLAGS[exc.option]
        print_error(command, exc.message if flag is None else f"{flag}: {exc.message}")
        return EXIT_BAD_INPUT
    if isinstance(exc, OSError) and exc.errno is None and exc.args:  # our own FILE: expected ...; got ...
        print_error(command, str(exc))
        return EXIT_BAD_INPUT
    return handle_error(command, exc)


#: Exceptions a database command reports as an error line (others are bugs and propagate).
USER_ERRORS = (CommandError, ValueError, KeyError, OSError, ParseError)
