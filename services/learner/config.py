"""The learner's options (``acnmp serve learner``, ``python -m services.learner``, the launcher's
learner arguments): torch-free, so a command line is built and checked without importing what the
learner runs; :class:`~services.learner.service.LearnerConfig` adds what runs it (services/learner/service.py)."""
from __future__ import annotations

import argparse
import os
from dataclasses import dataclass
from typing import ClassVar

from acnmp_core.data.demo_io import DemoArrays, load_demos
from services.transport import Service, option
from services.transport.argtypes import device, int_at_least, seconds
from services.transport.keys import check_name

from .limits import LearnerLimits, StateLimits
from .ownership import learner_ids

#: Runner kinds ``--job-runner`` takes, and the learner's defaults (chosen from
#: benchmarks/results/bench_jobs.json on a 2-core machine); services/learner/runner.py runs them.
RUNNERS = ("process", "thread")
DEFAULT_RUNNER = "process"
DEFAULT_JOBS = 2


def demos_skill(spec: str) -> str:
    """The skill a ``--demos`` value names, or the value itself when it is malformed (then
    the learner's start says what is wrong with it)."""
    try:
        return parse_demos_spec(spec)
    except ValueError:
        return spec


def parse_demos_spec(spec: str) -> str:
    """The skill name of a ``--demos`` value ``SKILL=FILE.npz``; ValueError naming ``--demos`` for a
    bad form or name."""
    name, sep, path = spec.partition("=")
    if not sep or not path:
        raise ValueError(f"--demos: expected SKILL=FILE.npz, got {spec!r}")
    try:
        return check_name("skill", name)
    except ValueError as exc:
        raise ValueError(f"--demos {spec}: {exc}") from None


def absolute_demos_spec(spec: str) -> str:
    """A ``--demos`` value ``SKILL=FILE.npz`` with FILE made absolute from this process's working
    directory (where the user typed it), for a child that runs elsewhere (a launcher's children run
    in the project's root)."""
    name, sep, path = spec.partition("=")
    return f"{name}{sep}{os.path.abspath(path)}" if sep and path else spec


def load_demos_spec(spec: str) -> DemoArrays:
    """The demonstration file of a ``--demos`` value ``SKILL=FILE.npz``, read and checked; ValueError
    naming ``--demos`` for a bad form, name or file (``acnmp up`` checks its values with it before
    it starts the learner)."""
    parse_demos_spec(spec)
    try:
        arrays = load_demos(spec.partition("=")[2])
        arrays.to_demo_set()
    except ValueError as exc:
        raise ValueError(f"--demos {spec}: {str(exc).removeprefix('path: ')}") from None
    return arrays


#: The learner's default ``--cross-check``: the fraction of roll-out chunks run again on a second
#: worker (services/worker/remote.py; measured in benchmarks/results/bench_cross_check.json).
DEFAULT_CROSS_CHECK = 0.05


def fraction(text: str) -> float:
    """An argparse type: a number in [0, 1]."""
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"expected a fraction in [0, 1], got {text!r}")
    return value


@dataclass
class LearnerOptions(Service):
    """The learner's options; :meth:`serve` runs it on an open session."""

    name: ClassVar[str] = "learner"
    summary: ClassVar[str] = "the learner: trains skills, runs adaptation jobs, checkpoints"

    state_dir: str | None = option(None, "checkpoints of skills and jobs, locked while the learner runs "
                                         "(default: ~/.local/state/acnmp/<namespace> on Linux, the user state "
                                         "directory; ./runs/<namespace>/state while only it exists)", metavar="DIR")
    learner_id: str | None = option(None, "learner id (default: learner-<pid>)", flag="--id", metavar="ID")
    demos: list[str] = option([], "train SKILL from a demonstration file at start unless it was trained from "
                                  "that file's demonstrations (a changed file retrains it; repeatable); the file's "
                                  "arrays: `acnmp up --help`, docs/ROBOTS.md",
                              metavar="SKILL=FILE.npz")
    train_steps: int = option(3000, "steps for --demos (default: %(default)s)", metavar="N", type=int_at_least(1))
    wait_recorder: float = option(0.0, "wait up to S seconds for a recorder before the first event (default: 0)",
                                  metavar="S", type=seconds(zero=True))
    chunk_timeout: float = option(60.0, "seconds a worker may take for its share of a batch (default: %(default)s)",
                                  metavar="S", type=seconds())
    device: str = option("cpu", "where skills train, adapt and assimilate: cpu, cuda or auto (cuda when present) "
                                "(default: %(default)s)", type=device)
    max_train_steps: int = option(LearnerLimits.max_train_steps,
                                  "refuse train requests (and assimilations) of more steps (default: %(default)s)",
                                  metavar="N", type=int_at_least(1))
    max_rollouts: int = option(LearnerLimits.max_rollouts,
                               "refuse adaptation jobs with a larger roll-out budget (default: %(default)s)", metavar="N",
                               type=int_at_least(1))
    max_queued_jobs: int = option(StateLimits.max_queued_jobs,
                                  "refuse new jobs (busy) while this many are unfinished (default: %(default)s)",
                                  metavar="N", type=int_at_least(1))
    keep_jobs: int = option(StateLimits.keep_finished_jobs,
                            "keep the records of this many finished jobs, removing older ones (default: %(default)s)",
                            metavar="N", type=int_at_least(0))
    keep_job_days: float = option(StateLimits.keep_finished_days,
                                  "remove a finished job's record this many days after its last change "
                                  "(default: %(default)s)", metavar="DAYS", type=seconds(zero=True))
    jobs: int = option(DEFAULT_JOBS, "adaptation jobs run at once, each with its own model copy, optimiser and "
                                     "random streams (default: %(default)s)", metavar="N", type=int_at_least(1))
    job_runner: str = option(DEFAULT_RUNNER, "where a job's adaptation computes: process (a child process per "
                                             "running job, so jobs use several cores) or thread (the learner's "
                                             "own, jobs share one core) (default: %(default)s)",
                             choices=RUNNERS)
    learners: tuple[str, ...] = option((), "the ids of every learner of the deployment when it runs several "
                                           "(the same list on each, --id among them): each skill is served by one "
                                           "of them, the same whichever learner computes it (docs/DEPLOYMENT.md, "
                                           "'Several learners')", metavar="ID,ID,...", type=learner_ids)
    cross_check: float = option(DEFAULT_CROSS_CHECK,
                                "the fraction of roll-out chunks run again on a second worker and compared, besides "
                                "every chunk whose success would end its job; a worker whose results disagree is "
                                "excluded; 0: none; a deployment of one worker checks nothing (default: "
                                "%(default)s; docs/FAULTS.md)", metavar="F", type=fraction)
    keep_versions: int = option(StateLimits.keep_versions,
                                "checkpoints kept per skill, the newest (default: %(default)s)", metavar="N",
                                type=int_at_least(1))

