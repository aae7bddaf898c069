"""``acnmp reproduce``: the paper's six experiments, one after the other, into one report.

Each experiment runs as ``acnmp experiment NAME`` in a child process (its numbers exactly as that
command gives them) under each recipe: the paper's method (``--recipe paper``), judged against the
paper's figure and the decided targets, writing ``OUT/<id>.json``, ``OUT/<id>.png`` and its printed
table ``OUT/<id>.txt``; and the product's default beside it (``--recipe default``, the same
targets), writing ``OUT/<id>_default.*``. ``OUT/report.md`` and a self-contained
``OUT/report.html`` (figures embedded) gather them with the paper's figure, the time and the
provenance of each. A finished run is kept (``--force`` runs it again), so an interrupted
reproduction resumes where it stopped.
"""
from __future__ import annotations

import argparse
import base64
import html
import json
import os
import subprocess
import sys
import time
from pathlib import Path

from acnmp_core.experiments.recipe import RECIPES  # light: no torch
from clients.experiments.catalog import OPTIONAL, PAPER, Experiment
from clients.experiments.targets import quick_check
from services.transport.argtypes import int_at_least, non_empty

#: What the report says of a run at quick sizes, whose numbers the decided targets do not apply to.
QUICK_NOTE = ("Quick sizes: each experiment is checked to run, to keep its accounting (its counts agree with its "
              "per-run records) and to render here. The decided targets apply at the sizes `acnmp reproduce` runs "
              "without --quick, and only such a run is judged against them.")


#: The paper's six experiments, as clients/experiments/catalog.py declares them (sizes, targets).
STEPS = PAPER
#: How the report names each recipe's column and section.
RECIPE_TITLES = {"paper": "the paper's method", "default": "the default"}


def runs_of(step: Experiment, recipes: tuple[str, ...]) -> tuple[str, ...]:
    """The recipes ``step`` runs under: the chosen ones for the paper's six, the experiment's own
    (it compares the methods itself: "paper" only) for an optional one."""
    return recipes if step in STEPS else ("paper",)


def stem(step: Experiment, recipe: str) -> str:
    """The files of ``step`` under ``recipe``: ``<id>`` for the paper's method, ``<id>_default``."""
    return step.ident if recipe == "paper" else f"{step.ident}_{recipe}"


def register(subparsers) -> None:
    """Add the ``reproduce`` sub-command."""
    p = subparsers.add_parser(
        "reproduce", help="run the paper's six experiments into one report (resumable)",
        description=__doc__.split(": ", 1)[1], formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="examples:\n  acnmp reproduce -o paper/                 # everything, at the documented sizes\n"
               "  acnmp reproduce -o quick/ --quick          # smaller sizes, the same report, marked quick\n"
               "  acnmp reproduce -o paper/ --only E3,E5 --force\n"
               "  acnmp reproduce -o paper/ --recipes paper  # the paper's method only, not the default beside it")
    p.add_argument("-o", "--out", required=True, type=non_empty, metavar="DIR", help="where the results and report go")
    p.add_argument("--only", default=None, metavar="E1,E3", help="these experiments only (default: all six)")
    p.add_argument("--with", dest="with_", default=None, metavar="NAME",
                   help="also run these experiments (comma-separated) after the chosen ones: "
                        + ", ".join(f"{e.name} ({e.help.split(':')[0]})" for e in OPTIONAL)
                        + " (run only when named here, with or without --quick)")
    p.add_argument("--quick", action="store_true",
                   help="smaller sizes (minutes), a smoke test: each experiment runs, its accounting holds, the report "
                        "renders; judged against the decided targets only at the full sizes")
    p.add_argument("--recipes", default=",".join(RECIPES), metavar="paper,default",
                   help="the methods each of the six runs, comma-separated: 'paper' (the paper's method, judged "
                        "against the paper) and 'default' (the product's default, beside it); default both")
    p.add_argument("--force", action="store_true", help="run again the experiments whose results are in DIR")
    p.add_argument("--jobs", type=int_at_least(1), default=min(2, os.cpu_count() or 1),
                   help="experiments run at once, each in its own process (default: 2 on two or more cores, "
                        "which is faster than one at a time)")
    p.set_defaults(func=run)


def _chosen(only: str | None) -> list[Experiment]:
    if only is None:
        return list(STEPS)
    wanted = [w.strip().upper() for w in only.split(",") if w.strip()]
    known = {s.ident: s for s in STEPS}
    unknown = [w for w in wanted if w not in known]
    if unknown or not wanted:
        raise ValueError(f"--only {only!r}: expected some of {', '.join(known)} separated by commas")
    return [known[w] for w in wanted]


def _extra(names: str | None) -> list[Experiment]:
    """The optional experiments ``--with`` names (none by default)."""
    if names is None:
        return []
    wanted = [w.strip() for w in names.split(",") if w.strip()]
    known = {e.name: e for e in OPTIONAL}
    if not wanted or any(w not in known for w in wanted):
        raise ValueError(f"--with {names!r}: expected some of {', '.join(known)} separated by commas")
    return [known[w] for w in wanted]


