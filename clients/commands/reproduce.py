"""``acnmp reproduce``: the paper's six experiments, one after the other, into one report.

Each experiment runs as ``acnmp experiment NAME`` in a child process (its numbers exactly as that
command gives them), writing ``OUT/<id>.json``, ``OUT/<id>.png`` and its printed table
``OUT/<id>.txt``; ``OUT/report.md`` and a self-contained ``OUT/report.html`` (figures embedded)
gather them with the paper's figure, the time and the provenance of each. A finished experiment is
kept (``--force`` runs it again), so an interrupted run resumes where it stopped.
"""
from __future__ import annotations

import argparse
import base64
import html
import json
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from services.transport.argtypes import non_empty


@dataclass(frozen=True)
class Step:
    """One experiment as ``acnmp reproduce`` runs it.

    ident : E1..E6. experiment : its ``acnmp experiment`` name. title : what it is. paper : what
    the paper reports for it. full, quick : the command's options at the documented size and at a
    smoke-test size. target : (text, passed or None) from the experiment's JSON, for the decided
    targets a single run can check; None when the report only shows the numbers.
    """

    ident: str
    experiment: str
    title: str
    paper: str
    full: tuple[str, ...]
    quick: tuple[str, ...]
    target: Callable[[dict], tuple[str, bool | None]] | None = None


def _e1_target(result: dict) -> tuple[str, bool | None]:
    shape = result["methods"]["acnmp"]["shape_error"]
    return f"ACNMP shape error <= 0.05 m: {shape:.3f} m", shape <= 0.05


def _e3_target(result: dict) -> tuple[str, bool | None]:
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
    return _all(f"seed {result['seed']}, {result['envs']} envs", checks)


#: E5's joint-error bound for ACNMP (deg) and the seeds that must meet it (of 5), issue 37.
E5_JOINT_DEG, E5_SEEDS_OK = 2.0, 4


def _e5_target(result: dict) -> tuple[str, bool | None]:
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
            ok = sum(r["acnmp"]["success"] and max(r["acnmp"]["joint_error_deg"]) <= E5_JOINT_DEG
                     for r in runs if r["case"] == case)
            checks.append((f"ACNMP at {case} succeeds within {E5_JOINT_DEG:g} deg in {ok}/{n}",
                           ok >= E5_SEEDS_OK * n / 5))
    for case in cases:
        if case not in ("8_10", "9_11"):
            lfd_fail = sum(not r["lfd"]["success"] for r in runs if r["case"] == case)
            acnmp_ok = sum(r["acnmp"]["success"] for r in runs if r["case"] == case)
            checks.append((f"at {case} LfD-only fails in {lfd_fail}/{n}, ACNMP succeeds in {acnmp_ok}/{n}",
                           lfd_fail >= 3 * n / 5 and acnmp_ok >= 4 * n / 5))
    return _all(f"{n} seeds", checks)


def _e6_target(result: dict) -> tuple[str, bool | None]:
    """ACNMP within 30 g in <= 20 roll-outs in >= 4/5 seeds; after each assimilation all 16
    demonstrations within 50 g and no fewer within 30 g than the LfD-only model's."""
    n = result["seeds"]
    within20 = round(result["acnmp"]["success_within_20_rate"] * n)
    checks = [(f"within 30 g in <= 20 roll-outs in {within20}/{n}", within20 >= 4 * n / 5)]
    assimilated = [r for r in result["runs"] if r.get("assimilation")]
    if assimilated:
        all50 = sum(max(r["assimilation"]["demo_errors_g"]) <= 50 for r in assimilated)
        kept = sum(r["assimilation"]["demos_within_30g"] >= r["lfd_demos_within_30g"] for r in assimilated)
        k = len(assimilated)
        checks += [(f"after assimilation all 16 demonstrations within 50 g in {all50}/{k} seeds", all50 == k),
                   (f"no fewer within 30 g than LfD-only's in {kept}/{k} seeds", kept == k)]
    return _all(f"{n} seeds", checks)


