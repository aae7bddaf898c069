"""The docs blocks of E5, the UR10: one renderer per block, each reading its JSON."""
from __future__ import annotations

from benchmarks.report_kit import block, fmt, frac, load, renderer, renderers, source, table


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
    return block(r, "e5_ur10",
                 ["case (cm)", "method", "shoulder pan", "shoulder lift", "elbow", "wrist 1", "wrist 2", "wrist 3",
                  "success", "roll-outs"],
                 rows,
                 "\n".join([
                     "* Per-joint error: mean |executed - expert executed| over the 625 rows (deg), median over the seeds; "
                     "success in physics; roll-outs: median.",
                     "* ACNMP roll-outs per seed: " + "; ".join(f"{E5_CASE_LABELS.get(c, c)} {', '.join(map(str, v))}"
                                                                for c, v in per_seed.items()) + ".",
                     f"* ACNMP succeeding with every joint within {E5_JOINT_DEG:g} deg: " + "; ".join(
                         f"{E5_CASE_LABELS.get(c, c)} {k}/{n}" for c, k in within.items()) + "."]))


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


#: Demonstration-shaped noise and task-parameter jitter on E5, and mixup training (the same study run
#: for that variant).
renderers(_e5_variant_table, {"e5-exploration": ("e5_exploration", E5_EXPLORATION_LABELS, "variant"),
                              "e5-exploration-mixup": ("e5_exploration_mixup", E5_EXPLORATION_LABELS, "variant")})
#: The training variants on E5's reported seeds, and on seeds that chose nothing.
renderers(_e5_training_table, {"e5-training": ("e5_training",), "e5-training-fresh": ("e5_training_fresh",)})
