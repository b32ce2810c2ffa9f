"""The command line's safety net and error path under hostile use (issue 14).

Outputs never overwrite what a command reads (``--json`` onto the ASF found beside an AMC,
onto the BVH just written, into a matrix folder), limits are checked before any work, and OS
errors, overflow and FIFOs end as one error line with exit code 2 or 3. (Temporaries of a
killed write: ``tests/test_temporaries.py``.)
"""

from __future__ import annotations

import errno
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from elastic_motion.cli import main
from elastic_motion.cli_commands._argparse import (
    EXIT_BAD_INPUT,
    EXIT_ENVIRONMENT,
    describe_error,
    exit_code_for,
)

CLI = [sys.executable, "-m", "elastic_motion.cli"]


def _bvh(path: Path, n_frames: int = 4) -> Path:
    lines = ["HIERARCHY", "ROOT Hips", "{", "  OFFSET 0 0 0"]
    lines.append("  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation")
    for k in range(2):
        lines += [f"  JOINT J{k}", "  {", "    OFFSET 0 10 0", "    CHANNELS 3 Zrotation Xrotation Yrotation"]
        lines += ["    End Site", "    {", "      OFFSET 0 5 0", "    }", "  }"]
    lines += ["}", "MOTION", f"Frames: {n_frames}", "Frame Time: 0.0333333"]
    for f in range(n_frames):
        lines.append(" ".join(["0", "90", str(f)] + ["0"] * 9))
    path.write_text("\n".join(lines) + "\n")
    return path


