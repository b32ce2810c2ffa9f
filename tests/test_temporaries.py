"""Temporaries of the atomic writers (issue 32): no file the program did not create is ever
removed, whatever its name or age; a temporary of a killed write is, by the next write.

A temporary is provably ours by a tag (HMAC with a per-user key) in its name
(:mod:`elastic_motion._io`): look-alike names -- the earlier patterns, old mtimes, dead pids,
the new pattern with a tag made by hand, by another user's key or on another host, links
and folders with a valid name -- all stay.
"""

from __future__ import annotations

import hashlib
import hmac
import os
import platform
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from elastic_motion import _io
from elastic_motion._io import atomic_write_text, is_our_temporary, remove_stale_temporaries

SRC = Path(__file__).resolve().parents[1] / "src"
DAY = 86400.0


@pytest.fixture
def cache_home(tmp_path: Path, monkeypatch) -> Path:
    """A private cache folder for the key (never the user's), and this process's key forgotten."""
    home = tmp_path / "cache"
    monkeypatch.setenv("XDG_CACHE_HOME", str(home))
    monkeypatch.setattr(_io, "_key_state", None)
    monkeypatch.setattr(_io, "_cleaned_folders", set())
    return home


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait(timeout=30)
    return proc.pid


def _name(stem: str, pid: int, suffix: str, *, key: bytes, host: str | None = None, token="0" * 16) -> str:
    head = f".{stem}.em{pid}-{token}-"
    msg = "\0".join((platform.node() if host is None else host, head, suffix)).encode()
    return head + hmac.new(key, msg, hashlib.sha256).hexdigest()[:32] + suffix


def _age(path: Path, seconds: float) -> None:
    t = time.time() - seconds
    os.utime(path, (t, t), follow_symlinks=False)


def test_look_alikes_are_never_removed(cache_home: Path, tmp_path: Path) -> None:
    d = tmp_path / "d"
    d.mkdir()
    out = d / "walk.bvh"
    atomic_write_text(out, "first\n")  # makes the key
    key, persistent = _io._temporary_key()
    assert persistent and (cache_home / "elastic_motion" / "temporaries.key").read_bytes() == key
    dead = _dead_pid()
    other_key = bytes(32)
    user_file = d / "precious.bvh"
    user_file.write_text("mine\n")
    files = {
        ".walk.original.bvh": "the user's own hidden backup",
        ".walk.abcd1234.bvh": "the earlier mkstemp pattern",
        ".walk.zzzz9999.bvh": "the earlier mkstemp pattern",
        f".walk.em{dead}-abc.bvh": "the earlier pid pattern, dead pid",
        f".walk.em{dead}-{'0' * 16}-{'f' * 32}.bvh": "the new pattern, a tag made by hand",
        _name("walk", dead, ".bvh", key=other_key): "another user's (or an earlier key's) temporary",
        _name("walk", dead, ".bvh", key=key, host="another-host"): "made on another host",
        _name("walk", dead, ".bvh", key=key) + ".bak": "a copy of a temporary under another name",
        f".walk.em{10**30}-abc.bvh": "the earlier pid pattern, a pid no system has",
        _name("walk", 10**30, ".bvh", key=key): "a pid no system has",
        _name("walk", os.getpid(), ".bvh", key=key): "a live writer (this process)",
        _name("walk", os.getppid(), ".bvh", key=key): "a live writer (another process)",
    }
    for name, text in files.items():
        (d / name).write_text(text)
        _age(d / name, 30 * DAY)  # old: age never matters
    link = d / _name("walk", dead, ".bvh", key=key, token="1" * 16)
    link.symlink_to(user_file)  # a valid name, but a link: neither it nor its target goes
    folder = d / _name("walk", dead, ".bvh", key=key, token="2" * 16)
    folder.mkdir()
    (folder / "inside.bvh").write_text("x")
    before = sorted(p.name for p in d.iterdir())

    assert remove_stale_temporaries(out) == []
    atomic_write_text(out, "second\n")
    atomic_write_text(d / "other.bvh", "x\n")
    assert remove_stale_temporaries(out) == []
    assert sorted(p.name for p in d.iterdir()) == sorted([*before, "other.bvh"])
    for name, text in files.items():
        assert (d / name).read_text() == text, name
    assert link.is_symlink() and user_file.read_text() == "mine\n" and (folder / "inside.bvh").exists()
    assert out.read_text() == "second\n"


