"""Robot plugins (issue 33): kinds from installed packages' entry points, from ACNMP_ROBOT_PLUGINS
and from ``package.module:attr``; a broken plugin is one line naming it and why, and every other
kind keeps working."""
from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import acnmp_core.robots.registry as registry
import acnmp_core.tasks.registry as tasks
from acnmp_core.errors import UnknownRobotError
from acnmp_core.robots.registry import plugin_problems, robot, robot_kinds, robot_source
from services.worker.core import Worker, rollout_request
from tests.paths import ROOT


GOOD = '''
import numpy as np
from acnmp_core.robots.spec import RobotSpec, TaskFactory
from acnmp_core.rollout import RolloutBatch

class Still:
    def evaluate(self, trajectories, times, task_params=None):
        b, t, _ = np.shape(trajectories)
        return RolloutBatch(rewards=-np.abs(np.asarray(trajectories)).sum(axis=2), success=np.ones(b, bool))

ROBOT = RobotSpec("{kind}", "holds still", tasks={{"{task}": {{}}}}, new_tasks={{"{task}": TaskFactory(lambda p: Still())}})
'''


def reset_registry(monkeypatch, tmp_path) -> None:
    """The registry as built in (plugins not loaded yet), restored after the test; ``tmp_path`` on
    sys.path for plugin modules. The tasks that plugins loaded earlier in this process brought are
    left out too (an installed plugin's task would otherwise clash when it is loaded again)."""
    built_in = {k for k in registry._ROBOTS if registry._SOURCES[k] == "built in"}
    brought = {t for k, spec in registry._ROBOTS.items() if k not in built_in for t in spec.new_tasks}
    monkeypatch.setattr(registry, "_ROBOTS", {k: v for k, v in registry._ROBOTS.items() if k in built_in})
    monkeypatch.setattr(registry, "_SOURCES", {k: "built in" for k in registry._ROBOTS})
    monkeypatch.setattr(registry, "_PROBLEMS", [])
    monkeypatch.setattr(registry, "_REFERENCES", [])
    monkeypatch.setattr(registry, "_PLUGINS_LOADED", False)
    monkeypatch.setattr(tasks, "_FACTORIES", {k: v for k, v in tasks._FACTORIES.items() if k not in brought})
    monkeypatch.setattr(tasks, "_CREDITS", {k: v for k, v in tasks._CREDITS.items() if k not in brought})
    registry._reference.cache_clear()
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delenv(registry.PLUGINS_ENV, raising=False)


@pytest.fixture
def fresh_registry(monkeypatch, tmp_path):
    """:func:`reset_registry` for one test; yields ``tmp_path``."""
    reset_registry(monkeypatch, tmp_path)
    yield tmp_path
    registry._reference.cache_clear()


def write_module(root: Path, name: str, text: str) -> None:
    (root / f"{name}.py").write_text(textwrap.dedent(text))


def write_dist(root: Path, dist: str, entry_points: dict[str, str]) -> None:
    """An installed distribution's metadata declaring ``acnmp.robots`` entry points (what pip
    writes for a package's ``[project.entry-points."acnmp.robots"]``)."""
    info = root / f"{dist}-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: 0.1\n")
    lines = "".join(f"{k} = {v}\n" for k, v in entry_points.items())
    (info / "entry_points.txt").write_text(f"[acnmp.robots]\n{lines}")


def test_a_reference_registers_its_robot_and_its_task(fresh_registry):
    write_module(fresh_registry, "still_bot", GOOD.format(kind="still", task="hold"))
    spec = robot("still_bot:ROBOT")
    assert spec.kind == "still" and robot("still") is spec and "still" in robot_kinds()
    assert robot_source("still") == "still_bot:ROBOT"
    batch = spec.make_evaluator("hold").evaluate(np.zeros((2, 5, 1)), np.linspace(0, 1, 5))
    assert batch.success.all() and tasks.task_credit("hold") == "step"
    assert robot("still_bot:ROBOT") is spec  # named again: the same robot, no clash
    assert registry.plugins_for_children() == "still_bot:ROBOT"


def test_installed_entry_points_are_found_and_broken_ones_are_one_line_each(fresh_registry):
    write_module(fresh_registry, "still_bot", GOOD.format(kind="still", task="hold"))
    write_module(fresh_registry, "typo_bot", "import numpy as np\nROBOT = np.zeros(3)\n")
    write_module(fresh_registry, "crash_bot", "raise RuntimeError('no licence server\\nsecond line')\n")
    write_module(fresh_registry, "bad_spec", '''
        from acnmp_core.robots.spec import RobotSpec
        ROBOT = RobotSpec("has space", "x", tasks={"viapoint": {}})
    ''')
    write_module(fresh_registry, "clash_bot", GOOD.format(kind="ur10", task="hold2"))
    write_dist(fresh_registry, "robots_of_a_lab", {
        "still": "still_bot:ROBOT", "typo": "typo_bot:ROBOT", "crash": "crash_bot:ROBOT",
        "malformed": "bad_spec:ROBOT", "clash": "clash_bot:ROBOT", "missing": "still_bot:NOPE"})
    kinds = robot_kinds()
    assert kinds[:5] == ("point2d", "planar3", "planar4", "ur10", "pour") and "still" in kinds
    assert robot_source("still") == "'still' (entry point of robots_of_a_lab)"
    problems = {p.source.split()[0]: p.reason for p in plugin_problems()}
    assert set(problems) == {"'typo'", "'crash'", "'malformed'", "'clash'", "'missing'"}
    assert "got ndarray" in problems["'typo'"]
    assert problems["'crash'"] == "cannot import 'crash_bot': RuntimeError: no licence server"
    assert "kind: a robot kind is" in problems["'malformed'"] and "'has space'" in problems["'malformed'"]
    assert "'ur10' is already registered (built in)" in problems["'clash'"]
    assert "has no attribute 'NOPE'" in problems["'missing'"]
    assert all("\n" not in str(p) for p in plugin_problems())
    # the built-in kinds keep working, and the clash did not replace the UR10
    assert robot("ur10").summary.startswith("UR10") and "hold2" not in tasks.task_names()
    with pytest.raises(UnknownRobotError, match="typo"):  # asking for a missing kind names the broken plugins
        robot("juggler")