def _refused(argv: list[str], capsys, *needles: str) -> str:
    assert main([str(a) for a in argv]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    for n in needles:
        assert n in err, err
    return err


# ------------------------------------------------------------------------------------------
# Outputs against inputs
# ------------------------------------------------------------------------------------------


def test_json_onto_the_asf_found_beside_the_amc_is_refused(tmp_path: Path, capsys) -> None:
    asf, amc = tmp_path / "02.asf", tmp_path / "02_01.amc"
    asf.write_text(":version 1.10\n")
    amc.write_text(":FULLY-SPECIFIED\n")
    before = asf.read_bytes()
    _refused(["blend", amc, amc, "-o", tmp_path / "o.bvh", "--json", asf], capsys, "--json", "02.asf")
    assert asf.read_bytes() == before and not (tmp_path / "o.bvh").exists()


def test_json_onto_the_written_bvh_is_refused_before_writing(tmp_path: Path, capsys) -> None:
    a, b = _bvh(tmp_path / "a.bvh"), _bvh(tmp_path / "b.bvh")
    out = tmp_path / "o.bvh"
    _refused(["blend", a, b, "-o", out, "--json", out], capsys, "--json", "a motion file's name")
    assert not out.exists()


@pytest.mark.parametrize("how", ["dotdot", "symlink", "hardlink"])
def test_outputs_reaching_an_input_by_another_name_are_refused(tmp_path: Path, capsys, how: str) -> None:
    a, b = _bvh(tmp_path / "a.bvh"), _bvh(tmp_path / "b.bvh")
    (tmp_path / "sub").mkdir()
    if how == "dotdot":
        out = tmp_path / "sub" / ".." / "a.bvh"
    elif how == "symlink":
        out = tmp_path / "link.bvh"
        out.symlink_to(a)
    else:
        out = tmp_path / "hard.bvh"
        os.link(a, out)
    before = a.read_bytes()
    _refused(["blend", a, b, "-o", out], capsys, "refusing to overwrite an input")
    _refused(["distance", a, b, "--json", out], capsys, "--json")  # a motion file's name, too
    assert a.read_bytes() == before


def test_matrix_folder_files_are_never_report_targets(tmp_path: Path, capsys) -> None:
    m = tmp_path / "M"
    m.mkdir()
    report = '{"command": "matrix", "version": "0"}'
    (m / "report.json").write_text(report)
    (m / "distances_lie.npy").write_bytes(b"x")
    labels = tmp_path / "labels.csv"
    labels.write_text("a,x\n")
    _refused(["classify", m, "--labels", labels, "--json", m / "report.json"], capsys, "input folder")
    _refused(["cluster", m, "--json", m / "distances_lie.npy"], capsys, "--json", "another existing file")
    assert (m / "report.json").read_text() == report and (m / "distances_lie.npy").read_bytes() == b"x"


def test_matrix_into_its_own_input_folder_is_refused(tmp_path: Path, capsys) -> None:
    db = tmp_path / "db"
    db.mkdir()
    _bvh(db / "a.bvh")
    _refused(["matrix", db, "-o", db / "M"], capsys, "-o", "neither holds nor lies inside")
    _refused(["matrix", db, "-o", tmp_path], capsys, "-o")
    _refused(["matrix", db, "-o", tmp_path / "M", "--json", tmp_path / "M" / "report.json"], capsys, "--json")
    assert not (db / "M").exists() and not (tmp_path / "M").exists()


def test_index_into_its_own_input_folder_is_refused_like_matrix(tmp_path: Path, capsys) -> None:
    from elastic_motion.apps.database import build_index
    from elastic_motion.errors import OptionError

    db = tmp_path / "db"
    db.mkdir()
    _bvh(db / "a.bvh")
    _refused(["index", db, "-o", db / "I"], capsys, "-o", "neither holds nor lies inside")
    _refused(["index", db / "a.bvh", "-o", db], capsys, "-o", "neither holds nor lies inside")
    _refused(["index", db, "-o", tmp_path / "I", "--json", tmp_path / "I" / "r.json"], capsys, "--json")
    with pytest.raises(OptionError, match="out: expected a folder that neither holds nor lies inside"):
        build_index([db], db / "I")
    with pytest.raises(OptionError, match="out: expected a folder that neither holds nor lies inside"):
        build_index([db], tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["db"] and os.listdir(db) == ["a.bvh"]


def test_json_that_took_the_next_input_never_replaces_it(tmp_path: Path, capsys) -> None:
    """``--json`` before the inputs takes the first of them as its PATH: a motion file's name
    is refused, and so is any existing file that is not an earlier report (a DeepMimic
    ``.json`` clip), before any work; an earlier report is replaced."""
    a, b, c = (_bvh(tmp_path / f"{n}.bvh") for n in "abc")
    before = a.read_bytes()
    _refused(["mean", "-o", tmp_path / "m.bvh", "--json", a, b, c], capsys, "--json", "a motion file's name")
    assert a.read_bytes() == before and not (tmp_path / "m.bvh").exists()
    clip = tmp_path / "clip.json"
    clip.write_text('{"Frames": [[0.1, 0.0]]}')
    _refused(["distance", a, b, "--json", clip], capsys, "--json", "another existing file")
    assert clip.read_text() == '{"Frames": [[0.1, 0.0]]}'
    rep = tmp_path / "rep.json"
    for _ in range(2):  # the second run replaces the first's report
        assert main(["distance", str(a), str(b), "--json", str(rep), "-q"]) == 0
    capsys.readouterr()
    from elastic_motion.apps.report import write_report

    with pytest.raises(
        ValueError, match=r"clip\.json: expected a new file or an earlier elastic-motion report"
    ):
        write_report(clip, {"command": "x"})


def test_mean_and_search_json_onto_an_input(tmp_path: Path, capsys) -> None:
    a, b = _bvh(tmp_path / "a.bvh"), _bvh(tmp_path / "b.bvh")
    _refused(["mean", a, b, "-o", tmp_path / "m.bvh", "--json", b], capsys, "--json")
    _refused(["search", a, b, "--json", a], capsys, "--json")


# ------------------------------------------------------------------------------------------
# Limits before work
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["render", "{a}", "-o", "{t}/x.gif", "--size", "0x0"], "--size"),
        (["render", "{a}", "-o", "{t}/x.gif", "--size", "100000x100"], "max_render_size"),
        (["render", "{a}", "-o", "{t}/x.gif", "--fps", "1e-9"], "min_render_fps"),
        (["render", "{a}", "-o", "{t}/x.gif", "--fps", "1e300"], "max_render_fps"),
        (["render", "{a}", "-o", "{t}/x.gif", "--fps", "nan"], "--fps"),
        (["render", "{a}", "-o", "{t}/x.gif", "--seconds", "1e9"], "max_render_frames"),
        (["render", "{a}", "-o", "{t}/x.png", "--kind", "seam", "--repeat", "100000"], "max_repeat"),
        (["loop", "{a}", "-o", "{t}/l.bvh", "--repeat", "100000"], "max_repeat"),
        (["matrix", "{a}", "-o", "{t}/M", "--engine", "local", "--workers", "0"], "--workers"),
    ],
)
def test_limits_are_checked_before_any_work(tmp_path: Path, capsys, argv: list[str], needle: str) -> None:
    a = _bvh(tmp_path / "a.bvh")
    t0 = time.perf_counter()
    _refused([x.format(a=a, t=tmp_path) for x in argv], capsys, needle)
    assert time.perf_counter() - t0 < 10.0


