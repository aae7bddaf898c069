"""benchmarks/studies/e6_pour/e6_fit_trace.py: tracing the policy updates leaves the adaptation exactly as it was,
and the trace says what each update did (one entry per update, its reuse steps and why it stopped)."""
import copy

import numpy as np
import pytest

from acnmp_core.adaptation import loop as adaptation
from acnmp_core.adaptation.loop import adapt
from acnmp_core.adaptation.config import AdaptConfig
from acnmp_core.experiments.viapoint import make_setup
from benchmarks.studies.e6_pour.e6_fit_trace import traced_update


@pytest.fixture(scope="module")
def setup():
    return make_setup("2d")


def test_tracing_changes_nothing_and_records_every_update(e1_model, setup, monkeypatch):
    cfg = AdaptConfig(max_rollouts=15, max_reuse=5)  # 3 iterations of 1 + 4
    plain = adapt(copy.deepcopy(e1_model), setup.demos, setup.target, setup.task, cfg, seed=3)
    trace: list[dict] = []
    monkeypatch.setattr(adaptation._Updater, "update", traced_update(adaptation._Updater.update, trace, cfg))
    traced = adapt(copy.deepcopy(e1_model), setup.demos, setup.target, setup.task, cfg, seed=3)
    np.testing.assert_array_equal(plain.trajectory, traced.trajectory)
    assert [h.mean_return for h in plain.history] == [h.mean_return for h in traced.history]
    # every iteration updates but a successful last one (E1's rewards always differ)
    assert len(trace) == len(traced.history) - traced.success
    assert [t["reuses"] for t in trace] == [h.reuses for h in traced.history[:len(trace)]]
    for t in trace:
        # a fit is measured before every further step and once when the tolerance ends the update
        assert len(t["fit_after_each_step"]) == t["reuses"] + (t["stopped_by"] == "fit_tolerance")
        assert (t["stopped_by"] == "max_reuse") == (t["reuses"] == cfg.max_reuse)
