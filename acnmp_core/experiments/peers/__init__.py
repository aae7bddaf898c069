"""ACNMP against the peers a robot-learning user would pick instead (``acnmp experiment peers``).

Tasks (:mod:`.tasks`): Meta-World's reach, push, pick-place, window-open and button-press; the
paper's E1 (via-point), E2 (push) and E3 (the wall, its hole's position as the condition);
Gymnasium's ``Pusher-v5``; two path families that bend with their condition (a bump moving in
time, an arc). Per task and seed, one test
condition outside the demonstrations' region (*extrapolation*) and, where the task has one, one
inside (*interpolation*). Methods (:mod:`.methods`), all on the same demonstrations and the same
test conditions: LfD only and ACNMP with the product's default model and adaptation, and with the
paper's (``lfd_paper``, ``acnmp_paper``); the project's ProMP + RL; black-box ProMP + CMA-ES
(fancy_gym's recipe with ``mp_pytorch`` and ``cma``) with its basis count chosen on the
demonstrations and with fancy_gym's 5 (on E2 also on ACNMP's dense reward); stable-baselines3's PPO
and SAC, warm-started by behaviour cloning or from scratch, where the task has a step-based
environment.

Seeds: every choice is made on the development seeds (:data:`~.config.DEVELOPMENT_SEEDS`); the
comparison of record reports :data:`~.config.REPORT_SEEDS`, which nothing else runs
(:func:`~.config.check_development_seeds`). The verdict per task and case: :mod:`.verdict`.

One metric for all: **episodes executed until the method's deterministic output first succeeds**
(the evaluation episodes count). A method that does not succeed within its budget is *censored*:
reported as "> budget", never as a number it did not reach. Every adaptive method has the same
budget (:data:`~.config.BUDGET`); LfD only executes one episode.

The study of what the linear peers exploit: every LfD-only and ProMP + CMA-ES run records the
distance between the trajectory the method starts from and the expert's own trajectory at the test
condition (``path_error_to_expert``, in the task's :attr:`~.tasks.PeerTask.path_unit`).

The result is written after every run (:func:`~.run.run_peers` with ``out``), so a partial run is
usable and ``resume`` continues it; :func:`~.run.merge_results` joins parts run side by side.
"""
from .config import (BUDGET, CASES, DEVELOPMENT_SEEDS, METHODS, NON_LINEAR_TASKS, REPORT_SEEDS, STEP_BASED_METHODS,
                     TASK_NAMES, TRAJECTORY_METHODS, PeerRun, PeersConfig, check_development_seeds, library_versions)
from .figure import STYLE, plot_peers
from .run import load_runs, merge_results, plan, run_line, run_peers, summarise
from .tasks import PeerTask, peer_task, test_position

__all__ = ["BUDGET", "CASES", "DEVELOPMENT_SEEDS", "NON_LINEAR_TASKS", "REPORT_SEEDS", "check_development_seeds",
           "METHODS", "STEP_BASED_METHODS", "TRAJECTORY_METHODS", "PeerRun", "PeersConfig",
           "library_versions", "STYLE", "plot_peers", "load_runs", "merge_results", "plan", "run_line", "run_peers",
           "summarise", "TASK_NAMES", "PeerTask", "peer_task", "test_position"]
