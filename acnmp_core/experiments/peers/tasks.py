"""The tasks of the peers comparison: each one's demonstrations, test positions, evaluators and
step-based environment, behind one interface (:class:`PeerTask`).

* ``metaworld-*`` (:class:`MetaWorldPeer`): Meta-World's reach, push, pick-place, window-open and
  button-press (:mod:`acnmp_core.tasks.metaworld`), the hand's path and gripper through the
  Gymnasium adapter; test positions drawn per seed (:func:`test_position`).
* ``e1-viapoint`` (:class:`ViaPointPeer`): the paper's E1, its extrapolated via-point
  (:mod:`acnmp_core.experiments.viapoint`); one test condition, the seeds vary the methods.
* ``e2-push`` (:class:`PushPeer`): the paper's E2, its held-out interpolation and extrapolation
  targets (:mod:`acnmp_core.experiments.push`), in PyBullet.
* ``pusher`` (:class:`PusherPeer`): Gymnasium's MuJoCo ``Pusher-v5`` (:mod:`acnmp_core.tasks.pusher`),
  test positions drawn per seed in the extrapolation region and inside the training region.
* ``e3-wall`` (:class:`HolePeer`): the paper's E3 wall with the hole's position as the condition
  (:mod:`acnmp_core.tasks.wall.hole`); ``bump`` and ``arc`` (:class:`FamilyPeer`): path families
  that bend with their condition (:mod:`acnmp_core.tasks.families`). Their demonstrations are not
  linear in their conditions; they are kinematic (a path scored at a few points), so the
  step-based peers do not apply.

A method that cannot run on a task is named in :attr:`PeerTask.not_applicable` with the reason.
"""
from __future__ import annotations

import functools

import numpy as np

from ...adaptation.config import AdaptTarget
from ...errors import InputError
from .config import CASES, DENSE_METHODS, E1_TASK, E2_TASK, E3_TASK, FAMILY_TASKS, PUSHER_TASK, TASK_NAMES

#: why the step-based peers cannot run on E1
NO_STEP_ENV = ("E1 scores a path at three points (start, via-point, end) and has no state between them "
               "for a step-based policy to act on")
#: why the step-based peers cannot run on the kinematic families
NO_DYNAMICS = ("the task scores a kinematic path at a few points (no dynamics, no state between them) "
               "for a step-based policy to act on")
STEP_BASED = ("ppo_bc", "ppo", "sac_bc", "sac")
#: why a ProMP method's dense-reward twin does not run on a task
ONE_REWARD = "every method is given this task's one reward: the plain method has it"


@functools.lru_cache(maxsize=None)
def test_position(kind: str, case: str, seed: int) -> tuple[float, ...]:
    """Seed ``seed``'s test position (P,) m of ``case`` on the Meta-World task ``kind``, drawn from the
    region (:meth:`~acnmp_core.tasks.metaworld.scene.MetaWorldTask.sample_extrapolation` or
    ``sample_training``) with generator ``[seed, case index]`` until Meta-World's scripted expert
    succeeds there."""
    from ...tasks.metaworld.demos import expert_succeeds
    from ...tasks.metaworld.scene import task

    spec = task(kind)
    rng = np.random.default_rng([int(seed), CASES.index(case)])
    while True:
        p = spec.sample_extrapolation(rng) if case == "extrapolation" else spec.sample_training(rng)
        if expert_succeeds(kind, p):
            return tuple(float(x) for x in p)


