# ruff: noqa: E501  (the embedded JavaScript keeps its own line lengths)
"""The viewer's first camera and its labels, measured in a real headless Chromium (skipped
when absent): each figure at least a quarter of the page's height, the floor in view under
and around every figure, all side-by-side figures in view, no two labels overlapping.

Measured on the page itself: each figure's joints projected to the screen with plotly's own
camera matrices (as plotly places its 3D annotations; cross-checked against the limb colours
in a screenshot) and each label's DOM rectangle. One Chromium and one page (a viewer per case,
plotly.js loaded once) for the whole module.
"""

from __future__ import annotations

import io
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

plotly = pytest.importorskip("plotly")

from elastic_motion.apps.palette import LEFT, RIGHT  # noqa: E402
from elastic_motion.apps.viewer import build_viewer, write_viewer  # noqa: E402
from elastic_motion.apps.viewer.browser import Browser, find_chromium  # noqa: E402
from elastic_motion.apps.viewer.page import page_html  # noqa: E402

pytestmark = pytest.mark.skipif(find_chromium() is None, reason="chromium is not installed")

WIDTH, HEIGHT = 1200, 900  # the page's viewport, CSS pixels

#: Screen geometry of the viewer ``id`` with ``K`` clips, in viewport pixels: each clip's figure (its joints
#: projected with plotly's camera matrices: bounding box; the floor under it (the corners of
#: its horizontal extent, 10 cm wider, within the scene's ranges, and the point under its lowest
#: joint) projected; whether every joint is inside the ranges,
#: which plotly clips to) and each label's rectangle (an older page without label elements:
#: plotly's 3D text labels, their size estimated from the font).
MEASURE = r"""
((id, K) => {
  const gd = document.querySelector('#' + id + ' .emv-scene'), v = window.emViewers[id];
  const fl = gd._fullLayout, sc = fl.scene._scene, cp = sc.glplot.cameraParams, ds = sc.dataScale;
  const sz = fl._size, dom = fl.scene.domain, box = gd.getBoundingClientRect();
  const mul = (m, x) => { const r = [0, 0, 0, 0]; for (let a = 0; a < 4; a++) for (let b = 0; b < 4; b++) r[b] += m[4 * a + b] * x[a]; return r; };
  const proj = (q) => {
    const p = mul(cp.projection, mul(cp.view, mul(cp.model, [q[0] * ds[0], q[1] * ds[1], q[2] * ds[2], 1])));
    return [box.left + sz.l + dom.x[0] * sz.w + 0.5 * (1 + p[0] / p[3]) * sz.w * (dom.x[1] - dom.x[0]),
            box.top + sz.t + (1 - dom.y[1]) * sz.h + 0.5 * (1 - p[1] / p[3]) * sz.h * (dom.y[1] - dom.y[0])];
  };
  const rng = ['xaxis', 'yaxis', 'zaxis'].map(a => fl.scene[a].range);
  const fz = gd.data[0].z[0];
  const clamp = (c, i) => Math.min(rng[i][1], Math.max(rng[i][0], c));
  const figures = [];
  for (let k = 0; k < K; k++) {
    const pts = v.pose(k), s = pts.map(proj);
    const xs = s.map(p => p[0]), ys = s.map(p => p[1]);
    const foot = pts.reduce((a, b) => (b[2] < a[2] ? b : a));
    const lo = [0, 1].map(a => Math.min(...pts.map(p => p[a])) - 0.1), hi = [0, 1].map(a => Math.max(...pts.map(p => p[a])) + 0.1);
    const around = [[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]], foot]
      .map(q => proj([clamp(q[0], 0), clamp(q[1], 1), fz]));
    const inRanges = pts.every(p => p.every((c, i) => c >= rng[i][0] - 1e-6 && c <= rng[i][1] + 1e-6))
      && fz >= rng[2][0] && fz <= rng[2][1];
    figures.push({ box: [Math.min(...xs), Math.min(...ys), Math.max(...xs), Math.max(...ys)], floor: around, inRanges });
  }
  let labels = Array.from(document.querySelectorAll('#' + id + ' .emv-label')).filter(e => e.offsetParent !== null)
    .map(e => { const r = e.getBoundingClientRect(); return [r.left, r.top, r.right, r.bottom]; });
  if (!document.querySelector('#' + id + ' .emv-label')) {
    labels = gd.data.filter(t => t.mode === 'text' && t.x.length).map(t => {
      const c = proj([t.x[0], t.y[0], t.z[0]]), w = 7.2 * String(t.text[0]).length, h = 16;
      return [c[0] - w / 2, c[1] - h / 2, c[0] + w / 2, c[1] + h / 2];
    });
  }
  return { viewport: [innerWidth, innerHeight], scene: [box.left, box.top, box.right, box.bottom], figures, labels };
})
"""

