"""Exact k-nearest search with bounds, the on-disk index, partial matching (issue 15).

Synthetic BVH clips (4 joints, 20-40 frames) from ``test_database.synthetic_motion``; real
long takes only in the ``mocap_dir`` tests (trimmed).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from database_testlib import synthetic_motion, write_clips

from elastic_motion.apps.database import (
    DatabaseSettings,
    build_index,
    find_within,
    knn_search,
    load_index,
    load_matrix,
    lower_bounds,
    pair_distance,
    part_norms,
    query_distances,
    upper_bound,
)
from elastic_motion.apps.database.preparation import heading_relative_root
from elastic_motion.errors import OptionError
from elastic_motion.motion import select_frames, to_lie_curve, write_bvh
from elastic_motion.motion.edit import _apply_world_transform
from elastic_motion.motion.rotations import axis_rotation
from elastic_motion.warp import WarpOptions, optimal_warp, warp_energy
from elastic_motion.warp.partial import partial_warp

SETTINGS = DatabaseSettings(n_samples=12, warp=WarpOptions(method="dp", neighbourhood=4))


@pytest.fixture(scope="module")
def many_dir(tmp_path_factory) -> Path:
    """24 clips of 3 kinds, 8 variants each (time warps, phases, lengths), one skeleton."""
    d = tmp_path_factory.mktemp("many")
    write_clips(d, kinds=(0, 1, 2), variants=8, frames=20, step=2)
    return d


# --------------------------------------------------------------------------------------------
# Bounds
# --------------------------------------------------------------------------------------------


def test_part_norms_are_kept_by_a_warp() -> None:
    """The bound's premise: ||(q * phi)_c^+|| = ||q_c^+|| (and -), checked on a fine grid."""
    n = 4000
    t = (np.arange(n) + 0.5) / n
    q = np.stack([np.sin(5 * t), np.cos(3 * t) - 0.2, t - 0.5], axis=1)
    phi = t + 0.3 * np.sin(np.pi * t) / np.pi  # increasing, phi(0) = 0, phi(1) = 1
    dphi = 1 + 0.3 * np.cos(np.pi * t)
    qphi = np.sqrt(dphi)[:, None] * np.stack([np.sin(5 * phi), np.cos(3 * phi) - 0.2, phi - 0.5], axis=1)
    np.testing.assert_allclose(part_norms(qphi), part_norms(q), rtol=2e-3)


def test_lower_bound_below_dp_and_upper_bound_above() -> None:
    rng = np.random.default_rng(3)
    for _ in range(30):
        n, d = rng.integers(5, 30), rng.integers(1, 6)
        q0 = rng.normal(size=(n, d)) * rng.uniform(0.1, 3)
        q1 = np.roll(q0, rng.integers(0, 3), axis=0) * rng.uniform(0.5, 2) + 0.3 * rng.normal(size=(n, d))
        dp = pair_distance(q0, q1, WarpOptions(method="dp", neighbourhood=4))
        lb = lower_bounds(part_norms(q0), part_norms(q1)[None])[0]
        assert lb <= dp + 1e-12 <= upper_bound(q0, q1) + 2e-12
        # coarser partitions are looser: the whole norm, and one norm per coordinate
        whole = abs(np.sqrt(np.mean(np.sum(q0**2, 1))) - np.sqrt(np.mean(np.sum(q1**2, 1))))
        assert whole <= lb + 1e-12
    # the bound is tight when q1 is q0 warped (distance 0 by a warp; here: identity)
    q = rng.normal(size=(10, 3))
    assert lower_bounds(part_norms(q), part_norms(q)[None])[0] == 0.0


def test_lower_bound_is_attained_by_a_scaled_copy() -> None:
    """q1 = 2 q0: d(q0, q1) at the identity is ||q0|| and the bound gives the same (factor check)."""
    q0 = np.array([[1.0, -2.0], [0.5, 1.0], [-1.0, 0.0]])
    lb = lower_bounds(part_norms(q0), part_norms(2 * q0)[None])[0]
    assert lb == pytest.approx(np.sqrt(np.mean(np.sum(q0**2, axis=1))), rel=1e-14)


