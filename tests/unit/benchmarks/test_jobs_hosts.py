"""The accounting of ``bench_jobs.py hosts`` (two learners on two hosts against one): the skills
split the jobs evenly between the pair's owners, and the summary's ratios, CPU split and projected
bound come out of the rounds' numbers as the docs state them."""
from __future__ import annotations

import pytest

from benchmarks.performance.bench_jobs import HOST_LEARNERS, host_jobs, host_skills, hosts_bound, hosts_summary
from services.learner.ownership import owner_of


def test_the_eight_jobs_fall_four_to_each_learner_of_the_pair():
    skills = host_skills()
    assert [owner_of(s, HOST_LEARNERS) for s in skills] == list(HOST_LEARNERS)
    jobs = host_jobs(8, skills)
    assert [seed for _, seed in jobs] == list(range(100, 108))
    owners = [owner_of(skill, HOST_LEARNERS) for skill, _ in jobs]
    assert owners.count("learner") == owners.count("learner-2") == 4


def _round(rep, learners, wall, learner_cpu, worker_cpu):
    return {"rep": rep, "learners": learners, "wall_s": wall, "learner_cpu_s": learner_cpu,
            "worker_cpu_s": {f"worker-{i}": c for i, c in enumerate(worker_cpu)}}


def test_the_summary_gives_the_wall_ratio_the_cpu_split_and_the_bound_of_learners_on_their_own_cores():
    rounds = [_round(0, 1, 20.0, {"learner": 16.0}, [1.0, 1.0, 1.0, 1.0]),
              _round(0, 2, 15.0, {"learner": 9.0, "learner-2": 7.0}, [1.0, 1.0, 1.0, 1.0]),
              _round(1, 2, 12.0, {"learner": 8.0, "learner-2": 8.0}, [2.0, 2.0, 2.0, 2.0]),
              _round(1, 1, 24.0, {"learner": 16.0}, [2.0, 2.0, 2.0, 2.0])]
    # the busiest learner over its 2 cores, or the workers over their 4, whichever is larger
    assert hosts_bound(rounds[1], 2.0, 4.0) == 4.5
    assert hosts_bound(_round(0, 2, 1.0, {"learner": 1.0, "learner-2": 1.0}, [8.0, 8.0, 8.0, 8.0]), 2.0, 4.0) == 8.0
    s = hosts_summary(rounds, cores_per_learner=2.0, worker_cores=4.0)
    assert [r["wall_ratio"] for r in s["by_rep"]] == [0.75, 0.5]
    assert s["wall_ratio"]["median"] == pytest.approx(0.625) and s["wall_ratio"]["n"] == 2
    assert s["by_rep"][0]["learner_cpu_share"] == {"learner": 9 / 16, "learner-2": 7 / 16}
    assert s["by_rep"][0]["bound_s"] == {"1": 8.0, "2": 4.5}
    assert s["by_rep"][0]["projected_ratio"] == 4.5 / 20.0
    assert s["by_rep"][1]["projected_bound_ratio"] == 4.0 / 8.0
    assert s["learner_cpu_share"]["learner"]["max"] == 9 / 16
