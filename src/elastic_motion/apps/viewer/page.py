# ruff: noqa: E501  (the embedded JavaScript keeps its own line lengths)
"""The viewer's HTML and JavaScript (drawing by plotly.js; no numerics).

:func:`viewer_fragment` turns the data of :func:`elastic_motion.apps.viewer.build_viewer`
into a ``<div>`` with controls, a ``<script type="application/json">`` holding the data and
a script that draws it; :func:`page_html` wraps fragments into a page with plotly.js
(:func:`plotly_js`: the bundle of the installed ``plotly`` package, imported when a page
is written, as it is an optional dependency). Colours are those of
:mod:`elastic_motion.apps.palette`.

The script keeps one viewer object per fragment in ``window.emViewers[id]`` (used by the
tests and by anyone scripting the page): ``setFrame(i)``, ``frame()``, ``count``,
``setLayout("side" | "overlay")``, ``setCamera("follow" | "path")``,
``showTrajectories([names])``, ``pose(k)`` (the points drawn for clip ``k``: plotly
coordinates, metres) and ``ready``.

The first camera follows the figures (``"follow"``: a window centred on the clips' roots at
each frame, its eye fitted to the first frame's figures; ``spec["camera"]``, made by
``build_viewer``, gives each clip's reach from its root and the height range); ``"path"``
shows the whole travelled paths. Each clip's label is an HTML element over the scene, placed
above its figure's head by projecting it with plotly's camera matrices each time plotly
draws the scene, then moved by whole label heights until no two labels (nor the legend)
overlap. Labels are written as ``textContent``: names show as written.
"""

from __future__ import annotations

import html
import json
from typing import Any

from elastic_motion.apps.palette import LEFT, PLANTED, RIGHT

__all__ = ["CSS", "html_text", "json_for_script", "page_html", "plotly_js", "viewer_fragment"]

#: The viewer's style sheet (a page holding viewers includes it once).
CSS = """
.emv{font-family:system-ui,sans-serif;font-size:14px;margin:1em 0;border:1px solid #ddd;padding:.5em}
.emv-title{font-weight:600;margin-bottom:.3em}
.emv-controls{display:flex;flex-wrap:wrap;gap:.6em;align-items:center;margin:.3em 0}
.emv-slider{flex:1 1 300px;min-width:200px}
.emv-time{font-variant-numeric:tabular-nums;min-width:9em}
.emv-stage{position:relative}
.emv-scene{width:100%;height:max(520px,72vh)}
.emv-labels{position:absolute;left:0;top:0;right:0;bottom:0;pointer-events:none;overflow:hidden}
.emv-label{position:absolute;white-space:nowrap;font-size:13px;line-height:16px;padding:0 3px;background:rgba(255,255,255,.75);border-radius:3px}
.emv-notes{color:#555;font-size:13px;margin:.3em 0 0 1.2em;padding:0}
.emv-key{color:#555;font-size:13px}
.emv-key span{display:inline-block;width:1.6em;height:.5em;margin:0 .3em 0 .8em;vertical-align:middle}
"""

