"""Distance matrices over motion databases: tiles, storage, resume, engines, bad input.

Synthetic BVH files (a 4-joint skeleton, 20-40 frames) keep every run small; the Dask tests
start a 2-worker ``LocalCluster``. Real data only in the ``mocap_dir`` tests.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from database_testlib import assert_same_as_serial, needs_dask, synthetic_motion, write_clips

from elastic_motion.apps.database import (
    ClusterUnavailableError,
    DatabaseSettings,
    QueryResult,
    compute_matrix,
    compute_tile,
    find_motion_files,
    load_matrix,
    pair_distance,
    prepare_motion,
    query_distances,
    tile_blocks,
)
from elastic_motion.apps.database.settings import FORMAT_VERSION
from elastic_motion.errors import OptionError
from elastic_motion.motion import write_bvh
from elastic_motion.motion.rotations import euler_to_matrix
from elastic_motion.warp import WarpOptions

SRC = Path(__file__).resolve().parents[2] / "src"


# --------------------------------------------------------------------------------------------
# Synthetic database
# --------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def db_dir(tmp_path_factory) -> Path:
    """7 readable clips (2 kinds x 3 + 1 with another skeleton) and 2 bad files."""
    d = tmp_path_factory.mktemp("db")
    write_clips(d, kinds=(0, 1), variants=3, frames=24, step=4)
    write_bvh(synthetic_motion(0, 1, extra_joint=True), d / "other_skeleton.bvh")
    (d / "broken.bvh").write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0\n")
    (d / "empty.bvh").write_bytes(b"")
    (d / "notes.txt").write_text("not a motion\n")
    return d


SETTINGS = DatabaseSettings(n_samples=12, tile_size=2, warp=WarpOptions(method="dp", neighbourhood=4))


def _arrays(out: Path) -> dict[str, bytes]:
    return {r: np.load(out / f"distances_{r}.npy").tobytes() for r in ("lie", "euler")}


# --------------------------------------------------------------------------------------------
# Pieces
# --------------------------------------------------------------------------------------------


def test_tile_blocks_cover_each_pair_once() -> None:
    m, ts = 7, 3
    seen: dict[tuple[int, int], int] = {}
    for bi, bj in tile_blocks(m, ts):
        for i in range(bi * ts, min((bi + 1) * ts, m)):
            for j in range(bj * ts, min((bj + 1) * ts, m)):
                if i <= j:
                    seen[(i, j)] = seen.get((i, j), 0) + 1
    assert seen == {(i, j): 1 for i in range(m) for j in range(i, m)}


def test_pair_distance_dp_below_none_and_symmetric() -> None:
    rng = np.random.default_rng(1)
    t = np.linspace(0, 1, 21)
    base = np.stack([np.sin(2 * np.pi * t[:-1] * (k + 1)) for k in range(5)], axis=1)
    q0 = base + 0.05 * rng.normal(size=base.shape)
    q1 = np.roll(base, 2, axis=0)
    none = pair_distance(q0, q1, WarpOptions(method="none"))
    assert none == pytest.approx(np.sqrt(np.mean(np.sum((q0 - q1) ** 2, axis=1))), rel=1e-14)
    dp = pair_distance(q0, q1, WarpOptions(method="dp"))
    assert dp <= none + 1e-12
    assert pair_distance(q1, q0, WarpOptions(method="dp")) == pytest.approx(dp, rel=1e-12)


def test_compute_tile_layout() -> None:
    q = [np.full((4, 2), float(k)) for k in range(4)]
    tile = compute_tile(
        np.array([0, 1]),
        np.array([1, 2, 3]),
        q,  # indexed by the global indices
        np.array([0, 0]),
        np.array([0, 0, 1]),
        WarpOptions(method="none"),
    )
    assert tile[0, 0] == pytest.approx(np.sqrt(2.0))  # d(0, 1): |0 - 1| in 2 dims
    assert tile[1, 0] == 0.0  # diagonal
    assert tile[0, 2] == np.inf and tile[1, 2] == np.inf  # other group
    assert np.isnan(compute_tile(np.array([2]), np.array([1]), q, [0], [0], WarpOptions("none"))).all()


def test_compute_tile_batched_dp_equals_one_optimal_warp_per_pair() -> None:
    """The tile's batched DP gives each pair the distance of ``optimal_warp(method="dp")``,
    across skeleton groups (another D) and for arrays of another length in the same tile."""
    from elastic_motion.warp import optimal_warp

    rng = np.random.default_rng(11)
    q = [np.cumsum(rng.normal(size=(16, 3)), axis=0) / 4 for _ in range(4)]
    q.append(rng.normal(size=(16, 5)))  # group 1: D = 5
    q.append(rng.normal(size=(16, 5)))
    q.append(rng.normal(size=(10, 3)))  # group 0, another length: solved in its own batch
    groups = np.array([0, 0, 0, 0, 1, 1, 0])
    rows, cols = np.array([0, 1, 4]), np.arange(7)
    warp = WarpOptions(method="dp", neighbourhood=5)
    tile = compute_tile(rows, cols, q, groups[rows], groups, warp)
    for a, i in enumerate(rows):
        for j in cols:
            if i == j:
                assert tile[a, j] == 0.0
            elif i > j:
                assert np.isnan(tile[a, j])
            elif groups[i] != groups[j]:
                assert tile[a, j] == np.inf
            else:
                ref = optimal_warp(q[i], q[j], method="dp", neighbourhood=5).distance
                assert tile[a, j] == pytest.approx(ref, rel=1e-12), (i, j)
                assert tile[a, j] == pair_distance(q[i], q[j], warp)  # the same numbers one by one
    c2f = compute_tile(rows[:1], cols[:3], q, groups[:1], groups[:3], warp.replace(coarse_to_fine=True))
    assert c2f[0, 1] == pytest.approx(
        optimal_warp(q[0], q[1], **warp.replace(coarse_to_fine=True).solver_kwargs()).distance
    )


def test_find_motion_files_ignores_text_and_keeps_bad_files(db_dir: Path) -> None:
    files, ignored = find_motion_files([db_dir, db_dir / "missing.bvh"])
    names = [f.name for f in files]
    assert "broken.bvh" in names and "empty.bvh" in names and "missing.bvh" in names
    assert [i.name for i in ignored] == ["notes.txt"]


def test_settings_default_warp_and_format_1_json() -> None:
    s = DatabaseSettings()
    assert s.warp == WarpOptions(method="dp") and s.warp.neighbourhood == 10  # WarpOptions' default
    assert s.warp.sample_smoothing == WarpOptions().sample_smoothing  # distance's low-pass
    assert DatabaseSettings(warp="none").warp == WarpOptions(method="none")
    assert DatabaseSettings.from_json(SETTINGS.to_json()) == SETTINGS
    old = {  # settings as written by format 1 (PairSpec)
        "n_samples": 12,
        "representations": ["lie"],
        "pair": {"warp": "none", "neighbourhood": 6, "coarse_to_fine": True},
        "joints": ["Hips", "Spine"],
        "drop_fingers": True,
        "align_heading": False,
        "tile_size": 2,
    }
    s = DatabaseSettings.from_json(old, 1)
    # its arrays were not low-passed: read as they were computed
    assert s.warp == WarpOptions(method="none", neighbourhood=6, coarse_to_fine=True, sample_smoothing=0.0)
    fmt2 = {**SETTINGS.to_json(), "warp": {**SETTINGS.warp.to_json(), "sample_smoothing": 0.5}}
    assert DatabaseSettings.from_json(fmt2, 2).warp.sample_smoothing == 0.0  # whatever its JSON says
    assert DatabaseSettings.from_json(fmt2).warp.sample_smoothing == 0.5  # this format: as written
    assert DatabaseSettings.from_json({"n_samples": 12}, 2).warp == WarpOptions(
        method="dp", sample_smoothing=0.0
    )
    # a warp stored by its method's name keeps that method, read without the low-pass too
    assert DatabaseSettings.from_json({"n_samples": 12, "warp": "none"}, 2).warp == WarpOptions(
        method="none", sample_smoothing=0.0
    )
    assert s.joints == ("Hips", "Spine") and s.representations == ("lie",) and not s.align_heading
    with pytest.raises(OptionError, match=r"settings: .*unknown \['colour'\]"):
        DatabaseSettings.from_json({**SETTINGS.to_json(), "colour": 1})


def test_prepare_motion_runs_the_shared_preparation_step() -> None:
    m = synthetic_motion(0, 0, frames=30)
    rot = m.rotations.copy()
    rot[0] = np.eye(3)  # a rest pose at frame 0, far from frame 1 (90 degrees below)
    rot[1:] = euler_to_matrix(np.array([0.0, 0.0, np.pi / 2]), "ZYX") @ rot[1:]
    m = m.replace(rotations=rot, up_axis="z")
    p = prepare_motion("clip.bvh", 8, motion=m)
    assert p.preparation is not None and p.preparation.tpose_dropped and p.preparation.up_axis_in == "z"
    assert p.original_frames == 29 and p.motion.n_frames == 9 and p.motion.up_axis == "y"
    assert any("T-pose" in n for n in p.notes) and any("z-up to y-up" in n for n in p.notes)
    with pytest.raises(OptionError, match=r"joints: clip: expected joints named \['Tail'\]"):
        prepare_motion("clip.bvh", 8, motion=m, joints=["Hips", "Tail"])


# --------------------------------------------------------------------------------------------
# Serial run: files, report, groups, bad input
# --------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def serial_run(db_dir: Path, tmp_path_factory):
    out = tmp_path_factory.mktemp("serial") / "out"
    return compute_matrix([db_dir], out, SETTINGS)


def test_serial_run_outputs(serial_run, db_dir: Path) -> None:
    out = serial_run.out_dir
    rep = json.loads((out / "report.json").read_text())
    assert rep["complete"] is True and serial_run.complete
    assert rep["n_motions"] == 7
    skipped = {Path(s["path"]).name: s["reason"] for s in rep["skipped"]}
    assert set(skipped) == {"broken.bvh", "empty.bvh"}
    assert all("ParseError" in r for r in skipped.values())
    assert [Path(p).name for p in rep["ignored"]] == ["notes.txt"]
    assert len(rep["groups"]) == 2 and rep["groups"][1]["motions"] == ["other_skeleton"]
    assert "+inf" in rep["comparison"]
    names = (out / "names.csv").read_text().splitlines()
    assert names[0] == "index,name,path,group,frames,fps,duration,joints" and len(names) == 8
    for r in ("lie", "euler"):
        d = np.load(out / f"distances_{r}.npy")
        assert d.shape == (7, 7) and not np.isnan(d).any()
        assert np.array_equal(d, d.T) and (np.diag(d) == 0).all()
        assert np.isinf(d[6, :6]).all()  # other skeleton: not comparable
        assert (d[:6, :6][~np.eye(6, dtype=bool)] > 0).all()
    man = json.loads((out / "manifest.json").read_text())
    assert len(man["tiles"]) == 2 * len(tile_blocks(7, 2))
    assert not list((out / "tiles").glob("*.tmp"))
    # the elastic distance separates the two kinds: nearest neighbour has the same kind
    d = np.load(out / "distances_lie.npy")[:6, :6] + np.diag([np.inf] * 6)
    kinds = [0, 0, 0, 1, 1, 1]
    assert all(kinds[int(np.argmin(d[i]))] == kinds[i] for i in range(6))
    # inputs untouched, nothing written beside them
    assert sorted(p.name for p in db_dir.iterdir()) == sorted(
        ["broken.bvh", "empty.bvh", "notes.txt", "other_skeleton.bvh"]
        + [f"k{k}_v{v}.bvh" for k in (0, 1) for v in range(3)]
    )


def test_warp_none_is_an_upper_bound(serial_run, db_dir: Path, tmp_path: Path) -> None:
    s = DatabaseSettings(n_samples=12, tile_size=2, warp=WarpOptions(method="none"))
    none = compute_matrix([db_dir], tmp_path / "none", s).distances["lie"]
    dp = np.load(serial_run.out_dir / "distances_lie.npy")
    fin = np.isfinite(dp)
    assert (dp[fin] <= np.asarray(none)[fin] + 1e-12).all()
    assert (dp[fin] < np.asarray(none)[fin] - 1e-9).sum() > 0


def test_rerun_is_a_noop_and_other_settings_are_refused(serial_run, db_dir: Path) -> None:
    out = serial_run.out_dir
    before = _arrays(out)
    again = compute_matrix([db_dir], out, SETTINGS)
    assert again.report["runs"][-1]["tiles_computed"] == 0 and again.complete
    assert _arrays(out) == before
    other = DatabaseSettings(n_samples=10, tile_size=2)
    with pytest.raises(ValueError, match=r"other settings or inputs.*n_samples"):
        compute_matrix([db_dir], out, other)


def test_overwrite_replaces_a_different_run(db_dir: Path, tmp_path: Path) -> None:
    out = tmp_path / "o"
    compute_matrix(
        [db_dir / "k0_v0.bvh", db_dir / "k1_v0.bvh"],
        out,
        DatabaseSettings(n_samples=8, representations=("lie",)),
    )
    res = compute_matrix(
        [db_dir / "k0_v0.bvh", db_dir / "k0_v1.bvh", db_dir / "k1_v1.bvh"],
        out,
        DatabaseSettings(n_samples=8, representations=("euler",)),
        overwrite=True,
    )
    assert res.names == ["k0_v0", "k0_v1", "k1_v1"]
    assert not (out / "distances_lie.npy").exists()


def test_common_joints_makes_one_group(db_dir: Path, tmp_path: Path) -> None:
    s = DatabaseSettings(n_samples=8, joints="common", representations=("lie",))
    res = compute_matrix([db_dir], tmp_path / "c", s)
    assert len(res.report["groups"]) == 1 and res.report["groups"][0]["n_joints"] == 4
    assert "4 joints they share" in res.report["comparison"]
    assert np.isfinite(np.asarray(res.distances["lie"])).all()


def test_no_readable_motion_is_an_error(db_dir: Path, tmp_path: Path) -> None:
    with pytest.raises(
        ValueError, match=r"expected at least one readable motion; got none \(skipped: .*broken"
    ):
        compute_matrix([db_dir / "broken.bvh"], tmp_path / "x", SETTINGS)
    assert not (tmp_path / "x").exists()  # nothing written


@needs_dask
def test_unreachable_scheduler_leaves_no_output(db_dir: Path, tmp_path: Path) -> None:
    out = tmp_path / "never"
    with pytest.raises(ClusterUnavailableError, match="could not reach the Dask scheduler"):
        compute_matrix(
            [db_dir], out, SETTINGS, engine="dask", scheduler="tcp://127.0.0.1:9", connect_timeout=1.0
        )
    assert not out.exists()


def test_search_matches_the_matrix_row(serial_run, db_dir: Path) -> None:
    m = load_matrix(serial_run.out_dir, "lie")
    res = query_distances(db_dir / "k1_v2.bvh", serial_run.out_dir, "lie")
    k = res.names.index("k1_v2")
    assert res.distances[k] == 0.0
    np.testing.assert_allclose(res.distances, m.distances[k], rtol=1e-10)
    assert res.group == 0 and res.names == m.names and res.settings == SETTINGS


def test_query_result_is_a_named_frozen_result(serial_run, db_dir: Path) -> None:
    res = query_distances(db_dir / "k0_v0.bvh", serial_run.out_dir, "euler")
    assert isinstance(res, QueryResult) and res.representation == "euler"
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.group = 1  # type: ignore[misc]
    assert res.distances.shape == (7,) and np.isinf(res.distances[6])  # the other skeleton
    near = res.nearest(2)
    assert [res.names[k][:2] for k in near] == ["k0", "k0"] and res.names.index("k0_v0") not in near
    summary = res.summary()
    text = json.dumps(summary, allow_nan=False)  # strict JSON: +inf became null
    assert json.loads(text)["distances"][6] is None and summary["settings"]["warp"]["neighbourhood"] == 4
    # a database of files: read now, with the settings given
    files = [db_dir / "k0_v1.bvh", db_dir / "k1_v0.bvh"]
    s = DatabaseSettings(n_samples=12, representations=("euler",), warp=WarpOptions(method="none"))
    res = query_distances(db_dir / "k0_v0.bvh", files, "euler", s)
    assert res.names == ["k0_v1", "k1_v0"] and res.settings == s and np.isfinite(res.distances).all()
    with pytest.raises(OptionError, match=r"method: expected one of .*\['euler-elastic'\]; got 'lie'"):
        query_distances(db_dir / "k0_v0.bvh", files, "lie", s)


def _as_format_1(out: Path) -> None:
    """Rewrite a run's manifest, report and SRV cache as the previous release wrote them."""

    def old(settings: dict) -> dict:
        d = dict(settings)
        w = d.pop("warp")
        d["pair"] = {"warp": w["method"], "neighbourhood": w["neighbourhood"], "coarse_to_fine": False}
        return d

    man = json.loads((out / "manifest.json").read_text())
    man["identity"]["format"] = 1
    man["identity"]["settings"] = old(man["identity"]["settings"])
    (out / "manifest.json").write_text(json.dumps(man))
    rep = json.loads((out / "report.json").read_text())
    rep["settings"] = old(rep["settings"])
    rep.pop("format", None)
    (out / "report.json").write_text(json.dumps(rep))
    with np.load(out / "srv_cache.npz") as z:
        arrays = {k: z[k] for k in z.files}
    meta = json.loads(str(arrays["meta"]))
    meta["format"] = 1
    meta["settings"] = old(meta["settings"])
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez(out / "srv_cache.npz", **arrays)


