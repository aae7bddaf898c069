"""Supervision and shutdown of a local deployment (issue 12, item 5), measured.

Three parts, one run, one JSON:

1. **Restart latency per child kind.** A deployment like ``acnmp up``'s (recorder, learner, model
   service, 2 workers; a skill trained, so the model service loads weights when it comes back).
   Each child is killed with SIGKILL ``--reps`` times; measured: from the kill to the new
   process's liveliness token (``kill_to_live_s``) and, from the supervisor, from its seeing the
   exit to that token (``live_after_s``). Baseline in the same run: the same child started again by
   hand with supervision off (``dep.respawn``: spawn to live, no detection, no backoff); ratio
   = supervised / by hand.
2. **Distributed E1 under kill -9.** ``run_viapoint_distributed`` undisturbed, then again with one
   child of each kind killed during the run (a worker, the model service, the learner, the
   recorder, each on a job_progress event); the methods' results are compared field by field,
   each killed child's time back is listed, and both recordings are checked with
   ``rerun rrd verify``.
3. **SIGTERM of ``acnmp up`` during a job.** ``acnmp up`` (a subprocess, 2 workers, a recorder)
   gets a skill and a long job; once the job runs, SIGTERM; measured: time until every process of
   the deployment is gone, whether one needed SIGKILL (an exit code -9), the job's saved state;
   then ``acnmp up`` again on the same state directory and the job resumes (attempt 1, running).
   Baseline in the same run: SIGTERM of an idle ``acnmp up`` (ratio during-job / idle).

Numbers from one run on a shared machine (2 cores; other work may run).

    python benchmarks/performance/bench_supervision.py [--reps 3] [--budget 100] [--train-steps 3000] [--out FILE]
"""
from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks._results import ROOT, benchmark_args, main_provenance, save_result  # noqa: E402

KINDS = ("worker-point2d-0", "model", "learner", "recorder")
SMALL = {"encoder_widths": [32, 32], "decoder_widths": [32, 32]}
TARGET_S = 5.0  # the bound for a restart and for a shutdown


def _verify(path: Path) -> bool:
    rerun = Path(sys.executable).with_name("rerun")
    return subprocess.run([str(rerun), "rrd", "verify", str(path)], capture_output=True, timeout=300).returncode == 0


def _train_and_job(setup, max_rollouts: int):
    tg = setup.target
    train = {"times": np.stack([d.times for d in setup.demos]), "values": np.stack([d.values for d in setup.demos]),
             "model": SMALL, "train": {"steps": 100}, "seed": 1}
    adapt = {"target": {"obs_times": tg.obs_times, "obs_values": tg.obs_values, "query_times": tg.query_times},
             "task": "viapoint", "task_config": setup.task_config, "robot": "point2d", "seed": 5,
             "config": {"max_rollouts": max_rollouts, "max_reuse": 5, "stop_on_success": False}}
    return train, adapt


def restart_latency(tmp: Path, reps: int) -> dict:
    """Part 1: kill each child ``reps`` times under supervision, then restart each by hand once."""
    from acnmp_core.experiments.viapoint import make_setup
    from services.launcher import LocalDeployment
    from services.transport import call

    setup = make_setup()
    train, _ = _train_and_job(setup, 10)
    out: dict = {}
    rrd = tmp / "latency.rrd"
    with LocalDeployment(f"bsup-{os.getpid()}", workers=2, record=rrd, state_dir=tmp / "latency") as dep:
        call(dep.session, dep.keys.train("e1"), train, timeout=120)
        for name in KINDS:
            kill_to_live, live_after = [], []
            for r in range(reps):
                t0 = time.monotonic()
                dep.kill(name)
                restarts = dep.supervisor.wait_restarts(name, r + 1, timeout=120)
                kill_to_live.append(time.monotonic() - t0)
                live_after.append(restarts[r].live_after)
                time.sleep(1.0)  # let the mesh settle before the next kill
            out[name] = {"kill_to_live_s": [round(x, 3) for x in kill_to_live],
                         "live_after_s": [round(x, 3) for x in live_after],
                         "backoff_s": [r.delay for r in dep.supervisor.restarts if r.name == name]}
        dep.supervisor.stop()  # the baseline: the same restarts by hand, no supervisor
        for name in KINDS:
            dep.kill(name)
            t0 = time.monotonic()
            dep.respawn(name, wait=True)
            out[name]["by_hand_s"] = round(time.monotonic() - t0, 3)
            out[name]["ratio_median_kill_to_live_over_by_hand"] = round(
                float(np.median(out[name]["kill_to_live_s"])) / out[name]["by_hand_s"], 3)
            time.sleep(1.0)
        codes = dep.stop()
    return {"children": out, "stop_codes": codes, "sigkilled_at_stop": dep.killed,
            "recording_files_merged": len(dep.recordings) == 1, "recording_verifies": _verify(rrd)}