_JS = r"""
(function () {
  "use strict";
  var ID = __ID__;
  var LEFT = "__LEFT__", RIGHT = "__RIGHT__", PLANTED = "__PLANTED__";
  var root = document.getElementById(ID);
  var spec = JSON.parse(document.getElementById(ID + "-data").textContent);
  function q(sel) { return root.querySelector(sel); }
  // plotly reads its text as a little HTML ("<b>", "<br>", "&amp;"): names are escaped so
  // that they show as written
  function txt(s) { return String(s).replace(/&/g, "&amp;").replace(/</g, "&lt;").replace(/>/g, "&gt;"); }
  function bytes(b64) {
    var s = atob(b64), u = new Uint8Array(s.length);
    for (var i = 0; i < s.length; i++) u[i] = s.charCodeAt(i);
    return u;
  }
  var clips = spec.clips;
  clips.forEach(function (c) {
    c.text = txt(c.label);
    c.p = new Float32Array(bytes(c.pos).buffer);
    if (c.contacts) c.mask = bytes(c.contacts.mask);
  });
  var dt = 1 / Math.max.apply(null, clips.map(function (c) { return c.fps; }));
  var total = Math.max.apply(null, clips.map(function (c) { return c.duration; }));
  var count = Math.floor(total / dt + 1e-6) + 1;
  var state = { i: 0, playing: false, layout: spec.layout, traj: [], last: null, busy: false, pending: null };
  var scene = q(".emv-scene"), timeline = q(".emv-timeline"), warpDiv = q(".emv-warp");
  var slider = q(".emv-slider"), timeLabel = q(".emv-time"), playBtn = q(".emv-play");
  slider.max = String(count - 1);

  function offset(c) { return state.layout === "side" ? c.offset : [0, 0, 0]; }
  function clipFrame(c, i) { return Math.min(Math.round(i * dt * c.fps), c.n - 1); }
  function pt(c, f, j, off) {
    var o = (f * c.P + j) * 3;
    return [c.p[o] + off[0], c.p[o + 1] + off[1], c.p[o + 2] + off[2]];
  }
  function segments(c, f, segs, off) {
    var x = [], y = [], z = [];
    segs.forEach(function (s) {
      for (var e = 0; e < 2; e++) {
        var v = pt(c, f, s[e], off);
        x.push(v[0]); y.push(v[1]); z.push(v[2]);
      }
      x.push(null); y.push(null); z.push(null);
    });
    return [x, y, z];
  }

  // ---- the 3D scene ---------------------------------------------------------------------
  var traces = [], dynamic = [];
  function floorTrace() {
    var r = spec.ranges.side, s = spec.ranges.overlay;
    var x0 = Math.min(r[0][0], s[0][0]), x1 = Math.max(r[0][1], s[0][1]);
    var y0 = Math.min(r[1][0], s[1][0]), y1 = Math.max(r[1][1], s[1][1]);
    return { type: "mesh3d", x: [x0, x1, x1, x0], y: [y0, y0, y1, y1], z: [spec.floor, spec.floor, spec.floor, spec.floor],
             i: [0, 0], j: [1, 2], k: [2, 3], color: "#cccccc", opacity: 0.35, hoverinfo: "skip",
             name: "floor", showlegend: false, flatshading: true };
  }
  traces.push(floorTrace());
  clips.forEach(function (c, k) {
    c.tr = traces.length;
    [["C", c.colour, c.text], ["L", LEFT, c.text + ": left"], ["R", RIGHT, c.text + ": right"]].forEach(function (s) {
      traces.push({ type: "scatter3d", mode: "lines", x: [], y: [], z: [], name: s[2], legendgroup: "clip" + k,
                    showlegend: s[0] === "C", line: { color: s[1], width: 6 }, hoverinfo: "skip" });
    });
    traces.push({ type: "scatter3d", mode: "markers", x: [], y: [], z: [], name: c.text + ": planted",
                  legendgroup: "clip" + k, showlegend: !!c.contacts,
                  marker: { color: PLANTED, size: 6, symbol: "diamond" }, hoverinfo: "skip" });
    traces.push({ type: "scatter3d", mode: "markers", x: [], y: [], z: [], name: c.text + ": contact starts",
                  legendgroup: "clip" + k, showlegend: c.footprints.length > 0,
                  marker: { color: PLANTED, size: 3, symbol: "x", opacity: 0.6 }, hoverinfo: "skip" });
    for (var t = 0; t < 5; t++) dynamic.push(c.tr + t);
  });
  var nFixed = traces.length;

  // ---- the camera ----------------------------------------------------------------------
  // "follow" (the first camera): at each frame a window centred on the figures' roots, wide
  // enough for every figure whole (spec.camera.reach around each root; z from under the floor
  // to above the highest head; plotly clips what is outside), of the shape of the window at
  // the frame shown when the camera was set, grown evenly when the figures spread further
  // apart. The eye looks across the axis along which the clips stand side by side, at the
  // distance where the figures of that frame (all their joints, the floor under them, room
  // for the labels) fill the scene. "path": the whole travelled path (spec.ranges) in view.
  var cam = spec.camera;
  var zSpan = cam.z[1] - cam.z[0];
  function rootSpread(i) {
    var lo = [Infinity, Infinity], hi = [-Infinity, -Infinity];
    clips.forEach(function (c) {
      var r = pt(c, clipFrame(c, i), 0, offset(c));
      for (var a = 0; a < 2; a++) { lo[a] = Math.min(lo[a], r[a]); hi[a] = Math.max(hi[a], r[a]); }
    });
    return { mid: [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2],
             need: [hi[0] - lo[0] + 2 * cam.reach[0], hi[1] - lo[1] + 2 * cam.reach[1]] };
  }
  function boxAspect(d) {
    var m = Math.max(d[0], d[1], d[2]);
    return { x: d[0] / m, y: d[1] / m, z: d[2] / m };
  }
  function windowLayout(i) {  // the scene's ranges at frame i
    if (state.camera === "path") return {};
    var w = rootSpread(i), b = state.base;
    var s = Math.max(1, w.need[0] / b[0], w.need[1] / b[1]);
    return { "scene.xaxis.range": [w.mid[0] - s * b[0] / 2, w.mid[0] + s * b[0] / 2],
             "scene.yaxis.range": [w.mid[1] - s * b[1] / 2, w.mid[1] + s * b[1] / 2],
             "scene.zaxis.range": [cam.z[0], cam.z[0] + s * b[2]] };
  }
  function corners(lo, hi) {  // the 8 corners of a box
    var out = [];
    for (var k = 0; k < 8; k++) out.push([0, 1, 2].map(function (e) { return (k >> e) & 1 ? hi[e] : lo[e]; }));
    return out;
  }
  function sceneLayout() {
    // ranges and aspect ratio of the camera mode and layout, and state.fit: the points (box
    // units, centred) the eye is fitted to
    var r = spec.ranges[state.layout], d, out;
    if (state.camera === "path") {
      d = r.map(function (a) { return a[1] - a[0]; });
      out = { "scene.xaxis.range": r[0], "scene.yaxis.range": r[1], "scene.zaxis.range": r[2] };
      state.fit = corners(d.map(function (v) { return -v / 2; }), d.map(function (v) { return v / 2; }));
    } else {
      var w = rootSpread(state.i), lo = [Infinity, Infinity], hi = [-Infinity, -Infinity];
      state.base = d = [w.need[0], w.need[1], zSpan];
      out = windowLayout(state.i);
      clips.forEach(function (c) {  // the figures as they are now, 15 cm around
        var f = clipFrame(c, state.i), off = offset(c);
        for (var j = 0; j < c.P; j++) {
          var v = pt(c, f, j, off);
          for (var a = 0; a < 2; a++) { lo[a] = Math.min(lo[a], v[a] - 0.15); hi[a] = Math.max(hi[a], v[a] + 0.15); }
        }
      });
      var zm = (cam.z[0] + cam.z[1]) / 2;
      state.fit = corners([lo[0] - w.mid[0], lo[1] - w.mid[1], cam.z[0] - zm], [hi[0] - w.mid[0], hi[1] - w.mid[1], cam.z[1] - zm]);
    }
    var m = Math.max(d[0], d[1], d[2]);
    state.fit = state.fit.map(function (p) { return p.map(function (v) { return v / m; }); });
    out["scene.aspectratio"] = boxAspect(d);
    // a following camera's x and y ticks would change at every frame: their numbers scroll by,
    // and re-drawing them and the axis titles (plotly draws text in WebGL) takes most of a
    // frame's time; the grid on the floor shows the motion
    var whole = state.camera === "path";
    out["scene.xaxis.showticklabels"] = out["scene.yaxis.showticklabels"] = whole;
    out["scene.xaxis.title.text"] = whole ? "x (m)" : "";
    out["scene.yaxis.title.text"] = whole ? "-z (m)" : "";
    return out;
  }
  function eyeFitting(pts, dir) {
    // the eye along dir (from the box centre) at the distance where pts (box units) fill 95 %
    // of the scene: plotly's perspective (vertical field of view 45 degrees, z up)
    var n = Math.hypot(dir[0], dir[1], dir[2]), u = dir.map(function (v) { return v / n; });
    var B = (scene.clientWidth || 1000) / (scene.clientHeight || 520), t = Math.tan(Math.PI / 8);
    var rgt = [-u[1], u[0], 0], rn = Math.hypot(rgt[0], rgt[1]) || 1;
    rgt = rgt.map(function (v) { return v / rn; });
    var up = [-rgt[1] * u[2], rgt[0] * u[2], rgt[1] * u[0] - rgt[0] * u[1]];  // rgt x (-u)
    function fits(D) {
      return pts.every(function (q) {
        var p = [0, 1, 2].map(function (e) { return q[e] - D * u[e]; });
        var depth = -(p[0] * u[0] + p[1] * u[1] + p[2] * u[2]);
        var x = p[0] * rgt[0] + p[1] * rgt[1] + p[2] * rgt[2], y = p[0] * up[0] + p[1] * up[1] + p[2] * up[2];
        return depth > 0.05 && Math.abs(x) <= 0.95 * depth * t * B && Math.abs(y) <= 0.95 * depth * t;
      });
    }
    var lo = 0.05, hi = 20;
    for (var it = 0; it < 40; it++) { var mid = (lo + hi) / 2; if (fits(mid)) hi = mid; else lo = mid; }
    return { x: hi * u[0], y: hi * u[1], z: hi * u[2] };
  }
  function firstEyeDirection() {
    // across the side-by-side axis (clip 0 on the left), turned 8 degrees, 12 degrees above
    var e = 12 * Math.PI / 180, a = 8 * Math.PI / 180, s = Math.sin(a) * Math.cos(e), c = Math.cos(a) * Math.cos(e);
    return cam.axis === 0 ? [s, -c, Math.sin(e)] : [c, s, Math.sin(e)];
  }
  function currentEyeDirection() {
    var e = scene.layout && scene.layout.scene && scene.layout.scene.camera && scene.layout.scene.camera.eye;
    return e && isFinite(e.x) ? [e.x, e.y, e.z] : firstEyeDirection();
  }
  state.camera = "follow";
  var sl = sceneLayout();
  var layout3d = {
    margin: { l: 0, r: 0, t: 0, b: 0 }, showlegend: true, legend: { x: 0, y: 1 }, uirevision: "keep",
    scene: { aspectmode: "manual", aspectratio: sl["scene.aspectratio"],
             xaxis: { title: { text: sl["scene.xaxis.title.text"] }, range: sl["scene.xaxis.range"], showticklabels: sl["scene.xaxis.showticklabels"] },
             yaxis: { title: { text: sl["scene.yaxis.title.text"] }, range: sl["scene.yaxis.range"], showticklabels: sl["scene.yaxis.showticklabels"] },
             zaxis: { title: { text: "up: y (m)" }, range: sl["scene.zaxis.range"] },
             camera: { eye: eyeFitting(state.fit, firstEyeDirection()) } }
  };
  var config = { responsive: true, displaylogo: false };

  // ---- labels: one per clip above its head, laid out on screen so that none overlap ------
  var labelBox = q(".emv-labels");
  clips.forEach(function (c) {
    c.labelEl = document.createElement("span");
    c.labelEl.className = "emv-label";
    c.labelEl.textContent = c.label;
    c.labelEl.style.color = c.colour;
    labelBox.appendChild(c.labelEl);
  });
  function glScene() { var s = scene._fullLayout && scene._fullLayout.scene; return s && s._scene; }
  function project(v) {
    // a point (plotly coordinates, metres) to CSS pixels in the scene's <div>, as plotly
    // places its 3D annotations; null behind the eye or before the scene is drawn
    var sc = glScene();
    if (!sc || !sc.glplot) return null;
    var cp = sc.glplot.cameraParams, ds = sc.dataScale, fl = scene._fullLayout, sz = fl._size, dom = fl.scene.domain;
    function mul(m, x) {
      var r = [0, 0, 0, 0];
      for (var a = 0; a < 4; a++) for (var b = 0; b < 4; b++) r[b] += m[4 * a + b] * x[a];
      return r;
    }
    var p = mul(cp.projection, mul(cp.view, mul(cp.model, [v[0] * ds[0], v[1] * ds[1], v[2] * ds[2], 1])));
    if (!(p[3] > 0)) return null;
    return [sz.l + dom.x[0] * sz.w + 0.5 * (1 + p[0] / p[3]) * sz.w * (dom.x[1] - dom.x[0]),
            sz.t + (1 - dom.y[1]) * sz.h + 0.5 * (1 - p[1] / p[3]) * sz.h * (dom.y[1] - dom.y[0])];
  }
  function headOf(c) {  // above the highest joint of clip c at the current frame
    var f = clipFrame(c, state.i), off = offset(c), top = -Infinity;
    for (var j = 0; j < c.P; j++) top = Math.max(top, c.p[(f * c.P + j) * 3 + 2]);
    var r0 = pt(c, f, 0, off);
    return [r0[0], r0[1], top + off[2] + 0.05];
  }
  function hits(a, b) { return a.x < b.x + b.w && b.x < a.x + a.w && a.y < b.y + b.h && b.y < a.y + a.h; }
  function placeLabels() {
    // greedy, in screen space: each label centred above its figure's head, else moved up
    // (or, at the top of the scene, down) by whole label heights to the nearest place free of the labels already
    // placed and of the legend, inside the scene
    var W = scene.clientWidth, H = scene.clientHeight, placed = [];
    var leg = scene.querySelector(".legend"), sr = scene.getBoundingClientRect();
    if (leg) { var lr = leg.getBoundingClientRect(); placed.push({ x: lr.left - sr.left, y: lr.top - sr.top, w: lr.width, h: lr.height }); }
    var items = clips.map(function (c) { return { c: c, at: project(headOf(c)) }; })
      .filter(function (it) { if (!it.at) it.c.labelEl.style.display = "none"; return !!it.at; });
    items.sort(function (a, b) { return a.at[1] - b.at[1] || a.at[0] - b.at[0]; });
    items.forEach(function (it) {
      var el = it.c.labelEl;
      el.style.display = "";
      var w = el.offsetWidth, h = el.offsetHeight + 2;
      var x = Math.max(0, Math.min(W - w, it.at[0] - w / 2)), y0 = it.at[1] - h, best = null;
      var n = clips.length + 2;
      for (var k = 0; k <= 2 * n && best === null; k++) {
        var dy = k <= n ? -k * h : (k - n) * h;  // 0, -h, -2h, ..., then +h, +2h, ...
        var r = { x: x, y: Math.max(0, Math.min(H - h, y0 + dy)), w: w, h: h };
        if (!placed.some(function (p) { return hits(p, r); })) best = r;
      }
      if (best === null) {  // a column at the left edge below everything placed
        var yb = placed.reduce(function (m, p) { return Math.max(m, p.y + p.h); }, 0);
        best = { x: 0, y: yb, w: w, h: h };
      }
      placed.push(best);
      el.style.left = best.x + "px"; el.style.top = best.y + "px";
    });
  }
  function hookLabels() {  // lay the labels out again each time plotly draws the scene (orbit, zoom)
    var sc = glScene();
    if (!sc || !sc.glplot || sc.glplot.emLabels) return;
    var drawn = sc.glplot.onrender;
    sc.glplot.onrender = function () { if (drawn) drawn.apply(this, arguments); placeLabels(); };
    sc.glplot.emLabels = true;
  }

  function poseUpdate(i) {
    var X = [], Y = [], Z = [];
    clips.forEach(function (c) {
      var f = clipFrame(c, i), off = offset(c);
      ["C", "L", "R"].forEach(function (s) {
        var a = segments(c, f, c.segs[s], off); X.push(a[0]); Y.push(a[1]); Z.push(a[2]);
      });
      var px = [], py = [], pz = [];
      if (c.contacts) {
        var K = c.contacts.idx.length;
        for (var k = 0; k < K; k++) {
          if (c.mask[f * K + k]) { var v = pt(c, f, c.contacts.idx[k], off); px.push(v[0]); py.push(v[1]); pz.push(v[2]); }
        }
      }
      X.push(px); Y.push(py); Z.push(pz);
      X.push(c.footprints.map(function (p) { return p[0] + off[0]; }));
      Y.push(c.footprints.map(function (p) { return p[1] + off[1]; }));
      Z.push(c.footprints.map(function (p) { return p[2] + off[2]; }));
    });
    return { x: X, y: Y, z: Z };
  }

  // ---- the timeline and the warp plot --------------------------------------------------
  var rows = [], tl = [], shapes = [], annotations = [];
  clips.forEach(function (c, k) {
    rows.push(c.text);
    tl.push({ type: "scatter", mode: "lines", x: [0, c.duration], y: [c.text, c.text], line: { color: c.colour, width: 6 },
              name: c.text, showlegend: false, hoverinfo: "x+y" });
    if (c.contacts) {
      c.contacts.joints.forEach(function (jn) {
        var row = c.text + ": " + txt(jn), x = [], y = [];
        rows.push(row);
        c.contacts.intervals[jn].forEach(function (r) {
          x.push(r[0] / c.fileFps, (r[1] - 1) / c.fileFps, null); y.push(row, row, null);
        });
        tl.push({ type: "scatter", mode: "lines", x: x, y: y, line: { color: PLANTED, width: 6 }, name: row,
                  showlegend: false, hoverinfo: "x+y" });
      });
    }
    c.firstRow = rows.indexOf(c.text); c.lastRow = rows.length - 1;
  });
  clips.forEach(function (c) {  // a seam spans its clip's rows (category k sits at position n - 1 - k)
    var n = rows.length;
    c.seams.forEach(function (t) {
      shapes.push({ type: "line", xref: "x", yref: "y", x0: t, x1: t, y0: n - 1 - c.lastRow - 0.45,
                    y1: n - 1 - c.firstRow + 0.45, line: { color: "#000", width: 2, dash: "dash" } });
      annotations.push({ x: t, y: n - 1 - c.firstRow + 0.45, xref: "x", yref: "y", text: "seam", showarrow: false,
                         xanchor: "right", yanchor: "top", font: { size: 11 } });
    });
  });
  var cursorIndex = tl.length;
  tl.push({ type: "scatter", mode: "lines", x: [0, 0], y: [rows[0], rows[rows.length - 1]], line: { color: "#000", width: 2 },
            name: "now", showlegend: false, hoverinfo: "skip" });
  timeline.style.height = (70 + 20 * rows.length) + "px";
  var layoutTl = { margin: { l: 200, r: 20, t: 20, b: 35 }, xaxis: { title: { text: "time (s)" }, range: [0, total] },
                   yaxis: { type: "category", categoryorder: "array", categoryarray: rows.slice().reverse(), automargin: true },
                   shapes: shapes, annotations: annotations, showlegend: false };

  var warpClips = clips.filter(function (c) { return c.warp; });
  var wtr = [], warpCursor = null;
  warpClips.forEach(function (c) {
    var x = []; for (var i = 0; i < c.n; i++) x.push(i / c.fps);
    c.warp.curves.forEach(function (y, k) {
      wtr.push({ type: "scatter", mode: "lines", x: x, y: y, name: c.text + " &lt;- " + txt(c.warp.inputs[k]) });
    });
  });
  if (warpClips.length) {
    warpCursor = wtr.length;
    wtr.push({ type: "scatter", mode: "markers", x: [], y: [], marker: { color: "#000", size: 9 }, name: "now", showlegend: false });
  }
  var layoutWarp = { margin: { l: 60, r: 20, t: 30, b: 40 }, title: { text: "time warp: where each input is at this moment", font: { size: 13 } },
                     xaxis: { title: { text: "time in the result (s)" } },
                     yaxis: { title: { text: warpClips.length && warpClips[0].warp.seconds.every(Boolean) ? "time in the input (s)" : "input curve parameter" } },
                     shapes: [{ type: "line", xref: "x", yref: "paper", x0: 0, x1: 0, y0: 0, y1: 1, line: { color: "#000", width: 1.5 } }] };

  function timeOf(i) { return i * dt; }
  function render(i) {
    var t = timeOf(i);
    var upd = poseUpdate(i);
    hookLabels();
    var jobs = [Plotly.update(scene, upd, windowLayout(i), dynamic),
                Plotly.restyle(timeline, { x: [[t, t]] }, [cursorIndex])];
    if (warpDiv && warpClips.length) {
      var mx = [], my = [];
      warpClips.forEach(function (c) {
        var f = clipFrame(c, i);
        c.warp.curves.forEach(function (y) { mx.push(f / c.fps); my.push(y[f]); });
      });
      jobs.push(Plotly.restyle(warpDiv, { x: [mx], y: [my] }, [warpCursor]));
      jobs.push(Plotly.relayout(warpDiv, { "shapes[0].x0": t, "shapes[0].x1": t }));
    }
    slider.value = String(i);
    timeLabel.textContent = t.toFixed(2) + " s / " + total.toFixed(2) + " s";
    return Promise.all(jobs).then(placeLabels);
  }
  function setFrame(i) {
    i = Math.max(0, Math.min(count - 1, Math.round(i)));
    state.i = i;
    if (state.busy) { state.pending = i; return Promise.resolve(); }
    state.busy = true;
    return render(i).then(function () {
      state.busy = false;
      if (state.pending !== null) { var p = state.pending; state.pending = null; if (p !== i) return setFrame(p); }
    });
  }
  function trajectoryTraces() {
    var out = [];
    state.traj.forEach(function (name) {
      clips.forEach(function (c) {
        var j = c.names.indexOf(name); if (j < 0) return;
        var off = offset(c), x = [], y = [], z = [];
        for (var f = 0; f < c.n; f++) { var v = pt(c, f, j, off); x.push(v[0]); y.push(v[1]); z.push(v[2]); }
        out.push({ type: "scatter3d", mode: "lines", x: x, y: y, z: z, name: c.text + ": " + txt(name) + " path",
                   line: { color: c.colour, width: 2, dash: "dot" }, hoverinfo: "skip" });
      });
    });
    return out;
  }
  function showTrajectories(names) {
    state.traj = names.slice();
    var n = scene.data.length, old = [];
    for (var t = nFixed; t < n; t++) old.push(t);
    var p = old.length ? Plotly.deleteTraces(scene, old) : Promise.resolve();
    return p.then(function () { var tr = trajectoryTraces(); return tr.length ? Plotly.addTraces(scene, tr) : null; });
  }
  function refit() {  // the scene for the layout and camera mode; the eye keeps its direction
    var l = sceneLayout();
    l["scene.camera.eye"] = eyeFitting(state.fit, currentEyeDirection());
    return Plotly.relayout(scene, l).then(function () { return showTrajectories(state.traj); })
      .then(function () { return setFrame(state.i); });
  }
  function setLayout(mode) {
    state.layout = mode;
    q(".emv-layout").value = mode;
    return refit();
  }
  function setCamera(mode) {
    state.camera = mode;
    q(".emv-camera").value = mode;
    return refit();
  }
  function tick(ts) {
    if (!state.playing) return;
    if (state.last === null) state.last = ts;
    var speed = parseFloat(q(".emv-speed").value), adv = (ts - state.last) / 1000 * speed;
    if (adv >= dt) {
      var steps = Math.floor(adv / dt), i = state.i + steps;
      state.last += steps * dt * 1000 / speed;
      if (i >= count) {
        if (q(".emv-loop").checked) i = i % count; else { i = count - 1; play(false); }
      }
      setFrame(i);
    }
    requestAnimationFrame(tick);
  }
  function play(on) {
    state.playing = on; state.last = null;
    playBtn.textContent = on ? "Pause" : "Play";
    if (on) requestAnimationFrame(tick);
  }
  function clickToTime(div, ev) {
    try {
      var xa = div._fullLayout.xaxis, box = div.getBoundingClientRect();
      var t = xa.p2c(ev.clientX - box.left - xa._offset);
      if (isFinite(t)) setFrame(t / dt);
    } catch (e) { /* a click outside the axes */ }
  }

  var init = [Plotly.newPlot(scene, traces, layout3d, config), Plotly.newPlot(timeline, tl, layoutTl, config)];
  if (warpDiv && warpClips.length) init.push(Plotly.newPlot(warpDiv, wtr, layoutWarp, config));
  var api = { count: count, dt: dt, ready: false, setFrame: setFrame, frame: function () { return state.i; },
              setLayout: setLayout, setCamera: setCamera, showTrajectories: showTrajectories, play: play,
              pose: function (k) { var c = clips[k], f = clipFrame(c, state.i), off = offset(c), out = [];
                                   for (var j = 0; j < c.P; j++) out.push(pt(c, f, j, off)); return out; } };
  window.emViewers = window.emViewers || {};
  window.emViewers[ID] = api;
  Promise.all(init).then(function () { return setFrame(0); }).then(function () {
    slider.addEventListener("input", function () { play(false); setFrame(parseInt(slider.value, 10)); });
    playBtn.addEventListener("click", function () { play(!state.playing); });
    q(".emv-layout").addEventListener("change", function (ev) { setLayout(ev.target.value); });
    q(".emv-camera").addEventListener("change", function (ev) { setCamera(ev.target.value); });
    q(".emv-traj").addEventListener("change", function (ev) {
      var names = Array.prototype.filter.call(ev.target.options, function (o) { return o.selected; })
        .map(function (o) { return o.value; });
      showTrajectories(names);
    });
    timeline.addEventListener("click", function (ev) { clickToTime(timeline, ev); });
    if (warpDiv && warpClips.length) warpDiv.addEventListener("click", function (ev) { clickToTime(warpDiv, ev); });
    api.ready = true;
    root.setAttribute("data-ready", "1");
  });
})();
"""


