"""The ``acnmp`` command line's argument checks: a bad value is refused while parsing, with
argparse's error naming the option and exit code 2, before anything is imported or started
(no deployment needed)."""
from __future__ import annotations

import argparse

import pytest

from clients.cli import main
from clients.experiments.catalog import CATALOG
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
    (["experiment", "viapoint", "--seeds", "-1"], ["argument --seeds: expected a count N (seeds 0..N-1) or the seeds",
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
    (["experiment", "viapoint", "--seeds", HUGE], "--seeds"),        # was: Overflow when unpacking long long
    (["experiment", "wall", "--seeds", f"{HUGE}-{HUGE}"], "--seeds"),
    (["experiment", "wall", "--seed", HUGE], "--seed"),              # the old spelling, still understood
    (["query", "predict", "--obs", "0:0", "--steps", HUGE], "--steps"),  # was: sent, cannot encode message
    (["query", "predict", "--obs", "0:0", "--samples", HUGE], "--samples"),
    (["query", "predict", "--obs", "0:0", "--seed", str(2**64)], "--seed"),  # the wire's uint64 holds 2**64 - 1
    (["query", "info", "--timeout", "1e300"], "--timeout"),           # was: negative timeout
    (["status", "--timeout", "-1"], "--timeout"),                     # was: negative timeout, exit 2 unnamed
    (["status", "--timeout", "nan"], "--timeout"),
])
def test_out_of_range_values_are_refused_naming_the_option(argv, option, capsys):
    assert option in refused(argv, capsys)


@pytest.mark.parametrize("argv, option", [
    (["experiment", "push", "--acnmp-budget", "0"], "--acnmp-budget"),  # was: silently the default, 300
    (["experiment", "push", "--promp-budget", "0"], "--promp-budget"),  # was: silently the default, 1500
    (["experiment", "push", "--seeds", HUGE], "--seeds"),           # was: OverflowError, exit 1
    (["experiment", "ur10", "--seeds", HUGE], "--seeds"),
    (["experiment", "pour", "--train-steps", HUGE], "--train-steps"),
    (["experiment", "transfer", "--seeds", HUGE], "--seeds"),
    (["experiment", "wall", "--envs", HUGE], "--envs"),            # was: "Maximum allowed dimension exceeded"
    (["experiment", "wall", "--test", "0"], "--test"),
    (["experiment", "viapoint", "--distributed", "--workers", "0"], "--workers"),
])
def test_experiment_counts_are_checked_while_parsing(argv, option, capsys):
    assert option in refused(argv, capsys)


def test_push_quick_keeps_the_options_given(monkeypatch):
    """--quick sets what was not given: an explicit --train-steps was silently replaced by 1500."""
    import acnmp_core.experiments.push as push

    seen = {}

    def fake_run_push(seeds, **kwargs):
        seen.update(kwargs, seeds=seeds)
        raise KeyboardInterrupt  # stop before printing a result

    monkeypatch.setattr(push, "run_push", fake_run_push)
    assert main(["experiment", "push", "--quick", "--train-steps", "200", "--quiet"]) == 130
    assert seen["train_steps"] == 200 and seen["adapt_config"].max_rollouts == 60
    assert main(["experiment", "push", "--quick", "--quiet"]) == 130 and seen["train_steps"] == 1500
    assert main(["experiment", "push", "--quiet"]) == 130 and seen["train_steps"] == 3000


@pytest.mark.parametrize("argv, option", [
    (["experiment", "viapoint", "--fresh"], "--fresh"),               # was: ignored, E1 ran in-process
    (["experiment", "viapoint", "--namespace", "lab"], "--namespace"),
    (["experiment", "viapoint", "--distributed", "--namespace", "lab", "--fresh"], "--fresh"),
])
def test_viapoint_deployment_options_need_distributed(argv, option, monkeypatch, capsys):
    import acnmp_core.experiments.viapoint as viapoint

    def must_not_run(**kwargs):
        raise AssertionError("E1 started despite the mistake")

    monkeypatch.setattr(viapoint, "run_viapoint", must_not_run)
    assert option in refused(argv, capsys)


