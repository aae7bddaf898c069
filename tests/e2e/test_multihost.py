"""A deployment over seven hosts (Linux network namespaces joined in a star on the router's, TLS and a
password per role as docker-compose.secure.yml): E1 run from the client host gives the in-process
numbers, also while the model's host, a worker's host and the recorder's host are cut off for
10 s; the worker rejoins and executes roll-outs again; the recording holds every roll-out once and says which worker ran it;
`acnmp status` says which host runs what; the model host cut off gives clients a one-line
`timeout`/`unavailable` error and answers resume without a restart; a process without the
deployment's password cannot join; a batch of UR10 roll-outs sent from the client host gives the
simulator's results here. Two learners on hosts of their own share the skills: each is trained and
adapted by its owner only, on its host, and `acnmp query jobs` lists both learners' jobs. Skipped,
with the reason, where namespaces cannot be made."""
from __future__ import annotations

import json
import subprocess
import sys
import time

import numpy as np
import pytest
import torch

from acnmp_core.experiments.viapoint import make_setup
from acnmp_core.data.demo_io import save_demos
from services.launcher import netns
from services.launcher.multihost import MultiHostDeployment
from services.learner.ownership import owner_of
from services.learner.store import demo_set_to_arrays
from services.recording.replay import summarize
from tests.conftest import E1_SMALL

WHY_NOT = netns.unavailable_reason()
pytestmark = pytest.mark.skipif(WHY_NOT is not None, reason=f"no network namespaces here: {WHY_NOT}")

SEED, BUDGET, STEPS = E1_SMALL  # e1_small_run (tests/conftest.py) is its in-process run
METHODS = ("lfd_only", "rl_only", "acnmp")
CUT_SECONDS = 10.0
#: An operator's process on the client host, one session for all it is asked (each request a JSON
#: line on stdin, each answer one on stdout): {"batch": [robot, task, task_config, n, in.npz, out.npz]}
#: sends a batch of roll-outs to the workers of ``robot`` once ``n`` of them are live (an operator
#: may call workers); {"info": skill} asks the model service.
OPERATOR = """
import json, sys, numpy as np
from clients.client import ACNMPClient
from services.transport import wait_for_liveliness
from services.worker.remote import RemoteEvaluator
with ACNMPClient(sys.argv[1], config_file=sys.argv[2], role="operator", timeout=30) as client:
    for line in sys.stdin:
        ask = json.loads(line)
        if "info" in ask:
            print(json.dumps({"version": client.info(ask["info"])["version"]}), flush=True)
            continue
        robot, task, task_config, n, data, out = ask["batch"]
        d = np.load(data)
        wait_for_liveliness(client.session, client.keys.worker_token(robot), count=n, timeout=60)
        b = RemoteEvaluator(client.session, client.keys, robot, task, task_config).evaluate(
            d["trajectories"], d["times"], d["task_params"] if d["task_params"].size else None)
        np.savez(out, rewards=b.rewards, success=b.success, hosts=np.array(b.hosts))
        print(json.dumps({"done": out}), flush=True)
"""


class Operator:
    """:data:`OPERATOR` running on the client host of ``dep``."""

    def __init__(self, dep: MultiHostDeployment, tmp_path) -> None:
        self.tmp = tmp_path
        self.proc = dep.popen([sys.executable, "-c", OPERATOR, dep.namespace, str(dep.config("operator"))],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)

    def ask(self, request: dict) -> dict:
        self.proc.stdin.write(json.dumps(request) + "\n")
        self.proc.stdin.flush()
        line = self.proc.stdout.readline()
        assert line, f"the operator process ended (exit {self.proc.poll()})"
        return json.loads(line)

    def batch(self, name: str, robot: str, task: str, task_config: dict, n_workers: int, batch: dict) -> dict:
        """Execute ``batch`` (trajectories, times, task_params) remotely; its rewards, success, hosts."""
        np.savez(self.tmp / f"{name}_in.npz", **{k: np.asarray([] if v is None else v) for k, v in batch.items()})
        out = str(self.tmp / f"{name}_out.npz")
        assert self.ask({"batch": [robot, task, task_config, n_workers, str(self.tmp / f"{name}_in.npz"), out]}) == \
            {"done": out}
        return dict(np.load(out))

    def close(self) -> None:
        self.proc.stdin.close()
        assert self.proc.wait(timeout=30) == 0


