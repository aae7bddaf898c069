"""Adaptation jobs side by side in one learner (``--jobs``, ``--job-runner``), measured.

Five parts, each one run writing one JSON:

``runner``: where the training part of concurrent jobs should compute. K E1 jobs on a
    :class:`~services.learner.core.LearnerCore` with the in-process via-point task as evaluator
    (no zenoh, no workers: what is left is the adaptation's arithmetic), run one after another
    (``--jobs 1``, the baseline), on K threads, and in K child processes; ``--reps`` times, in the
    same run. Wall and CPU seconds (the learner's and its job processes'), ratio to the baseline,
    and whether each job's result is bit-equal to the baseline's.
``deploy``: a local deployment (4 workers, no model service) per learner setting (``--jobs 1``
    and the default), all up at once; K = 1, 2, 4, 8 jobs submitted at once, ``--reps`` rounds of
    every setting in turn; time until all are done against K x one job alone (measured in the same
    deployment), and against ``--jobs 1``'s time for the same K in the same round. Then the same with roll-out-heavy jobs (each roll-out takes ``--rollout-delay`` s of
    the worker: a robot whose motion takes time). Learner and worker CPU seconds per round.
``ur10``: the same comparison (``--jobs 1`` against the default, K = 1, 2, 4) with jobs of a real
    roll-out-heavy kind: E5's UR10 pick and place on 4 UR10 workers, each roll-out a PyBullet
    episode of the worker's CPU.
``hosts``: two learners on two hosts against one (services/launcher/multihost.py: router, each
    learner and each of 4 workers on a network namespace of its own): 8 E1 jobs submitted at once
    from the client host on two skills, one owned by each learner of the pair (4 jobs each); wall
    time, each learner's and worker's CPU seconds (the process and its job processes); each job's
    result compared between 1 and 2 learners; a lower bound of the 2-learner time had each
    learner cores of its own (:func:`hosts_bound`). ``--reps`` times, the order alternating.
    ``hosts-client`` is its client side, run on the client host.
``kill``: 4 jobs at once (``--jobs 4``, the default runner), undisturbed; the same 4 jobs again with the learner
    killed by SIGKILL once all 4 run (the launcher restarts it): every job must end ``done`` with
    the undisturbed result, and the recording must hold every executed roll-out once.

    python benchmarks/performance/bench_jobs.py runner [--ks 2 4] [--reps 3] [--out FILE]
    python benchmarks/performance/bench_jobs.py deploy [--ks 1 2 4 8] [--out FILE]
    python benchmarks/performance/bench_jobs.py ur10 [--ks 1 2 4] [--budget 20] [--out FILE]
    python benchmarks/performance/bench_jobs.py hosts [--ks 8] [--reps 2] [--out FILE]   (as root)
    python benchmarks/performance/bench_jobs.py kill [--out FILE]

Numbers from one run on a shared machine (2 cores, other work running): the ratios of a run are
measured against baselines of the same run.
"""
from __future__ import annotations

import argparse
import contextlib
import os
import shutil
import statistics
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks._results import ROOT, main_provenance, save_result  # noqa: E402

if TYPE_CHECKING:
    from acnmp_core.adaptation.config import AdaptTarget
    from acnmp_core.data.demos import DemoSet

SMALL = {"encoder_widths": [32, 32], "decoder_widths": [32, 32]}
TRAIN_STEPS = 300
WAIT = 1800.0  # liveness bound


@dataclass(frozen=True)
class Workload:
    """What a benchmark's jobs adapt: the skill's demonstrations (trained into a 32x32 CNMP of
    ``TRAIN_STEPS`` steps, seed 3), and the adaptation's target, task and robot kind."""

    robot: str
    task: str
    task_config: dict
    demos: DemoSet
    target: AdaptTarget

    def train_request(self) -> dict:
        """The ``skill/<skill>/train`` request of the skill."""
        d = self.demos
        req = {"times": np.stack([x.times for x in d]), "values": np.stack([x.values for x in d]),
               "model": SMALL, "train": {"steps": TRAIN_STEPS}, "seed": 3}
        if d.n_task_params:
            req["task_params"] = d.all_task_params()
        return req

    def adapt_request(self, seed: int, budget: int) -> dict:
        """The ``skill/<skill>/adapt`` request of a job of ``budget`` roll-outs (no early stop) and ``seed``."""
        from acnmp_core.adaptation.config import AdaptConfig
        from acnmp_core.jobs.adapt import AdaptJob

        return AdaptJob(self.target, self.task, self.robot, self.task_config,
                        AdaptConfig(max_rollouts=budget, stop_on_success=False), seed=seed).to_dict()


