"""The demo: blends, loops, distances, figures and videos from data found on the machine.

:func:`run_demo` reads the DeepMimic motion clips shipped in the PyPI package ``pybullet``
(``pybullet_data.getDataPath()/data/motions``; importing ``pybullet_data`` does not load
the physics engine; install with ``pip install "elastic-motion[demo]"``) and writes a folder::

    index.html            the results side by side, with short explanations, a legend of the
                          pictures' colours and a link to every BVH file
    report.json           what was computed, the metrics, timings
    blends/*.bvh          walk x run blends by every method (paper 001 Fig. 5, paper 000)
    loops/*.bvh           the cartwheel and the backflip made seamless, and 3-cycle previews
    distances.csv/.png    elastic distances between the clips
    figures/*.png         foot trajectories, the warp, seams, SO(3) curves on the sphere
    videos/*.gif (.mp4)   skeleton animations (MP4 when imageio-ffmpeg is installed)

The walk (2 cycles, 2.5 s, 4 steps) and the run (3 cycles, 2.4 s, 6 steps) have different
rhythms and numbers of steps: the case of paper 001 Fig. 5. Clips are short and videos
small so that the whole demo runs in well under a minute once numba has compiled its
kernels (the first run on a fresh machine also compiles them).
"""

from __future__ import annotations

import html
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from elastic_motion._io import atomic_write_text
from elastic_motion.apps.align import AlignResult, align_motions
from elastic_motion.apps.blend import BlendResult, blend_motions
from elastic_motion.apps.csv_files import csv_text
from elastic_motion.apps.distance import DistanceTable, distance_table
from elastic_motion.apps.loop import LoopResult, loop_motion
from elastic_motion.apps.metrics import SeamMetrics, seam_metrics
from elastic_motion.apps.palette import CENTRE, CURVES, FLOOR, GHOST, LEFT, RIGHT, TRACE, UNIFORM, WARP
from elastic_motion.apps.plots_database import plot_distance_matrix
from elastic_motion.apps.progress import Progress, null_progress
from elastic_motion.apps.render import (
    joint_rotation_curve,
    plot_foot_trajectories,
    plot_seam,
    plot_so3_curves,
    plot_warp,
    render_animation,
)
from elastic_motion.apps.report import jsonable, report_header, write_report
from elastic_motion.apps.viewer import build_viewer, plotly_js
from elastic_motion.apps.viewer.page import CSS as VIEWER_CSS
from elastic_motion.motion import Motion, read_motion, write_bvh
from elastic_motion.motion.looping import repeat_motion

__all__ = ["DemoDataError", "DemoResult", "demo_data_dir", "run_demo"]

_MARKER = ".elastic-motion-demo"

#: (key, file in the motions folder, label, cycles to play for the blends)
_BLEND_INPUTS = (
    ("walk", "humanoid3d_walk.txt", "walk (2 cycles)", 2),
    ("run", "humanoid3d_run.txt", "run (3 cycles)", 3),
)
_LOOP_INPUTS = (
    ("cartwheel", "humanoid3d_cartwheel.txt", "cartwheel"),
    ("backflip", "humanoid3d_backflip.txt", "backflip"),
)
_DISTANCE_INPUTS = (
    ("walk", "humanoid3d_walk.txt"),
    ("run", "humanoid3d_run.txt"),
    ("jump", "humanoid3d_jump.txt"),
    ("cartwheel", "humanoid3d_cartwheel.txt"),
    ("backflip", "humanoid3d_backflip.txt"),
    ("spinkick", "humanoid3d_spinkick.txt"),
    ("kick", "humanoid3d_kick.txt"),
    ("punch", "humanoid3d_punch.txt"),
    ("walk turning left", "walker/turn_left0.txt"),
)
#: (file stem, method, warp, landmarks, label) -- paper 001 Fig. 5 (a)-(d), paper 000 Fig. 4
_METHODS = (
    ("euler_linear", "euler-linear", "none", None, "Euler, linear"),
    ("euler_elastic", "euler-elastic", "none", None, "Euler, elastic"),
    ("euler_elastic_warp", "euler-elastic", "dp", None, "Euler, elastic + warp"),
    ("euler_elastic_landmarks", "euler-elastic", "dp", "auto", "Euler, elastic + warp + landmarks"),
    ("lie", "lie", "none", None, "Lie group"),
    ("lie_warp", "lie", "dp", None, "Lie group + warp"),
)