@pytest.mark.parametrize("argv, option", [
    (["credentials", ""], "DIR"),                          # was: nine secret files written into the cwd
    (["experiment", "viapoint", "--json", ""], "--json"),  # was: E1 ran and saved nothing
    (["experiment", "wall", "--plot", " "], "--plot"),
    (["experiment", "ur10", "--distributed", "--record", ""], "--record"),
    (["up", "--state-dir", ""], "--state-dir"),            # was: silently runs/<namespace>/state
    (["up", "--record", ""], "--record"),
])
def test_empty_file_names_are_refused(argv, option, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert option in refused(argv, capsys)
    assert list(tmp_path.iterdir()) == []


def test_query_cancel_uses_the_operator_credentials(monkeypatch, capsys):
    """The router's ACL lets only the operator cancel: with the client's credentials (what every
    other `acnmp query` uses) the cancel was dropped and ended `unavailable` after the timeout."""
    import clients.client

    roles = []

    class FakeClient:
        def __init__(self, namespace, *, role, **kwargs):
            roles.append(role)

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            pass

        def cancel(self, job):
            return {"job": job, "state": "cancelled"}

        def skills(self):
            return ["e1"]

        def model_services(self):
            return 1

    monkeypatch.setattr(clients.client, "ACNMPClient", FakeClient)
    assert main(["query", "cancel", "e1-0123"]) == 0
    assert capsys.readouterr().out == "job e1-0123: cancelled\n"
    assert main(["query", "skills"]) == 0
    assert roles == ["operator", "client"]


@pytest.mark.parametrize("argv, expected", [
    (["up", "--demos", "e1"], ["--demos", "SKILL=FILE.npz"]),
    (["up", "--demos", "e1=/nonexistent/d.npz"], ["--demos e1=/nonexistent/d.npz", "cannot read"]),
    (["up", "--demos", "a/b=d.npz"], ["--demos a/b=d.npz", "not a valid name"]),
    (["up", "--record", "."], ["--record .", "is a directory"]),
    (["up", "--record", "/proc/nope/r.rrd"], ["--record /proc/nope/r.rrd", "cannot write there"]),
    (["up", "--namespace", "a b"], ["--namespace", "'a b'"]),
    (["up", "--workers", "-1"], ["--workers"]),
])
def test_up_checks_its_arguments_before_starting_anything(argv, expected, tmp_path, monkeypatch, capsys):
    """A bad --demos started the deployment, the learner exited 2 at its start and was restarted
    again and again while `acnmp up` said "deployment is up"; a bad --record was a RuntimeError
    once the recorder had exited; a bad namespace had left runs/<namespace>/state behind."""
    import services.launcher

    def must_not_start(*args, **kwargs):
        raise AssertionError("the deployment was started despite the mistake")

    monkeypatch.setattr(services.launcher, "LocalDeployment", must_not_start)
    monkeypatch.chdir(tmp_path)
    line = refused(argv, capsys)
    for text in expected:
        assert text in line
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name, content", [
    ("notes.txt", b"time,x\n0,1\n"),            # a text file: was "This file contains pickled (object) data"
    ("one.npy", None),                            # a single .npy array, not an archive of them
    ("empty.npz", b""),
])
def test_a_demos_file_that_is_no_npz_is_named_in_one_line(name, content, tmp_path, monkeypatch, capsys):
    """Issue 36, row 9: `--demos x=textfile` said numpy's "This file contains pickled (object)
    data ..."; it says the file is not a demonstrations .npz, and which."""
    import numpy as np

    import services.launcher

    def must_not_start(*args, **kwargs):
        raise AssertionError("the deployment was started despite the mistake")

    monkeypatch.setattr(services.launcher, "LocalDeployment", must_not_start)
    path = tmp_path / name
    if content is None:
        np.save(path, np.zeros((2, 3)))
    else:
        path.write_bytes(content)
    line = refused(["up", "--demos", f"x={path}"], capsys)
    assert f"not a demonstrations .npz: {path}" in line and "pickle" not in line


def test_a_good_demos_value_passes_the_check(tmp_path):
    from clients.default_skill import default_demos
    from services.learner.config import load_demos_spec

    spec = default_demos(tmp_path)  # e1=<tmp>/e1-demos.npz
    assert len(load_demos_spec(spec).to_demo_set()) == 6


@pytest.mark.parametrize("argv, option", [
    (["serve", "model", "--workers", "0"], "--workers"),      # was: answered on zenoh's own threads
    (["serve", "model", "--max-queue", "0"], "--max-queue"),  # was: every predict answered 'overloaded'
    (["serve", "model", "--batch-window", "nan"], "--batch-window"),
    (["serve", "model", "--batch-threads", "0"], "--batch-threads"),
    (["serve", "learner", "--train-steps", "0"], "--train-steps"),
    (["serve", "learner", "--chunk-timeout", "nan"], "--chunk-timeout"),
    (["serve", "learner", "--chunk-timeout", "-1"], "--chunk-timeout"),
    (["serve", "learner", "--wait-recorder", "-5"], "--wait-recorder"),
    (["serve", "learner", "--max-rollouts", "0"], "--max-rollouts"),
    (["serve", "learner", "--max-train-steps", "-1"], "--max-train-steps"),
    (["serve", "worker", "--delay", "inf"], "--delay"),
    (["serve", "recorder", "--out", ""], "--out"),
])
def test_serve_options_are_checked_while_parsing(argv, option, capsys):
    """These started a live process with the bad value (`acnmp serve ...` is what compose runs)."""
    assert option in refused(argv, capsys)