def _recipes(text: str) -> tuple[str, ...]:
    """The recipes ``--recipes`` names, in the report's order."""
    wanted = {w.strip() for w in text.split(",") if w.strip()}
    if not wanted or wanted - set(RECIPES):
        raise ValueError(f"--recipes {text!r}: expected some of {', '.join(RECIPES)} separated by commas")
    return tuple(r for r in RECIPES if r in wanted)


def run(args) -> int:
    """Run the chosen experiments under the chosen recipes (those without results in ``--out``
    unless ``--force``), ``--jobs`` at once, then write the report; 1 when a run failed (the report
    says which)."""
    from concurrent.futures import ThreadPoolExecutor

    from tqdm import tqdm

    steps = _chosen(args.only) + _extra(args.with_)
    recipes = _recipes(args.recipes)
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    todo = []
    for step in steps:
        for recipe in runs_of(step, recipes):
            done = out / f"{stem(step, recipe)}.json"
            if done.exists() and not args.force:
                print(f"{stem(step, recipe)}: kept {done} (--force runs it again)", flush=True)
            else:
                todo.append((step, recipe))
    failed = []
    t0 = time.perf_counter()
    with tqdm(total=len(todo), desc="reproduce", unit="run", disable=None, position=0) as whole, \
            ThreadPoolExecutor(max_workers=args.jobs) as pool:
        futures = {pool.submit(_run_step, step, out, args.quick, row + 1, recipe): (step, recipe)
                   for row, (step, recipe) in enumerate(todo)}
        for future, (step, recipe) in futures.items():
            if not future.result():
                failed.append(stem(step, recipe))
            whole.update(1)
    if todo:
        (out / "reproduce.meta.json").write_text(json.dumps(
            {"experiments": [stem(s, r) for s, r in todo], "jobs": args.jobs, "quick": args.quick,
             "wall_time_s": round(time.perf_counter() - t0, 1)}, indent=2) + "\n")
    report = write_report(out, steps, quick=args.quick, recipes=recipes)
    print(f"wrote {report} and {report.with_suffix('.html')}")
    if failed:
        print(f"acnmp reproduce: {', '.join(failed)} failed (their logs: {out}/<id>.txt)", file=sys.stderr)
    return 1 if failed else 0


def _say(line: str) -> None:
    """One whole line on stdout (experiments run on several threads; ``print`` writes the line and
    its newline separately, so two could interleave)."""
    sys.stdout.write(line + "\n")
    sys.stdout.flush()


def _run_step(step: Experiment, out: Path, quick: bool, position: int = 1, recipe: str = "paper") -> bool:
    """Run one experiment under ``recipe`` in a child process; its output goes to ``<stem>.txt``
    (:func:`stem`; and its last line to a progress bar of its own on a terminal), its time to
    ``<stem>.meta.json``."""
    from tqdm import tqdm

    name = stem(step, recipe)
    argv = [sys.executable, "-m", "clients.cli", "experiment", step.name, *(step.quick if quick else step.full),
            *(("--recipe", recipe) if step in STEPS else ()),
            "--json", str(out / f"{name}.json"), "--plot", str(out / f"{name}.png")]
    _say(f"{name}: acnmp {' '.join(argv[3:])}")
    t0 = time.perf_counter()
    with open(out / f"{name}.txt", "w") as log, \
            tqdm(desc=name, bar_format="{desc}: {elapsed} {postfix}", disable=None, position=position,
                 leave=False) as bar:
        child = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1)
        for line in child.stdout:
            log.write(line)
            if line.strip():
                bar.set_postfix_str(line.strip()[:70], refresh=True)
        code = child.wait()
    meta = {"command": "acnmp " + " ".join(argv[3:]), "wall_time_s": round(time.perf_counter() - t0, 1),
            "quick": quick, "exit_code": code}
    (out / f"{name}.meta.json").write_text(json.dumps(meta, indent=2) + "\n")
    _say(f"{name}: {'done' if code == 0 else f'failed (exit {code})'} in {meta['wall_time_s']} s")
    if code != 0:
        (out / f"{name}.json").unlink(missing_ok=True)  # not kept: the next run tries again
    return code == 0


def _verdict(out: Path, step: Experiment, recipe: str) -> tuple[str, str, dict]:
    """One run's verdict (PASS, FAIL, reported, ran (quick), ... or not run), its status line and its
    meta file (``{}`` when absent), from ``out``'s files of ``step`` under ``recipe``."""
    name = stem(step, recipe)
    meta_path = out / f"{name}.meta.json"
    meta = json.loads(meta_path.read_text()) if meta_path.exists() else {}
    if not (out / f"{name}.json").exists():
        return "not run", "not run (or failed: see its log)", meta
    result = json.loads((out / f"{name}.json").read_text())
    if meta.get("quick"):  # the targets are decided for the full sizes: a smoke test only
        target, ok = quick_check(result, step.target)
        verdict = "ran (quick)" if ok else "accounting wrong (quick)"
    else:
        target, passed = step.target(result) if step.target else ("no target a single run checks", None)
        verdict = {True: "PASS", False: "FAIL", None: "reported"}[passed]
    prov = result.get("provenance", {})
    return verdict, f"{verdict}: {target}. {meta.get('wall_time_s', '?')} s; commit {str(prov.get('commit', '?'))[:10]}", meta


