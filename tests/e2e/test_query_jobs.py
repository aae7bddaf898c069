"""``acnmp query train|adapt|jobs|watch`` and ``ACNMPClient.jobs`` against a live deployment
(learner, model service, a point2d worker as child processes): a skill trained from a file, an
adaptation queued and followed to its end, the job listed; wrong inputs are one line each."""
from __future__ import annotations

import json

import numpy as np

from acnmp_core.data.demo_io import save_demos
from acnmp_core.experiments.viapoint import make_setup
from clients.client import ACNMPClient, JobSummary
from services.launcher import LocalDeployment
from services.learner.store import demo_set_to_arrays

NS = "qjobs"


def test_a_skill_is_trained_adapted_listed_and_watched_from_the_shell(tmp_path, run_cli):
    setup = make_setup()
    demos = save_demos(tmp_path / "e1.npz", demo_set_to_arrays(setup.demos))
    tg = setup.target
    with LocalDeployment(NS, workers=1, state_dir=tmp_path / "state") as dep:
        conn = ("-n", NS, "--connect", dep.anchor)
        # the paper's CNMP and adaptation (--prior none, --paper): its mean misses the via-point, so it adapts
        code, out, err = run_cli("query", "train", "--skill", "e1", "--demos", str(demos), "--steps", "300",
                                 "--prior", "none", *conn)
        assert code == 0, err
        assert out.startswith("skill e1 version 0: trained on 6 demonstrations")

        obs = [f"--obs={t}:{x},{y}" for t, (x, y) in zip(tg.obs_times, tg.obs_values)]
        code, out, err = run_cli("query", "adapt", "--skill", "e1", "--task", "viapoint", *obs,
                                 "--task-config", json.dumps(setup.task_config), "--budget", "30", "--commit",
                                 "--paper", "--watch", *conn)
        assert code in (0, 1), err  # done -> 0; the outcome line says what happened either way
        job = out.split()[1]
        assert out.splitlines()[0] == (f"job {job} queued on skill e1 (viapoint on point2d, budget 30 roll-outs)")
        last = out.splitlines()[-1]
        assert last.startswith(f"job {job}: done, success ") and "roll-outs" in last
        assert f"job {job}: running" in err  # no terminal here: one progress line per change on stderr

        with ACNMPClient(NS, session=dep.session, timeout=10) as client:
            (row,) = client.jobs()
            status = client.job_status(job)
            assert client.info("e1")["config"]["prior"] == "none"
        assert isinstance(row, JobSummary) and row.job == job and row.state == "done" and row.budget == 30
        assert row.rollouts > 1 and row.rollouts % 5 == 0  # the paper's accounting: means and noisy ones in fives
        assert row.rollouts == status["result"]["rollouts"] and row.success == status["result"]["success"]
        assert row.task == "viapoint" and row.robot == "point2d" and row.created <= row.updated

        code, out, _ = run_cli("query", "jobs", *conn)
        assert code == 0
        header, line = out.splitlines()
        assert header.split()[:5] == ["JOB", "KIND", "SKILL", "TASK", "STATE"]
        assert line.split()[:6] == [job, "adapt", "e1", "viapoint", "done", f"{row.rollouts}/30"]
        code, out, _ = run_cli("query", "jobs", "--json", *conn)
        assert code == 0 and [r["job"] for r in json.loads(out)] == [job]
        # every attempt's roll-outs (what the recording holds), not only the final attempt's
        assert json.loads(out)[0]["rollouts_executed"] == status["rollouts_executed"] == row.rollouts_executed > 0

        code, out, _ = run_cli("query", "watch", job, "--json", *conn)
        assert code == 0 and json.loads(out)["state"] == "done"
        np.testing.assert_array_equal(np.array(json.loads(out)["result"]["trajectory"]),
                                      status["result"]["trajectory"])

        # wrong inputs: one line each, nothing queued
        for argv, exit_code, words in [
            (("query", "watch", "e1-nothing"), 1, "unknown_job"),
            (("query", "adapt", "--skill", "e1", "--task", "juggle", "--obs", "0:0,0"), 2, "juggle"),
            (("query", "adapt", "--skill", "e1", "--task", "viapoint", "--obs", "0:0,0", "--task-config", "[1"),
             2, "--task-config"),
            (("query", "train", "--skill", "e1", "--demos", str(tmp_path / "none.npz")), 2, "none.npz"),
            # shapes the skill does not have: the user's arguments, refused before the adapt is sent (issue 72)
            (("query", "adapt", "--skill", "e1", "--task", "viapoint", "--obs", "0:0,0,0"), 2,
             "--obs: 3 values per observation; skill 'e1' has 2 outputs (y0, y1)"),
            (("query", "adapt", "--skill", "e1", "--task", "viapoint", "--obs", "0:0,0", "--task-params", "0.7,0.45,0"),
             2, "--task-params: 3 values; skill 'e1' has 0 task parameters (none)"),
            (("query", "jobs", "--limit", "0"), 2, "--limit"),
        ]:
            code, out, err = run_cli(*argv, *conn)
            assert code == exit_code and len(err.strip().splitlines()) == 1 and words in err, (argv, err)
        # --robot defaults to the kind of the deployment's workers (the first adapt: point2d's); workers of two
        # kinds leave the choice to the user (issue 72: point2d was taken whatever ran)
        dep.start_worker("w-planar3", robot="planar3")
        code, out, err = run_cli("query", "adapt", "--skill", "e1", "--task", "viapoint", *obs, *conn)
        assert code == 2 and err.strip() == ("acnmp: error: --robot: the deployment runs workers of planar3, point2d: "
                                             "choose the kind that runs --task viapoint"), err
        with ACNMPClient(NS, session=dep.session, timeout=10) as client:
            assert [r.job for r in client.jobs()] == [job]
        # adapt --watch --json: stdout is the final status alone (the queued line goes to stderr)
        code, out, err = run_cli("query", "adapt", "--skill", "e1", "--task", "viapoint", *obs, "--robot", "point2d",
                                 "--task-config", json.dumps(setup.task_config), "--budget", "5", "--watch", "--json",
                                 *conn)
        assert code in (0, 1) and json.loads(out)["state"] == "done", err
        assert "queued on skill e1" in err
