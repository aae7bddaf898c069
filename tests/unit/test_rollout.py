"""What a roll-out may report (acnmp_core/rollout.py): every number finite and within
:data:`MAX_MAGNITUDE`, so nothing computed from it overflows (issue 66: rewards of -1e308, finite,
made a job's summed return -inf when its event was published, and the job failed there)."""
from __future__ import annotations

import numpy as np
import pytest

from acnmp_core.adaptation.credit import per_step_advantages
from acnmp_core.errors import NonFiniteError, ShapeError, TooLargeError
from acnmp_core.rollout import MAX_MAGNITUDE, RolloutBatch

OK = dict(rewards=np.zeros((3, 4)), success=np.zeros(3, bool))


@pytest.mark.parametrize("change, error, names", [
    (dict(rewards=np.full((3, 4), -1e308)), TooLargeError, "rewards"),
    (dict(rewards=np.full((3, 4), MAX_MAGNITUDE / 2)), TooLargeError, "returns"),  # each within, their sum not
    (dict(rewards=np.array([[np.nan] * 4] * 3)), NonFiniteError, "rewards"),
    (dict(errors=np.array([0.0, 1e200, 0.0])), TooLargeError, "errors"),
    (dict(states={"path": np.full((3, 4, 2), 1e300)}), TooLargeError, "states['path']"),
    (dict(states={"path": np.array([[[np.inf]]] * 3)}), NonFiniteError, "states['path']"),
    (dict(states={"path": np.zeros((2, 4, 2))}), ValueError, "states['path']"),
    (dict(rewards=np.zeros(4)), ShapeError, "rewards"),
])
def test_a_batch_with_a_number_no_task_reports_is_refused_naming_it(change, error, names):
    with pytest.raises(error, match=names.replace("[", r"\[").replace("]", r"\]")):
        RolloutBatch(**{**OK, **change})


def test_at_the_bound_every_statistic_of_the_adaptation_stays_finite():
    rng = np.random.default_rng(0)
    t = 100
    rewards = rng.choice([-1.0, 1.0], size=(8, t)) * MAX_MAGNITUDE / t  # returns up to the bound
    batch = RolloutBatch(rewards=rewards, success=np.zeros(8, bool), errors=np.full(8, -MAX_MAGNITUDE))
    returns = batch.returns
    for value in (returns, returns - returns[::-1], np.std(returns), np.mean(returns ** 2),
                  batch.remaining_errors()):
        assert np.all(np.isfinite(value))
    for kind in ("reinforce", "awr"):
        for credit in ("step", "future", "episode"):
            _rows, adv = per_step_advantages(batch.rewards, kind=kind, credit=credit)
            assert np.all(np.isfinite(adv)), (kind, credit)
