"""The renderers of benchmarks/report.py: one function per docs block, each reading its JSON."""
from __future__ import annotations

import numpy as np

from benchmarks.report_kit import RESULTS, fmt, frac, load, pct, renderer, source, table

E1_LABELS = {"lfd_only": "LfD-only", "rl_only": "RL-only", "acnmp": "ACNMP"}
TWO_LABELS = {"acnmp": "ACNMP", "promp_rl": "ProMP + RL (REPS)"}


# --------------------------------------------------------------------------------------------------
# E1
# --------------------------------------------------------------------------------------------------
@renderer("e1-results")
def e1_results() -> str:
    r = load("e1_viapoint")
    n = r["config"]["seeds"]
    rows = []
    for m, label in E1_LABELS.items():
        s = r["methods"][m]
        rows.append([label, frac(s["success_rate"], n), fmt(s["rollouts_median"]), frac(s["within_35_rate"], n),
                     fmt(s["viapoint_error_median"]), fmt(s["shape_error_median"]), fmt(s["endpoint_error_max"])])
    a = r["assimilation"]
    ratio = r["shape_error_ratio_rl_only_over_acnmp"]
    lines = [
        table(["method", "success", "roll-outs (median)", "≤ 35 roll-outs", "via-point error (median, m)",
               "shape error (median, m)", "start/end error (max, m)"], rows),
        "",
        f"* Roll-outs per seed, ACNMP: {', '.join(map(str, r['methods']['acnmp']['rollouts']))}; "
        f"RL-only: {', '.join(map(str, r['methods']['rl_only']['rollouts']))}.",
        "* Shape error RL-only / ACNMP (ratio of the medians): "
        + ("- (a method failed in some seed)" if ratio is None else f"{ratio:.2f}") + ".",
        f"* Assimilation ({a['performed']}/{n} seeds with a solution): conditioned again on the same points "
        f"with no RL, the assimilated model succeeds in {a['success_after']}/{a['performed']}; the old "
        f"demonstrations' reproduction RMSE is at most {fmt(a['old_demos_rmse_ratio_max'])}x the LfD model's "
        f"(median {fmt(a['old_demos_rmse_ratio_median'])}x); the solution is reproduced within "
        f"{fmt(a['solution_reproduction_rmse_max'])} m RMSE.",
        f"* Time per seed (three methods, training and assimilation): median {r['wall_time_per_seed_s_median']:.1f} s.",
        "",
        source(r, "e1_viapoint"),
    ]
    return "\n".join(lines)


@renderer("e1-assimilation")
def e1_assimilation() -> str:
    """E1's assimilation candidates side by side, on the benchmark's seeds (0-9) and on fresh ones:
    seeds within tolerance after assimilation, the old demonstrations' worst reproduction ratio."""
    r = load("e1_assimilation")
    labels = {"steps_1000": "1000 steps (the library's default)", "steps_3000": "3000 steps (E1's setting)",
              "anchor_5": "1000 steps, anchor weight 5"}
    groups = {"seeds 0-9 (the benchmark's)": [x for x in r["runs"] if x["seed"] < 10],
              "seeds 10-19 (fresh)": [x for x in r["runs"] if x["seed"] >= 10]}
    rows = []
    for name, label in labels.items():
        row = [label]
        for runs in groups.values():
            got = [x["candidates"][name] for x in runs if name in x["candidates"]]
            row += [f"{sum(g['success_after'] for g in got)}/{len(got)}",
                    fmt(max(g["old_demos_rmse_ratio"] for g in got)) if got else "-"]
        rows.append(row)
    head = ["assimilation"]
    for g in groups:
        head += [f"{g}: within tolerance, no RL", f"{g}: old demos' RMSE / LfD's (max)"]
    lines = [
        table(head, rows),
        "",
        "* Each seed adapted once (ACNMP, budget 100), then assimilated from the same adapted network by "
        "each candidate (lr 1e-4, 32 episodes of 10 targets per step, the anchor); seeds whose adaptation "
        "failed are left out of the count.",
        "",
        source(r, "e1_assimilation"),
    ]
    return "\n".join(lines)


def e1_row() -> list[str]:
    r = load("e1_viapoint")
    n = r["config"]["seeds"]
    a, lfd = r["methods"]["acnmp"], r["methods"]["lfd_only"]
    ratio = r["shape_error_ratio_rl_only_over_acnmp"]
    return [f"E1 via-point ({n} seeds)", "ACNMP ≤ 35 roll-outs, LfD misses",
            f"ACNMP {frac(a['success_rate'], n)} succeed, median {fmt(a['rollouts_median'])} roll-outs "
            f"({frac(a['within_35_rate'], n)} within 35); LfD-only {frac(lfd['success_rate'], n)}; shape error "
            f"RL-only / ACNMP {'-' if ratio is None else f'{ratio:.1f}x'}"]


# --------------------------------------------------------------------------------------------------
# E2
# --------------------------------------------------------------------------------------------------
@renderer("e2-results")
def e2_results() -> str:
    r = load("e2_push")
    n = r["seeds"]
    rows = []
    for m, label in TWO_LABELS.items():
        for c in ("interpolation", "extrapolation"):
            s = r["methods"][m][c]
            rows.append([label, c, fmt(s["rollouts_median"]), f"{min(s['rollouts'])}-{max(s['rollouts'])}",
                         frac(s["success_rate"], n), fmt(s["final_error_median"]), fmt(s["lfd_error_median"])])
    ratio = r["rollout_ratio_promp_over_acnmp"]
    lines = [
        table(["method", "case", "roll-outs (median)", "range", "success", "final error (median, m)",
               "initial error (median, m)"], rows),
        "",
        "* ProMP + RL / ACNMP roll-outs (ratio of the medians, only where both succeed in every seed): "
        + "; ".join(f"{c} {'-' if v is None else f'{v:.2f}x'}" for c, v in ratio.items()) + ".",
        f"* ACNMP extrapolation roll-outs per seed: {', '.join(map(str, r['methods']['acnmp']['extrapolation']['rollouts']))}.",
        "",
        source(r, "e2_push"),
    ]
    return "\n".join(lines)


def e2_row() -> list[str]:
    r = load("e2_push")
    n = r["seeds"]
    a, p = r["methods"]["acnmp"], r["methods"]["promp_rl"]
    ratio = r["rollout_ratio_promp_over_acnmp"].get("extrapolation")
    return [f"E2 push ({n} seeds)", "ACNMP ~130 roll-outs, ProMP+RL ~9x more",
            f"interpolation {frac(a['interpolation']['lfd_success_rate'], n)} with no adaptation; extrapolation "
            f"ACNMP median {fmt(a['extrapolation']['rollouts_median'])} ({frac(a['extrapolation']['success_rate'], n)}), "
            f"ProMP+RL {fmt(p['extrapolation']['rollouts_median'])} ({frac(p['extrapolation']['success_rate'], n)})"
            + ("" if ratio is None else f": {ratio:.1f}x")]


@renderer("e2-machines")
def e2_machines() -> str:
    """E2's ten seeds on two machines (e2_push.json and e2_push_second_machine.json): the same code
    and seeds, per-seed counts that differ, the medians and the ratio side by side."""
    rows = []
    files = ("e2_push", "e2_push_second_machine")
    for name in files:
        r = load(name)
        m, mach = r["methods"], r["provenance"]["machine"]
        a, p = m["acnmp"]["extrapolation"], m["promp_rl"]["extrapolation"]
        rows.append([f"{mach['cpu']}, {mach.get('torch_cpu_capability', '?')} (`{name}.json`)",
                     f"{fmt(a['rollouts_median'])} ({', '.join(map(str, a['rollouts']))})",
                     f"{fmt(p['rollouts_median'])} ({', '.join(map(str, p['rollouts']))})",
                     f"{frac(a['success_rate'], r['seeds'])} / {frac(p['success_rate'], r['seeds'])}",
                     f"{r['rollout_ratio_promp_over_acnmp']['extrapolation']:.2f}x"])
    return "\n".join([table(["machine", "ACNMP roll-outs, median (per seed 0-9)", "ProMP + RL roll-outs, median (per seed)",
                              "success ACNMP / ProMP + RL", "ProMP + RL / ACNMP"], rows),
                      "", *[source(load(n), n) + "\n" for n in files]]).rstrip()


BASELINE_LABELS = {"acnmp": "ACNMP", "promp_scratch": "ProMP + REPS, from scratch",
                   "promp_similar": "ProMP + REPS, most similar effect",
                   "promp_mixture": "ProMP + REPS, similarity-weighted mixture",
                   "promp_tuned": "ProMP + REPS, tuned (nearest task, CMA-style covariance)"}


def _median_ratio(s: dict, a: dict) -> str:
    """Method / ACNMP extrapolation roll-outs (ratio of medians), '-' unless both succeed in more
    than half of the seeds."""
    if s["success_rate"] <= 0.5 or a["success_rate"] <= 0.5:
        return "-"
    return f"{s['rollouts_median'] / a['rollouts_median']:.2f}x"


@renderer("e2-baselines")
def e2_baselines() -> str:
    r = load("e2_baselines")
    rows = [["Akbulut et al. 2020 (paper)", "ACNMP", "no adaptation", "-", "~130", "-", "-", "1x"],
            ["Akbulut et al. 2020 (paper)", "adaptive ProMP (Stark et al. 2019, quoted)", "-", "-", "~1200",
             "-", "-", "~9x"]]
    for name, res in r["settings"].items():
        n = res["seeds"]
        a = res["methods"]["acnmp"]["extrapolation"]
        for m, label in BASELINE_LABELS.items():
            i, e = res["methods"][m]["interpolation"], res["methods"][m]["extrapolation"]
            rows.append([f"ours, {name} setting ({n} seeds)", label, fmt(i["rollouts_median"]),
                         frac(i["success_rate"], n), fmt(e["rollouts_median"]), frac(e["success_rate"], n),
                         fmt(e["final_error_median"]), _median_ratio(e, a)])
    notes = []
    for name, res in r["settings"].items():
        ms = {m: res["methods"][m]["extrapolation"] for m in BASELINE_LABELS}
        scratch = ms["promp_scratch"]["rollouts_median"]
        vs = ", ".join(f"{BASELINE_LABELS[m].split(', ')[1]} {ms[m]['rollouts_median'] / scratch:.2f}x"
                       for m in ("promp_similar", "promp_mixture"))
        per_seed = ", ".join(map(str, ms["acnmp"]["rollouts"]))
        notes.append(f"* {name} setting, extrapolation, transfer / from scratch (ratio of the median roll-outs; "
                     f"Stark et al. report under 0.4x the iterations): {vs}. ACNMP per seed: {per_seed}.")
    lines = [
        table(["run", "method", "interpolation roll-outs (median)", "success", "extrapolation roll-outs (median)",
               "success", "final error (median, m)", "extrapolation / ACNMP"], rows),
        "",
        f"* Budget {r['budget']} roll-outs per target for every method; every executed trajectory counts; "
        "a failed run counts its whole budget in the median; ratios only where both succeed in more than "
        "half of the seeds.",
        *notes,
        "",
        source(r, "e2_baselines"),
    ]
    return "\n".join(lines)


# --------------------------------------------------------------------------------------------------
# E3
# --------------------------------------------------------------------------------------------------
def _e3_row(label: str, s: dict, time_s: float) -> list:
    """One E3 table row from a method's summary (run_wall's ``methods[m]``): success and error from
    the first to the last test evaluation, goal error, trajectories, adaptations, time."""
    return [label, f"{pct(s['test_success_rate_initial'], 1)} → {pct(s['test_success_rate'], 1)}",
            f"{fmt(s['test_error_mean_initial'])} → {fmt(s['test_error_mean'])}",
            fmt(s["test_goal_error_mean"]), s["trajectories_total"], s["trajectories_per_env_max"],
            f"{s['adaptations']} ({s['adaptations_failed']} failed)", f"{time_s:.0f}"]


