"""Supervision of `acnmp up`'s children: a child killed with SIGKILL is restarted by the launcher
(and the restart recorded as a ``process`` event), a child dying too often is given up, stopping
restarts nothing; a distributed E1 run survives a learner killed in the middle with the result of
an undisturbed run and a recording that verifies."""
from __future__ import annotations

import threading
import time

import numpy as np
import pytest
import zenoh

from acnmp_core.experiments.viapoint import make_setup, run_viapoint
from clients.cli import main
from clients.client import ACNMPClient
from clients.distributed import run_viapoint_distributed
from services.launcher import LocalDeployment
from services.launcher.supervision import RestartPolicy
from services.recording.replay import summarize
from services.transport import call, decode
from services.transport.runfile import RunFile
from services.worker.remote import RemoteEvaluator

WORKER = "worker-point2d-0"


def _recorded_processes(dep, want: int, timeout: float = 30.0) -> int:
    """Wait until the recorder has written ``want`` process events; returns its count."""
    deadline = time.monotonic() + timeout
    while True:
        n = call(dep.session, dep.keys.recorder_status(), timeout=10)["events"].get("process", 0)
        if n >= want or time.monotonic() > deadline:
            return n
        time.sleep(0.1)


def test_a_killed_child_is_restarted_and_recorded_then_given_up_after_the_limit(tmp_path, verify_rrd, capsys):
    setup = make_setup()
    lines: list[str] = []
    rrd = tmp_path / "sup.rrd"
    # secure, as `acnmp up` runs by default: the launcher's process events pass the router's ACL
    with LocalDeployment("sup", workers=1, model=False, learner=False, record=rrd, state_dir=tmp_path / "state",
                         secure=True, restart_policy=RestartPolicy(max_restarts=1, window=60.0),
                         report=lines.append) as dep:
        first = dep.children[WORKER].pid
        dep.kill(WORKER)  # SIGKILL, as a crash would
        (restart,) = dep.supervisor.wait_restarts(WORKER, 1, timeout=60)
        assert restart.old_pid == first and restart.exit_code == -9 and restart.pid == dep.children[WORKER].pid
        # the run file (`acnmp status`, discovery) names the new pid, not the dead one
        run = RunFile.read(dep.announcement.directory / "run.json")
        assert {p.name: p.pid for p in run.processes}[WORKER] == restart.pid
        # the new worker serves roll-outs under the same id
        t = setup.target.query_times
        batch = RemoteEvaluator(dep.session, dep.keys, "point2d", "viapoint", setup.task_config, timeout=30) \
            .evaluate(np.zeros((2, len(t), 2)), t)
        assert batch.workers == ("point2d-0",) * 2
        # a second death within the window is one more than the limit: given up, and said so
        dep.kill(WORKER)
        deadline = time.monotonic() + 30
        while WORKER not in dep.supervisor.given_up:
            assert time.monotonic() < deadline, lines
            time.sleep(0.05)
        assert _recorded_processes(dep, 2) == 2  # restarted + gave_up
        # `acnmp status` shows the child given up on as exited, and says so by its exit code
        assert main(["status", "--namespace", "sup"]) == 1
        assert f"{WORKER:<18}" in (out := capsys.readouterr().out) and out.rstrip().endswith("exited"), out
        codes = dep.stop()
    assert any("restarted as pid" in ln for ln in lines) and any("giving up" in ln for ln in lines), lines
    # stopping on purpose restarts nothing and needs no SIGKILL: the recorder is the one started first
    assert [r.name for r in dep.supervisor.restarts] == [WORKER, WORKER]
    assert dep.killed == [] and codes["recorder"] == 0 and codes[WORKER] == -9
    verify_rrd(rrd)


@pytest.mark.slow
def test_distributed_e1_survives_a_learner_killed_mid_job(tmp_path, verify_rrd):
    args = dict(seed=2, budget=10, train_steps=300)
    reference = run_viapoint(**args, progress=False)  # the in-process run (= an undisturbed distributed one)
    rrd = tmp_path / "e1.rrd"
    killed = threading.Event()
    with LocalDeployment("e1kill", workers=2, robot="point2d", record=rrd, state_dir=tmp_path / "state",
                         worker_delay=0.02) as dep:
        def on_progress(sample: zenoh.Sample) -> None:
            ev = decode(sample.payload.to_bytes())
            # the learner is in the middle of a job with exploration (not the one-roll-out LfD job)
            if ev["state"] == "running" and ev["rollouts"] >= 3 and not killed.is_set():
                killed.set()
                dep.kill("learner")

        sub = dep.session.declare_subscriber(f"{dep.keys.prefix}/event/job_progress/**", on_progress)
        try:
            with ACNMPClient(dep.namespace, session=dep.session, timeout=30) as client:
                run = run_viapoint_distributed(**args, progress=False, client=client)
        finally:
            sub.undeclare()
        assert killed.is_set()
        (restart,) = [r for r in dep.supervisor.restarts if r.name == "learner"]
        assert restart.exit_code == -9 and restart.live_after is not None
    for m in ("lfd_only", "rl_only", "acnmp"):
        for k in ("rollouts", "success", "error", "shape_error"):
            assert run.summary["methods"][m][k] == reference.summary["methods"][m][k], (m, k)
    verify_rrd(rrd)
    # the recording holds the restart and every job (the interrupted attempt's roll-outs too)
    summary = summarize(rrd)
    assert summary["events"].get("process") == 1
    for m in ("lfd_only", "rl_only", "acnmp"):
        rec = summary["jobs"][run.summary["methods"][m]["job"]]
        assert rec["rollouts"] >= run.summary["methods"][m]["rollouts"] and not rec["duplicates"]
