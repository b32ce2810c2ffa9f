"""Running the ``elastic-motion`` command from Blender: command lines, the subprocess, errors.

Standard library only (Blender's Python has no numpy or numba): the add-on never imports
elastic-motion, it runs the command of the user's environment (its path is a preference)
and reads the files and the JSON report it writes.

The options a command knows are read from its ``--help`` (so that the add-on works with
releases that lack a newer option: the setting is then skipped with a warning).
"""

from __future__ import annotations

import dataclasses
import json
import os
import re
import subprocess
from dataclasses import dataclass, field

PREFERENCES_HINT = "Edit > Preferences > Add-ons > elastic-motion > elastic-motion command"


class CliNotFound(RuntimeError):
    """The ``elastic-motion`` command could not be started."""


@dataclass
class CliResult:
    """What one run of the command gave.

    Attributes
    ----------
    ok : bool
        Exit code 0.
    code : int
    message : str
        The command's error line (``--flag: expected ...; got ...``) when not ok, else "".
    report : dict or None
        The JSON report it wrote (or printed).
    stdout, stderr : str
    """

    ok: bool
    code: int
    message: str = ""
    report: dict | None = None
    stdout: str = ""
    stderr: str = ""
    warnings: list = field(default_factory=list)


def error_message(stderr: str, code: int) -> str:
    """The command's own error line from its stderr (``elastic-motion CMD: error: ...``)."""
    lines = [ln.strip() for ln in stderr.splitlines() if ln.strip()]
    for ln in reversed(lines):
        m = re.search(r"error: (.*)$", ln)
        if m:
            return m.group(1)
    if lines:
        return lines[-1]
    return f"elastic-motion failed with exit code {code} and no message"


