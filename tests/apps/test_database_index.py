"""The on-disk index (issue 34): SRV arrays in one flat file per representation, read only for
the entries a search compares and checked then; the rest of the index checked at load; files
tampered with are refused with the command that rebuilds the index; an index of format 1 is
still read, with a note; paths resolved once.

A small synthetic database of two skeletons (``database_testlib``); every test takes seconds.
"""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from database_testlib import fail_on_blocking_read, synthetic_motion, write_clips  # noqa: F401

from elastic_motion.apps.database import (
    DatabaseSettings,
    build_index,
    knn_search,
    load_index,
    query_distances,
    verified,
)
from elastic_motion.apps.database.index import IndexRows
from elastic_motion.errors import OptionError
from elastic_motion.motion import write_bvh
from elastic_motion.warp import WarpOptions

SETTINGS = DatabaseSettings(n_samples=10, warp=WarpOptions(method="dp", neighbourhood=3))
REBUILD = "Rebuild it: elastic-motion index"


#: Every test: a read that blocks fails it after 60 s (database_testlib).
pytestmark = pytest.mark.usefixtures("fail_on_blocking_read")


@pytest.fixture(scope="module")
def db(tmp_path_factory) -> Path:
    """12 clips of one skeleton (3 kinds x 4 variants) and one of another (extra joint)."""
    d = tmp_path_factory.mktemp("db")
    write_clips(d, kinds=(0, 1, 2), variants=4, frames=18, step=2)
    write_bvh(synthetic_motion(1, 1, frames=20, extra_joint=True), d / "other.bvh")
    return d


@pytest.fixture(scope="module")
def built(db: Path, tmp_path_factory) -> Path:
    """The index of ``db`` (both representations); copy it before changing it."""
    return build_index([db], tmp_path_factory.mktemp("built") / "index", SETTINGS).path


@pytest.fixture
def index(built: Path, tmp_path: Path) -> Path:
    out = tmp_path / "index"
    shutil.copytree(built, out)
    return out


# --------------------------------------------------------------------------------------------
# Round trip
# --------------------------------------------------------------------------------------------


def test_the_layout_and_every_array_read_back_bit_for_bit(db: Path, tmp_path: Path) -> None:
    made = build_index([db], tmp_path / "index", SETTINGS)
    names = sorted(p.name for p in made.path.iterdir())
    assert names == sorted(
        ["index.json"]
        + [f"{s}_{r}.{e}" for s in ("srv", "norms") for r in ("lie", "euler") for e in ("npy", "json")]
    )
    with load_index(made.path) as back:
        assert back.meta["index_format"] == 2 and back.notes == ()
        assert "entries" not in back.summary()
        for r in ("lie", "euler"):
            rows = back.cache.q[r]
            assert isinstance(rows, IndexRows) and rows.n_read == 0  # nothing of the arrays read at load
            for a, b in zip(rows, made.cache.q[r], strict=True):
                assert a.dtype == np.float64 and a.shape == b.shape and a.tobytes() == b.tobytes()
        for f in ("names", "paths", "real_paths", "group_joints", "group_weights", "info", "skipped"):
            assert getattr(back.cache, f) == getattr(made.cache, f), f
        assert back.cache.groups.tolist() == made.cache.groups.tolist() == [0] * 12 + [1]


@pytest.mark.parametrize("method", ["lie", "euler-elastic"])
def test_search_on_the_index_is_brute_force_and_reads_only_the_rows_compared(
    db: Path, built: Path, method: str, monkeypatch
) -> None:
    reads: list[int] = []
    read = verified.VerifiedRows.read

    def counted(self, k):
        reads.append(k)
        return read(self, k)

    monkeypatch.setattr(verified.VerifiedRows, "read", counted)
    pruned = []
    for query in sorted(db.glob("k*.bvh")):
        brute = query_distances(query, db, method, SETTINGS)  # every distance, files read now
        for k in (1, 3):
            reads.clear()
            res = knn_search(query, built, k, method)
            want = brute.nearest(k)
            assert res.indices.tolist() == want.tolist()
            assert res.distances.tolist() == brute.distances[want].tolist()  # bit-identical
            assert sorted(reads) == np.flatnonzero(res.computed).tolist()  # each compared row once, no other
            pruned.append(res.fraction_pruned)
    assert max(pruned) > 0.3  # the bounds prune here: rows are left unread


# --------------------------------------------------------------------------------------------
# Tampered files: refused, naming the file, with the command that rebuilds the index
# --------------------------------------------------------------------------------------------


def _flip_byte(path: Path, at: int) -> None:
    data = bytearray(path.read_bytes())
    data[at] ^= 0x01
    path.write_bytes(bytes(data))


def _edit_json(path: Path, change: Callable[[dict], None]) -> None:
    obj = json.loads(path.read_text())
    change(obj)
    path.write_text(json.dumps(obj))


def _row_offset(index: Path, entry: int) -> int:
    record = json.loads((index / "srv_lie.json").read_text())
    return record["data_offset"] + 8 * sum(record["row_elements"][:entry])


