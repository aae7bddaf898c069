"""Nothing lost, one bad part never fails the whole (issue 66), measured from outside.

Two parts, one JSON:

``kills``: a deployment's launcher (recorder and 2 point2d workers, ``--record R``) and a learner
    connected to it run E1 jobs (2 at once); the learner is killed ``--kills`` times (default 20)
    by SIGKILL at a point between reserving a batch's roll-outs and publishing them
    (benchmarks/performance/fault_points.py: after the journal is written, after the indices are
    reserved, half-way through publishing, after publishing before the progress event; at the 1st,
    2nd or 3rd batch of its life, in turn) and started again on its state directory; at
    ``--launcher-kills`` of those kills (default 2) the launcher is killed with -9 too and started
    again on the same ``--record`` (its recorder continues the recording in a next segment). Then
    every job runs to its end. Counted from the job records (every index each job reserved) and the
    recording (all its segments): roll-outs lost (reserved, not recorded) and duplicated (recorded
    twice). Target: 0 and 0.
``workers``: a deployment (learner, 2 healthy point2d workers) and, per mode of
    benchmarks/performance/evil_workers.py (NaN, inf, -1e308, wrong shape, stale chunk, slow,
    failing, refusing), an evil worker beside them while ``--jobs-per-mode`` jobs (default 2) run
    at once. Counted: jobs done, jobs whose status names the evil worker (the others avoided it:
    the learner's other jobs do for 120 s), roll-outs the recording has from it. Target: every job
    done, the worker named, none of its roll-outs used.

    python benchmarks/performance/bench_faults.py [--kills 20] [--launcher-kills 2] [--out FILE]
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
import uuid
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks._results import RESULTS, main_provenance, save_result  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
ENV = dict(os.environ, PYTHONPATH=str(ROOT), RERUN_ANALYTICS="0", OMP_NUM_THREADS="1")

#: The launcher of the kills part: recorder and workers, no learner (the benchmark runs its own).
LAUNCHER = r"""
import sys
from services.launcher import LocalDeployment
from services.transport import install_shutdown_handlers, wait_until_stopped
ns, record, state = sys.argv[1:4]
stop = install_shutdown_handlers()
with LocalDeployment(ns, workers=2, model=False, learner=False, record=record, state_dir=state) as dep:
    print("anchor", dep.anchor, " ".join(str(p) for p in dep.recordings), flush=True)
    wait_until_stopped(stop)
"""
#: A small E1 network: the jobs' cost is the roll-outs and the bookkeeping this measures.
SMALL = {"encoder_widths": [32, 32], "decoder_widths": [32, 32]}


def _adapt_request(setup, seed: int, budget: int) -> dict:
    tg = setup.target
    return {"target": {"obs_times": tg.obs_times, "obs_values": tg.obs_values, "query_times": tg.query_times},
            "task": "viapoint", "task_config": setup.task_config, "robot": "point2d", "seed": seed,
            "config": {"max_rollouts": budget, "noisy_per_iter": 4, "stop_on_success": False, "max_reuse": 3}}


def _train_request(setup) -> dict:
    import numpy as np

    demos = setup.demos
    return {"times": np.stack([d.times for d in demos]), "values": np.stack([d.values for d in demos]),
            "model": SMALL, "train": {"steps": 100}, "seed": 3}


def _wait(predicate, timeout: float, what: str):
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() > deadline:
            raise TimeoutError(what)
        time.sleep(0.1)


class _Launcher:
    """The kills part's launcher process, started again on the same recording after a kill."""

    def __init__(self, ns: str, record: Path, state: Path):
        self.ns, self.record, self.state = ns, record, state
        self.proc: subprocess.Popen | None = None
        self.anchor = ""
        self.files: list[str] = []

    def start(self) -> None:
        self.proc = subprocess.Popen([sys.executable, "-c", LAUNCHER, self.ns, str(self.record), str(self.state)],
                                     cwd=ROOT, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        line = self.proc.stdout.readline().split()
        if not line or line[0] != "anchor":
            raise RuntimeError(f"the launcher did not start: {line}")
        self.anchor, self.files = line[1], line[2:]

    def kill(self) -> None:
        self.proc.kill()
        self.proc.wait(30)
        time.sleep(8)  # its children see it gone and stop (the recorder finishes its file)

    def stop(self) -> None:
        self.proc.send_signal(signal.SIGTERM)
        self.proc.wait(60)


def _learner(ns: str, anchor: str, state: Path, kill_at: str, batch: int, log) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "benchmarks.performance.fault_points", "--kill-at", kill_at,
                             "--batch", str(batch), "--", "--namespace", ns, "--mode", "peer", "--connect", anchor,
                             "--state-dir", str(state), "--wait-recorder", "20", "--id", "learner", "--jobs", "2"],
                            cwd=ROOT, env=ENV, stdout=log, stderr=subprocess.STDOUT)


