"""The docs blocks of the MuJoCo Pusher example: one renderer per block, each reading its JSON."""
from __future__ import annotations

from benchmarks.report_kit import block, fmt, frac, load, renderer, source


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
    return block(r, "pusher",
                 ["method", "success", "roll-outs (median)", "per seed", "final distance (median, m)"],
                 rows,
                 "\n".join([
                     f"* Targets: LfD only fails in {lfd_fail} of {n} (at least 8: {'met' if lfd_fail >= 8 else 'missed'}); "
                     f"ACNMP succeeds in {acnmp_ok} of {n} within {budgets['acnmp']} roll-outs "
                     f"(at least 8: {'met' if acnmp_ok >= 8 else 'missed'}).",
                     f"* ProMP + RL / ACNMP roll-outs: " + (f"{ratio:.2f}x (ratio of the medians)." if ratio is not None else
                                                            f"no ratio of medians: ProMP + RL succeeded in {promp_ok} of {n}. "
                                                            f"Counting its failures at its budget, the medians give at least "
                                                            f"{bound:.0f}x.")]))


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