def _run(executable: str, args: list, timeout: float) -> subprocess.CompletedProcess:
    exe = os.path.expanduser(executable.strip() or "elastic-motion")
    try:
        return subprocess.run(
            [exe, *args],
            capture_output=True,
            text=True,
            timeout=timeout,
            stdin=subprocess.DEVNULL,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
    except (FileNotFoundError, PermissionError, NotADirectoryError, OSError) as exc:
        raise CliNotFound(
            f"could not run the elastic-motion command {exe!r} ({exc.strerror or exc}); set its path in "
            f"{PREFERENCES_HINT} (e.g. /home/you/venv/bin/elastic-motion, the one `which elastic-motion` "
            "shows in the environment where it is installed)"
        ) from exc
    except subprocess.TimeoutExpired as exc:
        raise CliNotFound(
            f"elastic-motion did not finish within {timeout:g} s; raise the time limit in {PREFERENCES_HINT}"
        ) from exc


_HELP_CACHE: dict = {}


def command_help(executable: str, command: str, timeout: float = 60.0) -> str:
    """``elastic-motion COMMAND --help`` (cached per executable and command)."""
    key = (executable, command)
    if key not in _HELP_CACHE:
        proc = _run(executable, [command, "--help"], timeout)
        if proc.returncode != 0:
            raise CliNotFound(
                f"{executable!r} does not look like elastic-motion ('{command} --help' failed: "
                f"{error_message(proc.stderr, proc.returncode)}); set its path in {PREFERENCES_HINT}"
            )
        _HELP_CACHE[key] = proc.stdout
    return _HELP_CACHE[key]


def option_choices(help_text: str, flag: str):
    """``None`` when the command has no option ``flag``; its choices (``{a,b}``) or ``[]``."""
    m = re.search(re.escape(flag) + r"(?![\w-])(?: \{([^}]*)\}| ([A-Z_]+))?", help_text)
    if m is None:
        return None
    return m.group(1).split(",") if m.group(1) else []


@dataclass(frozen=True)
class BlendSettings:
    """The panel's blend settings, as :func:`blend_args` turns them into options.

    Attributes
    ----------
    weight : float, default 0.5
        ``--weight``: the share of B in the blend.
    warp : str, default "dp"
        ``--warp``: the time warp.
    landmarks : str, default ""
        ``--landmarks`` (empty: none).
    cleanup : bool, default True
        The footskate clean-up (``--contacts auto``, or ``off``).
    """

    weight: float = 0.5
    warp: str = "dp"
    landmarks: str = ""
    cleanup: bool = True


def blend_args(a, b, out, report, settings=None, *, help_text, extra=(), **overrides):
    """Command line of ``elastic-motion blend`` and the warnings about skipped settings.

    ``settings`` (a :class:`BlendSettings`, default ``BlendSettings()``) or its fields as
    keywords (``weight=0.3``); an unknown keyword is a ``TypeError`` naming it.
    """
    s = _settings(BlendSettings, settings, overrides, "blend_args")
    args = ["blend", a, b, "-o", out, "--json", report, "-q", "--weight", repr(float(s.weight))]
    args += ["--warp", s.warp]
    warnings = []
    if s.landmarks.strip():
        args += ["--landmarks", s.landmarks.strip()]
    if option_choices(help_text, "--skeleton") is not None:
        args += ["--skeleton", "first"]  # the armature's own bones: the action fits its rest pose
    # the footskate clean-up is `blend --contacts auto|off` (on by default when contacts are found)
    choices = option_choices(help_text, "--contacts")
    pick = None
    if choices:
        want = ("auto", "on") if s.cleanup else ("off", "none")
        pick = next((c for c in want if c in choices), None)
    if pick is not None:
        args += ["--contacts", pick]
    elif not s.cleanup:
        warnings.append("this elastic-motion has no --contacts option: the clean-up setting is ignored")
    args += list(extra)
    return args, warnings


@dataclass(frozen=True)
class LoopSettings:
    """The panel's loop settings, as :func:`loop_args` turns them into options.

    Attributes
    ----------
    root : str, default "travel"
        ``--root``: ``"travel"`` or ``"inplace"``.
    window : str, default "safe"
        ``--window``: ``"safe"`` (the whole clip when it loops with little change, else its
        best cycle), ``"whole"`` or ``"auto"``.
    contacts : bool, default True
        Keep the feet planted (``--contacts keep``), or not (``off``).
    force : bool, default False
        ``--force``: loop even a clip the loop would change by more than the command's bound.
    """

    root: str = "travel"
    window: str = "safe"
    contacts: bool = True
    force: bool = False


def _settings(kind, settings, overrides, caller):
    """``settings`` (default ``kind()``) with the keyword ``overrides``; an unknown keyword is a
    ``TypeError`` naming it."""
    fields = {f.name for f in dataclasses.fields(kind)}
    unknown = sorted(set(overrides) - fields)
    if unknown:
        raise TypeError(f"{caller}: unknown settings {unknown}; expected some of {sorted(fields)}")
    return dataclasses.replace(settings or kind(), **overrides)


def loop_args(inp, out, report, settings=None, *, help_text, extra=(), **overrides):
    """Command line of ``elastic-motion loop`` and the warnings about skipped settings.

    ``settings`` (a :class:`LoopSettings`, default ``LoopSettings()``) or its fields as
    keywords (``window="auto"``). Older versions of the command loop the whole clip by
    default and have neither the safe window nor ``--force``: said in a warning."""
    s = _settings(LoopSettings, settings, overrides, "loop_args")
    root, window, contacts, force = s.root, s.window, s.contacts, s.force
    args = ["loop", inp, "-o", out, "--json", report, "-q", "--root", root]
    warnings = []
    windows = option_choices(help_text, "--window")
    if windows is None:
        if window != "whole":
            warnings.append("this elastic-motion has no --window option: the whole clip is looped")
    elif "safe" in windows or window == "auto":
        args += ["--window", window]
    elif window == "safe":
        warnings.append("this elastic-motion has no safe window (an older version): the whole clip is looped")
    if force:
        if option_choices(help_text, "--force") is not None:
            args.append("--force")
        else:
            warnings.append("this elastic-motion has no --force option (it never refuses a loop)")
    choices = option_choices(help_text, "--contacts")
    if choices is not None:
        # "Keep the feet planted": 'keep' first ('report' only measures them, the feet slide)
        want = ("keep", "auto", "on", "report") if contacts else ("off", "none", "ignore")
        pick = next((c for c in want if c in choices), None) if choices else None
        if pick is not None:
            args += ["--contacts", pick]
    elif option_choices(help_text, "--no-contacts") is not None and not contacts:
        args.append("--no-contacts")
    elif not contacts:
        warnings.append("this elastic-motion has no contacts option: contacts setting ignored")
    args += list(extra)
    return args, warnings


#: Rest-pose sizes (largest extent, m) of a character at its real size; outside, the add-on
#: warns that the command measures contacts and seams in metres (a clip imported at the
#: wrong scale).
PLAUSIBLE_SIZE_M = (0.3, 4.0)

#: B moved vertically onto A's floor by more than this (m) is said in a warning.
FLOOR_NOTE_M = 0.01

#: What the add-on's exported files are (``transfer.export_bvh``): Blender's world is Z-up,
#: lengths are written in metres.
EXPORT_UP, EXPORT_UNITS = "z", "m"


def input_args(help_text, *, writes=True):
    """The options that say what the exported files are (``--up z --units m``) and, for a
    command that writes a BVH (``writes``), that its result is in metres too (``--units-out
    m``): nothing is left to the command's guesses. Options the command lacks (an older
    release) are skipped with a warning. Returns (options, warnings)."""
    wanted = [("--up", EXPORT_UP), ("--units", EXPORT_UNITS)]
    if writes:
        wanted.append(("--units-out", EXPORT_UNITS))
    args, missing = [], []
    for flag, value in wanted:
        if option_choices(help_text, flag) is None:
            missing.append(flag)
        else:
            args += [flag, value]
    warnings = []
    if missing:
        warnings.append(
            f"this elastic-motion has no {', '.join(missing)}: it guesses the up axis or units of Blender's "
            "files (update it)"
        )
    return args, warnings


def insert_options(args, options):
    """``args`` (``[command, ...]``) with ``options`` right after the command: the panel's
    *More options*, at the end, still override them."""
    return [args[0], *options, *args[1:]]


def status_line(command, message, report):
    """The status-bar line of a run: what was made and the report's key figures (its first
    lines, without the notes)."""
    figures = [ln for ln in report_lines(report) if not ln.startswith("note: ")][:3]
    return "; ".join([f"elastic-motion {command}: {message}", *figures])


def distance_args(a, b, *, warp):
    return ["distance", a, b, "--warp", warp, "--json", "-"]


def run_cli(executable: str, args: list, *, report_path=None, timeout: float = 600.0) -> CliResult:
    """Run the command; read its JSON report (from ``report_path``, or stdout for ``--json -``).

    Raises
    ------
    CliNotFound
        The command could not be started or did not finish in time.
    """
    proc = _run(executable, args, timeout)
    res = CliResult(ok=proc.returncode == 0, code=proc.returncode, stdout=proc.stdout, stderr=proc.stderr)
    if not res.ok:
        res.message = error_message(proc.stderr, proc.returncode)
        return res
    try:
        if report_path is not None and os.path.isfile(report_path):
            with open(report_path, encoding="utf-8") as fh:
                res.report = json.load(fh)
        elif "--json" in args and args[args.index("--json") + 1] == "-":
            res.report = json.loads(proc.stdout)
    except (OSError, ValueError):
        res.report = None
    return res


def report_lines(report: dict | None) -> list:
    """A few lines of a report for the panel (the whole report goes to a text block)."""
    if not report:
        return []
    cmd = report.get("command", "?")
    out = [f"{cmd}: {report.get('frames', '?')} frames at {report.get('fps', '?')} fps"]
    if cmd == "distance":
        d = report.get("distances")
        if isinstance(d, list) and len(d) > 1:
            out = [f"distance: {d[0][1]:.4g} ({report.get('method', '')}, warp {report.get('warp', '')})"]
    for key, label in (("seam_before", "seam before"), ("seam_after", "seam after")):
        s = report.get(key)
        if isinstance(s, dict) and "seam_angle_max_deg" in s:
            out.append(
                f"{label}: {s['seam_angle_max_deg']:.3g} deg, "
                f"{s.get('seam_position_max_m', float('nan')):.3g} m"
            )
    if "warp" in report and cmd == "blend":
        out.append(
            f"method {report.get('method')}, warp {report.get('warp')}, weights {report.get('weights')}"
        )
    clean = report.get("cleanup")
    if isinstance(clean, dict):
        b, a = clean.get("skating_before") or {}, clean.get("skating_after") or {}
        if "skating_mean_m_s" in b and "skating_mean_m_s" in a:
            out.append(f"skating {b['skating_mean_m_s']:.3g} -> {a['skating_mean_m_s']:.3g} m/s (clean-up)")
    con = report.get("contacts")
    if isinstance(con, dict) and isinstance(con.get("joints"), dict):
        out.append(
            "contacts: " + ", ".join(f"{k} {len(v.get('frames', []))}" for k, v in con["joints"].items())
        )
    out += [f"note: {n}" for n in report.get("notes", [])[:4]]
    return out
