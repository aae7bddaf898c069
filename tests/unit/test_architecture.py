"""The architecture as a checked contract: ``lint-imports`` (import-linter, pinned in the test
extras) with the contracts of pyproject.toml: clients/benchmarks above services above the library,
the library free of zenoh, rerun and everything above it, the library's own layers (experiments above
jobs above robots above tasks above the physics worlds above the learning, the model and the data),
the services wings each leaning only on the wings below it; and no import cycle among the project's
modules."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path
from tests.paths import ROOT



def _lint_imports() -> str:
    beside = Path(sys.executable).with_name("lint-imports")
    found = str(beside) if beside.exists() else shutil.which("lint-imports")
    assert found, "lint-imports is missing: install the test extras (pip install -e '.[test]')"
    return found


def test_import_contracts_are_kept():
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    out = subprocess.run([_lint_imports(), "--no-cache"], cwd=ROOT, env=env, capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "4 kept, 0 broken" in out.stdout, out.stdout


def _cycles(imports: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module of the graph ``imports``
    (module -> the modules it imports), each sorted: the import cycles (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    for root in sorted(imports):
        if root in index:
            continue
        work = [(root, iter(sorted(imports[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            v, children = work[-1]
            w = next(children, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(imports[w]))))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                component = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    component.append(w)
                    if w == v:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def test_cycles_are_found():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycle_among_the_projects_modules():
    """Every import counts (also those inside functions and under TYPE_CHECKING): a cycle means two
    modules that cannot be understood, tested or moved apart."""
    import grimp

    packages = ("acnmp_core", "services", "clients", "benchmarks")
    graph = grimp.build_graph(*packages, cache_dir=None)
    imports = {m: {i for i in graph.find_modules_directly_imported_by(m) if i.split(".")[0] in packages} - {m}
               for m in graph.modules if m.split(".")[0] in packages}
    assert _cycles(imports) == []
