"""``acnmp up`` hands the learner's bounds and runner to its learner(s) as ``acnmp serve learner``
takes them, with the same defaults, bounds and one-line errors."""
from __future__ import annotations

import pytest

from clients.cli import build_parser
from clients.commands.up import LEARNER_OPTIONS
from services.learner.config import LearnerOptions
from services.transport.service import handed_on, parser_for


def _up(*argv: str):
    return build_parser().parse_args(["up", *argv])


def test_the_learner_options_are_handed_on_only_when_given():
    assert handed_on(LearnerOptions, _up(), LEARNER_OPTIONS) == []
    args = _up("--max-queued-jobs", "5", "--keep-jobs", "0", "--keep-job-days", "1.5", "--keep-versions", "2",
               "--job-runner", "thread")
    argv = handed_on(LearnerOptions, args, LEARNER_OPTIONS)
    assert dict(zip(argv[::2], argv[1::2])) == {"--max-queued-jobs": "5", "--keep-jobs": "0", "--keep-job-days": "1.5",
                                                "--keep-versions": "2", "--job-runner": "thread"}
    learner = parser_for(LearnerOptions).parse_args(argv)  # what the learner then parses
    assert (learner.max_queued_jobs, learner.keep_jobs, learner.keep_job_days, learner.keep_versions,
            learner.job_runner) == (5, 0, 1.5, 2, "thread")


@pytest.mark.parametrize("argv", [["--max-queued-jobs", "0"], ["--keep-jobs", "-1"], ["--job-runner", "gpu"],
                                  ["--keep-job-days", "soon"]])
def test_a_bad_value_is_a_one_line_error(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        _up(*argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and argv[0] in err


def test_up_starts_its_learner_with_the_options_given(monkeypatch, tmp_path, capsys):
    import threading

    import services.launcher
    import services.transport
    from services.transport.state_dir import StateDirInUse

    started = {}

    class Deployment:  # records what `acnmp up` would start, and stops there
        def __init__(self, *args, **kwargs):
            started.update(kwargs)
            self.children = {}

        def start(self):
            raise StateDirInUse("stopped by the test")

        def stop(self):
            return {}

    monkeypatch.setattr(services.launcher, "LocalDeployment", Deployment)
    monkeypatch.setattr(services.transport, "install_shutdown_handlers", lambda: threading.Event())
    args = _up("--namespace", "upunit", "--state-dir", str(tmp_path), "--no-default-skill", "--keep-jobs", "7",
               "--job-runner", "thread")
    assert args.func(args) == 1
    learner = parser_for(LearnerOptions).parse_args(started["learner_args"])
    assert (learner.keep_jobs, learner.job_runner, learner.max_queued_jobs) == (7, "thread", 100)
