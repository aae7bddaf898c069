"""The mutation check of the learner: each break of a hand-kept table applied alone, its file's tests run.

    python benchmarks/mutation/run.py                       # all of them -> benchmarks/results/mutation.json
    python benchmarks/mutation/run.py --only core-cancel-finished,runner-weights-not-returned   # a few, printed
    python benchmarks/mutation/run.py --list                # the table, nothing run

The table (benchmarks/mutation/mutants.py) breaks the learner's state, job and ownership code.
The checkout is copied (its tracked and untracked files, so uncommitted tests count) to a temporary
directory, never changed in place. Each group of tests first runs on the unmutated copy and must
pass. Then each mutant: its ``find`` text replaced in the copy, ``pytest -x`` on its file's tests
(:data:`~benchmarks.mutation.mutants.TESTS`) with the copy first on the path, the file restored.
A mutant is killed when pytest fails (a failing test, an import error, or the time limit); the
first failing test is recorded. Exit 0 when at least ``--target`` of the mutants of the scope are
killed and every survivor is one the table marks equivalent (with its reason), else 1.

With the ``mutation`` extra installed (mutmut 3.8.1), the result also records how many mutants
mutmut would generate for the same files: why the table is hand-kept (docs/RELEASE.md).
"""
from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks._results import RESULTS, ROOT, main_provenance, save_result  # noqa: E402
from benchmarks.mutation.mutants import MUTANTS, SCOPE, SERVICE, TESTS, Mutant  # noqa: E402

#: Seconds one mutant's tests may take before the mutant counts as killed (a hang fails a suite too).
DEFAULT_TIMEOUT = 900.0
#: A line of pytest's short summary naming a failed test (not a captured log line at level ERROR).
FAILED = re.compile(r"^(?:FAILED|ERROR) (tests/.+?)(?: - .*)?$", re.M)


def copy_checkout(dest: Path) -> None:
    """Copy this checkout's tracked and untracked (not ignored) files to ``dest``."""
    out = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"], cwd=ROOT,
                         capture_output=True, check=True)
    for rel in filter(None, out.stdout.decode().split("\0")):
        src = ROOT / rel
        if src.is_file():
            (dest / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / rel)


