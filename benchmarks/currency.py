"""Whether each result of record is current: made, by a command a user can run in a clone, at or after
the last change to the code that produced it.

A result of record (:data:`RECORD`: what the README and the experiment pages' headline tables
publish) is *stale* when

* its provenance names no commit, or a commit this checkout does not descend from;
* a file of the code that produced it changed after that commit. That code is the script its
  command ran and every module of the project the script imports, directly or through others,
  read from the import graph (``grimp``, the graph ``lint-imports`` checks), imports inside
  functions included;
* its command names a script that is not in the repository (it moved), or a file outside the
  repository (a scratch file only the machine that made it had).

A result of record may be *pending* (:data:`PENDING`): not made at this commit, for the reason
given, its file absent; the pages then publish none of its numbers (its blocks say it is pending
and name its command; tests/unit/benchmarks/test_currency.py reads every block to check that), and
it is listed, not counted stale. Once its file exists it is checked as any other.

``python benchmarks/currency.py`` lists each stale result with why and the command that makes it
again; the test suite runs the same check (tests/unit/benchmarks/test_currency.py), so a change to
the code behind a published number fails the suite until the number is made again.
"""
from __future__ import annotations

import json
import shlex
import subprocess
import sys
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
#: the project's packages, whose modules a result's code can be
PACKAGES = ("acnmp_core", "services", "clients", "benchmarks")
#: the results of record: what the README and the experiment pages' headline tables publish
RECORD = ("e1_viapoint", "e2_push", "e3_wall", "e3_seeds", "e4_transfer", "e5_ur10", "e6_pour", "pusher", "peers",
          "bench_predict", "bench_predict_routed")

#: results of record not made at this commit, and why: no page publishes their numbers meanwhile
PENDING = {"peers": "the comparison of record on the report seeds 5-14 takes about 11 hours of CPU on the "
                    "project's 2-core machine; not run since the default's model changed"}


@dataclass(frozen=True)
class Stale:
    """A stale result: its name, why (one line), and its command (to make it again)."""

    name: str
    why: str
    command: str


def _git(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, timeout=30)


@lru_cache(maxsize=1)
def _graph():
    import grimp

    sys.path.insert(0, str(ROOT))
    return grimp.build_graph(*PACKAGES, include_external_packages=False)


def script_of(command: str) -> str | None:
    """The repository path of the Python script a provenance command ran (``python X.py ...``,
    ``X.py ...`` or the ``acnmp`` command line, whose code is ``clients/cli.py``), or None."""
    words = shlex.split(command)
    for w in words[:3]:
        if w.endswith(".py"):
            return w
        if Path(w).name == "acnmp":
            return "clients/cli.py"
    return None


def code_of(script: str) -> list[str]:
    """The repository files of ``script`` and of every project module it imports, transitively."""
    module = script.removesuffix(".py").replace("/", ".")
    graph = _graph()
    if module not in graph.modules:
        return [script]
    modules = {module} | graph.find_upstream_modules(module)
    files = []
    for m in sorted(modules):
        path = ROOT / Path(*m.split("."))
        files.append(str((path / "__init__.py" if path.is_dir() else path.with_suffix(".py")).relative_to(ROOT)))
    return files


def outside_paths(command: str) -> list[str]:
    """The absolute paths in ``command`` outside the repository (files only the maker had)."""
    return [w for w in shlex.split(command) if w.startswith("/") and not Path(w).is_relative_to(ROOT)]


def check(name: str, results: Path = RESULTS) -> Stale | None:
    """Whether the result ``<name>.json`` is current (None) or stale (:class:`Stale`)."""
    path = results / f"{name}.json"
    if not path.exists():
        return Stale(name, "no result file", "")
    result = json.loads(path.read_text())
    p = result.get("provenance") or {}
    command = p.get("command", "")
    # a merge of parts run side by side (peers.py --merge) is as old as its parts' code, not its own commit
    commits = [p.get("commit")] + [(part.get("provenance") or {}).get("commit") for part in result.get("parts", [])]
    for commit in commits:
        if not commit or _git("merge-base", "--is-ancestor", commit, "HEAD").returncode != 0:
            return Stale(name, f"made at commit {commit or 'unknown'}, which this checkout does not descend from",
                         command)
    outside = outside_paths(command)
    if outside:
        return Stale(name, f"its command names files outside the repository ({', '.join(outside)})", command)
    script = script_of(command)
    if script is None or not (ROOT / script).exists():
        return Stale(name, f"its command's script {script or '(none)'} is not in the repository", command)
    for commit in dict.fromkeys(commits):
        changed = _git("diff", "--name-only", commit, "HEAD", "--", *code_of(script)).stdout.split()
        if changed:
            return Stale(name, f"made at {commit[:10]}; its code changed since: {', '.join(changed[:6])}"
                               + (f" and {len(changed) - 6} more" if len(changed) > 6 else ""), command)
    return None


def pending(results: Path = RESULTS) -> list[str]:
    """The results of :data:`PENDING` whose file is absent: not made, and published nowhere."""
    return [n for n in PENDING if not (results / f"{n}.json").exists()]


def stale_results(names: tuple[str, ...] = RECORD, results: Path = RESULTS) -> list[Stale]:
    """Every stale result among ``names`` (a pending one, :func:`pending`, is not stale)."""
    waiting = set(pending(results))
    return [s for s in (check(n, results) for n in names if n not in waiting) if s is not None]


def main() -> int:
    stale = stale_results()
    for s in stale:
        print(f"{s.name}: {s.why}\n    made by: {s.command or '-'}")
    waiting = pending()
    for name in waiting:
        print(f"{name}: pending: {PENDING[name]}")
    print(f"{len(RECORD) - len(stale) - len(waiting)} of {len(RECORD)} results of record current"
          + (f", {len(waiting)} pending" if waiting else ""))
    return 1 if stale else 0


if __name__ == "__main__":
    sys.exit(main())