def _all(scope: str, checks: list[tuple[str, bool]]) -> tuple[str, bool | None]:
    """One line of every check ("[ok]" or "[missed]" before each) and whether all passed."""
    text = "; ".join(f"{'[ok]' if ok else '[missed]'} {what}" for what, ok in checks)
    return f"{scope}: {text}", all(ok for _, ok in checks) if checks else None


STEPS = (
    Step("E1", "viapoint", "2-D via-point beyond the demonstrations (Fig. 3, 4)",
         "ACNMP reaches the extrapolated via-point keeping the demonstrations' shape; RL alone distorts it",
         ("--seed", "0"), ("--seed", "0", "--train-steps", "200", "--budget", "10"), _e1_target),
    Step("E2", "push", "planar 3-DoF push, interpolation and extrapolation (Fig. 5 a-c)",
         "ACNMP needs about 9x fewer roll-outs than ProMP + RL", ("--seeds", "10"), ("--quick", "--seeds", "1")),
    Step("E3", "wall", "self-improvement over wall-with-a-hole environments (Fig. 5 d, e)",
         "ACNMP needs about 14x fewer trajectories than ProMP + RL for the same test success",
         ("--envs", "1500", "--eval-every", "50"), ("--envs", "10", "--test", "200"), _e3_target),
    Step("E4", "transfer", "skill transfer from a 3-DoF to a 4-DoF arm (Fig. 6)",
         "the transferred skill succeeds more often and sooner than learning from scratch", (),
         ("--runs", "1", "--pair-steps", "300", "--budget", "10", "--no-authors-data")),
    Step("E5", "ur10", "UR10 pick and place at heights beyond the demonstrations (Fig. 7)",
         "LfD alone fails in extrapolation; ACNMP places within a few roll-outs", (),
         ("--seeds", "1", "--train-steps", "500", "--budget", "10"), _e5_target),
    Step("E6", "pour", "pouring marbles into a target weight (Fig. 8)",
         "ACNMP reaches the target weight within 30 g in a few roll-outs", ("--jobs", "2"),
         ("--seeds", "1", "--train-steps", "500", "--budget", "10"), _e6_target),
)


def register(subparsers) -> None:
    """Add the ``reproduce`` sub-command."""
    p = subparsers.add_parser(
        "reproduce", help="run the paper's six experiments into one report (resumable)",
        description=__doc__.split(": ", 1)[1], formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="examples:\n  acnmp reproduce -o paper/                 # everything, at the documented sizes\n"
               "  acnmp reproduce -o quick/ --quick          # smaller sizes, the same report, marked quick\n"
               "  acnmp reproduce -o paper/ --only E3,E5 --force")
    p.add_argument("-o", "--out", required=True, type=non_empty, metavar="DIR", help="where the results and report go")
    p.add_argument("--only", default=None, metavar="E1,E3", help="these experiments only (default: all six)")
    p.add_argument("--quick", action="store_true", help="smaller sizes (minutes); the report says so")
    p.add_argument("--force", action="store_true", help="run again the experiments whose results are in DIR")
    p.set_defaults(func=run)


def _chosen(only: str | None) -> list[Step]:
    if only is None:
        return list(STEPS)
    wanted = [w.strip().upper() for w in only.split(",") if w.strip()]
    known = {s.ident: s for s in STEPS}
    unknown = [w for w in wanted if w not in known]
    if unknown or not wanted:
        raise ValueError(f"--only {only!r}: expected some of {', '.join(known)} separated by commas")
    return [known[w] for w in wanted]


def run(args) -> int:
    """Run the chosen experiments (those without results in ``--out`` unless ``--force``), then
    write the report; 1 when an experiment failed (the report says which)."""
    from tqdm import tqdm

    steps = _chosen(args.only)
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    failed = []
    with tqdm(steps, desc="reproduce", unit="experiment", disable=None) as bar:
        for step in bar:
            bar.set_postfix(now=step.ident)
            done = out / f"{step.ident}.json"
            if done.exists() and not args.force:
                print(f"{step.ident}: kept {done} (--force runs it again)", flush=True)
                continue
            if not _run_step(step, out, args.quick):
                failed.append(step.ident)
    report = write_report(out, steps, quick=args.quick)
    print(f"wrote {report} and {report.with_suffix('.html')}")
    if failed:
        print(f"acnmp reproduce: {', '.join(failed)} failed (their logs: {out}/<id>.txt)", file=sys.stderr)
    return 1 if failed else 0


