"""The verdict per task and case (acnmp_core/experiments/peers/verdict.py): the default against the
best peer by successes, median and mean, and the seeds where it needs more episodes than that peer."""
from __future__ import annotations

from acnmp_core.experiments.peers.config import PeerRun
from acnmp_core.experiments.peers.verdict import MEAN_RATIO, cell_verdicts, verdicts_of


def _runs(task, method, episodes, seeds=None):
    seeds = seeds or range(len(episodes))
    return [PeerRun(task, method, s, "extrapolation", [], e or 1000, e is not None, 1000, 0.0)
            for s, e in zip(seeds, episodes)]


def _verdicts(runs, methods):
    tasks = sorted({r.task for r in runs})
    return {v.task: v for v in cell_verdicts(runs, "acnmp", tasks, ["extrapolation"], methods)}


def test_the_target_needs_as_many_successes_a_median_no_larger_and_a_mean_within_its_ratio():
    methods = ["acnmp", "acnmp_paper", "promp_cma", "ppo_bc"]
    runs = (_runs("a", "acnmp", [1, 1, 6, 1, None]) + _runs("a", "promp_cma", [1, 14, 1, 1, 1])
            + _runs("a", "acnmp_paper", [1, 1, 1, 1, 1])  # ACNMP's own: not a peer
            + _runs("b", "acnmp", [3, None, None, 9, None]) + _runs("b", "ppo_bc", [None, None, 500, None, 700])
            + _runs("c", "acnmp", [1, 1, 1, 40, 40]) + _runs("c", "promp_cma", [1, 1, 1, 2, 2])
            + _runs("d", "acnmp", [1] * 5) + _runs("d", "ppo_bc", [1] * 5) + _runs("d", "promp_cma", [1] * 5))
    v = _verdicts(runs, methods)
    assert not v["a"].met and not v["a"].met_successes and v["a"].best.method == "promp_cma"
    assert v["a"].more_than_best == (2, 4)  # 6 > 1 at seed 2; censored against 1 at seed 4
    # both censored half of the time or more: the medians are beyond every number, and they tie
    assert v["b"].met_successes and v["b"].met_median and v["b"].mine.median == float("inf")
    assert v["b"].mine.mean_censored and v["b"].mine.mean == (3 + 9 + 3000) / 5
    # the same median, a mean 16.6 against 1.4: the mean misses its bound
    assert v["c"].met_successes and v["c"].met_median and not v["c"].met_mean
    assert v["c"].mine.mean > MEAN_RATIO * v["c"].best.mean and v["c"].more_than_best == (3, 4)
    # a tie names the peer first in the plan's order of methods
    assert v["d"].met and v["d"].best.method == "promp_cma" and v["d"].more_than_best == ()
    assert _verdicts(runs, ["acnmp", "ppo_bc", "promp_cma"])["d"].best.method == "ppo_bc"


def test_successes_compare_as_rates_when_a_peer_ran_fewer_seeds():
    """PPO + BC runs half of the report seeds: 5 of 5 is a better rate than 9 of 10."""
    runs = _runs("a", "acnmp", [1] * 9 + [None], seeds=range(5, 15)) + _runs("a", "ppo_bc", [3] * 5, seeds=range(5, 10))
    v = _verdicts(runs, ["acnmp", "ppo_bc"])["a"]
    assert v.best.rate == 1.0 and v.mine.rate == 0.9 and not v.met_successes
    assert v.more_than_best == ()  # seeds 5-9: 1 against 3; seed 14 has no peer run


def test_the_verdict_reads_a_result_json():
    runs = _runs("a", "acnmp", [1, 2]) + _runs("a", "promp_cma", [1, 1])
    result = {"config": {"tasks": ["a"], "cases": ["extrapolation"], "methods": ["acnmp", "promp_cma"]},
              "runs": [r.to_json() for r in runs]}
    (v,) = verdicts_of(result, "acnmp")
    assert v.mine.median == 1.5 and v.best.median == 1 and v.more_than_best == (1,)