def run_tests(copy: Path, tests: tuple[str, ...], timeout: float) -> dict:
    """``pytest -x`` on ``tests`` in ``copy``: its exit code (None after ``timeout``), seconds, and
    the first failing test."""
    env = dict(os.environ, PYTHONPATH=str(copy), RERUN_ANALYTICS="0", OMP_NUM_THREADS="1")
    env.pop("PYTEST_ADDOPTS", None)
    start = time.monotonic()
    try:
        out = subprocess.run([sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", *tests],
                             cwd=copy, env=env, capture_output=True, text=True, timeout=timeout)
        code, text = out.returncode, out.stdout + out.stderr
    except subprocess.TimeoutExpired:
        code, text = None, ""
    failed = FAILED.search(text)
    return {"exit_code": code, "seconds": round(time.monotonic() - start, 1),
            "first_failure": failed.group(1) if failed else ("timeout" if code is None else None),
            "tail": "" if code == 0 else "\n".join(text.strip().splitlines()[-3:])}


def apply(copy: Path, mutant: Mutant) -> str:
    """Apply ``mutant`` in ``copy``; returns the file's original text. ValueError when its ``find``
    text is not found exactly once (the table is stale)."""
    path = copy / mutant.file
    original = path.read_text()
    found = original.count(mutant.find)
    if found != 1:
        raise ValueError(f"mutant {mutant.id}: its text is found {found} times in {mutant.file}, expected once")
    path.write_text(original.replace(mutant.find, mutant.replace))
    return original


def mutmut_counts(copy: Path) -> dict | None:
    """How many mutants mutmut generates for each file of the scope (None without mutmut)."""
    try:
        from importlib.metadata import version
        tool = version("mutmut")
    except Exception:
        return None
    (copy / "setup.cfg").write_text("[mutmut]\nsource_paths=services\n")
    code = ("import json, sys\nfrom mutmut.mutation.file_mutation import mutate_file_contents\n"
            "print(json.dumps({p: len(mutate_file_contents(p, open(p).read(), None, set()).mutant_names) "
            "for p in sys.argv[1:]}))")
    out = subprocess.run([sys.executable, "-c", code, *SCOPE], cwd=copy, capture_output=True, text=True)
    (copy / "setup.cfg").unlink()
    if out.returncode != 0:
        return {"tool": f"mutmut {tool}", "error": out.stderr.strip().splitlines()[-1:]}
    import json
    counts = json.loads(out.stdout)
    return {"tool": f"mutmut {tool}", "mutants": counts, "total": sum(counts.values())}


def score(rows: list[dict]) -> dict:
    """Killed / total of ``rows``, and their survivors split into equivalent and not."""
    killed = sum(r["killed"] for r in rows)
    survivors = [r for r in rows if not r["killed"]]
    return {"killed": killed, "total": len(rows), "fraction": round(killed / len(rows), 4) if rows else None,
            "survivors_equivalent": sum(r["equivalent"] is not None for r in survivors),
            "survivors_unexplained": [r["id"] for r in survivors if r["equivalent"] is None]}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog="examples:\n" + "\n".join(__doc__.splitlines()[2:5]))
    ap.add_argument("--only", default=None, help="comma-separated mutant ids to run (default: all); the result "
                                                 "is printed, and written only with --out")
    ap.add_argument("--list", action="store_true", help="list the table's mutants and exit")
    ap.add_argument("--timeout", type=float, default=DEFAULT_TIMEOUT,
                    help=f"seconds one mutant's tests may take (default {DEFAULT_TIMEOUT:g})")
    ap.add_argument("--target", type=float, default=0.8, help="fraction of the scope's mutants to kill (default 0.8)")
    ap.add_argument("--out", default=None, help="result JSON (default: benchmarks/results/mutation.json when all run)")
    args = ap.parse_args(argv)
    if args.list:
        for m in MUTANTS:
            print(f"{m.id:42s} {m.file:32s} {m.breaks}" + (" [equivalent]" if m.equivalent else ""))
        return 0
    chosen = list(MUTANTS)
    if args.only:
        wanted = [s.strip() for s in args.only.split(",") if s.strip()]
        unknown = sorted(set(wanted) - {m.id for m in MUTANTS})
        if unknown:
            ap.error(f"--only: unknown mutant(s) {', '.join(unknown)} (--list shows them)")
        chosen = [m for m in MUTANTS if m.id in wanted]
    out = args.out if args.out is not None else (None if args.only else str(RESULTS / "mutation.json"))
    provenance = main_provenance(__file__, argv)
    started = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="acnmp-mutation-") as tmp:
        copy = Path(tmp)
        copy_checkout(copy)
        groups = {TESTS[f] for f in {m.file for m in chosen}}
        baseline = {}
        for tests in sorted(groups):
            res = run_tests(copy, tests, args.timeout)
            baseline[" ".join(tests)] = {"exit_code": res["exit_code"], "seconds": res["seconds"]}
            print(f"baseline {' '.join(tests)}: exit {res['exit_code']} in {res['seconds']} s", flush=True)
            if res["exit_code"] != 0:
                print(f"the tests fail without a mutant ({res['first_failure']}):\n{res['tail']}", file=sys.stderr)
                return 1
        rows = []
        for m in chosen:
            original = apply(copy, m)
            try:
                res = run_tests(copy, TESTS[m.file], args.timeout)
            finally:
                (copy / m.file).write_text(original)
            killed = res["exit_code"] != 0
            rows.append({"id": m.id, "file": m.file, "breaks": m.breaks, "issue_67_break": m.issue,
                         "find": m.find, "replace": m.replace, "killed": killed,
                         "killed_by": res["first_failure"] if killed else None, "exit_code": res["exit_code"],
                         "seconds": res["seconds"], "equivalent": m.equivalent})
            print(f"{'killed ' if killed else 'SURVIVED'} {m.id} ({res['seconds']} s)"
                  + (f" by {res['first_failure']}" if killed else "")
                  + ("" if killed or not m.equivalent else " [equivalent]"), flush=True)
        counts = mutmut_counts(copy)
    in_scope = [r for r in rows if r["file"] in SCOPE]
    result = {"provenance": provenance, "wall_time_s": round(time.monotonic() - started, 1),
              "scope": list(SCOPE), "tests": {f: list(t) for f, t in TESTS.items()}, "target": args.target,
              "score": score(in_scope), "beside_scope": score([r for r in rows if r["file"] == SERVICE]),
              "baseline": baseline, "mutants": rows, "tool_count": counts}
    ok = bool(in_scope) and result["score"]["fraction"] >= args.target and not result["score"]["survivors_unexplained"]
    if out is not None:
        save_result(result, out, headline=("score", "beside_scope"))
    else:
        print(f"scope: {result['score']}; beside it: {result['beside_scope']}")
    return 0 if ok or not in_scope else 1


if __name__ == "__main__":
    sys.exit(main())
