"""The learner wing: owns the skills, trains them, runs adaptation jobs, checkpoints everything.

========================  =========================================================
module                    one job
========================  =========================================================
``core``                  zenoh-free: :class:`LearnerCore` (skills, training, the job
                          loop, assimilation), :class:`TrainSpec`
``jobs``                  :class:`JobRecord`: one job's request, progress and result
``store``                 checkpoints of skills and job records on disk, quarantine
``service``               :class:`LearnerService` on a session, :class:`LearnerConfig`
========================  =========================================================
"""
from .core import LearnerBusy, LearnerCore, LearnerHealth, TrainSpec, UnknownJobError, UnknownSkillError
from .jobs import JOB_STATES, JobRecord
from .service import LearnerConfig, LearnerService, parse_train_request
from .store import JobStore, SkillState, SkillStore, StateDir, StateWriteError

__all__ = ["LearnerBusy", "LearnerCore", "LearnerHealth", "TrainSpec", "UnknownJobError", "UnknownSkillError",
           "JOB_STATES", "JobRecord", "LearnerConfig", "LearnerService", "parse_train_request", "JobStore",
           "SkillState", "SkillStore", "StateDir", "StateWriteError"]
