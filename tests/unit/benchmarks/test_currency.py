"""Results stay current: every result of record was made at or after the last change to the code that
produced it, by a command a user can run in a clone (benchmarks/currency.py); and the check itself
sees a changed module, a moved script and a scratch file."""
from __future__ import annotations

import json
import subprocess

import pytest

from benchmarks import currency


def _shallow() -> bool:
    out = subprocess.run(["git", "rev-parse", "--is-shallow-repository"], cwd=currency.ROOT, capture_output=True, text=True)
    return out.stdout.strip() == "true"


@pytest.mark.skipif(_shallow(), reason="a shallow clone lacks the commits the results were made at")
def test_every_result_of_record_is_current():
    stale = currency.stale_results()
    assert not stale, "\n".join(f"{s.name}: {s.why} (made by: {s.command})" for s in stale)


def test_the_code_of_a_result_is_its_script_and_every_module_it_imports():
    code = currency.code_of("benchmarks/experiments/e2_push.py")
    assert {"benchmarks/experiments/e2_push.py", "acnmp_core/experiments/push.py", "acnmp_core/model/cnmp.py",
            "acnmp_core/adaptation/loop.py", "acnmp_core/sim/planar_arm.py"} <= set(code)
    assert not any(f.startswith("services/learner") for f in code)
    assert currency.script_of("benchmarks/experiments/peers.py --part 1/2") == "benchmarks/experiments/peers.py"
    assert currency.outside_paths("x.py --out /elsewhere/a.json --in benchmarks/results/b.json") == ["/elsewhere/a.json"]


@pytest.mark.skipif(_shallow(), reason="a shallow clone lacks the commits the results were made at")
def test_a_result_is_stale_after_its_code_changes_or_when_its_command_cannot_be_run(tmp_path):
    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=currency.ROOT, capture_output=True, text=True).stdout.strip()
    first = subprocess.run(["git", "rev-list", "--max-parents=0", "HEAD"], cwd=currency.ROOT, capture_output=True,
                           text=True).stdout.split()[0]

    def result(name, command, commit):
        (tmp_path / f"{name}.json").write_text(json.dumps({"provenance": {"command": command, "commit": commit}}))
        return currency.check(name, tmp_path)

    assert result("now", "benchmarks/experiments/e2_push.py", head) is None
    assert "changed since" in result("old", "benchmarks/experiments/e2_push.py", first).why
    assert "not in the repository" in result("moved", "benchmarks/e2_push.py", head).why
    assert "outside the repository" in result("scratch", "benchmarks/experiments/e2_push.py --out /tmp/x.json", head).why
    assert "does not descend" in result("foreign", "benchmarks/experiments/e2_push.py", "0" * 40).why
    assert currency.check("missing", tmp_path).why == "no result file"
    # a merge made at HEAD of parts made before its code changed is as old as its parts
    (tmp_path / "merged.json").write_text(json.dumps({"provenance": {"command": "benchmarks/experiments/peers.py",
                                                                     "commit": head},
                                                      "parts": [{"provenance": {"commit": first}}]}))
    assert "changed since" in currency.check("merged", tmp_path).why


def test_a_pending_result_is_published_nowhere(monkeypatch):
    """A result of record not made at this commit (currency.PENDING, its file absent) is no stale
    result only as long as no block of any page reads it: each block says it is pending instead."""
    from benchmarks import report, report_kit

    waiting = set(currency.pending())
    read: list[str] = []
    where = report_kit.result_path
    monkeypatch.setattr(report_kit, "result_path", lambda name: (read.append(name), where(name))[1])
    for page in report.pages():
        for m in report.BLOCK.finditer(page.read_text()):
            report.RENDERERS[m.group(2)]()
    assert not waiting & set(read)


def test_a_pending_result_is_checked_once_its_file_exists(tmp_path):
    assert currency.pending(tmp_path) == list(currency.PENDING)
    assert currency.stale_results(tuple(currency.PENDING), tmp_path) == []
    for name in currency.PENDING:
        (tmp_path / f"{name}.json").write_text(json.dumps({"provenance": {"command": "x.py", "commit": "0" * 40}}))
    assert currency.pending(tmp_path) == []
    assert {s.name for s in currency.stale_results(tuple(currency.PENDING), tmp_path)} == set(currency.PENDING)
