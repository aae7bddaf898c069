"""The docs blocks of E3, the wall: one renderer per block, each reading its JSON."""
from __future__ import annotations

import numpy as np

from benchmarks.report_kit import block, fmt, has_result, load, pct, renderer, renderers, source, table
from .e2 import TWO_LABELS


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
    return block(r, name,
                 ["method", "test success", "mean test error", "mean goal error", "trajectories", "max per env",
                  "adaptations", "time (s)"],
                 rows,
                 "\n".join([
                     f"* Seed {r['seed']}: {r['envs']} new environments after {r['n_initial']} demonstrated ones; {r['n_test']} test "
                     f"environments; {_e3_paths(r)}.",
                     "* ProMP + RL / ACNMP trajectories in total: " + ("-" if ratio is None else f"{ratio:.2f}x") + "."]))


def _e3_paths(r: dict) -> str:
    """How a run executed its generated paths, from its config."""
    c = r["config"]
    if c.get("snap_rollouts"):
        return "every executed path moved onto its start and goal"
    return ("boundary conditions enforced (generated paths moved onto their start and goal, the default)"
            if c.get("snap_outputs") else "paths as generated (the paper's variant)")


renderers(_e3_results_block, {
    "e3-results": ("e3_wall",),  # seed 0 at the default, boundary conditions enforced
    "e3-results-paper-paths": ("e3_wall_paper_paths",),  # seed 0 with paths as generated, the paper's variant
})


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


renderers(_e3_per_env, {"e3-per-env": ("e3_wall", "e3_seeds"),
                        "e3-per-env-paper-paths": ("e3_wall_paper_paths", "e3_seeds_paper_paths")})


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
    return block(more, seeds_file,
                 ["seed", "ACNMP test success", "ProMP + RL test success", "ACNMP mean test error",
                  "ProMP + RL mean test error", "ACNMP trajectories", "ProMP + RL trajectories",
                  "ACNMP max per env", "ACNMP adaptations"],
                 rows,
                 "\n".join([
                     f"* {full['envs']} new environments after {full['n_initial']} demonstrated ones, {full['n_test']} test "
                     f"environments, {_e3_paths(full)}; both methods in one run per seed, one torch thread.",
                     f"* ACNMP at 95 % test success or more: {at_target} of {len(seeds)} seeds; its mean test error is "
                     f"{error_ratio:.2f}x ProMP + RL's (means over the seeds); ProMP + RL executes {traj_ratio:.2f}x as many "
                     "trajectories."]),
                 source(full, wall))


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
    header = ["seed", "ACNMP time alone (s)", "in the ten-seed table (s)", "adaptations", "test success",
              "same results as the ten-seed table"]
    summary = (f"* Alone: median {r['acnmp_time_s_median']:.0f} s, at most {r['acnmp_time_s_max']:.0f} s; "
               f"{r['seeds_within_120_s']} of {len(rows)} seeds within 120 s. In the ten-seed table seed 0 ran "
               "alone too, seeds 1-9 two at a time.")
    return block(r, "e3_time_alone", header, rows, summary)


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
    return block(snap, "e3_snap_outputs",
                 ["method", "test success", "mean test error", "mean goal error", "trajectories", "max per env",
                  "adaptations", "time (s)"],
                 rows,
                 f"* Seed {snap['seed']}, {snap['envs']} new environments after 30 demonstrated ones, 1000 test environments. "
                 "\"Generated paths snapped\": the path generated for a new or a test environment is moved onto its start "
                 "and goal before it is executed or scored, the adaptations' roll-outs are not; \"all executed paths "
                 "snapped\": the adaptations' roll-outs too. The two variants ran side by side (two processes).",
                 source(full, "e3_wall_paper_paths"))


E3_COMPARE_LABELS = {"acnmp": "ACNMP", "promp_rl": "ProMP + REPS (task-conditional)",
                     "ewerton": "ProMP + PRO + GP (after Ewerton et al. 2019)"}


@renderer("e3-compare")
def e3_compare() -> str:
    """The paper's E3 numbers beside ours in each setting, each method of one run per setting."""
    rows = [["Akbulut et al. 2020 (paper)", "ACNMP", "-", "-", "-", "-", "≤ 1.4K", "0.7M", "1x", "-"],
            ["Akbulut et al. 2020 (paper)", "Ewerton et al. 2019 (quoted)", "-", "-", "-", "-", "20K", "10M", "~14x",
             "-"]]
    files = ["e3_compare_paper", "e3_compare_authors"]
    files += [f for f in ("e3_compare_paper_snapped", "e3_compare_authors_snapped") if has_result(f)]
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
    return "\n".join([
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
        *[line for f, r in runs.items() for line in ("", source(r, f))],    ])


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
    return block(r, "e3_fit_precision",
                 ["expert demos", "steps x batch x targets per episode", "test success", "mean test error",
                  "mean goal error", "through the hole", "demonstrated envs: success", "demonstrated envs: goal error",
                  "training time (s)"],
                 rows,
                 f"* The first training of E3 only (seed {r['seed']}), no RL: one expert demonstration per random "
                 "environment, scored on the 1000 test environments and, conditioned the same way, on the demonstrated "
                 "environments themselves (how well the skill fits what it was trained on). Rate 1e-3, constant unless a "
                 "decay (half cosine) is given.")