# --------------------------------------------------------------------------------------------
# Exact k-nearest search
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("method", ["lie", "euler-elastic"])
def test_knn_search_equals_brute_force_and_prunes(many_dir: Path, method: str) -> None:
    files = sorted(many_dir.glob("*.bvh"))
    pruned = []
    for query in files[::5]:
        brute = query_distances(query, many_dir, method, SETTINGS)
        for k in (1, 3):
            res = knn_search(query, many_dir, k, method, SETTINGS)
            want = brute.nearest(k)
            assert res.indices.tolist() == want.tolist()
            assert res.distances.tolist() == brute.distances[want].tolist()  # bit-identical
            assert res.candidates == len(files) - 1
            assert (res.lower_bounds[res.computed] <= brute.distances[res.computed] + 1e-12).all()
            # the certificate: every motion skipped has a bound above the k-th distance
            skipped = ~res.computed & np.isfinite(res.lower_bounds)
            assert (res.lower_bounds[skipped] > res.distances[-1]).all()
            pruned.append(res.fraction_pruned)
    assert max(pruned) > 0.3  # the bounds do prune on this database
    s = res.summary()
    json.dumps(s, allow_nan=False)
    assert s["method"] == method and s["computed"] == res.n_computed


def test_knn_search_k_larger_than_the_database(many_dir: Path) -> None:
    files = sorted(many_dir.glob("*.bvh"))[:3]
    res = knn_search(files[0], files, 10, "lie", SETTINGS)
    assert len(res.indices) == 2 and res.fraction_pruned == 0.0
    with pytest.raises(OptionError, match="k: expected an integer >= 1; got 0"):
        knn_search(files[0], files, 0)


# --------------------------------------------------------------------------------------------
# Index
# --------------------------------------------------------------------------------------------


def test_index_round_trip_and_search(many_dir: Path, tmp_path: Path) -> None:
    idx = tmp_path / "idx"
    built = build_index([many_dir], idx, SETTINGS)
    assert built.meta["n_motions"] == 24 and (idx / "index.json").is_file()
    back = load_index(idx)
    assert back.cache.names == built.cache.names
    query = many_dir / "k1_v3.bvh"
    a = knn_search(query, idx, 3, "lie")
    b = knn_search(query, many_dir, 3, "lie", SETTINGS)
    assert a.names == b.names and a.indices.tolist() == b.indices.tolist()
    assert a.distances.tolist() == b.distances.tolist()
    assert query_distances(query, idx, "euler").distances.shape == (24,)
    with pytest.raises(OptionError, match="--overwrite"):
        build_index([many_dir], idx, SETTINGS)
    build_index([many_dir], idx, SETTINGS, overwrite=True)


def test_index_of_another_version_is_refused(many_dir: Path, tmp_path: Path) -> None:
    idx = tmp_path / "idx"
    build_index([many_dir], idx, SETTINGS)
    meta = json.loads((idx / "index.json").read_text())
    meta["library"] = "0.0.1"
    (idx / "index.json").write_text(json.dumps(meta))
    with pytest.raises(
        OptionError, match=r"written by elastic-motion '0.0.1'. Rebuild it: elastic-motion index"
    ):
        knn_search(many_dir / "k0_v0.bvh", idx)


def test_query_of_another_skeleton_says_which_joints_differ(many_dir: Path, tmp_path: Path) -> None:
    idx = tmp_path / "idx"
    build_index([many_dir], idx, SETTINGS)
    q = tmp_path / "other.bvh"
    write_bvh(synthetic_motion(0, 1, extra_joint=True), q)
    res = knn_search(q, idx, 3)
    assert res.group == -1 and len(res.indices) == 0
    assert "lacks nothing, has extra ['Head']" in res.notes[-1]
    # a stored database is measured as built: the advice is to build it again, on files to
    # compare now on shared joints
    assert "build the database again on shared joints" in res.notes[-1]
    files = knn_search(q, [many_dir], 3, settings=SETTINGS)
    assert "compare on shared joints with joints='common'" in files.notes[-1]


# --------------------------------------------------------------------------------------------
# method= (was representation=)
# --------------------------------------------------------------------------------------------


