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
    """Run ``acnmp argv``; assert it was refused with exit code 2 and one line on stderr; return it."""
    assert main(argv) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and captured.out == "", captured
    return lines[0]


@pytest.mark.parametrize("argv, expected", [
    (["bogus"], ["invalid choice: 'bogus'", "(see acnmp --help)"]),
    (["experiment"], ["required: NAME"]),
    (["experiment", "viapoint", "--seed", "-1"], ["argument --seed: expected an integer >= 0, got -1",
                                                  "(see acnmp experiment viapoint --help)"]),
    (["experiment", "push", "--setting", "x"], ["--setting", "'paper', 'authors'"]),
    (["query", "cancel"], ["required: JOB"]),
    (["serve", "worker", "--robot", "ur11"], ["--robot", "'point2d'"]),
])
def test_argparse_mistakes_are_one_line_and_exit_2(argv, expected, capsys):
    """Not argparse's usage block and a SystemExit: one line, and main returns 2 as for any bad value."""
    line = refused(argv, capsys)
    for text in expected:
        assert text in line


def test_help_still_exits_0(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["experiment", "viapoint", "--help"])
    assert exit_.value.code == 0 and "--seed" in capsys.readouterr().out


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