def test_run_of_the_previous_format_resumes_or_says_how_to_restart(
    serial_run, db_dir: Path, tmp_path: Path
) -> None:
    # the previous release did not low-pass the motions (format < 3): its run is that of
    # sample_smoothing 0, which its settings read as
    started = dataclasses.replace(SETTINGS, warp=dataclasses.replace(SETTINGS.warp, sample_smoothing=0.0))
    previous = compute_matrix([db_dir], tmp_path / "previous", started)
    out = tmp_path / "format1"
    shutil.copytree(previous.out_dir, out)
    _as_format_1(out)
    man = json.loads((out / "manifest.json").read_text())
    lost = sorted(man["tiles"])[0]
    del man["tiles"][lost]
    (out / "tiles" / f"{lost}.npy").unlink()  # interrupted before this tile
    (out / "manifest.json").write_text(json.dumps(man))
    # its cache and settings are read as they were
    q = query_distances(db_dir / "k1_v2.bvh", out, "lie")
    assert q.settings == started
    # other settings (the new default neighbourhood, the low-pass): refused, saying how to resume or restart
    with pytest.raises(
        OptionError,
        match=r"warp\.neighbourhood: 4 -> 10.*settings it was started with.*overwrite=True \(--overwrite\)",
    ):
        compute_matrix([db_dir], out, DatabaseSettings(n_samples=12, tile_size=2))
    with pytest.raises(
        OptionError,
        match=r"warp\.sample_smoothing: 0\.0 -> 0\.0166\d* \(resume it with --sample-smoothing 0\.0;",
    ):
        compute_matrix([db_dir], out, SETTINGS)
    # the settings it was started with: resumed, nothing recomputed but the lost tile
    res = compute_matrix([db_dir], out, started)
    assert res.complete and res.report["runs"][-1]["tiles_computed"] == 1
    assert json.loads((out / "manifest.json").read_text())["identity"]["format"] == FORMAT_VERSION
    assert _arrays(out) == _arrays(previous.out_dir)
    assert _arrays(out) != _arrays(serial_run.out_dir)  # the low-pass changes the numbers