CASES = {
    "long walk": ["cmu/bvh/08_02.bvh"],  # about 4 m of walking
    "side by side": ["cmu/bvh/07_01.bvh", "cmu/bvh/08_02.bvh", "cmu/bvh/131_02.bvh"],
    "pirouette": ["cmu/bvh/55_01.bvh"],  # a dance with whirls, travelling about 2 m
}


def overlapping_pairs(rects: list[list[float]]) -> list[tuple[int, int]]:
    """Index pairs of rectangles ``[left, top, right, bottom]`` that intersect."""
    return [
        (i, j)
        for i in range(len(rects))
        for j in range(i)
        if rects[i][0] < rects[j][2]
        and rects[j][0] < rects[i][2]
        and rects[i][1] < rects[j][3]
        and rects[j][1] < rects[i][3]
    ]


def geometry_problems(m: dict, n_clips: int) -> list[str]:
    """What is wrong with one measurement of :data:`MEASURE` (empty when all is well)."""
    out = []
    _, page_h = m["viewport"]
    x0, y0, x1, y1 = m["scene"]
    for k, f in enumerate(m["figures"]):
        bx0, by0, bx1, by1 = f["box"]
        if by1 - by0 < page_h / 4:
            out.append(f"figure {k}: {by1 - by0:.0f} px tall, expected >= {page_h / 4:.0f} (1/4 of the page)")
        if not (bx0 >= x0 and bx1 <= x1 and by0 >= y0 and by1 <= y1):
            out.append(f"figure {k}: {f['box']} not inside the scene {m['scene']}")
        if not f["inRanges"]:
            out.append(f"figure {k}: joints or the floor outside the scene's ranges (clipped)")
        for px, py in f["floor"]:
            if not (x0 <= px <= x1 and y0 <= py <= y1):
                out.append(f"figure {k}: the floor under it at ({px:.0f}, {py:.0f}) is off the scene")
                break
    if len(m["labels"]) != n_clips:
        out.append(f"{len(m['labels'])} labels shown, expected {n_clips}")
    for i, j in overlapping_pairs(m["labels"]):
        out.append(f"labels {j} and {i} overlap: {m['labels'][j]} {m['labels'][i]}")
    return out


def limb_pixels_box(png: bytes, scene: list[float]) -> tuple[int, int, int, int]:
    """Bounding box (page pixels) of the left and right limb colours inside the scene."""
    from PIL import Image

    img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
    x0, y0, x1, y1 = (round(v) for v in scene)
    img = img[y0:y1, x0:x1]
    hit = np.zeros(img.shape[:2], bool)
    for colour in (LEFT, RIGHT):
        rgb = np.array([int(colour[i : i + 2], 16) for i in (1, 3, 5)])
        hit |= np.abs(img - rgb).sum(axis=-1) < 40
    ys, xs = np.nonzero(hit)
    return xs.min() + x0, ys.min() + y0, xs.max() + x0, ys.max() + y0


def build_page(mocap_dir: Path, out: Path, builder=build_viewer) -> Path:
    """One page with a viewer per case (ids ``case0``...), loading the installed plotly.js from disk."""
    src = (Path(plotly.__file__).parent / "package_data" / "plotly.min.js").as_uri()
    fragments = [
        builder(
            [mocap_dir / f for f in files],
            plotly_src=src,
            reports=[False] * len(files),
            element_id=f"case{k}",
        )
        for k, files in enumerate(CASES.values())
    ]
    return write_viewer(
        replace(
            fragments[0], html=page_html("cases", "\n".join(f.fragment for f in fragments), plotly_src=src)
        ),
        out / "cases.html",
    )


