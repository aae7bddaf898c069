"""Nothing lost, one bad part never fails the whole (issues 66 and 73), measured from outside.

Three parts, one JSON:

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
    twice). Target: 0 and 0. And the jobs whose final status names an excluded worker (the workers
    going down with a killed launcher are no attempt's fault): target 0.
``joint``: the same, on a deployment of its own, with ``--joint-kills`` lives (default 24) in which
    the learner kills, at its point and just before itself, the recorder (its launcher starts it
    again on the recording's next segment) or the launcher and the recorder (the launcher is then
    started again on the same ``--record``), in turn, at the 2nd, 3rd or 4th batch of its life
    (issue 73: a recorder dying with the learner lost what it had received but not yet written).
``workers``: a deployment (learner, 2 healthy point2d workers) and, per mode of
    benchmarks/performance/evil_workers.py (NaN, inf, -1e308, wrong shape, stale chunk, slow,
    failing, refusing), an evil worker beside them while ``--jobs-per-mode`` jobs (default 2) run
    at once. Counted: jobs done, jobs whose status names the evil worker (the others avoided it:
    the learner's other jobs do for 120 s), roll-outs the recording has from it. Target: every job
    done, the worker named, none of its roll-outs used.

    python benchmarks/performance/bench_faults.py [--kills 20] [--launcher-kills 2] [--joint-kills 24]
        [--skip kills|joint|workers] [--out FILE]
"""
from __future__ import annotations

import argparse
import signal
import subprocess
import sys
import tempfile
import time
import uuid
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks._results import RESULTS, main_provenance, save_result  # noqa: E402
from benchmarks.performance.fault_points import ENV, ROOT  # noqa: E402

#: A small E1 network: the jobs' cost is the roll-outs and the bookkeeping this measures.
SMALL = {"encoder_widths": [32, 32], "decoder_widths": [32, 32]}
#: Who dies with the learner in a joint kill (fault_points.py --also), in turn.
JOINT = (("recorder",), ("launcher", "recorder"))


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