class PeerTask:
    """One task of the comparison (the module docstring lists them).

    name : its name in the results. cases : the cases it has. path_unit : the unit of
    :meth:`path_error`. not_applicable : method -> why it cannot run here. arrays : the
    demonstrations (:class:`~acnmp_core.data.demo_io.DemoArrays`: times (N, T), values (N, T, D),
    task parameters (N, P), names).
    """

    name: str
    cases: tuple[str, ...] = CASES
    path_unit: str = "m"
    not_applicable: dict[str, str] = {}
    #: the ProMP methods are given another reward than ACNMP's by default (their ``_dense`` twins
    #: then run on ACNMP's)
    other_reward: bool = False

    @classmethod
    def inapplicable(cls) -> dict[str, str]:
        """Method -> why it does not run on this task: :attr:`not_applicable`, and the dense-reward
        twins where every method has one reward."""
        return {**({} if cls.other_reward else {m: ONE_REWARD for m in DENSE_METHODS}), **cls.not_applicable}

    def __init__(self) -> None:
        self.arrays = self._demos()
        self._evaluators: dict[str, object] = {}
        self._cma_basis: int | None = None

    # ----- what every task says --------------------------------------------------------------------
    def _demos(self):
        raise NotImplementedError

    def target(self, seed: int, case: str) -> AdaptTarget:
        """The test condition of ``seed`` and ``case`` (raw units): what every method conditions on."""
        raise NotImplementedError

    def _evaluator(self, reward: str):
        raise NotImplementedError

    def expert_path(self, seed: int, case: str) -> np.ndarray | None:
        """(T, D) the expert's own trajectory at the test condition (never trained on), or None."""
        return None

    def step_env(self, params: np.ndarray):
        """A new step-based environment at task parameters ``params`` (for the SB3 peers)."""
        raise InputError(f"{self.name}: {self.not_applicable.get('ppo_bc', 'no step-based environment')}")

    def _transitions(self) -> tuple[np.ndarray, np.ndarray]:
        raise InputError(f"{self.name}: {self.not_applicable.get('ppo_bc', 'no step-based environment')}")

    def _rewards(self, method: str) -> str:
        """Which reward ``method`` is given (the tasks whose methods differ override it)."""
        return "task"

    # ----- derived ---------------------------------------------------------------------------------
    @property
    def times(self) -> np.ndarray:
        """(T,) the demonstrations' (and every trajectory's) times."""
        return self.arrays.times[0]

    @property
    def q0(self) -> np.ndarray:
        """(D,) the mean of the demonstrations' first rows: the start every CNMP query observes."""
        return self.arrays.values[:, 0].mean(axis=0)

    def params(self, seed: int, case: str) -> np.ndarray:
        """(P,) the task parameters of the test condition (empty without any)."""
        tp = self.target(seed, case).task_params
        return np.zeros(0) if tp is None else np.asarray(tp, dtype=np.float64)

    def evaluator(self, method: str):
        """The evaluator ``method``'s roll-outs run on (one per reward, shared by the runs)."""
        reward = self._rewards(method)
        if reward not in self._evaluators:
            self._evaluators[reward] = self._evaluator(reward)
        return self._evaluators[reward]

    @functools.cached_property
    def transitions(self) -> tuple[np.ndarray, np.ndarray]:
        """The demonstrations as (observations (M, O), actions (M, A)) of :meth:`step_env`, for
        behaviour cloning."""
        return self._transitions()

    @property
    def cma_basis(self) -> int:
        """ProMP + CMA-ES's basis count on this task, chosen by leave-one-out error on the
        demonstrations alone (:func:`~acnmp_core.peers.black_box.choose_n_basis`)."""
        if self._cma_basis is None:
            from ...peers.black_box import choose_n_basis

            self._cma_basis, self.cma_basis_errors = choose_n_basis(self.times, self.arrays.values,
                                                                    self.arrays.task_params)
        return self._cma_basis

    def chosen_settings(self) -> dict:
        """What was chosen on this task's demonstrations so far: ProMP + CMA-ES's basis count and
        every candidate's leave-one-out error (empty before ProMP + CMA-ES ran)."""
        if self._cma_basis is None:
            return {}
        return {"promp_cma_basis": self._cma_basis, "promp_cma_basis_loo": self.cma_basis_errors}

    def path_error(self, trajectory: np.ndarray, expert: np.ndarray) -> float:
        """Root mean square over the steps of the distance between two (T, D) trajectories in the
        dimensions that make the path (:attr:`path_unit`)."""
        diff = np.asarray(trajectory, dtype=np.float64) - expert
        return float(np.sqrt(np.mean(np.sum(diff[:, self._path_dims()] ** 2, axis=1))))

    def _path_dims(self) -> slice:
        return slice(None)

    def close(self) -> None:
        for ev in self._evaluators.values():
            close = getattr(ev, "close", None)
            if close is not None:
                close()
        self._evaluators.clear()