def e1_workload() -> Workload:
    """E1's via-point adaptation of a point robot (roll-outs cost microseconds)."""
    from acnmp_core.experiments.viapoint import make_setup

    setup = make_setup()
    return Workload("point2d", "viapoint", dict(setup.task_config), setup.demos, setup.target)


def ur10_workload() -> Workload:
    """E5's UR10 pick and place, adapted to its (8, 10) cm case (each roll-out a PyBullet episode)."""
    from acnmp_core.experiments import ur10

    setup = ur10.make_setup()
    return Workload("ur10", "pick_place", {}, setup.demos, ur10.make_target(setup, "8_10"))


def _cpu(pids) -> float:
    """User + system CPU seconds of processes ``pids`` and their live descendants now."""
    import psutil

    total = 0.0
    for pid in pids:
        try:
            proc = psutil.Process(pid)
            for p in [proc, *proc.children(recursive=True)]:
                t = p.cpu_times()
                total += t.user + t.system
        except psutil.NoSuchProcess:
            pass
    return total


def _spread(values: list[float]) -> dict:
    return {"median": statistics.median(values), "min": min(values), "max": max(values), "n": len(values)}


# ----- part 1: threads against processes ------------------------------------------------------
def _spin(n: int = 3_000_000) -> None:
    x = 0
    for i in range(n):
        x += i


def _parallel_ceiling(k: int) -> float:
    """What K-way parallelism gives on this machine now: the wall time of K processes each
    spinning a fixed pure-Python loop at once, over K times one spinning alone (1.0: no core to
    spare; 1/K: K free cores)."""
    import multiprocessing

    ctx = multiprocessing.get_context("fork")  # no session or job thread lives yet: a fork starts in ms
    t0 = time.perf_counter()
    _spin()
    alone = time.perf_counter() - t0
    procs = [ctx.Process(target=_spin) for _ in range(k)]
    t0 = time.perf_counter()
    for p in procs:
        p.start()
    for p in procs:
        p.join()
    return (time.perf_counter() - t0) / (k * alone)