def learner_lives(kills: int, launcher_kills: int) -> list[dict]:
    """Part ``kills``: the learner alone at each point in turn, at the 1st, 2nd or 3rd batch of its
    life; at ``launcher_kills`` of them (spread out) the launcher killed too, after the learner."""
    from benchmarks.performance.fault_points import POINTS

    after = {round((i + 1) * kills / (launcher_kills + 1)) for i in range(launcher_kills)}
    return [{"point": POINTS[k % len(POINTS)], "batch": 1 + (k // len(POINTS)) % 3, "with": [],
             "launcher_after": k in after} for k in range(kills)]


def joint_lives(kills: int) -> list[dict]:
    """Part ``joint``: each point with each of :data:`JOINT` in turn, dying at the same moment as the
    learner, at the 2nd, 3rd or 4th batch of its life (the batches before it still unwritten by
    the recorder, if ever)."""
    from benchmarks.performance.fault_points import POINTS

    return [{"point": POINTS[k % len(POINTS)], "batch": 2 + (k // (2 * len(POINTS))) % 3,
             "with": list(JOINT[(k // len(POINTS)) % len(JOINT)]), "launcher_after": False} for k in range(kills)]


def part_kills(lives: list[dict], jobs: int, budget: int, tmp: Path, env: dict | None = None) -> dict:
    """Run ``jobs`` E1 jobs through the learner ``lives`` (each ends by its kill; see the module
    docstring), then to their end; count what the recording lost or holds twice. ``env``: the
    processes' environment (default fault_points.ENV)."""
    from acnmp_core.experiments.viapoint import make_setup
    from benchmarks.performance.fault_points import Launcher, count_rollouts, start_learner
    from services.recording.segments import recording_segments
    from services.transport import Keyspace, WireError, alive_tokens, call, open_session

    tmp.mkdir(parents=True, exist_ok=True)
    setup = make_setup()
    ns = f"faults-{uuid.uuid4().hex[:6]}"
    keys = Keyspace(ns)
    record, state = tmp / "faults.rrd", tmp / "learner-state"
    launcher = Launcher(ns, record, tmp / "deployment-state", env=env)
    log = open(tmp / "learner.log", "w")
    where: dict[str, int] = {}
    job_ids: list[str] = []
    done = []
    learner = None
    t0 = time.perf_counter()
    launcher.start()
    try:
        for k, life in enumerate([*lives, {"point": "none", "batch": 1, "with": [], "launcher_after": False}]):
            recorder = launcher.children["recorder"]
            also = tuple(launcher.proc.pid if who == "launcher" else recorder for who in life["with"])
            learner = start_learner(ns, launcher.anchor, state, life["point"], life["batch"], log, also, jobs=2,
                                    env=env)
            with open_session("peer", connect=[launcher.anchor]) as session:
                _wait(lambda: alive_tokens(session, keys.learner_token("learner")), 120, "the learner's token")
                if k == 0:
                    call(session, keys.train("e1"), _train_request(setup), timeout=300)
                    job_ids = [call(session, keys.adapt("e1"), _adapt_request(setup, seed, budget), timeout=30)["job"]
                               for seed in range(jobs)]
                if life["point"] == "none":
                    def ended():
                        try:
                            states = [call(session, keys.job_status(j), timeout=10)["state"] for j in job_ids]
                        except WireError:
                            return False
                        return all(s in ("done", "failed", "cancelled") for s in states) and states
                    states = _wait(ended, 1800, "every job's end")
                    continue
            try:
                learner.wait(timeout=600)  # it kills itself (and those with it) at its point
            except subprocess.TimeoutExpired:
                raise RuntimeError(f"the learner did not reach {life['point']} of batch {life['batch']}: the jobs "
                                   "ended first (a larger --budget)") from None
            if learner.returncode != -signal.SIGKILL:
                raise RuntimeError(f"the learner exited {learner.returncode}, not by its kill")
            where[life["point"]] = where.get(life["point"], 0) + 1
            done.append({"kill": k, **life})
            if "launcher" in life["with"] or life["launcher_after"]:  # started again on the same --record
                launcher.kill()
                launcher.start()
            elif "recorder" in life["with"]:  # its supervisor starts the recorder again (a next segment)
                launcher.wait_child("recorder", lambda pid: pid not in (None, recorder))
        learner.send_signal(signal.SIGTERM)
        learner.wait(60)
        launcher.stop()
    finally:
        for proc in (launcher.proc, learner):
            if proc is not None and proc.poll() is None:
                proc.kill()
        log.close()
    files = recording_segments(record)
    counts = count_rollouts(record, state, job_ids)
    return {"kills": len(lives), "where": where, "lives": done,
            "with": {"+".join(["learner", *w]): sum(life["with"] == list(w) for life in lives) for w in ((), *JOINT)},
            "restarts_same_record": sum("launcher" in life["with"] or life["launcher_after"] for life in lives),
            "jobs": len(job_ids), "states": states, **counts,
            "excluded_at_end": sum(bool(j["excluded_workers"]) for j in counts["per_job"].values()),
            "segments": len(files), "files": [f.name for f in files], "seconds": round(time.perf_counter() - t0, 1)}


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
    p.add_argument("--joint-kills", type=int, default=24,
                   help="kill -9 of the learner with the recorder, or with the launcher and the recorder, at the "
                        "same moment (default: %(default)s)")
    p.add_argument("--jobs", type=int, default=2, help="jobs of the kills part (default: %(default)s)")
    p.add_argument("--budget", type=int, default=200, help="roll-outs per job of the kills part (default: %(default)s)")
    p.add_argument("--modes", nargs="+", default=list(MODES), help="evil worker modes (default: all)")
    p.add_argument("--jobs-per-mode", type=int, default=2, help="jobs beside each evil worker (default: %(default)s)")
    p.add_argument("--skip", choices=("kills", "joint", "workers"), action="append", default=[],
                   help="leave a part out (repeatable)")
    p.add_argument("--out", default=str(RESULTS / "bench_faults.json"), help="the JSON written (default: %(default)s)")
    args = p.parse_args(argv)
    prov = main_provenance(__file__, argv)
    t0 = time.perf_counter()
    result = {"benchmark": "faults", "provenance": prov,
              "config": {k: v for k, v in vars(args).items() if k != "out"}}
    with tempfile.TemporaryDirectory(prefix="bench-faults-") as tmp:
        if "kills" not in args.skip:
            result["kills"] = part_kills(learner_lives(args.kills, args.launcher_kills), args.jobs, args.budget,
                                         Path(tmp) / "kills")
        if "joint" not in args.skip:
            result["joint"] = part_kills(joint_lives(args.joint_kills), args.jobs, args.budget, Path(tmp) / "joint")
        if "workers" not in args.skip:
            result["workers"] = part_workers(args.modes, args.jobs_per_mode, 20, Path(tmp))
    result["wall_time_s"] = round(time.perf_counter() - t0, 1)
    result["note"] = ("Kills: each learner life ends by SIGKILL at its point (fault_points.py), the next starts on "
                      "its state directory; lost = indices a job record reserved that no file of the recording "
                      "holds. Joint kills: the recorder (its launcher restarts it on the next segment), or the "
                      "launcher and the recorder (started again on the same --record), killed by the learner at its "
                      "point just before itself. Workers: a job that avoided the evil worker (the learner's other "
                      "jobs do for 120 s after one excluded it) does not name it.")
    return save_result(result, args.out, headline=("kills", "joint", "workers"))


if __name__ == "__main__":
    sys.exit(main())
