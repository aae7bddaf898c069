"""What the supervised steps cost: train() at E1's and E3's sizes, one assimilation, one adaptation
(and its supervised steps), and a small E3 run, single-threaded torch.

Every figure is measured as CPU time of this process (``time.process_time``; with one torch thread
it is the work done, and it moves far less than wall time on a machine shared with other jobs) and
as wall time; the load average at the start and end is recorded. Each workload also records a
digest of its result (weights, losses, roll-out counts), so two runs of the script on two commits
show whether they computed the same numbers. To compare commits, run this script from a checkout
of each, back to back (it imports the library of the tree it sits in)::

    python benchmarks/performance/bench_training.py --out benchmarks/results/bench_training_before.json  # at the old commit
    python benchmarks/performance/bench_training.py --before benchmarks/results/bench_training_before.json

``--before`` adds the ratios before / after of every figure, and whether the digests are equal.
"""
from __future__ import annotations

import argparse
import copy
import hashlib
import json
import os
import sys
import time
from pathlib import Path

import numpy as np
import torch

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from benchmarks._results import provenance, save_result  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402


def _digest(*items) -> str:
    """SHA-256 (16 hex digits) of tensors, arrays and JSON-able values, in order."""
    h = hashlib.sha256()
    for x in items:
        if isinstance(x, torch.Tensor):
            h.update(x.detach().contiguous().numpy().tobytes())
        elif isinstance(x, np.ndarray):
            h.update(np.ascontiguousarray(x).tobytes())
        else:
            h.update(json.dumps(x, sort_keys=True, default=float).encode())
    return h.hexdigest()[:16]


def _model_digest(model) -> str:
    return _digest(*model.state_dict().values())


class _Clock:
    """CPU and wall seconds of a block: ``with _Clock() as c: ...; c.cpu, c.wall``."""

    def __enter__(self):
        self._p, self._w = time.process_time(), time.perf_counter()
        return self

    def __exit__(self, *exc):
        self.cpu, self.wall = time.process_time() - self._p, time.perf_counter() - self._w


def _per_step(clock: _Clock, steps: int) -> dict:
    return {"cpu_ms_per_step": round(1000 * clock.cpu / steps, 3), "wall_ms_per_step": round(1000 * clock.wall / steps, 3)}


def warm_up() -> dict:
    """A 5-step training of a tiny CNMP before anything is timed: the first optimiser of a process
    imports torch's compiler stack (seconds of CPU), which no workload below should be charged."""
    from acnmp_core.model.cnmp import CNMP, CNMPConfig
    from acnmp_core.model.training import TrainConfig, train
    from acnmp_core.tasks.viapoint.task import obstacle_demos

    with _Clock() as c:
        train(CNMP(CNMPConfig(n_outputs=2, encoder_widths=(8,), decoder_widths=(8,))), obstacle_demos(),
              TrainConfig(steps=5), progress=False)
    return {"workload": "process_warm_up", "cpu_s": round(c.cpu, 3), "wall_s": round(c.wall, 3), "digest": ""}


def bench_train(name: str, model, demos, steps: int) -> tuple[dict, object]:
    """train() for ``steps`` steps at batch 32 x 10 targets; returns the figures and the model."""
    from acnmp_core.model.training import TrainConfig, train

    with _Clock() as c:
        r = train(model, demos, TrainConfig(steps=steps, batch_size=32, n_targets=10), seed=0, progress=False)
    return {"workload": name, "steps": steps, **_per_step(c, steps),
            "digest": _digest(_model_digest(model), r.train_loss, r.val)}, model


def bench_assimilation(model, setup, steps: int) -> dict:
    """One E3 assimilation (anchor included) of the model's own trajectory for the first new environment."""
    from acnmp_core.adaptation.assimilation import AssimilationConfig, assimilate
    from acnmp_core.adaptation.config import AdaptTarget
    from acnmp_core.data.demos import Demonstration
    from acnmp_core.experiments.wall import TRAIN_DEFAULTS, cnmp_trajectories, wall_conditions

    c = setup.stream[0]
    obs_t, obs_v = wall_conditions(c[None])
    target = AdaptTarget(obs_t[0], obs_v[0], c, setup.times)
    traj = cnmp_trajectories(model, c[None], setup.times)[0]
    m = copy.deepcopy(model)
    with _Clock() as clock:
        _, losses = assimilate(m, setup.initial, Demonstration(setup.times.copy(), traj, c.copy()),
                               AssimilationConfig(steps=steps, lr=TRAIN_DEFAULTS["assimilate_lr"]),
                               conditions=target, seed=1)
    return {"workload": "e3_assimilation", "steps": steps, **_per_step(clock, steps),
            "digest": _digest(_model_digest(m), losses)}


