"""Issue 31's generated hostile suite, short: hypothesis writes (role, message kind, key expression,
payload) cases against an authenticated deployment; nothing changes outside the access table and
every process answers afterwards (benchmarks/performance/hostile_acl.py; 10,000 cases: benchmarks/performance/bench_acl.py)."""
from __future__ import annotations

import os

import pytest

from benchmarks.performance.hostile_acl import acl_deployment, run_cases

CASES = int(os.environ.get("ACNMP_ACL_CASES", "400"))


@pytest.fixture(scope="module")
def dep(tmp_path_factory):
    with acl_deployment(tmp_path_factory.mktemp("aclgen")) as d:
        yield d


def test_generated_cases_change_nothing_outside_the_table_and_crash_nothing(dep):
    result = run_cases(dep, CASES, batch=100)
    assert result["cases"] >= CASES
    assert result["tally"]["sent"] > CASES // 2  # most generated cases are not legitimate use
    assert result["state_changes"] == 0, result["changes"][:1]
    assert result["crashes"] == 0, result["crashed"]