#: ``<``, ``>`` and ``&`` as JSON ``\\uXXXX`` escapes (:func:`json_for_script`).
_SCRIPT_ESCAPES = str.maketrans({c: f"\\u{ord(c):04x}" for c in "<>&"})


def json_for_script(data: Any) -> str:
    """``data`` as JSON that is safe inside an HTML ``<script>`` element, whatever its strings.

    ``<``, ``>`` and ``&`` are written as ``\\u003c``, ``\\u003e``, ``\\u0026`` and every
    non-ASCII character as its ``\\uXXXX`` escape: the same value to ``JSON.parse`` and to a
    JavaScript parser, and nothing the HTML parser reacts to. (Replacing only ``</`` is not
    enough: in a ``<script>`` element the parser reads ``<!--<script>`` as the start of an
    escaped section, after which ``</script>`` no longer ends the element and the page never
    starts. U+2028 / U+2029 end a line for older JavaScript parsers; a lone surrogate, as
    ``os.fsdecode`` makes of a file name that is not UTF-8, cannot be written as UTF-8.)

    Parameters
    ----------
    data : JSON-ready value
        No NaN or infinity (``ValueError``).

    Returns
    -------
    str
        Compact ASCII JSON.
    """
    return json.dumps(data, separators=(",", ":"), allow_nan=False).translate(_SCRIPT_ESCAPES)


