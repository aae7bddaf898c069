"""A deployment over seven hosts (Linux network namespaces joined in a star on the router's, TLS and a
password per role as docker-compose.secure.yml): E1 run from the client host gives the in-process
numbers, also while a worker host and the recorder host are cut off for 10 s; the worker rejoins
and executes roll-outs again; the recording holds every roll-out once and says which worker ran it;
`acnmp status` says which host runs what; the model host cut off gives clients a one-line
`timeout`/`unavailable` error and answers resume without a restart; a process without the
deployment's password cannot join. Skipped, with the reason, where namespaces cannot be made."""
from __future__ import annotations

import json
import subprocess
import sys
import time

import pytest
import torch

from acnmp_core.experiments.viapoint import run_viapoint
from services.launcher import netns
from services.launcher.multihost import MultiHostDeployment
from services.recording.replay import summarize

WHY_NOT = netns.unavailable_reason()
pytestmark = pytest.mark.skipif(WHY_NOT is not None, reason=f"no network namespaces here: {WHY_NOT}")

SEED, BUDGET, STEPS = 2, 10, 300
METHODS = ("lfd_only", "rl_only", "acnmp")
CUT_SECONDS = 10.0


def e1(dep: MultiHostDeployment, out) -> subprocess.Popen:
    """E1 (small) started on the client host, as an operator joining through its zenoh config."""
    return dep.popen([sys.executable, "-m", "clients.cli", "experiment", "viapoint", "--seed", str(SEED),
                      "--budget", str(BUDGET), "--train-steps", str(STEPS), "--quiet", "--distributed",
                      "--namespace", dep.namespace, "--config", str(dep.config("operator")), "--json", str(out)],
                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def rejoined(dep: MultiHostDeployment, host: str, patience: float = 60.0) -> None:
    """Ask `acnmp status` from the client host until ``host``'s process answers again."""
    deadline = time.monotonic() + patience
    while True:
        status = dep.acnmp("status", "--json", role="client")
        if status.returncode == 0 and host in {p["host"] for p in json.loads(status.stdout)[0]["processes"]}:
            return
        assert time.monotonic() < deadline, f"{host} did not rejoin in {patience} s: {status.stdout}{status.stderr}"


def finished(proc: subprocess.Popen) -> str:
    out, _ = proc.communicate(timeout=300)
    assert proc.returncode == 0, out
    return out


def test_a_deployment_over_hosts_survives_cut_links_and_keeps_strangers_out(tmp_path):
    torch.set_num_threads(1)
    rrd = tmp_path / "hosts.rrd"
    with MultiHostDeployment(f"hosts-{tmp_path.name[-8:].strip('_-') or 'x'}", workers=2, record=rrd,
                             chunk_timeout=4.0, work_dir=tmp_path / "work") as dep:
        # which host runs what, asked from the client host with the client's credentials
        status = dep.acnmp("status", "--json", role="client")
        assert status.returncode == 0, status.stderr
        procs = json.loads(status.stdout)[0]["processes"]
        assert {(p["service"], p["host"]) for p in procs} == {
            ("router", "router"), ("recorder", "recorder"), ("learner", "learner"), ("model", "model"),
            ("worker", "worker-0"), ("worker", "worker-1")}
        assert {p["pid"] for p in procs} == {c.proc.pid for c in dep.processes.values()}

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
            local = json.loads(json.dumps(run_viapoint(seed=SEED, budget=BUDGET, train_steps=STEPS,
                                                       progress=False).summary))
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
        # worker-1 rejoins (its session to the router comes back) and takes work again
        rejoined(dep, "worker-1")
        finished(e1(dep, tmp_path / "clean.json"))
        for name in ("cut", "clean"):
            run = json.loads((tmp_path / f"{name}.json").read_text())
            for m in METHODS:
                for k in ("rollouts", "success", "error", "shape_error"):
                    assert run["methods"][m][k] == local["methods"][m][k], (name, m, k)
        # the same model process answers, nothing was restarted
        back = dep.acnmp("query", "info", "--skill", "e1", role="client")
        assert back.returncode == 0 and "e1" in back.stdout, back.stderr
        assert dep.processes["model"].proc.pid == model_pid
        assert all(c.proc.poll() is None for c in dep.processes.values())

        # a process on the client host without this deployment's password cannot join
        stranger = json.loads(dep.config("client").read_text())
        stranger["transport"]["auth"]["usrpwd"]["password"] = "not-the-password"
        bad = tmp_path / "stranger.json5"
        bad.write_text(json.dumps(stranger))
        refused = dep.acnmp("status", "--timeout", "2", role="client", config=bad)
        assert refused.returncode != 0 and "cannot open zenoh session" in refused.stderr, refused.stderr

        cut_jobs = {json.loads((tmp_path / "cut.json").read_text())["methods"][m]["job"]: m for m in METHODS}
        clean_jobs = {json.loads((tmp_path / "clean.json").read_text())["methods"][m]["job"]: m for m in METHODS}
    assert not netns.namespaces() or not any(n.startswith(dep.network.prefix) for n in netns.namespaces())

    # the recording: every roll-out of every job once, and which worker executed it
    jobs = summarize(rrd)["jobs"]
    for job, m in {**cut_jobs, **clean_jobs}.items():
        assert jobs[job]["rollouts"] == jobs[job]["unique_rollouts"] == local["methods"][m]["rollouts"]
        assert not jobs[job]["duplicates"]
    assert sum(jobs[j]["workers"].get("point2d-1", 0) for j in clean_jobs) > 0  # back at work
    # which host did what: every roll-out names its worker's host
    for job in {**cut_jobs, **clean_jobs}:
        assert sum(jobs[job]["hosts"].values()) == jobs[job]["rollouts"]
        assert set(jobs[job]["hosts"]) <= {"worker-0", "worker-1"}
    assert sum(jobs[j]["hosts"].get("worker-1", 0) for j in clean_jobs) > 0