def e1_under_kills(tmp: Path, budget: int, train_steps: int, seed: int) -> dict:
    """Part 2: E1 undisturbed, then with a worker, the model, the learner and the recorder killed."""
    import zenoh

    from clients.client import ACNMPClient
    from clients.distributed import run_viapoint_distributed
    from services.launcher import LocalDeployment
    from services.transport import decode

    t0 = time.monotonic()
    clean_rrd = tmp / "e1_clean.rrd"
    clean = run_viapoint_distributed(seed, budget=budget, train_steps=train_steps, record=str(clean_rrd),
                                     progress=False)
    clean_s = time.monotonic() - t0
    # kill schedule: the n-th job_progress event of the run (all jobs counted) kills that child
    schedule = {3: "worker-point2d-0", 6: "model", 10: "learner", 16: "recorder"}
    seen = [0]
    kills: dict[str, float] = {}
    rrd = tmp / "e1_killed.rrd"
    t0 = time.monotonic()
    with LocalDeployment(f"bsup-e1-{os.getpid()}", workers=2, robot="point2d", record=rrd, state_dir=tmp / "e1") as dep:
        lock = threading.Lock()

        def on_progress(sample: zenoh.Sample) -> None:
            if decode(sample.payload.to_bytes()).get("state") != "running":
                return
            with lock:
                seen[0] += 1
                name = schedule.get(seen[0])
                if name is not None and name not in kills:
                    kills[name] = time.monotonic()
                    threading.Thread(target=dep.kill, args=(name,), daemon=True).start()

        sub = dep.session.declare_subscriber(f"{dep.keys.prefix}/event/job_progress/**", on_progress)
        try:
            with ACNMPClient(dep.namespace, session=dep.session, timeout=30) as client:
                killed = run_viapoint_distributed(seed, budget=budget, train_steps=train_steps, progress=False,
                                                  client=client)
        finally:
            sub.undeclare()
        restarts = [{"process": r.name, "exit_code": r.exit_code, "live_after_s": r.live_after,
                     "backoff_s": r.delay} for r in dep.supervisor.restarts]
        dep.stop()
    killed_s = time.monotonic() - t0
    fields = ("rollouts", "success", "error", "shape_error")
    same = {m: {k: clean.summary["methods"][m][k] == killed.summary["methods"][m][k] for k in fields}
            for m in clean.summary["methods"]}
    return {"budget": budget, "train_steps": train_steps, "seed": seed, "kill_schedule": schedule,
            "killed": sorted(kills), "restarts": restarts,
            "all_back_within_target": all(r["live_after_s"] is not None and r["live_after_s"] <= TARGET_S
                                          for r in restarts),
            "same_result": all(all(v.values()) for v in same.values()), "same_by_field": same,
            "methods_undisturbed": {m: {k: clean.summary["methods"][m][k] for k in fields}
                                    for m in clean.summary["methods"]},
            "methods_killed": {m: {k: killed.summary["methods"][m][k] for k in fields}
                               for m in killed.summary["methods"]},
            "wall_s": {"undisturbed": round(clean_s, 1), "killed": round(killed_s, 1)},
            "ratio_wall_killed_over_undisturbed": round(killed_s / clean_s, 3),
            "recording_verifies": {"undisturbed": _verify(clean_rrd), "killed": _verify(rrd)}}