def _e3_results_block(name: str) -> str:
    r = load(name)
    rows = []
    for m, label in TWO_LABELS.items():
        s = r["methods"][m]
        rows.append(_e3_row(label, s, s["time_s"]))
    ratio = r["trajectory_ratio_promp_over_acnmp"]
    lines = [
        table(["method", "test success", "mean test error", "mean goal error", "trajectories", "max per env",
               "adaptations", "time (s)"], rows),
        "",
        f"* Seed {r['seed']}: {r['envs']} new environments after {r['n_initial']} demonstrated ones; {r['n_test']} test "
        f"environments; {_e3_paths(r)}.",
        "* ProMP + RL / ACNMP trajectories in total: " + ("-" if ratio is None else f"{ratio:.2f}x") + ".",
        "",
        source(r, name),
    ]
    return "\n".join(lines)


def _e3_paths(r: dict) -> str:
    """How a run executed its generated paths, from its config."""
    c = r["config"]
    if c.get("snap_rollouts"):
        return "every executed path moved onto its start and goal"
    return ("boundary conditions enforced (generated paths moved onto their start and goal, the default)"
            if c.get("snap_outputs") else "paths as generated (the paper's variant)")


@renderer("e3-results")
def e3_results() -> str:
    """Seed 0 at the default, boundary conditions enforced (e3_wall.json)."""
    return _e3_results_block("e3_wall")


@renderer("e3-results-paper-paths")
def e3_results_paper_paths() -> str:
    """Seed 0 with paths as generated, the paper's variant (e3_wall_paper_paths.json)."""
    return _e3_results_block("e3_wall_paper_paths")


def e3_seed_runs(wall: str = "e3_wall", seeds: str = "e3_seeds") -> tuple[dict, dict, dict]:
    """(seed 0's JSON ``wall``, seeds 1-9's ``seeds``, {seed: {method: summary}}) for ten seeds: by
    default those at the default settings."""
    full, more = load(wall), load(seeds)
    if full["envs"] != more["envs"]:
        raise ValueError(f"{wall}.json and {seeds}.json differ in envs")
    snapped = full["config"].get("snap_outputs", False)  # runs from before the option had none
    runs = {str(full["seed"]): full["methods"]}
    for seed, variants in more["seeds"].items():
        if seed in runs:
            raise ValueError(f"{seeds}.json repeats seed {seed} of {wall}.json")
        w = variants["baseline"]
        if w["config"].get("snap_outputs", False) != snapped:
            raise ValueError(f"{seeds}.json seed {seed} and {wall}.json differ in how they execute paths")
        runs[seed] = {"acnmp": w["summary"], **{m: o["summary"] for m, o in w.get("others", {}).items()}}
    return full, more, runs


def _e3_per_env(wall: str, seeds: str) -> str:
    """The largest number of trajectories one environment took, seed 0 and over the ten seeds, and
    the adaptations that ran to their budget (from the same JSON as the ten-seed table)."""
    full, _, runs = e3_seed_runs(wall, seeds)
    a0 = full["methods"]["acnmp"]
    top = max(runs[s]["acnmp"]["trajectories_per_env_max"] for s in runs)
    failed = {s: runs[s]["acnmp"]["adaptations_failed"] for s in sorted(runs, key=int)
              if runs[s]["acnmp"]["adaptations_failed"]}
    budget = (full.get("config", {}).get("acnmp", {}) or {}).get("max_rollouts")
    ran_out = (f"{sum(failed.values())} adaptation(s) ran to the budget and failed "
               f"(seed{'s' if len(failed) > 1 else ''} {', '.join(failed)})" if failed else "no adaptation ran to its budget")
    return (f"* Both stay below the paper's 1.4K trajectories for any one environment: ACNMP at most "
            f"{a0['trajectories_per_env_max']} in seed 0 and {top} over the {len(runs)} seeds; {ran_out}"
            + (f" (budget {budget} roll-outs)" if budget else "") + ".")


@renderer("e3-per-env")
def e3_per_env() -> str:
    return _e3_per_env("e3_wall", "e3_seeds")


@renderer("e3-per-env-paper-paths")
def e3_per_env_paper_paths() -> str:
    return _e3_per_env("e3_wall_paper_paths", "e3_seeds_paper_paths")


@renderer("e3-seeds")
def e3_seeds() -> str:
    """Both methods at the defaults over ten seeds: seed 0 from e3_wall.json (the Results table), seeds
    1-9 from e3_seeds.json (``e3_budget.py --candidates baseline --methods acnmp promp_rl``, one file
    per seed, combined). One row per seed, then the mean over the seeds."""
    return _e3_seeds("e3_wall", "e3_seeds")


@renderer("e3-seeds-paper-paths")
def e3_seeds_paper_paths() -> str:
    """The same with paths as generated (the paper's variant; the default before issue 37)."""
    return _e3_seeds("e3_wall_paper_paths", "e3_seeds_paper_paths")


def _e3_seeds(wall: str, seeds_file: str) -> str:
    full, more, runs = e3_seed_runs(wall, seeds_file)
    seeds = sorted(runs, key=int)
    rows = []
    for seed in seeds:
        a, p = runs[seed]["acnmp"], runs[seed]["promp_rl"]
        rows.append([seed, pct(a["test_success_rate"], 1), pct(p["test_success_rate"], 1),
                     fmt(a["test_error_mean"]), fmt(p["test_error_mean"]), a["trajectories_total"],
                     p["trajectories_total"], a["trajectories_per_env_max"],
                     f"{a['adaptations']} ({a['adaptations_failed']} failed)"])

    def mean(m: str, key: str) -> float:
        return float(np.mean([runs[s][m][key] for s in seeds]))

    rows.append([f"mean of {len(seeds)}", pct(mean("acnmp", "test_success_rate"), 1),
                 pct(mean("promp_rl", "test_success_rate"), 1), fmt(mean("acnmp", "test_error_mean")),
                 fmt(mean("promp_rl", "test_error_mean")), f"{mean('acnmp', 'trajectories_total'):.0f}",
                 f"{mean('promp_rl', 'trajectories_total'):.0f}",
                 max(runs[s]["acnmp"]["trajectories_per_env_max"] for s in seeds),
                 f"{mean('acnmp', 'adaptations'):.0f}"])
    at_target = sum(runs[s]["acnmp"]["test_success_rate"] >= 0.95 for s in seeds)
    error_ratio = mean("acnmp", "test_error_mean") / mean("promp_rl", "test_error_mean")
    traj_ratio = mean("promp_rl", "trajectories_total") / mean("acnmp", "trajectories_total")
    return "\n".join([
        table(["seed", "ACNMP test success", "ProMP + RL test success", "ACNMP mean test error",
               "ProMP + RL mean test error", "ACNMP trajectories", "ProMP + RL trajectories",
               "ACNMP max per env", "ACNMP adaptations"], rows),
        "",
        f"* {full['envs']} new environments after {full['n_initial']} demonstrated ones, {full['n_test']} test "
        f"environments, {_e3_paths(full)}; both methods in one run per seed, one torch thread.",
        f"* ACNMP at 95 % test success or more: {at_target} of {len(seeds)} seeds; its mean test error is "
        f"{error_ratio:.2f}x ProMP + RL's (means over the seeds); ProMP + RL executes {traj_ratio:.2f}x as many "
        "trajectories.",
        "",
        source(full, wall),
        "",
        source(more, seeds_file),
    ])


@renderer("e3-targets")
def e3_targets() -> str:
    """E3's decided targets at the default over the ten seeds (e3_wall.json + e3_seeds.json, the
    times alone from e3_time_alone.json), each with the measured value and whether it is met."""
    from clients.experiments.targets import E3_PER_ENV_MAX, E3_SUCCESS, E3_TIME_S, e3_median_time

    full, _, runs = e3_seed_runs()
    seeds = sorted(runs, key=int)

    def mean(m: str, key: str) -> float:
        return float(np.mean([runs[s][m][key] for s in seeds]))

    shared = [runs[s]["acnmp"]["time_s"] for s in seeds]
    alone = load("e3_time_alone")
    times = [alone["seeds"][s]["acnmp_time_s"] for s in seeds]  # KeyError: a seed not timed alone
    top = max(runs[s]["acnmp"]["trajectories_per_env_max"] for s in seeds)
    a_err, p_err = mean("acnmp", "test_error_mean"), mean("promp_rl", "test_error_mean")
    rows = [[f"mean test success ({len(seeds)} seeds)", f"≥ {100 * E3_SUCCESS:g} %",
             pct(mean("acnmp", "test_success_rate"), 1), mean("acnmp", "test_success_rate") >= E3_SUCCESS],
            ["mean test error", "≤ ProMP + RL's", f"{fmt(a_err)} against {fmt(p_err)}", a_err <= p_err],
            [f"ACNMP's time per seed, median of the {len(seeds)} (each alone)", f"≤ {E3_TIME_S} s",
             f"alone: median {np.median(times):.0f} s, at most {max(times):.0f} s; in the ten-seed table: median "
             f"{np.median(shared):.0f} s, at most {max(shared):.0f} s", e3_median_time(times)[1]],
            ["trajectories for any one environment", f"≤ {E3_PER_ENV_MAX}", f"at most {top}", top <= E3_PER_ENV_MAX]]
    return "\n".join([table(["decided target", "asked", "measured", "met"],
                             [[*r[:3], "yes" if r[3] else "**no**"] for r in rows]),
                      "",
                      f"*Seed 0 from `benchmarks/results/e3_wall.json`, seeds 1-9 from `e3_seeds.json` "
                      f"({len(seeds)} seeds, {full['envs']} environments each, {_e3_paths(full)}), seeds 1-9 "
                      "run two at a time; the times alone from `e3_time_alone.json` (each seed alone on the "
                      "machine, at the defaults).*"])


@renderer("e3-time-alone")
def e3_time_alone() -> str:
    """ACNMP's time per seed alone on the machine beside two at a time (e3_time_alone.json)."""
    r = load("e3_time_alone")
    rows = [[seed, f"{s['acnmp_time_s']:.0f}", f"{s['acnmp_time_s_ten_seed_table']:.0f}",
             f"{s['adaptations']} ({s['adaptations_failed']} failed)", pct(s["test_success_rate"], 1),
             "yes" if s["same_results_as_ten_seed_table"] else "**no**"] for seed, s in r["seeds"].items()]
    return "\n".join([
        table(["seed", "ACNMP time alone (s)", "in the ten-seed table (s)", "adaptations",
               "test success", "same results as the ten-seed table"], rows),
        "",
        f"* Alone: median {r['acnmp_time_s_median']:.0f} s, at most {r['acnmp_time_s_max']:.0f} s; "
        f"{r['seeds_within_120_s']} of {len(rows)} seeds within 120 s. In the ten-seed table seed 0 ran "
        "alone too, seeds 1-9 two at a time.",
        "",
        source(r, "e3_time_alone"),
    ])


@renderer("e3-paper-paths-summary")
def e3_paper_paths_summary() -> str:
    """One paragraph: the ten seeds with paths as generated (the paper's variant) beside the default."""
    _, _, runs = e3_seed_runs("e3_wall_paper_paths", "e3_seeds_paper_paths")
    seeds = sorted(runs, key=int)

    def mean(m: str, key: str) -> float:
        return float(np.mean([runs[s][m][key] for s in seeds]))

    top = max(runs[s]["acnmp"]["trajectories_per_env_max"] for s in seeds)
    return (f"With paths as generated (the paper's variant, `--snap-paths none`), over the same {len(seeds)} seeds: "
            f"ACNMP's mean test success {pct(mean('acnmp', 'test_success_rate'), 1)} against ProMP + RL's "
            f"{pct(mean('promp_rl', 'test_success_rate'), 1)}, its mean test error {fmt(mean('acnmp', 'test_error_mean'))} "
            f"against {fmt(mean('promp_rl', 'test_error_mean'))} (the CNMP's goal error), at most {top} trajectories for "
            f"one environment, ACNMP {mean('acnmp', 'time_s'):.0f} s per seed "
            "(`e3_wall_paper_paths.json`, `e3_seeds_paper_paths.json`).")


