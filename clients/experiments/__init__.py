"""CLI adapters of the experiments: :mod:`~clients.experiments.catalog` declares each one once (name,
help, the paper's claim, page, reproduce sizes, targets); its module here adds its options
(``add_arguments(p)``) and runs it (``run(args)``); the logic lives in :mod:`acnmp_core.experiments`."""