def _up(tmp: Path, ns: str, state: Path, rrd: Path) -> tuple[subprocess.Popen, str, list[int], list[str]]:
    """Start ``acnmp up``; returns (process, anchor, child pids, its output lines so far)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), RERUN_ANALYTICS="0")
    proc = subprocess.Popen([sys.executable, "-m", "clients.cli", "up", "--namespace", ns, "--workers", "2",
                             "--no-default-skill",
                             "--record", str(rrd), "--state-dir", str(state)], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines = []
    for line in proc.stdout:
        lines.append(line)
        if "deployment is up" in line:
            break
    anchor = next(m.group(1) for ln in lines if (m := re.search(r"anchor (\S+)", ln)))
    pids = [int(m.group(1)) for ln in lines
            if (m := re.match(r"\s+(?:recorder|learner|model|worker\S*)\s+(\d+)\s", ln))]
    return proc, anchor, pids, lines


def _running(pid: int) -> bool:
    try:
        return "zombie" not in Path(f"/proc/{pid}/status").read_text().lower()
    except OSError:
        return False


def _sigterm(proc: subprocess.Popen, pids: list[int]) -> dict:
    """SIGTERM ``acnmp up``; returns the seconds until it and every child are gone, and the codes."""
    t0 = time.monotonic()
    proc.send_signal(signal.SIGTERM)
    rest, _ = proc.communicate(timeout=120)
    while any(_running(p) for p in pids) and time.monotonic() - t0 < 120:
        time.sleep(0.01)
    gone = time.monotonic() - t0
    stopped = re.search(r"deployment stopped: (.*)", rest)
    codes = dict(item.split("=") for item in stopped.group(1).split()) if stopped else {}
    return {"all_gone_s": round(gone, 3), "exit_codes": codes, "sigkill_needed": "-9" in codes.values(),
            "launcher_code": proc.returncode}


def sigterm_during_job(tmp: Path) -> dict:
    """Part 3: SIGTERM of ``acnmp up`` idle (baseline) and during a job; the job resumes after."""
    from acnmp_core.experiments.viapoint import make_setup
    from clients.client import ACNMPClient
    from clients.distributed import patiently

    setup = make_setup()
    train, adapt = _train_and_job(setup, 5000)
    ns = f"bsup-up-{os.getpid()}"  # never a namespace another run (or a leftover) uses
    proc, _, pids, _ = _up(tmp, f"bsup-idle-{os.getpid()}", tmp / "idle", tmp / "idle.rrd")
    idle = _sigterm(proc, pids)

    state, rrd = tmp / "up", tmp / "up.rrd"
    proc, anchor, pids, _ = _up(tmp, ns, state, rrd)
    try:
        # a fresh peer may ask before it has discovered the learner: ask again on `unavailable`
        with ACNMPClient(ns, timeout=60) as client:
            patiently(lambda: client.request(client.keys.train("e1"), train, timeout=120), "train")
            job = patiently(lambda: client.request(client.keys.adapt("e1"), adapt), "adapt")["job"]
            while (st := client.job_status(job))["state"] != "running" or st["rollouts"] < 3:
                time.sleep(0.1)
        during = _sigterm(proc, pids)
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
            proc.wait(timeout=60)
    saved = json.loads((state / "jobs" / f"{job}.json").read_text())["state"]
    first_verifies = _verify(rrd)

    proc, anchor, pids, _ = _up(tmp, ns, state, tmp / "up2.rrd")
    try:
        with ACNMPClient(ns, timeout=60) as client:
            deadline = time.monotonic() + 120
            while (st := patiently(lambda: client.job_status(job), "status"))["state"] != "running" \
                    and time.monotonic() < deadline:
                time.sleep(0.1)
            resumed = {"state": st["state"], "attempt": st["attempt"]}
            cancelled = client.cancel(job)["state"]
            final = client.wait_job(job, timeout=120, progress=False)["state"]
        again = _sigterm(proc, pids)
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
            proc.wait(timeout=60)
    return {"idle": idle, "during_job": during, "ratio_during_job_over_idle": round(
        during["all_gone_s"] / idle["all_gone_s"], 3), "within_target": during["all_gone_s"] <= TARGET_S,
            "job_saved_as": saved, "resumed": resumed, "cancel_reply": cancelled, "after_cancel": final,
            "second_stop": again, "recording_verifies": first_verifies and _verify(tmp / "up2.rrd")}


def main(argv: list[str] | None = None) -> int:
    args = benchmark_args(__doc__, "bench_supervision", argv, reps=(3, "kills per child kind in part 1"),
                          budget=(100, "E1 roll-out budget per method in part 2"),
                          train_steps=(3000, "E1 training steps in part 2"), seed=0,
                          parts=("1,2,3", "which parts to run (comma-separated)"))
    prov = main_provenance(__file__, argv)
    parts = {int(x) for x in args.parts.split(",")}
    result: dict = {"benchmark": "supervision", "provenance": prov, "target_s": TARGET_S}
    with tempfile.TemporaryDirectory(prefix="bench-sup-") as tmp:
        tmp = Path(tmp)
        # the result is written after each part, so a long part 2 cannot lose the others
        if 1 in parts:
            result["restart_latency"] = restart_latency(tmp, args.reps)
            save_result(result, args.out, headline=("restart_latency",))
        if 3 in parts:
            result["sigterm"] = sigterm_during_job(tmp)
            save_result(result, args.out, headline=("sigterm",))
        if 2 in parts:
            result["e1_kill_9"] = e1_under_kills(tmp, args.budget, args.train_steps, args.seed)
            save_result(result, args.out, headline=("e1_kill_9",))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