class DemoDataError(RuntimeError):
    """The demo's motion clips were not found (pybullet is not installed)."""


@dataclass(frozen=True)
class DemoResult:
    """What :func:`run_demo` wrote.

    Attributes
    ----------
    out_dir : pathlib.Path
    index : pathlib.Path
        The ``index.html`` to open.
    files : tuple of pathlib.Path
        Every file written.
    report : dict
        The content of ``report.json``.
    seconds : float
        Wall-clock time.
    """

    out_dir: Path
    index: Path
    files: tuple[Path, ...]
    report: dict[str, Any] = field(repr=False)
    seconds: float = 0.0


def demo_data_dir() -> Path:
    """The DeepMimic motions folder of the installed ``pybullet`` package.

    Raises
    ------
    DemoDataError
        ``pybullet`` is not installed, or its data folder lacks the clips.
    """
    try:
        import pybullet_data
    except ImportError as exc:
        raise DemoDataError(
            "the demo reads the DeepMimic motion clips shipped with the PyPI package pybullet, which is "
            'not installed: python -m pip install "elastic-motion[demo]" (or pip install pybullet)'
        ) from exc
    folder = Path(pybullet_data.getDataPath()) / "data" / "motions"
    if not (folder / "humanoid3d_walk.txt").is_file():
        raise DemoDataError(f"the DeepMimic clips were not found in {folder} (a pybullet without its data?)")
    return folder


def _prepare_out(out_dir: Path, force: bool) -> None:
    if out_dir.exists():
        if not out_dir.is_dir():
            raise ValueError(f"out_dir: {str(out_dir)!r} exists and is not a folder")
        if any(out_dir.iterdir()) and not (out_dir / _MARKER).exists() and not force:
            raise ValueError(
                f"out_dir: {str(out_dir)!r} is not empty and was not written by the demo; choose another "
                "folder (or force=True / --force to write into it)"
            )
    for sub in ("blends", "loops", "figures", "videos"):
        (out_dir / sub).mkdir(parents=True, exist_ok=True)
    (out_dir / _MARKER).write_text("written by elastic-motion demo\n", encoding="utf-8")


def _mp4_available() -> bool:
    try:
        import imageio_ffmpeg  # noqa: F401
    except ImportError:
        return False
    return True


def run_demo(
    out_dir: str | os.PathLike[str] = "elastic-motion-demo",
    *,
    data_dir: str | os.PathLike[str] | None = None,
    video: bool = True,
    mp4: bool | None = None,
    force: bool = False,
    progress: Progress | None = None,
) -> DemoResult:
    """Run the demo pipeline and write its folder (module docstring).

    Parameters
    ----------
    out_dir : path
        Output folder (created; a non-empty folder not written by the demo is refused).
    data_dir : path, optional
        Folder with the DeepMimic clips (default :func:`demo_data_dir`).
    video : bool
        Render the animations (the slowest part).
    mp4 : bool, optional
        Also write MP4 files; default: when imageio-ffmpeg is installed.
    force : bool
        Write into a non-empty folder anyway.
    progress : callable, optional
        ``progress(stage, done, total)``.

    Returns
    -------
    DemoResult
    """
    t_start = time.perf_counter()
    data = Path(data_dir) if data_dir is not None else demo_data_dir()
    out = Path(out_dir)
    _prepare_out(out, force)
    mp4 = _mp4_available() if mp4 is None else bool(mp4)
    run = _Run(out, data, progress or null_progress)
    blends = run.timed("blends_s", lambda: _blends(run))
    loops = run.timed("loops_s", lambda: _loops(run))
    table = run.timed("distances_s", lambda: _distances(run))
    figs, al = run.timed("figures_s", lambda: _figures(run, blends, loops))
    videos = run.timed("videos_s", lambda: _videos(run, blends, loops, mp4) if video else {})
    viewers = _viewers(run, blends, loops)
    rep = _report(run, blends, loops, table, al)
    run.timings["total_s"] = time.perf_counter() - t_start
    rep["timings"] = run.timings
    index = out / "index.html"
    page = _Page(out, blends, loops, table, figs, videos, run.timings, run.bvh_files, viewers)
    atomic_write_text(index, _html(page))
    write_report(out / "report.json", rep)
    run.files += [index, out / "report.json"]
    return DemoResult(out, index, tuple(run.files), rep, time.perf_counter() - t_start)


