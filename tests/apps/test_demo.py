"""The demo: the README's first command, on the data pybullet ships (skipped without pybullet)."""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import pytest

from elastic_motion.apps.demo import DemoDataError, demo_data_dir, run_demo
from elastic_motion.cli import main
from elastic_motion.motion import read_bvh

pytest.importorskip("pybullet_data")


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo") / "elastic-motion-demo"
    code = main(["demo", "-o", str(out), "--no-mp4", "-q"])
    assert code == 0
    return out


def test_demo_folder(demo, capsys):
    index = demo / "index.html"
    text = index.read_text()
    # every picture, video and file the page points to exists
    targets = re.findall(r'(?:src|href)="([^"]+)"', text) + re.findall(r"href='([^']+)'", text)
    assert len(targets) >= 12
    for t in targets:
        assert (demo / t).is_file(), t
    for sub, n in (("blends", 8), ("loops", 6), ("figures", 5), ("videos", 4)):
        assert len(list((demo / sub).iterdir())) >= n, sub
    rep = json.loads((demo / "report.json").read_text())
    assert rep["command"] == "demo"
    assert len(rep["blends"]) == 6 and len(rep["loops"]) == 2
    assert len(rep["distances"]["distances"]) == 9
    for loop in rep["loops"]:
        assert (
            loop["seam_after"]["seam_position_max_m"]
            < 0.1 * loop["seam_before"]["seam_position_max_m"] + 1e-6
        )
    m = read_bvh(demo / "blends" / "walk_run_lie_warp.bvh")
    assert m.n_joints == 13 and m.n_frames > 30
    assert rep["timings"]["total_s"] < 180


def test_demo_prints_where_it_is(tmp_path, capsys):
    code = main(["demo", "-o", str(tmp_path / "d"), "--no-video", "-q"])
    out = capsys.readouterr().out
    assert code == 0
    assert f"open {(tmp_path / 'd' / 'index.html').resolve()}" in out


def test_demo_refuses_a_foreign_folder(tmp_path, capsys):
    (tmp_path / "mine.txt").write_text("keep me")
    code = main(["demo", "-o", str(tmp_path), "--no-video", "-q"])
    assert code == 2
    assert "not empty and was not written by the demo" in capsys.readouterr().err
    assert (tmp_path / "mine.txt").read_text() == "keep me"


def test_demo_without_pybullet_explains(monkeypatch):
    monkeypatch.setitem(sys.modules, "pybullet_data", None)
    with pytest.raises(DemoDataError, match=r'pip install "elastic-motion\[demo\]"'):
        demo_data_dir()
    with pytest.raises(DemoDataError):
        run_demo(Path("never-written"))
    assert not Path("never-written").exists()