@renderer("e3-assimilate-from")
def e3_assimilate_from() -> str:
    r = load("e3_assimilate_from")
    labels = {"skill": "the skill before the adaptation (the default)", "adapted": "the adapted copy"}
    rows = []
    for v, label in labels.items():
        s, w = r["variants"][v]["summary"], r["variants"][v]
        rows.append(_e3_row(label, s, w["wall_time_s"]))
    return block({**r, "wall_time_s": r.get("wall_time_s",
                 max(w["wall_time_s"] for w in r["variants"].values()))}, "e3_assimilate_from", ["assimilation continues from", "test success", "mean test error", "mean goal error",
                                                                                                 "trajectories", "max per env", "adaptations", "time (s)"],
                 rows,
                 f"* ACNMP only, seed {r['seed']}, {r['envs']} new environments after 30 demonstrated ones, 1000 test "
                 "environments; both variants side by side in one run (two processes), otherwise the defaults.")


@renderer("e3-assimilate-from-full")
def e3_assimilate_from_full() -> str:
    runs = {"skill": load("e3_wall_assimilate_skill"), "adapted": load("e3_wall_assimilate_adapted")}
    rows = []
    for v, r in runs.items():
        s = r["methods"]["acnmp"]
        rows.append(_e3_row(v, s, s["time_s"]))
    p = runs["adapted"]["methods"]["promp_rl"]
    return block(runs["adapted"], "e3_wall_assimilate_adapted",
                 ["ACNMP, assimilation from", "test success", "mean test error", "mean goal error", "trajectories",
                  "max per env", "adaptations", "time (s)"],
                 rows,
                 f"* {runs['skill']['envs']} new environments, the full `benchmarks/experiments/e3_wall.py` run for each variant, on one "
                 f"machine ({runs['skill']['provenance']['machine']['cpu']}); ProMP + RL in the same runs: "
                 f"{pct(p['test_success_rate'])} test success, mean test error {fmt(p['test_error_mean'])}, "
                 f"{p['trajectories_total']} trajectories.",
                 source(runs["skill"], "e3_wall_assimilate_skill"))


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
    return block(r, "e3_budget",
                 ["candidate: assimilation steps x episodes x targets, lr, anchor weight; first training",
                  "test success", "mean test error", "mean goal error", "trajectories", "max per env",
                  "adaptations", "ACNMP time (s)"],
                 rows,
                 "\n".join([
                     f"* ACNMP only, seed {r['seed']}, {r['envs']} new environments after 30 demonstrated ones, 1000 test "
                     "environments, otherwise the defaults; two candidates at a time side by side (two processes) on the "
                     "shared machine, so times compare only roughly (the load changed between pairs).",
                     f"* Variants run at commit(s) {', '.join(commits)} (each variant's own provenance is in the file); "
                     "the variants of one commit ran side by side, and only their times compare."]))


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
    return block(r, "e3_stop",
                 ["stopping criterion", "method", "test success (trigger: 0.25)", "test success, stopping criterion",
                  "mean test error", "mean goal error", "trajectories", "max per env", "adaptations", "time (s)"],
                 rows,
                 "\n".join([
                     f"* Seed {r['seed']}, {r['envs']} new environments after 30 demonstrated ones, 1000 test environments, "
                     "otherwise the defaults. An adaptation is triggered when the generated trajectory misses the 0.25 "
                     "criterion (start and goal errors ≤ 0.25, clearance > 0) and stops on the row's criterion; test "
                     "success is the trigger's criterion, the next column the stopping criterion's (\"=\": the same).",
                     f"* ACNMP baseline row: the `baseline` variant of `e3_budget.json` (commit "
                     f"{acnmp_base['provenance']['commit'][:10]}); the other rows ran at commit(s) {', '.join(commits)}, "
                     "the two ACNMP candidates side by side (two processes), so only their times compare."]))


