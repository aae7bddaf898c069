"""Shared fixtures and the test layers.

``tests/unit``: one process, no zenoh session, no child process. ``tests/e2e``: real zenoh
sessions on 127.0.0.1 and/or child processes; every test there is marked ``e2e`` (added below).
Tests marked ``slow`` (minutes each) run only when a ``-m`` expression names them (``-m slow``,
``-m "slow or not slow"``) or their node id is given: any other selection, ``-m "not e2e"``
included, leaves them out; ``--fast`` leaves out the heavy ones too (tests/selection.py).
"""
from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from tests.selection import add_options, deselect

os.environ.setdefault("RERUN_ANALYTICS", "0")

E2E = Path(__file__).parent / "e2e"


def pytest_addoption(parser):
    add_options(parser)


def pytest_collection_modifyitems(config, items):
    for item in items:
        if E2E in Path(str(item.fspath)).parents:
            item.add_marker(pytest.mark.e2e)
    deselect(config, items)


@pytest.fixture(scope="session", autouse=True)
def _one_torch_thread():
    """One torch thread in every process that runs tests (not at import: pytest-xdist's controller,
    which runs none, then starts its workers without importing torch first)."""
    import torch

    torch.set_num_threads(1)


def share_one_spawner(tmp_path_factory) -> None:
    """The deployments this test process starts fork their learners, model processes and workers
    from one spawner (services.launcher.deployment.share_spawner): torch is imported once per
    pytest worker, not once per deployment. Its log: ``<basetemp>/spawner.log``."""
    from services.launcher.deployment import share_spawner

    share_spawner(tmp_path_factory.getbasetemp() / "spawner.log", per_child_env=["PYTEST_CURRENT_TEST"])


@pytest.fixture(scope="session", autouse=True)
def _one_spawner_per_test_process(tmp_path_factory):
    """See :func:`share_one_spawner`; closed at the session's end."""
    from services.launcher.deployment import share_spawner

    share_one_spawner(tmp_path_factory)
    yield
    share_spawner(None)


@pytest.fixture(scope="session", autouse=True)
def _user_state_home(tmp_path_factory):
    """Deployments started without --state-dir keep their state under this run's temporary
    directory, never in the user's own ~/.local/state/acnmp."""
    before = os.environ.get("XDG_STATE_HOME")
    os.environ["XDG_STATE_HOME"] = str(tmp_path_factory.mktemp("xdg-state"))
    yield
    if before is None:
        os.environ.pop("XDG_STATE_HOME", None)
    else:
        os.environ["XDG_STATE_HOME"] = before


@pytest.fixture
def run_cli(capsys):
    """``run_cli(*argv, retry_unavailable=30.0) -> (exit code, stdout, stderr)``: ``acnmp ARGV`` in
    this process, run again while it answers ``unavailable`` (a fresh session may query before it
    has discovered the service's queryable), for up to ``retry_unavailable`` seconds."""
    import time

    from clients.cli import main

    def run(*argv: str, retry_unavailable: float = 30.0) -> tuple[int, str, str]:
        deadline = time.monotonic() + retry_unavailable
        while True:
            code = main(list(argv))
            out, err = capsys.readouterr()
            if "unavailable" not in err or time.monotonic() > deadline:
                return code, out, err
            time.sleep(0.2)

    return run


@pytest.fixture(scope="session")
def e1_demos():
    from acnmp_core.tasks.viapoint.task import obstacle_demos

    return obstacle_demos()


def _run_dir(tmp_path_factory) -> Path:
    """This run's temporary directory, the same for every pytest-xdist worker (each worker's own
    basetemp is inside it; without xdist it is the basetemp)."""
    base = tmp_path_factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


@contextlib.contextmanager
def _once(path: Path):
    """``with _once(path) as todo:`` build ``path`` when ``todo`` (no other worker of this run has):
    the workers of one run take turns under a file lock, so a long fixture is built once per run."""
    from filelock import FileLock

    path.parent.mkdir(parents=True, exist_ok=True)
    with FileLock(str(path) + ".lock"):
        yield not path.exists()