@dataclass
class _Run:
    """The demo's working state: where it reads and writes, what it wrote, how long it took."""

    out: Path
    data: Path
    progress: Progress
    files: list[Path] = field(default_factory=list)
    #: (path, what it holds), for index.html
    bvh_files: list[tuple[Path, str]] = field(default_factory=list)
    #: seconds per stage
    timings: dict[str, float] = field(default_factory=dict)

    def rel(self, p: Path) -> str:
        """``p`` relative to the output folder, with ``/``."""
        return p.relative_to(self.out).as_posix()

    def read(self, name: str) -> Motion:
        """A DeepMimic clip of the data folder, named after its file."""
        p = self.data / name
        if not p.is_file():
            raise DemoDataError(f"demo clip {name} not found in {self.data}")
        return read_motion(p).replace(name=Path(name).stem.replace("humanoid3d_", ""))

    def write_bvh(self, motion: Motion, path: Path, what: str) -> None:
        """Write a motion and list it among the page's files."""
        write_bvh(motion, path)
        self.files.append(path)
        self.bvh_files.append((path, what))

    def timed(self, key: str, stage: Callable[[], Any]) -> Any:
        """Run ``stage`` and record its wall-clock seconds as ``timings[key]``."""
        t0 = time.perf_counter()
        result = stage()
        self.timings[key] = time.perf_counter() - t0
        return result


@dataclass(frozen=True)
class _Blend:
    """One 50 % blend of the walk and the run."""

    stem: str
    label: str
    result: BlendResult
    path: Path


@dataclass(frozen=True)
class _Blends:
    """The blend inputs (the repeated walk and run, as read) and their blends by every method."""

    a: Motion
    b: Motion
    runs: tuple[_Blend, ...]

    @property
    def prepared(self) -> tuple[Motion, ...]:
        """The two inputs as blended (prepared: metres, placed like the walk)."""
        return self.runs[0].result.prepared.motions

    @property
    def lie_warp(self) -> BlendResult:
        """The Lie group blend with the time warp."""
        return next(r.result for r in self.runs if r.stem == "lie_warp")


@dataclass(frozen=True)
class _Loop:
    """One clip made seamless, and its seam before and after."""

    key: str
    label: str
    original: Motion
    result: LoopResult
    before: SeamMetrics
    after: SeamMetrics


def _blends(run: _Run) -> _Blends:
    """The walk x run blends by every method (paper 001 Fig. 5, paper 000), and the inputs."""
    inputs = {}
    for key, fname, label, cycles in _BLEND_INPUTS:
        inputs[key] = repeat_motion(run.read(fname), cycles).replace(name=label)
    a, b = inputs["walk"], inputs["run"]
    blends = []
    for n, (stem, method, warp, lm, label) in enumerate(_METHODS):
        run.progress("blends", n, len(_METHODS))
        # each method as named: no contact-guided warp replacing the plain one
        res = blend_motions(
            [a, b], 0.5, method=method, warp=warp, landmarks=lm, metrics=True, contact_warp="off"
        )
        path = run.out / "blends" / f"walk_run_{stem}.bvh"
        run.write_bvh(res.motion, path, f"50 % blend of walk and run: {label}")
        blends.append(_Blend(stem, label, res, path))
    run.progress("blends", len(_METHODS), len(_METHODS))
    out = _Blends(a, b, tuple(blends))
    for k, (key, what) in enumerate((("walk", "input A: the walk"), ("run", "input B: the run"))):
        path = run.out / "blends" / f"input_{key}.bvh"
        run.write_bvh(out.prepared[k], path, f"{what}, as blended (prepared: metres, placed like the walk)")
    return out


def _loops(run: _Run) -> list[_Loop]:
    """The cartwheel and the backflip made seamless, with 3-cycle previews."""
    loops = []
    for n, (key, fname, label) in enumerate(_LOOP_INPUTS):
        run.progress("loops", n, len(_LOOP_INPUTS))
        m = run.read(fname)
        res = loop_motion(m, window=None, force=True)  # paper 000's loop of a whole clip that does not repeat
        before = seam_metrics(m, joints=list(res.closed_joints))
        after = seam_metrics(res.motion, original=m, joints=list(res.closed_joints))
        folder = run.out / "loops"
        run.write_bvh(
            res.motion, folder / f"{key}_loop.bvh", f"{label} made seamless: one cycle, to loop in a player"
        )
        run.write_bvh(
            repeat_motion(res.motion, 3),
            folder / f"{key}_loop.repeat3.bvh",
            f"{label} made seamless, played 3 times",
        )
        run.write_bvh(
            repeat_motion(m, 3),
            folder / f"{key}_original.repeat3.bvh",
            f"the original {label} played 3 times (it jumps at each seam)",
        )
        loops.append(_Loop(key, label, m, res, before, after))
    run.progress("loops", len(_LOOP_INPUTS), len(_LOOP_INPUTS))
    return loops


