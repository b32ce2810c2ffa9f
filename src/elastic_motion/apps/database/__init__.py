"""All-pairs elastic distances over a motion database: the package's face.

Everything a user needs is importable from here (``from elastic_motion.apps.database import
compute_matrix``); each submodule does one job:

============== ===========================================================================
``files``      finding motion files in files and folders (:func:`find_motion_files`)
``settings``   what determines the numbers (:class:`DatabaseSettings`) and its JSON form
``preparation`` one motion to the database's common form (:func:`prepare_motion`), on top
               of the library's one preparation step (:func:`elastic_motion.apps.prepare.load_motion`)
``cache``      the SRV arrays of every motion, grouped by skeleton (:class:`SRVCache`)
``tiles``      pair distances and tiles of pairs, the numerical work (:func:`pair_distance`)
``engines``    where tiles run: serial, Dask ``LocalCluster``, Dask scheduler
``storage``    the output folder: file names, atomic writes, ``names.csv``
``matrix``     the resumable run (:func:`compute_matrix`)
``results``    reading a matrix back (:func:`load_matrix`)
``query``      one motion against a database (:func:`query_distances`), exact k nearest
               with pruning (:func:`knn_search`)
``bounds``     cheap lower/upper bounds of the elastic distance (:func:`lower_bounds`)
``index``      an on-disk index of SRV arrays and bounds (:func:`build_index`)
``partial``    where a short query happens inside long takes (:func:`find_within`)
``jointmap``   joint-name maps onto a common body (:func:`map_to_common_body`, ``joints="map"``)
``classify``   leave-one-out k-NN classification of a matrix's motions (:func:`classify_motions`)
``clustering`` hierarchical clustering of a matrix's motions (:func:`cluster_motions`)
``mean``       the Karcher mean of motion files, as a motion (:func:`mean_motion`)
============== ===========================================================================

The commands ``matrix``, ``search``, ``classify``, ``mean`` and ``cluster`` of the command line
are :func:`compute_matrix`, :func:`knn_search` (:func:`find_within` with ``--within``),
:func:`classify_motions`, :func:`mean_motion` and :func:`cluster_motions`: the same options
give the same numbers.

Conventions
-----------
* **Motions -> SRV arrays.** Every readable input is prepared once (:mod:`.preparation`),
  low-passed as ``distance`` does (``warp.sample_smoothing``), resampled to
  ``n_samples + 1`` frames uniformly in time and transformed to SRV arrays
  ``q`` of shape ``(n_samples, D)`` on the grid ``linspace(0, 1, n_samples + 1)`` (each
  clip's duration normalised to 1), in the representations of
  :mod:`elastic_motion.motion.representations` (``LIE``: ``R^3 x SO(3)^J``, weights shared by
  a skeleton group; ``EULER``: root position in metres, Euler angles in radians), stored under
  their keys ``"lie"`` and ``"euler"``; see :mod:`.cache`.
* **Pair distance**: with ``WarpOptions(method="dp")`` (:data:`DEFAULT_WARP`) or
  ``WarpOptions()`` (``"dp+refine"``, ``distance``'s default) the elastic distance
  ``min_phi ||q_i - q_j * phi||_L2`` (:func:`elastic_motion.warp.optimal_warp`), with
  ``method="none"`` the distance of parametrised curves ``||q_i - q_j||_L2`` (paper 000,
  eq. 4). Only ``i < j`` is computed and mirrored; diagonal 0; ``+inf`` between skeleton
  groups (:mod:`.tiles`). Every engine and tiling gives the same matrix bit for bit.
* **Output folder** and resume: :mod:`.storage`, :mod:`.matrix`.

Numerical code here prints nothing; progress goes to an optional ``progress(stage, done,
total)`` callback.
"""

from __future__ import annotations

from elastic_motion.apps.database.bounds import lower_bounds, part_norms, upper_bound
from elastic_motion.apps.database.cache import SRVCache, build_srv_cache, srv_arrays
from elastic_motion.apps.database.classify import Classification, classify_motions
from elastic_motion.apps.database.clustering import Clustering, cluster_motions
from elastic_motion.apps.database.engines import ClusterUnavailableError
from elastic_motion.apps.database.files import MOTION_EXTENSIONS, find_motion_files
from elastic_motion.apps.database.index import MotionIndex, build_index, load_index
from elastic_motion.apps.database.jointmap import COMMON_JOINTS, detect_convention, map_to_common_body
from elastic_motion.apps.database.matrix import MatrixOptions, MatrixResult, compute_matrix, remove_run
from elastic_motion.apps.database.mean import MeanMotionResult, MeanOptions, mean_motion
from elastic_motion.apps.database.partial import PartialMatch, WithinResult, find_within
from elastic_motion.apps.database.preparation import (
    PreparedMotion,
    prepare_motion,
    restrict_to_common_joints,
)
from elastic_motion.apps.database.query import (
    QueryResult,
    SearchResult,
    is_stored_database,
    knn_search,
    query_distances,
)
from elastic_motion.apps.database.results import DistanceMatrix, load_matrix
from elastic_motion.apps.database.settings import DEFAULT_WARP, DatabaseSettings
from elastic_motion.apps.database.tiles import (
    compute_tile,
    distance_matrix,
    pair_distance,
    pair_distances,
    single_threaded_blas,
    tile_blocks,
)
from elastic_motion.apps.progress import Progress
from elastic_motion.warp import WarpOptions

__all__ = [
    "COMMON_JOINTS",
    "DEFAULT_WARP",
    "MOTION_EXTENSIONS",
    "Classification",
    "ClusterUnavailableError",
    "Clustering",
    "DatabaseSettings",
    "DistanceMatrix",
    "MatrixOptions",
    "MatrixResult",
    "MeanMotionResult",
    "MeanOptions",
    "MotionIndex",
    "PartialMatch",
    "PreparedMotion",
    "Progress",
    "QueryResult",
    "SRVCache",
    "SearchResult",
    "WarpOptions",
    "WithinResult",
    "build_index",
    "build_srv_cache",
    "classify_motions",
    "cluster_motions",
    "compute_matrix",
    "compute_tile",
    "detect_convention",
    "distance_matrix",
    "find_motion_files",
    "find_within",
    "is_stored_database",
    "knn_search",
    "load_index",
    "load_matrix",
    "lower_bounds",
    "map_to_common_body",
    "mean_motion",
    "pair_distance",
    "pair_distances",
    "part_norms",
    "prepare_motion",
    "query_distances",
    "remove_run",
    "restrict_to_common_joints",
    "single_threaded_blas",
    "srv_arrays",
    "tile_blocks",
    "upper_bound",
]