_KILLED = (
    "import sys, time\n"
    "from elastic_motion._io import atomic_path\n"
    "with atomic_path(sys.argv[1]) as tmp:\n"
    "    open(tmp, 'w').write('partial' * 1000)\n"
    "    print(tmp, flush=True)\n"
    "    time.sleep(60)\n"
)


def _killed_write(out: Path, env: dict[str, str]) -> Path:
    """Start a write of ``out`` in a new process, SIGKILL it mid-write; its temporary."""
    proc = subprocess.Popen(
        [sys.executable, "-c", _KILLED, str(out)], stdout=subprocess.PIPE, text=True, env=env
    )
    try:
        tmp = Path(proc.stdout.readline().strip())
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
        proc.stdout.close()
    assert tmp.exists() and not out.exists()  # SIGKILL: nothing could clean up
    return tmp


def _env(cache: Path) -> dict[str, str]:
    return {**os.environ, "XDG_CACHE_HOME": str(cache), "PYTHONPATH": str(SRC)}


def test_a_write_killed_midway_leaves_a_temporary_the_next_write_removes(
    cache_home: Path, tmp_path: Path
) -> None:
    out = tmp_path / "out.bvh"
    tmp = _killed_write(out, _env(cache_home))
    assert tmp.name.startswith(".out.em") and tmp.suffix == ".bvh" and is_our_temporary(tmp.name)
    user_file = tmp_path / ".out.original.bvh"
    user_file.write_text("mine")
    atomic_write_text(out, "done\n")  # the next write in that folder
    assert out.read_text() == "done\n" and not tmp.exists() and user_file.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == [".out.original.bvh", "cache", "out.bvh"]


def test_without_a_usable_key_nothing_is_ever_removed(tmp_path: Path, monkeypatch) -> None:
    """A cache folder that cannot hold the key: writes work, and a killed write's temporary is
    left (it cannot be proven ours); a key file that is a link, or writable by others, is not used."""
    blocked = tmp_path / "blocked"
    blocked.write_text("a file where the cache folder should be")
    monkeypatch.setenv("XDG_CACHE_HOME", str(blocked))
    monkeypatch.setattr(_io, "_key_state", None)
    monkeypatch.setattr(_io, "_cleaned_folders", set())
    d = tmp_path / "d"
    d.mkdir()
    tmp = _killed_write(d / "out.bvh", _env(blocked))
    atomic_write_text(d / "out.bvh", "done\n")
    assert _io._temporary_key()[1] is False and tmp.exists() and remove_stale_temporaries(d / "out.bvh") == []

    cache = tmp_path / "cache"
    (cache / "elastic_motion").mkdir(parents=True, mode=0o700)
    real = tmp_path / "key"
    real.write_bytes(bytes(32))
    real.chmod(0o600)
    keyfile = cache / "elastic_motion" / "temporaries.key"
    keyfile.symlink_to(real)
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache))
    monkeypatch.setattr(_io, "_key_state", None)
    assert _io._temporary_key()[1] is False  # a link: not used, not replaced
    assert keyfile.is_symlink() and real.read_bytes() == bytes(32)
    keyfile.unlink()
    keyfile.write_bytes(bytes(32))
    keyfile.chmod(0o622)  # writable by others
    monkeypatch.setattr(_io, "_key_state", None)
    assert _io._temporary_key()[1] is False
    keyfile.chmod(0o600)
    monkeypatch.setattr(_io, "_key_state", None)
    assert _io._temporary_key() == (bytes(32), True)


def test_a_long_name_gets_a_temporary_within_the_name_limit(cache_home: Path, tmp_path: Path) -> None:
    """A 250-byte file name (UTF-8, a 2-byte character cut in the middle in the temporary's
    name) is written, and the temporary of a killed write of it is proven ours and removed."""
    out = tmp_path / ("é" * 123 + ".bvh")
    assert len(os.fsencode(out.name)) == 250
    tmp = _killed_write(out, _env(cache_home))
    assert len(os.fsencode(tmp.name)) <= 255 and is_our_temporary(tmp.name)
    atomic_write_text(out, "x\n")  # the next write in that folder
    assert out.read_text() == "x\n" and not tmp.exists()
