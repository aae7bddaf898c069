"""Cross-checks of roll-out chunks (issue 73): what they cost on E1 jobs, and how soon they find a
worker that lies with finite numbers.

A local deployment of ``--workers`` healthy point2d workers (default 2; no learner, no model
service) and two E1 skills trained in this process from E1's six demonstrations
(``--train-steps``): ``default``, the model ``acnmp up`` trains (``CNMPConfig``'s defaults), and
``paper``, the paper's CNMP (no linear path: it adapts for tens of roll-outs,
docs/experiments/e1.md). Each job is an adaptation
to E1's extrapolated via-point with the default settings (stop on success), run in this process
through a :class:`~services.worker.remote.RemoteEvaluator` over the workers: the learner's own
path, without its bookkeeping (which is the same either way).

``overhead``: per skill, ``--jobs`` jobs (seeds 0..jobs-1) with cross-checks off (the baseline)
    and with each fraction of ``--fractions`` (every chunk whose success would end the job checked
    too, as the learner does), in ``--rounds`` rounds, each running every setting in turn (the
    order rotating from round to round, after one job to warm up). Per setting: the
    roll-outs the jobs used, the roll-outs their checks ran on top (the ratio), the chunks checked,
    and the wall time of the jobs as a ratio to the baseline's in the same round (the median over
    rounds). A check changes no result when every worker is honest: each job's roll-outs must be
    the baseline's.
``detection``: per skill, a lying worker (benchmarks/performance/evil_workers.py ``liar``: every
    reward -1.0, finite, the right shape and tag) beside the healthy ones. ``--detections`` times, a
    fresh evaluator with ``--detect-fraction`` runs jobs until it excludes the liar (at most
    ``--max-jobs``): the chunks the liar answered until then, the jobs that took, and the lie's
    effect on the jobs meanwhile. And for comparison the same jobs without cross-checks: the
    liar's roll-outs used and the jobs' success.

    python benchmarks/performance/bench_cross_check.py [--jobs 10] [--rounds 3] [--fractions 0.05 0.1 1]
        [--detections 10] [--out FILE]

Wall times from one run on a shared machine (2 cores): only ratios to the baseline of the same
round are reported.
"""
from __future__ import annotations

import argparse
import copy
import statistics
import sys
import time
import uuid
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks._results import RESULTS, main_provenance, save_result  # noqa: E402


def _evaluator(session, keys, setup, **options):
    from services.worker.exclusion import WorkerExclusions
    from services.worker.remote import RemoteEvaluator

    return RemoteEvaluator(session, keys, "point2d", "viapoint", setup.task_config, timeout=30.0,
                           exclusions=WorkerExclusions(), **options)


def _job(model, setup, evaluator, seed: int) -> dict:
    """One E1 adaptation of a copy of ``model`` through ``evaluator``: its outcome and wall time."""
    from acnmp_core.adaptation.config import AdaptConfig
    from acnmp_core.adaptation.loop import adapt

    t = time.perf_counter()
    res = adapt(copy.deepcopy(model), setup.demos, setup.target, evaluator, AdaptConfig(), seed=seed)
    return {"seed": seed, "success": bool(res.success), "rollouts": int(res.rollouts),
            "seconds": time.perf_counter() - t}


