"""Subcommands of ``qsplan``: each module defines ``register(subparsers)``."""
