"""``acnmp up`` then, in another process, ``acnmp query`` / ``ACNMPClient()`` / ``acnmp status`` /
``acnmp experiment viapoint --distributed`` with no arguments: the run file finds the deployment,
the client's credentials let it in, and the default skill (E1's via-point skill ``e1``) answers.
Then Ctrl-C stops it and the run file goes. (That E1 on a deployment gives the in-process numbers
is tests/e2e/test_e1_distributed.py: the same DeployedSkill code on a fresh deployment.)"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from clients.cli import main
from clients.client import ACNMPClient
from services.launcher import LocalDeployment
from services.transport.runfile import DeploymentNotFound, find, running
from tests.paths import ROOT

# seed 0 and the deployment's --train-steps: E1's training is what `acnmp up` trained its skill e1 with
E1_ARGS = ["--seeds", "1", "--budget", "4", "--train-steps", "20", "--quiet"]


def _cli(*args: str, timeout: float = 60) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT), RERUN_ANALYTICS="0")
    return subprocess.run([sys.executable, "-m", "clients.cli", *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=timeout)


def test_acnmp_up_then_query_with_no_arguments_20_of_20_and_ctrl_c(tmp_path, capsys, acnmp_up):
    # --train-steps 20: the default skill is E1's, trained briefly (a user's first start trains 3000 steps)
    proc, _ = acnmp_up("--workers", "1", "--train-steps", "20", "--state-dir", str(tmp_path / "state"))
    try:
        run = find()
        assert run.namespace == "default" and run.pid == proc.pid
        for path in (run.path, Path(run.credentials), Path(run.operator_credentials)):
            assert path.stat().st_mode & 0o777 == 0o600, path
        assert run.path.parent.stat().st_mode & 0o777 == 0o700

        # no argument at all: the run file finds the deployment, its one served skill is asked
        out = _cli("query", "info")
        assert out.returncode == 0 and out.stdout.startswith("skill e1 version 0"), out.stderr
        assert main(["query", "predict", "--obs", "0:0,0", "--steps", "5"]) == 0
        assert "skill e1 version 0: 5 steps x 2 dims" in capsys.readouterr().out
        # the anchor given by hand (as before the run file): its credentials are used
        assert main(["query", "info", "--skill", "e1", "--connect", run.anchor]) == 0
        assert capsys.readouterr().out.startswith("skill e1 version 0")

        # a second deployment: the default namespace is still found, --namespace picks the other
        with LocalDeployment("other", workers=0, model=False, learner=False, secure=True):
            assert sorted(r.namespace for r in running()) == ["default", "other"]
            assert main(["status"]) == 0
            out = capsys.readouterr().out
            assert "deployment 'default'" in out and "deployment 'other'" in out
            health = {ln.split()[0]: ln.split()[-1] for ln in out.splitlines() if ln.startswith("  ") and
                      ln.split()[0] in ("learner", "model")}
            assert health == {"learner": "ok", "model": "ok"}, out
            with ACNMPClient(namespace="other", role="client") as c:
                assert c.namespace == "other"

        # 20 fresh clients in a row, each a new session finding the deployment by its run file
        answered = 0
        for _ in range(20):
            with ACNMPClient(role="client", timeout=10) as client:
                answered += client.info("e1")["skill"] == "e1"
        assert answered == 20

        # `acnmp experiment viapoint --distributed` runs on this deployment too (role operator)
        out_json = tmp_path / "e1.json"
        assert main(["experiment", "viapoint", *E1_ARGS, "--distributed", "--json", str(out_json)]) == 0
        assert "running E1 on deployment 'default'" in capsys.readouterr().out
        e1 = json.loads(out_json.read_text())
        assert all(m["job"] for m in e1["methods"].values())
        # what it ran on, as the deployment is: joined, its one worker, no recorder, authenticated
        assert e1["deployment"] == {"namespace": "default", "attached": True, "workers": 1, "recording": None,
                                    "authenticated": True}
        # the skill e1 was already trained from E1's demonstrations with these settings: not again
        assert e1["skill"] == {"name": "e1", "version": 0, "trained": False}
        # ... which records with its own recorder, and --namespace must name a running deployment
        assert main(["experiment", "viapoint", *E1_ARGS, "--distributed", "--record", str(tmp_path / "x.rrd")]) == 2
        assert main(["experiment", "viapoint", *E1_ARGS, "--distributed", "--namespace", "nope"]) == 2
        # --insecure is about a deployment the experiment starts: refused for a running one, and alone
        assert main(["experiment", "viapoint", *E1_ARGS, "--distributed", "--insecure"]) == 2
        assert main(["experiment", "viapoint", *E1_ARGS, "--insecure"]) == 2
        assert "--insecure: only with --distributed" in capsys.readouterr().err

        proc.send_signal(signal.SIGINT)  # what Ctrl-C in its terminal sends
        rest, _ = proc.communicate(timeout=30)
        assert proc.returncode == 0, rest
        assert "deployment stopped: learner=0 model=0 worker-point2d-0=0" in rest, rest
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert not run.path.parent.exists()  # run file and secrets removed on a clean exit
    with pytest.raises(DeploymentNotFound):
        ACNMPClient(role="client")
    assert main(["query", "info", "--skill", "e1"]) == 1
    assert "no running deployment" in capsys.readouterr().err
