"""A learner process that kills itself (SIGKILL, nothing saved) at a chosen point between reserving
and publishing a batch of roll-outs: the fault benchmark's precise kill -9 (bench_faults.py).

The learner's steps for each batch (services/learner/core.py): the batch's events written to the
job's journal, their indices reserved in the job record, the events published one by one, then
the progress event. The points, in that order:

============  ===========================================================================
journalled    after the journal is written, before the indices are reserved
reserved      after the indices are reserved, before the first event is published
publishing    after about half of the batch's roll-out events were published
published     after every roll-out event of the batch was published, before its progress
============  ===========================================================================

::

    python -m benchmarks.performance.fault_points --kill-at reserved --batch 3 -- <learner options>

kills itself at the 3rd batch this process reserves, at that point (``journalled``: the first journal
written once 2 batches are reserved: the steps of jobs running side by side interleave);
``--kill-at none`` runs the
learner unchanged. Everything else is the real learner (``python -m services.learner``).
``--also PID`` (repeatable) kills those processes too, at the same point, just before itself: the
recorder, or the launcher and the recorder, dying with the learner (issue 73: a joint kill).

The harness around it, shared by benchmarks/performance/bench_faults.py and the tests:
:class:`Launcher` (a deployment of a recorder and workers on one ``--record``, killed and started
again), :func:`start_learner` (one learner life), :func:`count_rollouts` (what the recording lost
or holds twice of each job's reserved roll-outs).
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

POINTS = ("journalled", "reserved", "publishing", "published")


def install(point: str, batch: int, also: tuple[int, ...] = ()) -> None:
    """Patch the learner's classes in this process so that it kills itself at ``point`` of the
    ``batch``-th batch it reserves (1-based), the processes ``also`` just before."""
    from services.learner.core import LearnerCore
    from services.learner.journals import Journals
    from services.recording.publisher import EventPublisher

    state = {"reserved": 0, "published": 0, "job": None}

    def die() -> None:
        sys.stderr.write(f"fault_points: SIGKILL at {point} of batch {batch}"
                         + (f", with {' '.join(map(str, also))}" if also else "") + "\n")
        sys.stderr.flush()
        for pid in also:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:  # gone already
                pass
        os.kill(os.getpid(), signal.SIGKILL)

    save, persist, publish = Journals.save, LearnerCore._persist, EventPublisher.publish

    def journal_save(self, job_id, events):
        save(self, job_id, events)
        # the first journal written once batch - 1 batches are reserved (two jobs' steps interleave)
        if point == "journalled" and state["reserved"] + 1 >= batch:
            die()

    def reserve(self, job, **changes):
        persist(self, job, **changes)
        if "next_index" in changes and "iteration" in changes:  # a batch's reservation (not a start's)
            state["reserved"] += 1
            if state["reserved"] == batch:
                # the job whose batch it is: another job's reservation may come before this one's
                # events are out (two jobs' steps interleave), and must not move the point
                state["job"] = job.job
                if point == "reserved":
                    die()

    def put(self, msg):
        here = msg.get("job") is not None and msg.get("job") == state.get("job")
        if here and point == "published" and msg.get("kind") == "job_progress" and msg.get("state") == "running":
            die()
        publish(self, msg)
        if here and point == "publishing" and msg.get("kind") == "rollout":
            state["published"] += 1
            if state["published"] >= 2:
                die()

    Journals.save, LearnerCore._persist, EventPublisher.publish = journal_save, reserve, put


def main(argv: list[str] | None = None) -> int:
    ours, _, learner = _split(sys.argv[1:] if argv is None else argv)
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--kill-at", choices=(*POINTS, "none"), required=True,
                   help="where the learner kills itself (the module docstring); none: never")
    p.add_argument("--batch", type=int, default=1, help="the batch (1-based, of this process) to kill at")
    p.add_argument("--also", type=int, action="append", default=[], metavar="PID",
                   help="a process killed (SIGKILL) at the same point, just before the learner (repeatable)")
    args = p.parse_args(ours)
    if args.kill_at != "none":
        install(args.kill_at, args.batch, tuple(args.also))
    from services.learner.service import LearnerConfig
    from services.transport.lifetime import exit_now
    from services.transport.service import main as serve

    exit_now(serve(LearnerConfig, learner))


ROOT = Path(__file__).resolve().parents[2]
ENV = dict(os.environ, PYTHONPATH=str(ROOT), RERUN_ANALYTICS="0", OMP_NUM_THREADS="1")

#: The harness's launcher: recorder and workers, no learner (the harness runs its own); prints
#: ``anchor <endpoint> <first file>``, then ``children <name>=<pid> ...`` whenever a pid changes
#: (the supervisor restarted a child).
LAUNCHER = r"""
import sys, time
from services.launcher import LocalDeployment
from services.transport import install_shutdown_handlers
ns, record, state, workers = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
stop = install_shutdown_handlers()
with LocalDeployment(ns, workers=workers, model=False, learner=False, record=record, state_dir=state) as dep:
    print("anchor", dep.anchor, " ".join(str(p) for p in dep.recordings), flush=True)
    said = None
    while not stop.wait(0.1):
        now = " ".join(f"{name}={child.pid}" for name, child in sorted(dep.children.items()))
        if now != said:
            print("children", now, flush=True)
            said = now
