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
"""
from __future__ import annotations

import argparse
import os
import signal
import sys
from pathlib import Path

if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

POINTS = ("journalled", "reserved", "publishing", "published")


def install(point: str, batch: int) -> None:
    """Patch the learner's classes in this process so that it kills itself at ``point`` of the
    ``batch``-th batch it reserves (1-based)."""
    from services.learner.core import LearnerCore
    from services.learner.journals import Journals
    from services.recording.publisher import EventPublisher

    state = {"reserved": 0, "published": 0}

    def die() -> None:
        sys.stderr.write(f"fault_points: SIGKILL at {point} of batch {batch}\n")
        sys.stderr.flush()
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
            state["published"] = 0
            if point == "reserved" and state["reserved"] == batch:
                die()

    def put(self, msg):
        here = state["reserved"] == batch
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
    args = p.parse_args(ours)
    if args.kill_at != "none":
        install(args.kill_at, args.batch)
    from services.learner.service import LearnerConfig
    from services.transport.lifetime import exit_now
    from services.transport.service import main as serve

    exit_now(serve(LearnerConfig, learner))


def _split(argv: list[str]) -> tuple[list[str], str, list[str]]:
    if "--" in argv:
        i = argv.index("--")
        return argv[:i], "--", argv[i + 1:]
    return argv, "", []


if __name__ == "__main__":
    sys.exit(main())
