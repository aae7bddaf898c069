"""Jobs side by side in a real learner (``--jobs 3``, job processes): three jobs run at once and
each advances (none waits for another to end), the learner is killed with SIGKILL while all three
run, and after the launcher restarts it every job ends ``done`` with the result it has alone; the
recording holds every roll-out of both attempts once (indices stay global over attempts; the journal
gives back what the kill kept from the recording)."""
from __future__ import annotations

import numpy as np
import psutil

from acnmp_core.experiments.viapoint import make_setup
from services.launcher import LocalDeployment
from services.recording.replay import summarize
from services.transport import Keyspace, call

NS = "cjobs"
KEYS = Keyspace(NS)
SMALL = {"encoder_widths": [32, 32], "decoder_widths": [32, 32]}
SEEDS = (5, 6, 7)


#: roll-outs per job: enough that no job ends while a job process the machine started late has yet
#: to reach its third (with 10, one fresh clone's run saw a job done before another was running)
BUDGET = 30


def _adapt(setup, seed: int) -> dict:
    tg = setup.target
    return {"target": {"obs_times": tg.obs_times, "obs_values": tg.obs_values, "query_times": tg.query_times},
            "task": "viapoint", "task_config": setup.task_config, "robot": "point2d", "seed": seed,
            "config": {"max_rollouts": BUDGET, "max_reuse": 3, "stop_on_success": False}}


def test_concurrent_jobs_survive_a_learner_kill_with_their_alone_results(tmp_path, wait_job, verify_rrd):
    setup = make_setup()
    rrd = tmp_path / "jobs.rrd"
    # roll-outs that take the workers' time (0.1 s each) keep the three jobs in step: on CPU-bound
    # roll-outs a job process that a busy machine schedules late lags the others by whole batches
    with LocalDeployment(NS, workers=2, model=False, worker_delay=0.1, state_dir=tmp_path / "state", record=rrd,
                         learner_args=["--jobs", "3"]) as dep:
        s = dep.session
        train = {"times": np.stack([d.times for d in setup.demos]), "values": np.stack([d.values for d in setup.demos]),
                 "model": SMALL, "train": {"steps": 100}, "seed": 3}
        call(s, KEYS.train("e1"), train, timeout=120)
        alone = {}
        for seed in SEEDS:  # each job alone first
            job = call(s, KEYS.adapt("e1"), _adapt(setup, seed), timeout=10)["job"]
            alone[seed] = wait_job(s, KEYS, job, lambda st: st["state"] in ("done", "failed"), timeout=300)
            assert alone[seed]["state"] == "done", alone[seed]["error"]

        jobs = {seed: call(s, KEYS.adapt("e1"), _adapt(setup, seed), timeout=10)["job"] for seed in SEEDS}
        # all three running at once, each past its first iteration: the workers serve them all
        def all_running(_st) -> bool:
            st = [call(s, KEYS.job_status(j), timeout=10) for j in jobs.values()]
            assert not any(x["state"] in ("done", "failed") for x in st), f"a job ended before all three ran: {st}"
            return all(x["state"] == "running" and x["rollouts"] >= 3 for x in st)

        wait_job(s, KEYS, jobs[SEEDS[0]], all_running, timeout=300)
        job_processes = psutil.Process(dep.children["learner"].pid).children()
        dep.kill("learner")
        # the killed learner's job processes end by themselves (their pipe to it closed)
        _, alive = psutil.wait_procs(job_processes, timeout=60)
        assert len(job_processes) == 3 and alive == [], alive
        dep.supervisor.wait_restarts("learner", 1, timeout=120)
        final = {seed: wait_job(s, KEYS, job, lambda st: st["state"] in ("done", "failed"), timeout=300)
                 for seed, job in jobs.items()}
    for seed, st in final.items():
        assert st["state"] == "done", st["error"]
        assert st["attempt"] == 1  # each restarted once, from its beginning with its seed
        np.testing.assert_array_equal(st["result"]["trajectory"], alone[seed]["result"]["trajectory"])
        assert st["rollouts_executed"] >= BUDGET + 3  # the killed attempt's roll-outs keep their indices
    verify_rrd(rrd)
    recorded = summarize(rrd)["jobs"]
    for seed, job in jobs.items():
        assert recorded[job]["duplicates"] == []
        # every roll-out of both attempts once: those the kill kept from the recording were in the
        # job's journal, published again by the restarted learner
        assert recorded[job]["rollouts"] == recorded[job]["unique_rollouts"] == final[seed]["rollouts_executed"]