def _distances(run: _Run) -> DistanceTable:
    """Elastic distances between the clips: distances.csv and distances.png."""
    clips = [run.read(f).replace(name=k) for k, f in _DISTANCE_INPUTS]
    table = distance_table(clips, labels=[k for k, _ in _DISTANCE_INPUTS], progress=run.progress)
    csv_path = run.out / "distances.csv"
    rows = [["", *table.labels]]
    rows += [[lab, *(f"{x:.4f}" for x in row)] for lab, row in zip(table.labels, table.matrix, strict=True)]
    atomic_write_text(csv_path, csv_text(rows))
    png = plot_distance_matrix(
        table.matrix, list(table.labels), run.out / "distances.png", title="Lie elastic distances"
    )
    run.files += [csv_path, Path(png)]
    return table


def _figures(run: _Run, blends: _Blends, loops: list[_Loop]) -> tuple[dict[str, Path], AlignResult]:
    """Foot trajectories, the warp, SO(3) curves on the sphere, the seams; and the alignment
    of the warp figure."""
    run.progress("figures", 0, 5)
    pa, pb = blends.prepared
    folder = run.out / "figures"
    figs = {"feet": folder / "blend_feet.png"}
    plot_foot_trajectories(
        [pa, pb] + [r.result.motion for r in blends.runs],
        figs["feet"],
        labels=["A: walk", "B: run"] + [r.label for r in blends.runs],
        ncols=4,
        title="Feet (left blue, right orange) of the inputs and of the 50 % blends",
    )
    al = align_motions(blends.a, blends.b, landmarks="auto")
    figs["warp"] = folder / "blend_warp.png"
    plot_warp(al, figs["warp"])
    figs["sphere"] = folder / "blend_sphere.png"
    joint = "right_hip"
    plot_so3_curves(
        [joint_rotation_curve(m, joint) for m in (pa, pb, blends.lie_warp.motion)],
        figs["sphere"],
        labels=["walk", "run", "Lie blend + warp"],
        vectors=((0.0, -1.0, 0.0),),
        title="right hip rotation: the thigh direction on the sphere",
    )
    run.progress("figures", 3, 5)
    for lp in loops:
        figs[f"seam_{lp.key}"] = folder / f"loop_{lp.key}_seam.png"
        plot_seam(
            lp.original,
            lp.result.motion,
            figs[f"seam_{lp.key}"],
            title=f"DeepMimic {lp.label}: 3 cycles before / after closing",
        )
    run.files += list(figs.values())
    run.progress("figures", 5, 5)
    return figs, al


def _videos(run: _Run, blends: _Blends, loops: list[_Loop], mp4: bool) -> dict[str, list[Path]]:
    """The skeleton animations (GIF, and MP4 when asked)."""
    pa, pb = blends.prepared
    jobs = [
        (
            "blend_inputs",
            [pa, pb, blends.lie_warp.motion, blends.runs[0].result.motion],
            ["A: walk", "B: run", "Lie + warp (50 %)", "Euler linear (50 %)"],
            dict(panel_size=(240, 240)),
        ),
        (
            "blend_methods",
            [r.result.motion for r in blends.runs],
            [r.label for r in blends.runs],
            dict(panel_size=(200, 220)),
        ),
    ]
    for lp in loops:
        jobs.append(
            (
                f"loop_{lp.key}",
                [repeat_motion(lp.original, 3), repeat_motion(lp.result.motion, 3)],
                [f"{lp.label} x3, original", f"{lp.label} x3, looped"],
                dict(panel_size=(240, 240), fps=20.0),
            )
        )
    videos: dict[str, list[Path]] = {}
    for n, (key, motions, labels, kw) in enumerate(jobs):
        run.progress("videos", n, len(jobs))
        paths = [run.out / "videos" / f"{key}.gif"]
        if mp4:
            paths.append(run.out / "videos" / f"{key}.mp4")
        render_animation(motions, paths[0], also=paths[1:], labels=labels, **kw)
        run.files += paths
        videos[key] = paths
    run.progress("videos", len(jobs), len(jobs))
    return videos


