"""elastic-motion: elastic shape analysis of curves in Lie groups for motion capture.

Layers (each depends only on the ones before it):
``groups`` -> ``curves`` -> ``warp`` -> ``closing`` -> ``motion`` -> ``apps``/``cli``.
See ``docs/architecture.md``.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("elastic-motion")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