def measure(b: Browser, vid: str, n_clips: int, frame: int | None = None) -> dict:
    """:data:`MEASURE` of viewer ``vid`` (after going to ``frame``), scrolled into view."""
    v = f"window.emViewers['{vid}']"
    b.evaluate(f"document.getElementById('{vid}').querySelector('.emv-scene').scrollIntoView(); 1")
    if frame is not None:
        b.evaluate(f"{v}.setFrame({frame}).then(() => 1)")
    time.sleep(0.3)  # plotly draws on the next animation frames; the labels are laid out then
    return b.evaluate(f"({MEASURE})('{vid}', {n_clips})")


@pytest.fixture(scope="module")
def measured(tmp_path_factory, mocap_dir):
    """Per case: the measurement at the first frame, its screenshot, and at two later frames."""
    page = build_page(mocap_dir, tmp_path_factory.mktemp("camera"))
    out = {}
    with Browser(WIDTH, HEIGHT) as b:
        b.open(page)
        b.wait_for("window.emViewers && [0, 1, 2].every(k => (window.emViewers['case' + k] || {}).ready)")
        for c, (name, files) in enumerate(CASES.items()):
            first = measure(b, f"case{c}", len(files))
            png = b.screenshot()
            count = b.evaluate(f"window.emViewers['case{c}'].count")
            later = [measure(b, f"case{c}", len(files), frame) for frame in (count // 2, count - 1)]
            out[name] = (first, png, later)
        # the side-by-side clips overlaid on one spot: their labels would all sit together
        b.evaluate(
            "window.emViewers['case1'].setLayout('overlay').then(() => window.emViewers['case1'].setFrame(0))"
        )
        out["overlaid"] = measure(b, "case1", len(CASES["side by side"]))
        assert b.errors == [], b.errors
    return out


@pytest.mark.parametrize("case", list(CASES))
def test_first_camera_fits_the_figures_and_labels_do_not_overlap(measured, case):
    first, _, later = measured[case]
    n = len(CASES[case])
    heights = [round((f["box"][3] - f["box"][1]) / first["viewport"][1], 3) for f in first["figures"]]
    print(f"{case}: figure height / page height {heights}, labels {len(first['labels'])}")
    assert geometry_problems(first, n) == []
    for m in later:  # the camera follows: still in view, floor under them, labels apart
        problems = [p for p in geometry_problems(m, n) if "px tall" not in p]
        assert problems == []


@pytest.mark.parametrize("case", list(CASES))
def test_the_measurement_matches_the_pixels(measured, case):
    """The projected figures are where the limb colours are on the screenshot (a few px of
    line width apart): the measurement above measures what is drawn."""
    first, png, _ = measured[case]
    boxes = np.array([f["box"] for f in first["figures"]])
    projected = np.r_[boxes[:, :2].min(axis=0), boxes[:, 2:].max(axis=0)]
    drawn = np.array(limb_pixels_box(png, first["scene"]))
    # the arms and legs span the figure's width and reach its bottom; the head (in the clip's
    # colour) is above the limbs' top
    assert np.abs(drawn - projected)[[0, 2, 3]].max() < 12, (drawn, projected)
    assert projected[1] - 12 < drawn[1] < projected[3], (drawn, projected)


def test_overlaid_clips_labels_do_not_overlap(measured):
    """Three clips on one spot: the labels are stacked apart; all figures in view."""
    m = measured["overlaid"]
    problems = [p for p in geometry_problems(m, 3) if "px tall" not in p]
    assert problems == []
    heads = [f["box"][1] for f in m["figures"]]
    assert all(lab[3] <= max(heads) + 5 for lab in m["labels"])  # above the heads, not aside


def test_labels_sit_by_their_figures(measured):
    """Side by side, each label is over its own figure (they are not all stacked aside)."""
    first, _, _ = measured["side by side"]
    for f, lab in zip(first["figures"], first["labels"], strict=True):
        centre = (lab[0] + lab[2]) / 2
        assert f["box"][0] - 20 <= centre <= f["box"][2] + 20
        assert lab[3] <= f["box"][1] + 5  # above the head