def html_text(s: str) -> str:
    """``s`` escaped for HTML text and attribute values (quotes included).

    A lone surrogate (``os.fsdecode`` of a file name that is not UTF-8) becomes a character
    reference, which the browser shows as U+FFFD, so that the page can be written as UTF-8.
    """
    return html.escape(s).encode("utf-8", "xmlcharrefreplace").decode("utf-8")


def viewer_fragment(spec: dict[str, Any]) -> str:
    """The viewer's ``<div>``, data and script (module docstring).

    Parameters
    ----------
    spec : dict
        As made by :func:`elastic_motion.apps.viewer.build_viewer`: ``id``, ``title``,
        ``clips`` (each with its display data), ``floor``, ``layout``, ``ranges``, ``notes``.

    Returns
    -------
    str
    """
    e = html_text
    vid = spec["id"]
    names: list[str] = []
    for c in spec["clips"]:
        names += [n for n in c["names"] if n not in names]
    options = "".join(f"<option value='{e(n)}'>{e(n)}</option>" for n in names)
    has_warp = any(c["warp"] for c in spec["clips"])
    notes = "".join(f"<li>{e(n)}</li>" for n in spec["notes"])
    clips = "; ".join(f"{e(c['label'])}: {e(c['info'])}" for c in spec["clips"])
    layout_opts = "".join(
        f"<option value='{v}'{' selected' if v == spec['layout'] else ''}>{lab}</option>"
        for v, lab in (("side", "side by side"), ("overlay", "overlaid"))
    )
    speeds = "".join(
        f"<option value='{s}'{' selected' if s == '1' else ''}>{s}x</option>"
        for s in ("0.1", "0.25", "0.5", "1", "2")
    )
    parts = [
        f"<div class='emv' id='{e(vid)}'>",
        f"<div class='emv-title'>{e(spec['title'])}</div>",
        "<div class='emv-controls'>",
        "<button type='button' class='emv-play'>Play</button>",
        "<input class='emv-slider' type='range' min='0' max='0' step='1' value='0' aria-label='frame'>",
        "<span class='emv-time'>0.00 s</span>",
        f"<label>speed <select class='emv-speed'>{speeds}</select></label>",
        "<label><input type='checkbox' class='emv-loop' checked> loop</label>",
        f"<label>clips <select class='emv-layout'>{layout_opts}</select></label>",
        "<label>camera <select class='emv-camera'><option value='follow' selected>follows the figures</option>"
        "<option value='path'>whole paths</option></select></label>",
        f"<label>joint paths <select class='emv-traj' multiple size='3'>{options}</select></label>",
        "</div>",
        "<div class='emv-stage'><div class='emv-scene'></div><div class='emv-labels'></div></div>",
        "<div class='emv-key'>"
        f"<span style='background:{LEFT}'></span>left limbs<span style='background:{RIGHT}'></span>right "
        f"limbs<span style='background:{PLANTED}'></span>planted (contacts from the report) and where each contact "
        "starts. Drag to orbit, scroll to zoom; click the timeline"
        + (" or the warp plot" if has_warp else "")
        + " to jump there.</div>",
        "<div class='emv-timeline'></div>",
        "<div class='emv-warp' style='height:280px'></div>" if has_warp else "",
        f"<ul class='emv-notes'><li>{clips}</li>{notes}</ul>",
        "</div>",
        f"<script type='application/json' id='{e(vid)}-data'>{json_for_script(spec)}</script>",
        "<script>"
        + _JS.replace("__ID__", json_for_script(vid))
        .replace("__LEFT__", LEFT)
        .replace("__RIGHT__", RIGHT)
        .replace("__PLANTED__", PLANTED)
        + "</script>",
    ]
    return "\n".join(p for p in parts if p)


def page_html(title: str, fragments: str, *, plotly_src: str | None = None) -> str:
    """A whole page: plotly.js (inline, or from ``plotly_src``), the viewer's style, ``fragments``."""
    if plotly_src is None:
        lib = "<script>" + plotly_js().replace("</script", "<\\/script") + "</script>"
    else:
        lib = f"<script src='{html_text(plotly_src)}'></script>"
    return (
        "<!doctype html>\n<html><head><meta charset='utf-8'>"
        f"<title>{html_text(title)}</title>\n{lib}\n<style>{CSS}</style></head>\n<body>\n"
        f"{fragments}\n</body></html>\n"
    )


def plotly_js() -> str:
    """The plotly.js bundle of the installed ``plotly`` package (about 4.6 MB of text).

    Raises
    ------
    ModuleNotFoundError
        ``plotly`` is not installed (``pip install "elastic-motion[viewer]"``).
    """
    try:
        from plotly.offline import get_plotlyjs
    except ImportError as exc:
        raise ModuleNotFoundError(
            'the viewer needs plotly: pip install "elastic-motion[viewer]" (or pip install plotly)',
            name="plotly",
        ) from exc
    return get_plotlyjs()
