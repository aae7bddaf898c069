"""``acnmp experiment viapoint --distributed`` with a deployment running: it runs E1 on that
deployment (found by its run file, as the operator role) and gets the in-process numbers."""
import json

from clients.cli import main
from services.launcher import LocalDeployment

ARGS = ["--seed", "1", "--budget", "4", "--train-steps", "30", "--quiet"]


def test_distributed_e1_runs_on_the_running_deployment(tmp_path, capsys):
    local, dist = tmp_path / "local.json", tmp_path / "dist.json"
    assert main(["experiment", "viapoint", *ARGS, "--json", str(local)]) == 0
    with LocalDeployment("lab", workers=1, secure=True, start_timeout=90):
        assert main(["experiment", "viapoint", *ARGS, "--distributed", "--json", str(dist)]) == 0
        assert "running E1 on deployment 'lab'" in capsys.readouterr().out
        assert main(["experiment", "viapoint", *ARGS, "--distributed", "--record", str(tmp_path / "x.rrd")]) == 2
    a, b = json.loads(local.read_text()), json.loads(dist.read_text())
    assert b["attached_to"] == "lab"
    for m in ("lfd_only", "rl_only", "acnmp"):
        for k in ("rollouts", "success", "error"):
            assert a["methods"][m][k] == b["methods"][m][k], (m, k)
    assert main(["experiment", "viapoint", *ARGS, "--distributed", "--namespace", "lab"]) == 2
