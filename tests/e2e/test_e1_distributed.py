"""E1 across a real local deployment gives the in-process numbers and a valid, complete recording,
also with its recorder killed -9 mid-run, and the recording is data: its export holds exactly the run's roll-outs per method, the in-process
solutions among them bit for bit; its roll-outs run again give the recorded returns; its best
roll-out, as a demonstrations file, trains a skill that reproduces it within E1's tolerance."""
import json
import os
import signal

import numpy as np
import psutil
import pyarrow.parquet as pq
import torch

from acnmp_core.data.demo_io import load_demos
from acnmp_core.experiments.viapoint import make_setup
from acnmp_core.model.cnmp import CNMP, CNMPConfig
from acnmp_core.model.training import TrainConfig, train
from clients.cli import main
from clients.distributed import DeployedSkill
from services.recording.replay import summarize
from services.recording.tables import read_recording
from tests.conftest import E1_SMALL

SEED, BUDGET, STEPS = E1_SMALL  # e1_small_run (tests/conftest.py) is its in-process run
ARGS = ["--seeds", f"{SEED}-{SEED}", "--budget", str(BUDGET), "--train-steps", str(STEPS), "--quiet"]
METHODS = ("lfd_only", "rl_only", "acnmp")


def _kill_the_recorder() -> int:
    (recorder,) = [p for p in psutil.Process().children(recursive=True)
                   if "--recording-id" in p.cmdline()]  # the recorder's own option
    os.kill(recorder.pid, signal.SIGKILL)
    return recorder.pid


def test_distributed_e1_matches_in_process_and_its_recording_is_data(tmp_path, verify_rrd, capsys, monkeypatch,
                                                                      e1_small_run):
    dist, rrd = tmp_path / "dist.json", tmp_path / "e1.rrd"
    torch.set_num_threads(1)
    # the recorder is killed with -9 mid-run, after LfD's roll-out and before RL's and ACNMP's: the
    # launcher restarts it on a new file, the publishers' caches give it what it missed, and the
    # recording (its files merged at the end) still holds every roll-out, each once
    real_adapt, killed = DeployedSkill.adapt, []

    def adapt(self, setup, method, cfg, seed, assimilation):
        if method == "rl_only":
            killed.append(_kill_the_recorder())
        return real_adapt(self, setup, method, cfg, seed, assimilation)

    monkeypatch.setattr(DeployedSkill, "adapt", adapt)
    local = e1_small_run  # SEED, BUDGET, STEPS
    assert main(["experiment", "viapoint", *ARGS, "--distributed", "--workers", "2",
                 "--record", str(rrd), "--json", str(dist)]) == 0
    assert len(killed) == 1
    a, b = json.loads(json.dumps(local.summary)), json.loads(dist.read_text())
    # the deployment it started: authenticated, as `acnmp up` is, its workers and recording; the skill
    # is new there, so the learner trained it
    assert {k: v for k, v in b["deployment"].items() if k != "namespace"} == {
        "attached": False, "workers": 2, "recording": str(rrd), "authenticated": True}
    assert b["skill"] == {"name": "e1", "version": 0, "trained": True}
    for m in METHODS:
        for k in ("rollouts", "success", "error", "shape_error"):
            assert a["methods"][m][k] == b["methods"][m][k], (m, k)
    # the model service serves the learner's LfD model: it reproduces the demos as the local one does
    assert abs(a["lfd_reproduction_rmse"] - b["lfd_reproduction_rmse"]) < 1e-5
    # the recording is finalised and holds exactly the roll-outs each job used
    verify_rrd(rrd)
    summary = summarize(rrd)
    for m in METHODS:
        job = summary["jobs"][b["methods"][m]["job"]]
        assert job["rollouts"] == job["unique_rollouts"] == b["methods"][m]["rollouts"] and not job["duplicates"]
        assert (job["method"], job["skill"], job["robot"], job["task"]) == (m, "e1", "point2d", "viapoint")

    # export: the counts per method are the JSON's, the solutions are among the roll-outs bit for bit
    capsys.readouterr()
    assert main(["replay", str(rrd), "--export", str(tmp_path / "tables")]) == 0
    assert f"wrote {tmp_path / 'tables' / 'rollouts.parquet'}" in capsys.readouterr().out
    rollouts = pq.read_table(tmp_path / "tables" / "rollouts.parquet").to_pylist()
    tables = read_recording(rrd)
    for m in METHODS:
        mine = [r for r in rollouts if r["method"] == m]
        assert len(mine) == b["methods"][m]["rollouts"]
        assert {r["job"] for r in mine} == {b["methods"][m]["job"]} and {r["model_version"] for r in mine} == {0}
        recorded = tables.trajectories(b["methods"][m]["job"])
        if a["methods"][m]["success"] or m == "lfd_only":  # an executed solution (LfD executes its one mean)
            assert any(np.array_equal(x, local.trajectories[m]) for x in recorded), m
    assert {"train/nll", "train/val_nll"} <= set(summary["metrics"]["e1"])

    # re-execution: every roll-out again, the recorded return each time
    assert main(["replay", str(rrd), "--execute", "--json"]) == 0
    audit = json.loads(capsys.readouterr().out)
    assert audit["rollouts"] == audit["equal"] == sum(b["methods"][m]["rollouts"] for m in METHODS)
    assert audit["differ"] == [] and audit["skipped_jobs"] == {}

    # demonstrations from the recording: a new skill trained on the best roll-out ACNMP's job found
    # reproduces it within E1's tolerance when conditioned on E1's query
    out = tmp_path / "found.npz"
    assert main(["demos", "from-recording", str(rrd), "--job", b["methods"]["acnmp"]["job"], "--best-per-job",
                 "-o", str(out)]) == 0
    found = load_demos(out)
    best = max(tables.rollout_rows(b["methods"]["acnmp"]["job"]), key=lambda r: r["return"])
    assert found.values.shape[0] == 1 and np.array_equal(found.values[0], best["trajectory"])
    setup = make_setup()
    model = CNMP(CNMPConfig(n_outputs=2, encoder_widths=(64, 64), decoder_widths=(64, 64)), seed=0)
    train(model, found.to_demo_set(), TrainConfig(steps=1500), seed=0, progress=False)
    tg = setup.target
    # conditioned where E1's query conditions, on the roll-out's own values there
    at = np.array([np.interp(t, best["times"], best["trajectory"][:, d]) for t in tg.obs_times for d in range(2)])
    again = model.predict(tg.obs_times, at.reshape(-1, 2), query_times=best["times"]).mean
    # a roll-out carries exploration noise the skill smooths: compared over the whole path (RMSE)
    gap = np.sqrt(np.mean(np.sum((again - best["trajectory"]) ** 2, axis=1)))
    assert gap <= max(setup.task.tolerance), gap