"""


class Launcher:
    """The harness's deployment process (:data:`LAUNCHER`), started again on the same recording
    after a kill. ``children``: the pid of each of its children, as it last said."""

    def __init__(self, ns: str, record: Path, state: Path, workers: int = 2, env: dict | None = None):
        self.ns, self.record, self.state, self.workers = ns, record, state, workers
        self.env = ENV if env is None else env
        self.proc: subprocess.Popen | None = None
        self.anchor = ""
        self.children: dict[str, int] = {}
        self._changed = threading.Condition()

    def start(self) -> None:
        """Start it and wait until its recorder and workers are live (its ``anchor`` line)."""
        self.proc = subprocess.Popen([sys.executable, "-c", LAUNCHER, self.ns, str(self.record), str(self.state),
                                      str(self.workers)], cwd=ROOT, env=self.env, stdout=subprocess.PIPE,
                                     stderr=subprocess.DEVNULL, text=True)
        line = self.proc.stdout.readline().split()
        if not line or line[0] != "anchor":
            raise RuntimeError(f"the launcher did not start: {line}")
        self.anchor = line[1]
        self.children = {}
        threading.Thread(target=self._read, args=(self.proc,), daemon=True).start()
        self.wait_child("recorder", lambda pid: pid is not None)

    def _read(self, proc: subprocess.Popen) -> None:
        for line in proc.stdout:
            words = line.split()
            if words[:1] == ["children"]:
                with self._changed:
                    if proc is self.proc:
                        self.children = {k: int(v) for k, v in (w.split("=") for w in words[1:])}
                    self._changed.notify_all()

    def wait_child(self, name: str, ok, timeout: float = 120.0) -> int:
        """Block until the pid the launcher says child ``name`` has satisfies ``ok(pid)``; returns it."""
        with self._changed:
            if not self._changed.wait_for(lambda: ok(self.children.get(name)), timeout):
                raise TimeoutError(f"the launcher's {name}: still {self.children.get(name)}")
            return self.children[name]

    def wait_gone(self, timeout: float = 60.0) -> None:
        """Block until the launcher and every child it named have exited (after a kill)."""
        self.proc.wait(timeout)
        deadline = time.monotonic() + timeout
        while any(_alive(pid) for pid in self.children.values()):
            if time.monotonic() > deadline:
                raise TimeoutError(f"children of the killed launcher still alive: {self.children}")
            time.sleep(0.1)

    def stop(self) -> None:
        """SIGTERM, and wait for it to end (its recorder finishes the file)."""
        self.proc.send_signal(signal.SIGTERM)
        self.proc.wait(60)

    def kill(self) -> None:
        """SIGKILL it (unless dead already) and wait until its children, seeing it gone, have stopped."""
        if self.proc.poll() is None:
            self.proc.kill()
        self.wait_gone()


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().rsplit(")", 1)[1].split()[0] != "Z"  # a zombie has exited
    except (FileNotFoundError, ProcessLookupError, IndexError):
        return False


def start_learner(ns: str, anchor: str, state: Path, kill_at: str, batch: int, log, also: tuple[int, ...] = (),
                  jobs: int = 2, env: dict | None = None) -> subprocess.Popen:
    """One learner life on ``state``, connected to ``anchor``, recording (``--wait-recorder``),
    killing itself (and ``also``) at ``kill_at`` of batch ``batch`` (``none``: never); output to ``log``."""
    return subprocess.Popen([sys.executable, "-m", "benchmarks.performance.fault_points", "--kill-at", kill_at,
                             "--batch", str(batch), *(a for pid in also for a in ("--also", str(pid))), "--",
                             "--namespace", ns, "--mode", "peer", "--connect", anchor, "--state-dir", str(state),
                             "--wait-recorder", "20", "--id", "learner", "--jobs", str(jobs)],
                            cwd=ROOT, env=ENV if env is None else env, stdout=log, stderr=subprocess.STDOUT)


def count_rollouts(record: Path, state: Path, job_ids: list[str]) -> dict:
    """Each job's reserved roll-outs (its record's ``next_index``) against the recording (all its
    segments): ``{"reserved", "lost" (reserved, in no file), "duplicated" (indices held twice),
    "per_job": {job: {...}}}``."""
    from services.recording.replay import summarize

    summary = summarize(record)
    per_job, lost, duplicated, reserved = {}, 0, 0, 0
    for job in job_ids:
        rec = json.loads((state / "jobs" / f"{job}.json").read_text())
        recorded = summary["jobs"].get(job, {"rollouts": 0, "unique_rollouts": 0, "duplicates": []})
        n = int(rec["next_index"])
        missing = n - recorded["unique_rollouts"]
        per_job[job] = {"state": rec["state"], "attempts": rec["attempt"] + 1, "reserved": n,
                        "recorded": recorded["rollouts"], "distinct": recorded["unique_rollouts"],
                        "duplicated": recorded["duplicates"], "lost": missing,
                        "excluded_workers": [e for e in rec.get("excluded_workers") or ()
                                             if e.get("attempt", 0) == rec["attempt"]]}
        lost += missing
        duplicated += len(recorded["duplicates"])
        reserved += n
    return {"reserved": reserved, "lost": lost, "duplicated": duplicated, "per_job": per_job}


def _split(argv: list[str]) -> tuple[list[str], str, list[str]]:
    if "--" in argv:
        i = argv.index("--")
        return argv[:i], "--", argv[i + 1:]
    return argv, "", []


if __name__ == "__main__":
    sys.exit(main())
