"""The demo: the README's first command, on the data pybullet ships (skipped without pybullet)."""

from __future__ import annotations

import json
import sys
from html.parser import HTMLParser
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


class _Page(HTMLParser):
    """The links, image sources and legend elements of a page."""

    def __init__(self) -> None:
        super().__init__()
        self.links: list[str] = []
        self.sources: list[str] = []
        self.legends = 0
        self.swatch_colours: set[str] = set()

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "a" and "href" in a:
            self.links.append(a["href"])
        if tag == "img" and "src" in a:
            self.sources.append(a["src"])
        classes = (a.get("class") or "").split()
        self.legends += "legend" in classes
        if "swatch" in classes:
            self.swatch_colours.add(a.get("title", "").lower())


def _page(demo: Path) -> _Page:
    page = _Page()
    page.feed((demo / "index.html").read_text(encoding="utf-8"))
    return page


def test_demo_folder(demo, capsys):
    page = _page(demo)
    # every picture, video and file the page points to exists (in-page anchors aside)
    targets = page.sources + [t for t in page.links if not t.startswith("#")]
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
    assert m.n_joints == 15 and m.n_frames > 30  # the DeepMimic humanoid with its fixed wrists
    assert rep["timings"]["total_s"] < 180


def test_demo_page_links_every_bvh_and_has_a_legend(demo):
    from elastic_motion.apps.palette import LEFT, RIGHT

    page = _page(demo)
    bvh = sorted(p.relative_to(demo).as_posix() for p in demo.rglob("*.bvh"))
    assert len(bvh) >= 14
    missing = [p for p in bvh if p not in page.links]
    assert not missing, f"BVH files the page does not link: {missing}"
    for link in page.links:  # relative links, so that the folder can be moved or served
        assert "://" not in link and not link.startswith("/"), link
    assert page.legends >= 1
    assert {LEFT, RIGHT} <= page.swatch_colours  # the side colours are explained


def test_demo_videos_play_in_real_time(demo):
    from PIL import Image

    for gif in sorted((demo / "videos").glob("*.gif")):
        img = Image.open(gif)
        total = 0
        for k in range(img.n_frames):
            img.seek(k)
            total += img.info["duration"]
        fps = 20.0 if gif.stem.startswith("loop_") else 30.0  # the demo's frame rates
        # each frame is shown for 1/fps on average (the clock changes in every frame, so no
        # frame is merged with the next)
        assert abs(total - 1000.0 * img.n_frames / fps) <= 5, (gif.name, img.n_frames, total)


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
