"""``acnmp query``'s own parsing: help texts and observation syntax (no deployment needed)."""
from __future__ import annotations

import numpy as np
import pytest

from clients.cli import main
from clients.commands.query import parse_obs, parse_obs_json


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
