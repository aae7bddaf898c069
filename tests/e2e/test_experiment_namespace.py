"""``acnmp experiment ... --distributed --namespace NS``: an experiment runs its roll-outs on the
workers of a deployment that is already running (found by its run file, joined with the operator's
credentials) and its recorder records them; wrong uses are one line each."""
from __future__ import annotations

import json

from clients.cli import main
from services.launcher import LocalDeployment
from services.recording.replay import summarize

NS = "nsexp"


def test_push_runs_on_a_running_deployments_workers_and_recorder(tmp_path, capsys, verify_rrd):
    rrd, out = tmp_path / "lab.rrd", tmp_path / "e2.json"
    with LocalDeployment(NS, workers=1, robot="planar3", record=rrd, model=False, learner=False, secure=True,
                         announce=True, state_dir=tmp_path / "state"):
        code = main(["experiment", "push", "--seeds", "1", "--train-steps", "100", "--acnmp-budget", "2",
                     "--promp-budget", "3", "--distributed", "--namespace", NS, "--json", str(out)])
        printed, err = capsys.readouterr()
        assert code == 0, err
        assert f"running on deployment '{NS}' (1 planar3 worker(s)); roll-outs recorded by its recorder" in printed

        for argv, words in [
            (["--namespace", "nowhere"], "--namespace nowhere: no such deployment is running"),
            (["--namespace", NS, "--record", str(tmp_path / "x.rrd")], "--record: with --namespace"),
            (["--namespace", NS, "--insecure"], "--insecure"),
        ]:
            assert main(["experiment", "push", "--seeds", "1", "--quick", "--distributed", *argv]) == 2
            err = capsys.readouterr().err.strip()
            assert len(err.splitlines()) == 1 and words in err, err
        assert main(["experiment", "wall", "--envs", "1", "--distributed", "--namespace", NS]) == 2
        err = capsys.readouterr().err.strip()
        assert "the deployment runs no point2d workers (start one with `acnmp up --robot point2d`)" in err
        # the recording so far (still being written) audits itself on the deployment's own workers
        assert main(["replay", str(rrd), "--execute", "--namespace", NS, "--limit", "2", "--json"]) == 0
        audit = json.loads(capsys.readouterr().out)
        assert audit["rollouts"] == audit["equal"] >= 2 and audit["differ"] == []
    verify_rrd(rrd)
    jobs = summarize(rrd)["jobs"]
    result = json.loads(out.read_text())
    # what it ran on, as the deployment is: joined, its worker, its recorder's file, authenticated
    assert result["deployment"] == {"namespace": NS, "attached": True, "workers": 1, "recording": str(rrd),
                                    "authenticated": True}
    assert jobs and all(j.startswith("push-") for j in jobs)
    assert {w for j in jobs.values() for w in j["workers"]} == {"planar3-0"}
    assert all(j["rollouts"] == j["unique_rollouts"] and not j["duplicates"] for j in jobs.values())
    for method in ("acnmp", "promp_rl"):  # every roll-out a run counts is in the recording
        counted = sum(r["rollouts"] for r in result["runs"] if r["method"] == method)
        assert sum(j["rollouts"] for name, j in jobs.items() if name.startswith(f"push-{method}-")) >= counted > 0

def test_namespace_is_only_for_distributed_runs(capsys):
    assert main(["experiment", "pour", "--namespace", NS]) == 2
    assert "--namespace: only with --distributed" in capsys.readouterr().err
