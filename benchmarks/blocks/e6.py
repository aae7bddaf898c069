"""The docs blocks of E6, the pour: one renderer per block, each reading its JSON."""
from __future__ import annotations

from benchmarks.report_kit import block, fmt, frac, load, renderer, source, table


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
    return block(r, "e6_pour",
                 ["", "paper (real rig)", f"here (PyBullet, {n} seeds)"],
                 rows,
                 f"* CPU per roll-out {fmt(r['rollout_cpu_s_median'])} s (median); the assimilation trains "
                 f"{_assimilation_text({**r['config']['assimilation'], 'start': r['config'].get('assimilate_from', 'adapted')})}.")


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
    return block(r, "e6_assimilation",
                 ["candidate", "assimilation", "all 16 within 50 g", "no fewer within 30 g than LfD-only",
                  "test within 30 g without RL", "within 30 g (median of 16)"],
                 rows,
                 f"* Seeds {', '.join(str(x['seed']) for x in solved)} of {r['seeds']} found a solution (the others have "
                 "nothing to assimilate); the LfD-only model reproduced "
                 + ", ".join(str(x["lfd_demos_within_30g"]) for x in solved) + " of 16 within 30 g in them.")


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
    return block(r, "pour_robust_angles",
                 ["demonstration set", "weights", "LfD held-tilt error (median)",
                  f"demonstrations within 30 g, seeds {seeds[0]}-{seeds[-1]}", "seeds with 16 of 16"],
                 rows,
                 f"* Robust tilts: at {len(s['robust_weights_g'])} of {len(s['weights'])} whole-marble weights a tilt within "
                 f"{fmt(s['window_deg'])} deg of the rule (steps of {fmt(s['step_deg'])} deg) pours within "
                 f"{fmt(s['tolerance_g'])} g of itself under held-tilt offsets of "
                 f"{', '.join(f'{o:+g}' for o in s['offsets_deg'])} deg, shifts of "
                 f"{', '.join(f'{x:+d}' for x in s['shifts_rows'])} rows and {s['noise_draws']} smooth noise draws of "
                 f"{fmt(s['noise_deg'])} deg; none at {', '.join(f'{w:g}' for w in missing)} g ({s['rollouts']} roll-outs).")
