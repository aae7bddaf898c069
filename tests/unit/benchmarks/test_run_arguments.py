"""The benchmarks' mains read the options of a run as ``acnmp experiment`` does (one preamble,
clients/experiments/common.py's add_run_arguments)."""
from __future__ import annotations

import pytest

from benchmarks._results import RESULTS, benchmark_args, study_results


def test_seeds_are_a_count_or_the_seeds_themselves_as_in_acnmp_experiment():
    assert benchmark_args("E.", "e", [], seeds=5).seeds == [0, 1, 2, 3, 4]
    assert benchmark_args("E.", "e", ["--seeds", "3"], seeds=5).seeds == [0, 1, 2]
    assert benchmark_args("E.", "e", ["--seeds", "3,7-8"], seeds=5).seeds == [3, 7, 8]


def test_a_bad_value_is_refused_in_one_line_naming_the_option(capsys):
    with pytest.raises(SystemExit) as exc:
        benchmark_args("E.", "e", ["--jobs", "0"], jobs=2)
    assert exc.value.code == 2 and "--jobs" in capsys.readouterr().err


def test_out_defaults_to_the_product_results_or_the_study_folder_and_is_also_spelled_json():
    assert benchmark_args("E.", "e", [], seeds=1).out == str(RESULTS / "e.json")
    assert benchmark_args("E.", "e", [], results=study_results("e3_wall")).out.endswith(
        "benchmarks/studies/e3_wall/results/e.json")
    assert benchmark_args("E.", "e", ["--json", "x.json"]).out == "x.json"


def test_every_other_option_states_its_meaning_and_default(capsys):
    with pytest.raises(SystemExit):
        benchmark_args("E.", "e", ["--help"], train_steps=(400, "CNMP training steps"))
    assert "CNMP training steps (default 400)" in " ".join(capsys.readouterr().out.split())
