"""k-NN search and classification, Karcher mean, clustering, DTW baseline, plots."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from elastic_motion.apps.database import MeanMotionResult, mean_motion
from elastic_motion.apps.statistics import (
    bandai_labels,
    cluster,
    cmu_label,
    dtw_matrix,
    karcher_mean,
    knn_evaluate,
    nearest,
)
from elastic_motion.curves import DiscreteCurve, reparametrize_curve, srv_distance, srv_transform
from elastic_motion.groups import Euclidean, animation_group
from elastic_motion.motion import Motion, Skeleton, read_bvh, write_bvh
from elastic_motion.motion.rotations import euler_to_matrix
from elastic_motion.warp import WarpOptions

# --------------------------------------------------------------------------------------------
# Labels, search, k-NN
# --------------------------------------------------------------------------------------------


def test_labels_from_names() -> None:
    assert bandai_labels("dataset-1_walk-back_normal_001") == ("walk-back", "normal")
    assert bandai_labels("/x/dataset-1_walk_angry_001.bvh") == ("walk", "angry")
    assert bandai_labels("07_01") is None
    assert cmu_label("09_11") == "run" and cmu_label("107_02_30hz.bvh") == "walk"
    assert cmu_label("49_08") == "cartwheel" and cmu_label("99_99") is None


def test_nearest_skips_excluded_and_infinite() -> None:
    d = np.array([0.0, 3.0, np.inf, 1.0, np.nan, 1.0])
    assert nearest(d, 3, exclude=[0]).tolist() == [3, 5, 1]
    assert nearest(d, 10, exclude=[0]).tolist() == [3, 5, 1]
    with pytest.raises(ValueError, match="k >= 1"):
        nearest(d, 0)


def _two_clusters() -> np.ndarray:
    x = np.array([0.0, 0.1, 0.25, 5.0, 5.2, 5.3])
    return np.abs(x[:, None] - x[None, :])


def test_knn_leave_one_out() -> None:
    d = _two_clusters()
    ev = knn_evaluate(d, ["a", "a", "a", "b", "b", "b"], k=1)
    assert ev.accuracy == 1.0 and ev.n_evaluated == 6 and ev.per_class == {"a": (3, 3), "b": (3, 3)}
    # a mislabelled point is misclassified, and its neighbour too
    ev = knn_evaluate(d, ["a", "b", "a", "b", "b", "b"], k=1)
    assert ev.predictions[:3] == ["b", "a", "b"] and ev.accuracy == pytest.approx(3 / 6)
    # k = 3: majorities outvote the nearest other-class point
    assert knn_evaluate(d, ["a", "a", "a", "b", "b", "b"], k=3).accuracy == 1.0


def test_knn_blocks_and_unlabelled() -> None:
    d = _two_clusters()
    labels = ["a", "a", "a", "b", "b", None]
    # leave one block out: motions 0, 1 (block 0) cannot vote for each other
    ev = knn_evaluate(d, labels, k=1, blocks=[0, 0, 1, 2, 3, 4])
    assert ev.predictions[0] == "a" and ev.predictions[5] is None and ev.n_evaluated == 5
    ev = knn_evaluate(d, ["a", "a", "a", "b", "b", "b"], k=1, blocks=[0, 0, 0, 1, 1, 1])
    assert ev.predictions[0] == "b"  # only the other block is left
    d2 = d.copy()
    d2[0, 1] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        knn_evaluate(d2, labels)
    with pytest.raises(ValueError, match="6 labels"):
        knn_evaluate(d, labels[:3])


# --------------------------------------------------------------------------------------------
# Clustering and plots
# --------------------------------------------------------------------------------------------


def test_cluster_two_groups_and_infinite(tmp_path: Path) -> None:
    d = _two_clusters()
    res = cluster(d, list("abcdef"), n_clusters=2)
    assert res.labels[:3].tolist() == [res.labels[0]] * 3 and res.labels[3] != res.labels[0]
    d[0, 5] = d[5, 0] = np.inf
    res = cluster(d, n_clusters=2, method="complete")
    assert res.linkage.shape == (5, 4) and np.isfinite(res.linkage).all()
    with pytest.raises(ValueError, match="method"):
        cluster(d, method="ward")
    from elastic_motion.apps.plots_database import plot_dendrogram, plot_distance_matrix, plot_energies

    for p in (
        plot_dendrogram(res, tmp_path / "d.png", colors=list("xxxyyy"), title="t"),
        plot_distance_matrix(d, list("abcdef"), tmp_path / "m.png"),
        plot_energies([3.0, 2.0, 1.9], tmp_path / "e.png"),
    ):
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# --------------------------------------------------------------------------------------------
# DTW baseline
# --------------------------------------------------------------------------------------------


def test_dtw_matrix_against_a_direct_recursion() -> None:
    pytest.importorskip("dtaidistance")
    rng = np.random.default_rng(3)
    series = [rng.normal(size=(n, 2)) for n in (5, 7, 6)]
    d = dtw_matrix(series, parallel=False)

    def naive(a, b):
        c = np.full((len(a) + 1, len(b) + 1), np.inf)
        c[0, 0] = 0.0
        for i in range(1, len(a) + 1):
            for j in range(1, len(b) + 1):
                cost = np.sum((a[i - 1] - b[j - 1]) ** 2)
                c[i, j] = cost + min(c[i - 1, j], c[i, j - 1], c[i - 1, j - 1])
        return np.sqrt(c[-1, -1])

    assert np.allclose(d, d.T) and (np.diag(d) == 0).all()
    assert d[0, 1] == pytest.approx(naive(series[0], series[1]), rel=1e-9)
    assert d[1, 2] == pytest.approx(naive(series[1], series[2]), rel=1e-9)


# --------------------------------------------------------------------------------------------
# Karcher mean
# --------------------------------------------------------------------------------------------


def _r3_curve(n: int = 40, warp: float = 0.0) -> DiscreteCurve:
    s = np.linspace(0, 1, n + 1)
    s = s + warp * np.sin(np.pi * s) / np.pi  # increasing for |warp| < 1
    return DiscreteCurve(np.stack([np.cos(3 * s), np.sin(3 * s), s**2], axis=1), Euclidean(3))


def test_karcher_mean_of_copies_is_the_curve() -> None:
    c = _r3_curve()
    res = karcher_mean([c, c, c], n_samples=40)
    assert res.energies[0] == pytest.approx(0.0, abs=1e-20)
    np.testing.assert_allclose(res.mean.values, c.values, atol=1e-12)


def test_karcher_mean_of_reparametrisations() -> None:
    curves = [_r3_curve(warp=w) for w in (-0.5, 0.0, 0.4, 0.6)]
    res = karcher_mean(curves, n_samples=40, warp=WarpOptions(method="dp", neighbourhood=6), max_iter=15)
    e = res.energies
    assert (np.diff(e) <= 1e-12 * e[0]).all()  # energy never increases
    plain = karcher_mean(curves, n_samples=40, warp="none")
    assert e[-1] < 0.2 * plain.energies[0]  # alignment removes most of the timing differences
    # the mean has the shape of the common curve: small elastic distance to it
    from elastic_motion.warp import optimal_warp

    q_mean = srv_transform(res.mean).q
    q_c = srv_transform(_r3_curve()).q
    assert optimal_warp(q_c, q_mean).distance < 0.1 * srv_distance(
        srv_transform(curves[0]), srv_transform(curves[3])
    )


def test_karcher_mean_in_the_lie_group() -> None:
    g = animation_group(2)
    rng = np.random.default_rng(0)
    t = np.linspace(0, 1, 21)
    base = np.concatenate([np.stack([t, 0 * t, 0 * t], 1), 0.8 * np.stack([np.sin(2 * t)] * 6, 1)], axis=1)
    curves = []
    for _ in range(3):
        alg = base + 0.05 * rng.normal(size=base.shape)
        pts = np.concatenate([alg[:, :3], g.factors[1].exp(alg[:, 3:]).reshape(len(t), 18)], axis=1)
        curves.append(DiscreteCurve(pts, g))
    res = karcher_mean(curves, warp=WarpOptions(method="dp", neighbourhood=4))
    assert res.mean.group == g and res.mean.n_points == 21
    assert (np.diff(res.energies) <= 1e-12).all() and res.distances.shape == (3,)
    with pytest.raises(ValueError, match=r"expected a curve in"):
        karcher_mean([curves[0], _r3_curve()])


def _walk(variant: int) -> Motion:
    names = ["Hips", "LeftLeg", "RightLeg"]
    rot = ("Zrotation", "Yrotation", "Xrotation")
    sk = Skeleton(
        names,
        [-1, 0, 0],
        [[0, 0, 0], [0.1, -0.1, 0], [-0.1, -0.1, 0]],
        [("Xposition", "Yposition", "Zposition", *rot), rot, rot],
        end_site_parents=[1, 2],
        end_site_offsets=[[0, -0.5, 0]] * 2,
    )
    f = 30 + 5 * variant
    s = np.linspace(0, 1, f)
    s = s + 0.1 * variant * np.sin(np.pi * s)
    ang = np.zeros((f, 3, 3))
    ang[:, 1, 2] = 0.5 * np.sin(2 * np.pi * s)
    ang[:, 2, 2] = -0.5 * np.sin(2 * np.pi * s)
    root = np.stack([0 * s, 0.9 + 0 * s, 1.2 * s], axis=1)
    return Motion(sk, 30.0, root, euler_to_matrix(ang, "ZYX"), metres_per_unit=1.0)


@pytest.mark.parametrize("representation", ["lie", "euler"])
def test_mean_motion_writes_a_bvh(representation: str, tmp_path: Path) -> None:
    files = []
    for v in range(3):
        files.append(write_bvh(_walk(v), tmp_path / f"w{v}.bvh"))
    res = mean_motion(
        files, n_samples=16, representation=representation, warp=WarpOptions(method="dp", neighbourhood=4)
    )
    motion = res.motion
    out = write_bvh(motion, tmp_path / "mean.bvh")
    back = read_bvh(out)
    assert back.n_joints == 3 and back.fps == pytest.approx(30.0)
    info = res.summary()
    assert info["energies"] == res.karcher.energies.tolist() and len(info["energies"]) >= 1
    assert back.n_frames == motion.n_frames and abs(back.duration - res.duration) < 1 / 30 + 1e-9
    # the legs still swing in opposition in the mean
    assert np.corrcoef(back.rotations[:, 1, 1, 2], back.rotations[:, 2, 1, 2])[0, 1] < -0.9


def test_mean_motion_refuses_mixed_skeletons(tmp_path: Path) -> None:
    a = write_bvh(_walk(0), tmp_path / "a.bvh")
    m = _walk(1)
    from elastic_motion.motion import drop_joints

    b = write_bvh(drop_joints(m, ["RightLeg"]), tmp_path / "b.bvh")
    with pytest.raises(ValueError, match=r"expected the skeleton of .*lacks \['RightLeg'\].*joints='common'"):
        mean_motion([a, b], n_samples=8)
    res = mean_motion([a, b], n_samples=8, joints="common", warp=WarpOptions(method="dp", neighbourhood=3))
    assert res.motion.skeleton.names == ("Hips", "LeftLeg")


def test_mean_motion_result_is_named_and_serialisable(tmp_path: Path) -> None:
    files = [str(write_bvh(_walk(v), tmp_path / f"w{v}.bvh")) for v in range(2)]
    res = mean_motion(files, n_samples=8, warp="none")  # a method name: WarpOptions(method="none")
    assert isinstance(res, MeanMotionResult) and res.inputs == tuple(files)
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.duration = 1.0  # type: ignore[misc]
    summary = res.summary()
    back = json.loads(json.dumps(summary, allow_nan=False))
    assert back["inputs"] == files and list(back["distances"]) == files
    assert back["distances"][files[1]] == pytest.approx(float(res.distances[1]))
    assert back["iterations"] == 0 and back["converged"] is True  # no warp: the plain average
    assert back["frames"] == res.motion.n_frames and back["fps"] == res.motion.fps
    assert back["representation"] == "lie" and back["n_samples"] == 8 and set(back["notes"]) == set(files)
    with pytest.raises(ValueError, match=r"warp: expected one of"):
        mean_motion(files, n_samples=8, warp="fast")


@pytest.mark.mocap
def test_mean_of_two_real_walks(mocap_dir: Path) -> None:
    files = [mocap_dir / "cmu" / "bvh" / f for f in ("07_01.bvh", "08_02.bvh")]
    res = mean_motion(files, n_samples=24, warp=WarpOptions(method="dp", neighbourhood=4), max_iter=5)
    assert res.motion.n_joints == 25 and (np.diff(res.energies) <= 1e-9 * res.energies[0]).all()
    assert 2.0 < res.duration < 3.0


def test_reparametrize_helper_consistency() -> None:
    # the curves used above are reparametrisations of one curve: sanity check of the fixture
    c = _r3_curve()
    phi = np.linspace(0, 1, 41) ** 1.5
    assert reparametrize_curve(c, phi).n_points == 41


# --------------------------------------------------------------------------------------------
# Re-centred warps and PCA (issue 15)
# --------------------------------------------------------------------------------------------


def test_recentred_warps_average_to_the_identity() -> None:
    from elastic_motion.apps.statistics import mean_warp, recenter_warps

    ws = [
        np.array([[0, 0], [0.3, 0.5], [1, 1.0]]),
        np.array([[0, 0], [0.6, 0.4], [0.8, 0.9], [1, 1.0]]),
        np.array([[0, 0], [1, 1.0]]),
    ]
    w = [0.5, 0.3, 0.2]
    x = np.linspace(0, 1, 1001)
    g = mean_warp(ws, w)
    # independent: the average of the interpolated functions
    np.testing.assert_allclose(
        np.interp(x, g[:, 0], g[:, 1]),
        sum(a * np.interp(x, v[:, 0], v[:, 1]) for a, v in zip(w, ws, strict=True)),
    )
    r = recenter_warps(ws, w)
    avg = sum(a * np.interp(x, v[:, 0], v[:, 1]) for a, v in zip(w, r, strict=True))
    np.testing.assert_allclose(avg, x, atol=1e-14)


def test_karcher_mean_recentred_keeps_the_energy_and_centres_the_warps() -> None:
    c = _r3_curve()
    curves = [reparametrize_curve(c, np.linspace(0, 1, 41) ** p) for p in (0.7, 1.0, 1.4)]
    warp = WarpOptions(method="dp", neighbourhood=4)
    plain = karcher_mean(curves, n_samples=40, warp=warp, max_iter=4)
    cent = karcher_mean(curves, n_samples=40, warp=warp, max_iter=4, recenter=True)
    x = np.linspace(0, 1, 501)
    avg = np.mean([np.interp(x, v[:, 0], v[:, 1]) for v in cent.warps], axis=0)
    assert np.abs(avg - x).max() < 1e-12
    # the plain mean's warps are not centred (the first iterate's timing)
    avg0 = np.mean([np.interp(x, v[:, 0], v[:, 1]) for v in plain.warps], axis=0)
    assert np.abs(avg0 - x).max() > 1e-3
    np.testing.assert_array_equal(cent.energies, plain.energies)


def test_pca_reproduces_its_inputs_and_the_covariance(tmp_path: Path) -> None:
    """warp='none': the PCA of the SRV arrays themselves, checked against numpy's covariance."""
    from elastic_motion.apps.database import DatabaseSettings, build_srv_cache
    from elastic_motion.apps.pca import motion_pca

    files = [str(write_bvh(_walk(v), tmp_path / f"w{v}.bvh")) for v in range(4)]
    model = motion_pca(files, n_samples=12, warp="none")
    # a statistical model prepares its motions as a mean does: without the database's low-pass
    unfiltered = WarpOptions(method="dp", sample_smoothing=0.0)
    q = build_srv_cache(files, DatabaseSettings(n_samples=12, representations=("lie",), warp=unfiltered)).q[
        "lie"
    ]
    q = np.stack([q[[Path(f).stem for f in files].index(Path(p).stem)] for p in files])
    n = q.shape[1]
    np.testing.assert_allclose(model.mean_srv, q.mean(axis=0), atol=1e-12)
    flat = q.reshape(len(files), -1) / np.sqrt(n)
    eig = np.sort(np.linalg.eigvalsh(np.cov(flat, rowvar=False)))[::-1][: model.n_modes]
    np.testing.assert_allclose(model.sigmas**2, eig, rtol=1e-8)
    assert model.explained.sum() == pytest.approx(1.0) and model.n_modes == 3
    for k in range(len(files)):  # every input is a point of the model
        np.testing.assert_allclose(model.srv_at(model.scores[k] / model.sigmas), q[k], atol=1e-10)
    json.dumps(model.summary(), allow_nan=False)


