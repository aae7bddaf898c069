"""Assimilation: an adapted solution joins the demonstrations and the skill trains on.

After :func:`~acnmp_core.adaptation.loop.adapt` has found a trajectory for a condition outside the
demonstrations, the trajectory becomes a demonstration and the CNMP continues its supervised
training on the enlarged set (paper Sec. 3.2), so the skill can be conditioned from any point of
the solution afterwards while the old demonstrations stay reproducible.

Continued training starts from the adapted network with a low learning rate and keeps the original
normalisation: the adapted network already produces the solution, so the supervised steps only have
to hold it, and a fresh optimiser at the rate of the first training would shake the network hard
enough to lose it again (Adam's first steps move every weight by about the full rate).

Random episodes alone do not keep what was learnt: the solution is one demonstration among many,
and the conditions it was found for (e.g. a start, a via-point and an end) are rarely the sampled
observations, so continued training drifts the answer to those conditions away from the
solution. Each step therefore also minimises the NLL of
the solution given exactly the adaptation's conditions (the *anchor*), weighted by
``anchor_weight``: assimilating a solution means the skill answers that query with it.
"""
from __future__ import annotations

import threading

import numpy as np

import torch

from ..data.demos import DemoSet, Demonstration
from ..model.cnmp import CNMP
from ..model.episodes import Episode
from ..model.optim_step import FusedAdam, Stepper, adam
from ..model.training import TrainConfig, check_stop, cosine_lr, make_sampler, nll_loss, set_lr
from ..threads import with_training_threads
from ..validation import check_array
from .config import AdaptTarget, AssimilationConfig


#: Which network a solution is assimilated into, for the experiments that choose: the skill as it
#: was before the adaptation ("skill"; the solution is learnt through the anchor, and the RL steps'
#: side effects stay out of the skill) or the adapted network ("adapted", which already produces it).
ASSIMILATE_FROM = ("skill", "adapted")


def check_assimilate_from(value: str) -> str:
    """``value`` if it is one of :data:`ASSIMILATE_FROM`, else ValueError in one line."""
    if value not in ASSIMILATE_FROM:
        raise ValueError(f"assimilate_from: expected one of {ASSIMILATE_FROM}, got {value!r}")
    return value


@with_training_threads
def assimilate(model: CNMP, demos: DemoSet, solution: Demonstration, cfg: AssimilationConfig | None = None, *,
               conditions: AdaptTarget | None = None, seed: int = 0,
               optimizer: torch.optim.Optimizer | FusedAdam | None = None,
               stop: threading.Event | None = None) -> tuple[DemoSet, list[float]]:
    """Add ``solution`` to ``demos`` and continue training ``model`` in place on the new set: the
    range its network sees widens to the solution's and its linear path, if any, is fitted again
    with the solution among the demonstrations (:meth:`~acnmp_core.model.cnmp.CNMP.follow_demos`).

    Parameters
    ----------
    model : the adapted CNMP (its normalisation is kept).
    demos : the demonstrations it was trained on (raw units).
    solution : the adapted trajectory as a demonstration: times (T,), values (T, D), task params (P,).
    cfg : :class:`AssimilationConfig`.
    conditions : the query the solution was found for (its observations and task parameters; the
        query times are replaced by the solution's). None trains on random episodes only.
    seed : seeds the episode sampling.
    optimizer : an optimiser over ``model``'s parameters to continue (its moments carry over from the
        training before, its rate is set to ``cfg.lr``); None starts a fresh Adam.
    stop : when set (e.g. the learner shutting down), InterruptedError at the next step (``model``
        is then part-trained: the caller discards it).

    Returns the enlarged :class:`DemoSet` and the loss per step (empty when ``cfg.steps`` is 0).
    """
    cfg = cfg or AssimilationConfig()
    new = demos.added(Demonstration(np.asarray(solution.times), np.asarray(solution.values),
                                    np.asarray(solution.task_params)))
    # beyond the first range the solution must reach the network as it is, and join the path's statistics
    model.follow_demos(new)
    if cfg.steps == 0:
        return new, []
    train_cfg = TrainConfig(batch_size=cfg.batch_size, n_targets=cfg.n_targets,
                            targets_include_obs=cfg.targets_include_obs)
    sampler = make_sampler(model, new, train_cfg)
    gen = torch.Generator().manual_seed(seed)
    anchor = None
    if conditions is not None and cfg.anchor_weight > 0:
        q = AdaptTarget(conditions.obs_times, conditions.obs_values, conditions.task_params, new[-1].times,
                        conditions.obs_dims_mask).query(model)
        with torch.no_grad():
            y = model.value_norm.normalize(torch.as_tensor(new[-1].values)).float()[None]
        anchor = Episode(q.obs_x, q.obs_mask, q.tgt_x, y)
    if optimizer is not None:
        set_lr(optimizer, cfg.lr)
    opt = Stepper(optimizer or adam(model.parameters(), lr=cfg.lr))
    losses = []
    model.train()
    for step in range(1, cfg.steps + 1):
        check_stop(stop, "assimilation")
        loss = nll_loss(model, sampler.sample(cfg.batch_size, gen), train_cfg.beta)
        if anchor is not None:
            loss = loss + cfg.anchor_weight * nll_loss(model, anchor, train_cfg.beta)
        opt.zero_grad()
        loss.backward()
        if cfg.lr_final is not None:
            set_lr(opt.opt, cosine_lr(cfg.lr, cfg.lr_final, step, cfg.steps))
        opt.step()
        losses.append(loss.item())
    model.eval()
    return new, losses