# ------------------------------------------------------------------------------------------
# The error path
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("exc", "code", "needle"),
    [
        (OSError(errno.EROFS, "Read-only file system", "/ro/o.bvh"), EXIT_ENVIRONMENT, "read-only"),
        (OSError(errno.EACCES, "Permission denied", "/x/o.bvh"), EXIT_ENVIRONMENT, "permission denied"),
        (OSError(errno.ENOSPC, "No space left on device", "/f/o.bvh"), EXIT_ENVIRONMENT, "no space left"),
        (IsADirectoryError(errno.EISDIR, "Is a directory", "/d"), EXIT_BAD_INPUT, "got a folder"),
        (
            OSError(errno.ELOOP, "Too many levels of symbolic links", "/l"),
            EXIT_BAD_INPUT,
            "symbolic-link loop",
        ),
        (MemoryError(), EXIT_ENVIRONMENT, "out of memory"),
        (OverflowError("cannot convert float infinity to integer"), EXIT_BAD_INPUT, "too large"),
        (RecursionError("maximum recursion depth exceeded"), EXIT_BAD_INPUT, "too deep"),
    ],
)
def test_error_kinds_map_to_exit_codes(exc: BaseException, code: int, needle: str) -> None:
    assert exit_code_for(exc) == code
    assert needle in describe_error(exc) and "internal error" not in describe_error(exc)


def test_ctrl_c_inside_compiled_code_is_an_interruption_not_a_bug() -> None:
    """Ctrl-C in a numba kernel surfaces as a ``SystemError`` whose context is the
    ``KeyboardInterrupt``: reported as the interruption it is (exit 1), not as a bug."""
    from elastic_motion.cli_commands._argparse import EXIT_INCOMPLETE

    try:
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            raise SystemError(
                "CPUDispatcher(<function dp>) returned a result with an exception set"
            ) from None
    except SystemError as exc:
        wrapped = exc
    wrapped.__context__ = KeyboardInterrupt()  # `from None` hid it; numba keeps it as context
    assert exit_code_for(wrapped) == EXIT_INCOMPLETE
    assert describe_error(wrapped).startswith("interrupted (Ctrl-C)")
    assert "internal error" in describe_error(SystemError("a real bug"))


def test_a_full_disk_on_a_real_report_write_is_one_line_exit_3(tmp_path: Path, capsys, monkeypatch) -> None:
    a, b = _bvh(tmp_path / "a.bvh"), _bvh(tmp_path / "b.bvh")
    out = tmp_path / "r.json"

    def full(src, dst):
        raise OSError(errno.ENOSPC, "No space left on device", str(dst))

    monkeypatch.setattr("elastic_motion._io.os.replace", full)
    assert main(["distance", str(a), str(b), "--json", str(out), "--warp", "none"]) == EXIT_ENVIRONMENT
    err = capsys.readouterr().err
    assert (
        err
        == f"elastic-motion distance: error: {out}: expected free disk space; got no space left on device\n"
    )
    assert not out.exists() and not [p for p in tmp_path.iterdir() if p.name.startswith(".r.")]


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_info_on_a_fifo_returns_at_once(tmp_path: Path) -> None:
    fifo = tmp_path / "x.bvh"
    os.mkfifo(fifo)
    res = subprocess.run([*CLI, "info", str(fifo)], capture_output=True, text=True, timeout=60, check=False)
    assert res.returncode == EXIT_BAD_INPUT
    assert res.stderr.endswith("x.bvh: expected a regular file, found a FIFO (named pipe)\n"), res.stderr