def part_kills(kills: int, launcher_kills: int, jobs: int, budget: int, tmp: Path) -> dict:
    """Part ``kills`` (see the module docstring)."""
    from acnmp_core.experiments.viapoint import make_setup
    from benchmarks.performance.fault_points import POINTS
    from services.recording.replay import summarize
    from services.recording.segments import recording_segments
    from services.transport import Keyspace, WireError, alive_tokens, call, open_session

    setup = make_setup()
    ns = f"faults-{uuid.uuid4().hex[:6]}"
    keys = Keyspace(ns)
    record, state = tmp / "faults.rrd", tmp / "learner-state"
    launcher = _Launcher(ns, record, tmp / "deployment-state")
    log = open(tmp / "learner.log", "w")
    launcher_at = {round((i + 1) * kills / (launcher_kills + 1)) for i in range(launcher_kills)}
    where: dict[str, int] = {}
    job_ids: list[str] = []
    lives = []
    t0 = time.perf_counter()
    launcher.start()
    try:
        for k in range(kills + 1):
            point, batch = (POINTS[k % len(POINTS)], 1 + (k // len(POINTS)) % 3) if k < kills else ("none", 1)
            learner = _learner(ns, launcher.anchor, state, point, batch, log)
            with open_session("peer", connect=[launcher.anchor]) as session:
                _wait(lambda: alive_tokens(session, keys.learner_token("learner")), 120, "the learner's token")
                if k == 0:
                    call(session, keys.train("e1"), _train_request(setup), timeout=300)
                    job_ids = [call(session, keys.adapt("e1"), _adapt_request(setup, seed, budget), timeout=30)["job"]
                               for seed in range(jobs)]
                if k < kills:
                    try:
                        learner.wait(timeout=600)  # it kills itself at its point
                    except subprocess.TimeoutExpired:
                        raise RuntimeError(f"the learner did not reach {point} of batch {batch}: the jobs ended "
                                           "first (a larger --budget)") from None
                    if learner.returncode != -signal.SIGKILL:
                        raise RuntimeError(f"the learner exited {learner.returncode}, not by its kill")
                    where[point] = where.get(point, 0) + 1
                    lives.append({"kill": k, "point": point, "batch": batch, "launcher_killed": k in launcher_at})
                    if k in launcher_at:  # the whole deployment too: started again on the same --record
                        launcher.kill()
                        launcher.start()
                    continue

                def ended():
                    try:
                        states = [call(session, keys.job_status(j), timeout=10)["state"] for j in job_ids]
                    except WireError:
                        return False
                    return all(s in ("done", "failed", "cancelled") for s in states) and states
                states = _wait(ended, 1800, "every job's end")
        learner.send_signal(signal.SIGTERM)
        learner.wait(60)
        launcher.stop()
    finally:
        for proc in (launcher.proc, learner):
            if proc is not None and proc.poll() is None:
                proc.kill()
        log.close()
    files = recording_segments(record)
    summary = summarize(record)
    per_job = {}
    lost = duplicated = reserved = 0
    for job in job_ids:
        rec = json.loads((state / "jobs" / f"{job}.json").read_text())
        recorded = summary["jobs"].get(job, {"rollouts": 0, "unique_rollouts": 0, "duplicates": []})
        n = int(rec["next_index"])
        missing = n - recorded["unique_rollouts"]
        per_job[job] = {"state": rec["state"], "attempts": rec["attempt"] + 1, "reserved": n,
                        "recorded": recorded["rollouts"], "distinct": recorded["unique_rollouts"],
                        "duplicated": recorded["duplicates"], "lost": missing}
        lost += missing
        duplicated += len(recorded["duplicates"])
        reserved += n
    return {"kills": kills, "where": where, "restarts_same_record": len(launcher_at), "lives": lives,
            "jobs": len(job_ids), "states": states, "reserved": reserved, "lost": lost, "duplicated": duplicated,
            "segments": len(files), "files": [f.name for f in files], "per_job": per_job,
            "seconds": round(time.perf_counter() - t0, 1)}


def part_workers(modes: list[str], jobs_per_mode: int, budget: int, tmp: Path) -> dict:
    """Part ``workers`` (see the module docstring)."""
    from acnmp_core.experiments.viapoint import make_setup
    from benchmarks.performance.evil_workers import MODES
    from services.launcher import LocalDeployment
    from services.recording.replay import summarize
    from services.transport import alive_tokens, call

    what = {"nan": "NaN rewards", "inf": "inf rewards", "huge": "rewards of -1e308", "shape": "rewards of the wrong shape",
            "stale": "another chunk's reply", "slow": "after 60 s (its peers: milliseconds)",
            "failing": "internal errors", "refusing": "bad_request to good requests"}
    setup = make_setup()
    ns = f"evil-{uuid.uuid4().hex[:6]}"
    rrd = tmp / "workers.rrd"
    out = {}
    with LocalDeployment(ns, workers=2, model=False, record=rrd, state_dir=tmp / "workers-state") as dep:
        s, keys = dep.session, dep.keys
        call(s, keys.train("e1"), _train_request(setup), timeout=300)
        for mode in modes:
            if mode not in MODES:
                raise ValueError(f"--modes: {mode!r} is not one of {MODES}")
            wid = f"evil-{mode}"
            evil = subprocess.Popen([sys.executable, "-m", "benchmarks.performance.evil_workers", "--mode", mode,
                                     "--id", wid, "--namespace", ns, "--connect", dep.anchor, "--slow-s", "60"],
                                    cwd=ROOT, env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            try:
                _wait(lambda: len(alive_tokens(s, keys.worker_token("point2d"))) == 3, 60, "the evil worker")
                t = time.perf_counter()
                ids = [call(s, keys.adapt("e1"), _adapt_request(setup, seed, budget), timeout=30)["job"]
                       for seed in range(jobs_per_mode)]
                done = _wait(lambda: (sts := [call(s, keys.job_status(j), timeout=10) for j in ids])
                             and all(st["state"] in ("done", "failed", "cancelled") for st in sts) and sts,
                             600, f"the jobs beside the {mode} worker")
                seconds = time.perf_counter() - t
            finally:
                evil.send_signal(signal.SIGTERM)
                evil.wait(30)
            out[mode] = {"what": what[mode], "jobs": len(ids), "done": sum(st["state"] == "done" for st in done),
                         "named": sum(any(e["worker"] == wid for e in st["excluded_workers"]) for st in done),
                         "reasons": sorted({e["reason"][:160] for st in done for e in st["excluded_workers"]
                                            if e["worker"] == wid}),
                         "errors": [st["error"] for st in done if st["error"]], "job_ids": ids,
                         "seconds": round(seconds, 1)}
    summary = summarize(rrd)
    for mode, m in out.items():
        m["rollouts_by_bad"] = sum(summary["jobs"].get(j, {}).get("workers", {}).get(f"evil-{mode}", 0)
                                   for j in m["job_ids"])
        m["rollouts_recorded"] = sum(summary["jobs"].get(j, {}).get("rollouts", 0) for j in m["job_ids"])
    return out


def main(argv: list[str] | None = None) -> int:
    from benchmarks.performance.evil_workers import MODES

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--kills", type=int, default=20, help="kill -9 of the learner (default: %(default)s)")
    p.add_argument("--launcher-kills", type=int, default=2,
                   help="of those, kills of the launcher too, started again on the same --record (default: %(default)s)")
    p.add_argument("--jobs", type=int, default=2, help="jobs of the kills part (default: %(default)s)")
    p.add_argument("--budget", type=int, default=200, help="roll-outs per job of the kills part (default: %(default)s)")
    p.add_argument("--modes", nargs="+", default=list(MODES), help="evil worker modes (default: all)")
    p.add_argument("--jobs-per-mode", type=int, default=2, help="jobs beside each evil worker (default: %(default)s)")
    p.add_argument("--skip", choices=("kills", "workers"), default=None, help="leave a part out")
    p.add_argument("--out", default=str(RESULTS / "bench_faults.json"), help="the JSON written (default: %(default)s)")
    args = p.parse_args(argv)
    prov = main_provenance(__file__, argv)
    t0 = time.perf_counter()
    result = {"benchmark": "faults", "provenance": prov,
              "config": {k: v for k, v in vars(args).items() if k != "out"}}
    with tempfile.TemporaryDirectory(prefix="bench-faults-") as tmp:
        if args.skip != "kills":
            result["kills"] = part_kills(args.kills, args.launcher_kills, args.jobs, args.budget, Path(tmp))
        if args.skip != "workers":
            result["workers"] = part_workers(args.modes, args.jobs_per_mode, 20, Path(tmp))
    result["wall_time_s"] = round(time.perf_counter() - t0, 1)
    result["note"] = ("Kills: each learner life ends by SIGKILL at its point (fault_points.py), the next starts on "
                      "its state directory; lost = indices a job record reserved that no file of the recording "
                      "holds. Workers: a job that avoided the evil worker (the learner's other jobs do for 120 s "
                      "after one excluded it) does not name it.")
    return save_result(result, args.out, headline=("kills", "workers"))


if __name__ == "__main__":
    sys.exit(main())