def e1(dep: MultiHostDeployment, out) -> subprocess.Popen:
    """E1 (small) started on the client host, as an operator joining through its zenoh config."""
    return dep.popen([sys.executable, "-m", "clients.cli", "experiment", "viapoint", "--seeds", f"{SEED}-{SEED}",
                      "--budget", str(BUDGET), "--train-steps", str(STEPS), "--quiet", "--distributed",
                      "--namespace", dep.namespace, "--config", str(dep.config("operator")), "--json", str(out)],
                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def finished(proc: subprocess.Popen) -> str:
    out, _ = proc.communicate(timeout=300)
    assert proc.returncode == 0, out
    return out


def ur10_batch(demo_file) -> dict:
    """Three UR10 trajectories at one demonstration's heights: the demonstration and two perturbed
    copies."""
    from acnmp_core.tasks.ur10_pick_place.demos import ur10_demos

    demo = ur10_demos(path=str(demo_file)).demo(0)
    rng = np.random.default_rng(0)
    noise = np.cumsum(rng.normal(0, 2e-4, size=(2, *demo[1].shape)), axis=1)
    return {"trajectories": np.concatenate([demo[1][None], demo[1][None] + noise]), "times": demo[0],
            "task_params": demo[2]}


@pytest.mark.slow
def test_a_deployment_over_hosts_survives_cut_links_and_keeps_strangers_out(tmp_path, ur10_demo_file, e1_small_run):
    from acnmp_core.tasks.ur10_pick_place.task import UR10PickPlaceTask

    torch.set_num_threads(1)
    rrd = tmp_path / "hosts.rrd"
    with MultiHostDeployment(f"hosts-{tmp_path.name[-8:].strip('_-') or 'x'}", workers=2, record=rrd,
                             chunk_timeout=4.0, work_dir=tmp_path / "work", extra_workers=("ur10",)) as dep:
        # which host runs what, asked from the client host with the client's credentials
        status = dep.acnmp("status", "--json", role="client")
        assert status.returncode == 0, status.stderr
        procs = json.loads(status.stdout)[0]["processes"]
        assert {(p["service"], p["host"]) for p in procs} == {
            ("router", "router"), ("recorder", "recorder"), ("learner", "learner"), ("model", "model"),
            ("worker", "worker-0"), ("worker", "worker-1"), ("worker", "worker-ur10")}
        assert {p["pid"] for p in procs} == {c.proc.pid for c in dep.processes.values()}

        # a batch of UR10 roll-outs from the client host gives what the simulator gives here
        operator = Operator(dep, tmp_path)
        batch = ur10_batch(ur10_demo_file)
        with UR10PickPlaceTask() as task:
            here = task.evaluate(batch["trajectories"], batch["times"], batch["task_params"])
        there = operator.batch("ur10", "ur10", "pick_place", {}, 1, batch)
        assert np.array_equal(there["rewards"], here.rewards) and np.array_equal(there["success"], here.success)
        assert list(there["hosts"]) == ["worker-ur10"] * 3

        # E1 with three hosts cut off. The model's, from the start for 10 s: the weights the learner
        # puts meanwhile are fetched once its link is back (E1 waits for them), and a client asking
        # it meanwhile gets one line within its timeout. Worker-1's, for 10 s from the first job's
        # first roll-out (while the router still counts it live, so the next job sends it a chunk,
        # which is found lost and re-sent to worker-0). The recorder's, from the start to that end.
        model_pid = dep.processes["model"].proc.pid
        dep.cut("model")
        dep.cut("recorder")
        model_cut = time.monotonic()
        try:
            cut_run = e1(dep, tmp_path / "cut.json")
            local = json.loads(json.dumps(e1_small_run.summary))
            lost = dep.acnmp("query", "info", "--skill", "e1", "--timeout", "3", role="client")
            dep.wait_for_line("learner", "version 0", timeout=120)  # put while the model is cut off
            time.sleep(max(0.0, model_cut + CUT_SECONDS - time.monotonic()))  # the cut's length, not a wait
            dep.heal("model")
            dep.wait_for_line("learner", "iteration 0, 1/10 roll-outs", timeout=120)  # LfD's one roll-out
            dep.cut("worker-1")
            worker_cut = time.monotonic()
            dep.wait_for_line("learner", "worker point2d-1 failed", timeout=120)
            time.sleep(max(0.0, worker_cut + CUT_SECONDS - time.monotonic()))
        finally:
            for host in ("model", "worker-1", "recorder"):
                dep.heal(host)
        finished(cut_run)
        assert lost.returncode != 0 and len(lost.stderr.strip().splitlines()) == 1, lost.stderr
        assert "timeout" in lost.stderr or "unavailable" in lost.stderr, lost.stderr
        run = json.loads((tmp_path / "cut.json").read_text())
        for m in METHODS:
            for k in ("rollouts", "success", "error", "shape_error"):
                assert run["methods"][m][k] == local["methods"][m][k], (m, k)
        # worker-1 rejoins (its session to the router comes back) and takes work again: a batch of
        # E1 roll-outs once both point-mass workers are live, half of it on worker-1's host
        setup = make_setup()
        paths = setup.target.query_times
        e1_batch = {"trajectories": np.stack([np.stack([paths, np.sin(k * paths)], 1) for k in range(8)]),
                    "times": paths, "task_params": None}
        there = operator.batch("e1", "point2d", "viapoint", setup.task_config, 2, e1_batch)
        assert sorted(set(there["hosts"])) == ["worker-0", "worker-1"]
        here = setup.task.evaluate(e1_batch["trajectories"], paths)
        assert np.array_equal(there["rewards"], here.rewards)
        # the same model process answers (the version E1 trained), nothing was restarted
        assert operator.ask({"info": "e1"}) == {"version": 0}
        operator.close()
        assert dep.processes["model"].proc.pid == model_pid
        assert all(c.proc.poll() is None for c in dep.processes.values())

        # a process on the client host without this deployment's password cannot join
        stranger = json.loads(dep.config("client").read_text())
        stranger["transport"]["auth"]["usrpwd"]["password"] = "not-the-password"
        bad = tmp_path / "stranger.json5"
        bad.write_text(json.dumps(stranger))
        refused = dep.acnmp("status", "--timeout", "2", role="client", config=bad)
        assert refused.returncode != 0 and "cannot open zenoh session" in refused.stderr, refused.stderr

        cut_jobs = {run["methods"][m]["job"]: m for m in METHODS}
    assert not netns.namespaces() or not any(n.startswith(dep.network.prefix) for n in netns.namespaces())

    # the recording: every roll-out of every job once, and which worker executed it
    jobs = summarize(rrd)["jobs"]
    for job, m in cut_jobs.items():
        assert jobs[job]["rollouts"] == jobs[job]["unique_rollouts"] == local["methods"][m]["rollouts"]
        assert not jobs[job]["duplicates"]
    # which host did what: every roll-out names its worker's host
    for job in cut_jobs:
        assert sum(jobs[job]["hosts"].values()) == jobs[job]["rollouts"]
        assert set(jobs[job]["hosts"]) <= {"worker-0", "worker-1"}


@pytest.mark.slow
def test_two_learners_on_hosts_of_their_own_each_serve_their_skills_and_list_every_job(tmp_path):
    setup = make_setup()
    demos = save_demos(tmp_path / "e1.npz", demo_set_to_arrays(setup.demos))
    ids = ("learner", "learner-2")
    skills = {lid: next(s for s in (f"e1-{i}" for i in range(100)) if owner_of(s, ids) == lid) for lid in ids}
    tg = setup.target
    obs = [f"--obs={t}:{x},{y}" for t, (x, y) in zip(tg.obs_times, tg.obs_values)]
    with MultiHostDeployment(f"hosts2-{tmp_path.name[-8:].strip('_-') or 'x'}", workers=1, learners=2,
                             work_dir=tmp_path / "work") as dep:
        status = dep.acnmp("status", "--json", role="client")
        assert status.returncode == 0, status.stderr
        hosts = {(p["service"], p["host"]) for p in json.loads(status.stdout)[0]["processes"]}
        assert {("learner", "learner"), ("learner", "learner-2")} <= hosts
        jobs = {}
        for lid, skill in skills.items():
            trained = dep.acnmp("query", "train", "--skill", skill, "--demos", str(demos), "--steps", "50")
            assert trained.returncode == 0, trained.stderr
            adapted = dep.acnmp("query", "adapt", "--skill", skill, "--task", "viapoint", *obs, "--task-config",
                                json.dumps(setup.task_config), "--budget", "4", "--watch", "--json")
            assert adapted.returncode == 0, adapted.stderr  # 0: the job is done
            final = json.loads(adapted.stdout)  # the queued line went to stderr
            jobs[lid] = final["job"]
        for lid, skill in skills.items():  # trained by its owner only, on its own host's state directory
            assert [other for other in ids if (dep.learner_state_dir(other) / "skills" / skill).is_dir()] == [lid]
        listed = dep.acnmp("query", "jobs", "--json", role="client")
        assert listed.returncode == 0, listed.stderr
        assert sorted(r["job"] for r in json.loads(listed.stdout)) == sorted(jobs.values())
    assert not any(n.startswith(dep.network.prefix) for n in netns.namespaces())