# --------------------------------------------------------------------------------------------
# Dask engines and interruption
# --------------------------------------------------------------------------------------------


@needs_dask
def test_local_cluster_equals_serial_bit_for_bit(serial_run, db_dir: Path, tmp_path: Path) -> None:
    res = compute_matrix(
        [db_dir], tmp_path / "local", SETTINGS, engine="local", n_workers=2, force_cluster=True
    )
    assert res.complete and res.report["engine"] == "local" and res.report["workers"] == 2
    assert _arrays(res.out_dir) == _arrays(serial_run.out_dir)
    # the files were read and prepared on the workers: the same cache, skipped files included
    assert_same_as_serial(res, serial_run)


_KILLER = textwrap.dedent(
    """
    import os, sys
    sys.path.insert(0, {src!r})
    from elastic_motion.apps.database import DatabaseSettings, compute_matrix
    from elastic_motion.warp import WarpOptions

    def progress(stage, done, total, seen=[0]):
        if stage == "tiles":
            seen[0] += 1
            if seen[0] > {after}:  # the first call reports tiles already done
                os._exit(17)  # hard exit, as SIGKILL: no cleanup, no final manifest

    if __name__ == "__main__":
        s = DatabaseSettings(n_samples=12, tile_size=2, warp=WarpOptions(method="dp", neighbourhood=4))
        compute_matrix(
            [{db!r}], {out!r}, s, engine={engine!r}, n_workers=2, progress=progress, force_cluster=True
        )
    """
)


