"""The package's version: its one home (``pyproject.toml`` reads it from here).

A plain assignment, so that the build reads it without importing the package and
``import elastic_motion`` gets it without ``importlib.metadata`` (which scans the installed
distributions: part of every command's start-up otherwise).
"""

__version__ = "0.1.0"