def test_pca_writes_modes_as_bvh(tmp_path: Path) -> None:
    from elastic_motion.apps.pca import motion_pca, write_modes

    files = [str(write_bvh(_walk(v), tmp_path / f"w{v}.bvh")) for v in range(3)]
    model = motion_pca(files, n_samples=16, warp=WarpOptions(method="dp", neighbourhood=4))
    x = np.linspace(0, 1, 301)
    avg = np.mean([np.interp(x, v[:, 0], v[:, 1]) for v in model.warps], axis=0)
    assert np.abs(avg - x).max() < 1e-12  # re-centred
    paths = write_modes(model, tmp_path / "modes", n_modes=1)
    assert [p.name for p in paths] == ["mean.bvh", "mode1_minus2sd.bvh", "mode1_plus2sd.bvh"]
    mean = read_bvh(paths[0])
    assert mean.n_joints == 3 and mean.fps == pytest.approx(30.0)
    # mean +- 2 sd differ from the mean, in opposite directions along mode 1
    lo, hi = read_bvh(paths[1]), read_bvh(paths[2])
    d_lo, d_hi = lo.rotations - mean.rotations, hi.rotations - mean.rotations
    assert np.abs(d_lo).max() > 1e-3 and np.sum(d_lo * d_hi) < 0
    samples = model.sample(2, seed=1)
    assert samples[0].n_frames == mean.n_frames
    with pytest.raises(ValueError, match="at least two"):
        motion_pca(files[:1])