def _run_killed(db_dir: Path, out: Path, engine: str, after: int) -> None:
    code = _KILLER.format(src=str(SRC), after=after, db=str(db_dir), out=str(out), engine=engine)
    proc = subprocess.Popen([sys.executable, "-c", code], start_new_session=True)
    try:
        assert proc.wait(timeout=90) == 17
    finally:
        # the local cluster's worker processes lost their driver: end them (our process group)
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


def test_local_engine_runs_serially_when_a_cluster_would_not_pay(
    serial_run, db_dir: Path, tmp_path: Path
) -> None:
    """--engine local on 7 small clips: starting a cluster (about 6 s) costs more than the pair
    work, so the run is serial, says so, and gives the serial numbers."""
    res = compute_matrix([db_dir], tmp_path / "small", SETTINGS, engine="local", n_workers=2)
    assert res.complete and res.report["engine"] == "serial"
    assert res.report["engine_note"].startswith("local cluster not started")
    assert _arrays(res.out_dir) == _arrays(serial_run.out_dir)


@pytest.mark.parametrize("engine", ["serial", pytest.param("local", marks=needs_dask)])
def test_interrupted_run_resumes_without_loss_or_duplicates(
    engine: str, serial_run, db_dir: Path, tmp_path: Path
) -> None:
    out = tmp_path / "killed"
    _run_killed(db_dir, out, engine, after=5)
    rep = json.loads((out / "report.json").read_text())
    assert rep["complete"] is False
    tiles_before = {p.name: (p.stat().st_ino, p.stat().st_mtime_ns) for p in (out / "tiles").glob("*.npy")}
    assert 5 <= len(tiles_before) < 2 * len(tile_blocks(7, 2))
    res = compute_matrix([db_dir], out, SETTINGS)  # resume, serially
    assert res.complete
    run = res.report["runs"][-1]
    total = 2 * len(tile_blocks(7, 2))
    assert run["tiles_before"] == len(tiles_before)
    assert run["tiles_computed"] == total - len(tiles_before)  # nothing computed twice
    for p in (out / "tiles").glob("*.npy"):
        if p.name in tiles_before:  # finished tiles were kept, not rewritten
            assert (p.stat().st_ino, p.stat().st_mtime_ns) == tiles_before[p.name]
    assert _arrays(out) == _arrays(serial_run.out_dir)