@pytest.fixture(scope="session")
def e1_model(e1_demos, tmp_path_factory):
    """The paper's CNMP (no linear path) trained on the E1 demonstrations (3000 steps, seed 0): its
    mean misses the extrapolated via-point, what the adaptation tests start from. Tests must
    deep-copy before changing it. Trained once per run (the first xdist worker saves it, the others
    load it)."""
    from acnmp_core.model.checkpoint import load_checkpoint, save_checkpoint
    from acnmp_core.model.cnmp import CNMP, CNMPConfig
    from acnmp_core.model.training import TrainConfig, train

    path = _run_dir(tmp_path_factory) / "e1_model_3000.pt"
    with _once(path) as todo:
        if not todo:
            return load_checkpoint(path)[0]
        model = CNMP(CNMPConfig(n_outputs=2, prior="none"), seed=0)
        train(model, e1_demos, TrainConfig(steps=3000), seed=0, progress=False)
        save_checkpoint(model, path)
        return model


#: E1's size in the tests that run it across a deployment: (seed, budget, train steps).
E1_SMALL = (2, 10, 100)


@pytest.fixture(scope="session")
def e1_small_run(tmp_path_factory):
    """E1 in one process at :data:`E1_SMALL` (a ViaPointRun), what the distributed runs must equal.
    Run once per test run (the first xdist worker saves it, the others load it)."""
    import pickle

    from acnmp_core.experiments.viapoint import run_viapoint

    path = _run_dir(tmp_path_factory) / "e1_small_run.pkl"
    with _once(path) as todo:
        if not todo:
            return pickle.loads(path.read_bytes())
        seed, budget, steps = E1_SMALL
        run = run_viapoint(seed=seed, budget=budget, train_steps=steps, progress=False)
        path.write_bytes(pickle.dumps(run))
        return run


@pytest.fixture(scope="session")
def small_model(e1_demos):
    """A small CNMP on the E1 demos (2 x 32 units, 50 steps): fast to train, for tests where only
    its determinism matters."""
    from acnmp_core.model.cnmp import CNMP, CNMPConfig
    from acnmp_core.model.training import TrainConfig, train

    model = CNMP(CNMPConfig(n_outputs=2, encoder_widths=(32, 32), decoder_widths=(32, 32)), seed=0)
    train(model, e1_demos, TrainConfig(steps=50), seed=0, progress=False)
    return model.eval()


def _demo_file(tmp_path_factory, folder: str, default_path: str, make) -> Path:
    """``<the run's folder>/<folder>/<default_path's name>``, written by ``make(path)`` once per run
    (the xdist workers share it)."""
    path = _run_dir(tmp_path_factory) / folder / Path(default_path).name
    with _once(path) as todo:
        if todo:
            make(str(path))
    return path


@pytest.fixture(scope="session")
def ur10_demo_file(tmp_path_factory):
    """Path of the E5 demonstration set, generated once per run (~6 s; shared by the xdist workers) in a temporary folder
    under its default name (with ``ACNMP_CACHE`` set to that folder, the default loads it)."""
    from acnmp_core.tasks.ur10_pick_place.demos import default_demo_path, ur10_demos

    return _demo_file(tmp_path_factory, "ur10_demos", default_demo_path(), lambda path: ur10_demos(path=path))


@pytest.fixture(scope="session")
def pour_demo_file(tmp_path_factory):
    """Path of the E6 demonstration set, generated once per run (~15-25 s; shared by the xdist workers) in a temporary folder
    under its default name (with ``ACNMP_CACHE`` set to that folder, the default loads it)."""
    from acnmp_core.tasks.pour.demos import default_demo_path, pour_demos

    return _demo_file(tmp_path_factory, "pour_demos", default_demo_path(), pour_demos)


@pytest.fixture(scope="session")
def serving():
    """``with serving(config) as line:`` runs a service on a thread (see :func:`_serving`)."""
    return _serving


@contextlib.contextmanager
def _serving(config, timeout: float = 15.0):
    """Run a service config (services.transport.service.Service) on a thread of this process until
    the block ends; yields the line it printed when live. Fails the test if it is not live in time
    or does not stop."""
    from services.transport.service import run_service

    stop, live, lines, result = threading.Event(), threading.Event(), [], []

    def ready(line: str) -> None:
        lines.append(line)
        live.set()

    def target() -> None:
        try:
            result.append(run_service(config, stop=stop, ready=ready))
        finally:
            live.set()

    thread = threading.Thread(target=target, name=f"serve-{config.name}", daemon=True)
    thread.start()
    try:
        assert live.wait(timeout) and lines, f"{config.name} did not come up"
        yield lines[0]
    finally:
        stop.set()
        thread.join(timeout=timeout)
        assert not thread.is_alive(), f"{config.name} did not stop"
    assert result == [0], f"{config.name} exited with {result}"