def test_the_recorder_refuses_a_directory_before_rerun_opens_it(tmp_path):
    """Was: rerun's RuntimeError, then its warning at exit: two lines."""
    from services.recording.recorder import RecorderConfig

    with pytest.raises(ValueError, match=f"--out {tmp_path}: is a directory"):
        RecorderConfig(out=str(tmp_path)).serve(None, None, None)


def test_replay_of_a_device_says_what_it_is(capsys):
    assert main(["replay", "/dev/null"]) == 1  # was: "/dev/null: no such file"
    assert capsys.readouterr().err == "acnmp replay: /dev/null: not a regular file, not a recording\n"


@pytest.mark.parametrize("text, expected", [("{ mode: 'x' ", "line:column 1:9: expected boolean or null"),
                                            (None, "No such file or directory")])
def test_a_bad_zenoh_config_file_is_one_line_naming_config(text, expected, tmp_path, capsys):
    """Was: "zenoh config F:" and zenoh's six-line drawing of a syntax error, with a Rust source path."""
    path = tmp_path / "bad.json5"
    if text is not None:
        path.write_text(text)
    line = refused(["query", "info", "--config", str(path)], capsys)
    assert line.startswith(f"acnmp: error: --config {path}: ") and expected in line and ".cargo" not in line


def test_a_plot_format_matplotlib_cannot_write_is_refused_before_the_run(tmp_path, monkeypatch, capsys):
    """Was: the whole run, then "Format 'txt' is not supported" when the figure was saved."""
    import acnmp_core.experiments.viapoint as viapoint

    def must_not_run(**kwargs):
        raise AssertionError("E1 started despite the mistake")

    monkeypatch.setattr(viapoint, "run_viapoint", must_not_run)
    plot = tmp_path / "e1.txt"
    line = refused(["experiment", "viapoint", "--plot", str(plot)], capsys)
    assert f"--plot {plot}: matplotlib cannot write .txt files" in line and ".png" in line


@pytest.mark.parametrize("argv, option", [
    (["--listen", "garbage"], "--listen"),  # was: written into router.json5; the router failed at its start
    (["--connect", ""], "--connect"),
    (["--tls", ""], "--tls"),
])
def test_credentials_checks_the_endpoints_it_writes(argv, option, tmp_path, capsys):
    assert option in refused(["credentials", str(tmp_path / "secrets"), *argv], capsys)
    assert not (tmp_path / "secrets").exists()


def test_obs_and_obs_json_are_one_or_the_other(capsys):
    """Was: --obs-json used and the --obs given beside it silently dropped."""
    line = refused(["query", "predict", "--obs", "0:0,0", "--obs-json", "[[1, [1, 0]]]"], capsys)
    assert "--obs-json: not allowed with argument --obs" in line


