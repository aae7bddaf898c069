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
