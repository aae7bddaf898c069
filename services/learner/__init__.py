"""The learner wing: owns the skills, trains them, runs adaptation jobs, checkpoints everything.

========================  =========================================================
module                    one job
========================  =========================================================
``core``                  zenoh-free: :class:`LearnerCore` (skills, training, the job
                          loop, assimilation), :class:`TrainSpec`
``jobs``                  :class:`JobRecord`: one job's request, progress and result
``store``                 checkpoints of skills and job records on disk, quarantine
``config``                :class:`LearnerOptions`: the learner's options (torch-free)
``service``               :class:`LearnerService` on a session, :class:`LearnerConfig` (runs it)
========================  =========================================================
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from services.transport.lazy import lazy_exports

if TYPE_CHECKING:  # what a type checker sees; at run time the names come from __getattr__
    from .core import LearnerBusy, LearnerCore, LearnerHealth, TrainSpec, UnknownJobError, UnknownSkillError
    from .jobs import JOB_STATES, JobRecord
    from .config import LearnerOptions
    from .service import LearnerConfig, LearnerService, parse_train_request
    from .store import JobStore, SkillState, SkillStore, StateDir, StateWriteError

__all__ = [
    "LearnerBusy", "LearnerCore", "LearnerHealth", "TrainSpec", "UnknownJobError", "UnknownSkillError",
    "JOB_STATES", "JobRecord", "LearnerConfig", "LearnerOptions", "LearnerService", "parse_train_request",
    "JobStore", "SkillState", "SkillStore", "StateDir", "StateWriteError",
]
__getattr__ = lazy_exports(__name__, {
    "LearnerBusy": "core", "LearnerCore": "core", "LearnerHealth": "core", "TrainSpec": "core",
    "UnknownJobError": "core", "UnknownSkillError": "core", "JOB_STATES": "jobs", "JobRecord": "jobs",
    "LearnerConfig": "service", "LearnerOptions": "config", "LearnerService": "service",
    "parse_train_request": "service", "JobStore": "store", "SkillState": "store", "SkillStore": "store",
    "StateDir": "store", "StateWriteError": "store",
})