SNAP_LABELS = {"snap_outputs": "generated paths snapped", "snap_outputs_rollouts": "all executed paths snapped"}


@renderer("e3-snap-outputs")
def e3_snap_outputs() -> str:
    """Both methods with their paths snapped onto start and goal (e3_snap_outputs.json: generated
    paths only, or every executed path) beside the full run as generated (e3_wall.json)."""
    full, snap = load("e3_wall_paper_paths"), load("e3_snap_outputs")
    if (full["envs"], full["seed"]) != (snap["envs"], snap["seed"]):
        raise ValueError("e3_wall_paper_paths.json and e3_snap_outputs.json differ in envs or seed")
    rows = []
    for m, label in TWO_LABELS.items():
        rows.append(_e3_row(f"{label}, as generated", full["methods"][m], full["methods"][m]["time_s"]))
        for name, w in snap["variants"].items():
            runs = {"acnmp": w["summary"], **{k: o["summary"] for k, o in w.get("others", {}).items()}}
            if m in runs:
                rows.append(_e3_row(f"{label}, {SNAP_LABELS.get(name, name)}", runs[m], runs[m]["time_s"]))
    return "\n".join([
        table(["method", "test success", "mean test error", "mean goal error", "trajectories", "max per env",
               "adaptations", "time (s)"], rows),
        "",
        f"* Seed {snap['seed']}, {snap['envs']} new environments after 30 demonstrated ones, 1000 test environments. "
        "\"Generated paths snapped\": the path generated for a new or a test environment is moved onto its start "
        "and goal before it is executed or scored, the adaptations' roll-outs are not; \"all executed paths "
        "snapped\": the adaptations' roll-outs too. The two variants ran side by side (two processes).",
        "",
        source(full, "e3_wall_paper_paths"),
        "",
        source(snap, "e3_snap_outputs"),
    ])


E3_COMPARE_LABELS = {"acnmp": "ACNMP", "promp_rl": "ProMP + REPS (task-conditional)",
                     "ewerton": "ProMP + PRO + GP (after Ewerton et al. 2019)"}


@renderer("e3-compare")
def e3_compare() -> str:
    """The paper's E3 numbers beside ours in each setting, each method of one run per setting."""
    rows = [["Akbulut et al. 2020 (paper)", "ACNMP", "-", "-", "-", "-", "≤ 1.4K", "0.7M", "1x", "-"],
            ["Akbulut et al. 2020 (paper)", "Ewerton et al. 2019 (quoted)", "-", "-", "-", "-", "20K", "10M", "~14x",
             "-"]]
    files = ["e3_compare_paper", "e3_compare_authors"]
    files += [f for f in ("e3_compare_paper_snapped", "e3_compare_authors_snapped") if (RESULTS / f"{f}.json").exists()]
    runs = {f: load(f) for f in files}
    default_from = load("e3_wall_paper_paths")["config"]["assimilate_from"]
    notes = []
    for file, r in runs.items():
        snapped = r["config"].get("snap_rollouts", False)
        name = r["setting"] + (" setting, paths snapped" if snapped else " setting")
        c = r["comparison"]
        for m, label in E3_COMPARE_LABELS.items():
            s = c["methods"][m]
            ratio = "1x" if m == "acnmp" else f"{c['trajectory_ratios'][f'{m}_over_acnmp']:.2f}x"
            strict = pct(s["test_success_rate_strict"], 1) if "test_success_rate_strict" in s else "="
            first = pct(r["methods"][m]["test_success_rate_initial"], 1)
            rows.append([f"ours, {name} ({r['envs']} envs)", label, f"{first} → {pct(s['test_success_rate'], 1)}",
                         strict,
                         fmt(s["test_error_mean"]), s["trajectories_total"], s["trajectories_per_env_max"],
                         s["trajectories_paper_style"], ratio, f"{s['time_s']:.0f}"])
        notes.append(f"* {name}: {r['envs']} new environments after {r['n_initial']} demonstrated, "
                     f"{r['n_test']} test; adaptations (failed): "
                     + ", ".join(f"{E3_COMPARE_LABELS[m].split(' (')[0]} {c['methods'][m]['adaptations']} "
                                 f"({c['methods'][m]['adaptations_failed']})" for m in E3_COMPARE_LABELS)
                     + f"; paper-style total / ACNMP's: "
                     + ", ".join(f"{E3_COMPARE_LABELS[m].split(' (')[0]} "
                                 f"{c['methods'][m]['trajectories_paper_style'] / c['methods']['acnmp']['trajectories_paper_style']:.2f}x"
                                 for m in E3_COMPARE_LABELS if m != "acnmp")
                     + f"; ACNMP's assimilation continued from the {r['config']['assimilate_from']!r} network"
                     + ("" if r["config"]["assimilate_from"] == default_from
                        else f" (the published E3 run's, e3_wall.json: {default_from!r})")
                     + f"; {r['wall_time_s']:.0f} s in all.")
    lines = [
        table(["run", "method", "test success (first → last)", "test success, stopping criterion", "mean test error",
               "trajectories (measured total)", "max per env", "paper-style total (envs x max per env)",
               "measured total / ACNMP", "time (s)"], rows),
        "",
        "* Test success counts a test environment as solved when its generated trajectory would not trigger "
        "an adaptation; in the authors' setting the next column counts it by their stricter stopping "
        "criterion (\"=\": the same criterion in the paper setting).",
        "* The paper's totals are environments x the per-environment maximum (upper bounds, not counts); "
        "the paper-style column computes ours the same way, the measured column counts every trajectory executed.",
        *(["* \"Paths snapped\" (section 7 above, `e3_compare.py --snap-outputs`): every path of every method, "
           "generated or an adaptation's roll-out, is moved onto its start and goal before it is executed or "
           "scored; not the paper's method."] if len(runs) > 2 else []),
        *notes,
        *[line for f, r in runs.items() for line in ("", source(r, f))],
    ]
    return "\n".join(lines)


def e3_row() -> list[str]:
    r, _, runs = e3_seed_runs()
    a, p = r["methods"]["acnmp"], r["methods"]["promp_rl"]
    ratio = r["trajectory_ratio_promp_over_acnmp"]

    def mean(m: str, key: str) -> float:
        return float(np.mean([runs[s][m][key] for s in runs]))

    snapped = ", ends enforced" if r["config"].get("snap_outputs") else ""
    return [f"E3 wall ({r['envs']} envs{snapped})", "≤ 1.4K per env, ProMP+RL ~14x more",
            f"seed 0: ACNMP {pct(a['test_success_rate_initial'], 1)} → {pct(a['test_success_rate'], 1)} test success, "
            f"max {a['trajectories_per_env_max']} per env, {a['trajectories_total']} in all"
            + ("" if ratio is None else f" (ProMP+RL {ratio:.1f}x)")
            + f", {a['time_s']:.0f} s. {len(runs)} seeds: {pct(mean('acnmp', 'test_success_rate'), 1)} against "
              f"{pct(mean('promp_rl', 'test_success_rate'), 1)}, max "
              f"{max(runs[s]['acnmp']['trajectories_per_env_max'] for s in runs)} per env, test error "
              f"{mean('acnmp', 'test_error_mean') / mean('promp_rl', 'test_error_mean'):.2f}x ProMP+RL's"]


# --------------------------------------------------------------------------------------------------
# README
# --------------------------------------------------------------------------------------------------
def e4_row() -> list[str]:
    r = load("e4_transfer")
    t, scratch = r["conditions"]["transfer"], r["conditions"]["no_transfer"]
    paper = r["paper"]["success_by_iteration"]
    return [f"E4 transfer 3 → 4 DoF ({r['runs']} runs)", "success " + "/".join(pct(v) for v in paper.values())
            + f" after {'/'.join(paper)} it.",
            "success " + "/".join(pct(t["success_by_iteration"][k]) for k in paper) + "; from scratch "
            + "/".join(pct(scratch["success_by_iteration"][k]) for k in paper)]


def e5_row() -> list[str]:
    r = load("e5_ur10")
    n, cases = r["seeds"], r["cases"]
    wrist = r["joint_names"].index("wrist_1_joint")
    c = cases["9_11"]
    far = [k for k in cases if k not in ("8_10", "9_11")]
    head = "; ".join(f"{E5_CASE_LABELS.get(k, k)} cm: LfD-only {frac(cases[k]['lfd_only']['success_rate'], n)}, "
                     f"ACNMP {frac(cases[k]['acnmp']['success_rate'], n)}" for k in far)
    return [f"E5 UR10 ({n} seeds)", "(9, 11) cm: wrist 1 14.89 → 1.51°, LfD fails",
            (head + "; " if head else "") + f"(9, 11): {frac(c['lfd_only']['success_rate'], n)} → "
            f"{frac(c['acnmp']['success_rate'], n)}, wrist 1 {c['lfd_only']['joint_error_deg'][wrist]:.2f} → "
            f"{c['acnmp']['joint_error_deg'][wrist]:.2f}° (PyBullet)"]


def e6_row() -> list[str]:
    r = load("e6_pour")
    n, a = r["seeds"], r["acnmp"]
    return [f"E6 pouring ({n} seeds)", "LfD 600 g off → 27 g after 18 roll-outs",
            f"LfD-only {r['lfd_only']['error_g']:.0f} g off; ACNMP within 30 g in {frac(a['success_rate'], n)}, "
            f"median {fmt(a['rollouts_median'])} roll-outs ({frac(a['success_within_20_rate'], n)} within 20)"]


def _targets_block(name: str, target) -> str:
    """The decided targets of one experiment, checked on its published JSON by the same function
    ``acnmp reproduce`` uses (clients/experiments/targets.py): one bullet per check."""
    text, passed = target(load(name))
    scope, _, checks = text.partition(": ")
    bullets = [f"* {c.replace('[ok]', '**met**:').replace('[missed]', '**missed**:')}" for c in checks.split("; ")]
    verdict = {True: "all met", False: "not all met", None: "not checked"}[passed]
    return "\n".join([f"The decided targets, {scope} (`benchmarks/results/{name}.json`), {verdict}:", "", *bullets])


@renderer("e5-targets")
def e5_targets() -> str:
    from clients.experiments.targets import e5_target

    return _targets_block("e5_ur10", e5_target)


@renderer("e6-targets")
def e6_targets() -> str:
    from clients.experiments.targets import e6_target

    return _targets_block("e6_pour", e6_target)


E5_CASE_LABELS = {"8_10": "(8, 10)", "9_11": "(9, 11)", "10_12": "(10, 12)"}


