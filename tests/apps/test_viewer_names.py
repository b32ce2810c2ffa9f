"""The viewer page with names that mean something to HTML, JavaScript or plotly: joint names,
file names and report labels such as ``<!--<script>``, ``</script>``, ``&amp;``, ``<br>``,
U+2028, or not UTF-8 at all, start the page and show as written (issue 32)."""

from __future__ import annotations

import html
import json
import os
import re

import numpy as np
import pytest

pytest.importorskip("plotly")

from loop_testlib import chain_skeleton

from elastic_motion.apps.viewer import build_viewer, write_viewer
from elastic_motion.apps.viewer.browser import Browser, find_chromium
from elastic_motion.groups import SO3
from elastic_motion.motion import Motion, write_bvh

JOINTS = ("<!--<script>", "</script>", "a<b>c&amp;d<br>e", "x\"y'z&#60;")
STEM = "we<!--<script>ird-->\u2028\u2029&lt;<b>"
F = 40


def _motion() -> Motion:
    k = np.arange(F)
    root = np.stack([0.02 * k, np.full(F, 0.9), np.zeros(F)], 1)
    rv = np.zeros((F, 4, 3))
    rv[:, 1, 0] = 0.5 * np.sin(k / 5)
    rv[:, 2, 0] = 0.3 * np.sin(k / 4)
    return Motion(chain_skeleton(JOINTS), 30.0, root, SO3().exp(rv), metres_per_unit=1.0)


def _report() -> dict:
    """A report that puts the names on the timeline (contacts, a seam) and in the warp plot."""
    return {
        "command": "loop",
        "frames": F,
        "fps": 30.0,
        "contacts": {"joints": {"</script>": {"frames": [[0, 10]]}, "<!--<script>": {"frames": [[5, 20]]}}},
        "warp_vertices": [[[0.0, 0.0], [1.0, 1.0]]],
        "weights": [1.0],
        "preparation": [{"label": "<!--<script> in", "frames_kept": F, "fps": 30.0}],
    }


@pytest.fixture(scope="module")
def weird_file(tmp_path_factory):
    return write_bvh(_motion(), tmp_path_factory.mktemp("names") / f"{STEM}.bvh")


def _scripts(page_html: str) -> list[str]:
    """The content of every ``<script>`` element, cut where the HTML parser ends it (the first
    ``</script``; the test below checks that nothing in it could move that end)."""
    return re.findall(r"<script[^>]*>(.*?)</script", page_html, flags=re.S | re.I)


def test_names_cannot_end_or_change_the_script_elements(weird_file):
    page = build_viewer([weird_file], reports=[_report()], plotly_src="plotly.min.js")
    scripts = _scripts(page.fragment)
    assert len(scripts) == 2  # the data and the code: nothing ended early
    for text in scripts:
        # the HTML parser's script states: no comment opening, no script tag, no line terminator
        assert not re.search(r"<!--|<script|</script|-->", text, flags=re.I), text[:200]
        assert "\u2028" not in text and "\u2029" not in text
    data = json.loads(scripts[0])
    assert data["clips"][0]["names"][:4] == list(JOINTS)  # the data keeps the names exactly
    assert data["clips"][0]["label"] == STEM
    assert data["clips"][0]["warp"]["inputs"] == ["<!--<script> in"]
    # in the markup, the names are text: escaped, and the same once unescaped
    select = re.search(r"<select class='emv-traj'[^>]*>(.*?)</select>", page.fragment).group(1)
    options = re.findall(r"<option value='([^']*)'>([^<]*)</option>", select)
    assert [html.unescape(v) for v, _ in options][:4] == list(JOINTS)
    assert [html.unescape(t) for _, t in options][:4] == list(JOINTS)
    assert html.escape(STEM) in page.fragment


def test_a_file_name_that_is_not_utf8_still_makes_a_page(tmp_path):
    path = tmp_path / os.fsdecode(b"bad\xff\xfe.bvh")
    write_bvh(_motion(), path)
    page = build_viewer([path], plotly_src="plotly.min.js")
    out = write_viewer(page, tmp_path / "v.html")
    assert "bad&#56575;&#56574;" in out.read_text(encoding="utf-8")  # shown as U+FFFD


@pytest.mark.skipif(find_chromium() is None, reason="chromium is not installed")
def test_page_with_such_names_starts_in_chromium_and_shows_them(weird_file, tmp_path):
    page = build_viewer([weird_file], reports=[_report()])
    out = write_viewer(page, tmp_path / "view.html")
    v = "window.emViewers['em-viewer']"
    with Browser(1000, 800, timeout=30) as b:
        b.open(out)
        b.wait_for(f"window.emViewers && {v} && {v}.ready")
        b.evaluate(f"{v}.showTrajectories({json.dumps(list(JOINTS[:2]))}).then(() => 1)")
        options = b.evaluate("Array.from(document.querySelectorAll('.emv-traj option')).map(o => o.value)")
        title = b.evaluate("document.querySelector('.emv-notes li').textContent")
        # every text plotly drew (legend, labels, timeline rows, warp plot): the names as written
        drawn = b.evaluate("Array.from(document.querySelectorAll('.emv svg text')).map(t => t.textContent)")
        labels = b.evaluate("Array.from(document.querySelectorAll('.emv-label')).map(t => t.textContent)")
        assert b.errors == [], b.errors
    assert labels == [STEM]  # the figure's label, as written
    assert options[:4] == list(JOINTS)
    assert title.startswith(STEM + ":")
    for want in (
        STEM,  # the clip's legend entry and the timeline
        f"{STEM}: {JOINTS[0]} path",
        f"{STEM}: {JOINTS[1]} path",
        f"{STEM}: </script>",  # a contact row on the timeline
        f"{STEM} <- <!--<script> in",  # the warp plot's legend
    ):
        assert want in drawn, (want, drawn)
