"""Merging earlier benchmark results: a bad input file is a one-line error, not a traceback."""
import subprocess
import sys

import pytest
from tests.paths import ROOT



@pytest.mark.parametrize("flag", ["--combine", "--combine-seeds"])
@pytest.mark.parametrize("content", [None, "{"])
def test_e3_budget_refuses_a_missing_or_broken_result_in_one_line(tmp_path, flag, content):
    src = tmp_path / "earlier.json"
    if content is not None:
        src.write_text(content)
    out = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "experiments" / "e3_budget.py"), flag, str(src),
                          "--out", str(tmp_path / "merged.json")], capture_output=True, text=True, timeout=120)
    assert out.returncode == 1
    assert out.stderr.strip().startswith("e3_budget.py: cannot read an earlier result:")
    assert "Traceback" not in out.stderr and len(out.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "merged.json").exists()
