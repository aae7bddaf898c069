"""Can E6's demonstrations be chosen so that a model reproduces all 16 within 30 g?

Issue 15 asks that the assimilated model still pours every demonstrated amount within 30 g. The rig
is chaotic near many tilts: nudging a demonstration's held tilt by 0.01 deg can change its pour by
two 25 g marbles (``pour_sensitivity_flare35.json``), and the LfD model's tilt differs from a
demonstration's by 1-5 deg, because E6's tilts are a fixed shuffle of 85-95 deg that the task
parameters (weight, poured amount) do not determine (the pour is flat above about 90 deg). This
script builds the most reproducible demonstration set we could design and measures how often models
trained on it reproduce it, beside the current set, in one run:

1. **A tilt the model can infer**: the expert's tilt rises evenly with the weight, 85 deg at 650 g to
   95 deg at 1200 g (:func:`rule_tilt_deg`), so the weight alone gives it.
2. **Only robust tilts**: for every whole-marble weight of 650-1200 g, the tilts within ``--window``
   deg of the rule (steps of ``--step``, nearest first) are tried, and the first whose pour holds
   within ``--tolerance`` g (one marble) under every perturbation is kept: the held tilt offset by each
   of ``--offsets`` deg, the motion shifted by each of ``--shifts`` rows, and ``--noise-draws`` draws
   of the adaptation's smooth noise (12 knots) of ``--noise-deg`` deg added to the motion.
3. **16 weights** among the robust ones, in order, as near as possible to the current weights
   (:func:`pick`).
4. **Reproduction**: for each of ``--seeds``, E6's LfD model (:func:`~acnmp_core.experiments.pour.train_pour_cnmp`)
   is trained on that set and on the current set (:func:`~acnmp_core.tasks.pour.demos.pour_demos`),
   and each demonstration is reproduced (conditioned on its weight and poured amount, executed once):
   how many pour within 30 g, and how far the model's held tilt is from the demonstration's.

Usage::

    python benchmarks/studies/e6_pour/pour_robust_angles.py [--seeds 0-4] [--window 1.0] [--step 0.25] [--jobs 2]
        [--out benchmarks/studies/e6_pour/results/pour_robust_angles.json]
"""
from __future__ import annotations

import argparse
import sys
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))

from acnmp_core.data.demos import DemoSet, Demonstration  # noqa: E402
from acnmp_core.experiments.pour import (  # noqa: E402
    TOLERANCE_G, PourSetup, make_setup, make_target, mean_errors_g, train_pour_cnmp,
)
from acnmp_core.adaptation.exploration import SmoothNoise  # noqa: E402
from acnmp_core.sim.pour import PourConfig  # noqa: E402
from acnmp_core.tasks.pour.task import PourTask  # noqa: E402
from acnmp_core.tasks.pour.demos import (  # noqa: E402
    N_STEPS, NOMINAL_WEIGHTS_G, TILT_STEPS, HOLD_STEPS, demo_weights_g, expert_pour_trajectory,
)
from benchmarks._results import provenance, save_result  # noqa: E402
from clients.experiments.common import add_run_arguments  # noqa: E402
from benchmarks.studies.e1_viapoint.e1_assimilation import seed_range  # noqa: E402
from benchmarks.studies.e6_pour.pour_sensitivity import shifted  # noqa: E402

#: The expert's range of tilts (deg), the paper's.
ANGLE_RANGE_DEG = (85.0, 95.0)
TIMES = np.linspace(0.0, 1.0, N_STEPS)


def rule_tilt_deg(weight_g: float) -> float:
    """The tilt rule (deg): 85 deg at 650 g rising evenly to 95 deg at 1200 g."""
    (a0, a1), (w0, w1) = ANGLE_RANGE_DEG, (NOMINAL_WEIGHTS_G[0], NOMINAL_WEIGHTS_G[-1])
    return float(a0 + (a1 - a0) * (float(weight_g) - w0) / (w1 - w0))