def write_report(out: Path, steps: list[Experiment], *, quick: bool, recipes: tuple[str, ...] = RECIPES) -> Path:
    """``OUT/report.md`` and ``OUT/report.html`` from the results in ``out``: per experiment, the
    paper's method and the default beside it (those of ``recipes``); returns the .md path."""
    sections_md, sections_html, summary = [], [], []
    for step in steps:
        verdicts, times = {}, []
        md_parts, html_parts = [f"## {step.ident}: {step.title}\n\nPaper: {step.paper}.\n"], [
            f"<h2>{html.escape(step.ident)}: {html.escape(step.title)}</h2><p>Paper: {html.escape(step.paper)}.</p>"]
        for recipe in runs_of(step, recipes):
            name = stem(step, recipe)
            verdict, status, meta = _verdict(out, step, recipe)
            verdicts[recipe] = verdict
            times.append(meta.get("wall_time_s"))
            table = (out / f"{name}.txt").read_text() if (out / f"{name}.txt").exists() else ""
            png = out / f"{name}.png"
            head = f"### {RECIPE_TITLES[recipe][0].upper()}{RECIPE_TITLES[recipe][1:]}\n\n" if step in STEPS else ""
            md_parts.append(f"{head}{status}\n\n`{meta.get('command', 'acnmp experiment ' + step.name)}`\n\n"
                            f"```\n{table.strip()}\n```\n" + (f"\n![{name}]({png.name})\n" if png.exists() else ""))
            image = (f'<img alt="{name}" src="data:image/png;base64,{base64.b64encode(png.read_bytes()).decode()}">'
                     if png.exists() else "")
            html_parts.append((f"<h3>{html.escape(RECIPE_TITLES[recipe])}</h3>" if step in STEPS else "")
                              + f"<p>{html.escape(status)}</p><pre>{html.escape(table.strip())}</pre>{image}")
        known = [t for t in times if t is not None]
        summary.append((step.ident, step.title, [verdicts.get(r, "–") for r in recipes],
                        sum(known) if known else None))
        sections_md.append("\n".join(md_parts))
        sections_html.append("".join(html_parts))
    title = "ACNMP: the paper reproduced" + (" (quick sizes)" if quick else "")
    whole = out / "reproduce.meta.json"
    last = json.loads(whole.read_text()) if whole.exists() else None
    lead = ("" if last is None else f"The last run: {', '.join(last['experiments'])} in {last['wall_time_s']:.0f} s "
            f"({last['jobs']} at once{', quick sizes' if last['quick'] else ''}).\n\n")
    if "default" in recipes:
        lead += ("Each experiment runs the paper's method (judged against the paper and the decided targets) and, "
                 "beside it, the product's default (the model chooses its linear path from the demonstrations, "
                 "AdaptConfig()'s settings plus the experiment's protocol; `acnmp experiment NAME --recipe "
                 "default`), judged against the same targets.\n\n")
    quick_runs = quick or any(v.endswith("(quick)") for _, _, vs, _ in summary for v in vs)
    if quick_runs:
        lead += QUICK_NOTE + "\n\n"
    what = "decided target, or the quick check" if quick_runs else "decided target"
    columns = [f"{RECIPE_TITLES[r]}: {what}" for r in recipes]
    rows = "".join(f"| {i} | {t} | {' | '.join(vs)} | {'-' if w is None else f'{w:.0f} s'} |\n"
                   for i, t, vs, w in summary)
    md = out / "report.md"
    md.write_text(f"# {title}\n\n{lead}| id | experiment | {' | '.join(columns)} | time |\n"
                  f"| --- | --- | {' | '.join('---' for _ in columns)} | --- |\n{rows}\n" + "\n".join(sections_md))
    md.with_suffix(".html").write_text(
        f"<!doctype html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
        f"<style>body{{font-family:sans-serif;max-width:60em;margin:auto}}img{{max-width:100%}}</style></head>"
        f"<body><h1>{html.escape(title)}</h1><p>{html.escape(lead.strip())}</p><table border=1 cellpadding=4>"
        f"<tr><th>id</th><th>experiment</th>{''.join(f'<th>{html.escape(c)}</th>' for c in columns)}<th>time</th></tr>"
        + "".join(f"<tr><td>{i}</td><td>{html.escape(t)}</td>{''.join(f'<td>{v}</td>' for v in vs)}"
                  f"<td>{'-' if w is None else f'{w:.0f} s'}</td></tr>" for i, t, vs, w in summary)
        + f"</table>{''.join(sections_html)}</body></html>\n")
    return md
