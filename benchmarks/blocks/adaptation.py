"""The docs blocks of the adaptation's settings sweep: one renderer per block, each reading its JSON."""
from __future__ import annotations

from benchmarks.report_kit import RESULTS, fmt, frac, load, pct, renderer, source, table


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
    return "\n".join([
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
        *[source(run, f) for run, f in zip(runs, files)],    ])
