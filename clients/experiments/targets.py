"""Issue 37's decided targets, each read from one experiment's JSON result (what ``acnmp experiment
NAME --json`` writes): ``target(result) -> (one line naming every check, passed or None)``, None
when the run cannot tell (e.g. E3 run with paths as generated)."""
from __future__ import annotations


def e1_target(result: dict) -> tuple[str, bool | None]:
    """E1: ACNMP's shape error (m) within 0.05 of the demonstrations' (issue 37)."""
    shape = result["methods"]["acnmp"]["shape_error"]
    return f"ACNMP shape error <= 0.05 m: {shape:.3f} m", shape <= 0.05


def e3_target(result: dict) -> tuple[str, bool | None]:
    """Issue 37's E3 targets that one seed's run checks (the ten-seed mean is the benchmark's,
    ``benchmarks/results/e3_seeds.json``): boundary conditions enforced, test success >= 95 %,
    mean test error <= ProMP + RL's, <= 120 s, <= 1400 trajectories for any one environment."""
    if not result["config"].get("snap_outputs"):
        return "targets are for the default (boundary conditions enforced); this run has paths as generated", None
    a, p = result["methods"]["acnmp"], result["methods"].get("promp_rl")
    checks = [(f"test success {100 * a['test_success_rate']:.1f} % >= 95 %", a["test_success_rate"] >= 0.95),
              (f"at most {a['trajectories_per_env_max']} <= 1400 trajectories per env", a["trajectories_per_env_max"] <= 1400),
              (f"{a['time_s']:.0f} s <= 120 s", a["time_s"] <= 120)]
    if p is not None:
        checks.append((f"mean test error {a['test_error_mean']:.4f} <= ProMP + RL's {p['test_error_mean']:.4f}",
                       a["test_error_mean"] <= p["test_error_mean"]))
    return all_checks(f"seed {result['seed']}, {result['envs']} envs", checks)


#: E5's joint-error bound for ACNMP (deg) and the seeds that must meet it (of 5), issue 37.
E5_JOINT_DEG, E5_SEEDS_OK = 2.0, 4


def e5_within_bound(runs: list[dict], case: str) -> int:
    """How many of an E5 result's ``runs`` at ``case`` ACNMP solved (success in physics) with
    every joint within :data:`E5_JOINT_DEG` of the expert."""
    return sum(r["acnmp"]["success"] and max(r["acnmp"]["joint_error_deg"]) <= E5_JOINT_DEG
               for r in runs if r["case"] == case)


def e5_target(result: dict) -> tuple[str, bool | None]:
    """LfD-only's largest joint error grows from (8, 10) to (9, 11) (medians over seeds); ACNMP
    succeeds with every joint within 2 deg in >= 4/5 seeds at each case; at a case further out
    (when run), LfD-only fails in >= 3/5 seeds and ACNMP succeeds in >= 4/5."""
    runs, n = result["runs"], result["seeds"]
    cases = result["cases"]
    checks = []
    if {"8_10", "9_11"} <= set(cases):
        near, far = (max(cases[c]["lfd_only"]["joint_error_deg"]) for c in ("8_10", "9_11"))
        checks.append((f"LfD-only's largest joint error {near:.2f} deg at (8, 10) < {far:.2f} at (9, 11)", far > near))
    for case in ("8_10", "9_11"):
        if case in cases:
            ok = e5_within_bound(runs, case)
            checks.append((f"ACNMP at {case} succeeds within {E5_JOINT_DEG:g} deg in {ok}/{n}",
                           ok >= E5_SEEDS_OK * n / 5))
    for case in cases:
        if case not in ("8_10", "9_11"):
            lfd_fail = sum(not r["lfd"]["success"] for r in runs if r["case"] == case)
            acnmp_ok = sum(r["acnmp"]["success"] for r in runs if r["case"] == case)
            checks.append((f"at {case} LfD-only fails in {lfd_fail}/{n}, ACNMP succeeds in {acnmp_ok}/{n}",
                           lfd_fail >= 3 * n / 5 and acnmp_ok >= 4 * n / 5))
    return all_checks(f"{n} seeds", checks)


def e6_all_within_50(runs: list[dict]) -> int:
    """How many of an E6 result's assimilated ``runs`` reproduce all 16 demonstrations within 50 g."""
    return sum(max(r["assimilation"]["demo_errors_g"]) <= 50 for r in runs if r.get("assimilation"))


def e6_target(result: dict) -> tuple[str, bool | None]:
    """ACNMP within 30 g in <= 20 roll-outs in >= 4/5 seeds; after each assimilation all 16
    demonstrations within 50 g and no fewer within 30 g than the LfD-only model's."""
    n = result["seeds"]
    within20 = round(result["acnmp"]["success_within_20_rate"] * n)
    checks = [(f"within 30 g in <= 20 roll-outs in {within20}/{n}", within20 >= 4 * n / 5)]
    assimilated = [r for r in result["runs"] if r.get("assimilation")]
    if assimilated:
        all50 = e6_all_within_50(assimilated)
        kept = sum(r["assimilation"]["demos_within_30g"] >= r["lfd_demos_within_30g"] for r in assimilated)
        k = len(assimilated)
        checks += [(f"after assimilation all 16 demonstrations within 50 g in {all50}/{k} seeds", all50 == k),
                   (f"no fewer within 30 g than LfD-only's in {kept}/{k} seeds", kept == k)]
    return all_checks(f"{n} seeds", checks)


def all_checks(scope: str, checks: list[tuple[str, bool]]) -> tuple[str, bool | None]:
    """One line of every check ("[ok]" or "[missed]" before each) and whether all passed."""
    text = "; ".join(f"{'[ok]' if ok else '[missed]'} {what}" for what, ok in checks)
    return f"{scope}: {text}", all(ok for _, ok in checks) if checks else None
