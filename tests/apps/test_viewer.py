"""The 3D viewer: its data (reports matched to motions, decimation, bad input) and, in a real
headless Chromium (skipped when absent), the page: no console errors, the skeleton drawn, the
slider moves the pose."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest

pytest.importorskip("plotly")

from elastic_motion.apps.viewer import build_viewer, find_report
from elastic_motion.apps.viewer.browser import Browser, find_chromium
from elastic_motion.cli import main
from elastic_motion.motion import drop_tpose, forward_kinematics, read_motion, write_bvh

CHROMIUM = find_chromium()


@pytest.fixture(scope="module")
def loop_files(tmp_path_factory, mocap_dir):
    """A looped DeepMimic cartwheel written by the CLI with its report (contacts, seam)."""
    tmp = tmp_path_factory.mktemp("viewer")
    src = mocap_dir / "deepmimic/humanoid3d_cartwheel.txt"
    out = tmp / "cart_loop.bvh"
    assert (
        main(
            ["loop", str(src), "-o", str(out), "--repeat", "2", "--json", str(tmp / "cart_loop.json"), "-q"]
            + ["--window", "whole", "--force"]  # the whole clip, as the viewer shows it
        )
        == 0
    )
    return tmp, out, tmp / "cart_loop.repeat2.bvh", json.loads((tmp / "cart_loop.json").read_text())


def _spec(page):
    """The data of the page's first viewer."""
    html = page.fragment
    start = html.index("type='application/json'")
    start = html.index(">", start) + 1
    return json.loads(html[start : html.index("</script>", start)].replace("<\\/", "</"))


def test_report_found_beside_and_matched(loop_files):
    _, loop, preview, rep = loop_files
    hit = find_report(loop)
    assert hit is not None and hit[0].name == "cart_loop.json"
    page = build_viewer([loop, preview], plotly_src="plotly.min.js")
    c0, c1 = page.clips
    assert c0.report and c0.seams and c1.report
    fps = rep["fps"]
    # one seam per cycle: the loop's end, and each cycle's end in the 2-cycle preview
    assert np.allclose(c0.seams, [(rep["frames"] - 1) / fps])
    assert np.allclose(c1.seams, [(rep["frames"] - 1) / fps, 2 * (rep["frames"] - 1) / fps])
    spec = _spec(page)
    con = rep.get("contacts")
    if con and con["joints"]:
        assert c0.contacts and c1.contacts
        j, runs = next(iter(con["joints"].items()))
        assert spec["clips"][0]["contacts"]["intervals"][j] == [list(r) for r in runs["frames"]]
        # the preview repeats each contact one cycle later
        period = rep["frames"] - 1
        shifted = [[a + period, b + period] for a, b in runs["frames"]]
        assert all(r in spec["clips"][1]["contacts"]["intervals"][j] for r in shifted)


def test_report_that_does_not_match_is_ignored_with_a_note(loop_files, tmp_path):
    _, loop, _, rep = loop_files
    bad = dict(rep, frames=rep["frames"] + 7)
    page = build_viewer([loop], reports=[bad], plotly_src="x.js")
    assert page.clips[0].report is None and not page.clips[0].seams and not page.clips[0].contacts
    assert any("does not match" in n and f"{rep['frames'] + 7} frames" in n for n in page.notes)
    assert "does not match" in page.html  # said on the page
    wrong_joint = dict(rep, contacts={"joints": {"NoSuchJoint": {"frames": [[0, 5]]}}})
    page = build_viewer([loop], reports=[wrong_joint], plotly_src="x.js")
    assert page.clips[0].report is not None and not page.clips[0].contacts
    assert any("NoSuchJoint" in n for n in page.notes)


def test_viewer_options_and_the_contact_vocabulary(loop_files):
    """One ViewerOptions or its fields as keywords; contacts speak the contact policy's words
    ("off"), with the viewer's old "none" accepted."""
    from elastic_motion.apps.viewer import CONTACT_MARKS, ViewerOptions
    from elastic_motion.errors import OptionError

    _, loop, _, rep = loop_files
    assert CONTACT_MARKS == ("report", "detect", "off")
    assert ViewerOptions(contacts="none").contacts == "off"
    for bad, option in (
        (dict(contacts="maybe"), "contacts"),
        (dict(layout="stacked"), "layout"),
        (dict(max_frames=1), "max_frames"),
        (dict(max_fps=0), "max_fps"),
    ):
        with pytest.raises(OptionError, match=f"^{option}: expected"):
            ViewerOptions(**bad)
    with pytest.raises(OptionError, match="unknown option"):
        build_viewer([loop], colour="red")
    opts = ViewerOptions(plotly_src="x.js", title="t", element_id="v1")
    assert (
        build_viewer([loop], opts).html
        == build_viewer([loop], plotly_src="x.js", title="t", element_id="v1").html
    )
    marked = build_viewer([loop], opts)
    assert marked.clips[0].contacts == bool(rep.get("contacts") and rep["contacts"]["joints"])
    for word in ("off", "none"):
        page = build_viewer([loop], opts, contacts=word)
        assert not page.clips[0].contacts and _spec(page)["clips"][0]["contacts"] is None
        assert page.clips[0].seams == marked.clips[0].seams  # only the contacts are left out