def candidates(nominal: float, step: float, window: float) -> list[float]:
    """Tilts (deg, rounded to 0.01) on the ``step`` grid about ``nominal``, at most ``window`` from it and
    within :data:`ANGLE_RANGE_DEG`, nearest first (the lower on a tie)."""
    k = np.floor(window / step + 1e-9)
    grid = np.round(nominal + step * np.arange(-k, k + 1), 2)
    grid = grid[(grid >= ANGLE_RANGE_DEG[0]) & (grid <= ANGLE_RANGE_DEG[1])]
    order = np.lexsort((grid, np.abs(grid - nominal)))
    return [float(a) for a in grid[order]]


def pour_g(task: PourTask, traj: np.ndarray, weight_g: float) -> float:
    """Poured grams of one roll-out of ``traj`` (240, 1) rad at ``weight_g``."""
    return float(task.evaluate(traj[None], TIMES, np.array([weight_g, 0.0])).states["poured_g"][0])


def check_tilt(task: PourTask, weight_g: float, angle: float, offsets, shifts, noise: np.ndarray,
               tolerance: float) -> dict:
    """Pour at ``angle`` and under each perturbation (held tilt + each of ``offsets`` deg, the motion
    shifted by each of ``shifts`` rows, the motion plus each row of ``noise`` (N, 240, 1) rad), stopping
    at the first one off by more than ``tolerance`` g. Returns {angle_deg, poured_g, perturbed
    {name: g}, robust (bool), rollouts}."""
    traj = expert_pour_trajectory(angle)
    base = pour_g(task, traj, weight_g)
    trials = [(f"{d:+g}deg", expert_pour_trajectory(angle + d)) for d in offsets]
    trials += [(f"{s:+d}rows", shifted(traj, s)) for s in shifts]
    trials += [(f"noise{i}", traj + n) for i, n in enumerate(noise)]
    perturbed: dict[str, float] = {}
    robust = True
    for name, t in trials:
        perturbed[name] = pour_g(task, t, weight_g)
        if abs(perturbed[name] - base) > tolerance:
            robust = False
            break
    return {"angle_deg": angle, "poured_g": base, "perturbed": perturbed, "robust": robust,
            "rollouts": 1 + len(perturbed)}


def smooth_noise(draws: int, std_deg: float, seed: int) -> np.ndarray:
    """(draws, 240, 1) rad of the adaptation's time-correlated noise (12 knots), ``std_deg`` deg per step."""
    return SmoothNoise(N_STEPS, 12).sample(draws, 1, np.random.default_rng(seed), std=np.deg2rad(std_deg))


def robust_tilt(args: tuple) -> dict:
    """The first robust tilt for one weight: ``args`` = (config, weight g, step, window, offsets, shifts,
    noise, tolerance); the tilts of :func:`candidates` about :func:`rule_tilt_deg` in turn.

    Returns {weight_g, rule_deg, chosen_deg (None if none is robust), poured_g, tried (every
    :func:`check_tilt` result in order)}.
    """
    config, weight, step, window, offsets, shifts, noise, tolerance = args
    rule = rule_tilt_deg(weight)
    tried: list[dict] = []
    with PourTask(config, max_worlds=1) as task:
        for angle in candidates(rule, step, window):
            tried.append(check_tilt(task, weight, angle, offsets, shifts, noise, tolerance))
            if tried[-1]["robust"]:
                break
    ok = bool(tried) and tried[-1]["robust"]
    return {"weight_g": weight, "rule_deg": rule, "chosen_deg": tried[-1]["angle_deg"] if ok else None,
            "poured_g": tried[-1]["poured_g"] if ok else None, "tried": tried}


def pick(robust_weights, nominal) -> list[float]:
    """One of ``robust_weights`` (sorted, g) per ``nominal`` weight (sorted, g), in order and none twice,
    with the largest distance between a nominal weight and its pick as small as possible (then the
    smallest total distance). Raises ValueError when there are fewer robust weights than nominal ones."""
    r, n = list(robust_weights), list(nominal)
    if len(r) < len(n):
        raise ValueError(f"{len(r)} robust weights for {len(n)} demonstrations")
    inf = (float("inf"), float("inf"))
    # best[i][j]: (largest, total) distance of the best order-keeping matching of n[:i] into r[:j]
    best = [[(0.0, 0.0)] * (len(r) + 1)] + [[inf] * (len(r) + 1) for _ in n]
    for i in range(1, len(n) + 1):
        for j in range(i, len(r) + 1):
            d = abs(r[j - 1] - n[i - 1])
            best[i][j] = min(best[i][j - 1], (max(best[i - 1][j - 1][0], d), best[i - 1][j - 1][1] + d))
    out, j = [], len(r)
    for i in range(len(n), 0, -1):
        while best[i][j] == best[i][j - 1]:
            j -= 1
        out.append(r[j - 1])
        j -= 1
    return out[::-1]