@renderer("e5-results")
def e5_results() -> str:
    """E5 per case and method: per-joint errors (deg, medians over the seeds), success in physics,
    roll-outs, with the paper's two published entries at (9, 11) (e5_ur10.json)."""
    r = load("e5_ur10")
    n = r["seeds"]
    rows = []
    for case, methods in r["cases"].items():
        for m, label in (("lfd_only", "LfD only"), ("acnmp", "ACNMP")):
            s = methods[m]
            rows.append([E5_CASE_LABELS.get(case, case), label, *(f"{e:.2f}" for e in s["joint_error_deg"]),
                         frac(s["success_rate"], n), fmt(s["rollouts_median"])])
        if case == "9_11":
            rows += [["(9, 11)", "paper, LfD", "", "", "17.98", "14.89", "", "", "fails", ""],
                     ["(9, 11)", "paper, ACNMP", "", "", "1.78", "1.51", "", "", "succeeds", ""]]
    per_seed = {case: [x["acnmp"]["rollouts"] for x in r["runs"] if x["case"] == case] for case in r["cases"]}
    from clients.experiments.targets import E5_JOINT_DEG, e5_within_bound

    within = {case: e5_within_bound(r["runs"], case) for case in r["cases"]}
    return "\n".join([
        table(["case (cm)", "method", "shoulder pan", "shoulder lift", "elbow", "wrist 1", "wrist 2", "wrist 3",
               "success", "roll-outs"], rows),
        "",
        "* Per-joint error: mean |executed - expert executed| over the 625 rows (deg), median over the seeds; "
        "success in physics; roll-outs: median.",
        "* ACNMP roll-outs per seed: " + "; ".join(f"{E5_CASE_LABELS.get(c, c)} {', '.join(map(str, v))}"
                                                   for c, v in per_seed.items()) + ".",
        f"* ACNMP succeeding with every joint within {E5_JOINT_DEG:g} deg: " + "; ".join(
            f"{E5_CASE_LABELS.get(c, c)} {k}/{n}" for c, k in within.items()) + ".",
        "",
        source(r, "e5_ur10"),
    ])


E5_TRAINING_LABELS = {"steps_3000_constant": "3000 steps, constant rate (before)",
                      "steps_3000_cosine": "3000 steps, decay to 1e-5",
                      "steps_10000_cosine": "10000 steps, decay to 1e-5 (the default)",
                      "steps_20000_cosine": "20000 steps, decay to 1e-5"}


E5_EXPLORATION_LABELS = {"default": "default (as published)",
                         "demo_noise": "demonstration-shaped noise",
                         "jitter_0.1_demo_noise": "jitter 0.1, demonstration-shaped noise",
                         "jitter_0.3_demo_noise": "jitter 0.3, demonstration-shaped noise",
                         "jitter_0.3_rbf": "jitter 0.3, default noise",
                         "mixup": "mixup training, default noise"}


def _e5_variant_table(name: str, labels: dict[str, str], first: str) -> str:
    """E5 per variant and case from ``name``.json (benchmarks/studies/e5_ur10/e5_training.py or
    e5_exploration.py): LfD's and ACNMP's successes, ACNMP's within the joint bound, ACNMP's
    roll-outs per seed, and the variant's time when recorded; ``first`` heads the variant column."""
    r = load(name)
    n, bound = r["seeds"], r["joint_bound_deg"]
    timed = all("wall_time_s" in v for v in r["variants"].values())
    rows = []
    for variant, v in r["variants"].items():
        cells = [f"{c['lfd_success']}/{n}, {c['acnmp_success']}/{n}, {c['acnmp_within_deg']}/{n}"
                 for c in v["cases"].values()]
        rows.append([labels.get(variant, variant), *cells,
                     "; ".join(", ".join(map(str, c["acnmp_rollouts"])) for c in v["cases"].values()),
                     *([f"{v['wall_time_s']:.0f}"] if timed else [])])
    cases = list(next(iter(r["variants"].values()))["cases"])
    seeds = r.get("seed_list", list(range(n)))
    return "\n".join([
        f"Seeds {seeds[0]}-{seeds[-1]}:",
        "",
        table([first, *(f"{E5_CASE_LABELS.get(c, c)}: LfD, ACNMP, ACNMP within {bound:g} deg" for c in cases),
               "ACNMP roll-outs per seed, per case", *(["time (s)"] if timed else [])], rows),
        "",
        source(r, name),
    ])


def _e5_training_table(name: str) -> str:
    """The training variants of ``name``.json (benchmarks/studies/e5_ur10/e5_training.py)."""
    return _e5_variant_table(name, E5_TRAINING_LABELS, "LfD model")


@renderer("e5-exploration")
def e5_exploration() -> str:
    """Demonstration-shaped noise and task-parameter jitter on E5 (e5_exploration.json)."""
    return _e5_variant_table("e5_exploration", E5_EXPLORATION_LABELS, "variant")


@renderer("e5-exploration-mixup")
def e5_exploration_mixup() -> str:
    """Mixup training on E5 (e5_exploration_mixup.json, the same study run for that variant)."""
    return _e5_variant_table("e5_exploration_mixup", E5_EXPLORATION_LABELS, "variant")


@renderer("e5-training")
def e5_training() -> str:
    """The training variants on E5's reported seeds (e5_training.json)."""
    return _e5_training_table("e5_training")


@renderer("e5-training-fresh")
def e5_training_fresh() -> str:
    """The same on seeds that chose nothing (e5_training_fresh.json)."""
    return _e5_training_table("e5_training_fresh")


@renderer("e6-results")
def e6_results() -> str:
    """E6 against the paper's Table 2 (right): LfD's error, ACNMP's roll-outs to 30 g, the
    assimilation's checks, per seed and summed up (e6_pour.json)."""
    r = load("e6_pour")
    n, a = r["seeds"], r["acnmp"]
    runs = r["runs"]
    assim = [x for x in runs if x.get("assimilation")]
    within50 = sum(max(x["assimilation"]["demo_errors_g"]) <= 50 for x in assim)
    kept = sum(x["assimilation"]["demos_within_30g"] >= x["lfd_demos_within_30g"] for x in assim)

    def per(values) -> str:
        return ", ".join(fmt(x) for x in values)

    rows = [
        ["LfD-only error at (1400 g, 1322 g)", "591 g", f"{fmt(r['lfd_only']['error_g'])} g ({per(r['lfd_only']['errors_g'])})"],
        ["ACNMP: first roll-out within 30 g", "18", f"{frac(a['success_rate'], n)} seeds within the budget of "
         f"{r['config']['adapt']['max_rollouts']}, at roll-out {per(a['first_success_rollout'])}"],
        ["ACNMP within 20 roll-outs", "yes", frac(a["success_within_20_rate"], n)],
        ["error of the solution", "27 g", f"{fmt(a['final_error_g_median'])} g (median)"],
        ["after assimilation, the test without RL", "solved",
         f"{sum(x['assimilation']['error_g_no_rl'] <= 30 for x in assim)}/{len(assim)} within 30 g"],
        ["after assimilation, demonstrations within 30 g (of 16)", "–",
         f"{per(x['assimilation']['demos_within_30g'] for x in assim)}; LfD-only before adapting "
         f"{per(x['lfd_demos_within_30g'] for x in assim)}: no fewer in {kept}/{len(assim)} seeds"],
        ["after assimilation, all 16 within 50 g", "–", f"{within50}/{len(assim)} seeds"],
    ]
    return "\n".join([table(["", "paper (real rig)", f"here (PyBullet, {n} seeds)"], rows), "",
                      f"* CPU per roll-out {fmt(r['rollout_cpu_s_median'])} s (median); the assimilation trains "
                      f"{_assimilation_text({**r['config']['assimilation'], 'start': r['config'].get('assimilate_from', 'adapted')})}.",
                      "", source(r, "e6_pour")])


def _assimilation_text(cfg: dict) -> str:
    """'1000 steps at 0.0001 from the adapted model' from an E6 result's assimilation config."""
    start = {"skill": "the model before the adaptation", "adapted": "the adapted model"}[cfg.get("start", "adapted")]
    rate = fmt(cfg["lr"]) + ("" if cfg.get("lr_final") is None else f" decaying to {fmt(cfg['lr_final'])}")
    return f"{cfg['steps']} steps at {rate} from {start}"


@renderer("e6-machines")
def e6_machines() -> str:
    """E6's five seeds on the two machines that ran it, with each exploration and assimilation that
    was the default or tried (e6_pour.json, e6_pour_setting_s.json, e6_pour_setting_t.json,
    e6_pour_first_machine.json)."""
    rows = []
    for name in ("e6_pour", "e6_pour_setting_s", "e6_pour_setting_t", "e6_pour_first_machine"):
        r = load(name)
        n, a, mach = r["seeds"], r["acnmp"], r["provenance"]["machine"]
        noise = r["config"]["adapt"].get("noise", "rbf")
        assimilation = {**r["config"]["assimilation"], "start": r["config"].get("assimilate_from", "adapted")}
        rows.append([f"{mach['cpu']}, {mach.get('torch_cpu_capability', '?')} (`{name}.json`)",
                     "demonstration-shaped (T)" if noise == "demos" else "per step (S)",
                     _assimilation_text(assimilation),
                     ", ".join(fmt(e) for e in r["lfd_only"]["errors_g"]),
                     ", ".join("-" if f is None else str(f) for f in a["first_success_rollout"]),
                     frac(a["success_within_20_rate"], n), fmt(r["assimilation"]["demos_reproduced_within_30g"]),
                     fmt(r["assimilation"]["lfd_demos_reproduced_within_30g"]), _e6_all_within_50(r)])
    return table(["machine", "exploration noise", "assimilation", "LfD-only error per seed (g)",
                  "ACNMP's first roll-out within 30 g, per seed", "within 20 roll-outs",
                  "demos within 30 g after assimilation (median)", "LfD-only's (median)",
                  "all 16 within 50 g after assimilation"], rows)


def _e6_all_within_50(r: dict) -> str:
    """"k/n": of an E6 result's n assimilated seeds, k reproduce all 16 demonstrations within 50 g."""
    from clients.experiments.targets import e6_all_within_50

    return f"{e6_all_within_50(r['runs'])}/{sum(1 for x in r['runs'] if x.get('assimilation'))}"


@renderer("e6-settings-demos")
def e6_settings_demos() -> str:
    """Settings S and T (S with the demonstration-shaped noise) on the tuning seeds 100-115, on
    this machine (e6_settings_demos.json, benchmarks/studies/e6_pour/e6_settings.py)."""
    r = load("e6_settings_demos")
    n = len(r["seeds"])
    rows = [[name, f"{r['within_20'][name]}/{n}", fmt(r["first_success_median"][name]),
             ", ".join("-" if f is None else str(f) for f in r["first_success_rollout"][name])]
            for name in r["candidates"]]
    return "\n".join([
        f"Seeds {', '.join(map(str, r['seeds']))}, budget {r['budget']}:",
        "",
        table(["setting", "within 20 roll-outs", "first roll-out within 30 g (median)", "per seed"], rows),
        "",
        source(r, "e6_settings_demos"),
    ])


@renderer("e6-assimilation")
def e6_assimilation() -> str:
    """The assimilation candidates of benchmarks/studies/e6_pour/e6_assimilation.py, each on the same solution per
    seed: issue 37's reproduction checks and the test poured without RL (e6_assimilation.json)."""
    r = load("e6_assimilation")
    rows = []
    for name, s in r["summary"].items():
        c = r["candidates"][name]
        rows.append([name, _assimilation_text({**c["config"], "start": c["start"]}), f"{s['all_within_50g']}/{s['seeds']}",
                     f"{s['no_fewer_within_30g']}/{s['seeds']}", f"{s['test_within_30g_no_rl']}/{s['seeds']}",
                     fmt(s["demos_within_30g_median"])])
    solved = [x for x in r["runs"] if x["success"]]
    return "\n".join([
        table(["candidate", "assimilation", "all 16 within 50 g", "no fewer within 30 g than LfD-only",
               "test within 30 g without RL", "within 30 g (median of 16)"], rows),
        "",
        f"* Seeds {', '.join(str(x['seed']) for x in solved)} of {r['seeds']} found a solution (the others have "
        "nothing to assimilate); the LfD-only model reproduced "
        + ", ".join(str(x["lfd_demos_within_30g"]) for x in solved) + " of 16 within 30 g in them.",
        "",
        source(r, "e6_assimilation"),
    ])


