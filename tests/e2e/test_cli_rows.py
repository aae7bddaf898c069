"""The ``acnmp`` command line tried as a new user would (issue 12, item 7): each mistake ends in one
line on stderr and a nonzero exit, never a traceback. Run as a real child process
(``python -m clients.cli``), as a shell runs it."""
from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from services.recording.events import rollout_event
from services.recording.rrd_writer import RrdWriter
from services.transport import loopback_endpoint
from tests.paths import ROOT



def acnmp(*argv: str, stdout=subprocess.PIPE) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT), RERUN_ANALYTICS="0")
    env.pop("ACNMP_TRACEBACK", None)
    return subprocess.run([sys.executable, "-m", "clients.cli", *argv], cwd=ROOT, env=env, stdout=stdout,
                          stderr=subprocess.PIPE, text=True, timeout=120)


@pytest.fixture
def cli(capsys):
    """``cli(*argv)``: the ``acnmp`` command run in this process (no interpreter start-up and imports
    per case) -> a CompletedProcess with its exit code, stdout and stderr. An exception escaping
    ``main`` fails the test, as a traceback would."""
    from clients.cli import main

    def run(*argv: str) -> subprocess.CompletedProcess:
        capsys.readouterr()
        try:
            code = main(list(argv))
        except SystemExit as exc:  # argparse's refusals
            code = exc.code if isinstance(exc.code, int) else 1
        out = capsys.readouterr()
        return subprocess.CompletedProcess(["acnmp", *argv], code, out.out, out.err)

    return run


def one_line_error(out: subprocess.CompletedProcess, *expected: str) -> str:
    """The failure's stderr, checked: nonzero exit, no traceback, one line of its own (argparse
    may print its usage first), containing every ``expected`` text."""
    assert out.returncode != 0, out
    assert "Traceback" not in out.stderr, out.stderr
    last = out.stderr.strip().splitlines()[-1]
    for text in expected:
        assert text in last, out.stderr
    return last


NO_SERVICE = ["--connect", loopback_endpoint(1), "--timeout", "1"]


@pytest.mark.parametrize("argv, expected", [
    (["query", "predict", "-s", "e1", "--obs", "0:nan,2,3", *NO_SERVICE], ["--obs", "finite"]),
    (["query", "predict", "-s", "e1", "--obs", "0:abc", *NO_SERVICE], ["--obs", "'abc'"]),
    (["query", "predict", "-s", "e1", "--obs-json", "@/nonexistent.json", *NO_SERVICE],
     ["--obs-json", "/nonexistent.json", "No such file"]),
    (["query", "predict", "-s", "e1", "--obs-json", "[[0, [1, NaN]]]", *NO_SERVICE], ["--obs-json", "finite"]),
    (["query", "predict", "-s", "e1", "--obs", "0:0,0", "--steps", "0", *NO_SERVICE], ["--steps", ">= 2", "0"]),
    (["query", "predict", "-s", "e1", "--obs", "0:0,0", "--seed", "x", *NO_SERVICE], ["--seed"]),
    (["query", "predict", "-s", "e1", "--obs", "0:0,0", "--task-params", "1,inf", *NO_SERVICE],
     ["--task-params", "finite"]),
    (["query", "info", "-s", "e1", "--connect", "notanendpoint"], ["--connect", "notanendpoint"]),
    (["query", "info", "-s", "e1", "--mode", "client", *NO_SERVICE], ["cannot open zenoh session"]),
    (["query", "info", "-s", "e1", "--timeout", "0"], ["--timeout"]),
])
def test_query_mistakes_are_one_line(cli, argv, expected):
    one_line_error(cli(*argv), *expected)


def test_steps_zero_is_refused_not_silently_100(cli):
    out = cli("query", "predict", "-s", "e1", "--obs", "0:0,0", "--steps", "0", *NO_SERVICE)
    assert out.returncode == 2  # refused while parsing: nothing was sent
    one_line_error(out, "--steps")


def test_replay_of_a_directory_says_so(cli, tmp_path):
    one_line_error(cli("replay", str(tmp_path)), str(tmp_path), "is a directory")
    one_line_error(cli("replay", str(tmp_path / "missing.rrd")), "no such file")


@pytest.mark.parametrize("experiment, option, path, expected", [
    ("viapoint", "--json", "/proc/nope/x.json", "cannot write there"),
    ("viapoint", "--plot", "/proc/nope/x.png", "cannot write there"),
    ("push", "--json", "{tmp}", "is a directory"),
    ("wall", "--json", "/proc/nope/x.json", "cannot write there"),
])
def test_experiment_output_is_checked_before_the_run_starts(cli, tmp_path, experiment, option, path, expected):
    out = cli("experiment", experiment, option, path.format(tmp=tmp_path))
    one_line_error(out, option, expected)
    assert out.stdout == ""  # refused before any work was printed


def test_replay_into_a_closed_pipe_exits_quietly(tmp_path):
    rrd = tmp_path / "r.rrd"
    with RrdWriter(rrd) as writer:
        for i in range(3):
            writer.log_event(rollout_event("j", i, np.zeros((3, 2)), [0, 0.5, 1], [0, 0, 1.0], worker="w"))
    env = dict(os.environ, PYTHONPATH=str(ROOT), RERUN_ANALYTICS="0")
    proc = subprocess.Popen([sys.executable, "-m", "clients.cli", "replay", str(rrd)], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # `| head` that has gone: nobody reads what replay prints
    err = proc.stderr.read().decode()
    proc.wait(timeout=120)
    assert "Traceback" not in err and "BrokenPipe" not in err, err
    assert proc.returncode == 141  # 128 + SIGPIPE, as a shell tool killed by it reports
