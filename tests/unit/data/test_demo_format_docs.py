"""A robot's author finds the demonstration file format where they look: docs/ROBOTS.md states
every array of acnmp_core.data.demo_io.FIELDS (key, shape, dtype, meaning) with an example written with
numpy, and the ``--help`` of each command taking ``--demos`` lists the arrays."""
from __future__ import annotations

import re

import numpy as np
import pytest

from acnmp_core.data.demo_io import FIELDS, load_demos
from clients.cli import main
from tests.paths import ROOT



def _section(text: str, title: str) -> str:
    start = text.index(f"## {title}\n")
    end = text.find("\n## ", start + 1)
    return text[start:end if end >= 0 else None]


def test_robots_md_states_every_array_and_its_numpy_example_writes_a_file_load_demos_reads(tmp_path):
    section = _section((ROOT / "docs" / "ROBOTS.md").read_text(), "The demonstration file")
    for f in FIELDS:
        assert f"| `{f.key}` | {f.shape} | {f.dtype} |" in section, f.key
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    goals = [(0.5, 0.1 * i) for i in range(7)]
    namespace = {"goals": goals, "my_inverse_kinematics": lambda g: np.linspace(0, 1, 300).reshape(100, 3) + g[0]}
    path = tmp_path / "demos.npz"
    exec(code.replace('"demos.npz"', repr(str(path))), namespace)  # the page's example as written
    demos = load_demos(path)
    assert demos.values.shape == (7, 100, 3) and demos.task_params.shape == (7, 2)
    assert list(demos.task_param_names) == ["goal_x", "goal_y"]


@pytest.mark.parametrize("command", [["up"], ["query", "train"], ["experiment", "robot"]], ids=" ".join)
def test_the_help_of_each_command_taking_demos_lists_the_arrays(command, capsys):
    with pytest.raises(SystemExit):
        main([*command, "--help"])
    out = capsys.readouterr().out
    assert "docs/ROBOTS.md" in out and "np.savez" in out
    for f in FIELDS:
        assert re.search(rf"^  {f.key} +{re.escape(f.shape)} +{f.dtype} +(required|optional)$", out, re.M), f.key
