"""The spawner (services/launcher/spawner.py): a deployment's learner, model and workers are forks of
one process that imported torch, and each behaves as the ``python -m`` interpreter it replaces:
its arguments, exit code, output and session; signals reach it, a kill -9 is its exit code; a
child whose environment differs starts as a fresh interpreter."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import psutil
import pytest

from services.launcher import LocalDeployment
from services.launcher.deployment import ROOT, child_env, share_spawner
from services.launcher.spawner import Spawner, SpawnerGone
from tests.conftest import share_one_spawner


@pytest.fixture
def spawner(tmp_path):
    with Spawner(["services.worker"], child_env(), ROOT, tmp_path / "spawner.log") as sp:
        yield sp


def test_a_forked_child_runs_its_module_as_python_m_would(spawner, tmp_path):
    log = tmp_path / "help.log"
    child = spawner.spawn([sys.executable, "-m", "services.worker", "--help"], log)
    assert child.wait(timeout=60) == 0
    assert "usage: acnmp serve worker" in log.read_text()
    bad = spawner.spawn([sys.executable, "-m", "services.worker", "--robot"], tmp_path / "bad.log")
    assert bad.wait(timeout=60) == 2  # argparse's usage error, as from a fresh interpreter
    assert "error:" in (tmp_path / "bad.log").read_text()


def test_signals_reach_the_child_and_its_exit_code_is_popens(spawner, tmp_path):
    argv = [sys.executable, "-m", "services.worker", "--namespace", "spawn", "--robot", "point2d", "--id", "w0"]
    child = spawner.spawn(argv, tmp_path / "w0.log")
    with pytest.raises(subprocess.TimeoutExpired):
        child.wait(timeout=0.2)
    assert child.poll() is None
    _wait_for_line(tmp_path / "w0.log", "worker live as", child)  # running: its title was set after the fork
    proc = psutil.Process(child.pid)
    assert proc.ppid() == spawner.pid
    assert " ".join(proc.cmdline()).startswith(" ".join(argv))  # what `ps` shows: the command it replaces
    assert os.getsid(child.pid) == child.pid != os.getsid(0)  # a session of its own: no terminal's Ctrl-C
    child.kill()
    assert child.wait(timeout=30) == -signal.SIGKILL and child.poll() == -signal.SIGKILL
    child.kill()  # after its exit, a no-op as Popen's
    child = spawner.spawn(argv, tmp_path / "w1.log")
    _wait_for_line(tmp_path / "w1.log", "worker live as", child)
    child.terminate()  # SIGTERM: the service's clean stop
    assert child.wait(timeout=60) == 0
    assert "signal SIGTERM: shutting down" in (tmp_path / "w1.log").read_text()


def _wait_for_line(log, text: str, child, timeout: float = 60.0) -> None:
    """Wait until the child's log holds ``text`` (it printed it; fails if the child exits first)."""
    deadline = time.monotonic() + timeout
    while not (log.exists() and text in log.read_text()):
        assert child.poll() is None, log.read_text()
        assert time.monotonic() < deadline, f"no {text!r} in {log}"
        time.sleep(0.05)


def test_a_closed_spawner_refuses_and_only_matching_environments_are_forked(tmp_path):
    sp = Spawner(["services.worker"], child_env(), ROOT, tmp_path / "spawner.log")
    argv = [sys.executable, "-m", "services.worker", "--help"]
    assert sp.usable_for(argv, child_env())
    assert not sp.usable_for(argv, {**child_env(), "EXTRA": "1"})  # another environment: a fresh interpreter
    assert not sp.usable_for(argv, {**child_env(), "OMP_NUM_THREADS": "2"})  # read when torch is imported
    assert sp.usable_for(argv, {**child_env(), "ACNMP_RUNTIME_DIR": str(tmp_path)})  # read at run time only
    assert not sp.usable_for([sys.executable, "-m", "services.recording"], child_env())  # rerun starts threads
    sp.close()
    with pytest.raises(SpawnerGone):
        sp.spawn(argv, tmp_path / "x.log")
    assert not sp.usable_for(argv, child_env())


@pytest.fixture
def own_spawners(tmp_path_factory):
    """Each deployment starts (and stops) a spawner of its own during the test (the suite's
    processes otherwise keep one: tests/conftest.py), as without share_spawner."""
    share_spawner(None)
    yield
    share_one_spawner(tmp_path_factory)


def test_a_deployments_learner_model_and_workers_are_forks_and_a_respawn_is_too(tmp_path, own_spawners):
    with LocalDeployment("forked", workers=1, state_dir=tmp_path / "state", supervise=False) as dep:
        spawner = dep.spawner_pid
        for name in ("learner", "model", "worker-point2d-0"):
            assert psutil.Process(dep.children[name].pid).ppid() == spawner, name
        dep.kill("worker-point2d-0")
        assert dep.children["worker-point2d-0"].proc.returncode == -signal.SIGKILL
        again = dep.respawn("worker-point2d-0")
        assert psutil.Process(again.pid).ppid() == spawner
    assert not psutil.pid_exists(spawner) or psutil.Process(spawner).status() == psutil.STATUS_ZOMBIE
    with LocalDeployment("fresh", workers=1, model=False, learner=False, state_dir=tmp_path / "s2",
                         fork_server=False) as dep:
        assert dep.spawner_pid is None and psutil.Process(dep.children["worker-point2d-0"].pid).ppid() == os.getpid()


def test_a_child_gets_the_environment_it_was_spawned_with(spawner, tmp_path):
    env = {**child_env(), "ACNMP_RUNTIME_DIR": str(tmp_path / "mine")}
    log = tmp_path / "env.log"
    child = spawner.spawn([sys.executable, "-m", "tests.e2e.spawned_env", "ACNMP_RUNTIME_DIR", "ACNMP_PARENT_PID"],
                          log, env)
    assert child.wait(timeout=60) == 0
    # its own runtime directory; it watches the spawner, not the launcher
    assert log.read_text().split() == [f"ACNMP_RUNTIME_DIR={tmp_path / 'mine'}", f"ACNMP_PARENT_PID={spawner.pid}"]


def test_a_kept_spawner_serves_the_deployments_of_a_process_until_it_is_closed(tmp_path, own_spawners,
                                                                               monkeypatch):
    share_spawner(tmp_path / "kept.log", per_child_env=["PYTEST_CURRENT_TEST"])
    pids = []
    for run in ("a", "b"):  # each test's deployments have their own runtime directory
        monkeypatch.setenv("ACNMP_RUNTIME_DIR", str(tmp_path / f"run-{run}"))
        with LocalDeployment(f"kept-{run}", workers=1, model=False, state_dir=tmp_path / run, supervise=False) as dep:
            pids.append(dep.spawner_pid)
            assert psutil.Process(dep.children["worker-point2d-0"].pid).ppid() == dep.spawner_pid
    kept = psutil.Process(pids[0])
    assert pids[0] == pids[1] and kept.is_running()  # it outlived the first deployment
    monkeypatch.setenv("PYTHONWARNINGS", "ignore")  # read as an interpreter starts: not the kept spawner's
    with LocalDeployment("kept-c", workers=1, model=False, learner=False, state_dir=tmp_path / "c",
                         supervise=False) as dep:
        assert dep.spawner_pid not in (None, pids[0])
    share_spawner(None)
    assert not kept.is_running()  # closed: it exited
