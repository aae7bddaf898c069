"""CLI adapters of the paper's experiments: each module exposes ``register(subparsers)`` adding
``acnmp experiment <name>``; the logic lives in :mod:`acnmp_core.experiments`."""