def part_runner(args) -> dict:
    from acnmp_core.jobs.adapt import AdaptJob
    from acnmp_core.adaptation.config import AdaptConfig
    from acnmp_core.model.cnmp import CNMPConfig
    from acnmp_core.experiments.viapoint import make_setup
    from acnmp_core.model.training import TrainConfig
    from services.learner.core import LearnerCore, TrainSpec
    from services.worker.core import ExecutedBatch

    setup = make_setup()

    class Local:
        credit = "step"

        def evaluate(self, trajectories, times, task_params=None):
            return ExecutedBatch.of(setup.task.evaluate(trajectories, times, task_params), ["w0"] * len(trajectories))

    tmp = Path(tempfile.mkdtemp(prefix="bench-jobs-"))
    try:
        trained = tmp / "trained"
        core = LearnerCore(trained, evaluator_for=lambda job: Local())
        core.train_skill("e1", TrainSpec(setup.demos, CNMPConfig(n_outputs=2, encoder_widths=(32, 32),
                                                                 decoder_widths=(32, 32)),
                                         TrainConfig(steps=TRAIN_STEPS), seed=3))
        core.close()

        def job(seed, budget=args.budget):
            return AdaptJob(setup.target, "viapoint", "point2d", setup.task_config,
                            AdaptConfig(max_rollouts=budget, stop_on_success=False), seed=seed)

        def run(k: int, jobs: int, runner: str, tag: str) -> dict:
            state = tmp / tag
            shutil.copytree(trained, state, ignore=shutil.ignore_patterns("*.lock"))
            core = LearnerCore(state, evaluator_for=lambda job: Local(), jobs=jobs, job_runner=runner).start()
            try:
                # warm-up, off the clock: every job slot runs a tiny job (its child process starts)
                warm = [core.submit("e1", job(1, budget=2)).job for _ in range(jobs)]
                assert core.wait_idle(WAIT) and all(core.status(w)["state"] == "done" for w in warm)
                pids = [os.getpid()]
                cpu0, t0 = _cpu(pids), time.perf_counter()
                ids = [core.submit("e1", job(100 + i)).job for i in range(k)]
                assert core.wait_idle(WAIT)
                wall, cpu = time.perf_counter() - t0, _cpu(pids) - cpu0
                results = [core.status(i)["result"] for i in ids]
                assert all(core.status(i)["state"] == "done" for i in ids)
            finally:
                core.close()
                shutil.rmtree(state, ignore_errors=True)
            return {"wall_s": wall, "cpu_s": cpu, "trajectories": [r["trajectory"] for r in results]}

        rounds = []
        for rep in range(args.reps):
            for k in args.ks:
                ceiling = _parallel_ceiling(k)
                seq = run(k, 1, "thread", f"seq-{rep}-{k}")
                row = {"rep": rep, "k": k, "sequential": {x: seq[x] for x in ("wall_s", "cpu_s")},
                       "ceiling_wall_ratio": ceiling}
                for name, runner in (("threads", "thread"), ("processes", "process")):
                    got = run(k, k, runner, f"{name}-{rep}-{k}")
                    row[name] = {"wall_s": got["wall_s"], "cpu_s": got["cpu_s"],
                                 "wall_ratio": got["wall_s"] / seq["wall_s"],
                                 "bit_equal": all(np.array_equal(a, b) for a, b in
                                                  zip(got["trajectories"], seq["trajectories"]))}
                print(f"rep {rep} K={k}: sequential {seq['wall_s']:.1f}s, threads x{row['threads']['wall_ratio']:.2f}, "
                      f"processes x{row['processes']['wall_ratio']:.2f}, ceiling x{ceiling:.2f}", flush=True)
                rounds.append(row)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    summary = {}
    for k in args.ks:
        rows = [r for r in rounds if r["k"] == k]
        summary[str(k)] = {name: {"wall_ratio": _spread([r[name]["wall_ratio"] for r in rows]),
                                  "bit_equal": all(r[name]["bit_equal"] for r in rows)}
                           for name in ("threads", "processes")}
        summary[str(k)]["sequential_wall_s"] = _spread([r["sequential"]["wall_s"] for r in rows])
        summary[str(k)]["ceiling_wall_ratio"] = _spread([r["ceiling_wall_ratio"] for r in rows])
        for name in ("threads", "processes"):
            summary[str(k)][name]["cpu_ratio"] = _spread([r[name]["cpu_s"] / r["sequential"]["cpu_s"] for r in rows])
    return {"rounds": rounds, "summary": summary}


