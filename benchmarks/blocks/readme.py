"""The docs blocks of the README's results table, the experiments' table, the targets, the demonstration format: one renderer per block, each reading its JSON."""
from __future__ import annotations

import numpy as np

from benchmarks.report_kit import RESULTS, fmt, frac, load, pct, renderer, table
from .e3 import e3_seed_runs
from .e5 import E5_CASE_LABELS


def e1_row() -> list[str]:
    r = load("e1_viapoint")
    n = r["config"]["seeds"]
    a, lfd = r["methods"]["acnmp"], r["methods"]["lfd_only"]
    ratio = r["shape_error_ratio_rl_only_over_acnmp"]
    return [f"E1 via-point ({n} seeds)", "ACNMP ≤ 35 roll-outs, LfD misses",
            f"ACNMP {frac(a['success_rate'], n)} succeed, median {fmt(a['rollouts_median'])} roll-outs "
            f"({frac(a['within_35_rate'], n)} within 35); LfD-only {frac(lfd['success_rate'], n)}; shape error "
            f"RL-only / ACNMP {'-' if ratio is None else f'{ratio:.1f}x'}"]


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
    from benchmarks.blocks.peers import peers_row

    rows = [e1_row(), e2_row(), e3_row(), e4_row(), e5_row(), e6_row(), peers_row()]
    from clients.experiments.targets import PREDICT_CEILING_SHARE, ceiling_share

    p, routed = load("bench_predict"), load("bench_predict_routed")["modes"]
    rows.append(["predict over zenoh", "–", f"p50 {p['latency']['predict_zenoh']['p50_ms']:.2f} ms "
                 f"({p['p50_ratio']:.2f}x in-process + empty query); 16 clients at "
                 f"{ceiling_share(routed['routed2']):.2f} of the CPU ceiling with 2 model processes "
                 f"(target ≥ {PREDICT_CEILING_SHARE:g}), {ceiling_share(routed['routed1']):.2f} with 1"])
    return table(["experiment", "paper", "measured here (JSON in `benchmarks/results/`)"], rows)
