"""Sub-commands of the ``elastic-motion`` CLI; each module has ``register(subparsers)``."""
