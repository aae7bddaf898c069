"""The ``acnmp`` command line's argument checks: a bad value is refused while parsing, with
argparse's error naming the option and exit code 2, before anything is imported or started
(no deployment needed)."""
from __future__ import annotations

import argparse

import pytest

from clients.cli import main
from services.transport.argtypes import MAX_INT, int_at_least, non_empty, seconds

HUGE = "99999999999999999999"


def refused(argv: list[str], capsys) -> str:
    """Run ``acnmp argv``; assert argparse refused it (exit 2); return its last stderr line."""
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    assert exit_.value.code == 2
    return capsys.readouterr().err.strip().splitlines()[-1]


def test_shared_types_have_bounds():
    assert int_at_least(1)("3") == 3 and int_at_least(0)(str(MAX_INT)) == MAX_INT
    assert seconds()("0.5") == 0.5 and seconds(zero=True)("0") == 0.0
    for parse, text in [(int_at_least(1), "0"), (int_at_least(0), HUGE), (int_at_least(0), "1.5"),
                        (seconds(), "0"), (seconds(), "nan"), (seconds(), "inf"), (seconds(), "1e300"),
                        (seconds(zero=True), "-1"), (non_empty, ""), (non_empty, "  ")]:
        with pytest.raises(argparse.ArgumentTypeError):
            parse(text)


@pytest.mark.parametrize("argv, option", [
    (["experiment", "viapoint", "--seed", HUGE], "--seed"),          # was: Overflow when unpacking long long
    (["experiment", "wall", "--seed", HUGE], "--seed"),
    (["query", "predict", "--obs", "0:0", "--steps", HUGE], "--steps"),  # was: sent, cannot encode message
    (["query", "predict", "--obs", "0:0", "--samples", HUGE], "--samples"),
    (["query", "predict", "--obs", "0:0", "--seed", HUGE], "--seed"),
    (["query", "info", "--timeout", "1e300"], "--timeout"),           # was: negative timeout
    (["status", "--timeout", "-1"], "--timeout"),                     # was: negative timeout, exit 2 unnamed
    (["status", "--timeout", "nan"], "--timeout"),
])
def test_out_of_range_values_are_refused_naming_the_option(argv, option, capsys):
    assert option in refused(argv, capsys)