#: The E6 assimilation study's runs: (setting, its exploration noise, seed set, result file).
E6_ASSIMILATION_RUNS = (("S", "per step (S)", "seeds 0-4", "e6_assimilation"),
                        ("S", "per step (S)", "seeds 100-115", "e6_assimilation_rbf_tuning"),
                        ("T", "demonstration-shaped (T)", "seeds 0-4", "e6_assimilation_demos"),
                        ("T", "demonstration-shaped (T)", "seeds 100-115", "e6_assimilation_demos_tuning"))


def e6_seed_checks(run: dict, candidate: str) -> dict[str, bool]:
    """Issue 37's E6 checks for one seed of the assimilation study and one candidate: within 30 g
    in <= 20 roll-outs, all 16 demonstrations within 50 g, no fewer within 30 g than the LfD
    model, the test within 30 g without RL (the last three False when no solution was found)."""
    c = run["candidates"].get(candidate)
    return {"within_20": bool(run["success"] and run["rollouts"] <= 20),
            "all_50": c is not None and c["demos_max_error_g"] <= 50,
            "no_fewer_30": c is not None and c["demos_within_30g"] >= run["lfd_demos_within_30g"],
            "test_no_rl": c is not None and c["error_g_no_rl"] <= 30}


@renderer("e6-assimilation-noise")
def e6_assimilation_noise() -> str:
    """Both explorations (S, T) with the two assimilations on the reported and the tuning seeds:
    per seed set, how many seeds meet each of issue 37's E6 checks and all of them
    (e6_assimilation*.json, benchmarks/studies/e6_pour/e6_assimilation.py)."""
    rows, sources, unsolved = [], [], []
    for setting, noise, seeds, name in E6_ASSIMILATION_RUNS:
        r = load(name)
        unsolved += [f"{setting} seed {run['seed']}" for run in r["runs"] if not run["success"]]
        for cand in ("adapted", "skill_4000"):
            c = r["candidates"][cand]
            checks = [e6_seed_checks(run, cand) for run in r["runs"]]
            n = len(checks)
            rows.append([noise, seeds, _assimilation_text({**c["config"], "start": c["start"]}),
                         *(f"{sum(x[k] for x in checks)}/{n}" for k in ("within_20", "all_50", "no_fewer_30", "test_no_rl")),
                         f"{sum(all(x.values()) for x in checks)}/{n}"])
        sources.append(source(r, name))
    return "\n".join([table(["exploration", "seeds", "assimilation", "within 30 g in <= 20 roll-outs", "all 16 within 50 g",
                             "no fewer within 30 g than LfD-only", "test within 30 g without RL", "all four"], rows),
                      "", "* Per seed; a seed whose adaptation found no solution within 60 roll-outs (here "
                      + (", ".join(unsolved) or "none") + ") has nothing to assimilate and fails the last three checks.",
                      "", *(x + "\n" for x in sources)]).rstrip()


@renderer("experiments-table")
def experiments_table() -> str:
    """docs/EXPERIMENTS.md's table, from the experiments' catalog (clients/experiments/catalog.py)."""
    from clients.experiments.catalog import CATALOG

    rows = []
    for e in CATALOG:
        if e.page is None:
            continue
        rows.append([e.ident or e.name, f"[{e.page}](experiments/{e.page}) ([studies](studies/{e.page}))"
                     if (RESULTS.parents[1] / "docs" / "studies" / e.page).exists() else f"[{e.page}](experiments/{e.page})",
                     f"`acnmp experiment {e.name}`", e.title or e.help, ", ".join(f"`{b.strip()}`" for b in
                                                                                 (e.benchmark or "").split(",") if b.strip())])
    return table(["id", "page", "command", "what", "benchmark"], rows)


@renderer("demo-format")
def demo_format() -> str:
    """docs/ROBOTS.md's table of the demonstration file's arrays (acnmp_core.data.demo_io.FIELDS)."""
    from acnmp_core.data.demo_io import format_table

    return format_table()


@renderer("readme-results")
def readme_results() -> str:
    rows = [e1_row(), e2_row(), e3_row(), e4_row(), e5_row(), e6_row()]
    from clients.experiments.targets import PREDICT_CEILING_SHARE, ceiling_share

    p, routed = load("bench_predict"), load("bench_predict_routed")["modes"]
    rows.append(["predict over zenoh", "–", f"p50 {p['latency']['predict_zenoh']['p50_ms']:.2f} ms "
                 f"({p['p50_ratio']:.2f}x in-process + empty query); 16 clients at "
                 f"{ceiling_share(routed['routed2']):.2f} of the CPU ceiling with 2 model processes "
                 f"(target ≥ {PREDICT_CEILING_SHARE:g}), {ceiling_share(routed['routed1']):.2f} with 1"])
    return table(["experiment", "paper", "measured here (JSON in `benchmarks/results/`)"], rows)



# --------------------------------------------------------------------------------------------------
# The adaptation sweep
# --------------------------------------------------------------------------------------------------
@renderer("adaptation-sweep")
def adaptation_sweep() -> str:
    files = sorted(p.stem for p in RESULTS.glob("adapt_sweep*.json"))
    runs = [load(f) for f in files]
    r = runs[0]
    n, envs = r["config"]["seeds"], r["config"]["e3_envs"]
    settings: dict[str, dict] = {}
    for run in runs:  # one table over every sweep file: each setting keeps the experiments of each
        for name, s in run["settings"].items():
            settings.setdefault(name, {}).update(s)
    rows = []
    for name, s in settings.items():
        e1, e2, e3 = s.get("e1"), s.get("e2"), s.get("e3")
        fields = ", ".join(f"`{k}={v}`" for k, v in s["fields"].items()) or "(none)"
        rows.append([
            f"**{name}**" if name == "default" else name, fields,
            "-" if e1 is None else f"{frac(e1['success_rate'], n)}, {fmt(e1['rollouts_median'])}, "
                                   f"{frac(e1['within_35_rate'], n)}, {fmt(e1['shape_error_median'])}",
            "-" if e2 is None else f"{frac(e2['success_rate'], n)}, {fmt(e2['rollouts_median'])}",
            "-" if e3 is None else f"{pct(e3['test_success_rate'], 1)}, {fmt(e3['test_error_mean'])}, "
                                   f"{e3['trajectories_total']}, {e3['trajectories_per_env_max']}, "
                                   f"{e3['adaptations_failed']}/{e3['adaptations']}",
        ])
    lines = [
        table(["setting", "changed from the default",
               f"E1 ({n} seeds): success, roll-outs (median), ≤ 35, shape error (median, m)",
               f"E2 extrapolation ({n} seeds): success, roll-outs (median)",
               f"E3 ({envs} new envs, 200 test): test success, mean test error, trajectories, max per env, "
               "failed/adaptations"], rows),
        "",
        "* The default: " + ", ".join(f"`{k}={v}`" for k, v in r["config"]["default"].items()) + ".",
        "* '-': not run (see the text below the table)."
        + ("" if all(run.get("complete", True) for run in runs) else " A sweep was stopped before all its runs "
                                                                     "finished; what it measured is kept."),
        "",
        *[source(run, f) for run, f in zip(runs, files)],
    ]
    return "\n".join(lines)


@renderer("e3-fit-precision")
def e3_fit_precision() -> str:
    r = load("e3_fit_precision")

    def budget(x: dict) -> str:
        extra = ([f"rate → {x['lr_final']:g}"] if x.get("lr_final") else []) + \
            (["targets include the observations"] if x.get("targets_include_obs") else [])
        return f"{x['steps']} x {x['batch_size']} x {x['n_targets']}" + (f" ({', '.join(extra)})" if extra else "")

    def fit(x: dict, key: str, f) -> str:
        return f(x["demonstrated"][key]) if "demonstrated" in x else "-"

    rows = [[x["demos"], budget(x), pct(x["test_success_rate"], 1), fmt(x["test_error_mean"]),
             fmt(x["test_goal_error_mean"]), pct(x["test_through_hole_rate"]),
             fit(x, "test_success_rate", lambda v: pct(v, 1)), fit(x, "test_goal_error_mean", fmt),
             f"{x['time_s']:.0f}"] for x in r["runs"]]
    return "\n".join([
        table(["expert demos", "steps x batch x targets per episode", "test success", "mean test error",
               "mean goal error", "through the hole", "demonstrated envs: success", "demonstrated envs: goal error",
               "training time (s)"], rows),
        "",
        f"* The first training of E3 only (seed {r['seed']}), no RL: one expert demonstration per random "
        "environment, scored on the 1000 test environments and, conditioned the same way, on the demonstrated "
        "environments themselves (how well the skill fits what it was trained on). Rate 1e-3, constant unless a "
        "decay (half cosine) is given.",
        "",
        source(r, "e3_fit_precision"),
    ])


@renderer("e3-assimilate-from")
def e3_assimilate_from() -> str:
    r = load("e3_assimilate_from")
    labels = {"skill": "the skill before the adaptation (the default)", "adapted": "the adapted copy"}
    rows = []
    for v, label in labels.items():
        s, w = r["variants"][v]["summary"], r["variants"][v]
        rows.append(_e3_row(label, s, w["wall_time_s"]))
    return "\n".join([
        table(["assimilation continues from", "test success", "mean test error", "mean goal error",
               "trajectories", "max per env", "adaptations", "time (s)"], rows),
        "",
        f"* ACNMP only, seed {r['seed']}, {r['envs']} new environments after 30 demonstrated ones, 1000 test "
        "environments; both variants side by side in one run (two processes), otherwise the defaults.",
        "",
        # The variants ran side by side: the run took as long as the slower one.
        source({**r, "wall_time_s": r.get("wall_time_s", max(w["wall_time_s"] for w in r["variants"].values()))},
               "e3_assimilate_from"),
    ])


@renderer("e3-assimilate-from-full")
def e3_assimilate_from_full() -> str:
    runs = {"skill": load("e3_wall_assimilate_skill"), "adapted": load("e3_wall_assimilate_adapted")}
    rows = []
    for v, r in runs.items():
        s = r["methods"]["acnmp"]
        rows.append(_e3_row(v, s, s["time_s"]))
    p = runs["adapted"]["methods"]["promp_rl"]
    return "\n".join([
        table(["ACNMP, assimilation from", "test success", "mean test error", "mean goal error", "trajectories",
               "max per env", "adaptations", "time (s)"], rows),
        "",
        f"* {runs['skill']['envs']} new environments, the full `benchmarks/experiments/e3_wall.py` run for each variant, on one "
        f"machine ({runs['skill']['provenance']['machine']['cpu']}); ProMP + RL in the same runs: "
        f"{pct(p['test_success_rate'])} test success, mean test error {fmt(p['test_error_mean'])}, "
        f"{p['trajectories_total']} trajectories.",
        "",
        source(runs["skill"], "e3_wall_assimilate_skill"),
        "",
        source(runs["adapted"], "e3_wall_assimilate_adapted"),
    ])


def _budget_label(c: dict) -> str:
    """A budget candidate's settings from its run_wall config: the assimilation's steps x episodes x
    targets at its learning rate (and anchor weight), then the first training's when not the default's."""
    label = (f"{c['assimilate_steps']} x {c['assimilate_batch_size']} x {c['assimilate_targets']}, "
             f"lr {c['assimilate_lr']:g}, anchor {c['assimilate_anchor_weight']:g}")
    return label + f"; first {c['train_steps']} x {c['batch_size']} x {c['n_targets']}"