def bench_adaptation(model, setup, max_rollouts: int) -> dict:
    """One E3 adaptation (library defaults, ``max_rollouts``) on the first new environment the model
    fails, with its supervised steps timed apart."""
    from acnmp_core.adaptation import loop as adaptation
    from acnmp_core.adaptation.loop import adapt
    from acnmp_core.adaptation.config import AdaptConfig, AdaptTarget
    from acnmp_core.experiments.wall import cnmp_trajectories, wall_conditions
    from acnmp_core.tasks.wall.task import WallTask

    ev = WallTask()
    c = next(c for c in setup.stream
             if not ev.evaluate(cnmp_trajectories(model, c[None], setup.times), setup.times, c).success[0])
    obs_t, obs_v = wall_conditions(c[None])
    target = AdaptTarget(obs_t[0], obs_v[0], c, setup.times)
    sl_clock = {"cpu": 0.0, "wall": 0.0, "steps": 0}
    real_sl = adaptation._Updater.sl

    def timed_sl(self, steps: int) -> None:
        with _Clock() as k:
            real_sl(self, steps)
        sl_clock["cpu"] += k.cpu
        sl_clock["wall"] += k.wall
        sl_clock["steps"] += steps

    adaptation._Updater.sl = timed_sl
    try:
        m = copy.deepcopy(model)
        with _Clock() as clock:
            res = adapt(m, setup.initial, target, ev, AdaptConfig.paper(max_rollouts=max_rollouts), seed=7)
    finally:
        adaptation._Updater.sl = real_sl
    n = max(sl_clock["steps"], 1)
    return {"workload": "e3_adaptation", "rollouts": res.rollouts, "success": bool(res.success),
            "cpu_s": round(clock.cpu, 3), "wall_s": round(clock.wall, 3), "sl_steps": sl_clock["steps"],
            "sl_cpu_ms_per_step": round(1000 * sl_clock["cpu"] / n, 3),
            "sl_wall_ms_per_step": round(1000 * sl_clock["wall"] / n, 3),
            "digest": _digest(_model_digest(m), res.trajectory, res.rollouts)}


def bench_e3(envs: int, n_test: int) -> dict:
    """A small E3 run (ACNMP only): run_wall(envs, 0, n_test=n_test)."""
    from acnmp_core.experiments.wall import run_wall

    with _Clock() as clock:
        r = run_wall(envs, 0, n_test=n_test, eval_every=envs, methods=("acnmp",))
    s = r["methods"]["acnmp"]
    return {"workload": f"e3_run_{envs}_envs", "envs": envs, "n_test": n_test, "adaptations": s["adaptations"],
            "trajectories_total": s["trajectories_total"], "cpu_s": round(clock.cpu, 2), "wall_s": round(clock.wall, 2),
            "digest": _digest(r["rollouts_per_env"], s["test_success_rate"])}


def ratios(before: dict, after: dict) -> dict:
    """Per workload: before / after of every timing figure (> 1: faster now) and digest equality."""
    old = {w["workload"]: w for w in before["workloads"]}
    out = {}
    for w in after["workloads"]:
        b = old.get(w["workload"])
        if b is None:
            continue
        r = {k: round(b[k] / w[k], 3) for k in w if (k.endswith("_per_step") or k.endswith("_s")) and w[k]}
        out[w["workload"]] = {**r, "same_digest": b["digest"] == w["digest"]}
    return out


def _add_ratios(result: dict, before_path: str) -> None:
    """Add to ``result`` the commit of the JSON at ``before_path`` and :func:`ratios` against it."""
    before = json.loads(Path(before_path).read_text())
    result["before"] = {"file": Path(before_path).name, "commit": before["provenance"]["commit"],
                        "load_average_start_end": before.get("load_average_start_end")}
    result["ratios_before_over_after"] = ratios(before, result)


def main(argv: list[str] | None = None) -> int:
    from acnmp_core.experiments.wall import make_wall_cnmp, make_setup
    from acnmp_core.model.cnmp import CNMP, CNMPConfig
    from acnmp_core.tasks.viapoint.task import obstacle_demos

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--train-steps", type=int, default=3000, help="E3's first training (E1: a third)")
    ap.add_argument("--assimilate-steps", type=int, default=300, help="supervised steps of the assimilation timed (default 300)")
    ap.add_argument("--adapt-rollouts", type=int, default=100, help="roll-out budget of the adaptation timed (default 100)")
    ap.add_argument("--e3-envs", type=int, default=5, help="new environments of the small E3 run (default 5)")
    ap.add_argument("--e3-test", type=int, default=200, help="test environments of the small E3 run (default 200)")
    ap.add_argument("--before", help="a JSON this script wrote at another commit: add the ratios")
    ap.add_argument("--measured", help="with --before: take the figures from this JSON (written by this script) "
                                       "instead of measuring, e.g. when both runs went concurrently")
    add_run_arguments(ap, out=str(ROOT / "benchmarks" / "results" / "bench_training.json"))
    args = ap.parse_args(argv)
    if args.measured:
        if not args.before:
            ap.error("--measured needs --before")
        result = json.loads(Path(args.measured).read_text())
        _add_ratios(result, args.before)
        return save_result(result, args.out, headline=("load_average_start_end", "ratios_before_over_after"))
    torch.set_num_threads(1)
    meta = provenance()
    load0 = os.getloadavg()
    setup = make_setup(max(args.e3_envs, 50), 0, n_test=args.e3_test)
    workloads = [warm_up(), bench_train("e1_train", CNMP(CNMPConfig(n_outputs=2), seed=0), obstacle_demos(),
                             max(args.train_steps // 3, 1))[0]]
    e3, model = bench_train("e3_train", make_wall_cnmp(0), setup.initial, args.train_steps)
    workloads += [e3, bench_assimilation(model, setup, args.assimilate_steps),
                  bench_adaptation(model, setup, args.adapt_rollouts), bench_e3(args.e3_envs, args.e3_test)]
    result = {"benchmark": "bench_training", "provenance": meta,
              "config": {k: v for k, v in vars(args).items() if k not in ("out", "before")},
              "load_average_start_end": [round(load0[0], 2), round(os.getloadavg()[0], 2)],
              "workloads": workloads,
              "note": "cpu = process CPU time with 1 torch thread; wall includes waiting for the shared cores"}
    if args.before:
        _add_ratios(result, args.before)
    return save_result(result, args.out, headline=("load_average_start_end", "ratios_before_over_after"))


if __name__ == "__main__":
    sys.exit(main())
