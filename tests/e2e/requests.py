"""E1's train and adapt requests as the e2e tests send them to a learner (docs/PROTOCOL.md):
a small network, a few steps, the extrapolated via-point of ``make_setup()``."""
from __future__ import annotations

import numpy as np

#: A 2 x 32 CNMP: trains in a second, enough for what the e2e tests check (never the outcome).
SMALL = {"encoder_widths": [32, 32], "decoder_widths": [32, 32]}


def train_request(demos, steps: int = 200, seed: int = 3, value_names=None) -> dict:
    """A train request of ``demos`` (a DemoSet of one length) for a :data:`SMALL` network."""
    request = {"times": np.stack([d.times for d in demos]), "values": np.stack([d.values for d in demos]),
               "model": SMALL, "train": {"steps": steps}, "seed": seed}
    if value_names is not None:
        request["value_names"] = list(value_names)
    return request


def adapt_request(setup, seed: int = 5, **config) -> dict:
    """An adapt request to ``setup``'s target (a ViaPointSetup) on point2d workers; ``config``
    overrides AdaptConfig fields (``max_reuse`` 5 unless given)."""
    tg = setup.target
    return {"target": {"obs_times": tg.obs_times, "obs_values": tg.obs_values, "query_times": tg.query_times},
            "task": "viapoint", "task_config": setup.task_config, "robot": "point2d", "seed": seed,
            "config": {"max_reuse": 5, **config}}