@renderer("e3-budget")
def e3_budget() -> str:
    r = load("e3_budget")
    rows = []
    # The defaults first, then the candidates in the order they ran.
    for name, w in sorted(r["variants"].items(), key=lambda kv: kv[0] != "baseline"):
        s = w["summary"]
        rows.append([f"{name}: {_budget_label(w['config'])}", *_e3_row("", s, s["time_s"])[1:]])
    commits = sorted({(w["provenance"]["commit"] or "unknown")[:10] for w in r["variants"].values()})
    return "\n".join([
        table(["candidate: assimilation steps x episodes x targets, lr, anchor weight; first training",
               "test success", "mean test error", "mean goal error", "trajectories", "max per env",
               "adaptations", "ACNMP time (s)"], rows),
        "",
        f"* ACNMP only, seed {r['seed']}, {r['envs']} new environments after 30 demonstrated ones, 1000 test "
        "environments, otherwise the defaults; two candidates at a time side by side (two processes) on the "
        "shared machine, so times compare only roughly (the load changed between pairs).",
        f"* Variants run at commit(s) {', '.join(commits)} (each variant's own provenance is in the file); "
        "the variants of one commit ran side by side, and only their times compare.",
        "",
        source(r, "e3_budget"),
    ])


def _stop_label(setting: dict) -> str:
    """A stopping criterion from a run's setting: errors at most the tolerance, clearance above."""
    return f"errors ≤ {setting['goal_tolerance']:g}, clearance > {setting['goal_clearance']:g}"


@renderer("e3-stop")
def e3_stop() -> str:
    """The stopping-criterion candidates (e3_stop.json) beside the baseline (stop = trigger): ACNMP's
    baseline row from e3_budget.json (the same run, reproduced exactly), ProMP + RL's from e3_stop.json."""
    r, budget = load("e3_stop"), load("e3_budget")
    rows = []
    acnmp_base = budget["variants"]["baseline"]
    runs = [("baseline", acnmp_base["config"]["setting"], "acnmp", acnmp_base["summary"])]
    for name, w in sorted(r["variants"].items(), key=lambda kv: kv[0] != "baseline"):
        if "summary" in w:
            runs.append((name, w["config"]["setting"], "acnmp", w["summary"]))
        runs += [(name, w["config"]["setting"], m, o["summary"]) for m, o in w.get("others", {}).items()]
    for name, setting, m, s in sorted(runs, key=lambda x: x[2] != "acnmp"):
        row = _e3_row(f"{name}: {_stop_label(setting)}", s, s["time_s"])
        strict = s.get("test_success_rate_strict")
        rows.append([row[0], TWO_LABELS[m], row[1], "=" if strict is None else pct(strict, 1), *row[2:]])
    commits = sorted({(w["provenance"]["commit"] or "unknown")[:10] for w in r["variants"].values()})
    return "\n".join([
        table(["stopping criterion", "method", "test success (trigger: 0.25)", "test success, stopping criterion",
               "mean test error", "mean goal error", "trajectories", "max per env", "adaptations", "time (s)"], rows),
        "",
        f"* Seed {r['seed']}, {r['envs']} new environments after 30 demonstrated ones, 1000 test environments, "
        "otherwise the defaults. An adaptation is triggered when the generated trajectory misses the 0.25 "
        "criterion (start and goal errors ≤ 0.25, clearance > 0) and stops on the row's criterion; test "
        "success is the trigger's criterion, the next column the stopping criterion's (\"=\": the same).",
        f"* ACNMP baseline row: the `baseline` variant of `e3_budget.json` (commit "
        f"{acnmp_base['provenance']['commit'][:10]}); the other rows ran at commit(s) {', '.join(commits)}, "
        "the two ACNMP candidates side by side (two processes), so only their times compare.",
        "",
        source(r, "e3_stop"),
    ])


@renderer("e3-profile")
def e3_profile() -> str:
    r = load("e3_profile")
    c = r["config"]
    labels = {"first_training": "first training (3000 steps)", "adaptation": "adaptation (adapt(), all of it)",
              "adaptation_supervised_steps": "… of which the supervised steps", "assimilation": "assimilation",
              "rollouts": "executed roll-outs (scoring)", "test_evaluation": "test evaluation"}
    rows = [[labels.get(k, k), f"{v['seconds']:.1f}", pct(v["share"])] for k, v in r["stages"].items()]
    return "\n".join([
        table(["stage", "seconds", "share of the run"], rows),
        "",
        f"* ACNMP only, {c['envs']} new environments after {c['n_initial']} demonstrated ones, {c['n_test']} "
        f"test environments: {r['adaptations']} adaptations, {r['trajectories_total']} trajectories, "
        f"{r['wall_time_s']:.0f} s under cProfile (which slows every Python call; read the shares).",
        "",
        source(r, "e3_profile"),
    ])


@renderer("e3-threads")
def e3_threads() -> str:
    """ACNMP's E3 time by torch thread count (bench_e3_threads.json), runs one after the other."""
    r = load("bench_e3_threads")
    c = r["config"]
    rows = [[x["threads"], f"{x['acnmp_time_s']:.1f}", f"{x['speedup_over_one_thread']:.2f}x",
             "yes" if x["identical_to_one_thread"] else "**no**", pct(x["test_success_rate"], 1),
             x["trajectories_total"]] for x in r["runs"]]
    machine = r["provenance"]["machine"]
    return "\n".join([
        table(["torch threads", "ACNMP time (s)", "speed-up over 1 thread", "same numbers as 1 thread",
               "test success", "trajectories"], rows),
        "",
        f"* ACNMP only, seed {c['seed']}, {c['envs']} new environments after 30 demonstrated ones, 1000 test "
        f"environments; the runs one after the other in one process on {machine['cpu']} "
        f"({machine['cpu_count']} cores); \"same numbers\": summary, test curve and roll-outs per environment "
        "equal bit for bit.",
        "",
        source(r, "bench_e3_threads"),
    ])


# --------------------------------------------------------------------------------------------------
# E4
# --------------------------------------------------------------------------------------------------
E4_LABELS = {"transfer": "transfer (A's encoder, B's decoder)", "no_alignment": "control a: no alignment term",
             "no_transfer": "control b: B's own LfD model"}


@renderer("e4-results")
def e4_results() -> str:
    r = load("e4_transfer")
    paper = r["paper"]["success_by_iteration"]
    rows = [["paper", *(pct(v) for v in paper.values()), "-", "-", "-", "-"]]
    for cond, label in E4_LABELS.items():
        s = r["conditions"].get(cond)
        if s is None:
            continue
        rows.append([label, *(pct(s["success_by_iteration"][k]) for k in paper), fmt(s["iterations_median"]),
                     fmt(s["initial_error_median"]), fmt(s["initial_rmse_to_expert_median"]),
                     fmt(s.get("blind_iterations_mean"))])
    a = r.get("authors_data")
    la = r["latent_alignment"]
    lines = [
        table(["condition", *(f"success after {k} it." for k in paper), "iterations (median)",
               "first cube error (median, m)", "first trajectory vs expert (median RMSE, rad)",
               "iterations without a signal (mean per run)"], rows),
        "",
        f"* Runs: {r['runs']} of {r['runs_requested']} requested, RL seeds {r['seed_list'][0]}..{r['seed_list'][-1]}, "
        f"{r['config']['pair_seeds']} pair seeds shared by the runs; 2 roll-outs per iteration "
        "(iteration 0 is the un-adapted trajectory).",
        f"* Paired latent distance (relative to the distance between different skills' latents, median over "
        f"pairs): {fmt(la['aligned'])} with the alignment term, {fmt(la['plain'])} without.",
        f"* The 3-DoF demonstration of the new skill leaves the cube {fmt(1000 * r['demo_error'])} mm from the goal.",
    ]
    if a:
        lines.append(f"* Authors' data (their arrays, seed {a['seed']}): RMSE of the transferred 4-DoF button press "
                     f"{fmt(a['transfer_rmse'])} rad; mean 4-DoF demonstration {fmt(a['mean_demo_rmse'])} rad; "
                     f"4-DoF partner of the nearest 3-DoF demonstration {fmt(a['nearest_partner_rmse'])} rad.")
    lines += ["", source(r, "e4_transfer")]
    return "\n".join(lines)


def _config_changes(config: dict, base: dict) -> str:
    """The settings of ``config`` that differ from ``base`` (nested dicts), as 'pair.steps=6000'."""
    out = []
    for part, values in config.items():
        if isinstance(values, dict):
            # before authors_pair existed, the authors' data check trained with the pair settings
            ref = base.get(part, base.get("pair", {}) if part == "authors_pair" else {})
            out += [f"{part}.{k}={v}" for k, v in values.items() if ref.get(k) != v]
        elif base.get(part) != values:
            out.append(f"{part}={values}")
    return ", ".join(out) or "(the settings before the sweep)"


def _e4_pooled_fresh(variants: dict) -> dict[str, list[float]]:
    """Success by iteration pooled over the two fresh RL seed sets (``name@30+seed30`` and
    ``name@30+seed60``, 30 runs each), for each variant that has both: ``{name: [rate, ...]}``."""
    out = {}
    for key, v in variants.items():
        name, _, tail = key.partition("@")
        other = variants.get(f"{name}@30+seed60")
        if tail == "30+seed30" and other and v.get("success_by_iteration"):
            out[name] = [(v["success_by_iteration"][k] + other["success_by_iteration"][k]) / 2
                         for k in v["success_by_iteration"]]
    return out


@renderer("e4-sweep")
def e4_sweep() -> str:
    r = load("e4_sweep")
    variants = r["variants"]
    base = next(v["config"] for k, v in variants.items() if k.startswith("default@"))
    rl_rows, authors_rows = [], []
    for name, v in variants.items():
        changes = _config_changes(v["config"], base)
        if v.get("success_by_iteration"):
            rl_rows.append([name, changes, v["runs"], *(pct(x) for x in v["success_by_iteration"].values()),
                            fmt(v["initial_error_median"]), fmt(v.get("blind_iterations_mean"))])
        rmse = v["authors_data"]["transfer_rmse"]
        if rmse:
            authors_rows.append([name, changes, ", ".join(fmt(x) for x in rmse)])
    lines = [table(["variant@runs", "settings changed", "runs", "success after 3 it.", "7 it.", "11 it.", "19 it.",
                    "first cube error (median, m)", "iterations without a signal (mean per run)"], rl_rows)]
    pooled = _e4_pooled_fresh(variants)
    if pooled:
        lines += ["", "* Pooled over both fresh sets (RL seeds 30..89, 60 runs), success after 3 / 7 / 11 / 19 "
                      "iterations: " + "; ".join(f"`{name}` " + " / ".join(pct(x) for x in rates)
                                                 for name, rates in pooled.items()) + "."]
    if authors_rows:
        first = next(v for v in variants.values() if v["authors_data"]["transfer_rmse"])["authors_data"]
        lines += ["", table(["variant", "settings changed", "authors' data: transfer RMSE per pair seed 0, 1, ... (rad)"],
                            authors_rows),
                  "", f"* Naive answers on the authors' data: mean 4-DoF demonstration {fmt(first['mean_demo_rmse'])} "
                      f"rad, nearest demonstration's partner {fmt(first['nearest_partner_rmse'])} rad."]
    d = r.get("authors_data_diagnosis")
    if d:
        b = d["button_affine"]
        loo = d["loo_median"]
        lines += [
            "* No network, the authors' arrays only: the button press written as an affine combination of the "
            "twelve 3-DoF demonstrations (ridge " + ", ".join(b) + ") fits robot A within "
            + ", ".join(fmt(x["fit_a"]) for x in b.values()) + " rad; the same combination of their 4-DoF "
            "partners is " + ", ".join(fmt(x["b_vs_truth"]) for x in b.values()) + " rad from the 4-DoF truth "
            f"(the mean demonstration: {fmt(d['button_mean_demo_rmse'])} rad).",
            "* Leave-one-out over the twelve proxy pairs (median RMSE on robot B, rad): affine combination "
            + ", ".join(f"{fmt(v)} (ridge {k.split('_')[1]})" for k, v in loo.items() if k.startswith("affine_"))
            + f"; nearest 3-DoF demonstration's partner {fmt(loo['nearest_partner'])}; mean of the other 4-DoF "
            f"demonstrations {fmt(loo['mean_of_others'])}.",
        ]
        near = sorted(zip(d["per_demo"]["a_to_button"], d["per_demo"]["b_partner_to_truth"]))[:2]
        lines.append("* The two 3-DoF demonstrations nearest to the button press (" + ", ".join(fmt(x) for x, _ in near)
                     + " rad RMSE) have 4-DoF partners " + ", ".join(fmt(y) for _, y in near)
                     + " rad from the 4-DoF truth.")
    commits = sorted({(v.get("provenance") or {}).get("commit", "unknown")[:10] for v in variants.values()})
    lines += ["", f"*From `benchmarks/results/e4_sweep.json`: `benchmarks/studies/e4_transfer/e4_sweep.py` (transfer condition only; "
                  f"pairs of the pair seeds shared by the variants with the same pair settings), commits "
                  f"{', '.join(commits)}.*"]
    return "\n".join(lines)


