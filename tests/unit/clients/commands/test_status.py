"""What an operator reads when something is wrong (issue 49, points 1 and 6): `acnmp status` exits
1 when a process is not healthy (exited, given up, no token, problems it reports) and its help is
whole; the launcher's "exited before going live" names the child's last error line; a learner
refusing a request for its bounds or its disk answers `busy` or `write_failed`."""
from __future__ import annotations

import errno
import os
from pathlib import Path
from types import SimpleNamespace

import pytest

from clients.cli import build_parser
from clients.commands import status
from services.launcher.deployment import ChildExited, last_error_line
from services.learner.core import LearnerBusy
from services.learner.service import _storage_errors
from services.learner.store import StateWriteError
from services.transport.wire import WireError


def _run(monkeypatch, capsys, *procs: status.ProcessHealth) -> tuple[int, str]:
    import services.transport.runfile as runfile

    run = SimpleNamespace(namespace="lab", anchor="tcp/127.0.0.1:1", pid=1, state_dir="/s", credentials="")
    monkeypatch.setattr(runfile, "running", lambda: [run])
    monkeypatch.setattr(status, "process_health", lambda _run, _timeout: list(procs))
    code = status.run(SimpleNamespace(config=None, namespace=None, timeout=0.1, json=False))
    return code, capsys.readouterr().out


def test_status_exits_1_unless_every_process_is_healthy(monkeypatch, capsys):
    ok = status.ProcessHealth("model", 11, True, True, "vm")
    code, out = _run(monkeypatch, capsys, ok)
    assert code == 0 and out.splitlines()[-1].split()[-1] == "ok"
    gave_up = status.ProcessHealth("learner", 12, False, False)  # what a child given up on looks like
    code, out = _run(monkeypatch, capsys, ok, gave_up)
    assert code == 1 and out.splitlines()[-1].split()[-1] == "exited"
    line = "cannot write its state: no space left on device while saving job e1-0 to /s/jobs/e1-0.json"
    sick = status.ProcessHealth("learner", 12, True, True, "vm", (line,))
    code, out = _run(monkeypatch, capsys, ok, sick)
    assert code == 1 and out.splitlines()[-2].split()[-1] == "problems" and out.splitlines()[-1].strip() == line


def test_status_help_is_whole_sentences_and_says_the_exit_codes():
    parser = build_parser()
    sub = next(a for a in parser._actions if getattr(a, "choices", None) and "status" in a.choices)
    description = sub.choices["status"].description  # was cut after "...processes and health; with"
    assert description.endswith("or when none runs.") and "Exit 0" in description and "``" not in description


def test_a_child_that_exits_before_going_live_is_named_with_its_last_error_line(tmp_path):
    log = tmp_path / "learner.log"
    log.write_text("2026-12-04 10:00:00,000 learner INFO starting\n"
                   "2026-12-04 10:00:01,000 learner WARNING quarantined skills/e1/model-v3.pt: not a readable checkpoint\n"
                   "acnmp serve learner: error: --demos e1=/x.npz: path: not a demonstrations .npz: /x.npz\n"
                   "\n")
    exc = ChildExited("learner", 2, log)
    first = str(exc).splitlines()[0]
    assert first == (f"learner exited with code 2 before going live: acnmp serve learner: error: --demos e1=/x.npz: "
                     f"path: not a demonstrations .npz: /x.npz (log {log})")
    log.write_text("Traceback (most recent call last):\n  File \"x\", line 1\nRuntimeError: boom\n")
    assert last_error_line(log) == "RuntimeError: boom"
    log.write_text("just one line\n")
    assert last_error_line(log) == "just one line" and last_error_line(tmp_path / "none.log") == ""


def test_refusals_for_the_queue_limit_and_the_disk_have_their_codes():
    with pytest.raises(WireError) as busy, _storage_errors("the job was not queued"):
        raise LearnerBusy("the learner already holds 100 unfinished jobs, its limit (--max-queued-jobs 100)")
    assert busy.value.code == "busy" and "--max-queued-jobs 100" in busy.value.message
    full = OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    with pytest.raises(WireError) as failed, _storage_errors("the job was not cancelled"):
        raise StateWriteError("job e1-0", Path("/s/jobs/e1-0.json"), full)
    assert failed.value.code == "write_failed" and failed.value.message == (
        "no space left on device while saving job e1-0 to /s/jobs/e1-0.json; the job was not cancelled")


def test_a_job_loop_that_stops_is_reported(tmp_path):
    from services.learner.core import LearnerCore

    core = LearnerCore(tmp_path, evaluator_for=lambda job: None)

    def broken():
        raise RuntimeError("the loop broke")

    core._next_job = broken  # what no job's failure can do (those are caught), but a bug might
    core.start()
    try:
        for thread in core._threads:  # every job thread meets the broken loop
            thread.join(10)
        assert core.loop_error == "RuntimeError: the loop broke"
        assert core.health().problems() == ["the job loop has stopped: RuntimeError: the loop broke"]
    finally:
        core.close()
    assert core.loop_error == "RuntimeError: the loop broke"
