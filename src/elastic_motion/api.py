"""The notebook face of the package: read, blend, loop, align, compare and write in a few calls.

``import elastic_motion as em`` exposes every name here (loaded on first use, so that the
command line starts fast). Each function is the one the command line calls, with the same
defaults, so a notebook and ``elastic-motion`` give the same numbers for the same files::

    import elastic_motion as em

    res = em.blend(["walk.bvh", "run.bvh"], 0.5, warp="dp")   # paths or Motion objects
    em.write(res, "walk_run.bvh")          # in the first input's length unit
    print(em.to_json(res))                 # the report the CLI's --json writes (without header)

Inputs may be paths or :class:`~elastic_motion.motion.Motion` objects; both go through the
one preparation step (:mod:`elastic_motion.apps.prepare`: T-pose frame, trim, static root,
metres, Y-up, joints, placement), set with ``prepare=em.PrepareOptions(...)``. How warps are
found is one :class:`~elastic_motion.warp.WarpOptions` (``warp="dp"`` is short for
``em.WarpOptions(method="dp")``).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from elastic_motion.apps.align import AlignResult, align_motions
from elastic_motion.apps.blend import BlendResult, blend_motions
from elastic_motion.apps.blend_options import BlendOptions
from elastic_motion.apps.blendspace import BlendSpace, blendspace
from elastic_motion.apps.blendspace2d import BlendSpace2D, blendspace_2d
from elastic_motion.apps.cleanup import CleanupOptions, CleanupResult, cleanup_footskate
from elastic_motion.apps.cycles import gait_cycles
from elastic_motion.apps.database import (  # motion databases (issue 15)
    Classification,
    Clustering,
    MatrixOptions,
    MatrixResult,
    MeanMotionResult,
    MeanOptions,
    MotionIndex,
    SearchResult,
    WithinResult,
    build_index,
    classify_motions,
    cluster_motions,
    compute_matrix,
    find_within,
    knn_search,
    mean_motion,
)
from elastic_motion.apps.distance import DistanceTable, distance_table
from elastic_motion.apps.landmark_detection import LandmarkReport, detect_landmarks
from elastic_motion.apps.landmark_files import LandmarkFile, read_landmark_file
from elastic_motion.apps.loop import (
    KeptContacts,
    LoopOptions,
    LoopRefused,
    LoopResult,
    loop_motion,
    repeat_loop,
)
from elastic_motion.apps.loop.limits import joint_limit_report
from elastic_motion.apps.metrics import BlendMetrics, SeamMetrics, blend_metrics, seam_metrics
from elastic_motion.apps.pca import MotionPCA, motion_pca
from elastic_motion.apps.prepare import (
    MotionPreparation,
    PreparedMotions,
    PrepareOptions,
    Source,
    load_motion,
    output_motion,
    prepare_motions,
)
from elastic_motion.apps.render_files import RenderResult, render_motions
from elastic_motion.apps.report import jsonable, report_json
from elastic_motion.apps.viewer import ViewerOptions, ViewerPage, build_viewer
from elastic_motion.errors import OptionError
from elastic_motion.motion import UNITS, Motion, read_motion, write_motion
from elastic_motion.motion.contacts import ContactOptions
from elastic_motion.motion.looping import repeat_motion
from elastic_motion.notes import Note
from elastic_motion.warp import WarpOptions

__all__ = [
    "AlignResult",
    "BlendMetrics",
    "BlendOptions",
    "BlendResult",
    "BlendSpace",
    "BlendSpace2D",
    "Classification",
    "CleanupOptions",
    "CleanupResult",
    "Clustering",
    "ContactOptions",
    "DistanceTable",
    "KeptContacts",
    "LandmarkFile",
    "LandmarkReport",
    "LoopOptions",
    "LoopRefused",
    "LoopResult",
    "MatrixOptions",
    "MatrixResult",
    "MeanMotionResult",
    "MeanOptions",
    "Motion",
    "MotionIndex",
    "MotionPCA",
    "MotionPreparation",
    "Note",
    "PrepareOptions",
    "PreparedMotions",
    "RenderResult",
    "SeamMetrics",
    "SearchResult",
    "ViewerOptions",
    "ViewerPage",
    "WarpOptions",
    "WithinResult",
    "align",
    "blend",
    "blend_metrics",
    "blendspace",
    "blendspace_2d",
    "build_index",
    "classify",
    "cleanup_footskate",
    "cluster",
    "detect_landmarks",
    "distance",
    "distances",
    "find_within",
    "gait_cycles",
    "joint_limits",
    "load",
    "loop",
    "matrix",
    "mean",
    "pca",
    "prepare",
    "read",
    "read_landmarks",
    "render",
    "repeat",
    "seam_metrics",
    "search",
    "to_json",
    "view",
    "write",
]

#: ``em.read(path, units=..., up_axis=...)``: a motion file as it is, no preparation.
read = read_motion
#: ``em.load(source, options)``: one input through the per-input preparation steps.
load = load_motion
#: ``em.prepare(sources, options)``: inputs made comparable (the step every app runs first).
prepare = prepare_motions
#: ``em.blend(motions, weights, options=BlendOptions(...), **overrides)`` (``method=``, ``warp=``,
#: ``landmarks=``, ``prepare=``, ``contacts=``, ``metrics=``...).
blend = blend_motions
#: ``em.blendspace(motions, params="speed", one_cycle=)``: motions placed by a parameter,
#: aligned to one template; ``.at(p)`` blends any parameter (a BlendResult).
#: ``em.blendspace_2d(motions, params=("speed", "turn"))``: placed on a plane (m/s x deg/s, or
#: given points), triangulated; ``.at((x, y))`` blends the containing triangle, corrected to
#: meet the point.
#: ``em.cleanup_footskate(motion, contacts)``: plant contacts by leg IK (blends do it by default).
#: ``em.gait_cycles(motion)``: heel strike to heel strike, from the contacts.
#: ``em.loop(motion, options=LoopOptions(...), **overrides)`` (``root=``, ``seam=``, ``method=``,
#: ``solver=``, ``window=``, ``contacts=``, ``change_bound=``, ``force=``...): ``window="safe"``
#: (default) the whole clip when its loop changes it by at most ``change_bound``, else the best
#: cycle (``"auto"``); a loop that changes more or adds skids raises ``LoopRefused`` unless
#: ``force=True``; ``contacts="keep"`` plants contacts.
loop = loop_motion
#: ``em.joint_limits(motion, limits=None)``: DOF angles beyond / at their ASF limits
#: (``loop(joint_limits="keep")`` keeps the loop within the limits the input respects).
joint_limits = joint_limit_report
#: ``em.align(a, b, method=, warp=, landmarks=, prepare=)``: the warp of B onto A.
align = align_motions
#: ``em.read_landmarks(path, inputs=[a, b])``: a landmarks file (the report of
#: ``elastic-motion landmarks A B --json``, or pairs); ``em.blend(..., landmarks=lm)`` meets
#: its pairs with the weight it records, as ``blend --landmarks FILE`` does.
read_landmarks = read_landmark_file
#: ``em.distances(motions, method=, warp=, prepare=)``: all pairwise distances (DistanceTable).
distances = distance_table
#: ``em.view(motions, reports=, layout=)``: the interactive 3D player (``.html``; ``em.write``
#: does not take it: ``Path(...).write_text(page.html)``).
view = build_viewer
#: ``em.search(query, database, k=5, method="lie")``: the exact k nearest motions (bounds prune
#: the DPs); ``database``: files/folders, a ``matrix`` folder or an index (``em.build_index``).
search = knn_search
#: ``em.pca(files, method=, warp=)``: mean and principal modes of aligned motions (MotionPCA:
#: ``.motion_at(z)``, ``.sample(n)``, ``.explained``).
pca = motion_pca
#: ``em.matrix(files, out_dir, settings, options=MatrixOptions(...))``: all-pairs distances of
#: a database, resumable (the ``matrix`` command; MatrixResult).
matrix = compute_matrix
#: ``em.classify(matrix, labels, k=1)``: leave-one-out k-NN accuracy (the ``classify`` command).
classify = classify_motions
#: ``em.mean(files, options=MeanOptions(...))``: the Karcher mean of motions as a motion (the
#: ``mean`` command; MeanMotionResult).
mean = mean_motion
#: ``em.cluster(matrix, linkage="average", n_clusters=)``: hierarchical clustering (the
#: ``cluster`` command; Clustering, ``.plot(path)`` the dendrogram).
cluster = cluster_motions
#: ``em.render(sources, path, kind="auto")``: pictures and videos (the ``render`` command).
render = render_motions
# (``em.detect_landmarks(a, b=None, kinds=)``, imported above under its own name: events of a
# motion, paired by phase with those of a second; the ``landmarks`` command, LandmarkReport.)


def distance(
    a: Source,
    b: Source,
    *,
    method: str = "lie",
    warp: str | WarpOptions | None = None,
    prepare: PrepareOptions | None = None,
) -> float:
    """Elastic distance of two motions (the ``[0, 1]`` entry of :func:`distances`).

    Parameters
    ----------
    a, b : path or Motion
    method : {"lie", "euler-elastic"}
    warp : str or WarpOptions, optional
        Default ``WarpOptions()``; ``"none"`` gives the distance without warp.
    prepare : PrepareOptions, optional

    Returns
    -------
    float
        In the SRV metric of the representation (dimensionless for ``"lie"`` with the
        default weights).
    """
    return float(distance_table([a, b], method=method, warp=warp, prepare=prepare).matrix[0, 1])


def repeat(motion: Motion | LoopResult, cycles: int = 3, root: str | None = None) -> Motion:
    """A loop played ``cycles`` times (``loop --repeat``).

    Parameters
    ----------
    motion : LoopResult or Motion
        A result of :func:`loop`: played with its own ``root`` mode (unless ``root`` is
        given) and returned in its output unit (the first input's), so ``em.write`` writes
        the file ``loop --repeat`` writes (:func:`elastic_motion.apps.loop.repeat_loop`).
        A Motion: played as it is (:func:`elastic_motion.motion.looping.repeat_motion`, root
        ``"travel"`` by default), in its own unit.
    cycles : int
    root : {"travel", "inplace"}, optional
    """
    if isinstance(motion, LoopResult):
        return repeat_loop(motion, cycles, root)
    if not isinstance(motion, Motion):
        raise OptionError("motion", f"expected a LoopResult or a Motion; got {type(motion).__name__}")
    return repeat_motion(motion, cycles, "travel" if root is None else root)


def write(
    result: Motion | BlendResult | LoopResult,
    path: str | os.PathLike[str],
    *,
    units: str | None = None,
    protected: Sequence[str | os.PathLike[str]] = (),
) -> Path:
    """Write a motion or an app's result as BVH or glTF, atomically, in the documented unit.

    Parameters
    ----------
    result : Motion, BlendResult or LoopResult
        A result is written in its first input's length unit (the command line's rule,
        :attr:`PreparedMotions.units_out`); a Motion in its own unit.
    path : path
        ``.bvh``, ``.gltf`` or ``.glb`` destination (:func:`elastic_motion.motion.write_motion`;
        glTF is always metres); never one of the inputs (refused).
    units : str, optional
        Force the output unit (``"m"``, ``"cm"``, ``"mm"``, ``"inch"``, ``"cmu"``).
    protected : sequence of paths
        More files that must not be overwritten.

    Returns
    -------
    pathlib.Path
    """
    if units is not None and units not in UNITS:
        raise OptionError("units", f"expected one of {sorted(UNITS)}; got {units!r}")
    if isinstance(result, BlendResult | LoopResult):
        motion, prepared = result.motion, result.prepared
        target = UNITS[units] if units is not None else prepared.units_out
        sources = [r.source for r in prepared.inputs if r.source is not None]
    elif isinstance(result, Motion):
        motion, target, sources = result, (UNITS[units] if units is not None else None), []
    else:
        raise OptionError(
            "result", f"expected a Motion, BlendResult or LoopResult; got {type(result).__name__}"
        )
    return write_motion(output_motion(motion, target), path, protected=[*sources, *protected])


def to_json(result: Any) -> str:
    """A result as the JSON text of its report (``summary()`` when it has one), strict JSON."""
    body = result.summary() if hasattr(result, "summary") else jsonable(result)
    return report_json(body if isinstance(body, dict) else {"value": body})