def search(config: PourConfig, step: float, window: float, offsets, shifts, noise: np.ndarray, tolerance: float,
           jobs: int) -> list[dict]:
    """:func:`robust_tilt` for every whole-marble weight of 650-1200 g, in ``jobs`` processes."""
    lo, hi = config.n_marbles(NOMINAL_WEIGHTS_G[0]), config.n_marbles(NOMINAL_WEIGHTS_G[-1])
    work = [(config, config.weight_g(n), step, window, tuple(offsets), tuple(shifts), noise, tolerance)
            for n in range(lo, hi + 1)]
    if jobs == 1:
        return [robust_tilt(a) for a in work]
    import multiprocessing as mp

    with mp.get_context("spawn").Pool(jobs) as pool:
        return pool.map(robust_tilt, work, chunksize=1)


def build_demos(task: PourTask, weights, angles) -> DemoSet:
    """The expert's demonstrations at ``weights`` (g) and tilts ``angles`` (deg), each with what it pours."""
    demos = []
    for w, a in zip(weights, angles):
        traj = expert_pour_trajectory(a)
        demos.append(Demonstration(TIMES.copy(), traj, np.array([w, pour_g(task, traj, w)])))
    return DemoSet(demos)


def reproduction(task: PourTask, demos: DemoSet, seeds) -> list[dict]:
    """For each seed, E6's LfD model trained on ``demos``: {seed, errors_g (16,), within_30g, held_tilt_error_deg
    (16,): the model's mean tilt over the demonstration's hold rows minus the demonstration's}."""
    setup = PourSetup(demos, TIMES.copy(), demos[0].values[0].copy())
    tp = np.stack([d.task_params for d in demos])
    hold = slice(TILT_STEPS, TILT_STEPS + HOLD_STEPS)
    out = []
    for seed in seeds:
        model = train_pour_cnmp(demos, seed)
        errors = mean_errors_g(model, setup, task, tp)
        tilt = []
        for d in demos:
            q = make_target(setup, d.task_params)
            mean = model.predict(q.obs_times, q.obs_values, q.task_params, q.query_times).mean
            tilt.append(float(np.rad2deg(mean[hold, 0].mean() - d.values[hold, 0].mean())))
        out.append({"seed": int(seed), "errors_g": errors.tolist(), "within_30g": int(np.sum(errors <= TOLERANCE_G)),
                    "held_tilt_error_deg": np.round(tilt, 3).tolist()})
        print(f"  seed {seed}: {out[-1]['within_30g']} of {len(demos)} within 30 g; held tilt off by at most "
              f"{np.max(np.abs(tilt)):.2f} deg", flush=True)
    return out


def _summary(runs: list[dict]) -> dict:
    """Per-seed counts within 30 g, their median, and the median |held tilt error| (deg)."""
    counts = [r["within_30g"] for r in runs]
    return {"within_30g_per_seed": counts, "within_30g_median": float(np.median(counts)),
            "seeds_16_of_16": int(sum(c == 16 for c in counts)),
            "held_tilt_error_deg_median": float(np.median([abs(e) for r in runs for e in r["held_tilt_error_deg"]]))}


