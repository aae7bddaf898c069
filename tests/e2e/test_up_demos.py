"""`acnmp up --demos SKILL=FILE` as a new user runs it (issue 36): "deployment is up" only once the
model service serves SKILL (row 3: it was printed before, and a predict right after failed
``unknown_skill``); Ctrl-C then says what it stops before the deployment stops (row 10). With
``--model-processes 2`` a client shares its predicts between both processes (issue 37)."""
from __future__ import annotations

import contextlib
import signal
import subprocess
import sys
import uuid

import numpy as np

import clients.client
from acnmp_core.data.demo_io import save_demos
from acnmp_core.tasks.viapoint.task import obstacle_demos
from clients.client import ACNMPClient
from services.learner.store import demo_set_to_arrays
from services.transport import wait_for_liveliness
from tests.paths import ROOT


@contextlib.contextmanager
def ctrl_c_at_the_end(proc: subprocess.Popen):
    """Yield a list that holds, after the block, the rest of ``proc``'s output: at the block's end
    ``proc`` gets SIGINT and must exit 0 (killed if it is still running when the block fails)."""
    out: list[str] = []
    try:
        yield out
        proc.send_signal(signal.SIGINT)
        out.append(proc.communicate(timeout=60)[0])
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, out


def test_up_with_demos_is_up_once_the_skill_is_served_and_ctrl_c_says_what_it_stops(tmp_path, acnmp_up,
                                                                                    monkeypatch):
    (tmp_path / "out").mkdir()
    save_demos(tmp_path / "out" / "mine.npz", demo_set_to_arrays(obstacle_demos(n_steps=30)))
    ns = f"demos-{uuid.uuid4().hex[:8]}"
    # enough steps that training outlasts the start of the other processes; the file named relative
    # to where the command runs (issue 65: the learner, which runs in the project's root, could not
    # read it, and `acnmp up` gave up after 5 restarts)
    proc, lines = acnmp_up("--namespace", ns, "--workers", "0", "--demos", "mine=out/mine.npz",
                           "--train-steps", "100", "--state-dir", "state", "--model-processes", "2", cwd=tmp_path)
    with ctrl_c_at_the_end(proc) as out:
        assert any("waiting for the model service to serve skill 'mine'" in ln for ln in lines), lines
        with ACNMPClient(namespace=ns, role="client", timeout=10) as client:
            info = client.info("mine")  # at once: was unknown_skill for as long as the training took
            assert info["skill"] == "mine" and info["version"] == 0
            # both model processes serve it; the client (its role's ACL) sends predicts to each in turn
            wait_for_liveliness(client.session, client.keys.model_process_token("mine"), count=2, timeout=30)
            sent = []
            real_call = clients.client.call
            monkeypatch.setattr(clients.client, "call", lambda s, key, *a, **k: sent.append(key) or real_call(
                s, key, *a, **k))
            client.model_processes("mine", at_least=2)  # its liveliness subscriber sees both (history)
            got = [client.predict("mine", [0.0], [[0.0, 0.0]], n_steps=20) for _ in range(6)]
        zids = set(client.model_processes("mine"))
        assert len(zids) == 2 and {k.rsplit("/", 1)[-1] for k in sent} == zids, sent  # both, nothing else
        assert all(k.startswith(client.keys.predict("mine") + "/") for k in sent)
        for p in got[1:]:  # the same weights in both processes: the same numbers
            np.testing.assert_array_equal(p.mean, got[0].mean)
    out = out[0]
    stopping = [ln for ln in out.splitlines() if ln.startswith("acnmp up: stopping")]
    assert len(stopping) == 1 and "learner" in stopping[0] and "model service (2 processes)" in stopping[0], out
    assert "deployment stopped" in out.splitlines()[-1]


def test_a_learner_given_up_on_is_named_with_its_reason(tmp_path, capsys):
    """Issue 65, friction 1: `acnmp up` said only "learner exited before serving 'via'; logs in ...";
    the reason (here: a file it cannot read) was in the learner's log alone. No restart here
    (the policy allows none), so the child is given up on at its first exit. The learner trains
    another skill first, so that it is surely live (it serves while it trains) when it fails."""
    import threading

    from clients.commands.up import wait_for_skill
    from services.launcher import LocalDeployment
    from services.launcher.supervision import RestartPolicy

    save_demos(tmp_path / "first.npz", demo_set_to_arrays(obstacle_demos(n_steps=30)))
    dep = LocalDeployment(f"gone-{uuid.uuid4().hex[:8]}", 0, model=False, state_dir=tmp_path / "state",
                          learner_args=["--demos", f"first={tmp_path / 'first.npz'}", "--demos",
                                        f"via={tmp_path / 'moved-away.npz'}", "--train-steps", "300"],
                          restart_policy=RestartPolicy(max_restarts=0))
    try:
        dep.start()
        assert not wait_for_skill(dep, "via", threading.Event(), "moved-away.npz", poll=0.2)
    finally:
        dep.stop()
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert line.startswith("acnmp up: learner exited before serving 'via'; learner: "), line
    assert "cannot read a demonstration file at" in line and "moved-away.npz" in line, line
    assert f"(log {tmp_path / 'state' / 'logs' / 'learner.log'})" in line


def test_ctrl_c_while_the_learner_trains_stops_it_without_a_kill(tmp_path, acnmp_up):
    """Row 10: `acnmp up` took 8-14 s to stop when its learner was training (the default skill at a
    first start, a train request, an assimilation): SIGTERM was not seen until the training ended,
    so the launcher SIGKILLed the learner after its stop timeout. Training now stops at its next step."""
    proc = subprocess.Popen([sys.executable, "-m", "clients.cli", "up", "--namespace", f"t-{uuid.uuid4().hex[:8]}",
                             "--workers", "0", "--train-steps", "1000000", "--state-dir", str(tmp_path / "state")],
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    with ctrl_c_at_the_end(proc) as out:
        for line in proc.stdout:  # the learner is live and trains the default skill
            if "waiting for the model service to serve skill 'e1'" in line:
                break
    out = out[0]
    last = out.strip().splitlines()[-1]
    assert last.startswith("deployment stopped:") and "learner=0" in last, out  # was learner=-9
    assert "stopped while training the --demos skills" in (tmp_path / "state" / "logs" / "learner.log").read_text()
