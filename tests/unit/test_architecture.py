"""The architecture as a checked contract: ``lint-imports`` (import-linter, pinned in the test
extras) with the contracts of pyproject.toml: clients/benchmarks above services above the library,
the library free of zenoh, rerun and everything above it, the services wings each leaning only on
the wings below it."""
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
    assert "3 kept, 0 broken" in out.stdout, out.stdout