class MetaWorldPeer(PeerTask):
    """A Meta-World task (module docstring); ``kind`` its robot kind."""

    def __init__(self, kind: str) -> None:
        from ...tasks.metaworld.scene import require_metaworld, task

        require_metaworld()
        self.name, self.spec = kind, task(kind)
        super().__init__()

    def _demos(self):
        from ...tasks.metaworld.demos import metaworld_demos

        return metaworld_demos(self.name)

    @functools.lru_cache(maxsize=None)
    def target(self, seed: int, case: str) -> AdaptTarget:
        t = self.times
        return AdaptTarget(t[:1].copy(), self.q0[None], np.array(test_position(self.name, case, seed)), t.copy())

    def _evaluator(self, reward: str):
        from ...robots.metaworld import task_name
        from ...robots.registry import robot

        return robot(self.name).make_evaluator(task_name(self.name))

    @functools.lru_cache(maxsize=None)
    def expert_path(self, seed: int, case: str) -> np.ndarray:
        from ...tasks.metaworld.demos import expert_episode

        return expert_episode(self.name, self.params(seed, case)).trajectory

    def _path_dims(self) -> slice:
        return slice(0, 3)  # the hand's x, y, z (the gripper command is not a place)

    def step_env(self, params: np.ndarray):
        from ...tasks.metaworld.scene import fixed_task_env

        return fixed_task_env(self.name, params)

    def _transitions(self):
        from ...tasks.metaworld.demos import expert_transitions

        return expert_transitions(self.name)


class ViaPointPeer(PeerTask):
    """The paper's E1: the 2-D obstacle paths and their extrapolated via-point (module docstring)."""

    name = E1_TASK
    cases = ("extrapolation",)
    not_applicable = {"promp_rl": "it starts from the demonstration nearest in task parameters, and E1's "
                                  "condition is a via-point, not a task parameter",
                      **{m: NO_STEP_ENV for m in ("ppo_bc", "ppo", "sac_bc", "sac")}}

    def __init__(self) -> None:
        from ..viapoint import make_setup

        self.setup = make_setup("2d")
        super().__init__()

    def _demos(self):
        from ...data.demo_io import DemoArrays

        demos = self.setup.demos
        return DemoArrays(np.stack([d.times for d in demos]), np.stack([d.values for d in demos]),
                          np.zeros((len(demos), 0)), value_names=np.array(["x", "y"]))

    def target(self, seed: int, case: str) -> AdaptTarget:
        return self.setup.target

    def _evaluator(self, reward: str):
        return self.setup.task

    def expert_path(self, seed: int, case: str) -> np.ndarray:
        from ...tasks.viapoint.task import EXTRAPOLATION_AMPLITUDE, two_bump

        t = self.setup.target.query_times
        return np.stack([t, two_bump(t, EXTRAPOLATION_AMPLITUDE)], axis=1)


class PushPeer(PeerTask):
    """The paper's E2 (module docstring): the CNMP methods get ACNMP's dense reward, the ProMP
    methods the final distance (E2's choice for its episodic baseline) and, as their ``_dense``
    twins, ACNMP's reward."""

    name = E2_TASK
    path_unit = "rad"
    other_reward = True

    def __init__(self) -> None:
        from ..push import make_setup

        self.setup = make_setup()
        super().__init__()

    def _demos(self):
        return self.setup.demo_arrays.with_role("train")

    def target(self, seed: int, case: str) -> AdaptTarget:
        from ..push import make_target

        return make_target(self.setup, case)

    def _rewards(self, method: str) -> str:
        from ..push import reward_for

        final = method.startswith("promp") and method not in DENSE_METHODS
        return reward_for(self.setup.setting, "promp_rl" if final else "acnmp")

    def _evaluator(self, reward: str):
        from ..push import make_task

        return make_task(self.setup, "promp_rl" if reward == "final" else "acnmp", "extrapolation")

    def expert_path(self, seed: int, case: str) -> np.ndarray:
        return self.setup.demo_arrays.with_role(case).values[0]

    def step_env(self, params: np.ndarray):
        from ...tasks.push.env import push_env

        return push_env(self.setup.q0, params, self.setup.tolerance)

    def _transitions(self):
        from ...tasks.push.env import demo_transitions

        return demo_transitions(self.arrays.values, self.arrays.task_params)


