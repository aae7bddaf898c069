"""The rules that keep the comparison of record from being fitted: report seeds no study runs, a
resumed result made at one commit, wall time that counts every run's training, and a basis count
that constant outputs do not choose."""
from __future__ import annotations

import json
import runpy
from pathlib import Path

import numpy as np
import pytest

from acnmp_core.errors import InputError
from acnmp_core.experiments.peers import (DEVELOPMENT_SEEDS, REPORT_SEEDS, TASK_NAMES, PeerRun, PeersConfig,
                                          check_development_seeds, run_peers)

ROOT = Path(__file__).resolve().parents[3]
STUDIES = ROOT / "benchmarks" / "studies"


def test_the_report_seeds_are_ten_and_apart_from_the_development_seeds():
    assert len(REPORT_SEEDS) == 10 and not set(REPORT_SEEDS) & set(DEVELOPMENT_SEEDS)
    assert PeersConfig(tasks=("bump",)).seeds == DEVELOPMENT_SEEDS
    assert check_development_seeds([0, 4], "a study") == (0, 4)
    with pytest.raises(InputError, match=r"a study: seeds 5, 14 are report seeds"):
        check_development_seeds([0, 5, 14], "a study")


def _seeds_on_peer_tasks(obj, found: list) -> None:
    """Every seed a study JSON records beside a task of the comparison."""
    if isinstance(obj, dict):
        task = obj.get("task")
        if isinstance(task, str) and task in TASK_NAMES:
            for key in ("seed", "seeds"):
                if key in obj:
                    found.extend(np.atleast_1d(obj[key]).astype(int).tolist())
        if "tasks" in obj and isinstance(obj["tasks"], list) and set(obj["tasks"]) & set(TASK_NAMES):
            if isinstance(obj.get("seeds"), list):
                found.extend(int(s) for s in obj["seeds"])
        for value in obj.values():
            _seeds_on_peer_tasks(value, found)
    elif isinstance(obj, list):
        for value in obj:
            _seeds_on_peer_tasks(value, found)


@pytest.mark.parametrize("path", sorted(STUDIES.rglob("*.json")), ids=lambda p: str(p.relative_to(STUDIES)))
def test_no_study_ran_a_report_seed_of_the_comparison(path):
    """A study that ran a task of the comparison ran development seeds only: a setting chosen there
    was chosen on them (a run of record's seeds would make its verdict one fitted to)."""
    found: list = []
    _seeds_on_peer_tasks(json.loads(path.read_text()), found)
    assert not set(found) & set(REPORT_SEEDS), f"{path.name} names report seeds {sorted(set(found) & set(REPORT_SEEDS))}"


def _peer_studies() -> list[Path]:
    return sorted(p for p in STUDIES.rglob("*.py") if "peers" in p.read_text() and "--seeds" in p.read_text())


@pytest.mark.parametrize("script", _peer_studies(), ids=lambda p: str(p.relative_to(STUDIES)))
def test_a_study_of_the_comparison_refuses_a_report_seed(script, capsys, monkeypatch):
    monkeypatch.setattr("sys.argv", [str(script), "--seeds", "3,7"])
    with pytest.raises(SystemExit) as exc:
        runpy.run_path(str(script), run_name="__main__")
    assert exc.value.code == 2 and "report seeds" in capsys.readouterr().err


class _Task:
    cases = ("extrapolation",)

    def __init__(self, kind):
        self.name = kind

    def chosen_settings(self):
        return {}

    def close(self):
        pass


def _run(task, config, seed, case, method, state):
    if "model" not in state:  # the first run of a seed pays for its model's training
        state["model"] = True
        return PeerRun(task.name, method, seed, case, [], 1, True, 1, 0.5, {"train_s": 30.0})
    return PeerRun(task.name, method, seed, case, [], 1, True, 1, 0.5)


def test_resume_refuses_runs_made_at_another_commit_and_wall_time_counts_every_run(tmp_path):
    out = tmp_path / "peers.json"
    config = PeersConfig(tasks=("bump",), methods=("lfd", "acnmp"), seeds=(0,), cases=("extrapolation",))
    first = run_peers(config, out=out, run_method=_run, make_task=_Task, commit="aaa")
    assert [r["commit"] for r in first["runs"]] == ["aaa", "aaa"]
    assert first["wall_time_s"] == pytest.approx(sum(r["wall_s"] for r in first["runs"]), abs=0.2)
    more = PeersConfig(**{**config.__dict__, "seeds": (0, 1)})
    with pytest.raises(InputError, match="made at commit aaa, not at bbb"):
        run_peers(more, out=out, resume=True, run_method=_run, make_task=_Task, commit="bbb")
    resumed = run_peers(more, out=out, resume=True, run_method=_run, make_task=_Task, commit="aaa")
    assert len(resumed["runs"]) == 4 and resumed["wall_time_s"] >= first["wall_time_s"]
    # a run made before runs recorded their whole time counts its training beside its own time
    old = PeerRun("bump", "lfd", 0, "extrapolation", [], 1, True, 1, 0.5, {"train_s": 30.0})
    assert old.whole_wall_s == 30.5


def test_the_benchmark_refuses_to_resume_another_commit_s_runs_in_one_line(tmp_path, capsys):
    from benchmarks.experiments.peers import main

    out = tmp_path / "p.json"
    out.write_text(json.dumps({"runs": [PeerRun("bump", "lfd", 5, "extrapolation", [], 1, True, 1, 0.1,
                                                commit="0" * 40).to_json()]}))
    with pytest.raises(SystemExit) as exc:
        main(["--tasks", "bump", "--methods", "lfd", "--seeds", "5", "--out", str(out), "--resume"])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "made at commit 0000000000000000000000000000000000000000" in err and "Traceback" not in err


def test_constant_outputs_do_not_choose_the_basis_count():
    """A gripper held at one value: its spread is rounding noise, and dividing errors by it made
    them any size (window-open's leave-one-out errors 22.9-103, K = 4 chosen). Left out, the count
    follows the outputs that vary, and is the count chosen without the constant output."""
    pytest.importorskip("mp_pytorch")
    from acnmp_core.model.prior import choose_n_basis as path_basis
    from acnmp_core.peers.black_box import choose_n_basis

    times = np.linspace(0.0, 1.0, 60)
    amps = np.linspace(-0.6, 0.6, 7)
    shape = np.exp(-((times - 0.3) ** 2) / 0.004) - np.exp(-((times - 0.7) ** 2) / 0.004)
    varying = amps[:, None, None] * shape[None, :, None]
    gripper = np.full((7, 60, 1), 0.7) + 1e-17 * np.arange(60)[None, :, None] * (np.arange(7) % 2)[:, None, None]
    both = np.concatenate([varying, gripper], axis=2)
    for choose in (choose_n_basis, lambda t, v, p: path_basis(np.tile(t, (len(v), 1)), v, p)):
        k_alone, errors_alone = choose(times, varying, amps[:, None])
        k_both, errors_both = choose(times, both, amps[:, None])
        assert k_both == k_alone and max(errors_both.values()) < 10
        assert errors_both == pytest.approx(errors_alone)