def test_tile_on_disk_but_not_in_manifest_is_adopted(serial_run, db_dir: Path, tmp_path: Path) -> None:
    import shutil

    out = tmp_path / "copy"
    shutil.copytree(serial_run.out_dir, out)
    man = json.loads((out / "manifest.json").read_text())
    keys = sorted(man["tiles"])
    del man["tiles"][keys[0]]  # finished, but the crash came before the manifest write
    (out / "tiles" / f"{keys[1]}.npy").unlink()  # lost: must be recomputed
    (out / "manifest.json").write_text(json.dumps(man))
    rep = json.loads((out / "report.json").read_text())
    rep["complete"] = False
    (out / "report.json").write_text(json.dumps(rep))
    res = compute_matrix([db_dir], out, SETTINGS)
    run = res.report["runs"][-1]
    assert run["tiles_recovered"] == 1 and run["tiles_computed"] == 1
    assert _arrays(out) == _arrays(serial_run.out_dir)


# --------------------------------------------------------------------------------------------
# CLI
# --------------------------------------------------------------------------------------------


def _parser() -> argparse.ArgumentParser:
    from elastic_motion.cli_commands import database
    from elastic_motion.cli_commands._argparse import CliParser

    parser = CliParser(prog="elastic-motion")
    database.register(parser.add_subparsers(dest="command"))
    return parser