def snap_to_observations(solution: Demonstration, conditions: AdaptTarget) -> Demonstration:
    """The solution moved so that it passes exactly through the observations it was found for.

    An adaptation stops as soon as the task's tolerance is met, so a solution may end e.g. 0.2 away
    from the goal it was conditioned on (E3's tolerance is 0.25). Assimilated as it is, it teaches
    the skill that conditioning on a point means missing it by that much, and the skill's own
    fitting error then adds to the miss. Snapping removes the inconsistency (see
    :func:`snap_path`); a path that passes through its observations is unchanged. The correction
    is smooth and no larger than the largest miss, but it can move a path into an obstacle, so a
    task with constraints between the observations should execute the snapped path before keeping it.

    solution : the adapted trajectory, times (T,), values (T, D) raw units.
    conditions : its query (obs_times (N,), obs_values (N, D), obs_dims_mask (N, D) or None).
    Returns a new :class:`Demonstration` with the same times and task parameters.
    """
    t = np.asarray(solution.times, dtype=np.float64)
    values = snap_path(t, solution.values, conditions.obs_times, conditions.obs_values, conditions.obs_dims_mask)
    return Demonstration(t.copy(), values, np.asarray(solution.task_params).copy())


def snap_path(times, values, obs_times, obs_values, obs_dims_mask=None) -> np.ndarray:
    """A path moved onto observations by a correction linear in time between them.

    At each observed time the offset ``observation - path`` (the path linearly interpolated there)
    is computed per observed dimension; the offsets are interpolated linearly in time between the
    observation times (held constant before the first and after the last; repeated times average
    their offsets) and added to the whole path. Dimensions never observed are unchanged.

    times (T,) increasing; values (T, D); obs_times (N,); obs_values (N, D); obs_dims_mask (N, D)
    bool or None (all observed). Returns the moved values (T, D), float64, same units.
    """
    t = check_array("times", times, ndim=1, min_size=2)
    v = check_array("values", values, ndim=2, shape=(t.shape[0], None))
    d = v.shape[1]
    ot = check_array("obs_times", obs_times, ndim=1)
    ov = check_array("obs_values", obs_values, ndim=2, shape=(ot.shape[0], d))
    mask = np.ones(ov.shape, dtype=bool) if obs_dims_mask is None else np.asarray(obs_dims_mask, dtype=bool)
    out = v.astype(np.float64, copy=True)
    for j in range(d):
        keep = mask[:, j]
        if not keep.any():
            continue
        times_j, inv = np.unique(ot[keep], return_inverse=True)
        miss = ov[keep, j] - np.interp(ot[keep], t, v[:, j])
        offsets = np.bincount(inv, weights=miss) / np.bincount(inv)
        out[:, j] += np.interp(t, times_j, offsets)
    return out
