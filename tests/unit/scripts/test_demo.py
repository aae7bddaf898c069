"""scripts/demo.sh (the README's first command) runs its own deployment whatever else runs
(issue 36, row 1: it attached to a running `acnmp up` and was refused for its --record)."""
from __future__ import annotations

import os
import shlex
import uuid

from clients.cli import build_parser
from clients.experiments.viapoint import _running_deployment
from services.transport.runfile import RUNTIME_ENV, RunFile, find
from tests.paths import ROOT

DEMO = ROOT / "scripts" / "demo.sh"


def demo_experiment_argv() -> list[str]:
    """The arguments demo.sh gives `acnmp` for its experiment (its own extra "$@" left out)."""
    script = DEMO.read_text().replace("\\\n", " ")
    lines = [line for line in script.splitlines() if "acnmp experiment" in line]
    assert len(lines) == 1, lines
    words = shlex.split(lines[0])
    return [w for w in words[words.index("experiment"):] if w != "$@"]


def test_the_demo_starts_its_own_deployment_while_another_one_runs(tmp_path, monkeypatch):
    monkeypatch.setenv(RUNTIME_ENV, str(tmp_path / "run"))
    other = RunFile(f"other-{uuid.uuid4().hex[:8]}", "tcp/127.0.0.1:9", os.getpid())  # alive: our pid
    other.write()
    assert find().namespace == other.namespace  # a running `acnmp up` as the experiment sees it
    args = build_parser().parse_args(demo_experiment_argv())
    assert args.distributed and args.record
    with _running_deployment(args) as client:  # was: ValueError "--record: deployment ... is running"
        assert client is None  # None: a fresh deployment of its own