def _cli(argv: list[str]) -> int:
    args = _parser().parse_args(argv)
    return args.func(args)


def test_cli_matrix_search_classify_cluster(db_dir: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "cli"
    common = ["--samples", "10", "--neighbourhood", "4", "--tile-size", "3", "--quiet"]
    assert _cli(["matrix", str(db_dir), "-o", str(out), *common, "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["complete"] and len(rep["skipped"]) == 2
    assert _cli(["search", str(db_dir / "k0_v0.bvh"), str(out), "-k", "2", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)["results"]
    assert [r["name"][:2] for r in res] == ["k0", "k0"]  # itself excluded, same kind first
    labels = tmp_path / "labels.csv"
    labels.write_text("".join(f"k{k}_v{v},kind{k}\n" for k in (0, 1) for v in range(3)))
    assert _cli(["classify", str(out), "--labels", str(labels), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["command"] == "classify" and report["inputs"] == [str(out)]  # the shared header
    acc = report["results"]
    assert acc["lie"]["accuracy"] == 1.0 and acc["lie"]["evaluated"] == 6
    # a rule that labels none of these files is an error, not an accuracy of nan
    assert _cli(["classify", str(out), "--labels", "cmu"]) == 2
    assert (
        "--labels: cmu: expected labels for at least 2 motions of the matrix; got 0 of"
        in capsys.readouterr().err
    )
    # several stored databases at once: refused, named; -k larger than the candidates: say how many
    query = str(db_dir / "k0_v0.bvh")
    assert _cli(["search", query, str(out), str(out)]) == 2
    assert "DATABASE: expected one stored database (an index or a matrix folder)" in capsys.readouterr().err
    assert _cli(["search", query, str(out), "-k", "100"]) == 0
    text = capsys.readouterr().out
    assert "exact 5 nearest: full DP on" in text and "exact 100" not in text
    png = tmp_path / "dendro.png"
    assert (
        _cli(["cluster", str(out), "--clusters", "3", "--plot", str(png), "--labels", str(labels), "--json"])
        == 0
    )
    cl = json.loads(capsys.readouterr().out)["clusters"]
    assert cl["k0_v0"] == cl["k0_v1"] == cl["k0_v2"] != cl["k1_v0"]
    assert png.stat().st_size > 1000


def test_cli_mean_refuses_to_overwrite_an_input(db_dir: Path, capsys) -> None:
    a, b = db_dir / "k0_v0.bvh", db_dir / "k0_v1.bvh"
    before = a.read_bytes()
    assert _cli(["mean", str(a), str(b), "-o", str(a), "--quiet"]) == 2
    assert "refusing to overwrite an input" in capsys.readouterr().err
    assert a.read_bytes() == before


def test_cli_mean_writes_the_named_result(db_dir: Path, tmp_path: Path, capsys) -> None:
    a, b = str(db_dir / "k0_v0.bvh"), str(db_dir / "k0_v1.bvh")
    out = tmp_path / "mean.bvh"
    argv = ["mean", a, b, "--output", str(out), "--samples", "8", "--neighbourhood", "3", "--quiet", "--json"]
    assert _cli(argv) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["command"] == "mean" and rep["output"] == str(out) and rep["outputs"] == [str(out)]
    assert rep["inputs"] == [a, b] and list(rep["distances"]) == [a, b] and rep["representation"] == "lie"
    assert len(rep["energies"]) == rep["iterations"] >= 1 and out.stat().st_size > 0


@needs_dask
def test_cli_unreachable_scheduler_exit_code(db_dir: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "never"
    argv = ["matrix", str(db_dir), "-o", str(out), "--engine", "dask", "--scheduler", "tcp://127.0.0.1:9"]
    assert _cli([*argv, "--timeout", "1", "--quiet"]) == 3
    assert "could not reach the Dask scheduler" in capsys.readouterr().err
    assert not out.exists()


COMMANDS = ("matrix", "search", "classify", "mean", "cluster")


def _subparsers() -> dict[str, argparse.ArgumentParser]:
    sub = next(a for a in _parser()._actions if isinstance(a, argparse._SubParsersAction))
    return {c: sub.choices[c] for c in COMMANDS}


def test_cli_help_one_name_per_concept_and_every_default() -> None:
    for cmd, p in _subparsers().items():
        text = p.format_help()
        assert "--method" in text, cmd
        for old in ("--repr", "--out ", "--no-align-heading"):
            assert old not in text, (cmd, old)  # hidden aliases
        for a in p._actions:
            if a.help == argparse.SUPPRESS or not a.option_strings or a.nargs == 0:
                continue
            if a.default is not None:
                shown = re.search(r"\(default: ([^)]*)\)", a.help)
                assert shown, (cmd, a.option_strings)
                if isinstance(a.default, float):
                    assert float(shown[1]) == a.default, (cmd, a.option_strings)
                else:
                    assert shown[1] == str(a.default), (cmd, a.option_strings)
    helps = {c: p.format_help() for c, p in _subparsers().items()}
    assert "(default: 1)" in helps["classify"] and "(default: 10)" in helps["matrix"]
    for cmd in ("matrix", "mean"):
        assert "-o OUTPUT, --output OUTPUT" in helps[cmd]
    for cmd in ("matrix", "search", "mean"):
        assert "--no-align" in helps[cmd] and "--neighbourhood N" in helps[cmd]
    assert "--linkage {average,complete,single,weighted}" in helps["cluster"]


def test_cli_old_spellings_still_work_with_a_note(db_dir: Path, tmp_path: Path, capsys) -> None:
    files = [str(db_dir / f"k{k}_v{v}.bvh") for k in (0, 1) for v in (0, 1)]
    common = ["--samples", "8", "--neighbourhood", "3", "--tile-size", "3", "--quiet", "--json"]
    old = tmp_path / "old"
    assert _cli(["matrix", *files, "--out", str(old), "--repr", "lie", "--no-align-heading", *common]) == 0
    out, err = capsys.readouterr()
    for a, b in (("--out", "--output"), ("--repr", "--method"), ("--no-align-heading", "--no-align")):
        assert f"{a} is deprecated" in err and f"use {b}" in err
    rep = json.loads(out)
    assert rep["settings"]["representations"] == ["lie"] and rep["settings"]["align_heading"] is False
    new = tmp_path / "new"
    assert _cli(["matrix", *files, "-o", str(new), "--method", "lie", "--no-align", *common]) == 0
    assert "deprecated" not in capsys.readouterr().err
    assert np.load(old / "distances_lie.npy").tobytes() == np.load(new / "distances_lie.npy").tobytes()
    args = _parser().parse_args(["search", files[0], str(new), "--repr", "euler"])
    assert args.method == "euler"
    args = _parser().parse_args(["mean", *files[:2], "--out", str(tmp_path / "m.bvh")])
    assert args.output == str(tmp_path / "m.bvh")


def test_cli_errors_name_the_option(serial_run, db_dir: Path, capsys) -> None:
    out = str(serial_run.out_dir)
    assert _cli(["cluster", out, "--method", "average"]) == 2
    assert capsys.readouterr().err.strip() == (
        "elastic-motion cluster: error: --method: expected a curve representation, one of lie, "
        "euler-elastic; "
        "got 'average', a linkage (use --linkage average)"
    )
    assert _cli(["cluster", out, "--linkage", "complete", "--clusters", "2", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["linkage_method"] == "complete"
    assert _cli(["classify", out, "--labels", "cmu", "--method", "lie,quaternion"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(
        "elastic-motion classify: error: --method: expected distinct entries of lie, euler-elastic;"
    )
    assert _cli(["matrix", str(db_dir), "-o", out, "--neighbourhood", "0", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("elastic-motion matrix: error: --neighbourhood: expected an integer >= 1")
    before = _arrays(serial_run.out_dir)
    assert _cli(["matrix", str(db_dir), "-o", out, "--samples", "10", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("elastic-motion matrix: error: --output: ") and "n_samples: 12 -> 10" in err
    assert "--overwrite" in err and _arrays(serial_run.out_dir) == before


# --------------------------------------------------------------------------------------------
# Real data
# --------------------------------------------------------------------------------------------


@pytest.mark.mocap
def test_real_folders_groups_and_skips(mocap_dir: Path, tmp_path: Path) -> None:
    files = [mocap_dir / "cmu" / "bvh" / n for n in ("07_01.bvh", "09_11.bvh", "131_01.bvh")]
    files += [
        mocap_dir / "bandai" / n for n in ("dataset-1_walk_normal_001.bvh", "dataset-1_run_normal_001.bvh")
    ]
    bad = tmp_path / "truncated.bvh"
    bad.write_text((mocap_dir / "cmu" / "bvh" / "07_01.bvh").read_text()[:5000])
    s = DatabaseSettings(n_samples=16, warp=WarpOptions(method="dp", neighbourhood=4))
    res = compute_matrix([*files, bad], tmp_path / "real", s)
    rep = res.report
    assert rep["complete"] and rep["n_motions"] == 5
    assert [Path(x["path"]).name for x in rep["skipped"]] == ["truncated.bvh"]
    # CMU (two conversions with different joint names) and Bandai: three skeleton groups
    assert len(rep["groups"]) == 3
    d = np.asarray(res.distances["lie"])
    assert np.isfinite(d[0, 1]) and np.isinf(d[0, 2])
