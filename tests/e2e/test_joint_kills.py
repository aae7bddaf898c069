"""Nothing lost when the learner dies together with the recorder, or with the recorder and the
launcher (issue 73, defect 1), through the fault-point harness of bench_faults.py.

A learner life kills itself with SIGKILL at a point between writing a batch's journal and its
roll-outs reaching the recorder (benchmarks/performance/fault_points.py: journalled, reserved,
publishing, published), at its 3rd batch, and kills the recorder (or the launcher and the
recorder) at the same moment. The recorder writes its file late (Rerun's flush tick set to 5 s
instead of 0.2 s: a busy disk), so what it had received is in no file when it dies. Before, a
journal kept the job's last two batches only: the batches before them were lost at every such
kill. Now a roll-out leaves the journal only once the recorder says its file holds it, and every
reserved index is in the recording exactly once.
"""
from __future__ import annotations

import signal
import time
import uuid

import numpy as np

from acnmp_core.experiments.viapoint import make_setup
from benchmarks.performance.fault_points import ENV, Launcher, count_rollouts, start_learner
from services.transport import Keyspace, WireError, alive_tokens, call, open_session

SMALL = {"encoder_widths": [32, 32], "decoder_widths": [32, 32]}
#: (point, who dies with the learner) of each killed life; then a life that runs the job to its end
LIVES = (("published", ("recorder",)), ("publishing", ("launcher", "recorder")),
         ("journalled", ("recorder",)), ("reserved", ("launcher", "recorder")))


def _until(predicate, timeout: float, what: str):
    deadline = time.monotonic() + timeout
    while not (value := predicate()):
        assert time.monotonic() < deadline, what
        time.sleep(0.1)
    return value


def test_every_reserved_rollout_is_recorded_once_when_the_learner_dies_with_the_recorder(tmp_path):
    setup = make_setup()
    env = dict(ENV, RERUN_FLUSH_TICK_SECS="5")
    ns = f"joint-{uuid.uuid4().hex[:6]}"
    keys = Keyspace(ns)
    record, state = tmp_path / "joint.rrd", tmp_path / "learner-state"
    launcher = Launcher(ns, record, tmp_path / "deployment-state", env=env)
    job = None
    learner = None
    with open(tmp_path / "learner.log", "w") as log:
        launcher.start()
        try:
            for point, who in (*LIVES, ("none", ())):
                recorder = launcher.children["recorder"]
                also = tuple(launcher.proc.pid if w == "launcher" else recorder for w in who)
                learner = start_learner(ns, launcher.anchor, state, point, 3, log, also, jobs=1, env=env)
                with open_session("peer", connect=[launcher.anchor]) as session:
                    _until(lambda: alive_tokens(session, keys.learner_token("learner")), 120, "the learner's token")
                    if job is None:
                        tg = setup.target
                        call(session, keys.train("e1"), {
                            "times": np.stack([d.times for d in setup.demos]),
                            "values": np.stack([d.values for d in setup.demos]),
                            "model": SMALL, "train": {"steps": 50}, "seed": 3}, timeout=300)
                        job = call(session, keys.adapt("e1"), {
                            "target": {"obs_times": tg.obs_times, "obs_values": tg.obs_values,
                                       "query_times": tg.query_times},
                            "task": "viapoint", "task_config": setup.task_config, "robot": "point2d", "seed": 1,
                            "config": {"max_rollouts": 120, "noisy_per_iter": 4, "stop_on_success": False,
                                       "max_reuse": 3}}, timeout=30)["job"]
                    if point == "none":
                        def ended():
                            try:
                                return call(session, keys.job_status(job), timeout=10)["state"] in ("done", "failed")
                            except WireError:
                                return False
                        _until(ended, 600, "the job's end")
                        continue
                assert learner.wait(timeout=300) == -signal.SIGKILL, f"the learner did not die at {point}"
                if "launcher" in who:  # its workers stop by themselves; the deployment starts again on --record
                    launcher.kill()
                    launcher.start()
                else:  # the launcher's supervisor starts the recorder again, on the recording's next segment
                    launcher.wait_child("recorder", lambda pid: pid not in (None, recorder))
            learner.send_signal(signal.SIGTERM)
            learner.wait(60)
            launcher.stop()
        finally:
            for proc in (launcher.proc, learner):
                if proc is not None and proc.poll() is None:
                    proc.kill()
    counts = count_rollouts(record, state, [job])
    (mine,) = counts["per_job"].values()
    assert mine["state"] == "done" and mine["attempts"] == len(LIVES) + 1, mine
    assert counts["lost"] == 0 and counts["duplicated"] == 0, counts
    assert mine["reserved"] > 120  # the killed attempts' roll-outs are reserved and recorded too
    assert mine["excluded_workers"] == []  # workers going down with their launcher are no attempt's fault