def _viewers(run: _Run, blends: _Blends, loops: list[_Loop]) -> list[str]:
    """The interactive 3D viewers (plotly.js beside the page); none without plotly."""
    try:
        lib = run.out / "plotly.min.js"
        atomic_write_text(lib, plotly_js())
    except ModuleNotFoundError:  # plotly is not installed: the page keeps its pictures only
        return []
    run.files.append(lib)
    pa, pb = blends.prepared
    lie = blends.lie_warp
    lp = loops[0]
    return [
        build_viewer(
            [pa, pb, lie.motion],
            labels=["walk", "run", "Lie + warp (50 %)"],
            reports=[False, False, jsonable(lie.summary())],
            plotly_src=lib.name,
            title="Walk, run and their Lie blend with the time warp",
            element_id="viewer-blend",
        ).fragment,
        build_viewer(
            [repeat_motion(lp.original, 2), repeat_motion(lp.result.motion, 2)],
            labels=[f"{lp.label} x2, original", f"{lp.label} x2, looped"],
            reports=[False, jsonable(lp.result.summary())],
            plotly_src=lib.name,
            title=f"The {lp.label}, played twice: original and looped (seams and contacts marked)",
            element_id="viewer-loop",
        ).fragment,
    ]


def _report(
    run: _Run, blends: _Blends, loops: list[_Loop], table: DistanceTable, al: AlignResult
) -> dict[str, Any]:
    """The content of report.json (its timings are added last)."""
    rep = report_header("demo", [str(run.data)], [run.rel(p) for p in run.files])
    rep["data"] = str(run.data)
    rep["blends"] = [{"file": run.rel(r.path), "label": r.label, **r.result.summary()} for r in blends.runs]
    rep["loops"] = [
        {
            "clip": lp.key,
            "closed_joints": list(lp.result.closed_joints),
            "heading_change_rad": lp.result.heading_change,
            "seam_before": lp.before.summary(),
            "seam_after": lp.after.summary(),
            "closing_iterations": lp.result.closing.iterations,
        }
        for lp in loops
    ]
    rep["distances"] = table.summary()
    rep["alignment"] = al.summary()
    return rep


# ------------------------------------------------------------------------------------------
# index.html
# ------------------------------------------------------------------------------------------

_CSS = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1250px;
       color: #222; line-height: 1.45; }