# ----- part 2: a deployment, K jobs at once ----------------------------------------------------
class _Deployed:
    """A session on a deployment with trained ``skills`` (the E1 skill each, trained the same way),
    and a way to run jobs at once and time them; ``pids(kind)`` gives the pids of its learners or
    workers (none: no CPU is counted)."""

    def __init__(self, session, keys, workload: Workload, budget: int, skills=("e1",), pids=lambda kind: []):
        from services.transport import call

        self.session, self.keys, self.workload, self.budget, self.call = session, keys, workload, budget, call
        self.pids = pids
        for skill in skills:
            call(session, keys.train(skill), workload.train_request(), timeout=600)

    @classmethod
    def local(cls, dep, workload: Workload, budget: int) -> "_Deployed":
        """On a :class:`~services.launcher.LocalDeployment`, with skill ``e1``."""
        return cls(dep.session, dep.keys, workload, budget,
                   pids=lambda kind: [c.pid for name, c in dep.children.items() if name.startswith(kind)])

    def submit(self, seeds, skills=None, budget: int | None = None) -> list[str]:
        """Queue a job per seed (on the skill at the same place of ``skills``, default ``e1``) of
        ``budget`` roll-outs (default the deployment's)."""
        skills = skills or ["e1"] * len(seeds)
        return [self.call(self.session, self.keys.adapt(skill), self.workload.adapt_request(s, budget or self.budget),
                          timeout=30)["job"] for skill, s in zip(skills, seeds)]

    def wait(self, ids, pred=lambda st: st["state"] in ("done", "failed", "cancelled")) -> dict:
        deadline = time.monotonic() + WAIT
        while True:
            st = {i: self.call(self.session, self.keys.job_status(i), timeout=30) for i in ids}
            if all(pred(s) for s in st.values()):
                return st
            if time.monotonic() > deadline:
                raise TimeoutError(st)
            time.sleep(0.1)

    def run(self, seeds, skills=None, budget: int | None = None) -> dict:
        """Submit the jobs of :meth:`submit` at once and wait for them all; wall and CPU seconds
        (learners', workers') until then, and each job's resulting trajectory."""
        lcpu0, wcpu0 = _cpu(self.pids("learner")), _cpu(self.pids("worker"))
        t0 = time.perf_counter()
        ids = self.submit(seeds, skills, budget)
        st = self.wait(ids)
        wall = time.perf_counter() - t0
        bad = {i: s["error"] for i, s in st.items() if s["state"] != "done"}
        if bad:
            raise RuntimeError(f"jobs did not finish: {bad}")
        return {"wall_s": wall, "learner_cpu_s": _cpu(self.pids("learner")) - lcpu0,
                "worker_cpu_s": _cpu(self.pids("worker")) - wcpu0,
                "trajectories": [st[i]["result"]["trajectory"] for i in ids]}


def _runs_interleaved(deployed: dict, seeds, reps: int) -> dict:
    """Run the jobs of ``seeds`` at once on every deployment of ``deployed`` (setting -> _Deployed),
    ``reps`` rounds, each round every setting once in turn: so a ratio between settings compares
    runs a few seconds apart, not minutes (the shared machine's speed drifts between minutes).
    Per setting, every round's run in order."""
    runs = {conf: [] for conf in deployed}
    for _ in range(reps):
        for conf, d in deployed.items():
            runs[conf].append(d.run(seeds))
    return runs