@renderer("e3-profile")
def e3_profile() -> str:
    r = load("e3_profile")
    c = r["config"]
    labels = {"first_training": "first training (3000 steps)", "adaptation": "adaptation (adapt(), all of it)",
              "adaptation_supervised_steps": "… of which the supervised steps", "assimilation": "assimilation",
              "rollouts": "executed roll-outs (scoring)", "test_evaluation": "test evaluation"}
    rows = [[labels.get(k, k), f"{v['seconds']:.1f}", pct(v["share"])] for k, v in r["stages"].items()]
    return block(r, "e3_profile",
                 ["stage", "seconds", "share of the run"],
                 rows,
                 f"* ACNMP only, {c['envs']} new environments after {c['n_initial']} demonstrated ones, {c['n_test']} "
                 f"test environments: {r['adaptations']} adaptations, {r['trajectories_total']} trajectories, "
                 f"{r['wall_time_s']:.0f} s under cProfile (which slows every Python call; read the shares).")


@renderer("e3-threads")
def e3_threads() -> str:
    """ACNMP's E3 time by torch thread count (bench_e3_threads.json), runs one after the other."""
    r = load("bench_e3_threads")
    c = r["config"]
    rows = [[x["threads"], f"{x['acnmp_time_s']:.1f}", f"{x['speedup_over_one_thread']:.2f}x",
             "yes" if x["identical_to_one_thread"] else "**no**", pct(x["test_success_rate"], 1),
             x["trajectories_total"]] for x in r["runs"]]
    machine = r["provenance"]["machine"]
    return block(r, "bench_e3_threads",
                 ["torch threads", "ACNMP time (s)", "speed-up over 1 thread", "same numbers as 1 thread",
                  "test success", "trajectories"],
                 rows,
                 f"* ACNMP only, seed {c['seed']}, {c['envs']} new environments after 30 demonstrated ones, 1000 test "
                 f"environments; the runs one after the other in one process on {machine['cpu']} "
                 f"({machine['cpu_count']} cores); \"same numbers\": summary, test curve and roll-outs per environment "
                 "equal bit for bit.")


def _optimizer_label(name: str, c: dict) -> str:
    """An assimilation-optimiser candidate: fresh or kept Adam, its rate and where the rate decays to."""
    opt = "one Adam kept" if c.get("keep_optimizer") else "fresh Adam per solution"
    end = c.get("assimilate_lr_final")
    rate = f"lr {c['assimilate_lr']:g}" + (f" → {end:g} (cosine)" if end is not None else "")
    snap = ", solutions snapped onto start and goal" if c.get("snap_solutions") else ""
    obs = ", targets include the observations" if c.get("targets_include_obs") else ""
    return f"{name}: {opt}, {c['assimilate_steps']} steps, {rate}{snap}{obs}"


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
    return block(r, "e3_consolidate",
                 ["after the stream", "test success", "mean test error", "mean goal error", "time (s)"],
                 rows,
                 f"* ACNMP, seed {r['seed']}, {r['envs']} new environments after 30 demonstrated ones, 1000 test "
                 "environments; the left of each arrow is the skill at the end of the stream (the same run as the Results "
                 f"table), the right the same skill after the further steps ({cfg['assimilate_batch_size']} episodes of "
                 f"{cfg['assimilate_targets']} targets, one Adam continued, rate decaying along a half cosine).")


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


#: Both methods at the defaults over ten seeds: seed 0 from e3_wall.json (the Results table), seeds
#: 1-9 from e3_seeds.json (``e3_budget.py --candidates baseline --methods acnmp promp_rl``, one file
#: per seed, combined), one row per seed, then the mean; and the same with paths as generated.
renderers(_e3_seeds, {"e3-seeds": ("e3_wall", "e3_seeds"),
                      "e3-seeds-paper-paths": ("e3_wall_paper_paths", "e3_seeds_paper_paths")})
#: The assimilation-optimiser candidates at 300 environments, and the previous and the new one at 1500.
renderers(_optimizer_table, {"e3-optimizer": ("e3_optimizer",), "e3-optimizer-1500": ("e3_optimizer_1500",)})
#: Solutions snapped onto their start and goal against the same defaults without (the kept-optimiser
#: row of e3_optimizer.json): seeds 0-2 at 300 environments, seeds 1 and 2 at 1500.
renderers(_snap_table, {"e3-snap": ("e3_snap", "e3_optimizer"), "e3-snap-1500": ("e3_snap_1500", "e3_optimizer_1500")})
#: Supervised episodes whose targets include their observations against the defaults (the snap
#: variant of e3_snap.json), seeds 0-2 at 300 environments.
renderers(_beside, {"e3-targets-obs": ("e3_targets_obs", "e3_snap", "snap", "default (snap)")})
