"""The Python faces of the database commands (``matrix``, ``classify``, ``mean``, ``cluster``):
the same numbers as the command line; their options objects and records."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from database_testlib import write_clips

from elastic_motion.apps.database import (
    Classification,
    Clustering,
    DatabaseSettings,
    MatrixOptions,
    MeanOptions,
    classify_motions,
    cluster_motions,
    compute_matrix,
    load_matrix,
    mean_motion,
)
from elastic_motion.apps.database.classify import labels_of
from elastic_motion.cli import main
from elastic_motion.errors import OptionError
from elastic_motion.motion import write_bvh
from elastic_motion.motion.representations import EULER, LIE
from elastic_motion.warp import WarpOptions

#: Report fields that hold times or the machine (they differ from run to run).
VOLATILE = {"created", "started", "host", "seconds", "timings", "pairs_per_second"}


def _stable(obj):
    if isinstance(obj, dict):
        return {k: _stable(v) for k, v in obj.items() if k not in VOLATILE and not k.startswith("seconds")}
    if isinstance(obj, list):
        return [_stable(v) for v in obj]
    return obj


@pytest.fixture(scope="module")
def clips(tmp_path_factory) -> Path:
    """6 clips: 2 kinds x 3 variants of one skeleton."""
    d = tmp_path_factory.mktemp("clips")
    write_clips(d, kinds=(0, 1), variants=3, frames=24, step=4)
    return d


FLAGS = ["--samples", "10", "--neighbourhood", "4", "--tile-size", "4"]
SETTINGS = DatabaseSettings(n_samples=10, tile_size=4, warp=WarpOptions(method="dp", neighbourhood=4))


def _cli_json(argv: list[str], capsys) -> dict:
    assert main([*argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


@pytest.fixture(scope="module")
def runs(clips: Path, tmp_path_factory) -> tuple[Path, Path, dict]:
    """The same matrix by the command line and by compute_matrix; the CLI's report."""
    base = tmp_path_factory.mktemp("runs")
    cli_out, api_out = base / "cli", base / "api"
    assert (
        main(["matrix", str(clips), "-o", str(cli_out), *FLAGS, "--quiet", "--json", str(base / "r.json")])
        == 0
    )
    res = compute_matrix([clips], api_out, SETTINGS)
    assert res.complete
    return cli_out, api_out, json.loads((base / "r.json").read_text())


def test_compute_matrix_is_the_matrix_command(runs) -> None:
    cli_out, api_out, report = runs
    for key in ("lie", "euler"):
        a = np.load(cli_out / f"distances_{key}.npy")
        b = np.load(api_out / f"distances_{key}.npy")
        assert a.tobytes() == b.tobytes()
    assert (cli_out / "names.csv").read_bytes() == (api_out / "names.csv").read_bytes()
    api = json.loads((api_out / "report.json").read_text())
    assert _stable({k: v for k, v in report.items() if k in api}) == _stable(api)


def test_matrix_summary_is_the_report(runs, clips: Path) -> None:
    _, api_out, _ = runs
    res = compute_matrix([clips], api_out, SETTINGS)  # resumed: every tile on disk
    assert res.summary() == json.loads((api_out / "report.json").read_text())
    assert res.summary()["runs"][-1]["tiles_computed"] == 0


def test_classify_motions_is_the_classify_command(runs, tmp_path: Path, capsys) -> None:
    cli_out, _, _ = runs
    labels = tmp_path / "labels.csv"
    labels.write_text("".join(f"k{k}_v{v},kind{k}\n" for k in (0, 1) for v in range(3)))
    for k in (1, 3):
        report = _cli_json(["classify", str(cli_out), "--labels", str(labels), "-k", str(k)], capsys)
        for rep in (LIE, EULER):
            res = classify_motions(cli_out, labels, k=k, method=rep.name)
            assert isinstance(res, Classification) and res.representation == rep.key
            assert report["results"][rep.key] == res.summary() and res.evaluation.k == k
    # the same labels as a mapping, a sequence, and the matrix read back
    m = load_matrix(cli_out, "euler")
    by_name = {n: "kind" + n[1] for n in m.names}
    a = classify_motions(m, by_name, k=3)
    b = classify_motions(cli_out, [by_name[n] for n in m.names], k=3, method="euler")
    assert a.summary() == b.summary() == classify_motions(cli_out, labels, k=3, method="euler").summary()
    assert a.predictions == dict(zip(m.names, a.evaluation.predictions, strict=True))


def test_classify_refuses_what_it_cannot_classify(runs) -> None:
    cli_out, _, _ = runs
    with pytest.raises(OptionError, match=r"^labels: cmu: expected labels for at least 2 motions"):
        classify_motions(cli_out, "cmu")
    with pytest.raises(OptionError, match="labels: expected a CSV file"):
        classify_motions(cli_out, "nowhere.csv")
    with pytest.raises(OptionError, match="labels: expected 6 labels"):
        classify_motions(cli_out, ["a", "b"])
    with pytest.raises(OptionError, match="method: expected the matrix's representation 'lie'"):
        classify_motions(load_matrix(cli_out, "lie"), ["a", "b"] * 3, method="euler")
    assert labels_of(["x", "y"], {"x": "walk"}) == ["walk", None]


