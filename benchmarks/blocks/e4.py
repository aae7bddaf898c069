"""The docs blocks of E4, the transfer: one renderer per block, each reading its JSON."""
from __future__ import annotations

import numpy as np

from benchmarks.report_kit import fmt, has_result, load, pct, renderer, source, table, where


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
    lines += ["", f"*From `{where('e4_sweep')}`: `benchmarks/studies/e4_transfer/e4_sweep.py` (transfer condition only; "
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
             if has_result(f)]
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
        lines.append(f"*From `{where(f)}`: `{p.get('command', '?')}` at commit "
                     f"{(p.get('commit') or 'unknown')[:10]}{' (dirty tree)' if p.get('dirty') else ''}.*")
        lines.append("")
    return "\n".join(lines).rstrip("\n")
