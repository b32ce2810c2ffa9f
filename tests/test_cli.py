"""The console entry point: version, help, the error format, exit codes, closed pipes, progress."""

from __future__ import annotations

import errno
import io
import json
import os
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from elastic_motion import __version__
from elastic_motion.cli import main
from elastic_motion.cli_commands._argparse import (
    EXIT_BAD_INPUT,
    EXIT_ENVIRONMENT,
    EXIT_INCOMPLETE,
    EXIT_OK,
)

CLI = [sys.executable, "-m", "elastic_motion.cli"]


def _bvh(path: Path, n_joints: int = 2, n_frames: int = 3) -> Path:
    """A small valid BVH: a root with ``n_joints`` one-bone children (a star)."""
    lines = ["HIERARCHY", "ROOT Hips", "{", "  OFFSET 0 0 0"]
    lines.append("  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation")
    for k in range(n_joints):
        lines += [f"  JOINT J{k}", "  {", "    OFFSET 0 10 0", "    CHANNELS 3 Zrotation Xrotation Yrotation"]
        lines += ["    End Site", "    {", "      OFFSET 0 5 0", "    }", "  }"]
    lines += ["}", "MOTION", f"Frames: {n_frames}", "Frame Time: 0.0333333"]
    for f in range(n_frames):
        lines.append(" ".join(["0", "90", str(f)] + ["0"] * (3 + 3 * n_joints)))
    path.write_text("\n".join(lines) + "\n")
    return path


def _shell(command: str, tmp_path: Path, *, unbuffered: bool = False) -> subprocess.CompletedProcess:
    """Run ``command`` in bash; its exit status is the one of the pipeline's first command.

    Python's stdout is block-buffered on a pipe unless ``PYTHONUNBUFFERED`` is set (as in
    some CI and container setups): both are tried, since the write that fails differs.
    """
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    if unbuffered:
        env["PYTHONUNBUFFERED"] = "1"
    script = f"{command}; exit ${{PIPESTATUS[0]}}"
    return subprocess.run(
        ["bash", "-c", script],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env=env,
        timeout=120,
        check=False,
    )


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"elastic-motion {__version__}"


def test_no_command_prints_help(capsys):
    assert main([]) == 0
    assert "usage: elastic-motion" in capsys.readouterr().out


def test_console_script_runs():
    out = subprocess.run(CLI + ["--help"], capture_output=True, text=True, check=True)
    assert "Lie groups" in out.stdout


def test_top_level_help_lists_every_exit_code(capsys):
    assert main([]) == 0
    out = capsys.readouterr().out
    assert "exit codes:" in out
    for code, word in ((0, "success"), (1, "the run did not complete"), (2, "bad input"), (3, "environment")):
        assert f"  {code}  {word}" in out


# ------------------------------------------------------------------------------------------
# A closed pipe (`| head`) ends the command quietly with exit code 0
# ------------------------------------------------------------------------------------------


def test_closed_pipe_exits_0_without_traceback(tmp_path):
    big = _bvh(tmp_path / "many_joints.bvh", n_joints=600)  # `info --json` prints > 64 KiB
    small = _bvh(tmp_path / "small.bvh")
    cli = " ".join(shlex.quote(c) for c in CLI)
    for command, unbuffered in (
        (f"{cli} info {big} --json | head -1", False),  # the reader stops after a line, mid-output
        (f"{cli} info {big} --json | head -1", True),
        (f"{cli} info {small} | head -n 0", False),  # the reader is gone before the first write
        (f"{cli} info {small} | head -n 0", True),
        (f"{cli} --help | head -n 0", False),  # argparse's own printing
        (f"{cli} --version | head -n 0", False),  # argparse ignores the error; the last flush fails
    ):
        res = _shell(command, tmp_path, unbuffered=unbuffered)
        assert res.returncode == 0, (command, unbuffered, res.stderr)
        assert "Traceback" not in res.stderr and "Exception ignored" not in res.stderr, res.stderr
        if "head -1" in command:
            assert res.stdout == "{\n"


def test_broken_pipe_that_is_not_stdout_is_an_environment_error(monkeypatch, capsys):
    """A BrokenPipeError from elsewhere (a socket) while stdout is fine is not swallowed."""

    def run(args):
        raise BrokenPipeError(errno.EPIPE, "Broken pipe")

    monkeypatch.setattr("elastic_motion.cli_commands.info.run", run)
    assert main(["info", "x.bvh"]) == EXIT_ENVIRONMENT
    assert capsys.readouterr().err.startswith("elastic-motion info: error: expected the operation")


# ------------------------------------------------------------------------------------------
# One error format and the exit codes
# ------------------------------------------------------------------------------------------


