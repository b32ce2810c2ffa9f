"""A resumed matrix run trusts nothing on disk (issue 32).

Every tile tampered with -- another shape or dtype, negative, huge, NaN or +inf values, empty,
garbage, a pickle, a FIFO, a link or a folder in its place, its record missing, damaged,
a link, or the record and tile of another position or representation -- is detected, noted
and computed again, and the matrices stay bit-identical to a clean run; the SRV cache
likewise. A FIFO never blocks (an alarm fails the test instead of hanging the suite).
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import shutil
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from database_testlib import fail_on_blocking_read, synthetic_motion, write_clips  # noqa: F401

from elastic_motion.apps.database import DatabaseSettings, compute_matrix
from elastic_motion.cli import main
from elastic_motion.motion import write_bvh
from elastic_motion.warp import WarpOptions

SETTINGS = DatabaseSettings(n_samples=8, tile_size=2, warp=WarpOptions(method="dp", neighbourhood=3))
#: The motions in matrix order: group 0 (k0_v0, k0_v1, k1_v0, k1_v1), group 1 (other); blocks of
#: 2: tile (0, 1) holds 4 pairs of group 0, tile (0, 2) 2 pairs across groups (+inf).
TILE = "lie_0_1"


#: Every test: a read that blocks fails it after 60 s (database_testlib).
pytestmark = pytest.mark.usefixtures("fail_on_blocking_read")


@pytest.fixture(scope="module")
def clean(tmp_path_factory) -> tuple[Path, Path]:
    """A small database and its clean, complete run."""
    db = tmp_path_factory.mktemp("db")
    write_clips(db, kinds=(0, 1), variants=2, frames=16, step=3)
    write_bvh(synthetic_motion(0, 1, frames=16, extra_joint=True), db / "other.bvh")
    out = tmp_path_factory.mktemp("clean") / "run"
    assert compute_matrix([db], out, SETTINGS).complete
    return db, out


def _arrays(out: Path) -> dict[str, bytes]:
    return {r: np.load(out / f"distances_{r}.npy").tobytes() for r in ("lie", "euler")}


def _npy(arr: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, arr, allow_pickle=True)
    return buf.getvalue()


def _write(tiles: Path, key: str, data: bytes, *, record: bool = False, **fields) -> None:
    """Write ``tiles/<key>.npy``; with ``record``, a record that matches it (a consistent forgery)."""
    (tiles / f"{key}.npy").write_bytes(data)
    if record:
        arr = np.load(io.BytesIO(data), allow_pickle=True)
        rec = {
            "file": f"{key}.npy",
            "bytes": len(data),
            "sha256": hashlib.sha256(data).hexdigest(),
            "shape": list(arr.shape),
            "dtype": arr.dtype.str,
            "tile": key,
            **fields,
        }
        (tiles / f"{key}.json").write_text(json.dumps(rec))


def _tile(tiles: Path, key: str = TILE) -> np.ndarray:
    return np.load(tiles / f"{key}.npy")


def _with(key: str, change: Callable[[np.ndarray], np.ndarray], *, record: bool = False):
    def tamper(tiles: Path, outside: Path) -> str:
        _write(tiles, key, _npy(change(_tile(tiles, key).copy())), record=record)
        return key

    return tamper


def _set(index, value):
    def change(a: np.ndarray) -> np.ndarray:
        a[index] = value
        return a

    return change


def _replace_tile(make: Callable[[Path, Path], None], key: str = TILE, *, copy_outside: bool = False):
    def tamper(tiles: Path, outside: Path) -> str:
        p = tiles / f"{key}.npy"
        if copy_outside:
            shutil.copy(p, outside / "copy.npy")
        p.unlink()
        make(p, outside)
        return key

    return tamper


def _record(change: Callable[[Path, Path], None]):
    def tamper(tiles: Path, outside: Path) -> str:
        change(tiles / f"{TILE}.json", outside)
        return TILE

    return tamper


def _copy_from(src: str):
    """The tile and record of another position or representation (same shape) put here."""

    def tamper(tiles: Path, outside: Path) -> str:
        shutil.copy(tiles / f"{src}.npy", tiles / f"{TILE}.npy")
        shutil.copy(tiles / f"{src}.json", tiles / f"{TILE}.json")
        return TILE

    return tamper


def _symlink_copy(p: Path, outside: Path) -> None:
    shutil.copy(p.with_name("lie_0_0.json"), outside / "record.json")
    p.unlink()
    p.symlink_to(outside / "record.json")


TAMPERS = {
    "shape": _with(TILE, lambda a: a[:, :1]),
    "shape, consistent record": _with(TILE, lambda a: a[:, :1], record=True),
    "float32": _with(TILE, lambda a: a.astype(np.float32)),
    "int8": _with(TILE, lambda a: a.astype(np.int8)),
    "int8, consistent record": _with(TILE, lambda a: a.astype(np.int8), record=True),
    "big-endian": _with(TILE, lambda a: a.astype(">f8")),
    "negative": _with(TILE, lambda a: -a),
    "negative, consistent record": _with(TILE, lambda a: -a, record=True),
    "1e308": _with(TILE, _set((0, 1), 1e308)),
    "NaN": _with(TILE, _set((0, 1), np.nan)),
    "NaN, consistent record": _with(TILE, _set((0, 1), np.nan), record=True),
    "+inf within a group, consistent record": _with(TILE, _set((1, 0), np.inf), record=True),
    "diagonal not 0, consistent record": _with("lie_0_0", _set((1, 1), 0.5), record=True),
    "finite across groups, consistent record": _with("lie_0_2", _set((0, 0), 1.0), record=True),
    "pickle, consistent record": _with(TILE, lambda a: a.astype(object), record=True),
    "empty": _replace_tile(lambda p, o: p.write_bytes(b"")),
    "garbage": _replace_tile(lambda p, o: p.write_bytes(b"\x93NUMPY\x01\x00garbage")),
    "FIFO": _replace_tile(lambda p, o: os.mkfifo(p)),
    "symbolic link to the same bytes": _replace_tile(
        lambda p, o: p.symlink_to(o / "copy.npy"), copy_outside=True
    ),
    "dangling link": _replace_tile(lambda p, o: p.symlink_to(o / "missing.npy")),
    "folder": _replace_tile(lambda p, o: (p.mkdir(), (p / "x").write_text("kept"))),
    "no record": _record(lambda r, o: r.unlink()),
    "record garbage": _record(lambda r, o: r.write_text("not json")),
    "record FIFO": _record(lambda r, o: (r.unlink(), os.mkfifo(r))),
    "record a link": _record(_symlink_copy),
    "record and tile of another position": _copy_from("lie_1_1"),
    "record and tile of another representation": _copy_from("euler_0_1"),
}


@pytest.mark.parametrize("how", list(TAMPERS))
def test_every_tampered_tile_is_detected_and_computed_again(clean, tmp_path: Path, how: str) -> None:
    db, ref = clean
    out = tmp_path / "run"
    shutil.copytree(ref, out, symlinks=True)
    outside = tmp_path / "outside"
    outside.mkdir()
    key = TAMPERS[how](out / "tiles", outside)
    before_outside = {p.name: p.read_bytes() for p in outside.iterdir()}

    res = compute_matrix([db], out, SETTINGS)

    run = res.report["runs"][-1]
    assert res.complete and run["tiles_computed"] == 1, run
    assert any(n.startswith(f"tiles/{key}.") for n in run["tiles_rejected"]), run["tiles_rejected"]
    assert _arrays(out) == _arrays(ref)  # bit-identical to the clean run
    for ext in (".npy", ".json"):  # the tile and its record written again, regular files
        p = out / "tiles" / f"{key}{ext}"
        assert (
            not p.is_symlink()
            and p.is_file()
            and p.read_bytes() == (ref / "tiles" / f"{key}{ext}").read_bytes()
        )
    assert {p.name: p.read_bytes() for p in outside.iterdir()} == before_outside  # link targets untouched
    if how == "folder":
        assert (out / "tiles" / f"{key}.npy.moved-aside" / "x").read_text() == "kept"
    again = compute_matrix([db], out, SETTINGS)  # and now it is trusted
    assert again.report["runs"][-1]["tiles_computed"] == 0 and not again.report["runs"][-1]["tiles_rejected"]


def _cache_values(out: Path, outside: Path) -> None:
    """Every SRV array doubled, the record left as it was."""
    with np.load(out / "srv_cache.npz") as z:
        arrays = {k: (z[k] * 2 if k.startswith("q_") else z[k]) for k in z.files}
    np.savez(out / "srv_cache.npz", **arrays)


def _cache_nan_consistent(out: Path, outside: Path) -> None:
    with np.load(out / "srv_cache.npz") as z:
        arrays = {k: z[k] for k in z.files}
    arrays["q_lie_0"] = arrays["q_lie_0"].copy()
    arrays["q_lie_0"][0, 0] = np.nan
    np.savez(out / "srv_cache.npz", **arrays)
    data = (out / "srv_cache.npz").read_bytes()
    rec = {"file": "srv_cache.npz", "bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}
    (out / "srv_cache.json").write_text(json.dumps(rec))


def _cache_fifo(out: Path, outside: Path) -> None:
    (out / "srv_cache.npz").unlink()
    os.mkfifo(out / "srv_cache.npz")


def _cache_link(out: Path, outside: Path) -> None:
    shutil.move(out / "srv_cache.npz", outside / "cache.npz")
    (out / "srv_cache.npz").symlink_to(outside / "cache.npz")


def _cache_of_other_inputs(out: Path, outside: Path) -> None:
    """The cache and record of a run over other inputs (one motion fewer), consistent."""
    inputs = json.loads((out / "manifest.json").read_text())["identity"]["inputs"]
    other = compute_matrix(inputs[1:], outside / "other", SETTINGS)
    for name in ("srv_cache.npz", "srv_cache.json"):
        shutil.copy(other.out_dir / name, out / name)


CACHE_TAMPERS = {
    "values": _cache_values,
    "NaN, consistent record": _cache_nan_consistent,
    "FIFO": _cache_fifo,
    "symbolic link": _cache_link,
    "another run's, consistent record": _cache_of_other_inputs,
}


@pytest.mark.parametrize("how", list(CACHE_TAMPERS))
def test_a_tampered_srv_cache_is_built_again(clean, tmp_path: Path, how: str) -> None:
    """One tile lost, so the cache is needed: a cache that is not the run's own is built again
    from the inputs, and the tile computed from it is the clean one."""
    db, ref = clean
    out = tmp_path / "run"
    shutil.copytree(ref, out, symlinks=True)
    outside = tmp_path / "outside"
    outside.mkdir()
    (out / "tiles" / f"{TILE}.npy").unlink()
    (out / "tiles" / f"{TILE}.json").unlink()
    CACHE_TAMPERS[how](out, outside)

    res = compute_matrix([db], out, SETTINGS)

    run = res.report["runs"][-1]
    assert res.complete and run["tiles_computed"] == 1 and run["cache_reused"] is False, run
    assert "srv_cache" in run["cache_note"] and "built again" in run["cache_note"]
    assert _arrays(out) == _arrays(ref)
    assert (out / "srv_cache.npz").read_bytes() == (ref / "srv_cache.npz").read_bytes()


def test_the_command_line_says_what_it_did_not_trust(clean, tmp_path: Path, capsys) -> None:
    db, _ = clean
    out = tmp_path / "cli"
    argv = ["matrix", str(db), "-o", str(out), "--samples", "8", "--neighbourhood", "3", "--tile-size", "2"]
    assert main([*argv, "--quiet"]) == 0
    capsys.readouterr()
    os.unlink(out / "tiles" / "euler_1_2.npy")
    os.mkfifo(out / "tiles" / "euler_1_2.npy")
    assert main([*argv, "--quiet"]) == 0
    text = capsys.readouterr().out
    assert (
        "not trusted: tiles/euler_1_2.npy: expected a regular file, found a FIFO (named pipe): computed again"
        in text
    ), text


@pytest.mark.parametrize(
    "name", ["manifest.json", "report.json", "distances_lie.npy", "index:norms_lie.npy", "index:srv_lie.npy"]
)
def test_a_fifo_in_a_run_or_index_folder_is_an_error_never_a_wait(clean, tmp_path: Path, name: str) -> None:
    from elastic_motion.apps.database import build_index, load_index, load_matrix
    from elastic_motion.errors import OptionError, ParseError

    db, ref = clean
    if name.startswith("index:"):
        out = build_index([db], tmp_path / "index", SETTINGS).path
        name = name.split(":")[1]
    else:
        out = tmp_path / "run"
        shutil.copytree(ref, out, symlinks=True)
    os.unlink(out / name)
    os.mkfifo(out / name)
    t0 = time.monotonic()
    if name == "manifest.json":  # unreadable: refused, as any other run
        with pytest.raises(ValueError, match="unreadable"):
            compute_matrix([db], out, SETTINGS)
    elif name.startswith(("norms", "srv")):  # a file of the index: not what it wrote, rebuild it
        with pytest.raises(OptionError, match=f"{name}: expected a regular file, found a FIFO.*Rebuild it"):
            load_index(out)
    else:
        with pytest.raises(ParseError, match="found a FIFO"):
            load_matrix(out, "lie")
    assert time.monotonic() - t0 < 10  # at once, not after the alarm broke a wait


def test_an_index_rebuilt_over_the_temporary_of_a_killed_build(clean, tmp_path: Path) -> None:
    """The temporary a killed index build left is the program's own: rebuilding with overwrite
    is not refused for it, and removes it; a look-alike file of the user is refused as before."""
    import subprocess
    import sys

    from elastic_motion.apps.database import build_index
    from elastic_motion.errors import OptionError

    db, _ = clean
    idx = build_index([db], tmp_path / "index", SETTINGS).path
    code = "import os, sys\nfrom elastic_motion._io import atomic_path\nwith atomic_path(sys.argv[1]):\n"
    code += "    os._exit(0)"
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2] / "src")}
    subprocess.run([sys.executable, "-c", code, str(idx / "srv_cache.npz")], check=True, env=env)
    (left,) = [p for p in idx.iterdir() if p.name.startswith(".srv_cache.em")]
    build_index([db], idx, SETTINGS, overwrite=True)
    assert not left.exists()
    (idx / ".srv_cache.em1-abc.npz").write_text("the user's")
    with pytest.raises(OptionError, match="expected an empty or index folder"):
        build_index([db], idx, SETTINGS, overwrite=True)
    assert (idx / ".srv_cache.em1-abc.npz").read_text() == "the user's"
