"""The retrieval distance in the database commands (issue 15, ``docs/database.md``, "Retrieval
quality"): the pose term beside the SRV (``DatabaseSettings.pose_weight``, balanced without
labels) and phase-free matching (``DatabaseSettings.cyclic``), in the cache, the matrix, the
index, search and the CLI.

Synthetic BVH clips of ``test_database.synthetic_motion`` (4 joints, 16-30 frames).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from database_testlib import assert_local_cluster_is_serial, needs_dask, write_clips

from elastic_motion.apps.database import (
    DatabaseSettings,
    build_index,
    compute_matrix,
    knn_search,
    pair_distance,
    pair_distances,
    query_distances,
)
from elastic_motion.apps.database.cache import SRVCache, build_srv_cache
from elastic_motion.apps.database.preparation import (
    balanced_pose_weight,
    pose_arrays,
    prepare_motion,
    with_pose_term,
)
from elastic_motion.errors import OptionError
from elastic_motion.warp import WarpOptions

WARP = WarpOptions(method="dp", neighbourhood=4)
PLAIN = DatabaseSettings(n_samples=10, representations=("lie",), warp=WARP)
RETRIEVAL = DatabaseSettings(
    n_samples=10, representations=("lie", "euler"), warp=WARP, pose_weight="balanced", cyclic=True
)


@pytest.fixture(scope="module")
def clips(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("clips")
    write_clips(d, kinds=(0, 1), variants=4, frames=16, step=4)
    return d


def _brute_cyclic(q0: np.ndarray, q1: np.ndarray) -> float:
    """Independent: every cyclic shift of either array, one plain DP pair each."""
    n = q0.shape[0]
    return min(
        min(pair_distance(q0, np.roll(q1, s, axis=0), WARP), pair_distance(q1, np.roll(q0, s, axis=0), WARP))
        for s in range(n)
    )


def test_cyclic_distance_is_the_least_over_the_shifts_of_either_array() -> None:
    rng = np.random.default_rng(0)
    q = [rng.normal(size=(9, 4)) for _ in range(4)]
    q.append(np.roll(q[0], 4, axis=0))  # the first started at another phase
    pairs = np.array([(a, b) for a in range(5) for b in range(5) if a != b])
    got = pair_distances(q, q, pairs, WARP, cyclic=True)
    plain = pair_distances(q, q, pairs, WARP)
    for (a, b), d in zip(pairs, got, strict=True):
        assert d == _brute_cyclic(q[a], q[b])
    sym = {(a, b): d for (a, b), d in zip(pairs, got, strict=True)}
    assert all(sym[a, b] == sym[b, a] for a, b in sym)
    assert (got <= plain).all() and (got < plain - 1e-3).any()
    assert pair_distance(q[0], q[4], WARP, cyclic=True) == 0.0 < pair_distance(q[0], q[4], WARP)
    with pytest.raises(OptionError, match="cyclic: phase-free matching needs the DP alone"):
        pair_distance(q[0], q[1], WarpOptions(method="dp+refine"), cyclic=True)


def test_settings_of_the_retrieval_distance() -> None:
    s = DatabaseSettings(pose_weight="balanced", cyclic=True)
    assert DatabaseSettings.from_json(s.to_json()) == s
    assert "pose_weight" not in DatabaseSettings().to_json()  # default files read as before
    assert DatabaseSettings(pose_weight="2").pose_weight == 2.0
    for bad, msg in (
        ({"pose_weight": -1}, "pose_weight: expected a number >= 0 or 'balanced'"),
        ({"pose_weight": "heavy"}, "pose_weight: expected a number >= 0 or 'balanced'"),
        ({"cyclic": "yes"}, "cyclic: expected True or False"),
        ({"cyclic": True, "warp": "dp+refine"}, "cyclic: phase-free matching needs the DP warp"),
        (
            {"cyclic": True, "warp": WarpOptions(method="dp", coarse_to_fine=True)},
            "cyclic: phase-free matching needs the DP warp .*got warp 'dp' with coarse to fine",
        ),
    ):
        with pytest.raises(OptionError, match=msg):
            DatabaseSettings(**bad)


def test_the_cache_appends_the_balanced_pose_term(clips: Path, tmp_path: Path) -> None:
    files = sorted(str(f) for f in clips.glob("*.bvh"))
    plain = build_srv_cache(files, PLAIN)
    cache = build_srv_cache(files, DatabaseSettings(**{**_fields(PLAIN), "pose_weight": "balanced"}))
    # independently: the pose arrays of the prepared motions with the group's joint weights
    jw = np.asarray(plain.group_weights[0][0])
    smoothing = PLAIN.warp.sample_smoothing  # the low-pass the database applies (issue 34)
    poses = [pose_arrays(prepare_motion(f, 10, smoothing=smoothing).motion, jw) for f in plain.paths]
    lam = balanced_pose_weight(plain.q["lie"], poses)
    assert lam > 0 and cache.pose_weights == {"lie": [pytest.approx(lam, rel=1e-12)]}
    for a, b, p in zip(cache.q["lie"], plain.q["lie"], poses, strict=True):
        np.testing.assert_allclose(a, with_pose_term(b, p, lam), rtol=0, atol=1e-12)
    # a given weight is used as it is; the cache keeps the weights through save and load
    fixed = build_srv_cache(files, DatabaseSettings(**{**_fields(PLAIN), "pose_weight": 0.5}))
    np.testing.assert_allclose(
        fixed.q["lie"][3], with_pose_term(plain.q["lie"][3], poses[3], 0.5), atol=1e-12
    )
    cache.save(tmp_path / "c.npz")
    back = SRVCache.load(tmp_path / "c.npz")
    assert back.pose_weights == cache.pose_weights and back.settings == cache.settings
    # a cache that lost its pose weights is refused by name, not by a KeyError at query time
    dataclasses.replace(cache, pose_weights={}).save(tmp_path / "damaged.npz")
    with pytest.raises(OptionError, match=r"damaged\.npz: expected one pose weight per representation"):
        SRVCache.load(tmp_path / "damaged.npz")


def _fields(s: DatabaseSettings) -> dict:
    return {k: getattr(s, k) for k in s.__dataclass_fields__}


def test_matrix_query_search_and_index_agree(clips: Path, tmp_path: Path) -> None:
    res = compute_matrix([clips], tmp_path / "m", RETRIEVAL)
    d = res.distances["lie"]
    names = res.names
    idx = tmp_path / "idx"
    build_index([clips], idx, RETRIEVAL)
    for query in sorted(clips.glob("*.bvh"))[::3]:
        row = names.index(query.stem)
        for db in (idx, clips):
            q = query_distances(query, db, "lie", RETRIEVAL)
            np.testing.assert_allclose(q.distances, d[row], rtol=1e-12, atol=1e-12)
        brute = query_distances(query, idx, "euler")
        for k in (1, 3):
            hit = knn_search(query, idx, k, "euler")
            assert hit.indices.tolist() == brute.nearest(k).tolist()
            assert hit.distances.tolist() == brute.distances[brute.nearest(k)].tolist()


@needs_dask
def test_local_cluster_gives_the_serial_matrix(clips: Path, tmp_path: Path) -> None:
    """The pose arrays are made on the workers (with the files), the weight on the driver."""
    assert_local_cluster_is_serial(clips, tmp_path, RETRIEVAL)


def test_cli_pose_weight_and_cyclic(clips: Path, tmp_path: Path, capsys) -> None:
    from elastic_motion.cli import main

    opts = ["--samples", "10", "--neighbourhood", "4", "--warp", "dp", "--method", "lie", "--quiet"]
    out = tmp_path / "m"
    assert main(["matrix", str(clips), "-o", str(out), *opts, "--pose-weight", "balanced", "--cyclic"]) == 0
    api = compute_matrix(
        [clips], tmp_path / "api", DatabaseSettings(**{**_fields(RETRIEVAL), "representations": ("lie",)})
    )
    np.testing.assert_array_equal(np.load(out / "distances_lie.npy"), api.distances["lie"])
    query = str(clips / "k1_v2.bvh")
    capsys.readouterr()
    assert main(["search", query, str(clips), "-k", "2", *opts, "--pose-weight", "1", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["settings"]["pose_weight"] == 1.0 and len(rep["results"]) == 2
    assert main(["matrix", str(clips), "-o", str(tmp_path / "x"), *opts, "--pose-weight", "heavy"]) != 0
    assert "--pose-weight: expected a number >= 0 or 'balanced'; got 'heavy'" in capsys.readouterr().err
    bad = [*opts[:-3], "--warp", "dp+refine", "--cyclic", "--quiet"]
    assert main(["matrix", str(clips), "-o", str(tmp_path / "y"), *bad]) != 0
    assert "--cyclic: phase-free matching needs the DP warp" in capsys.readouterr().err
    assert main(["search", query, str(clips), "--within", "--cyclic", "--quiet"]) != 0
    assert "--within: expected none of --cyclic (partial matching" in capsys.readouterr().err
    # resuming without --cyclic names what changed (the field is written only when set)
    argv = ["matrix", str(clips), "-o", str(out), *opts, "--pose-weight", "balanced"]
    assert main(argv) != 0
    assert "cyclic: True -> False" in capsys.readouterr().err
    # against a stored database its own settings are used: other flags are named, not silent
    plain = tmp_path / "plain"
    assert main(["matrix", str(clips), "-o", str(plain), *opts]) == 0
    capsys.readouterr()
    assert main(["search", query, str(plain), "-k", "2", *opts, "--cyclic", "--pose-weight", "balanced"]) == 0
    text = capsys.readouterr().out
    assert (
        "note: settings ignored: pose_weight='balanced' (built with 0.0), cyclic=True (built with False); "
        "a stored database is measured with the settings it was built with" in text
    )
    assert main(["search", query, str(out), "-k", "2", *opts, "--cyclic", "--pose-weight", "balanced"]) == 0
    assert "ignored" not in capsys.readouterr().out  # the same as stored: nothing to say


def test_a_stored_database_names_every_setting_it_does_not_use(clips: Path, tmp_path: Path, capsys) -> None:
    """Against an index or a matrix folder the stored settings are used; each flag given (API:
    each field of ``settings``) that differs from them is named, the flags not given never are
    (the stored database was built with --samples 10: searching without --samples is not a
    request for the default 64)."""
    from elastic_motion.apps.database import is_stored_database
    from elastic_motion.cli import main

    opts = ["--samples", "10", "--neighbourhood", "4", "--method", "lie", "--quiet"]
    idx = tmp_path / "idx"
    assert main(["index", str(clips), "-o", str(idx), *opts]) == 0
    assert is_stored_database(idx) and not is_stored_database(clips) and not is_stored_database([idx, idx])
    query = str(clips / "k1_v2.bvh")
    capsys.readouterr()
    assert main(["search", query, str(idx), "-k", "2", "--json"]) == 0
    plain = json.loads(capsys.readouterr().out)
    assert not any("ignored" in n for n in plain["notes"])
    argv = ["search", query, str(idx), "-k", "2", "--samples", "12", "--keep-fingers", "--warp", "dp+refine"]
    assert main([*argv, "--neighbourhood", "4", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["notes"][0].startswith(
        "settings ignored: n_samples=12 (built with 10), warp.method='dp+refine' (built with 'dp'), "
        "drop_fingers=False (built with True);"
    )
    assert rep["results"] == plain["results"] and rep["settings"] == plain["settings"]
    # the API: the fields of the settings given that differ from the stored ones
    stored = DatabaseSettings(
        n_samples=10, representations=("lie",), warp=WarpOptions(method="dp", neighbourhood=4)
    )
    assert knn_search(query, idx, 2, "lie", stored).notes == knn_search(query, idx, 2, "lie").notes
    asked = dataclasses.replace(
        stored, n_samples=12, align_heading=False, warp=WarpOptions(method="dp", sample_smoothing=0.0)
    )
    notes = query_distances(query, idx, "lie", asked).notes
    assert notes[0].startswith(
        "settings ignored: n_samples=12 (built with 10), "
        "warp.sample_smoothing=0.0 (built with 0.016666666666666666), "
        "warp.neighbourhood=10 (built with 4), align_heading=False (built with True);"
    )
    assert knn_search(query, idx, 2, "lie", asked).notes[0] == notes[0]
    # a database of files is read with the settings given: nothing is ignored
    assert not any("ignored" in n for n in query_distances(query, clips, "lie", asked).notes)
    # the same settings asked from both doors: the same note, word for word
    asked = DatabaseSettings(
        n_samples=12,
        representations=("lie",),
        warp=WarpOptions(method="dp+refine", neighbourhood=4),
        drop_fingers=False,
    )
    assert knn_search(query, idx, 2, "lie", asked).notes[0] == rep["notes"][0]


def test_settings_differences_in_order_and_joint_lists_as_sets() -> None:
    """The fields in ``new``'s order, those written only when set (pose weight, cyclic) last
    (a resumed folder's message reads the changed fields first); a list of joints in another
    order is the same selection (the preparation keeps the skeleton's order)."""
    from elastic_motion.apps.database.settings import settings_differences

    old = DatabaseSettings(n_samples=16, cyclic=True, pose_weight=1.0, joints=("b", "a")).to_json()
    new = DatabaseSettings(n_samples=12, warp=WarpOptions(method="dp", neighbourhood=4), joints=("a", "b"))
    assert settings_differences(old, new.to_json()) == [
        ("n_samples", 16, 12),
        ("warp.neighbourhood", 10, 4),
        ("pose_weight", 1.0, 0.0),
        ("cyclic", True, False),
    ]
    assert settings_differences(old, old, ("n_samples",)) == []
    # a resumed folder refused for the order of its joints says so (not "format differs")
    from elastic_motion.apps.database.matrix import _identity_diff

    ident = {"inputs": ["x"], "settings": DatabaseSettings(joints=("a", "b")).to_json()}
    swapped = {"inputs": ["x"], "settings": DatabaseSettings(joints=("b", "a")).to_json()}
    assert (
        _identity_diff(ident, swapped) == "joints: the same joints in another order, ['a', 'b'] -> ['b', 'a']"
    )


def test_each_skeleton_group_gets_its_own_balanced_weight(tmp_path: Path) -> None:
    """One balanced weight per skeleton group, from that group's motions only (with the group's
    joint weights); a group of one motion gets 1 (nothing to balance it against). A query is
    measured with its own group's weight: it equals its matrix row."""
    import dataclasses

    from database_testlib import synthetic_motion

    from elastic_motion.motion import write_bvh

    clips = tmp_path / "clips"
    clips.mkdir()
    for k in range(4):
        write_bvh(synthetic_motion(k % 2, k, frames=14 + 2 * k), clips / f"a{k}.bvh")
    for k in range(3):
        write_bvh(synthetic_motion(2, k, frames=15 + 3 * k, extra_joint=True), clips / f"b{k}.bvh")
    lone = synthetic_motion(1, 2, frames=17, extra_joint=True)
    sk = dataclasses.replace(lone.skeleton, names=("Hips", "Spine", "LeftLeg", "RightLeg", "Neck"))
    write_bvh(lone.replace(skeleton=sk), clips / "c0.bvh")
    files = sorted(str(f) for f in clips.glob("*.bvh"))
    settings = DatabaseSettings(**{**_fields(PLAIN), "pose_weight": "balanced"})
    plain = build_srv_cache(files, PLAIN)
    cache = build_srv_cache(files, settings)
    assert plain.groups.tolist() == cache.groups.tolist() == [0] * 4 + [1] * 3 + [2]
    want = []
    for g in range(2):
        idx = np.flatnonzero(plain.groups == g)
        jw = np.asarray(plain.group_weights[g][0])
        smoothing = PLAIN.warp.sample_smoothing  # the database's low-pass (issue 34)
        poses = [pose_arrays(prepare_motion(plain.paths[k], 10, smoothing=smoothing).motion, jw) for k in idx]
        want.append(balanced_pose_weight([plain.q["lie"][k] for k in idx], poses))
    assert want[0] != pytest.approx(want[1])
    assert cache.pose_weights["lie"] == [
        pytest.approx(want[0], rel=1e-12),
        pytest.approx(want[1], rel=1e-12),
        1.0,
    ]
    res = compute_matrix([clips], tmp_path / "out", settings)
    d = np.asarray(res.distances["lie"])
    for row in (1, 5):
        q = query_distances(files[row], res.out_dir, "lie", settings)
        np.testing.assert_allclose(q.distances, d[row], rtol=1e-12, atol=1e-12)
