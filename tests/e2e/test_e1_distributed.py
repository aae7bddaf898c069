"""E1 across a real local deployment gives the in-process numbers and a valid, complete recording."""
import json

from clients.cli import main
from services.recording.replay import summarize

ARGS = ["--seed", "2", "--budget", "10", "--train-steps", "300", "--quiet"]


def test_distributed_e1_matches_in_process_and_records_every_rollout(tmp_path, verify_rrd):
    local, dist, rrd = tmp_path / "local.json", tmp_path / "dist.json", tmp_path / "e1.rrd"
    assert main(["experiment", "viapoint", *ARGS, "--json", str(local)]) == 0
    assert main(["experiment", "viapoint", *ARGS, "--distributed", "--workers", "2",
                 "--record", str(rrd), "--json", str(dist)]) == 0
    a, b = json.loads(local.read_text()), json.loads(dist.read_text())
    assert b["authenticated"] is True  # the deployment it started is authenticated, as `acnmp up` is
    for m in ("lfd_only", "rl_only", "acnmp"):
        for k in ("rollouts", "success", "error", "shape_error"):
            assert a["methods"][m][k] == b["methods"][m][k], (m, k)
    # the model service serves the learner's LfD model: it reproduces the demos as the local one does
    assert abs(a["lfd_reproduction_rmse"] - b["lfd_reproduction_rmse"]) < 1e-5
    # the recording is finalised and holds exactly the roll-outs each job used
    verify_rrd(rrd)
    summary = summarize(rrd)
    by_job = {j: s for j, s in summary["jobs"].items()}
    for m in ("lfd_only", "rl_only", "acnmp"):
        job = b["methods"][m]["job"]
        assert by_job[job]["rollouts"] == b["methods"][m]["rollouts"]
        assert by_job[job]["unique_rollouts"] == by_job[job]["rollouts"] and not by_job[job]["duplicates"]