@pytest.fixture(scope="session")
def wait_job():
    """``wait_job(session, keys, job, pred, timeout=120)``: poll the job's status until ``pred(status)``
    holds and return that status (the timeout is only a liveness bound)."""
    import time

    from services.transport import call

    def wait(session, keys, job: str, pred, timeout: float = 120.0) -> dict:
        deadline = time.monotonic() + timeout
        while True:
            st = call(session, keys.job_status(job), timeout=10)
            if pred(st):
                return st
            assert time.monotonic() < deadline, st
            time.sleep(0.1)

    return wait


@pytest.fixture(scope="session")
def verify_rrd():
    """``verify_rrd(path)``: ``rerun rrd verify`` passes on ``path`` (the footer and every chunk are
    valid). The ``rerun`` command comes with rerun-sdk; its absence is a broken install, not a skip."""
    rerun = Path(sys.executable).with_name("rerun")
    assert rerun.exists(), f"{rerun}: the rerun command of rerun-sdk is missing"

    def verify(path) -> None:
        out = subprocess.run([str(rerun), "rrd", "verify", str(path)], capture_output=True, text=True, timeout=60)
        assert out.returncode == 0, out.stderr

    return verify


@pytest.fixture
def saved_figures(monkeypatch):
    """Every matplotlib figure saved during the test, as (figure, path), in order: so a test checks a
    plot's axes, legend and data rather than the size of its file."""
    from matplotlib.figure import Figure

    saved = []
    real = Figure.savefig

    def savefig(self, fname, *args, **kwargs):
        saved.append((self, Path(fname)))
        return real(self, fname, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", savefig)
    return saved



@pytest.fixture(autouse=True)
def _private_runtime_dir(tmp_path_factory, monkeypatch):
    """Every test gets its own runtime directory (services/transport/runfile.py): the run files
    and secrets of the deployments it starts never meet the user's, nor another test's."""
    monkeypatch.setenv("ACNMP_RUNTIME_DIR", str(tmp_path_factory.mktemp("run")))


@pytest.fixture(autouse=True)
def _training_threads_as_configured():
    """A command run in-process (``acnmp experiment wall --threads N``) chooses the training threads
    for its whole process; after each test the choice goes back to the environment's."""
    yield
    from acnmp_core.threads import set_training_threads

    set_training_threads(None)


@pytest.fixture(scope="session")
def acnmp_up():
    """``start(*args)``: run ``acnmp up ARGS`` as a child process (stdout piped, text) and read its
    output until "deployment is up"; returns (Popen, lines read). The caller stops it (in a finally).
    ``path``: directories put before the project's on PYTHONPATH (e.g. an installed plugin's);
    ``cwd``: where it runs (default: the project's root)."""
    root = Path(__file__).resolve().parents[1]

    def start(*args: str, path: tuple[str, ...] = (), cwd: str | os.PathLike | None = None
              ) -> tuple[subprocess.Popen, list[str]]:
        env = dict(os.environ, PYTHONPATH=os.pathsep.join([*path, str(root)]), RERUN_ANALYTICS="0")
        proc = subprocess.Popen([sys.executable, "-m", "clients.cli", "up", *args], cwd=cwd or root, env=env,
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        lines = []
        for line in proc.stdout:
            lines.append(line)
            if "deployment is up" in line:
                return proc, lines
        proc.wait()
        raise AssertionError("acnmp up ended before it was up:\n" + "".join(lines))

    return start


@pytest.fixture(scope="session")
def lerobot():
    """lerobot-dataset's ``ledataset.datasets`` modules (the ``datasets`` extra), imported as
    :func:`acnmp_core.datasets.lerobot.import_lerobot` says: ``lerobot_dataset``
    (LeRobotDataset) and ``utils`` (validate_frame, DEFAULT_FEATURES)."""
    from acnmp_core.datasets.lerobot import import_lerobot

    return import_lerobot()
