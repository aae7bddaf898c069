"""examples/my_robot as its README says (issue 33): the plugin package installed, `acnmp robots`
lists its kind from the entry point, `acnmp up --robot my_arm --demos reach=...` serves the skill
and runs workers of the plugin's robot, and examples/my_robot/adapt.py adapts the skill on that
deployment to a goal beyond the demonstrations."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.e2e.test_up_demos import ctrl_c_at_the_end
from tests.paths import ROOT

EXAMPLE = ROOT / "examples" / "my_robot"

pytest.importorskip("gymnasium", reason="gymnasium is not installed (scripts/setup.sh installs it)")


@pytest.fixture
def installed_example(tmp_path) -> Path:
    """The example package pip-installed into a directory of its own (not the test environment's
    site-packages, which other tests share); returns that directory, to put on PYTHONPATH."""
    src, site = tmp_path / "src", tmp_path / "site"
    shutil.copytree(EXAMPLE, src, ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation",
                    "--no-compile", "--target", str(site), str(src)], check=True, capture_output=True)
    return site


@pytest.mark.slow
def test_the_example_plugin_from_install_to_an_adaptation_on_a_deployment(installed_example, acnmp_up, tmp_path):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(installed_example), str(ROOT)]))
    listed = subprocess.run([sys.executable, "-m", "clients.cli", "robots", "--json"], cwd=tmp_path, env=env,
                            capture_output=True, text=True, check=True)
    rows = {r["kind"]: r for r in json.loads(listed.stdout)["robots"]}
    assert rows["my_arm"]["tasks"] == ["reach"] and "entry point of my-robot" in rows["my_arm"]["source"]
    assert {"point2d", "ur10"} <= set(rows)

    demos = installed_example / "my_robot" / "demos.npz"
    proc, lines = acnmp_up("--robot", "my_arm", "--workers", "1", "--no-default-skill", "--demos", f"reach={demos}",
                           "--train-steps", "800", "--state-dir", str(tmp_path / "state"),
                           path=(str(installed_example),))
    with ctrl_c_at_the_end(proc):
        run = subprocess.run([sys.executable, str(EXAMPLE / "adapt.py"), "0.6", "0.45"], cwd=tmp_path, env=env,
                             capture_output=True, text=True, timeout=300)
        assert run.returncode == 0, run.stderr[-2000:]
        # from the shell, no --robot: the deployment's workers are my_arm's (issue 72: it took point2d's and
        # failed); a task parameter too many is the user's argument, refused before anything is sent
        query = [sys.executable, "-m", "clients.cli", "query", "adapt", "--skill", "reach", "--task", "reach",
                 "--obs", "0:0.3,1.2", "--budget", "5"]
        queued = subprocess.run([*query, "--task-params", "0.6,0.45"], cwd=tmp_path, env=env, capture_output=True,
                                text=True, timeout=120)
        assert queued.returncode == 0 and "queued on skill reach (reach on my_arm," in queued.stdout, queued.stderr
        for bad, words in ((["--task-params", "0.6,0.45,0"], "--task-params: 3 values; skill 'reach' has 2 task "
                                                              "parameters ("),
                           (["--task-params", "0.6,0.45", "--obs", "1:0.3,1.2,0"],
                            "--obs: 3 values per observation; skill 'reach' has 2 outputs")):
            refused = subprocess.run([*query, *bad], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
            assert refused.returncode == 2 and refused.stderr.count("\n") == 1 and words in refused.stderr, \
                refused.stderr
    assert "success True" in run.stdout, run.stdout