def test_method_names_and_the_old_keyword(many_dir: Path, tmp_path: Path) -> None:
    files = sorted(many_dir.glob("*.bvh"))[:4]
    s = DatabaseSettings(n_samples=8, representations=("lie", "euler-elastic"))
    assert s.representations == ("lie", "euler")
    a = query_distances(files[0], files, "euler-elastic", s)
    b = query_distances(files[0], files, "euler", s)
    c = query_distances(files[0], files, settings=s, representation="euler")
    assert a.distances.tolist() == b.distances.tolist() == c.distances.tolist()
    assert a.method == "euler-elastic" and a.representation == "euler"
    with pytest.raises(OptionError, match=r"method: expected one of \['lie', 'euler-elastic'\]"):
        query_distances(files[0], files, "quaternion", s)
    with pytest.raises(OptionError, match="representations: expected distinct entries"):
        DatabaseSettings(representations=("euler", "euler-elastic"))


def test_load_matrix_accepts_euler_elastic(tmp_path: Path, many_dir: Path) -> None:
    from elastic_motion.apps.database import compute_matrix

    files = sorted(many_dir.glob("*.bvh"))[:3]
    out = tmp_path / "m"
    compute_matrix(files, out, DatabaseSettings(n_samples=8, representations=("euler-elastic",)))
    m = load_matrix(out, "euler-elastic")
    assert m.representation == "euler" and m.distances.shape == (3, 3)
    with pytest.raises(OptionError, match=r"method: .*computed \['euler-elastic'\]; got 'lie'"):
        load_matrix(out, "lie")


# --------------------------------------------------------------------------------------------
# Partial matching
# --------------------------------------------------------------------------------------------


def test_partial_warp_finds_an_exact_segment() -> None:
    rng = np.random.default_rng(0)
    q1 = rng.normal(size=(150, 4))
    r = partial_warp(q1[40:60], q1)
    assert (r.start, r.stop) == (40, 60) and r.energy == pytest.approx(0.0, abs=1e-12)
    # a segment played at half speed: 20 cells of the long curve in a query of 10 cells
    q0 = np.sqrt(2.0) * q1[80:100:2]
    q1b = q1.copy()
    q1b[81:100:2] = q1b[80:100:2]  # piecewise constant on pairs: slope 2 is exact
    r = partial_warp(q0, q1b)
    assert (r.start, r.stop) == (80, 100) and r.energy == pytest.approx(0.0, abs=1e-12)