def test_query_help_names_every_sub_command(capsys):
    """Was: "query a running model service (predict, info, skills)": no transfer, and cancel asks the learner."""
    with pytest.raises(SystemExit):
        main(["--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "query ask a running deployment (predict, transfer, info, skills; train, adapt, jobs, watch, cancel)" in out


def test_query_seed_takes_what_the_wire_takes():
    from clients.cli import build_parser

    args = build_parser().parse_args(["query", "predict", "--obs", "0:0", "--seed", str(2**64 - 1)])
    assert args.seed == 2**64 - 1


def test_up_refuses_a_running_namespace_before_touching_the_state_directory(tmp_path, monkeypatch, capsys):
    """`acnmp up -n NS --state-dir NEW` while NS runs was refused only after NEW/e1-demos.npz and
    NEW/deployment.lock had been written; now nothing is written and nothing started."""
    import os

    import services.launcher
    from services.transport.runfile import RunFile

    def must_not_start(*args, **kwargs):
        raise AssertionError("the deployment was started despite the running namespace")

    monkeypatch.setenv("ACNMP_RUNTIME_DIR", str(tmp_path / "runtime"))
    RunFile("lab", "tcp/127.0.0.1:1", os.getppid()).write()  # a live process (pytest's parent) announced "lab"
    monkeypatch.setattr(services.launcher, "LocalDeployment", must_not_start)
    new = tmp_path / "new-state"
    assert main(["up", "--namespace", "lab", "--state-dir", str(new)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "namespace 'lab' is already running" in err[0]
    assert not new.exists()


def test_a_service_started_as_a_module_refuses_a_bad_option_in_one_line(capsys):
    """``python -m services.<wing>`` parses with the same one-line parser as ``acnmp``."""
    from services.model.service import ModelConfig
    from services.transport.service import main as service_main

    for argv, expected in [(["--bogus"], "unrecognized arguments: --bogus"),
                           (["--workers", "0"], "argument --workers: expected an integer >= 1, got 0")]:
        assert service_main(ModelConfig, argv) == 2
        captured = capsys.readouterr()
        lines = captured.err.strip().splitlines()
        assert len(lines) == 1 and expected in lines[0] and "usage:" not in captured.err, captured


@pytest.mark.parametrize("argv, expected", [
    (["--obs", "0:0.1,0.2", "--times", "1,,2"], "--times '1,,2': an empty entry"),
    (["--obs", "0:0.1,0.2", "--times", "0,1,"], "--times '0,1,': an empty entry"),
    (["--obs", "0:0.1,0.2", "--task-params", ",0.3"], "--task-params ',0.3': an empty entry"),
    (["--obs-json", "[[0, [true, 0.1]]]"], "--obs-json: true is not a number"),
    (["--obs-json", '[["0.5", [0.1, 0.2]]]'], '--obs-json: "0.5" is not a number'),
])
def test_query_predict_refuses_what_is_not_a_list_of_numbers(argv, expected, capsys):
    """Checked before any session is opened (no deployment runs here)."""
    assert expected in refused(["query", "predict", *argv], capsys)


def test_an_output_that_is_not_a_regular_file_is_refused_before_the_run(capsys):
    """/dev/full opens for writing; every write then fails: a result of minutes would be lost."""
    assert "--json /dev/full: not a regular file" in refused(["experiment", "viapoint", "--json", "/dev/full"], capsys)


#: What each experiment needs besides --seeds to parse.
REQUIRED = {"robot": ["--robot", "point2d", "--demos", "d.npz", "--at", "0.5"]}


@pytest.mark.parametrize("name", [e.name for e in CATALOG])
def test_every_experiment_takes_seeds_with_one_meaning(name, capsys):
    """One seed option across `acnmp experiment`: --seeds N is seeds 0..N-1, --seeds A-B and lists
    name the seeds; the spellings an experiment had before (viapoint and wall --seed S, transfer
    --runs N) still parse to the same list, and the help shows --seeds only."""
    from clients.cli import build_parser
    from clients.experiments.common import seed_list

    def seeds(*argv: str) -> list[int]:
        return seed_list(build_parser().parse_args(["experiment", name, *REQUIRED.get(name, []), *argv]), 7)

    assert seeds() == list(range(7))  # not given: the experiment's default count
    assert seeds("--seeds", "3") == [0, 1, 2]
    assert seeds("--seeds", "5-7") == [5, 6, 7] and seeds("--seeds", "9,0-1") == [9, 0, 1]
    old = {"viapoint": ("--seed", "4", [4]), "wall": ("--seed", "4", [4]), "transfer": ("--runs", "2", [0, 1])}
    if name in old:
        flag, value, want = old[name]
        assert seeds(flag, value) == want
    with pytest.raises(SystemExit):
        build_parser().parse_args(["experiment", name, "--help"])
    text = capsys.readouterr().out
    assert "--seeds SEEDS" in text and "--seed " not in text and "--runs" not in text


@pytest.mark.parametrize("argv, dest, value", [
    (["query", "predict", "--skill", "e1", "--obs", "-5:0,0"], "obs", ["-5:0,0"]),
    (["query", "predict", "--skill", "e1", "--obs", "-.5:0,0", "--obs", "1:-2,3"], "obs", ["-.5:0,0", "1:-2,3"]),
    (["query", "predict", "--skill", "e1", "--obs", "0:0,0", "--task-params", "-1,2"], "task_params", "-1,2"),
])
def test_a_value_starting_with_a_minus_and_a_digit_is_a_value(argv, dest, value):
    """``--obs -5:0,0`` was read as an unknown option -5:0,0 (only ``--obs=-5:0,0`` worked)."""
    from clients.cli import build_parser

    assert getattr(build_parser().parse_args(argv), dest) == value


def test_an_unknown_option_is_still_refused(capsys):
    assert "unrecognized arguments: -x" in refused(["query", "predict", "--skill", "e1", "--obs", "0:0,0", "-x"], capsys)


def _parsers(parser: argparse.ArgumentParser, name: str = "acnmp"):
    """``(command, parser)`` of ``parser`` and of every sub-command under it."""
    yield name, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub, child in action.choices.items():
                yield from _parsers(child, f"{name} {sub}")


def test_every_help_example_keeps_its_line_breaks():
    """An example continued with a backslash stays on two lines in `--help` (issue 72: a ``\\`` at
    a line's end inside a plain string joined the lines, `--split topic:/goal       --trajectory ...`
    came out as one 182-column line): no example line is wider than 120 columns, none holds the
    indentation of a line it swallowed."""
    import re

    from clients.cli import build_parser

    bad = [f"{name}: {line.strip()[:60]}" for name, parser in _parsers(build_parser())
           for line in (parser.epilog or "").splitlines()
           if len(line) > 120 or re.search(r"\S {3,}--", line)]
    assert not bad, bad
