"""``acnmp query``'s own parsing: help texts and observation syntax (no deployment needed)."""
from __future__ import annotations

import numpy as np
import pytest

from clients.cli import main
from clients.commands.common import parse_obs, parse_obs_json


def test_query_help_explains_the_observation_syntax(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["query", "predict", "--help"])
    out = capsys.readouterr().out
    assert exit_.value.code == 0
    for text in ("--obs", "--obs-json", "--task-params", "--steps", "--json", "--connect", "_ for a dimension"):
        assert text in out


def test_obs_parsers():
    t, v, m = parse_obs(["0:1,_", "0.5:2,3"])
    np.testing.assert_array_equal(t, [0.0, 0.5])
    np.testing.assert_array_equal(v, [[1.0, 0.0], [2.0, 3.0]])
    np.testing.assert_array_equal(m, [[True, False], [True, True]])
    t2, v2, m2 = parse_obs_json("[[0, [1, null]], [0.5, [2, 3]]]")
    np.testing.assert_array_equal(v2, v)
    np.testing.assert_array_equal(m2, m)
    with pytest.raises(ValueError):
        parse_obs(["0:1", "1:1,2"])


@pytest.mark.parametrize("bad, option", [(lambda: parse_obs(["0:nan,1"]), "--obs"), (lambda: parse_obs(["x:1"]), "--obs"),
                                         (lambda: parse_obs_json("[[0, [Infinity]]]"), "--obs-json"),
                                         (lambda: parse_obs_json("[[0, "), "--obs-json"),
                                         (lambda: parse_obs_json("@/nonexistent.json"), "--obs-json")])
def test_obs_parsers_name_the_option_and_refuse_non_finite_values(bad, option):
    with pytest.raises(ValueError, match=option):
        bad()


def test_experiment_outputs_are_checked_where_they_will_be_written(tmp_path):
    from clients.experiments.common import check_output_path

    check_output_path(str(tmp_path / "new" / "r.json"), "--json")  # parents are created, no file left
    assert (tmp_path / "new").is_dir() and not (tmp_path / "new" / "r.json").exists()
    for path, text in [(str(tmp_path), "is a directory"), ("/proc/nope/x.json", "cannot write there")]:
        with pytest.raises(ValueError, match=f"--json {path}: {text}"):
            check_output_path(path, "--json")


def test_a_predict_request_with_both_query_times_and_n_steps_is_refused_before_it_is_sent():
    from clients.client import predict_request

    with pytest.raises(ValueError, match="query_times and n_steps"):
        predict_request([0.0], [[0.0, 0.0]], query_times=np.linspace(0, 1, 50), n_steps=10)
    assert predict_request([0.0], [[0.0, 0.0]], n_steps=10)["n_steps"] == 10
