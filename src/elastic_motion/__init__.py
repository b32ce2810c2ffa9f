"""elastic-motion: elastic shape analysis of curves in Lie groups for motion capture.

``import elastic_motion as em`` gives the notebook API of :mod:`elastic_motion.api`
(``em.read``, ``em.blend``, ``em.loop``, ``em.align``, ``em.distance``, ``em.write``...),
loaded on first use so that the command line starts fast. See ``docs/api.md``.

Layers (each depends only on the ones before it):
``groups`` -> ``curves`` -> ``warp`` -> ``closing`` -> ``motion`` -> ``apps``/``cli``.
See ``docs/architecture.md``.
"""

from importlib.metadata import PackageNotFoundError, version
from typing import Any

try:
    __version__ = version("elastic-motion")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+unknown"

_API = (
    "AlignResult",
    "BlendMetrics",
    "BlendResult",
    "DistanceTable",
    "LoopResult",
    "Motion",
    "MotionPreparation",
    "PrepareOptions",
    "PreparedMotions",
    "SeamMetrics",
    "WarpOptions",
    "align",
    "blend",
    "blend_metrics",
    "distance",
    "distances",
    "load",
    "loop",
    "prepare",
    "read",
    "repeat",
    "seam_metrics",
    "to_json",
    "write",
)

__all__ = ["__version__", *_API]


def __getattr__(name: str) -> Any:
    # PEP 562: the API (numba, scipy, the apps) is imported on first use, not by the CLI's start.
    if name in _API:
        from elastic_motion import api

        return getattr(api, name)
    raise AttributeError(f"module 'elastic_motion' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)