def _other_build(index: Path, db: Path, names: tuple[str, ...]) -> None:
    """Replace the files ``names`` (and their records) by those of another build of the same files."""
    other = build_index([db], index.parent / "other", SETTINGS).path
    for n in names:
        for f in (n, n.replace(".npy", ".json")):
            shutil.copy(other / f, index / f)


def _header_of_another_array(index: Path) -> None:
    """The same values under the ``.npy`` header of an ``(n, 1)`` array (a header of the same length)."""
    p = index / "srv_lie.npy"
    data = p.read_bytes()
    total = sum(json.loads((index / "srv_lie.json").read_text())["row_elements"])
    end = 10 + int.from_bytes(data[8:10], "little")  # magic, version, length, then the header
    head = data[:end].replace(f"({total},)".encode(), f"({total}, 1)".encode(), 1)[:-1].rstrip(b" ")
    p.write_bytes(head + b" " * (end - 1 - len(head)) + b"\n" + data[end:])


def _append(path: Path, data: bytes) -> None:
    with open(path, "ab") as fh:
        fh.write(data)


def _replace_by_link(path: Path) -> None:
    shutil.move(path, path.parent.parent / "moved.npy")
    os.symlink(path.parent.parent / "moved.npy", path)


def _replace_by_folder(path: Path) -> None:
    os.unlink(path)
    os.mkdir(path)


TAMPERINGS: dict[str, tuple[Callable[[Path, Path], None], str]] = {
    # (change, what the error says): every one detected at load or when the row is read
    "srv value changed": (
        lambda i, d: _flip_byte(i / "srv_lie.npy", _row_offset(i, 0) + 3),
        r"srv_lie.npy: row 0: its SHA-256",
    ),
    "srv truncated": (
        lambda i, d: os.truncate(i / "srv_lie.npy", 500),
        r"srv_lie.npy: 500 bytes; its record says",
    ),
    "srv grown": (lambda i, d: _append(i / "srv_lie.npy", b"\0" * 8), r"srv_lie.npy: \d+ bytes; its record"),
    "srv header of another shape": (
        lambda i, d: _header_of_another_array(i),
        r"srv_lie.npy: expected a .npy header",
    ),
    "srv record missing": (
        lambda i, d: os.unlink(i / "srv_lie.json"),
        r"srv_lie.npy: no record srv_lie.json",
    ),
    "srv record garbage": (
        lambda i, d: (i / "srv_lie.json").write_text("{"),
        r"srv_lie.json: expected a record",
    ),
    "srv record digest changed": (
        lambda i, d: _edit_json(i / "srv_lie.json", lambda r: r["row_sha256"].__setitem__(0, "0" * 64)),
        r"srv_lie.npy: row 0: its SHA-256",
    ),
    "srv record of fewer rows": (
        lambda i, d: _edit_json(i / "srv_lie.json", lambda r: r["row_elements"].pop()),
        r"srv_lie.json: expected row_elements",
    ),
    "srv a symbolic link": (
        lambda i, d: _replace_by_link(i / "srv_lie.npy"),
        r"srv_lie.npy: cannot read the file \(a symbolic link",
    ),
    "srv a folder": (
        lambda i, d: _replace_by_folder(i / "srv_lie.npy"),
        r"srv_lie.npy: expected a file, found a directory",
    ),
    "srv of another build": (
        lambda i, d: _other_build(i, d, ("srv_lie.npy",)),
        r"srv_lie.json: expected build",
    ),
    "norms value changed": (lambda i, d: _flip_byte(i / "norms_lie.npy", 200), r"norms_lie.npy: its SHA-256"),
    "norms of another build": (
        lambda i, d: _other_build(i, d, ("norms_lie.npy",)),
        r"norms_lie.json: expected build",
    ),
    "norms record missing": (lambda i, d: os.unlink(i / "norms_lie.json"), r"norms_lie.npy: no record"),
    "index.json not JSON": (
        lambda i, d: (i / "index.json").write_text('{"index_format": 2'),
        r"index.json: not JSON",
    ),
    "index.json an entry fewer": (
        lambda i, d: _edit_json(i / "index.json", lambda m: m["entries"]["names"].pop()),
        r"index.json: damaged \(ValueError: expected names, paths",
    ),
    "index.json other dimensions": (
        lambda i, d: _edit_json(i / "index.json", lambda m: m["dims"]["lie"].__setitem__(0, 9)),
        r"srv_lie.json: expected shape \[\d+\]; got \[\d+\]",
    ),
    "index.json another build": (
        lambda i, d: _edit_json(i / "index.json", lambda m: m.__setitem__("build", "0" * 32)),
        r"srv_lie.json: expected build",
    ),
}


