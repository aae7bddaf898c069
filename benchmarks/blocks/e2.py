"""The docs blocks of E2, the push: one renderer per block, each reading its JSON."""
from __future__ import annotations

from benchmarks.report_kit import block, fmt, frac, load, renderer, source, table


TWO_LABELS = {"acnmp": "ACNMP", "promp_rl": "ProMP + RL (REPS)"}


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
    return block(r, "e2_push",
                 ["method", "case", "roll-outs (median)", "range", "success", "final error (median, m)",
                  "initial error (median, m)"],
                 rows,
                 "\n".join([
                     "* ProMP + RL / ACNMP roll-outs (ratio of the medians, only where both succeed in every seed): "
                     + "; ".join(f"{c} {'-' if v is None else f'{v:.2f}x'}" for c, v in ratio.items()) + ".",
                     f"* ACNMP extrapolation roll-outs per seed: {', '.join(map(str, r['methods']['acnmp']['extrapolation']['rollouts']))}."]))


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
    return block(r, "e2_baselines",
                 ["run", "method", "interpolation roll-outs (median)", "success", "extrapolation roll-outs (median)",
                  "success", "final error (median, m)", "extrapolation / ACNMP"],
                 rows,
                 "\n".join([
                     f"* Budget {r['budget']} roll-outs per target for every method; every executed trajectory counts; "
                     "a failed run counts its whole budget in the median; ratios only where both succeed in more than "
                     "half of the seeds.",
                     *notes]))