h1 { font-size: 1.6em; } h2 { font-size: 1.25em; margin-top: 2em; border-bottom: 1px solid #ddd; }
img { max-width: 100%; border: 1px solid #eee; }
table { border-collapse: collapse; font-size: 0.9em; margin: 0.8em 0; }
td, th { border: 1px solid #ddd; padding: 0.25em 0.6em; text-align: right; }
th { background: #f5f5f5; } td:first-child, th:first-child { text-align: left; }
.row { display: flex; flex-wrap: wrap; gap: 1em; align-items: flex-start; }
.row > figure { margin: 0; flex: 1 1 380px; } figcaption { font-size: 0.85em; color: #555; }
code { background: #f3f3f3; padding: 0 0.2em; } .note { color: #666; font-size: 0.9em; }
.legend { border: 1px solid #ddd; background: #fafafa; padding: 0.4em 1em; font-size: 0.9em; }
.legend dt { font-weight: 600; margin-top: 0.5em; } .legend dd { margin-left: 1.2em; }
.swatch { display: inline-block; width: 1.6em; height: 0.55em; vertical-align: middle;
          margin-right: 0.3em; border: 1px solid #ccc; }
.swatch.line { height: 0.22em; border: none; }
"""


def _viewer_head() -> str:
    return f"<script src='plotly.min.js'></script><style>{VIEWER_CSS}</style>"


def _img(out: Path, p: Path, caption: str) -> str:
    return (
        f'<figure><img src="{html.escape(p.relative_to(out).as_posix())}" alt="{html.escape(caption)}">'
        f"<figcaption>{html.escape(caption)}</figcaption></figure>"
    )


def _video(out: Path, paths: Sequence[Path], caption: str) -> str:
    gif = next((p for p in paths if p.suffix == ".gif"), None)
    mp4 = next((p for p in paths if p.suffix == ".mp4"), None)
    body = _img(out, gif, caption) if gif is not None else ""
    if mp4 is not None:
        body = body.replace(
            "</figcaption>",
            f' (<a href="{html.escape(mp4.relative_to(out).as_posix())}">MP4</a>)</figcaption>',
        )
    return body


def _f(x: Any, d: int = 3) -> str:
    try:
        return f"{float(x):.{d}g}"
    except (TypeError, ValueError):
        return html.escape(str(x))


def _swatch(colour: str, what: str, *, line: bool = False, dashed: bool = False) -> str:
    """A coloured sample and what it means."""
    style = f"background: {colour};"
    if dashed:
        style = f"background: repeating-linear-gradient(90deg, {colour} 0 5px, transparent 5px 8px);"
    cls = "swatch line" if line or dashed else "swatch"
    return f'<span class="{cls}" style="{style}" title="{html.escape(colour)}"></span>{html.escape(what)}'


def _legend() -> str:
    """How to read the colours and lines of the pictures (the drawing code's palette)."""

    def item(*parts: str) -> str:
        return "<dd>" + "; ".join(parts) + "</dd>"

    return "\n".join(
        [
            "<div class='legend' id='legend'><h3>How to read the pictures</h3><dl>",
            "<dt>Skeleton videos</dt>",
            item(
                _swatch(LEFT, "left limbs"),
                _swatch(RIGHT, "right limbs"),
                _swatch(CENTRE, "spine, neck and head"),
            ),
            item(
                _swatch(LEFT, "left ankle over the last second", line=True),
                _swatch(RIGHT, "right ankle over the last second", line=True),
            ),
            item(
                _swatch(
                    FLOOR,
                    "the floor, seen from slightly above (its front edge is a grey line; a "
                    "tick every 0.5 m shows the travel)",
                ),
                "the clock under each panel: seconds",
            ),
            item(
                "panel titles: <b>A: walk</b> is input A, <b>B: run</b> is input B, the other panels are "
                "the 50 % blends (the method in the title); in the loop videos, the original clip and the "
                "looped one"
            ),
            "<dt>Foot trajectories</dt>",
            item(
                _swatch(LEFT, "left foot", line=True),
                _swatch(RIGHT, "right foot", line=True),
                _swatch(GHOST, "a few poses of the whole body"),
                "axes in metres",
            ),
            "<dt>Time warp</dt>",
            item(
                _swatch(
                    WARP,
                    "the optimal warp: time in A (walk) against the matched time in B (run), seconds",
                    line=True,
                ),
                _swatch(UNIFORM, "no warp (uniform)", dashed=True),
                "black crosses: landmarks",
            ),
            "<dt>Curves on the sphere</dt>",
            item(
                _swatch(CURVES[0], "input A (walk)", line=True),
                _swatch(CURVES[1], "input B (run)", line=True),
                _swatch(CURVES[2], "the Lie blend with warp", line=True),
                "a dot marks each start",
            ),
            "<dt>Loop seams</dt>",
            item(
                _swatch(TRACE[0], "the right ankle's path", line=True),
                _swatch(TRACE[1], "the left hand's (or elbow's) path", line=True),
                "black circles: where a cycle's last frame puts the joint; red crosses: where the next "
                "cycle starts (they coincide for a seamless loop)",
            ),
            item(
                "close-up: " + _swatch(LEFT, "the last 3 frames of a cycle"),
                _swatch(RIGHT, "the first 3 frames of the next one"),
            ),
            "</dl></div>",
        ]
    )


@dataclass(frozen=True)
class _Page:
    """What index.html shows."""

    out: Path
    blends: _Blends
    loops: list[_Loop]
    table: DistanceTable
    figs: dict[str, Path]
    videos: dict[str, list[Path]]
    timings: dict[str, float]
    bvh_files: list[tuple[Path, str]]
    viewers: list[str]


def _html(page: _Page) -> str:
    """index.html: the results side by side, with short explanations (module docstring)."""
    parts = [
        *_head(page),
        *_blend_section(page),
        *_loop_section(page),
        *_distance_section(page),
        *_files_section(page),
        _reproduce(page),
    ]
    return "\n".join(parts)


def _head(page: _Page) -> list[str]:
    """The page's head, introduction, legend and the interactive viewers."""
    return [
        "<!doctype html><html><head><meta charset='utf-8'><title>elastic-motion demo</title>",
        f"<style>{_CSS}</style>",
        _viewer_head() if page.viewers else "",
        "</head><body>",
        "<h1>elastic-motion demo</h1>",
        "<p>Everything on this page was computed on this machine from the DeepMimic motion clips that "
        "ship with the <code>pybullet</code> package (MIT licence). Motions are curves in "
        "R<sup>3</sup> &times; SO(3)<sup>J</sup> (root position and one rotation per joint); the square "
        "root velocity transform (SRVT) turns them into functions in a vector space where blends are "
        "straight lines and distances are L2 distances, after the optimal time warp. The BVH files beside "
        "this page open in Blender and three.js (<a href='#files'>list of files</a>).</p>",
        _legend(),
        *(
            [
                "<h2>See it move</h2><p>Interactive 3D players (drag to orbit, scroll to zoom, play or "
                "scrub with the slider, pick joints to draw their paths). The blend's time warp is "
                "linked to the player; the loop's seams and the feet's contacts come from its report.</p>",
                *page.viewers,
            ]
            if page.viewers
            else []
        ),
    ]


def _blend_section(page: _Page) -> list[str]:
    """Section 1: the walk x run blends, their videos, feet, table, warp and sphere."""
    e = html.escape
    out, videos, figs = page.out, page.videos, page.figs
    parts = [
        "<h2>1. Blending a walk and a run</h2>",
        "<p>A walk (2 cycles, 2.5 s, 4 steps) and a run (3 cycles, 2.4 s, 6 steps) have different rhythms "
        "and numbers of steps, the hard case of paper 001 Fig. 5. Each blend is 50 % of each, computed by "
        "the four methods of paper 001 (Euler angles: linear; elastic; elastic with the optimal time warp; "
        "with the warp and landmarks: the left knee passing the right knee, paired in order) and by the Lie "
        "group method of paper 000 without and with the warp. The run is first turned and moved to run "
        "where the walk goes. Read the table with the pictures: without a warp the elastic blends mix "
        "steps out of phase and their feet slide most; the linear Euler blend slides little here but is "
        "the farthest from the walk (it looks mostly like the run); with the warp the blends sit near the "
        "middle between walk and run. Four steps cannot be matched to six one by one, so the warp "
        "compresses part of the run (the steep section of the warp plot) and the feet slide there.</p>",
    ]
    if "blend_inputs" in videos:
        parts.append(
            "<div class='row'>"
            + _video(
                out, videos["blend_inputs"], "the inputs, the Lie blend with warp and the linear Euler blend"
            )
            + "</div><div class='row'>"
            + _video(out, videos["blend_methods"], "all six blends side by side")
            + "</div>"
        )
    parts.append("<div class='row'>" + _img(out, figs["feet"], "foot trajectories (side view)") + "</div>")
    parts.append(
        "<table><tr><th>method</th><th>file</th><th>frames</th><th>foot sliding (m/s)</th>"
        "<th>distance to walk</th><th>distance to run</th></tr>"
    )
    metrics0 = page.blends.runs[0].result.metrics.summary()
    slide_in = metrics0["foot_sliding"]["inputs"]
    parts.append(
        f"<tr><td>inputs</td><td></td><td></td><td>walk {_f(slide_in[0]['mean_speed_m_s'])}, run "
        f"{_f(slide_in[1]['mean_speed_m_s'])}</td><td colspan=2>walk to run: "
        f"{_f(metrics0['distances']['between_inputs'][0][1])}</td></tr>"
    )
    for b in page.blends.runs:
        met = b.result.metrics.summary()
        d = met["distances"]["result_to_inputs"]
        href = e(b.path.relative_to(out).as_posix())
        parts.append(
            f"<tr><td>{e(b.label)}</td><td><a href='{href}'>{e(b.path.name)}</a></td>"
            f"<td>{b.result.motion.n_frames}</td><td>{_f(met['foot_sliding']['result']['mean_speed_m_s'])}</td>"
            f"<td>{_f(d[0])}</td><td>{_f(d[1])}</td></tr>"
        )
    parts.append(
        "</table><p class='note'>Foot sliding: mean horizontal speed of the foot joints while they are "
        "within 5 cm of their lowest height (compare with the inputs' own values: the measure is coarse). "
        "Distances: "
        "Lie elastic distance of the result to each input; a blend on the SRV geodesic with the warp sits at "
        "half the walk-run distance from each.</p>"
    )
    parts.append(
        "<div class='row'>"
        + _img(out, figs["warp"], "the optimal time warp (Lie, with landmarks), seconds of the walk -> run")
        + _img(
            out,
            figs["sphere"],
            "SO(3) curves on the sphere (paper 000 Fig. 2): the right hip of walk, run, blend",
        )
        + "</div>"
    )
    return parts


def _loop_section(page: _Page) -> list[str]:
    """Section 2: the seamless loops, their videos, seams and table."""
    e = html.escape
    out = page.out
    parts = [
        "<h2>2. Seamless loops</h2><p>Played three times in a row, the original cartwheel and backflip "
        "jump at each seam: their last frame is not their first. Closing the curve in R<sup>3</sup> &times; "
        "SO(3)<sup>J</sup> (paper 000, sec. 4, Gauss-Newton) moves the whole clip a little so that it ends "
        "where it starts, keeping the displacement and turn of one cycle (the character travels on).</p>"
    ]
    for lp in page.loops:
        if f"loop_{lp.key}" in page.videos:
            parts.append(
                "<div class='row'>"
                + _video(out, page.videos[f"loop_{lp.key}"], f"{lp.label}: original and looped, 3 cycles")
                + "</div>"
            )
        parts.append(
            "<div class='row'>"
            + _img(out, page.figs[f"seam_{lp.key}"], f"{lp.label}: the seam before and after")
            + "</div>"
        )
    parts.append(
        "<table><tr><th>clip</th><th>largest joint angle at the seam (deg)</th><th>largest position jump (m)"
        "</th><th>largest change of the clip (m)</th><th>iterations</th></tr>"
    )
    for lp in page.loops:
        before, after = lp.before, lp.after
        parts.append(
            f"<tr><td>{e(lp.key)}</td>"
            f"<td>{_f(before.seam_angle_max_deg)} &rarr; {_f(after.seam_angle_max_deg)}</td>"
            f"<td>{_f(before.seam_position_max_m)} &rarr; {_f(after.seam_position_max_m)}</td>"
            f"<td>{_f(after.deviation_max_m or 0)}</td><td>{lp.result.closing.iterations}</td></tr>"
        )
    parts.append("</table>")
    return parts


def _distance_section(page: _Page) -> list[str]:
    """Section 3: the distance matrix and table."""
    e = html.escape
    out, table = page.out, page.table
    parts = [
        "<h2>3. Distances between motions</h2><p>Elastic distances of the clips' SRV functions after the "
        "optimal time warp (each clip's duration normalised): similar motions are close (walks, runs), "
        "acrobatics far from everything. This is the basis of search and classification "
        "(<code>elastic-motion matrix</code> scales it to databases).</p>",
        "<div class='row'>"
        + _img(out, page.figs.get("distances", out / "distances.png"), "distance matrix")
        + "</div>",
        "<table><tr><th></th>" + "".join(f"<th>{e(x)}</th>" for x in table.labels) + "</tr>",
    ]
    for lab, row in zip(table.labels, table.matrix, strict=True):
        parts.append(f"<tr><td>{e(lab)}</td>" + "".join(f"<td>{x:.2f}</td>" for x in row) + "</tr>")
    parts.append("</table>")
    return parts


def _files_section(page: _Page) -> list[str]:
    """The list of every motion written."""
    if not page.bvh_files:
        return []
    e = html.escape

    def link(p: Path) -> str:
        rel = e(p.relative_to(page.out).as_posix())
        return f"<a href='{rel}'>{rel}</a>"

    return [
        "<h2 id='files'>Files</h2><p>Every motion written by this run (BVH, open in Blender or "
        "three.js); <a href='report.json'>report.json</a> holds the numbers, "
        "<a href='distances.csv'>distances.csv</a> the distance table.</p><ul>",
        *[f"<li>{link(p)}: {e(what)}</li>" for p, what in page.bvh_files],
        "</ul>",
    ]


def _reproduce(page: _Page) -> str:
    """The commands that reproduce the page, and the run's timings."""
    return (
        "<h2>Reproduce</h2><p><code>elastic-motion blend A.bvh B.bvh -o out.bvh --method lie --warp dp "
        "--json report.json</code>, <code>elastic-motion loop clip.bvh -o loop.bvh --repeat 3</code>, "
        "<code>elastic-motion distance A B C</code>, <code>elastic-motion render A B -o cmp.gif</code>; "
        "see <code>docs/cli.md</code>. Timings of this run: "
        + ", ".join(f"{k.replace('_s', '')} {v:.1f} s" for k, v in page.timings.items())
        + ".</p></body></html>\n"
    )