def test_a_reset_registry_loads_an_installed_plugin_with_its_task_again(fresh_registry, monkeypatch):
    """Issue 65, friction 3: with a plugin that brings a task installed (``pip install -e`` of a
    user's robot package), the registry reset of these tests kept the task the plugin had brought
    when an earlier test loaded it, so loading it again clashed and three tests here failed."""
    write_module(fresh_registry, "lab_bot", GOOD.format(kind="lab", task="stack"))
    write_dist(fresh_registry, "robots_of_a_lab", {"lab": "lab_bot:ROBOT"})
    assert "lab" in robot_kinds() and "stack" in tasks.task_names()  # loaded, as by an earlier test
    reset_registry(monkeypatch, fresh_registry)  # what the next test's fixture does
    assert "stack" not in tasks.task_names()
    assert "lab" in robot_kinds() and plugin_problems() == ()


def test_a_plugin_task_cannot_replace_a_built_in_task(fresh_registry):
    write_module(fresh_registry, "thief", GOOD.format(kind="thief", task="push"))
    with pytest.raises(UnknownRobotError, match="'push'.*already taken"):
        robot("thief:ROBOT")
    assert "thief" not in robot_kinds()


def test_the_environment_variable_names_plugins_for_every_process(fresh_registry, monkeypatch):
    write_module(fresh_registry, "still_bot", GOOD.format(kind="still", task="hold"))
    monkeypatch.setenv(registry.PLUGINS_ENV, "still_bot:ROBOT, nowhere:ROBOT")
    assert "still" in robot_kinds()
    assert [str(p) for p in plugin_problems()] == [
        "robot plugin nowhere:ROBOT (ACNMP_ROBOT_PLUGINS) left out: cannot import 'nowhere': "
        "ModuleNotFoundError: No module named 'nowhere'"]


def test_the_command_line_says_one_line_for_a_broken_plugin_and_serves_the_rest(tmp_path):
    (tmp_path / "crash_bot.py").write_text("import not_a_module_anywhere\n")
    env = {"PYTHONPATH": f"{tmp_path}:{ROOT}", "PATH": "/usr/bin:/bin", "ACNMP_ROBOT_PLUGINS": "crash_bot:ROBOT"}
    listed = subprocess.run([sys.executable, "-m", "clients.cli", "robots"], cwd=tmp_path, env=env,
                            capture_output=True, text=True)
    assert listed.returncode == 0 and "pour" in listed.stdout
    assert listed.stderr.strip() == ("robot plugin crash_bot:ROBOT (ACNMP_ROBOT_PLUGINS) left out: cannot import "
                                     "'crash_bot': ModuleNotFoundError: No module named 'not_a_module_anywhere'")
    served = subprocess.run([sys.executable, "-m", "clients.cli", "serve", "worker", "--robot", "crash_bot:ROBOT"],
                            cwd=tmp_path, env=env, capture_output=True, text=True)
    assert served.returncode == 2 and "Traceback" not in served.stderr
    assert "argument --robot: plugin 'crash_bot:ROBOT': cannot import 'crash_bot'" in served.stderr


def test_a_plugin_imports_the_robot_types_without_the_registry():
    """The types (RobotSpec, RobotBody, Joint, TaskFactory, the drawings) live apart from the
    registry: importing them loads neither the registry nor the built-in robots and tasks."""
    code = ("import sys, acnmp_core.robots.spec as s, acnmp_core.robots.gym_robot; "
            "print(sorted(m for m in sys.modules if m.startswith('acnmp_core.robots') or m.startswith('acnmp_core.tasks')))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    assert eval(out) == ["acnmp_core.robots", "acnmp_core.robots.gym_robot", "acnmp_core.robots.spec"]


def test_a_worker_serves_a_built_in_kind_while_a_plugin_is_broken(fresh_registry, monkeypatch):
    write_module(fresh_registry, "bad_spec", '''
        from acnmp_core.robots.spec import RobotSpec
        ROBOT = RobotSpec("fine", "x", tasks={})
    ''')
    monkeypatch.setenv(registry.PLUGINS_ENV, "bad_spec:ROBOT")
    worker = Worker("point2d", "w1")
    t = np.linspace(0, 1, 5)
    reply = worker.handle(rollout_request("viapoint", {"t_v": 0.5, "point": [0.0, 0.0], "tolerance": 0.1},
                                          np.zeros((2, 5, 2)), t))
    assert reply["success"].tolist() == [True, True]
    assert [p.reason for p in plugin_problems()] == [
        "cannot import 'bad_spec': InputError: tasks: robot 'fine' must run at least one task "
        "(a map name -> fixed parameters)"]


def test_pybullet_is_imported_without_its_banner():
    """Issue 36, a friction: every PyBullet run printed its build-time banner."""
    out = subprocess.run([sys.executable, "-c", "import acnmp_core.sim.planar_arm, acnmp_core.tasks.transfer.scene, "
                          "acnmp_core.sim.ur10, acnmp_core.sim.pour"], cwd=ROOT, capture_output=True, text=True)
    assert out.returncode == 0 and "pybullet build time" not in out.stdout + out.stderr, out.stderr