def main(argv=None) -> int:
    """Search, pick, reproduce both sets; print the summary and write one JSON. Returns 0, or 1 when fewer
    than 16 weights have a robust tilt (the JSON then has the search only)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=seed_range, default=list(range(5)), help="LfD seeds, e.g. 0-4")
    ap.add_argument("--step", type=float, default=0.25, help="grid of tilts tried about the rule (deg)")
    ap.add_argument("--window", type=float, default=1.0, help="farthest tilt tried from the rule (deg)")
    ap.add_argument("--offsets", type=float, nargs="+", default=[-0.5, -0.25, 0.25, 0.5],
                    help="held-tilt offsets a robust tilt must absorb (deg)")
    ap.add_argument("--shifts", type=int, nargs="+", default=[-2, -1, 1, 2],
                    help="time shifts a robust tilt must absorb (rows)")
    ap.add_argument("--noise-deg", type=float, default=0.25, help="std (deg) of the smooth noise draws")
    ap.add_argument("--noise-draws", type=int, default=6, help="smooth noise draws a robust tilt must absorb")
    ap.add_argument("--noise-seed", type=int, default=0, help="seed of the noise draws (the same for every tilt)")
    ap.add_argument("--tolerance", type=float, default=25.0, help="largest change of the pour allowed (g)")
    ap.add_argument("--jobs", type=int, default=2, help="processes for the search (one weight each)")
    add_run_arguments(ap, out="benchmarks/studies/e6_pour/results/pour_robust_angles.json")
    args = ap.parse_args(argv)
    if not args.step > 0 or not args.window >= 0:
        ap.error("--step: expected a number > 0; --window: a number >= 0")
    if args.noise_draws < 0 or not args.noise_deg >= 0:
        ap.error("--noise-draws and --noise-deg: expected numbers >= 0")
    if args.jobs < 1:
        ap.error("--jobs: expected an integer >= 1")
    meta = provenance()
    t0 = time.perf_counter()
    config = PourConfig()
    noise = smooth_noise(args.noise_draws, args.noise_deg, args.noise_seed)
    rows = search(config, args.step, args.window, args.offsets, args.shifts, noise, args.tolerance, args.jobs)
    robust = [r["weight_g"] for r in rows if r["chosen_deg"] is not None]
    result = {"provenance": meta, "benchmark": "pour_robust_angles", "rig": asdict(config),
              "search": {"rule": "85 deg at 650 g to 95 deg at 1200 g, linear", "step_deg": args.step,
                         "window_deg": args.window, "offsets_deg": args.offsets, "shifts_rows": args.shifts,
                         "noise_deg": args.noise_deg, "noise_draws": args.noise_draws, "noise_seed": args.noise_seed,
                         "tolerance_g": args.tolerance, "weights": rows, "robust_weights_g": robust,
                         "rollouts": int(sum(t["rollouts"] for r in rows for t in r["tried"]))},
              "seeds": args.seeds, "tolerance_g": TOLERANCE_G}
    print(f"robust tilts at {len(robust)} of {len(rows)} weights: {robust}", flush=True)
    try:
        weights = pick(robust, [float(w) for w in demo_weights_g(config)])
    except ValueError as e:
        result["wall_time_s"] = round(time.perf_counter() - t0, 1)
        save_result(result, args.out)
        print(f"pour_robust_angles: {e}", file=sys.stderr)
        return 1
    tilt = {r["weight_g"]: r["chosen_deg"] for r in rows}
    angles = [tilt[w] for w in weights]
    with PourTask(config, max_worlds=1) as task:
        robust_set = build_demos(task, weights, angles)
        print("robust set:", [(w, a, float(d.task_params[1])) for w, a, d in zip(weights, angles, robust_set)],
              flush=True)
        runs_robust = reproduction(task, robust_set, args.seeds)
        current = make_setup().demos
        print("current set:", flush=True)
        runs_current = reproduction(task, current, args.seeds)
    result["sets"] = {
        "robust": {"weights_g": weights, "angles_deg": angles,
                   "poured_g": [float(d.task_params[1]) for d in robust_set], "runs": runs_robust,
                   **_summary(runs_robust)},
        "current": {"weights_g": [float(d.task_params[0]) for d in current],
                    "angles_deg": [float(np.rad2deg(d.values[:, 0].max())) for d in current],
                    "poured_g": [float(d.task_params[1]) for d in current], "runs": runs_current,
                    **_summary(runs_current)}}
    result["summary"] = {k: {m: v[m] for m in ("within_30g_per_seed", "within_30g_median", "seeds_16_of_16",
                                                 "held_tilt_error_deg_median")} for k, v in result["sets"].items()}
    result["wall_time_s"] = round(time.perf_counter() - t0, 1)
    return save_result(result, args.out, None, ("summary", "wall_time_s"))


if __name__ == "__main__":
    sys.exit(main())