def test_blend_warp_timing(tmp_path, mocap_dir):
    """The warp plot's times: the blend's own clock rebuilt from its report (blend step 4)."""
    from elastic_motion.apps.blend import blend_motions

    a = str(mocap_dir / "deepmimic/humanoid3d_walk.txt")
    b = str(mocap_dir / "deepmimic/humanoid3d_run.txt")
    res = blend_motions([a, b], 0.3, warp="dp", metrics=False)
    path = write_bvh(res.motion, tmp_path / "blend.bvh")
    rep = json.loads(json.dumps(res.summary()))
    page = build_viewer([path], reports=[rep], plotly_src="x.js", max_fps=1000)
    assert page.clips[0].warp
    warp = _spec(page)["clips"][0]["warp"]
    d = [(p["frames_kept"] - 1) / p["fps"] for p in rep["preparation"]]
    for k, v in enumerate(res.warps):  # input k's time at each frame = d_k phi_k(u(frame))
        expect = d[k] * np.interp(res.timing, v[:, 0], v[:, 1])
        assert np.allclose(warp["curves"][k], expect, atol=2e-5), k


def test_long_clip_is_decimated_and_said(mocap_dir):
    from elastic_motion.motion.looping import repeat_motion

    m = drop_tpose(read_motion(mocap_dir / "cmu/bvh/07_01.bvh"))
    long = repeat_motion(m, 33)
    assert long.n_frames >= 10_000 and long.n_joints == 31
    page = build_viewer([long], plotly_src="x.js")
    c = page.clips[0]
    assert c.shown_frames <= 2000 and c.step == -(-long.n_frames // 2000)
    assert any("shown 1 frame in" in n for n in page.notes) and "shown 1 frame in" in page.html
    assert len(page.html) < 12_000_000
    # the drawn points are the file's joints (plotly axes: x, -z, y), metres
    spec = _spec(page)
    import base64

    pts = np.frombuffer(base64.b64decode(spec["clips"][0]["pos"]), dtype=np.float32).reshape(
        c.shown_frames, -1, 3
    )
    p = forward_kinematics(long, end_sites=True)[:: c.step] * long.metres_per_unit
    assert np.allclose(pts[..., 0], p[..., 0], atol=1e-4) and np.allclose(pts[..., 1], -p[..., 2], atol=1e-4)
    assert np.allclose(pts[..., 2], p[..., 1], atol=1e-4)


def test_the_following_cameras_window_holds_every_joint(mocap_dir):
    """The page's following camera centres a window on the roots with ``camera.reach`` around
    each (plotly clips what is outside): every joint of every frame is within reach of its
    clip's root, and between the window's heights; the window is not the whole path."""
    import base64

    files = [mocap_dir / "cmu/bvh/08_02.bvh", mocap_dir / "deepmimic/humanoid3d_cartwheel.txt"]
    spec = _spec(build_viewer(files, plotly_src="x.js", reports=[False, False]))
    cam = spec["camera"]
    assert cam["axis"] in (0, 1) and len(cam["reach"]) == 2
    for c in spec["clips"]:
        p = np.frombuffer(base64.b64decode(c["pos"]), dtype=np.float32).reshape(c["n"], c["P"], 3)
        assert (np.abs(p[:, :, :2] - p[:, :1, :2]) <= np.array(cam["reach"]) - 0.05).all()
        assert cam["z"][0] < p[..., 2].min() and p[..., 2].max() < cam["z"][1]
    assert cam["z"][0] < spec["floor"]
    side = spec["ranges"]["side"]
    travelled = max(side[0][1] - side[0][0], side[1][1] - side[1][0])
    assert 2 * max(cam["reach"]) < travelled / 2  # a window around the figures, not the path


def test_view_refuses_an_unreadable_file(tmp_path, capsys):
    bad = tmp_path / "broken.bvh"
    bad.write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0\n")
    out = tmp_path / "view.html"
    assert main(["view", str(bad), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "broken.bvh" in err and "Traceback" not in err
    assert not out.exists()  # no page written


# ------------------------------------------------------------------------------------------
# In a real browser
# ------------------------------------------------------------------------------------------

pytestmark_browser = pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed")


def _colour_pixels(png: bytes, hex_colour: str, box=None) -> int:
    import io

    from PIL import Image

    img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
    if box is not None:
        x, y, w, h = (int(v) for v in box)
        img = img[y : y + h, x : x + w]
    rgb = np.array([int(hex_colour[i : i + 2], 16) for i in (1, 3, 5)])
    return int((np.abs(img - rgb).sum(axis=-1) < 40).sum())


@pytestmark_browser
def test_page_in_chromium(loop_files, tmp_path):
    from elastic_motion.apps.palette import LEFT, RIGHT

    _, loop, preview, _ = loop_files
    out = tmp_path / "view.html"
    assert main(["view", str(loop), str(preview), "-o", str(out)]) == 0
    with Browser(1200, 1000) as b:
        b.open("about:blank")
        blank = b.screenshot()
        b.open(out)
        b.wait_for("window.emViewers && window.emViewers['em-viewer'] && window.emViewers['em-viewer'].ready")
        time.sleep(0.3)
        v = "window.emViewers['em-viewer']"
        box = b.evaluate(
            "(()=>{const r=document.querySelector('.emv-scene').getBoundingClientRect();"
            "return [r.left,r.top,r.width,r.height]})()"
        )
        shot0 = b.screenshot()
        assert shot0 != blank
        # the skeleton: limbs in the side colours inside the 3D scene
        assert _colour_pixels(shot0, LEFT, box) > 50 and _colour_pixels(shot0, RIGHT, box) > 50
        pose0 = b.evaluate(f"{v}.pose(0)")
        # drag the slider's thumb to the middle, as a user does
        r = b.evaluate(
            "(()=>{const r=document.querySelector('.emv-slider').getBoundingClientRect();"
            "return [r.left,r.top,r.width,r.height]})()"
        )
        b.mouse_drag(r[0] + 4, r[1] + r[3] / 2, r[0] + 0.5 * r[2], r[1] + r[3] / 2)
        b.wait_for(f"{v}.frame() > 0")
        time.sleep(0.3)
        frame = b.evaluate(f"{v}.frame()")
        count = b.evaluate(f"{v}.count")
        assert 0.3 * count < frame < 0.7 * count
        pose1 = b.evaluate(f"{v}.pose(0)")
        assert np.abs(np.array(pose1) - np.array(pose0)).max() > 0.05  # metres: the pose changed
        shot1 = b.screenshot()
        assert shot1 != shot0
        # joint paths on demand, overlay on one floor: no errors either
        b.evaluate(f"{v}.showTrajectories(['left_ankle', 'right_ankle']).then(() => 1)")
        b.evaluate(f"{v}.setLayout('overlay').then(() => 1)")
        n_traces = b.evaluate("document.querySelector('#em-viewer .emv-scene').data.length")
        assert n_traces == 1 + 2 * 5 + 2 * 2  # floor, 5 per clip, 2 joint paths per clip
        # the camera showing the whole paths, and back to following the figures
        b.evaluate(f"{v}.setCamera('path').then(() => {v}.setCamera('follow')).then(() => 1)")
        assert b.errors == [], b.errors


@pytestmark_browser
def test_long_clip_stays_responsive_in_chromium(mocap_dir, tmp_path):
    """10,000 frames of 31 joints: the page loads and scrubs (timings printed, not asserted)."""
    from elastic_motion.apps.viewer import write_viewer
    from elastic_motion.motion.looping import repeat_motion

    m = drop_tpose(read_motion(mocap_dir / "cmu/bvh/07_01.bvh"))
    long = repeat_motion(m, 33)
    page = build_viewer([long])
    write_viewer(page, tmp_path / "long.html")
    with Browser(1200, 900) as b:
        t0 = time.perf_counter()
        b.open(tmp_path / "long.html")
        b.wait_for("window.emViewers && window.emViewers['em-viewer'].ready")
        load_s = time.perf_counter() - t0
        ms = b.evaluate(
            "(async()=>{const v=window.emViewers['em-viewer'];const t=performance.now();"
            "for(let i=0;i<50;i++){await v.setFrame(i*37 % v.count);}return (performance.now()-t)/50;})()"
        )
        print(
            f"10,000-frame page: {len(page.html) / 1e6:.1f} MB, ready in {load_s:.1f} s, "
            f"{ms:.1f} ms per frame"
        )
        assert b.errors == [], b.errors
