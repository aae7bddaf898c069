"""E4: what the runs that the RL does not solve do, iteration by iteration (issue 13, third round).

For RL seeds of the transfer condition (E4's settings, or a named variant of ``e4_sweep.py``),
record per iteration: the mean and the noisy roll-out's final cube error (m); how far each moved
the cube (m, the largest distance from its start: 0 = untouched up to the simulator's jitter);
where the mean left the cube relative to the gap (along the walls' normal, + beyond the wall line,
and along the wall from the gap's centre, m); how close the paddle came to the cube's start (m);
how far the paddle's tip got past the wall line (m, each roll-out); the exploration std (rad, per
joint); how far the mean trajectory moved since the last iteration (rad, largest over steps and
joints); how much of the way to the last noisy roll-out it moved (``follow``: 1 - RMS(new mean -
noisy) / RMS(old mean - noisy); 1 reached it, 0 stayed); whether the iteration had a signal; and
how many further policy steps its update took (``reuses``). Each run then gets a label (see
:func:`classify`). Writes benchmarks/studies/e4_transfer/results/e4_failures.json. Usage:
``python benchmarks/studies/e4_transfer/e4_failures.py --seeds 30-59 [--variant tol1e-4] [--cache DIR]``.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import torch

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from acnmp_core.adaptation.credit import per_step_advantages  # noqa: E402
from acnmp_core.experiments.transfer import BLIND_TOLERANCE, CHECKPOINTS, make_setup, run_condition  # noqa: E402
from acnmp_core.tasks.transfer.scene import CubeGapTask  # noqa: E402
from benchmarks._results import provenance, save_result, study_results  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402
from benchmarks.studies.e4_transfer.e4_sweep import VARIANTS, _memo_trainer  # noqa: E402

#: The cube counts as moved by a roll-out when it ends up this far (m) from its start at some step
#: (the simulator's jitter of an untouched cube is micrometres, benchmarks/studies/e4_transfer/results/e4_jitter.json).
MOVED = 1e-3


def _seeds(text: str) -> list[int]:
    """'30-59' or '30,35,39' -> the list of seeds."""
    if "-" in text:
        a, b = (int(x) for x in text.split("-"))
        return list(range(a, b + 1))
    return [int(x) for x in text.split(",")]


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x ** 2)))


def iteration_record(log, trajs: np.ndarray, batch, scene, last: np.ndarray | None, credit: str) -> dict:
    """One iteration's facts (see the module docstring) from adapt()'s on_iteration arguments:
    trajs (1+K, T, D) rad, row 0 the mean; batch the RolloutBatch with states "object_xy" and
    "ee_xy" (1+K, T, 2) m; last the previous iteration's trajs (None for the first)."""
    cube = batch.states["object_xy"]
    start = np.asarray(scene.cube_xy)
    moved = np.linalg.norm(cube - start, axis=2).max(axis=1)  # (1+K,)
    final = cube[0, -1] - scene.gap_centre
    near = np.linalg.norm(batch.states["ee_xy"][0] - start, axis=1).min()
    # how far the paddle's tip got past the wall line (m): a paddle stopped at the gap's edges stays near 0
    beyond = ((batch.states["ee_xy"] - scene.gap_centre) @ scene.wall_normal).max(axis=1)  # (1+K,)
    signal = per_step_advantages(batch.rewards, "awr", 0.1, credit, BLIND_TOLERANCE) is not None
    return {"iteration": log.iteration, "mean_error": float(batch.errors[0]),
            "noisy_error": [float(e) for e in batch.errors[1:]],
            "mean_moved": float(moved[0]), "noisy_moved": [float(m) for m in moved[1:]],
            "mean_cube_normal": float(final @ scene.wall_normal), "mean_cube_along": float(final @ scene.wall_direction),
            "mean_paddle_to_cube_min": float(near), "mean_paddle_beyond": float(beyond[0]),
            "noisy_paddle_beyond": [float(b) for b in beyond[1:]], "explore_std": [float(s) for s in log.explore_std],
            "mean_shift": None if last is None else float(np.abs(trajs[0] - last[0]).max()),
            "follow": None if last is None or len(last) < 2 else 1.0 - _rms(trajs[0] - last[1]) / _rms(last[0] - last[1]),
            "signal": bool(signal)}


def first_touches(its: list[dict]) -> dict:
    """The first iteration in which any roll-out moved the cube and the first in which the mean did
    (None: never), and how many iterations had no signal."""
    def first(pred):
        return next((i["iteration"] for i in its if pred(i)), None)

    return {"first_touch": first(lambda i: i["mean_moved"] > MOVED or any(m > MOVED for m in i["noisy_moved"])),
            "first_mean_touch": first(lambda i: i["mean_moved"] > MOVED),
            "blind": sum(not i["signal"] for i in its)}


def classify(its: list[dict], tolerance: float, half_gap: float) -> str:
    """A run's label from its iterations: "solved"; "never_touched" (no roll-out moved the cube);
    "touched_mean_never" (noisy roll-outs moved it, the mean never did); "plateau_near" (the mean's
    best error within 1.5 x the tolerance: the cube pushed towards the goal, stopping short or
    beside it); "wall" (the mean's cube ends on the robot's side of the wall line, outside the gap:
    pushed into a wall); "beyond_far" (through the gap but far from the goal)."""
    if any(i["mean_error"] < tolerance for i in its):
        return "solved"
    if not any(i["mean_moved"] > MOVED or any(m > MOVED for m in i["noisy_moved"]) for i in its):
        return "never_touched"
    if not any(i["mean_moved"] > MOVED for i in its):
        return "touched_mean_never"
    best = min(its, key=lambda i: i["mean_error"])
    if best["mean_error"] < 1.5 * tolerance:
        return "plateau_near"
    if best["mean_cube_normal"] < 0.01 and abs(best["mean_cube_along"]) > half_gap:
        return "wall"
    return "beyond_far"


