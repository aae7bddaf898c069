"""What a command line start imports: `acnmp --help`, every command's parser, the launcher of
`acnmp up` and a worker stay clear of torch and rerun (seconds of CPU each, paid by every command a
user types and every process a deployment starts); only the processes that compute import them."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.paths import ROOT

HEAVY = ("torch", "rerun")


def _imported(code: str) -> dict[str, bool]:
    """Run ``code`` in a fresh interpreter; which of :data:`HEAVY` it imported."""
    probe = f"{code}\nimport json, sys\nprint(json.dumps({{m: m in sys.modules for m in {HEAVY!r}}}))"
    out = subprocess.run([sys.executable, "-c", probe], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.splitlines()[-1])


@pytest.mark.parametrize("code", [
    "from clients.cli import build_parser; build_parser()",  # acnmp --help, acnmp status, acnmp query ...
    "import services.launcher.deployment, clients.default_skill, clients.commands.up",  # acnmp up's launcher
    "from services.launcher import options_class, PROCESSES; [options_class(n) for n in PROCESSES]",
    "import services.worker.service",
], ids=["parser", "launcher", "options", "worker"])
def test_a_command_line_start_imports_neither_torch_nor_rerun(code):
    assert _imported(code) == {"torch": False, "rerun": False}

