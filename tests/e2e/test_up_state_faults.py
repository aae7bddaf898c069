"""`acnmp up` on a state directory with bad files (issue 49, fault 1) and a changed `--demos` file
(issue 54, item 1), as an operator meets them.

Before: one unreadable checkpoint (of any skill) or job record stopped the whole deployment with
``learner exited with code 2 before going live`` and no reason; and "deployment is up" was printed
while the model service still served the version trained from the old file. Now the bad files
are quarantined and named on `acnmp up`'s output and by `acnmp status` (exit 1), every other skill
serves, and "up" means the skill is served at the version trained from the file given, numbered
above every version the state directory ever held. And when the launcher is killed, the running
job's last event (``interrupted``) is in the recording.
"""
from __future__ import annotations

import json
import subprocess
import sys
import time
import uuid

from acnmp_core.adaptation.config import AdaptConfig
from acnmp_core.data.demo_io import save_demos
from acnmp_core.data.demos import DemoSet, Demonstration
from acnmp_core.experiments.viapoint import make_setup
from acnmp_core.jobs.adapt import AdaptJob
from acnmp_core.model.cnmp import CNMPConfig
from acnmp_core.model.training import TrainConfig
from acnmp_core.tasks.viapoint.task import obstacle_demos
from clients.client import ACNMPClient
from services.learner.core import LearnerCore, TrainSpec
from services.learner.service import bootstrap
from services.learner.store import demo_set_to_arrays
from services.recording.replay import summarize
from services.transport.runfile import find, pid_alive
from tests.paths import ROOT



def test_up_quarantines_bad_files_serves_the_rest_and_is_up_once_the_changed_file_is_served(tmp_path, acnmp_up,
                                                                                              verify_rrd):
    old, new = tmp_path / "a.npz", tmp_path / "b.npz"
    demos_a = obstacle_demos(n_steps=30)
    demos_b = DemoSet([Demonstration(d.times, d.values + 0.25, d.task_params) for d in demos_a])
    save_demos(old, demo_set_to_arrays(demos_a))
    save_demos(new, demo_set_to_arrays(demos_b))
    state = tmp_path / "state"
    core = LearnerCore(state, evaluator_for=lambda job: None)
    try:  # e1 from a.npz at versions 0 and 1, e2 at version 0, e3 at versions 0 and 1, two job records
        bootstrap(core, [f"e1={old}"], 5)
        core.train_skill("e1", TrainSpec(demos_a, CNMPConfig(n_outputs=2), TrainConfig(steps=5)))
        core.train_skill("e2", TrainSpec(demos_a, CNMPConfig(n_outputs=2), TrainConfig(steps=5)))
        for _ in range(2):
            core.train_skill("e3", TrainSpec(demos_a, CNMPConfig(n_outputs=2), TrainConfig(steps=5)))
        setup = make_setup()
        job = core.submit("e2", AdaptJob(setup.target, "viapoint", "point2d", setup.task_config))
        assimilated = core.submit("e3", AdaptJob(setup.target, "viapoint", "point2d", setup.task_config))
        core._persist(assimilated, state="done", committed_version=1)  # as if its solution made e3 v1
    finally:
        core.close()
    # e3's newest version deleted by hand, its version record too: its job record alone remembers it
    # (issue 73, defect 3: before, version 0 was served without a word and `acnmp status` said ok)
    for name in ("model-v1.pt", "demos-v1.npz", "versions.json"):
        (state / "skills/e3" / name).unlink()
    (state / "skills/e1/model-v1.pt").write_bytes(b"\x80\x02" + bytes(range(256)) * 40)  # garbage
    ckpt = state / "skills/e2/model-v0.pt"
    ckpt.write_bytes(ckpt.read_bytes()[:1000])  # truncated: e2 has no usable version left
    record = state / "jobs" / f"{job.job}.json"
    record.write_text(record.read_text()[:29] + "\x00")  # cut inside a string

    ns = f"faults-{uuid.uuid4().hex[:8]}"
    rrd = tmp_path / "faults.rrd"
    # enough steps that retraining e1 outlasts the model service's start (which fetched the old one)
    # --insecure: a peer mesh, whose links outlive the launcher (an authenticated deployment's router
    # is the launcher: once it is killed, nothing reaches the recorder any more)
    proc, lines = acnmp_up("--namespace", ns, "--workers", "1", "--demos", f"e1={new}", "--train-steps", "150",
                           "--state-dir", str(state), "--record", str(rrd), "--insecure")
    try:
        children = [p.pid for p in find(ns).processes]
        said = "".join(lines)
        for rel, reason in ((f"jobs/{job.job}.json", "not a job record (truncated or not JSON)"),
                            ("skills/e1/model-v1.pt", "not a readable checkpoint (truncated or not a torch file)"),
                            ("skills/e2/model-v0.pt", "not a readable checkpoint (truncated or not a torch file)")):
            assert f"acnmp up: learner: quarantined {rel}: {reason} (moved to quarantine/" in said, said
        assert "weights_only" not in said and "before going live" not in said
        # which version is served instead, on acnmp up's output too (issue 66: the learner's log alone)
        assert "acnmp up: learner: skill e1: version(s) 1 unusable (quarantined); serving version 0" in said, said
        missing = (f"skill e3: version(s) 1 missing (no file of it is left; job {assimilated.job} records it "
                   "committed); serving version 0, the newest present; its next version will be 2")
        assert f"acnmp up: learner: {missing}" in said, said
        with ACNMPClient(namespace=ns, timeout=10) as client:
            info = client.info("e1")  # right after "up": the new file's skill, above every version used
            assert info["version"] == 2 and info["data_hash"] == demos_b.content_hash(), info
            endless = AdaptConfig(max_rollouts=2000, stop_on_success=False)  # still running when killed
            running = client.adapt("e1", AdaptJob(setup.target, "viapoint", "point2d", setup.task_config, endless))
            _until(lambda: client.job_status(running)["rollouts"] > 0, timeout=120)
        status = subprocess.run([sys.executable, "-m", "clients.cli", "status", "--namespace", ns, "--timeout", "10"],
                                cwd=ROOT,
                                capture_output=True, text=True, timeout=60)
        assert status.returncode == 1, status.stdout + status.stderr
        learner = [ln for ln in status.stdout.splitlines() if ln.split()[:1] == ["learner"]]
        assert learner and learner[0].split()[-1] == "problems", status.stdout
        assert "quarantined skills/e2/model-v0.pt: not a readable checkpoint" in status.stdout
        assert missing in status.stdout, status.stdout
        # the launcher killed: each child stops by itself, the learner saves the job interrupted and
        # the recorder records that before it closes the file (issue 49, point 6)
        proc.kill()
        proc.wait(30)
        _until(lambda: not any(pid_alive(pid) for pid in children), timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    verify_rrd(rrd)
    assert summarize(rrd)["jobs"][running]["last_progress"]["state"] == "interrupted"
    assert json.loads((state / "jobs" / f"{running}.json").read_text())["state"] == "interrupted"
    learner_log = (state / "logs" / "learner.log").read_text()
    assert "weights_only" not in learner_log and "skill e1: version(s) 1 unusable" in learner_log


def _until(condition, timeout: float) -> None:
    end = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < end, "timed out"
        time.sleep(0.1)