def _e4_failure_rows(r: dict) -> list[list[str]]:
    """One row per run of ``r`` (an e4_failures result) not solved within 11 iterations."""
    tol = 0.015
    rows = []
    for run in r["runs"]:
        if run["iterations"] is not None and run["iterations"] <= 11:
            continue
        its = run["per_iteration"]
        best = min(its, key=lambda i: i["mean_error"])
        noisy = next((i["iteration"] for i in its if any(e < tol for e in i["noisy_error"])), None)
        std = best["explore_std"][0] / its[0]["explore_std"][0]
        rows.append([r["variant"], run["seed"], run["pair_seed"], fmt(run["iterations"]), run["label"].replace("_", " "),
                     fmt(run["first_touch"]), fmt(run["first_mean_touch"]), run["blind"],
                     fmt(best["mean_error"]), fmt(best["mean_cube_normal"]), fmt(best["mean_cube_along"]),
                     fmt(best["mean_paddle_beyond"]), fmt(noisy), fmt(std, 2)])
    return rows


@renderer("e4-failures")
def e4_failures() -> str:
    files = [f for f in ("e4_failures", "e4_failures_seed0", "e4_failures_sl_once", "e4_failures_cubic")
             if (RESULTS / f"{f}.json").exists()]
    results = [load(f) for f in files]
    rows = [row for r in results for row in _e4_failure_rows(r)]
    lines = [table(["setting (e4_sweep.py variant)", "RL seed", "pair seed", "mean solved at iteration", "label", "first iteration a roll-out moved "
                    "the cube", "first the mean did", "iterations without a signal", "mean's best error (m)",
                    "there, cube beyond the wall line (m)", "and off the gap's centre line (m)",
                    "paddle's tip beyond the wall line (m)",
                    "first noisy roll-out within 1.5 cm (iteration)", "std there (x its start)"], rows), ""]
    for f, r in zip(files, results):
        solved = [next(i for i in run["per_iteration"] if i["mean_error"] < 0.015)["mean_paddle_beyond"]
                  for run in r["runs"] if run["iterations"] is not None]
        s = r["summary"]
        seeds = [run["seed"] for run in r["runs"]]
        mean_s = " / ".join(pct(v) for v in s["success_by_iteration"].values())
        any_s = " / ".join(pct(v) for v in s["any_rollout_success_by_iteration"].values())
        fol = s["follow_after_better_noisy_median"]
        cnt = s["follow_after_better_noisy_count"]
        lines.append(
            f"* {r['variant']}, RL seeds {seeds[0]}..{seeds[-1]} (`{f}.json`): labels "
            + ", ".join(f"{k.replace('_', ' ')} {v}" for k, v in r["labels"].items())
            + f"; success after 3 / 7 / 11 / 19 iterations of the mean {mean_s}, of any roll-out (the mean or the "
            f"noisy one) {any_s}; {s['noisy_success_not_kept']} times a noisy roll-out succeeded and the next mean "
            f"did not; after a noisy roll-out beat the mean by more than 1 mm the next mean moved a median "
            f"{fmt(fol['solved_by_11'], 2)} of the way to it in the runs solved within 11 iterations "
            f"({cnt['solved_by_11']} iterations), {fmt(fol['later_or_never'], 2)} in the others "
            f"({cnt['later_or_never']}); where the mean first succeeds its paddle's tip gets "
            f"{fmt(float(np.median(solved)))} m beyond the wall line (median; {fmt(min(solved))}..{fmt(max(solved))}).")
    for f, r in zip(files, results):
        p = r.get("provenance") or {}
        lines.append(f"*From `benchmarks/results/{f}.json`: `{p.get('command', '?')}` at commit "
                     f"{(p.get('commit') or 'unknown')[:10]}{' (dirty tree)' if p.get('dirty') else ''}.*")
        lines.append("")
    return "\n".join(lines).rstrip("\n")


# --------------------------------------------------------------------------------------------------
# E6
# --------------------------------------------------------------------------------------------------
@renderer("e6-robust-demos")
def e6_robust_demos() -> str:
    """The current E6 demonstrations beside the designed robust set: the LfD model's held-tilt error and
    how many demonstrations it reproduces within 30 g, per seed (pour_robust_angles.json)."""
    r = load("pour_robust_angles")
    s = r["search"]
    labels = {"current": "current (shuffled tilts)", "robust": "designed (robust tilts following the weight)"}
    rows = []
    for k, label in labels.items():
        m = r["sets"][k]
        counts = m["within_30g_per_seed"]
        n_tilts = len(m["runs"]) * len(m["weights_g"])
        rows.append([label, f"{min(m['weights_g']):g}-{max(m['weights_g']):g} g",
                     f"{m['held_tilt_error_deg_median']:.2f} deg (over {n_tilts})",
                     f"{', '.join(map(str, counts))} (median {fmt(m['within_30g_median'])})",
                     f"{m['seeds_16_of_16']} of {len(counts)}"])
    seeds = r["seeds"]
    missing = sorted(set(w["weight_g"] for w in s["weights"]) - set(s["robust_weights_g"]))
    return "\n".join([
        table(["demonstration set", "weights", "LfD held-tilt error (median)",
               f"demonstrations within 30 g, seeds {seeds[0]}-{seeds[-1]}", "seeds with 16 of 16"], rows),
        "",
        f"* Robust tilts: at {len(s['robust_weights_g'])} of {len(s['weights'])} whole-marble weights a tilt within "
        f"{fmt(s['window_deg'])} deg of the rule (steps of {fmt(s['step_deg'])} deg) pours within "
        f"{fmt(s['tolerance_g'])} g of itself under held-tilt offsets of "
        f"{', '.join(f'{o:+g}' for o in s['offsets_deg'])} deg, shifts of "
        f"{', '.join(f'{x:+d}' for x in s['shifts_rows'])} rows and {s['noise_draws']} smooth noise draws of "
        f"{fmt(s['noise_deg'])} deg; none at {', '.join(f'{w:g}' for w in missing)} g ({s['rollouts']} roll-outs).",
        "",
        source(r, "pour_robust_angles"),
    ])


# --------------------------------------------------------------------------------------------------
# The model service's predict throughput (docs/ARCHITECTURE.md)
# --------------------------------------------------------------------------------------------------
PREDICT_MODES = {"on": "batching on (default)", "threads2": "batching on, 2 batcher threads",
                 "window": "batching on, 1 ms collection window", "off": "batching off (--batch-max 1)"}


def _predict_rows(r: dict, run: str) -> list[list]:
    rows = []
    for m, label in PREDICT_MODES.items():
        if m not in r["modes"]:
            continue
        row = r["modes"][m]
        rates = " / ".join(f"{v:.0f}" for v in row["predicts_per_s_median"].values())
        top = max(row["scaling_vs_1"], key=int)
        rows.append([run, label, rates, f"{row['scaling_vs_1'][top]:.2f}x", f"{row['p50_ratio']:.2f}x",
                     "-" if "scaling_ceiling" not in row else f"{row['scaling_ceiling']:.2f}x"])
    return rows


def _predict_source(r: dict, file: str) -> str:
    p = r["provenance"]
    return (f"*From `benchmarks/results/{file}.json`: `benchmarks/performance/bench_predict.py --reps {r['reps']}` at commit "
            f"{p['commit'][:10]}{' (dirty tree)' if p.get('dirty') else ''}, {p['machine']['cpu']}, "
            f"{p['machine']['cpu_count']} cores, {r['duration_s']:g} s per throughput point.*")


@renderer("predict-target")
def predict_target_block() -> str:
    """The decided predict-throughput target checked on bench_predict_routed.json (two model
    processes sharing the predicts, one process beside it)."""
    from clients.experiments.targets import predict_target

    r = load("bench_predict_routed")
    text, passed = predict_target(r)
    verdict = {True: "met", False: "missed", None: "not checked"}[passed]
    prov = r["provenance"]
    return "\n".join([f"The decided target, {verdict}: {text.replace('[ok] ', '').replace('[missed] ', '')}.", "",
                       f"*From `benchmarks/results/bench_predict_routed.json`: `{prov['command']}` at commit "
                       f"{prov['commit'][:10]}, {prov['machine']['cpu']}, {prov['machine']['cpu_count']} cores, "
                       f"{r['duration_s']:g} s per throughput point.*"])


@renderer("predict-scaling")
def predict_scaling() -> str:
    r, before = load("bench_predict"), load("bench_predict_handler_threads")
    prof = load("predict_profile")["forward_cpu_ms_per_item"]
    on = r["modes"]["on"]
    cpu1, cpu16 = on["cpu_ms_per_predict_median"]["1"], on["cpu_ms_per_predict_median"]["16"]
    svc16, cli16 = on["service_cpu_ms_per_predict_median"]["16"], on["client_cpu_ms_per_predict_median"]["16"]
    cores = r["provenance"]["machine"]["cpu_count"]
    rate1 = on["predicts_per_s_median"]["1"]
    forward = " / ".join(f"{prof[k]:.2f}" for k in ("batch_1", "batch_2", "batch_6", "batch_16"))
    lines = [
        table(["run", "model service", "predicts/s, 1 / 4 / 16 clients (medians)", "16 clients / 1",
               "p50 / floor (1 client)", "CPU ceiling at 16"],
              _predict_rows(r, "now") + _predict_rows(before, "before (handler threads)")),
        "",
        f"Why 16 clients get about {on['scaling_vs_1']['16']:.1f}x one client's predicts here, not 3x: a single "
        f"client's round trip is CPU work from end to end (client, zenoh threads on both sides, service), so one "
        f"client already keeps {on['cores_busy_median']['1']:.2f} of the {cores} cores busy. With 16 clients a "
        f"predict costs {cpu16:.2f} ms of CPU in all (service {svc16:.2f}, clients {cli16:.2f}; {cpu1:.2f} with one "
        f"client): at that cost all {cores} cores could serve at most {cores * 1e3 / cpu16:.0f} predicts/s, "
        f"{on['scaling_ceiling']:.2f}x one client's {rate1:.0f}/s (the CPU ceiling). Making every predict cheaper "
        f"does not lift it (one client speeds up as much); only work that batching removes does, and batching "
        f"removes only what is paid per pass: the forward pass's arithmetic is paid per predict ({forward} ms of CPU "
        f"per predict in passes of 1 / 2 / 6 / 16, `predict_profile.json`), and so are each query's decoding, "
        f"checks and reply and the clients' own work. The collection window reaches 3x only by slowing a single "
        f"client (its p50 is {r['modes']['window']['p50_ratio']:.2f}x the floor, target ≤ 1.5x)." if "window" in r["modes"]
        else "",
        "",
        _predict_source(r, "bench_predict"),
        _predict_source(before, "bench_predict_handler_threads"),
    ]
    return "\n".join(lines)


