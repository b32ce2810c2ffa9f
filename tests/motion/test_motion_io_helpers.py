"""The atomic writer and the text reader."""

from __future__ import annotations

import pytest

from elastic_motion._io import atomic_write_text, read_text
from elastic_motion.errors import ParseError


def test_atomic_write_replaces_and_protects(tmp_path):
    dest = tmp_path / "out.txt"
    dest.write_text("old")
    atomic_write_text(dest, "new\n")
    assert dest.read_text() == "new\n"
    src = tmp_path / "in.txt"
    src.write_text("input")
    with pytest.raises(ValueError, match="refusing to overwrite the input file"):
        atomic_write_text(src, "x", protected=[src])
    link = tmp_path / "link.txt"
    link.symlink_to(src)
    with pytest.raises(ValueError, match="refusing"):
        atomic_write_text(link, "x", protected=[src])
    assert src.read_text() == "input"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.txt", "link.txt", "out.txt"]


def test_read_text_never_raises_decode_errors(tmp_path):
    p = tmp_path / "x.bvh"
    p.write_bytes(b"caf\xe9 \xff\n")
    assert read_text(p) == "café ÿ\n"
    p.write_bytes("\ufeffHIERARCHY".encode())  # a UTF-8 byte-order mark is dropped
    assert read_text(p) == "HIERARCHY"
    with pytest.raises(ParseError, match="cannot read the file"):
        read_text(tmp_path / "missing.bvh")


def test_atomic_path_commits_on_success_and_leaves_nothing_on_failure(tmp_path):
    from elastic_motion._io import atomic_path, atomic_write_bytes

    dest = tmp_path / "fig.png"
    atomic_write_bytes(dest, b"old")
    with pytest.raises(RuntimeError, match="encoder died"), atomic_path(dest) as tmp:
        assert tmp.suffix == ".png" and tmp.parent == tmp_path
        tmp.write_bytes(b"half-written")
        raise RuntimeError("encoder died")
    assert dest.read_bytes() == b"old"  # the previous file survives a failed write
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fig.png"]  # no temporary left
    with atomic_path(dest) as tmp:
        tmp.write_bytes(b"new")
    assert dest.read_bytes() == b"new"
    src = tmp_path / "input.bvh"
    src.write_text("HIERARCHY")
    with (
        pytest.raises(ValueError, match="refusing to overwrite the input file"),
        atomic_path(src, protected=[src]),
    ):
        pass
    assert src.read_text() == "HIERARCHY"
