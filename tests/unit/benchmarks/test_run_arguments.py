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


def test_the_defaults_result_goes_beside_the_papers_unless_out_says_otherwise():
    assert benchmark_args("E.", "e", [], recipe=True).out == str(RESULTS / "e.json")
    assert benchmark_args("E.", "e", ["--recipe", "default"], recipe=True).out == str(RESULTS / "e_default.json")
    assert benchmark_args("E.", "e", ["--recipe", "default", "--out", "x.json"], recipe=True).out == "x.json"


def test_a_benchmark_run_of_the_default_writes_its_json_beside_the_papers(tmp_path, monkeypatch, capsys):
    """E1's benchmark at small sizes, once per recipe: the default's JSON lands beside the paper's,
    with the same layout, and records its recipe and the prior each seed's model chose."""
    import json
    from functools import partial

    from acnmp_core.experiments import viapoint
    from benchmarks.experiments import e1_viapoint

    monkeypatch.setattr(e1_viapoint, "RESULTS", tmp_path)
    monkeypatch.setattr(e1_viapoint, "BUDGET", 3)
    monkeypatch.setattr(e1_viapoint, "TRAIN_STEPS", 50)
    monkeypatch.setattr(e1_viapoint, "run_viapoint", partial(viapoint.run_viapoint, assimilation_steps=50))
    for argv in ([], ["--recipe", "default"]):
        assert e1_viapoint.main(["--seeds", "1", "--figure-seed", "9", *argv]) == 0
    paper, default = (json.loads((tmp_path / f"{n}.json").read_text()) for n in ("e1_viapoint", "e1_viapoint_default"))
    assert sorted(paper) == sorted(default) and sorted(paper["runs"][0]) == sorted(default["runs"][0])
    assert paper["recipe"] == {"name": "paper", "prior": "none"} and default["recipe"] == {"name": "default", "prior": "auto"}
    assert paper["runs"][0]["model"]["prior"] == "none" and default["runs"][0]["model"]["prior"] in ("none", "linear")
    # the settings recorded are each recipe's: the paper's batch iterations, the default's mean first
    assert paper["config"]["adapt"]["acnmp"]["mean_first"] is False and default["config"]["adapt"]["acnmp"]["mean_first"]
    capsys.readouterr()
