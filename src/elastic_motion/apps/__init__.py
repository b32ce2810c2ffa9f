"""Applications over the numerical layers: blend, loop, databases (distance, search, mean,
clustering), plots. Import the submodules explicitly, e.g. ``elastic_motion.apps.database``."""
