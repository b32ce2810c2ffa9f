"""``--up`` and ``--units`` are honoured by ``view``, ``matrix``, ``search``, ``index`` and
``info`` (issue 31; that every command has them: ``tests/test_cli_up_units.py``).

The data: the synthetic walker turned Z-up (a world rotation, as Blender's import turns it),
twice with different headings (the same walk, so aligned in
heading its distance is about 0), and a walk of another gait. Read Z-up, the heading
alignment turns about the real up axis and the two headings meet; read Y-up (a wrong
``--up y``), the body lies on the floor, its "heading" is a tilt and they stay apart.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from blend_testlib import walker

from elastic_motion.cli import main
from elastic_motion.motion import Motion, set_up_axis, write_bvh


def _z_up(m: Motion) -> Motion:
    """``m`` turned Z-up by a world rotation (Blender's import, ``(x, y, z) -> (x, -z, y)``)."""
    return set_up_axis(m, "z")


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("zup")
    a = write_bvh(_z_up(walker(duration=2.0, yaw=0.0, name="a")), d / "a.bvh")
    b = write_bvh(_z_up(walker(duration=2.0, yaw=1.2, name="b")), d / "b.bvh")
    c = write_bvh(_z_up(walker(duration=2.0, amp=0.2, freq=1.6, name="c")), d / "c.bvh")
    return d, a, b, c


def _json(capsys, argv):
    quiet = [] if argv[0] == "view" else ["-q"]
    assert main([*argv, "--json", *quiet]) == 0, capsys.readouterr().err
    return json.loads(capsys.readouterr().out)


def _matrix(capsys, out, inputs, *flags):
    argv = ["matrix", *map(str, inputs), "-o", str(out), "--method", "lie", "--engine", "serial", *flags]
    rep = _json(capsys, argv)
    return np.load(out / "distances_lie.npy"), rep


def test_matrix_reads_with_up_and_units(files, capsys, tmp_path):
    _, a, b, c = files
    right, rep = _matrix(capsys, tmp_path / "z", [a, b, c], "--up", "z")
    wrong, _ = _matrix(capsys, tmp_path / "y", [a, b, c], "--up", "y")
    cm, _ = _matrix(capsys, tmp_path / "cm", [a, b, c], "--up", "z", "--units", "cm")
    assert right[0, 1] < 1e-3 * wrong[0, 1], (right[0, 1], wrong[0, 1])  # one walk, two headings
    # the Lie metric weighs the root's path by the body's size: the same numbers in any unit,
    # but the matrix records the unit it read (what `view` shows of it: below)
    np.testing.assert_allclose(cm, right, rtol=1e-9, atol=1e-12)
    assert rep["settings"]["up"] == "z" and "units" not in rep["settings"]  # recorded with the matrix
    assert json.loads((tmp_path / "cm" / "report.json").read_text())["settings"]["units"] == "cm"
    manifest = json.loads((tmp_path / "z" / "manifest.json").read_text())
    assert manifest["identity"]["settings"]["up"] == "z"


def test_search_and_index_read_with_up_and_units(files, capsys, tmp_path):
    _, a, b, c = files
    right = _json(capsys, ["search", str(a), str(b), str(c), "-k", "2", "--up", "z", "--method", "lie"])
    wrong = _json(capsys, ["search", str(a), str(b), str(c), "-k", "2", "--up", "y", "--method", "lie"])
    near = {r["name"]: r["distance"] for r in right["results"]}
    far = {r["name"]: r["distance"] for r in wrong["results"]}
    assert right["results"][0]["name"] == "b" and near["b"] < 1e-3 * far["b"], (near, far)
    # an index records how it read its files; a search naming another reading is refused
    idx = tmp_path / "idx"
    built = _json(capsys, ["index", str(b), str(c), "-o", str(idx), "--up", "z", "--method", "lie"])
    assert built["settings"]["up"] == "z"
    found = _json(capsys, ["search", str(a), str(idx), "-k", "1", "--method", "lie"])
    assert found["results"][0]["name"] == "b" and found["results"][0]["distance"] == pytest.approx(near["b"])
    assert main(["search", str(a), str(idx), "--up", "y", "-q"]) == 2
    err = capsys.readouterr().err
    assert "--up: expected z" in err and "built with --up z" in err
    assert main(["search", str(a), str(idx), "--units", "cm", "-q"]) == 2
    assert "--units" in capsys.readouterr().err
    assert _json(capsys, ["search", str(a), str(idx), "-k", "1", "--up", "z", "--method", "lie"])["results"]


def test_view_and_info_read_with_up(files, capsys, tmp_path):
    from elastic_motion.apps.viewer.clips import load_clip

    _, a, _, _ = files
    upright, _ = load_clip(str(a), None, up="z")
    lying, _ = load_clip(str(a), None, up="y")
    assert np.ptp(upright.root_translation[:, 1]) < 0.01  # Y-up: the hips at one height
    assert np.ptp(lying.root_translation[:, 1]) > 1.5  # read y-up: "height" is the 2 m walked
    small, _ = load_clip(str(a), None, up="z", units="cm")  # our metres read as centimetres
    np.testing.assert_allclose(small.root_translation, upright.root_translation / 100, atol=1e-12)
    pages = {}
    for up in ("z", "y"):
        out = tmp_path / f"{up}.html"
        rep = _json(capsys, ["view", str(a), "-o", str(out), "--up", up])
        assert rep["clips"][0]["frames"] == 61
        pages[up] = out.read_text()
    auto = tmp_path / "auto.html"
    _json(capsys, ["view", str(a), "-o", str(auto)])
    assert pages["z"] != pages["y"] and auto.read_text() == pages["z"]  # detected z: the same page
    assert main(["info", str(a), "--up", "y"]) == 0 and "up axis:    y" in capsys.readouterr().out
    assert main(["info", str(a)]) == 0 and "up axis:    z" in capsys.readouterr().out