def test_info_errors_use_the_error_format_and_exit_2(tmp_path, capsys):
    missing = tmp_path / "missing.bvh"
    assert main(["info", str(missing)]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert err.startswith(f"elastic-motion info: error: {missing}:") and "Traceback" not in err
    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT a\n{\nOFFSET 0 0\n}\n")
    assert main(["info", str(bad)]) == EXIT_BAD_INPUT
    assert capsys.readouterr().err.startswith(f"elastic-motion info: error: {bad}:5: expected")
    other = tmp_path / "notes.xyz"
    other.write_text("hello\n")
    assert main(["info", str(other)]) == EXIT_BAD_INPUT
    assert capsys.readouterr().err.startswith("elastic-motion info: error: ")


def test_option_errors_from_argparse_use_the_error_format(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["info", "x.bvh", "--fps", "fast"])
    assert exc.value.code == EXIT_BAD_INPUT
    assert capsys.readouterr().err.splitlines()[-1] == (
        "elastic-motion info: error: --fps: expected a number > 0; got 'fast'"
    )
    with pytest.raises(SystemExit):
        main(["info", "x.bvh", "--bogus"])
    last = capsys.readouterr().err.splitlines()[-1]
    assert last.startswith("elastic-motion info: error: --bogus: expected ")  # the sub-command, not the top
    with pytest.raises(SystemExit):
        main(["info"])
    assert capsys.readouterr().err.splitlines()[-1] == (
        "elastic-motion info: error: file: expected a value (required); got none"
    )


@pytest.mark.parametrize(
    ("code", "expected"),
    [
        (errno.EROFS, "expected a writable file system; got a read-only file system"),
        (errno.EACCES, "expected read/write permission; got permission denied"),
        (errno.ENOSPC, "expected free disk space; got no space left on device"),
    ],
)
def test_environment_os_errors_exit_3(monkeypatch, capsys, tmp_path, code, expected):
    target = str(tmp_path / "out.bvh")

    def read_motion(path, **kw):  # as a write to a read-only or full disk fails
        raise OSError(code, os.strerror(code), target)

    monkeypatch.setattr("elastic_motion.motion.read_motion", read_motion)
    assert main(["info", str(_bvh(tmp_path / "a.bvh"))]) == EXIT_ENVIRONMENT
    err = capsys.readouterr().err
    assert err == f"elastic-motion info: error: {target}: {expected}\n"


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full (Linux)")
def test_full_disk_on_stdout_exits_3(tmp_path):
    """A real ENOSPC: the output redirected to /dev/full."""
    src = _bvh(tmp_path / "a.bvh")
    cli = " ".join(shlex.quote(c) for c in CLI)
    res = _shell(f"{cli} info {src} --json > /dev/full", tmp_path)
    assert res.returncode == EXIT_ENVIRONMENT, res.stderr
    assert res.stderr == (  # one line, no traceback
        "elastic-motion info: error: <stdout>: expected free disk space; got no space left on device\n"
    )
    res = _shell(f"{cli} info {src} --json > /dev/full", tmp_path, unbuffered=True)  # fails in print()
    assert res.returncode == EXIT_ENVIRONMENT, res.stderr
    assert res.stderr == "elastic-motion info: error: expected free disk space; got no space left on device\n"


def test_memory_interrupt_and_bugs(monkeypatch, capsys, tmp_path):
    src = str(_bvh(tmp_path / "a.bvh"))
    raised: list[BaseException] = []

    def run(args):
        raise raised[-1]

    monkeypatch.setattr("elastic_motion.cli_commands.info.run", run)
    monkeypatch.delenv("ELASTIC_MOTION_DEBUG", raising=False)
    raised.append(MemoryError())
    assert main(["info", src]) == EXIT_ENVIRONMENT
    assert capsys.readouterr().err.startswith("elastic-motion info: error: memory: expected enough memory")
    raised.append(KeyboardInterrupt())
    assert main(["info", src]) == EXIT_INCOMPLETE
    assert (
        capsys.readouterr().err
        == "elastic-motion info: error: interrupted (Ctrl-C): the run did not finish\n"
    )
    raised.append(ModuleNotFoundError("No module named 'imageio_ffmpeg'", name="imageio_ffmpeg"))
    assert main(["info", src]) == EXIT_ENVIRONMENT
    assert "imageio_ffmpeg: expected the optional package" in capsys.readouterr().err
    raised.append(TypeError("unsupported operand"))  # a bug: one line, where it happened, exit 1
    assert main(["info", src]) == EXIT_INCOMPLETE
    err = capsys.readouterr().err
    assert err.startswith(
        "elastic-motion info: error: internal error: TypeError: unsupported operand (in run"
    )
    assert "ELASTIC_MOTION_DEBUG=1" in err and "Traceback" not in err
    monkeypatch.setenv("ELASTIC_MOTION_DEBUG", "1")  # developers get the exception
    with pytest.raises(TypeError):
        main(["info", src])


def test_cluster_unreachable_exits_3(monkeypatch, capsys):
    from elastic_motion.apps.database import ClusterUnavailableError

    def run(args):
        raise ClusterUnavailableError(
            "--scheduler: expected a Dask scheduler at tcp://nowhere:8786; got none"
        )

    monkeypatch.setattr("elastic_motion.cli_commands.info.run", run)
    assert main(["info", "x.bvh"]) == EXIT_ENVIRONMENT
    assert capsys.readouterr().err == (
        "elastic-motion info: error: --scheduler: expected a Dask scheduler at tcp://nowhere:8786; got none\n"
    )


def test_exceptions_can_carry_their_exit_code(monkeypatch, capsys):
    class Unreachable(RuntimeError):
        exit_code = EXIT_ENVIRONMENT

    def run(args):
        raise Unreachable("tcp://host:8786: expected a Dask scheduler; got no answer in 10 s")

    monkeypatch.setattr("elastic_motion.cli_commands.info.run", run)
    assert main(["info", "x.bvh"]) == EXIT_ENVIRONMENT
    assert capsys.readouterr().err == (
        "elastic-motion info: error: tcp://host:8786: expected a Dask scheduler; got no answer in 10 s\n"
    )


def test_success_is_0_and_prints_json(tmp_path, capsys):
    assert main(["info", str(_bvh(tmp_path / "a.bvh")), "--json"]) == EXIT_OK
    assert json.loads(capsys.readouterr().out)["joints"] == 3


# ------------------------------------------------------------------------------------------
# Progress bars (tqdm)
# ------------------------------------------------------------------------------------------


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_bar_draws_one_bar_per_stage_after_its_delay(monkeypatch):
    from elastic_motion.apps.progress import ProgressBar

    monkeypatch.delenv("ELASTIC_MOTION_PROGRESS", raising=False)
    buf = _Terminal()
    bar = ProgressBar("blend", stream=buf, delay=0.0)
    for i in range(4):
        bar("warp", i + 1, 4)
    bar("metrics", 1, 0)  # total 0: unknown
    bar.close()
    text = buf.getvalue()
    assert "blend: warp" in text and "4/4" in text and "blend: metrics" in text
    assert text.endswith("\n")  # finished bars stay, each on its line
    quiet = _Terminal()
    bar = ProgressBar("blend", stream=quiet, delay=10.0)
    bar("warp", 1, 4)
    bar("warp", 4, 4)
    bar.close()
    assert quiet.getvalue() == ""  # work under the delay shows nothing


def test_progress_bar_is_off_unless_a_terminal_or_asked(monkeypatch):
    from elastic_motion.apps.progress import ProgressBar

    monkeypatch.delenv("ELASTIC_MOTION_PROGRESS", raising=False)
    assert ProgressBar("x", stream=_Terminal()).enabled
    assert not ProgressBar("x", stream=io.StringIO()).enabled  # a pipe or a file: quiet
    assert not ProgressBar("x", stream=_Terminal(), enabled=False).enabled  # --quiet
    monkeypatch.setenv("ELASTIC_MOTION_PROGRESS", "1")
    log = io.StringIO()
    bar = ProgressBar("x", stream=log, delay=0.0)
    bar("stage", 2, 2)
    bar.close()
    assert bar.enabled and "x: stage" in log.getvalue()
    monkeypatch.setenv("ELASTIC_MOTION_PROGRESS", "0")
    assert not ProgressBar("x", stream=_Terminal(), enabled=True).enabled


def test_progress_bar_without_tqdm_is_a_silent_no_op(monkeypatch):
    from elastic_motion.apps.progress import ProgressBar

    monkeypatch.setitem(sys.modules, "tqdm", None)  # `import tqdm` raises ImportError
    buf = _Terminal()
    with ProgressBar("x", stream=buf, delay=0.0, enabled=True) as bar:
        assert not bar.enabled
        bar("stage", 1, 2)
    assert buf.getvalue() == ""


def test_progress_bar_survives_a_closed_stream(monkeypatch):
    from elastic_motion.apps.progress import ProgressBar

    monkeypatch.delenv("ELASTIC_MOTION_PROGRESS", raising=False)
    buf = _Terminal()
    bar = ProgressBar("x", stream=buf, delay=0.0)
    bar("stage", 1, 3)
    buf.close()
    bar("stage", 2, 3)
    bar("next", 1, 3)
    bar.close()