def _wait_workers(evaluator, n: int, timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while len(evaluator.workers()) < n:
        if time.monotonic() > deadline:
            raise TimeoutError(f"{n} workers: {evaluator.workers()}")
        time.sleep(0.05)


def part_overhead(session, keys, setup, model, jobs: int, rounds: int, fractions: list[float]) -> dict:
    """Part ``overhead`` of one skill (see the module docstring)."""
    settings = [0.0, *fractions]
    per: dict[float, list[dict]] = {f: [] for f in settings}
    _job(model, setup, _evaluator(session, keys, setup), jobs)  # warm: the first job pays what later ones reuse
    for r in range(rounds):
        for f in settings[r % len(settings):] + settings[:r % len(settings)]:
            ev = _evaluator(session, keys, setup, cross_check=f, check_success=f > 0, check_seed=1000 * r + 1)
            runs = [_job(model, setup, ev, seed) for seed in range(jobs)]
            per[f].append({"round": r, "seconds": sum(x["seconds"] for x in runs),
                           "rollouts": sum(x["rollouts"] for x in runs), "successes": sum(x["success"] for x in runs),
                           "per_job_rollouts": [x["rollouts"] for x in runs], "chunks": ev.chunks,
                           "checks": ev.checks, "check_rollouts": ev.check_rollouts,
                           "disagreements": ev.disagreements, "excluded": [e.line() for e in ev.excluded]})
    base = per[0.0]
    out = {}
    for f in settings:
        rows = per[f]
        ratios = [row["seconds"] / b["seconds"] for row, b in zip(rows, base)]
        out[f"{f:g}"] = {
            "cross_check": f, "rounds": rows,
            "rollouts": rows[0]["rollouts"], "check_rollouts": statistics.median(r["check_rollouts"] for r in rows),
            "check_rollouts_ratio": statistics.median(r["check_rollouts"] / r["rollouts"] for r in rows),
            "chunks_checked": statistics.median(r["checks"] / max(1, r["chunks"]) for r in rows),
            "wall_ratio": statistics.median(ratios), "wall_ratios": [round(x, 3) for x in ratios],
            "same_rollouts_as_baseline": all(r["per_job_rollouts"] == b["per_job_rollouts"] for r, b in zip(rows, base)),
            "disagreements": sum(r["disagreements"] for r in rows)}
    return out


def part_detection(session, keys, setup, model, workers: int, fraction: float, detections: int,
                   max_jobs: int) -> dict:
    """Part ``detection`` of one skill (see the module docstring)."""
    from benchmarks.performance.evil_workers import serve_evil

    evil, rpc, token = serve_evil(session, keys, "liar", "point2d", "liar")
    try:
        reps = []
        for rep in range(detections):
            ev = _evaluator(session, keys, setup, cross_check=fraction, check_success=True, check_seed=rep)
            _wait_workers(ev, workers + 1)
            asked, runs = evil.asked, []
            while not ev.excluded and len(runs) < max_jobs:
                runs.append(_job(model, setup, ev, 100 * rep + len(runs)))
            liar = [e for e in ev.excluded if e.worker == "liar"]
            reps.append({"found": bool(liar), "liar_chunks": evil.asked - asked, "jobs": len(runs),
                         "chunks": ev.chunks, "checks": ev.checks,
                         "excluded": [e.line() for e in ev.excluded], "successes": sum(x["success"] for x in runs)})
        # the same jobs without cross-checks: what the lie does when nobody looks
        plain = _evaluator(session, keys, setup)
        asked = evil.asked
        unchecked = [_job(model, setup, plain, seed) for seed in range(max(1, min(max_jobs, 10)))]
        found = [r["liar_chunks"] for r in reps if r["found"]]
        return {"cross_check": fraction, "repetitions": reps, "found": len(found), "of": len(reps),
                "liar_chunks_median": statistics.median(found) if found else None,
                "liar_chunks_max": max(found) if found else None,
                "jobs_median": statistics.median(r["jobs"] for r in reps),
                "unchecked": {"jobs": len(unchecked), "successes": sum(x["success"] for x in unchecked),
                              "liar_chunks": evil.asked - asked, "excluded": [e.line() for e in plain.excluded]}}
    finally:
        token.undeclare()
        rpc.close()


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--workers", type=int, default=2, help="healthy point2d workers (default: %(default)s)")
    p.add_argument("--train-steps", type=int, default=3000, help="training of the skill (default: %(default)s)")
    p.add_argument("--jobs", type=int, default=10, help="E1 jobs per setting and round (default: %(default)s)")
    p.add_argument("--rounds", type=int, default=3, help="rounds of every setting in turn (default: %(default)s)")
    p.add_argument("--fractions", type=float, nargs="+", default=[0.05, 0.1, 1.0],
                   help="cross-check fractions measured against none (default: %(default)s)")
    p.add_argument("--detections", type=int, default=10, help="repetitions of the detection (default: %(default)s)")
    p.add_argument("--detect-fraction", type=float, default=0.05, help="the fraction detecting (default: %(default)s)")
    p.add_argument("--max-jobs", type=int, default=40, help="jobs at most per detection (default: %(default)s)")
    p.add_argument("--skip", choices=("overhead", "detection"), action="append", default=[], help="leave a part out")
    p.add_argument("--out", default=str(RESULTS / "bench_cross_check.json"), help="the JSON (default: %(default)s)")
    args = p.parse_args(argv)
    prov = main_provenance(__file__, argv)

    import torch

    from acnmp_core.experiments.viapoint import make_setup
    from acnmp_core.model.cnmp import CNMP, CNMPConfig
    from acnmp_core.model.training import TrainConfig, train
    from services.launcher import LocalDeployment

    torch.set_num_threads(1)
    t0 = time.perf_counter()
    setup = make_setup()
    models = {}
    for name, config in (("default", CNMPConfig(n_outputs=2)), ("paper", CNMPConfig(n_outputs=2, prior="none"))):
        models[name] = CNMP(config, seed=0)
        train(models[name], setup.demos, TrainConfig(steps=args.train_steps), seed=0, progress=False)
    result = {"benchmark": "cross_check", "provenance": prov, "config": {k: v for k, v in vars(args).items() if k != "out"},
              "priors": {name: m.config.prior for name, m in models.items()}, "overhead": {}, "detection": {}}
    ns = f"xcheck-{uuid.uuid4().hex[:6]}"
    with LocalDeployment(ns, workers=args.workers, model=False, learner=False, record=None) as dep:
        _wait_workers(_evaluator(dep.session, dep.keys, setup), args.workers)
        for name, model in models.items():
            if "overhead" not in args.skip:
                result["overhead"][name] = part_overhead(dep.session, dep.keys, setup, model, args.jobs, args.rounds,
                                                         args.fractions)
            if "detection" not in args.skip:
                result["detection"][name] = part_detection(dep.session, dep.keys, setup, model, args.workers,
                                                           args.detect_fraction, args.detections, args.max_jobs)
    result["wall_time_s"] = round(time.perf_counter() - t0, 1)
    result["note"] = ("Wall time as the ratio of a setting's jobs to the baseline's (cross-checks off) in the same "
                      "round, the median over rounds; check roll-outs are executed on top of the jobs' own, which "
                      "do not count them. A liar's chunks: those it answered until its exclusion.")
    return save_result(result, args.out, headline=("overhead", "detection"))


if __name__ == "__main__":
    sys.exit(main())
