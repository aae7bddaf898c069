"""The docs blocks of E1, the via-point: one renderer per block, each reading its JSON."""
from __future__ import annotations

from benchmarks.report_kit import block, fmt, frac, load, renderer


E1_LABELS = {"lfd_only": "LfD-only", "rl_only": "RL-only", "acnmp": "ACNMP"}


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
    return block(r, "e1_viapoint",
                 ["method", "success", "roll-outs (median)", "≤ 35 roll-outs", "via-point error (median, m)",
                  "shape error (median, m)", "start/end error (max, m)"],
                 rows,
                 "\n".join([
                     f"* Roll-outs per seed, ACNMP: {', '.join(map(str, r['methods']['acnmp']['rollouts']))}; "
                     f"RL-only: {', '.join(map(str, r['methods']['rl_only']['rollouts']))}.",
                     "* Shape error RL-only / ACNMP (ratio of the medians): "
                     + ("- (a method failed in some seed)" if ratio is None else f"{ratio:.2f}") + ".",
                     f"* Assimilation ({a['performed']}/{n} seeds with a solution): conditioned again on the same points "
                     f"with no RL, the assimilated model succeeds in {a['success_after']}/{a['performed']}; the old "
                     f"demonstrations' reproduction RMSE is at most {fmt(a['old_demos_rmse_ratio_max'])}x the LfD model's "
                     f"(median {fmt(a['old_demos_rmse_ratio_median'])}x); the solution is reproduced within "
                     f"{fmt(a['solution_reproduction_rmse_max'])} m RMSE.",
                     f"* Time per seed (three methods, training and assimilation): median {r['wall_time_per_seed_s_median']:.1f} s."]))


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
    return block(r, "e1_assimilation",
                 head,
                 rows,
                 "* Each seed adapted once (ACNMP, budget 100), then assimilated from the same adapted network by "
                 "each candidate (lr 1e-4, 32 episodes of 10 targets per step, the anchor); seeds whose adaptation "
                 "failed are left out of the count.")