class PusherPeer(PeerTask):
    """Gymnasium's ``Pusher-v5`` (module docstring): extrapolation positions as the Pusher example
    draws them (generator ``seed``), interpolation positions inside the training region (generator
    ``[seed, 1]``)."""

    name = PUSHER_TASK
    path_unit = "rad"

    def _demos(self):
        from ...tasks.pusher.scene import pusher_demos

        return pusher_demos()

    @functools.lru_cache(maxsize=None)
    def target(self, seed: int, case: str) -> AdaptTarget:
        from ...tasks.pusher.scene import TRAINING_REGION, extrapolation_params

        p = (extrapolation_params(1, np.random.default_rng(seed))[0] if case == "extrapolation"
             else TRAINING_REGION.sample(1, np.random.default_rng([seed, 1]))[0])
        t = self.times
        return AdaptTarget(t[:1].copy(), self.q0[None], p, t.copy())

    def _evaluator(self, reward: str):
        from ...robots.registry import robot

        return robot("pusher").make_evaluator("pusher_push")

    def expert_path(self, seed: int, case: str) -> np.ndarray:
        from ...tasks.pusher.scene import pusher_expert

        return pusher_expert(self.params(seed, case))

    def step_env(self, params: np.ndarray):
        from ...tasks.pusher.env import pusher_env

        return pusher_env(params)

    def _transitions(self):
        from ...tasks.pusher.env import demo_transitions

        return demo_transitions(self.arrays.values, self.arrays.task_params)


class _KinematicPeer(PeerTask):
    """A kinematic task scored at a few points of a path: one test condition drawn per seed and
    case (generator ``[seed, case index]``), the query observing the demonstrations' common start."""

    not_applicable = {m: NO_DYNAMICS for m in STEP_BASED}
    path_unit = "units"

    def _draw(self, case: str, rng: np.random.Generator) -> np.ndarray:
        raise NotImplementedError

    @functools.lru_cache(maxsize=None)
    def target(self, seed: int, case: str) -> AdaptTarget:
        p = self._draw(case, np.random.default_rng([int(seed), CASES.index(case)]))
        t = self.times
        return AdaptTarget(t[:1].copy(), self.q0[None], p, t.copy())


class HolePeer(_KinematicPeer):
    """The paper's E3 wall, the hole's centre as the condition (module docstring)."""

    name = E3_TASK

    def _demos(self):
        from ...data.demo_io import DemoArrays
        from ...tasks.wall.hole import PARAM_NAMES, hole_demos

        times, values, params = hole_demos()
        return DemoArrays(times, values, params, task_param_names=np.array(PARAM_NAMES), value_names=np.array(["x", "y"]))

    def _draw(self, case: str, rng: np.random.Generator) -> np.ndarray:
        from ...tasks.wall.hole import sample_hole

        return sample_hole(case, rng)

    def _evaluator(self, reward: str):
        from ...tasks.wall.hole import HoleTask

        return HoleTask()

    def expert_path(self, seed: int, case: str) -> np.ndarray:
        from ...tasks.wall.hole import expert_path

        return expert_path(self.params(seed, case))


class FamilyPeer(_KinematicPeer):
    """A path family of :mod:`acnmp_core.tasks.families` (module docstring), called ``name``."""

    def __init__(self, name: str) -> None:
        from ...tasks.families import family

        self.name, self.family = name, family(name)
        super().__init__()

    def _demos(self):
        from ...data.demo_io import DemoArrays

        times, values, params = self.family.demonstrations()
        return DemoArrays(times, values, params, task_param_names=np.array(self.family.param_names),
                          value_names=np.array(self.family.output_names))

    def _draw(self, case: str, rng: np.random.Generator) -> np.ndarray:
        return self.family.sample(case, rng)

    def _evaluator(self, reward: str):
        return self.family.task()

    def expert_path(self, seed: int, case: str) -> np.ndarray:
        return self.family.path(self.times, self.params(seed, case))


def peer_task(name: str) -> PeerTask:
    """A new :class:`PeerTask` called ``name`` (one of :data:`TASK_NAMES`); InputError otherwise."""
    if name == ViaPointPeer.name:
        return ViaPointPeer()
    if name == PushPeer.name:
        return PushPeer()
    if name == PusherPeer.name:
        return PusherPeer()
    if name == HolePeer.name:
        return HolePeer()
    if name in FAMILY_TASKS:
        return FamilyPeer(name)
    if name in TASK_NAMES:
        return MetaWorldPeer(name)
    raise InputError(f"tasks: expected one of {', '.join(TASK_NAMES)}, got {name!r}")
