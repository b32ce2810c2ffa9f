"""The console entry point: version, help, exit codes."""

from __future__ import annotations

import subprocess
import sys

import pytest

from elastic_motion import __version__
from elastic_motion.cli import main


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"elastic-motion {__version__}"


def test_no_command_prints_help(capsys):
    assert main([]) == 0
    assert "usage: elastic-motion" in capsys.readouterr().out


def test_console_script_runs():
    out = subprocess.run(
        [sys.executable, "-m", "elastic_motion.cli", "--help"], capture_output=True, text=True, check=True
    )
    assert "Lie groups" in out.stdout
