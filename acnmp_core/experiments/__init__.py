"""The experiments of the paper (E1 via-point ... E6 pour) and the project's own robot runner, with the
figures they draw (:mod:`~acnmp_core.experiments.plots`)."""
