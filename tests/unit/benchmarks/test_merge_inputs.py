"""Merging earlier benchmark results: a bad input file is a one-line error, not a traceback."""
import pytest

from benchmarks.experiments.e3_budget import main


@pytest.mark.parametrize("flag", ["--combine", "--combine-seeds"])
@pytest.mark.parametrize("content", [None, "{"])
def test_e3_budget_refuses_a_missing_or_broken_result_in_one_line(tmp_path, flag, content):
    src = tmp_path / "earlier.json"
    if content is not None:
        src.write_text(content)
    with pytest.raises(SystemExit) as exit_:  # a message: Python prints it as one line and exits 1
        main([flag, str(src), "--out", str(tmp_path / "merged.json")])
    message = exit_.value.code
    assert isinstance(message, str) and message.startswith("e3_budget.py: cannot read an earlier result:")
    assert "\n" not in message
    assert not (tmp_path / "merged.json").exists()
