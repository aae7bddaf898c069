"""Issue 65, friction 4 (and issue 67, item 8): the exports dropped the skill's names: its outputs
became ``q0..`` and its task parameters ``task_params.0..`` in LeRobot and Minari. The learner's job
event now names them, and every export carries them to where each format keeps names, so an
import of the export gives them back."""
from __future__ import annotations

import json

from acnmp_core.data.demo_io import load_demos
from tests.unit.datasets.conftest import SKILL_NAMES, SKILL_PARAM_NAMES


def test_the_lerobot_export_names_action_and_state_as_the_skill_does(tmp_path, recording, run_cli):
    root = tmp_path / "e1"
    assert run_cli("replay", str(recording[0]), "--export-lerobot", str(root))[0] == 0
    features = json.loads((root / "meta" / "info.json").read_text())["features"]
    assert features["action"]["names"] == features["observation.state"]["names"] == list(SKILL_NAMES)
    assert features["observation.task_params"]["names"] == list(SKILL_PARAM_NAMES)
    back = tmp_path / "back.npz"
    assert run_cli("demos", "import", "--format", "lerobot", str(root), "-o", str(back), "--trajectory", "action",
                   "--task-params", "acnmp/task_params")[0] == 0
    demos = load_demos(back)
    assert tuple(demos.value_names) == SKILL_NAMES and tuple(demos.task_param_names) == SKILL_PARAM_NAMES


def test_the_minari_export_names_actions_state_and_task_params_as_the_skill_does(minari_root, tmp_path, recording,
                                                                                run_cli):
    import h5py

    assert run_cli("replay", str(recording[0]), "--export-minari", "acnmp/named-v0")[0] == 0
    with h5py.File(minari_root / "acnmp" / "named-v0" / "data" / "main_data.hdf5") as f:
        episode = f["episode_0"]
        assert [str(n) for n in episode["actions"].attrs["names"]] == list(SKILL_NAMES)
        assert [str(n) for n in episode["observations/state"].attrs["names"]] == list(SKILL_NAMES)
        assert [str(n) for n in episode["observations/task_params"].attrs["names"]] == list(SKILL_PARAM_NAMES)
    for trajectory, params in (("actions", "acnmp/task_params"), ("observations/state", "observations/task_params@first")):
        back = tmp_path / "back.npz"
        assert run_cli("demos", "import", "--format", "minari", "acnmp/named-v0", "-o", str(back), "--trajectory",
                       trajectory, "--task-params", params)[0] == 0
        demos = load_demos(back)
        assert tuple(demos.value_names) == SKILL_NAMES and tuple(demos.task_param_names) == SKILL_PARAM_NAMES
        back.unlink()