def _median_run(runs: list[dict]) -> dict:
    """The run of median wall time among ``runs``."""
    return sorted(runs, key=lambda r: r["wall_s"])[len(runs) // 2]


def _compare(kinds, args) -> dict:
    """For each (name, roll-out delay s, workload) of ``kinds``: a deployment per learner setting
    of ``args.configs`` (``JOBS:RUNNER``; the first is the baseline), all up at once; one job alone,
    then K jobs at once for each K of ``args.ks``, ``args.reps`` rounds of every setting in turn
    (:func:`_runs_interleaved`). Each figure is the run of median wall time; a setting's ratio to the
    baseline is the median of its rounds' ratios (each round's two runs seconds apart)."""
    from services.launcher import LocalDeployment

    out = {}
    for kind, delay, workload in kinds:
        print(f"{kind}: " + ", ".join(args.configs), flush=True)
        with contextlib.ExitStack() as stack:
            deployed = {}
            for conf in args.configs:
                jobs, runner = conf.split(":")
                dep = stack.enter_context(LocalDeployment(
                    f"bjobs-{os.getpid()}-{kind}-{jobs}-{runner}", workers=args.workers, robot=workload.robot,
                    model=False, worker_delay=delay, learner_args=["--jobs", jobs, "--job-runner", runner]))
                deployed[conf] = _Deployed.local(dep, workload, args.budget)
            for conf, d in deployed.items():  # warm-up: the job processes start their first job
                d.run([1] * min(int(conf.split(":")[0]), 2))
            alone = {conf: _median_run(runs)["wall_s"]
                     for conf, runs in _runs_interleaved(deployed, [100], args.reps).items()}
            rows = {conf: {"jobs": int(conf.split(":")[0]), "runner": conf.split(":")[1], "one_alone_s": alone[conf],
                           "k": {}} for conf in args.configs}
            base = args.configs[0]
            for k in args.ks:
                runs = _runs_interleaved(deployed, [100 + i for i in range(k)], args.reps)
                for conf in args.configs:
                    got = _median_run(runs[conf])
                    row = {"wall_s": got["wall_s"], "wall_s_runs": [r["wall_s"] for r in runs[conf]],
                           "ratio_to_k_alone": got["wall_s"] / (k * alone[conf]),
                           "learner_cpu_s": got["learner_cpu_s"], "worker_cpu_s": got["worker_cpu_s"]}
                    if conf != base:
                        paired = [r["wall_s"] / b["wall_s"] for r, b in zip(runs[conf], runs[base])]
                        row["ratio_to_baseline_runs"] = paired
                        row["ratio_to_baseline"] = statistics.median(paired)
                        row["bit_equal_to_baseline"] = all(
                            np.array_equal(a, b) for r, b_run in zip(runs[conf], runs[base])
                            for a, b in zip(r["trajectories"], b_run["trajectories"]))
                    rows[conf]["k"][str(k)] = row
                    print(f"  {conf} K={k}: {got['wall_s']:.1f}s ({row['ratio_to_k_alone']:.2f} x K alone"
                          + (f", {row['ratio_to_baseline']:.2f} x {base})" if conf != base else ")"), flush=True)
        out[kind] = {"rollout_delay_s": delay, "robot": workload.robot, "task": workload.task,
                     "baseline": args.configs[0], "by_config": rows}
    return out


def part_deploy(args) -> dict:
    e1 = e1_workload()
    return _compare((("e1", 0.0, e1), ("rollout_heavy", args.rollout_delay, e1)), args)


def part_ur10(args) -> dict:
    return _compare((("ur10", 0.0, ur10_workload()),), args)


# ----- part 3: kill -9 during 4 concurrent jobs -----------------------------------------------
def part_kill(args) -> dict:
    from services.launcher import LocalDeployment
    from services.recording.replay import summarize

    tmp = Path(tempfile.mkdtemp(prefix="bench-jobs-kill-"))
    rrd = tmp / "kill.rrd"
    seeds = [100, 101, 102, 103]
    try:
        with LocalDeployment(f"bjobk-{os.getpid()}", workers=args.workers, model=False, record=rrd,
                             state_dir=tmp / "state", worker_delay=args.kill_delay,
                             learner_args=["--jobs", str(len(seeds))]) as dep:
            d = _Deployed.local(dep, e1_workload(), args.budget)
            t0 = time.perf_counter()
            calm = d.run(seeds)
            calm_s = time.perf_counter() - t0
            ids = d.submit(seeds)
            d.wait(ids, lambda st: st["state"] == "running" and st["rollouts"] >= 10)
            t_kill = time.perf_counter()
            dep.kill("learner")
            (restart,) = dep.supervisor.wait_restarts("learner", 1, timeout=120)
            back_s = time.perf_counter() - t_kill
            st = d.wait(ids)
        # the recording is complete once the deployment stopped
        jobs = summarize(rrd)["jobs"]
    finally:
        pass
    rows = []
    for i, seed, calm_traj in zip(ids, seeds, calm["trajectories"]):
        s, rec = st[i], jobs.get(i, {})
        rows.append({"job": i, "seed": seed, "state": s["state"], "attempt": s["attempt"],
                     "result_equal_to_undisturbed": s["state"] == "done"
                     and bool(np.array_equal(s["result"]["trajectory"], calm_traj)),
                     "rollouts_executed": s["rollouts_executed"], "recorded_rollouts": rec.get("rollouts"),
                     "recorded_unique": rec.get("unique_rollouts"), "recorded_duplicates": rec.get("duplicates")})
    shutil.rmtree(tmp, ignore_errors=True)
    return {"undisturbed_s": calm_s, "learner_back_s": back_s, "restart_exit_code": restart.exit_code,
            "jobs": rows,
            "all_done_equal": all(r["result_equal_to_undisturbed"] for r in rows),
            "recording_each_rollout_once": all(r["recorded_rollouts"] == r["recorded_unique"] == r["rollouts_executed"]
                                               and not r["recorded_duplicates"] for r in rows)}


# ----- part 4: two learners on two hosts against one -----------------------------------------
HOST_LEARNERS = ("learner", "learner-2")


def host_skills(learners=HOST_LEARNERS) -> list[str]:
    """One skill name per learner of ``learners`` (the first ``e1-<i>`` it owns), in their order."""
    from services.learner.ownership import owner_of

    names = [f"e1-{i}" for i in range(1000)]
    return [next(s for s in names if owner_of(s, learners) == lid) for lid in learners]


def host_jobs(k: int, skills) -> list[tuple[str, int]]:
    """K jobs (skill, seed) dealt round the ``skills`` in turn, seeds 100, 101, ..."""
    return [(skills[i % len(skills)], 100 + i) for i in range(k)]


def part_hosts_client(args) -> int:
    """The client side of ``hosts``, run on the client host: train ``args.skills``, warm every
    job slot up, print ``{"ready": true}``; at a line on stdin run ``args.ks[0]`` jobs at once
    (:func:`host_jobs`), save their trajectories to ``args.out`` (.npz, in job order) and print
    ``{"wall_s": ...}``."""
    import json

    from clients.client import ACNMPClient

    with ACNMPClient(args.namespace, config_file=args.config, role="operator", timeout=30) as client:
        d = _Deployed(client.session, client.keys, e1_workload(), args.budget, skills=args.skills)
        warm = [s for s in args.skills for _ in range(2 * args.slots)]  # every job process starts, off the clock
        d.run([1] * len(warm), warm, budget=2)
        print(json.dumps({"ready": True}), flush=True)
        sys.stdin.readline()
        skills, seeds = zip(*host_jobs(args.ks[0], args.skills))
        got = d.run(list(seeds), list(skills))
    np.savez(args.out, *[np.asarray(t) for t in got["trajectories"]])
    print(json.dumps({"wall_s": got["wall_s"]}), flush=True)
    return 0


def _hosts_round(n_learners: int, args, work: Path, tag: str) -> dict:
    """One deployment over hosts with ``n_learners`` learners and ``args.workers`` workers: K jobs
    at once from the client host; wall time, each learner's and worker's CPU seconds over them.
    ``tag`` names its namespace and its files in ``work``."""
    import json
    import subprocess

    from services.launcher.multihost import MultiHostDeployment

    with MultiHostDeployment(f"bjobh-{os.getpid()}-{tag}", workers=args.workers, learners=n_learners, model=False,
                             learner_args=["--jobs", str(args.slots)], work_dir=work / tag) as dep:
        out = work / f"{tag}.npz"
        client = dep.popen([sys.executable, str(Path(__file__).resolve()), "hosts-client", "--namespace", dep.namespace,
                            "--config", str(dep.config("operator")), "--skills", *args.skills, "--ks", str(args.ks[0]),
                            "--budget", str(args.budget), "--slots", str(args.slots), "--out", str(out)],
                           stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        try:
            if json.loads(client.stdout.readline() or "{}") != {"ready": True}:
                raise RuntimeError(f"the client on the client host failed (exit {client.wait(timeout=30)})")
            names = [n for n in dep.processes if n.startswith(("learner", "worker"))]
            cpu0 = {n: _cpu([dep.processes[n].proc.pid]) for n in names}
            client.stdin.write("go\n")
            client.stdin.flush()
            line = client.stdout.readline()
            cpu = {n: _cpu([dep.processes[n].proc.pid]) - cpu0[n] for n in names}  # just before the stop
            if not line or client.wait(timeout=60) != 0:
                raise RuntimeError(f"the client on the client host failed (exit {client.poll()})")
        finally:
            if client.poll() is None:
                client.kill()
                client.wait()
        with np.load(out) as z:
            trajectories = [z[f"arr_{i}"] for i in range(len(z.files))]
    return {"learners": n_learners, "wall_s": json.loads(line)["wall_s"],
            "learner_cpu_s": {n: c for n, c in cpu.items() if n.startswith("learner")},
            "worker_cpu_s": {n: c for n, c in cpu.items() if n.startswith("worker")},
            "trajectories": trajectories}


def hosts_bound(row: dict, cores_per_learner: float, worker_cores: float) -> float:
    """A lower bound of a round's wall time had each learner ``cores_per_learner`` cores of its own
    and the workers ``worker_cores`` in all: the busiest learner's CPU seconds over its cores, or
    the workers' CPU seconds over theirs, whichever is larger."""
    return max(max(row["learner_cpu_s"].values()) / cores_per_learner,
               sum(row["worker_cpu_s"].values()) / worker_cores)


def hosts_summary(rounds: list[dict], cores_per_learner: float, worker_cores: float) -> dict:
    """The ``hosts`` part's summary from its rounds (each with ``rep``, ``learners`` 1 or 2,
    ``wall_s``, ``learner_cpu_s`` and ``worker_cpu_s`` per process): per repetition the wall ratio
    2 learners / 1, the CPU split between the two learners (each one's share of their CPU), and the
    projected ratio (:func:`hosts_bound` of the 2-learner round over the 1-learner round's measured
    wall and over its own bound); the spread of each over the repetitions."""
    reps = []
    for rep in sorted({r["rep"] for r in rounds}):
        one, two = (next(r for r in rounds if r["rep"] == rep and r["learners"] == n) for n in (1, 2))
        bound_one, bound_two = (hosts_bound(r, cores_per_learner, worker_cores) for r in (one, two))
        total = sum(two["learner_cpu_s"].values())
        reps.append({"rep": rep, "wall_ratio": two["wall_s"] / one["wall_s"],
                     "learner_cpu_share": {n: c / total for n, c in two["learner_cpu_s"].items()},
                     "bound_s": {"1": bound_one, "2": bound_two},
                     "projected_ratio": bound_two / one["wall_s"], "projected_bound_ratio": bound_two / bound_one})
    return {"by_rep": reps,
            "wall_ratio": _spread([r["wall_ratio"] for r in reps]),
            "projected_ratio": _spread([r["projected_ratio"] for r in reps]),
            "projected_bound_ratio": _spread([r["projected_bound_ratio"] for r in reps]),
            "learner_cpu_share": {n: _spread([r["learner_cpu_share"][n] for r in reps]) for n in HOST_LEARNERS}}


def part_hosts(args) -> dict:
    """1 learner against 2, each on a host of its own, ``args.reps`` times (the order alternating);
    the jobs' results compared between the two for each job."""
    from services.launcher import netns

    why = netns.unavailable_reason()
    if why:
        raise SystemExit(f"bench_jobs.py hosts: {why}")
    args.skills = host_skills()
    work = Path(tempfile.mkdtemp(prefix="bench-jobs-hosts-"))
    rounds = []
    try:
        for rep in range(args.reps):
            for n in ((1, 2) if rep % 2 == 0 else (2, 1)):
                row = {"rep": rep, **_hosts_round(n, args, work, f"{rep}-{n}")}
                print(f"rep {rep}, {n} learner(s): {row['wall_s']:.1f} s, learner CPU "
                      + ", ".join(f"{k} {v:.1f}" for k, v in row["learner_cpu_s"].items())
                      + f" s, workers' CPU {sum(row['worker_cpu_s'].values()):.1f} s", flush=True)
                rounds.append(row)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    for rep in range(args.reps):
        one, two = (next(r for r in rounds if r["rep"] == rep and r["learners"] == n) for n in (1, 2))
        two["bit_equal_to_one_learner"] = [bool(np.array_equal(a, b)) for a, b in
                                           zip(one["trajectories"], two["trajectories"])]
    for r in rounds:
        r.pop("trajectories")
    summary = hosts_summary(rounds, args.cores_per_learner, args.worker_cores or args.workers)
    summary["bit_equal"] = all(all(r["bit_equal_to_one_learner"]) for r in rounds if r["learners"] == 2)
    return {"skills": args.skills, "jobs": [list(j) for j in host_jobs(args.ks[0], args.skills)],
            "rounds": rounds, "summary": summary}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("part", choices=("runner", "deploy", "ur10", "kill", "hosts", "hosts-client"))
    p.add_argument("--ks", type=int, nargs="+", default=None,
                   help="jobs at once (runner: 2 4; deploy: 1 2 4 8; ur10: 1 2 4; hosts: 8)")
    p.add_argument("--reps", type=int, default=None,
                   help="runner, deploy, ur10, hosts: repetitions (default: 3; hosts 2; deploy and ur10 1)")
    p.add_argument("--budget", type=int, default=50, help="roll-outs per job (default: %(default)s)")
    p.add_argument("--workers", type=int, default=4, help="deploy, kill, hosts: workers (default: %(default)s)")
    p.add_argument("--rollout-delay", type=float, default=0.2,
                   help="deploy: seconds per roll-out of the roll-out-heavy jobs (default: %(default)s)")
    p.add_argument("--kill-delay", type=float, default=0.05,
                   help="kill: seconds per roll-out, so the kill lands mid-job (default: %(default)s)")
    p.add_argument("--configs", nargs="+", default=None,
                   help="deploy, ur10: learner settings JOBS:RUNNER, the first the baseline (default: deploy "
                        "1:thread 2:thread 2:process; ur10 1:process 2:process)")
    p.add_argument("--slots", type=int, default=2, help="hosts: --jobs of every learner (default: %(default)s)")
    p.add_argument("--cores-per-learner", type=float, default=2.0,
                   help="hosts: cores of each learner's own host in the projection (default: %(default)s)")
    p.add_argument("--worker-cores", type=float, default=None,
                   help="hosts: cores of the workers in all in the projection (default: one per worker)")
    p.add_argument("--namespace", help=argparse.SUPPRESS)  # hosts-client: the deployment's
    p.add_argument("--config", help=argparse.SUPPRESS)
    p.add_argument("--skills", nargs="+", help=argparse.SUPPRESS)
    p.add_argument("--out", default=None, metavar="FILE",
                   help="write the result here (default benchmarks/results/bench_jobs_<part>.json; deploy: bench_jobs.json)")
    args = p.parse_args(argv)
    args.ks = args.ks or {"runner": [2, 4], "ur10": [1, 2, 4], "hosts": [8], "hosts-client": [8]}.get(args.part,
                                                                                                  [1, 2, 4, 8])
    args.configs = args.configs or (["1:process", "2:process"] if args.part == "ur10"
                                    else ["1:thread", "2:thread", "2:process"])
    args.reps = args.reps or {"hosts": 2, "deploy": 1, "ur10": 1}.get(args.part, 3)
    from services.learner.config import RUNNERS

    for conf in args.configs:
        jobs, _, runner = conf.partition(":")
        if not (jobs.isdigit() and int(jobs) >= 1 and runner in RUNNERS):
            p.error(f"--configs: {conf!r} is not JOBS:RUNNER (JOBS >= 1, RUNNER one of {', '.join(RUNNERS)})")
    if args.part == "hosts-client":
        return part_hosts_client(args)
    started = time.perf_counter()
    prov = main_provenance(__file__, argv)
    config = {"part": args.part, "ks": args.ks, "budget": args.budget, "model": SMALL, "train_steps": TRAIN_STEPS,
              "task": "viapoint (E1), AdaptConfig defaults, stop_on_success false"}
    if args.part == "runner":
        config["reps"] = args.reps
        result = part_runner(args)
    elif args.part == "deploy":
        config.update(workers=args.workers, rollout_delay_s=args.rollout_delay, configs=args.configs, reps=args.reps)
        result = part_deploy(args)
    elif args.part == "ur10":
        config.update(workers=args.workers, configs=args.configs, reps=args.reps,
                      task="E5 UR10 pick and place (case 8_10), AdaptConfig defaults, stop_on_success false")
        result = part_ur10(args)
    elif args.part == "hosts":
        config.update(workers=args.workers, reps=args.reps, jobs_per_learner=args.slots,
                      cores_per_learner=args.cores_per_learner, worker_cores=args.worker_cores or args.workers,
                      layout="MultiHostDeployment: router, each learner and each worker on a network namespace of "
                             "its own, jobs submitted from the client host; no model service, no recorder")
        result = part_hosts(args)
    else:
        config.update(workers=args.workers, rollout_delay_s=args.kill_delay)
        result = part_kill(args)
    out = args.out or ROOT / "benchmarks" / "results" / {"runner": "bench_jobs_runner.json", "deploy": "bench_jobs.json",
                                                         "kill": "bench_jobs_kill.json",
                                                         "hosts": "bench_jobs_hosts.json", "ur10": "bench_jobs_ur10.json"}[args.part]
    result["wall_time_s"] = time.perf_counter() - started
    save_result({"benchmark": f"jobs_{args.part}", "provenance": prov, "config": config, **result}, out,
                headline=("summary", "all_done_equal", "recording_each_rollout_once"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