@pytest.mark.parametrize("name", sorted(TAMPERINGS))
def test_a_tampered_index_is_refused_with_the_command_that_rebuilds_it(
    db: Path, index: Path, name: str
) -> None:
    change, message = TAMPERINGS[name]
    change(index, db)
    with pytest.raises(OptionError, match=message) as info:
        knn_search(db / "k0_v1.bvh", index, 3)
    assert REBUILD in str(info.value) and f"-o {index} --overwrite" in str(info.value)
    if name == "srv a folder":  # not the index's: never removed, the rebuild says so
        with pytest.raises(
            OptionError, match=r"expected an empty or index folder.*holding \['srv_lie.npy'\]"
        ):
            build_index([db], index, SETTINGS, overwrite=True)
        os.rmdir(index / "srv_lie.npy")
    # rebuilt as the message says, it is searched again
    build_index([db], index, SETTINGS, overwrite=True)
    assert len(knn_search(db / "k0_v1.bvh", index, 3).indices) == 3


def test_a_row_changed_after_loading_is_refused_when_read(db: Path, index: Path) -> None:
    """The file stays the one checked at load; its bytes are checked when read, not trusted."""
    with load_index(index) as idx:
        _flip_byte(index / "srv_lie.npy", _row_offset(index, 5) + 100)
        assert idx.cache.q["lie"][4].shape[0] == 10
        with pytest.raises(OptionError, match=f"srv_lie.npy: row 5: its SHA-256.*{REBUILD}"):
            idx.cache.q["lie"][5]
        os.truncate(index / "srv_lie.npy", _row_offset(index, 11) + 8)  # a short read: an error, no SIGBUS
        with pytest.raises(OptionError, match=r"srv_lie.npy: row 11: the file ends after 8 of its \d+ bytes"):
            idx.cache.q["lie"][11]
    with pytest.raises(ValueError, match="the index was closed"):
        idx.cache.q["lie"][3]


# --------------------------------------------------------------------------------------------
# Index format 1, paths
# --------------------------------------------------------------------------------------------


def _as_format_1(index: Path) -> None:
    """The layout of format 1 (written by this library before issue 34): ``srv_cache.npz``,
    ``norms_<repr>.npy`` without records, ``index.json`` without entries."""
    made = build_index(
        [json.loads((index / "index.json").read_text())["inputs"][0]], index, SETTINGS, overwrite=True
    )
    replace(made.cache, real_paths=[]).save(index / "srv_cache.npz")  # format 1 stored no resolved paths
    for r in ("lie", "euler"):
        os.unlink(index / f"srv_{r}.npy")
        os.unlink(index / f"srv_{r}.json")
        os.unlink(index / f"norms_{r}.json")
    meta = {k: v for k, v in made.meta.items() if k not in ("dims", "build")}
    (index / "index.json").write_text(json.dumps({**meta, "index_format": 1}))


def test_an_index_of_format_1_is_read_with_a_note_then_rebuilt(db: Path, built: Path, index: Path) -> None:
    _as_format_1(index)
    query = db / "k2_v3.bvh"
    old = knn_search(query, index, 3)
    new = knn_search(query, built, 3)
    assert old.indices.tolist() == new.indices.tolist() and old.distances.tolist() == new.distances.tolist()
    (note,) = [n for n in old.notes if "format 1" in n]
    assert note.startswith(f"{index}: an index of format 1") and "rebuilding it makes searches faster" in note
    assert f"{REBUILD} {db} -o {index} --overwrite" in note
    build_index([db], index, SETTINGS, overwrite=True)  # its files replaced, none left
    assert not (index / "srv_cache.npz").exists()
    assert sorted(p.name for p in index.iterdir()) == sorted(p.name for p in built.iterdir())
    assert knn_search(query, index, 3).notes == new.notes


def test_the_cli_prints_the_note_of_an_old_index(db: Path, index: Path, capsys) -> None:
    from elastic_motion.cli import main

    _as_format_1(index)
    assert main(["search", str(db / "k2_v3.bvh"), str(index), "-k", "2"]) == 0
    out = capsys.readouterr().out
    assert f"note: {index}: an index of format 1" in out and REBUILD in out


def test_an_index_of_an_unknown_format_is_refused(db: Path, index: Path) -> None:
    _edit_json(index / "index.json", lambda m: m.__setitem__("index_format", 3))
    with pytest.raises(OptionError, match=rf"expected an index of format \[1, 2\].*got format 3.*{REBUILD}"):
        knn_search(db / "k0_v0.bvh", index)


def test_paths_are_resolved_when_built_not_at_every_search(
    db: Path, built: Path, tmp_path: Path, monkeypatch
) -> None:
    """A search resolves the query's path only, never an entry's (resolved once, at build time),
    and still leaves out the query's own file, here reached through a link."""
    entries = set(load_index(built).cache.paths)
    link = tmp_path / "link.bvh"
    os.symlink(db / "k1_v2.bvh", link)
    calls = []
    realpath = os.path.realpath

    def counted(p, *a, **kw):
        calls.append(os.fspath(p))
        return realpath(p, *a, **kw)

    monkeypatch.setattr(os.path, "realpath", counted)
    res = knn_search(link, built, 3)
    assert "k1_v2" not in [res.names[i] for i in res.indices]  # the query itself is left out
    assert res.candidates == 11 and os.fspath(link) in calls
    assert not entries & set(calls)  # no entry's path resolved
