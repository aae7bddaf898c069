"""The pouring task: the rig of :mod:`acnmp_core.sim.pour` scored on how much it pours, in grams."""
from __future__ import annotations

from collections import OrderedDict

import numpy as np

from ...rollout import ClosedAtExit, RolloutBatch
from ...validation import check_array
from ...sim.pour import PourConfig, PourSim


class PourTask(ClosedAtExit):
    """The pouring task as a :class:`~acnmp_core.rollout.RolloutEvaluator`.

    ``evaluate(trajectories (B, T, 1), times (T,), task_params (2,))`` runs each wrist trajectory
    (rad, one row per control step) on the world for the task's initial weight; ``task_params`` is
    ``(initial weight g, target amount g)``.

    Reward: zero at every step except the last, where it is minus ``|poured - target|`` (g), the
    poured mass read after the marbles settled: the user asks only how much ends up in the receiving
    cup, so the return is minus the final error, as in the paper. ``errors`` (B,) is that error (g).
    Success: the error is at most ``tolerance_g`` (default 30 g, the paper's final error being 27 g).

    States (B, ...): ``wrist_angle`` (B, T) rad, ``poured_g_t`` (B, T) g after each step,
    ``marble_xyz`` (B, F, M, 3) m at the F control steps ``frame_steps`` (B, F) (T: after settling),
    ``poured_g`` (B,) g, ``initial_weight_g`` (B,) g (tare plus the whole marbles the weight rounds to).

    Worlds are cached per marble count (at most ``max_worlds``, least recently used dropped), so
    roll-outs at one weight pay the initial settling once.

    Parameters
    ----------
    config : the rig (:class:`PourConfig`).
    tolerance_g : success tolerance (g).
    max_worlds : how many settled worlds (one physics client each) to keep.
    n_frames : marble-position frames per roll-out.
    """

    task_param_names = ("initial_weight_g", "target_g")
    #: The only reward comes at the end and every wrist motion before it shapes the pour: an action
    #: is credited with the rewards after it (see :func:`acnmp_core.adaptation.credit.per_step_advantages`).
    credit = "future"

    def __init__(self, config: PourConfig | None = None, *, tolerance_g: float = 30.0, max_worlds: int = 2,
                 n_frames: int = 6) -> None:
        self.config = config if config is not None else PourConfig()
        self.tolerance_g = float(tolerance_g)
        if isinstance(max_worlds, bool) or not isinstance(max_worlds, (int, np.integer)) or max_worlds < 1:
            raise ValueError(f"max_worlds: expected an integer >= 1, got {max_worlds!r}")
        self.max_worlds = int(max_worlds)
        self.n_frames = int(n_frames)
        self._worlds: OrderedDict[int, PourSim] = OrderedDict()

    def world(self, weight_g: float, name: str = "weight_g") -> PourSim:
        """The settled world for an initial weight ``weight_g`` (g), built on first use."""
        n = self.config.n_marbles(weight_g, name)
        if n in self._worlds:
            self._worlds.move_to_end(n)
            return self._worlds[n]
        sim = PourSim(n, self.config)
        self._worlds[n] = sim
        while len(self._worlds) > self.max_worlds:
            self._worlds.popitem(last=False)[1].close()
        return sim

    def evaluate(self, trajectories, times, task_params=None) -> RolloutBatch:
        """Pour with each of B wrist trajectories from the settled world of the initial weight.

        Parameters
        ----------
        trajectories : (B, T, 1) wrist targets (rad), one row per control step; clipped into the
            wrist's limits.
        times : (T,) strictly increasing labels of the rows (the project uses phase in [0, 1]).
        task_params : (2,) initial weight (g, from the tare to ``max_weight_g``) and target amount (g, >= 0).

        Returns a :class:`~acnmp_core.rollout.RolloutBatch` (see the class docstring); ValueError
        naming the argument for a wrong shape, NaN/inf or a weight or target out of range.
        """
        trajs = check_array("trajectories", trajectories, ndim=3, min_size=1)
        b, t_len, d = trajs.shape
        if d != 1:
            raise ValueError(f"trajectories: expected one wrist angle per step (shape (B, T, 1)), "
                             f"got shape {trajs.shape}")
        times = check_array("times", times, shape=(t_len,))
        if t_len > 1 and np.any(np.diff(times) <= 0):
            raise ValueError("times: expected strictly increasing times")
        if task_params is None:
            raise ValueError("task_params: expected (initial weight g, target amount g), got None")
        weight, target = check_array("task_params", task_params, shape=(2,))
        if target < 0:
            raise ValueError(f"task_params: expected a target amount >= 0 g, got {target:g}")
        sim = self.world(weight, "task_params")
        outs = [sim.rollout(trajs[i], n_frames=self.n_frames) for i in range(b)]
        poured = np.array([o["poured_g"] for o in outs])
        errors = np.abs(poured - target)
        rewards = np.zeros((b, t_len))
        rewards[:, -1] = -errors
        states = {k: np.stack([o[k] for o in outs]) for k in ("wrist_angle", "poured_g_t", "marble_xyz", "frame_steps")}
        states["poured_g"] = poured
        states["initial_weight_g"] = np.full(b, sim.initial_weight_g)
        return RolloutBatch(rewards=rewards, success=errors <= self.tolerance_g, states=states, errors=errors)

    def close(self) -> None:
        """Disconnect every cached world (idempotent)."""
        while self._worlds:
            self._worlds.popitem()[1].close()
