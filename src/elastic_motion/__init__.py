"""elastic-motion: elastic shape analysis of curves in Lie groups for motion capture.

``import elastic_motion as em`` gives the notebook API of :mod:`elastic_motion.api`
(``em.read``, ``em.blend``, ``em.loop``, ``em.align``, ``em.distance``, ``em.write``...),
loaded on first use so that the command line starts fast. See ``docs/api.md``.

Layers (each depends only on the ones before it):
``groups`` -> ``curves`` -> ``warp`` -> ``closing`` -> ``motion`` -> ``apps``/``cli``.
See ``docs/architecture.md``.
"""

import importlib
import importlib.util
from typing import Any

from elastic_motion._version import __version__

__all__ = ["__version__"]  # the API's names are listed once, in elastic_motion.api.__all__


def __getattr__(name: str) -> Any:
    # PEP 562: the API (numba, scipy, the apps) is imported on first use, not by the CLI's start.
    # a submodule (``from elastic_motion import limits``) is left to the import system
    if not name.startswith("__") and importlib.util.find_spec(f"{__name__}.{name}") is None:
        api = importlib.import_module("elastic_motion.api")
        if name in api.__all__:
            return getattr(api, name)
    raise AttributeError(f"module 'elastic_motion' has no attribute {name!r}")


def __dir__() -> list[str]:
    api = importlib.import_module("elastic_motion.api")
    return sorted({*globals(), *api.__all__})