def _optimizer_label(name: str, c: dict) -> str:
    """An assimilation-optimiser candidate: fresh or kept Adam, its rate and where the rate decays to."""
    opt = "one Adam kept" if c.get("keep_optimizer") else "fresh Adam per solution"
    end = c.get("assimilate_lr_final")
    rate = f"lr {c['assimilate_lr']:g}" + (f" → {end:g} (cosine)" if end is not None else "")
    snap = ", solutions snapped onto start and goal" if c.get("snap_solutions") else ""
    obs = ", targets include the observations" if c.get("targets_include_obs") else ""
    return f"{name}: {opt}, {c['assimilate_steps']} steps, {rate}{snap}{obs}"


@renderer("e3-optimizer")
def e3_optimizer() -> str:
    """The assimilation-optimiser candidates at 300 environments (e3_optimizer.json)."""
    return _optimizer_table("e3_optimizer")


@renderer("e3-optimizer-1500")
def e3_optimizer_1500() -> str:
    """The previous and the new assimilation optimiser at the full 1500 environments (e3_optimizer_1500.json)."""
    return _optimizer_table("e3_optimizer_1500")


@renderer("e3-snap")
def e3_snap() -> str:
    """Solutions snapped onto their start and goal (e3_snap.json) against the same defaults without
    (the kept-optimiser row of e3_optimizer.json), seeds 0-2 at 300 environments."""
    return _snap_table("e3_snap", "e3_optimizer")


@renderer("e3-snap-1500")
def e3_snap_1500() -> str:
    """The same at 1500 environments, seeds 1 and 2 (e3_snap_1500.json against e3_optimizer_1500.json)."""
    return _snap_table("e3_snap_1500", "e3_optimizer_1500")


@renderer("e3-targets-obs")
def e3_targets_obs() -> str:
    """Supervised episodes whose targets include their observations (e3_targets_obs.json) against the
    defaults (the snap variant of e3_snap.json), seeds 0-2 at 300 environments."""
    return _beside("e3_targets_obs", "e3_snap", "snap", "default (snap)")


@renderer("e3-targets-obs-1500")
def e3_targets_obs_1500() -> str:
    """The same at 1500 environments: the defaults from e3_wall.json (seed 0) and e3_snap_1500.json
    (seeds 1, 2) against e3_targets_obs_1500.json (seeds 0-2)."""
    full, snap, cand = load("e3_wall_paper_paths"), load("e3_snap_1500"), load("e3_targets_obs_1500")
    if not full["envs"] == snap["envs"] == cand["envs"]:
        raise ValueError("e3_wall_paper_paths.json, e3_snap_1500.json and e3_targets_obs_1500.json differ in envs")
    seed0 = {"provenance": full["provenance"], "config": full["config"], "curve": full["curves"]["acnmp"],
             "summary": full["methods"]["acnmp"]}
    defaults = {str(full["seed"]): seed0, **{s: v["snap"] for s, v in snap["seeds"].items()}}
    seeds = {s: {"default (snap)": defaults[s], **cand["seeds"][s]} for s in cand["seeds"] if s in defaults}
    return _optimizer_table("e3_targets_obs_1500", {"envs": cand["envs"], "seeds": seeds},
                            sources=[(full, "e3_wall_paper_paths"), (snap, "e3_snap_1500"), (cand, "e3_targets_obs_1500")])


@renderer("e3-consolidate")
def e3_consolidate() -> str:
    """More supervised steps after the stream (run_wall consolidate_steps): the skill at the end of the
    stream against the same skill trained further, one row per candidate (e3_consolidate.json)."""
    r = load("e3_consolidate")
    cfg = next(iter(r["variants"].values()))["config"]
    rows = []
    for v in r["variants"].values():
        s, c = v["summary"], v["summary"]["consolidated"]
        rows.append([f"{c['steps']} steps, rate {fmt(v['config']['assimilate_lr'])} → "
                     f"{fmt(v['config']['consolidate_lr_final'])}",
                     f"{pct(s['test_success_rate'], 1)} → {pct(c['test_success_rate'], 1)}",
                     f"{fmt(s['test_error_mean'])} → {fmt(c['test_error_mean'])}",
                     f"{fmt(s['test_goal_error_mean'])} → {fmt(c['test_goal_error_mean'])}",
                     f"{c['time_s']:.0f}"])
    return "\n".join([
        table(["after the stream", "test success", "mean test error", "mean goal error", "time (s)"], rows),
        "",
        f"* ACNMP, seed {r['seed']}, {r['envs']} new environments after 30 demonstrated ones, 1000 test "
        "environments; the left of each arrow is the skill at the end of the stream (the same run as the Results "
        f"table), the right the same skill after the further steps ({cfg['assimilate_batch_size']} episodes of "
        f"{cfg['assimilate_targets']} targets, one Adam continued, rate decaying along a half cosine).",
        "",
        source(r, "e3_consolidate"),
    ])


def _snap_table(snap_file: str, before_file: str) -> str:
    """``snap_file``'s variants beside the kept-optimiser variant of ``before_file`` ("as found"),
    on the seeds both ran."""
    return _beside(snap_file, before_file, "keep_opt_cos3e-5", "as found")


def _beside(cand_file: str, base_file: str, base_variant: str, base_label: str) -> str:
    """``cand_file``'s variants beside the variant ``base_variant`` of ``base_file`` (shown as
    ``base_label``), on the seeds both ran; the two files must have the same number of environments."""
    base, cand = load(base_file), load(cand_file)
    if base["envs"] != cand["envs"]:
        raise ValueError(f"{base_file}.json and {cand_file}.json differ in envs")
    seeds = {s: {base_label: base["seeds"][s][base_variant], **cand["seeds"][s]}
             for s in cand["seeds"] if base_variant in base["seeds"].get(s, {})}
    return _optimizer_table(cand_file, {"envs": cand["envs"], "seeds": seeds},
                            sources=[(base, base_file), (cand, cand_file)])


def _optimizer_table(name: str, r: dict | None = None, *, sources: list[tuple[dict, str]] | None = None) -> str:
    """Assimilation-optimiser candidates over one or more seeds (e3_budget --combine-seeds): final test
    success per seed ("-": not run for that seed) and its mean over the seeds run, the mean of the last
    four test evaluations (less noisy than the last one), goal error, trajectories, ACNMP time.
    ``r`` : the seeds and envs to show (default: those of ``name``'s file); ``sources`` : the files
    they come from, (result, file) pairs (default: ``name``'s)."""
    r = r or load(name)
    sources = sources or [(r, name)]
    seeds = sorted(r["seeds"], key=int)
    names = list(dict.fromkeys(n for s in seeds for n in r["seeds"][s]))
    names.sort(key=lambda n: (n != "baseline", -sum(n in r["seeds"][s] for s in seeds)))
    rows = []
    for n in names:
        runs = [r["seeds"][s][n] for s in seeds if n in r["seeds"][s]]
        final = [r["seeds"][s][n]["summary"]["test_success_rate"] if n in r["seeds"][s] else None for s in seeds]
        last4 = [np.mean([c["test_success_rate"] for c in w["curve"][-4:]]) for w in runs]
        rows.append([_optimizer_label(n, runs[0]["config"]), " / ".join("-" if f is None else pct(f, 1) for f in final),
                     pct(float(np.mean([f for f in final if f is not None])), 1), pct(float(np.mean(last4)), 1),
                     fmt(float(np.mean([w["summary"]["test_goal_error_mean"] for w in runs]))),
                     f"{np.mean([w['summary']['trajectories_total'] for w in runs]):.0f}",
                     max(w["summary"]["trajectories_per_env_max"] for w in runs),
                     f"{np.mean([w['summary']['time_s'] for w in runs]):.0f}"])
    commits = sorted({(w["provenance"]["commit"] or "unknown")[:10] for s in seeds for w in r["seeds"][s].values()})
    return "\n".join([
        table(["candidate", f"test success, seeds {' / '.join(seeds)}", "mean", "mean of the last 4 evaluations",
               "mean goal error", "trajectories (mean)", "max per env", "ACNMP time (s, mean)"], rows),
        "",
        f"* ACNMP only, {r['envs']} new environments after 30 demonstrated ones, 1000 test environments, test "
        f"evaluations every {r['seeds'][seeds[0]][names[0]]['config']['eval_every']} environments; otherwise the "
        "defaults of the commit each ran at. Two candidates at a "
        "time side by side (two processes) on one machine. Means are over the seeds a candidate ran.",
        f"* Run at commit(s) {', '.join(commits)}; each variant's provenance is in the file.",
        "",
        "\n\n".join(source(res, file) for res, file in sources),
    ])


PUSHER_LABELS = {"lfd": "LfD only", "acnmp": "ACNMP", "promp_rl": "ProMP + RL (REPS)"}


@renderer("pusher-results")
def pusher_results() -> str:
    """The Pusher example's table (pusher.json), the targets met or missed, the ratio as far as it exists."""
    r = load("pusher")
    n, budgets = r["seeds"], r["budgets"]
    m = r["methods"]
    rows = [[PUSHER_LABELS[k] + (f" (budget {budgets[k]})" if k in budgets else ""), frac(s["success_rate"], n),
             fmt(s["rollouts_median"]), ", ".join(map(str, s["rollouts"])), fmt(s["final_error_median"])]
            for k, s in m.items()]
    lfd_fail = round(n * (1 - m["lfd"]["success_rate"]))
    acnmp_ok = round(n * m["acnmp"]["success_rate"])
    ratio = r["rollout_ratio_promp_over_acnmp"]
    promp_ok = round(n * m["promp_rl"]["success_rate"])
    bound = (budgets["promp_rl"] if m["promp_rl"]["success_rate"] <= 0.5 else m["promp_rl"]["rollouts_median"]) \
        / m["acnmp"]["rollouts_median"]
    lines = [
        table(["method", "success", "roll-outs (median)", "per seed", "final distance (median, m)"], rows),
        "",
        f"* Targets: LfD only fails in {lfd_fail} of {n} (at least 8: {'met' if lfd_fail >= 8 else 'missed'}); "
        f"ACNMP succeeds in {acnmp_ok} of {n} within {budgets['acnmp']} roll-outs "
        f"(at least 8: {'met' if acnmp_ok >= 8 else 'missed'}).",
        f"* ProMP + RL / ACNMP roll-outs: " + (f"{ratio:.2f}x (ratio of the medians)." if ratio is not None else
                                               f"no ratio of medians: ProMP + RL succeeded in {promp_ok} of {n}. "
                                               f"Counting its failures at its budget, the medians give at least "
                                               f"{bound:.0f}x."),
        "",
        source(r, "pusher"),
    ]
    return "\n".join(lines)


@renderer("pusher-cost")
def pusher_cost() -> str:
    """What a Pusher roll-out costs and how the workers scale (bench_pusher_rollouts.json)."""
    r = load("bench_pusher_rollouts")
    w = r["workers_rollouts_per_s"]
    return "\n".join([
        f"One {r['steps']}-step episode takes {r['adapter_ms']:.1f} ms through the adapter, against "
        f"{r['raw_env_ms']:.1f} ms for a plain Gymnasium loop with the same actions ({r['adapter_over_raw']:.2f}x). "
        f"Batches through Gymnasium's `AsyncVectorEnv` with 2 sub-processes take {r['vector_2_ms']:.1f} ms per episode "
        f"({r['vector_2_speedup']:.2f}x the adapter's speed): the step is too short for the inter-process traffic to "
        f"pay, so the adapter runs one environment per worker by default. A deployment executes {w['1']:.1f} "
        f"roll-outs/s with one worker and {w['2']:.1f} with two ({r['workers_2_over_1']:.2f}x).",
        "",
        source(r, "bench_pusher_rollouts"),
    ])
