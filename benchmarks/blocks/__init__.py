"""The renderers of the docs blocks (benchmarks/report.py), one module per experiment: e1 ... e6,
pusher, peers, jobs (jobs side by side, sizing), faults (docs/FAULTS.md), mutation (the learner's
mutation check), datasets, predict (the model service's throughput), adaptation (the settings sweep),
readme (the README's results table, the experiments' table, the targets), recipes (each of the
paper's experiments under the paper's method and the default, side by side); reference: the tables
the code holds (error codes, keys, the access table, request bounds, options). Each renderer
registers itself in :data:`benchmarks.report_kit.RENDERERS` by its block name when its module is
imported; importing this package imports them all."""
from . import (adaptation, datasets, e1, e2, e3, e4, e5, e6, faults, jobs, mutation, peers, predict, pusher,  # noqa: F401
               readme, recipes, reference)
