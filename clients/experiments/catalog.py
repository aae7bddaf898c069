"""The experiments, declared once: ``acnmp experiment NAME`` (its parser's help and description),
``acnmp reproduce`` (the paper's six, their sizes and decided targets) and the experiments table of
docs/EXPERIMENTS.md are all made from :data:`CATALOG`. Each entry's options and run live in its
module of :mod:`clients.experiments` (``add_arguments(p)``, ``run(args)``)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from . import targets


@dataclass(frozen=True)
class Experiment:
    """One ``acnmp experiment``.

    name : the sub-command, and its module in :mod:`clients.experiments`. help, description : its
    parser's. ident : E1..E6 for the paper's experiments (``acnmp reproduce`` runs those), the report's
    name of an optional one, else None.
    title, paper : what it is and what the paper reports. page : its page in docs/experiments/.
    benchmark : the script(s) writing its published JSON. full, quick : ``acnmp reproduce``'s
    options at the documented size and at a smoke-test size. target : the decided targets read
    from its JSON (:mod:`clients.experiments.targets`), None when the numbers are only reported.
    optional : ``acnmp reproduce`` runs it only when asked (``--with NAME``), not with the paper's six.
    """

    name: str
    help: str
    description: str
    ident: str | None = None
    title: str = ""
    paper: str = ""
    page: str | None = None
    benchmark: str | None = None
    full: tuple[str, ...] = ()
    quick: tuple[str, ...] = ()
    target: Callable[[dict], tuple[str, bool | None]] | None = None
    optional: bool = False

    @property
    def module(self) -> str:
        """The module holding its ``add_arguments`` and ``run``."""
        return f"clients.experiments.{self.name}"


CATALOG: tuple[Experiment, ...] = (
    Experiment(
        'viapoint',
        help="E1: 2D obstacle avoidance, via-point outside the demonstrations",
        description=("Train a CNMP on 6 demonstrations, condition it on a via-point outside them, then run "
                     "LfD-only, RL-only and ACNMP (RL with simultaneous supervised learning) side by side, and "
                     "assimilate the ACNMP solution. Prints a table; --json and --plot save the results."),
        ident="E1",
        title="2-D via-point beyond the demonstrations (Fig. 3, 4)",
        paper="ACNMP reaches the extrapolated via-point keeping the demonstrations' shape; RL alone distorts it",
        page="e1_viapoint.md",
        benchmark="benchmarks/experiments/e1_viapoint.py",
        full=('--seeds', '1'),
        quick=('--seeds', '1', '--train-steps', '200', '--budget', '10'),
        target=targets.e1_target,
    ),
    Experiment(
        'push',
        help="E2: planar arm pushes a cylinder to an interpolated and an extrapolated target",
        description=("Train a CNMP on 9 pushing demonstrations (task parameter: target x, y), then run ACNMP "
                     "and adaptive ProMP + RL (REPS) side by side on a held-out interpolation target and an "
                     "extrapolation target, over several seeds. Prints a table; --json and --plot save "
                     "results."),
        ident="E2",
        title="planar 3-DoF push, interpolation and extrapolation (Fig. 5 a-c)",
        paper="ACNMP needs about 9x fewer roll-outs than ProMP + RL",
        page="e2_push.md",
        benchmark="benchmarks/experiments/e2_push.py, benchmarks/experiments/e2_baselines.py",
        full=('--seeds', '10'),
        quick=('--quick', '--seeds', '1'),
    ),
    Experiment(
        'wall',
        help="E3: 2D wall with a hole; self-improvement over many environments, ACNMP vs ProMP + RL",
        description=("Learn from 30 demonstrated environments, then draw new ones: generate a trajectory, "
                     "adapt it when it fails (ACNMP: RL with simultaneous SL; baseline: task-conditional ProMP "
                     "+ REPS), assimilate the solution, go on. Test success and error on 1000 fixed "
                     "environments are printed as learning proceeds; --json and --plot save the result and the "
                     "Fig. 5 d, e curves."),
        ident="E3",
        title="self-improvement over wall-with-a-hole environments (Fig. 5 d, e)",
        paper="ACNMP needs about 14x fewer trajectories than ProMP + RL for the same test success",
        page="e3_wall.md",
        benchmark="benchmarks/experiments/e3_wall.py, benchmarks/experiments/e3_budget.py, benchmarks/experiments/e3_compare.py",
        full=('--envs', '1500', '--eval-every', '50'),
        quick=('--envs', '10', '--test', '200'),
        target=targets.e3_target,
    ),
    Experiment(
        'transfer',
        help="E4: transfer a cube-pushing skill from a 3-DoF to a 4-DoF planar arm through a shared latent space",
        description=("Train two CNMPs (3-DoF and 4-DoF arm) on 12 paired proxy demonstrations with a latent "
                     "alignment loss, encode the 3-DoF arm's demonstration of a new skill (pushing a cube "
                     "through a gap between two walls) and decode it for the 4-DoF arm, then refine it by RL "
                     "in the 4-DoF arm (its decoder only). Controls in the same run: no alignment term, and RL "
                     "from the 4-DoF arm's own LfD model. Prints success after 3/7/11/19 RL iterations."),
        ident="E4",
        title="skill transfer from a 3-DoF to a 4-DoF arm (Fig. 6)",
        paper="the transferred skill succeeds more often and sooner than learning from scratch",
        page="e4_transfer.md",
        benchmark="benchmarks/experiments/e4_transfer.py",
        quick=('--seeds', '1', '--pair-steps', '300', '--budget', '10', '--no-authors-data'),
    ),
    Experiment(
        'ur10',
        help="E5: UR10 pick and place over an obstacle at object/obstacle heights outside the demos",
        description=("Train a CNMP on 8 UR10 pick-and-place demonstrations (task parameters: object and "
                     "obstacle heights, 2-6 and 2-8 cm), then execute its LfD trajectory and adapt it with "
                     "ACNMP at the paper's (8, 10) and (9, 11) cm and at (10, 12) cm in PyBullet, over several "
                     "seeds. Prints per-joint errors (deg) against the expert at the test heights; --json and "
                     "--plot save results."),
        ident="E5",
        title="UR10 pick and place at heights beyond the demonstrations (Table 2, left)",
        paper="LfD alone fails in extrapolation; ACNMP places within a few roll-outs",
        page="e5_ur10.md",
        benchmark="benchmarks/experiments/e5_ur10.py",
        quick=('--seeds', '1', '--train-steps', '500', '--budget', '10', '--cases', '10_12'),
        target=targets.e5_target,
    ),
    Experiment(
        'pour',
        help="E6: pour a target amount of marbles from a cup heavier than any demonstrated one",
        description=("Train a CNMP on 16 pouring demonstrations (task parameters: initial cup weight 650-1200 "
                     "g and poured amount), then execute its LfD trajectory and adapt it with ACNMP for a 1400 "
                     "g cup and a 1322 g target in PyBullet, assimilate the solution and check it without RL, "
                     "over several seeds. --json and --plot save results."),
        ident="E6",
        title="pouring marbles into a target weight (Table 2, right)",
        paper="ACNMP reaches the target weight within 30 g in a few roll-outs",
        page="e6_pour.md",
        benchmark="benchmarks/experiments/e6_pour.py",
        full=('--jobs', '2'),
        quick=('--seeds', '1', '--train-steps', '500', '--budget', '10'),
        target=targets.e6_target,
    ),
    Experiment(
        'pusher',
        help="Gymnasium Pusher-v5 (MuJoCo): a 7-DoF arm pushes a cylinder at positions beyond the demos",
        description=("Train a CNMP on 12 scripted Pusher-v5 pushes (task parameters: object and goal x, y), "
                     "then, per seed, at one position 0.20-0.25 m beyond the demonstrations: execute its LfD "
                     "trajectory, adapt it with ACNMP, and run ProMP + RL from the nearest demonstration. "
                     "Success: the object ends within 0.05 m of the goal. docs/experiments/pusher.md explains "
                     "it."),
        page="pusher.md",
        benchmark="benchmarks/experiments/pusher.py",
    ),
    Experiment(
        'peers',
        help="ACNMP beside SB3 PPO (+BC), black-box ProMP + CMA-ES and ProMP + RL on 8 tasks (Meta-World, E1, E2, Pusher)",
        description=("On Meta-World's reach, push, pick-place, window-open and button-press (demonstrations by "
                     "Meta-World's scripted policies in its own training region), the paper's E1 and E2, and "
                     "Gymnasium's Pusher-v5, per seed at one condition beyond the demonstrations and one inside: "
                     "LfD only and ACNMP (the product's default and the paper's method), the project's ProMP + RL, "
                     "black-box ProMP + CMA-ES (fancy_gym's recipe; basis count chosen on the demonstrations, and "
                     "fancy_gym's 5), and stable-baselines3 PPO and SAC from scratch or warm-started by behaviour "
                     "cloning where the task has a step-based environment. One metric: episodes until the "
                     "method's deterministic output first succeeds (\"> budget\" when it does not). Needs the "
                     "peers extra. docs/experiments/peers.md explains it."),
        ident="peers",
        title="ACNMP beside SB3, black-box ProMP + CMA-ES and ProMP + RL on eight tasks",
        paper="not in the paper: the peers a robot-learning user would pick instead",
        page="peers.md",
        benchmark="benchmarks/experiments/peers.py",
        full=(),
        quick=('--quick',),
        optional=True,
    ),
    Experiment(
        'robot',
        help="any robot kind (a plugin too): train on your demonstrations, then LfD only vs ACNMP at --at points",
        description=("Train a CNMP on a demonstration file, then per seed and test point: execute its mean "
                     "trajectory (LfD only) and adapt it with ACNMP on the robot's task until success or the "
                     "budget. The robot is any kind `acnmp robots` lists, or a plugin package.module:attr."),
    ),
)

#: The paper's experiments in order (what ``acnmp reproduce`` runs).
PAPER: tuple[Experiment, ...] = tuple(e for e in CATALOG if e.ident and not e.optional)
#: What ``acnmp reproduce --with NAME`` adds (long, or needing an extra).
OPTIONAL: tuple[Experiment, ...] = tuple(e for e in CATALOG if e.optional)