def summary(runs: list[dict], tolerance: float) -> dict:
    """Across runs: success by iteration of the mean (the experiment's metric) and, for comparison,
    of any roll-out (the first iteration in which the mean or the noisy roll-out succeeded: what
    the runs found, kept or not); how often a noisy roll-out succeeded without the next mean
    succeeding; and the median ``follow`` after the iterations whose noisy roll-out beat the mean
    by more than 1 mm, in the runs solved within 11 iterations and in the others."""
    def first_any(r):
        return next((i["iteration"] for i in r["per_iteration"]
                     if i["mean_error"] < tolerance or any(e < tolerance for e in i["noisy_error"])), None)

    def share(firsts):
        return {str(k): float(np.mean([f is not None and f <= k for f in firsts])) for k in CHECKPOINTS}

    lost, follows = 0, {"solved_by_11": [], "later_or_never": []}
    for r in runs:
        its = r["per_iteration"]
        group = "solved_by_11" if r["iterations"] is not None and r["iterations"] <= 11 else "later_or_never"
        for a, b in zip(its, its[1:]):
            if any(e < tolerance for e in a["noisy_error"]) and b["mean_error"] >= tolerance:
                lost += 1
            if a["noisy_error"] and a["noisy_error"][0] < a["mean_error"] - 1e-3 and b["follow"] is not None:
                follows[group].append(b["follow"])
    return {"success_by_iteration": share([r["iterations"] for r in runs]),
            "any_rollout_success_by_iteration": share([first_any(r) for r in runs]),
            "noisy_success_not_kept": lost,
            "follow_after_better_noisy_median": {k: float(np.median(v)) if v else None for k, v in follows.items()},
            "follow_after_better_noisy_count": {k: len(v) for k, v in follows.items()}}


def main(argv: list[str] | None = None) -> int:
    """Run the seeds, write the per-iteration records, the labels and their counts."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="30-59", help="RL seeds: A-B (A to B) or A,B,C (default 30-59)")
    ap.add_argument("--variant", default="tol1e-4", help="a variant of benchmarks/studies/e4_transfer/e4_sweep.py (default: E4's setting)")
    ap.add_argument("--cache", default=None, metavar="DIR",
                    help="directory for trained pairs, shared with e4_sweep.py (default: in memory only)")
    add_run_arguments(ap, out=str(study_results("e4_transfer") / "e4_failures.json"))
    args = ap.parse_args(argv)
    if args.variant not in VARIANTS:
        print(f"e4_failures: unknown variant {args.variant!r}; benchmarks/studies/e4_transfer/e4_sweep.py --list names them", file=sys.stderr)
        return 2
    torch.set_num_threads(1)
    meta = provenance()
    cfg = VARIANTS[args.variant]()
    setup, trainer = make_setup(), _memo_trainer(None if args.cache is None else Path(args.cache))
    task = CubeGapTask(4)
    scene, runs = task.scene, []
    half_gap = task.scene.gap_width / 2
    try:
        for seed in _seeds(args.seeds):
            its: list[dict] = []
            last: list[np.ndarray] = []
            logs: list = []

            def record(log, trajs, batch, its=its, last=last, logs=logs):
                its.append(iteration_record(log, trajs, batch, scene, last[-1] if last else None, task.credit))
                last.append(trajs.copy())
                logs.append(log)  # adapt() sets log.reuses after this call

            res = run_condition(trainer(setup, cfg, seed % cfg.pair_seeds), setup, "transfer", task, cfg, seed, record)
            for i, log in zip(its, logs):
                i["reuses"] = log.reuses
            label = classify(its, task.tolerance, half_gap)
            runs.append({"seed": seed, "pair_seed": seed % cfg.pair_seeds, "iterations": res["iterations"],
                         "label": label, "best_mean_error": min(i["mean_error"] for i in its),
                         **first_touches(its), "per_iteration": its})
            print(f"seed {seed} pair {seed % cfg.pair_seeds} it {res['iterations']} {label} "
                  f"best {runs[-1]['best_mean_error']:.4f}", flush=True)
    finally:
        task.close()
    labels: dict[str, int] = {}
    for r in runs:
        labels[r["label"]] = labels.get(r["label"], 0) + 1
    late = [r for r in runs if r["iterations"] is None or r["iterations"] > 11]
    result = {"provenance": meta, "experiment": "transfer_failures", "variant": args.variant,
              "config": cfg.to_dict(), "moved_threshold": MOVED, "labels": labels,
              "summary": summary(runs, task.tolerance),
              "late_or_unsolved": [{"seed": r["seed"], "pair_seed": r["pair_seed"], "iterations": r["iterations"],
                                    "label": r["label"], "best_mean_error": r["best_mean_error"], "first_touch": r["first_touch"],
                                    "first_mean_touch": r["first_mean_touch"], "blind": r["blind"]} for r in late],
              "runs": runs}
    return save_result(result, args.out, None, ("labels", "summary", "late_or_unsolved"))


if __name__ == "__main__":
    sys.exit(main())