def test_cluster_motions_is_the_cluster_command(runs, tmp_path: Path, capsys) -> None:
    cli_out, _, _ = runs
    for method, linkage in (("lie", "average"), ("euler-elastic", "complete")):
        argv = ["cluster", str(cli_out), "--method", method, "--linkage", linkage, "--clusters", "2"]
        report = _cli_json(argv, capsys)
        res = cluster_motions(cli_out, method=method, linkage=linkage, n_clusters=2)
        assert isinstance(res, Clustering) and report_body(report) == res.summary()
        assert res.clusters == report["clusters"] and set(res.clusters.values()) == {1, 2}
    # the plot: leaves coloured by labels, "?" where a motion has none
    res = cluster_motions(cli_out, labels={"k0_v0": "a"})
    assert res.leaf_labels == ["a"] + ["?"] * 5 and res.clusters is None
    png = res.plot(tmp_path / "d.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "clusters" not in res.summary()
    with pytest.raises(OptionError, match="method"):
        cluster_motions(cli_out, linkage="ward")  # type: ignore[arg-type]


def report_body(report: dict) -> dict:
    """The fields of a command's report after the shared header."""
    return {
        k: v for k, v in report.items() if k in ("linkage_method", "representation", "linkage", "clusters")
    }


def test_mean_motion_is_the_mean_command(clips: Path, tmp_path: Path, capsys) -> None:
    files = [str(clips / f"k0_v{v}.bvh") for v in range(3)]
    out = tmp_path / "mean.bvh"
    argv = ["mean", *files, "-o", str(out), "--samples", "10", "--neighbourhood", "4", "--method", "euler"]
    report = _cli_json([*argv, "--max-iter", "3", "--quiet"], capsys)
    res = mean_motion(
        files, n_samples=10, method="euler", warp=WarpOptions(method="dp", neighbourhood=4), max_iter=3
    )
    summary = res.summary()
    assert {k: report[k] for k in summary} == summary and summary["method"] == "euler-elastic"
    assert write_bvh(res.motion, tmp_path / "api.bvh").read_bytes() == out.read_bytes()
    # one options object, the same numbers
    opts = MeanOptions(
        n_samples=10, method="euler-elastic", warp=WarpOptions(method="dp", neighbourhood=4), max_iter=3
    )
    assert mean_motion(files, opts).summary() == summary


def test_mean_options_validate_and_round_trip() -> None:
    opts = MeanOptions(method="euler", joints=["Hips", "Spine"], warp="none", fps=24)
    assert opts.method == "euler-elastic" and opts.joints == ("Hips", "Spine")
    assert opts.warp == WarpOptions(method="none")
    back = MeanOptions.from_json(json.loads(json.dumps(opts.to_json())))
    assert back == opts and opts.replace(max_iter=3).max_iter == 3
    assert MeanOptions().warp == WarpOptions(method="dp")  # the database's warp
    for field, value in (
        ("n_samples", 1),
        ("method", "quaternion"),
        ("joints", "some"),
        ("warp", 3),
        ("max_iter", -1),
        ("tol", float("nan")),
        ("fps", 0.0),
    ):
        with pytest.raises(OptionError, match=f"^{field}: expected"):
            MeanOptions(**{field: value})
    with pytest.raises(OptionError, match=r"unknown option \['samples'\] of MeanOptions"):
        mean_motion(["a.bvh"], samples=3)
    with pytest.raises(OptionError, match="mean options: unknown fields"):
        MeanOptions.from_json({"bogus": 1})
    with pytest.raises(dataclasses.FrozenInstanceError):
        opts.tol = 1.0  # type: ignore[misc]


def test_matrix_options_and_overrides(clips: Path, tmp_path: Path) -> None:
    with pytest.raises(OptionError, match=r"^engine: expected one of \['serial', 'local', 'dask'\]"):
        MatrixOptions(engine="threads")  # type: ignore[arg-type]
    with pytest.raises(OptionError, match=r"unknown option \['workers'\] of MatrixOptions"):
        compute_matrix([clips], tmp_path / "o", SETTINGS, workers=2)
    with pytest.raises(OptionError, match=r"^workers: expected 1 to 1024"):
        compute_matrix([clips], tmp_path / "o", SETTINGS, MatrixOptions(engine="local", n_workers=0))
    assert not (tmp_path / "o").exists()


def test_settings_take_representations_by_name_key_or_object() -> None:
    assert DatabaseSettings(representations=(EULER, "lie")).representations == ("euler", "lie")
    assert DatabaseSettings(representations="euler-elastic").representations == ("euler",)
    with pytest.raises(OptionError, match="representations: expected distinct entries"):
        DatabaseSettings(representations=(LIE, "lie"))
    with pytest.raises(OptionError, match="representations: expected distinct entries"):
        DatabaseSettings(representations=("quaternion",))


def test_cli_choices_are_the_api_types() -> None:
    """``--method``, ``--linkage`` and ``--engine`` list what the Python types accept."""
    from elastic_motion._options import choices
    from elastic_motion.apps.database.engines import EngineName
    from elastic_motion.apps.statistics import Linkage
    from elastic_motion.cli_commands import database, distance
    from elastic_motion.cli_commands._argparse import CliParser
    from elastic_motion.motion.representations import Method

    parser = CliParser(prog="elastic-motion")
    sub = parser.add_subparsers(dest="command")
    database.register(sub)
    distance.register(sub)

    def action(command: str, flag: str):
        p = sub.choices[command]
        return next(a for a in p._actions if flag in a.option_strings)

    assert tuple(action("cluster", "--linkage").choices) == choices(Linkage)
    assert tuple(action("matrix", "--engine").choices) == choices(EngineName)
    assert tuple(action("distance", "--method").choices) == choices(Method)
    assert action("mean", "--method").metavar == "{" + ",".join(choices(Method)) + "}"
    assert action("matrix", "--method").metavar == "{" + ",".join(choices(Method)) + "}[,...]"