def test_partial_warp_energy_is_the_energy_of_its_path() -> None:
    """Independent check: the DP value is warp_energy of the returned path on the segment."""
    rng = np.random.default_rng(5)
    q0 = rng.normal(size=(16, 3))
    q1 = rng.normal(size=(60, 3))
    r = partial_warp(q0, q1, neighbourhood=3)
    n0 = len(q0)
    seg = q1[r.start : r.stop]
    length = (r.stop - r.start) / n0  # segment length in units of the query's duration
    q_seg = np.sqrt(length) * seg  # SRV of the segment reparametrised onto [0, 1]
    v = r.vertices.copy()
    v[:, 1] = (v[:, 1] - v[0, 1]) / (v[-1, 1] - v[0, 1])
    e = warp_energy(q0, q_seg, v)
    assert r.energy == pytest.approx(e, rel=1e-10, abs=1e-12)
    # and no segment does better: brute force over all segments with the ordinary DP
    best = np.inf
    for a in range(len(q1)):
        for b in range(a + max(1, -(-n0 // 3)), min(len(q1), a + 3 * n0) + 1):
            qs = np.sqrt((b - a) / n0) * q1[a:b]
            if not (1 / 3 <= (b - a) / n0 <= 3):
                continue
            # on the break points of both (the grid the partial DP searches)
            grid = (np.linspace(0.0, 1.0, n0 + 1), np.linspace(0.0, 1.0, b - a + 1))
            best = min(best, optimal_warp(q0, qs, method="dp", neighbourhood=3, grid=grid).energy)
    assert r.energy <= best + 1e-9


def test_heading_relative_root_is_heading_invariant() -> None:
    m = synthetic_motion(1, 2, frames=40)
    turned = _apply_world_transform(m, axis_rotation(1.1, "Y"), np.array([2.0, 0.0, -1.0]))
    a, b = heading_relative_root(m), heading_relative_root(turned)
    np.testing.assert_allclose(a.root_translation, b.root_translation, atol=1e-12)
    np.testing.assert_allclose(a.rotations, b.rotations, atol=1e-12)
    # speed and height are kept
    sa = np.linalg.norm(np.diff(a.root_translation, axis=0), axis=1)
    sm = np.linalg.norm(np.diff(m.root_translation, axis=0), axis=1)
    np.testing.assert_allclose(sa, sm, rtol=1e-12)
    q = to_lie_curve(a)
    assert np.isfinite(q.values).all()


def test_find_within_locates_a_cut_segment(tmp_path: Path) -> None:
    long = synthetic_motion(2, 1, frames=120)
    takes = tmp_path / "takes"
    takes.mkdir()
    write_bvh(long, takes / "long.bvh")
    write_bvh(synthetic_motion(0, 0, frames=90), takes / "other.bvh")
    turned = _apply_world_transform(select_frames(long, slice(50, 81)), axis_rotation(0.8, "Y"), np.zeros(3))
    q = tmp_path / "q.bvh"
    write_bvh(turned, q)
    res = find_within(q, takes, n_samples=30)
    best = res.matches[0]
    assert best.name == "long" and abs(best.start_frame - 50) <= 1 and abs(best.stop_frame - 80) <= 1
    assert best.distance < 0.1 * res.matches[1].distance
    json.dumps(res.summary(), allow_nan=False)


@pytest.mark.mocap
def test_find_within_real_long_take(mocap_dir: Path, tmp_path: Path) -> None:
    from elastic_motion.motion import drop_tpose, read_motion

    m = drop_tpose(read_motion(mocap_dir / "cmu" / "bvh" / "01_01.bvh"))
    long = tmp_path / "take.bvh"
    write_bvh(select_frames(m, slice(0, 1200)), long)  # 10 s of the 23-s take
    q = tmp_path / "q.bvh"
    write_bvh(select_frames(m, slice(700, 941)), q)  # 2 s from inside it
    res = find_within(q, [long, mocap_dir / "cmu" / "bvh" / "07_01.bvh"], n_samples=32)
    best = res.matches[0]
    assert best.name == "take" and abs(best.start - 700 / 120) < 0.1 and abs(best.stop - 940 / 120) < 0.1


# --------------------------------------------------------------------------------------------
# Command line: index, search (index, --within), pca
# --------------------------------------------------------------------------------------------


def test_cli_index_search_within_pca(many_dir: Path, tmp_path: Path, capsys) -> None:
    from elastic_motion.cli import main

    idx = tmp_path / "idx"
    common = ["--samples", "10", "--neighbourhood", "3", "--quiet"]
    assert main(["index", str(many_dir), "-o", str(idx), *common, "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["command"] == "index" and rep["n_motions"] == 24 and rep["index_format"] == 2
    query = str(many_dir / "k2_v4.bvh")
    assert main(["search", query, str(idx), "-k", "3", "--json", "--quiet"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert [r["name"][:2] for r in rep["results"]] == ["k2"] * 3
    assert rep["candidates"] == 23 and 0 <= rep["fraction_pruned"] < 1 and rep["method"] == "lie"
    assert main(["search", query, str(idx), "-k", "2", "--method", "euler-elastic", "--quiet"]) == 0
    assert "pruned by the bounds" in capsys.readouterr().out
    # --within: the query is a piece of a long take
    take = tmp_path / "take.bvh"
    write_bvh(synthetic_motion(2, 1, frames=120), take)
    piece = tmp_path / "piece.bvh"
    write_bvh(select_frames(synthetic_motion(2, 1, frames=120), slice(40, 71)), piece)
    argv = ["search", str(piece), str(take), str(many_dir / "k0_v0.bvh"), "--within", "--samples", "30"]
    assert main([*argv, "--neighbourhood", "3", "--json", "--quiet"]) == 0
    rep = json.loads(capsys.readouterr().out)
    best = rep["matches"][0]
    assert best["name"] == "take" and abs(best["start_frame"] - 40) <= 1 and abs(best["stop_frame"] - 70) <= 1
    # without flags the CLI is find_within with its own defaults (48 cells, neighbourhood 4)
    argv = ["search", str(piece), str(take), str(many_dir / "k0_v0.bvh"), "--within", "--json", "--quiet"]
    assert main(argv) == 0
    api = find_within(piece, [take, many_dir / "k0_v0.bvh"])
    assert [m["distance"] for m in json.loads(capsys.readouterr().out)["matches"]] == [
        m.distance for m in api.matches
    ]
    # flags partial matching cannot honour are refused, named; so is a stored database
    assert main(["search", str(piece), str(take), "--within", "--joints", "common", "--no-align", "-q"]) != 0
    assert "--within: expected none of --joints, --no-align (partial matching" in capsys.readouterr().err
    assert (
        main(["search", str(piece), str(take), "--within", "--warp", "dp", "--pose-weight", "0", "-q"]) == 0
    )
    assert main(["search", str(piece), str(idx), "--within", "-q"]) != 0
    assert "--within: expected motion files or folders (the long takes); got a stored database" in (
        capsys.readouterr().err
    )
    # pca: mean and +-2 sd along 2 modes, a sample, the variance plot
    out = tmp_path / "pca"
    files = [str(f) for f in sorted(many_dir.glob("k1_*.bvh"))]
    argv = ["pca", *files, "-o", str(out), "--modes", "2", "--samples-out", "1", *common, "--json"]
    assert main(argv) == 0
    rep = json.loads(capsys.readouterr().out)
    names = sorted(p.name for p in out.iterdir())
    assert names == sorted(
        ["mean.bvh", "mode1_minus2sd.bvh", "mode1_plus2sd.bvh", "mode2_minus2sd.bvh", "mode2_plus2sd.bvh"]
        + ["sample1.bvh", "variance.png"]
    )
    assert rep["command"] == "pca" and abs(sum(rep["explained"]) - 1) < 1e-9 and rep["n_modes"] == 7
    assert "modes_note" not in rep
    # more modes asked than 3 motions have: both of their 2 modes written (4 files), and said
    argv = ["pca", *files[:3], "-o", str(tmp_path / "pca3"), "--modes", "4", "--samples-out", "0", *common]
    assert main([*argv, "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["modes_note"] == (
        "--modes 4: the model has 2 modes (3 motions give at most 2, fewer when they do not vary "
        "independently): wrote 2 (4 files)"
    )
    assert len(list((tmp_path / "pca3").glob("mode*.bvh"))) == 4


# --------------------------------------------------------------------------------------------
# One database across skeletons: joints="map"
# --------------------------------------------------------------------------------------------


def test_map_to_common_body_keeps_the_legs_and_refuses_unknown_skeletons() -> None:
    from elastic_motion.apps.database.jointmap import COMMON_JOINTS, CONVENTIONS, map_to_common_body
    from elastic_motion.motion import Skeleton, forward_kinematics

    # a DeepMimic-named chain: pelvis -> chest -> neck, hips/knees/ankles, shoulders/elbows
    names = list(CONVENTIONS["deepmimic"])
    parents = [-1, 0, 1, 0, 3, 4, 0, 6, 7, 1, 9, 1, 11]
    rng = np.random.default_rng(2)
    offsets = rng.normal(size=(13, 3)) * 0.2
    rot = ("Zrotation", "Yrotation", "Xrotation")
    sk = Skeleton(names, parents, offsets, [("Xposition", "Yposition", "Zposition", *rot)] + [rot] * 12)
    m0 = synthetic_motion(0, 0, frames=10)
    from elastic_motion.motion import Motion
    from elastic_motion.motion.rotations import euler_to_matrix

    r = euler_to_matrix(rng.normal(size=(10, 13, 3)) * 0.3, "ZYX")
    m = Motion(sk, 30.0, rng.normal(size=(10, 3)), r, metres_per_unit=1.0)
    c = map_to_common_body(m)
    assert c.skeleton.names == COMMON_JOINTS
    np.testing.assert_allclose(forward_kinematics(c), forward_kinematics(m), atol=1e-12)
    with pytest.raises(OptionError, match=r"joints: .*no joint-name map fits.*lacks"):
        map_to_common_body(m0)


@pytest.mark.mocap
def test_one_database_across_five_conventions(mocap_dir: Path, tmp_path: Path) -> None:
    from elastic_motion.apps.database import compute_matrix

    files = [
        mocap_dir / "cmu" / "bvh" / "07_01.bvh",  # CMU FBX conversion
        mocap_dir / "cmu" / "bvh" / "131_01.bvh",  # CMU cgspeed conversion
        mocap_dir / "cmu" / "asfamc" / "02_01.amc",  # CMU ASF/AMC
        mocap_dir / "bandai" / "dataset-1_walk_normal_001.bvh",
        mocap_dir / "deepmimic" / "humanoid3d_walk.txt",
        mocap_dir / "deepmimic" / "humanoid3d_backflip.txt",
    ]
    s = DatabaseSettings(n_samples=16, joints="map", representations=("lie",), warp=WarpOptions("dp", 3))
    res = compute_matrix(files, tmp_path / "mapped", s)
    assert res.report["n_motions"] == 6 and len(res.report["groups"]) == 1
    d = np.asarray(res.distances["lie"])
    assert np.isfinite(d).all()
    names = res.names
    # walks of three conventions (CMU FBX, CMU ASF, DeepMimic) are nearer to each other than
    # any of them to the DeepMimic backflip
    walks = [names.index(n) for n in ("07_01", "02_01", "humanoid3d_walk")]
    flip = names.index("humanoid3d_backflip")
    assert max(d[i, j] for i in walks for j in walks) < min(d[i, flip] for i in walks)


def test_cluster_worth_it_only_for_enough_work() -> None:
    from elastic_motion.apps.database.tiles import (
        LOCAL_CLUSTER_STARTUP,
        cluster_worth_it,
        estimated_serial_seconds,
    )

    w = WarpOptions("dp", 6)
    small, why = cluster_worth_it(38 * 37 // 2, 64, w)  # the 38 clips of the issue: 703 pairs
    assert not small and "not started" in why
    big, _ = cluster_worth_it(499_500, 64, w)
    assert big
    # the threshold: serial > startup * W / (W - 1)
    n = int(2 * LOCAL_CLUSTER_STARTUP / estimated_serial_seconds(1, 64, w)) + 2
    assert cluster_worth_it(n, 64, w)[0] and not cluster_worth_it(n // 2, 64, w)[0]
    assert estimated_serial_seconds(10, 64, WarpOptions("none")) < estimated_serial_seconds(10, 64, w)
    # one optimal_warp call per pair (refinement, coarse to fine) costs more than the batched DP
    for slower in (WarpOptions("dp+refine", 6), WarpOptions("dp", 6, coarse_to_fine=True)):
        assert estimated_serial_seconds(10, 64, slower) > estimated_serial_seconds(10, 64, w)


@pytest.mark.mocap
def test_two_conversions_in_one_database_share_the_first_rest_pose(mocap_dir: Path, tmp_path: Path) -> None:
    """CMU 107_02_30hz and 07_01 share their joint names, not their rest pose: in a database
    the later one is re-expressed in its group's first rest pose (a note), the index stores
    that rest pose, and a query of that conversion is re-expressed the same way, so it
    measures its own matrix row exactly; a mean of both conversions stands."""
    from elastic_motion.apps.database import compute_matrix, mean_motion
    from elastic_motion.apps.database.cache import SRVCache
    from elastic_motion.motion import forward_kinematics

    bvh = mocap_dir / "cmu" / "bvh"
    files = [bvh / "07_01.bvh", bvh / "08_02.bvh", bvh / "107_02_30hz.bvh"]
    settings = DatabaseSettings(
        n_samples=16, representations=("lie",), warp=WarpOptions(method="dp", neighbourhood=4)
    )
    res = compute_matrix(files, tmp_path / "m", settings)
    cache = SRVCache.load(tmp_path / "m" / "srv_cache.npz")
    assert [r["name"] for r in cache.group_rest] == ["07_01"]
    k = cache.names.index("107_02_30hz")
    assert any(n.startswith("107_02_30hz: rest pose unlike 07_01's") for n in cache.info[k]["notes"])
    q = query_distances(files[2], tmp_path / "m", "lie")
    assert any(n.startswith("107_02_30hz: rest pose unlike 07_01's") for n in q.notes)
    np.testing.assert_allclose(q.distances, res.distances["lie"][k], rtol=1e-12, atol=1e-12)
    m = mean_motion(files[::2], n_samples=16).motion
    feet = [m.skeleton.names.index(n) for n in ("LeftFoot", "RightFoot")]
    heights = np.median(forward_kinematics(m)[:, feet, 1], axis=0) * m.metres_per_unit
    assert (heights < 0.15).all()  # in two rest poses the mean's feet were at 0.84 and 0.88 m