def _run_step(step: Step, out: Path, quick: bool) -> bool:
    """Run one experiment in a child process; its table goes to ``<id>.txt``, its time to ``<id>.meta.json``."""
    argv = [sys.executable, "-m", "clients.cli", "experiment", step.experiment, *(step.quick if quick else step.full),
            "--json", str(out / f"{step.ident}.json"), "--plot", str(out / f"{step.ident}.png")]
    print(f"{step.ident}: acnmp {' '.join(argv[3:])}", flush=True)
    t0 = time.perf_counter()
    with open(out / f"{step.ident}.txt", "w") as log:
        code = subprocess.run(argv, stdout=log, stderr=subprocess.STDOUT).returncode
    meta = {"command": "acnmp " + " ".join(argv[3:]), "wall_time_s": round(time.perf_counter() - t0, 1),
            "quick": quick, "exit_code": code}
    (out / f"{step.ident}.meta.json").write_text(json.dumps(meta, indent=2) + "\n")
    if code != 0:
        (out / f"{step.ident}.json").unlink(missing_ok=True)  # not kept: the next run tries again
    return code == 0


def write_report(out: Path, steps: list[Step], *, quick: bool) -> Path:
    """``OUT/report.md`` and ``OUT/report.html`` from the results in ``out``; returns the .md path."""
    sections_md, sections_html = [], []
    for step in steps:
        result_path, meta_path = out / f"{step.ident}.json", out / f"{step.ident}.meta.json"
        table = (out / f"{step.ident}.txt").read_text() if (out / f"{step.ident}.txt").exists() else ""
        meta = json.loads(meta_path.read_text()) if meta_path.exists() else {}
        if result_path.exists():
            result = json.loads(result_path.read_text())
            target, passed = step.target(result) if step.target else ("no target a single run checks", None)
            verdict = {True: "PASS", False: "FAIL", None: "reported"}[passed]
            prov = result.get("provenance", {})
            status = (f"{verdict}: {target}. {meta.get('wall_time_s', '?')} s; commit "
                      f"{str(prov.get('commit', '?'))[:10]}{' (quick)' if meta.get('quick') else ''}")
        else:
            status = "not run (or failed: see its log)"
        png = out / f"{step.ident}.png"
        sections_md.append(f"## {step.ident}: {step.title}\n\nPaper: {step.paper}.\n\n{status}\n\n"
                           f"`{meta.get('command', 'acnmp experiment ' + step.experiment)}`\n\n```\n{table.strip()}\n```\n"
                           + (f"\n![{step.ident}]({png.name})\n" if png.exists() else ""))
        image = (f'<img alt="{step.ident}" src="data:image/png;base64,{base64.b64encode(png.read_bytes()).decode()}">'
                 if png.exists() else "")
        sections_html.append(f"<h2>{html.escape(step.ident)}: {html.escape(step.title)}</h2>"
                             f"<p>Paper: {html.escape(step.paper)}.</p><p>{html.escape(status)}</p>"
                             f"<pre>{html.escape(table.strip())}</pre>{image}")
    title = "ACNMP: the paper reproduced" + (" (quick sizes)" if quick else "")
    md = out / "report.md"
    md.write_text(f"# {title}\n\n" + "\n".join(sections_md))
    md.with_suffix(".html").write_text(
        f"<!doctype html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
        f"<style>body{{font-family:sans-serif;max-width:60em;margin:auto}}img{{max-width:100%}}</style></head>"
        f"<body><h1>{html.escape(title)}</h1>{''.join(sections_html)}</body></html>\n")
    return md
