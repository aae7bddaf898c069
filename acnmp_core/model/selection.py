"""Which model a skill's demonstrations need, chosen from them: the network alone (the paper's
CNMP), or the same network with the demonstrations' linear trend beyond its range ("trend").

Inside the demonstrations' range both are one network: the paper's CNMP, trained and answering as
the paper's. They differ beyond it. The network alone extrapolates as a network does: it follows a
family that bends with its condition (a bump moving in time) some way, and stays short of a trend
(a scripted arm's paths toward a goal). With the trend, the network answers the query clipped to
its range and the demonstrations' linear path (:mod:`.prior`) adds its change from there, which
extrapolates demonstrations that vary linearly with their conditions and smears those that do not.
Which one a skill needs shows in its own demonstrations, at the edges of their conditions' range:

* **Edge folds** (:func:`edge_folds`): for each task parameter, the demonstrations at its largest
  value are held out together, then those at its smallest (a grid's whole face: a real step beyond
  the others); without task parameters, the two demonstrations at the ends of the demonstrations'
  first principal component.
* **Held-out error** (:func:`held_out_errors`): one network per fold is trained on the others as the
  skill is (the folds sharing as many steps as the skill's own training: :func:`fold_steps`) and
  predicts each held-out demonstration, alone and with the trend, from what a query gives it (its
  task parameters and start; without task parameters, its start, middle and end:
  :func:`~.prior.condition_marks`). The error is the RMS in units of each output's spread over the
  demonstrations (outputs that do not vary left out), the mean over the held-out demonstrations.
* **The choice** (:func:`choose_prior`): the candidate with the smaller error; a tie goes to the
  network alone (the paper's). With fewer than :data:`MIN_DEMOS` demonstrations nothing can be held
  out and leave enough to fit: the network alone, said in the choice's one-line reason.

The choice, every candidate's error and the folds are recorded in the skill's config
(:class:`~.choice.PriorChoice`, ``CNMPConfig.prior_choice``).
"""
from __future__ import annotations

import copy
from dataclasses import replace
from typing import Callable

import numpy as np

from ..data.demos import DemoSet
from .choice import PriorChoice
from .cnmp import CNMP, CNMPConfig
from .prior import condition_marks, varying_outputs

#: how a fold's model is trained: ``fit(model, demos, n_fits)`` with ``n_fits`` the number of fold
#: networks the choice trains (the library's trains it as the skill is, for :func:`fold_steps` steps:
#: :func:`~acnmp_core.model.training.train` passes it, since it chooses the prior through this module)
Fit = Callable[[CNMP, DemoSet, int], object]

#: the candidates, in the order a tie is broken: the network alone first
CANDIDATES = ("none", "trend")
#: what the candidates and the study's diagnostics are, in a user's words
NAMES = {"none": "the network alone (the paper's CNMP)", "trend": "the network with the demonstrations' linear trend "
         "beyond its range", "linear": "the linear path beside the network", "path": "the linear path alone"}
#: fewer demonstrations than this: no choice, the network alone
MIN_DEMOS = 4
#: a fold keeps at least this many demonstrations to fit
MIN_KEPT = 3
#: the folds' networks train this many times the skill's steps between them ...
CHOICE_STEP_SHARE = 1.0
#: ... each at least this many steps
MIN_FOLD_STEPS = 300


def edge_folds(task_params: np.ndarray, values: np.ndarray) -> list[tuple[int, ...]]:
    """The held-out sets at the edges of the demonstrations' conditions (module docstring): task
    parameters (N, P) and values (N, T, D) on one grid. Each fold keeps at least :data:`MIN_KEPT`
    demonstrations; equal folds appear once."""
    n = len(values)
    folds: list[tuple[int, ...]] = []
    if task_params.shape[1]:
        columns = task_params.T
    else:  # the demonstrations' main mode of variation stands in for a condition
        flat = values.reshape(n, -1)
        flat = flat - flat.mean(axis=0)
        columns = (flat @ np.linalg.svd(flat, full_matrices=False)[2][0])[None]
    for col in columns:
        span = col.max() - col.min()
        if span <= 0:
            continue
        for end in (col.max(), col.min()):
            fold = tuple(int(i) for i in np.flatnonzero(np.abs(col - end) <= 1e-9 * span))
            if n - len(fold) >= MIN_KEPT and fold not in folds:
                folds.append(fold)
    return folds


def _on_grid(demos: DemoSet) -> tuple[np.ndarray, np.ndarray]:
    """(N, T) phases and (N, T, D) values of ``demos`` resampled on one grid of T = the shortest's length."""
    t_len = min(len(d.times) for d in demos)
    grid = np.linspace(0.0, 1.0, t_len)
    values = np.stack([np.stack([np.interp(grid, (d.times - d.times[0]) / (d.times[-1] - d.times[0]), d.values[:, j])
                                 for j in range(d.values.shape[1])], axis=1) for d in demos])
    return np.tile(grid, (len(demos), 1)), values


def fold_steps(steps: int, n_fits: int) -> int:
    """The training steps of each of ``n_fits`` fold networks (folds x trained candidates) for a skill
    trained ``steps`` steps: together :data:`CHOICE_STEP_SHARE` of them, each at least
    :data:`MIN_FOLD_STEPS`. The choice costs about one more training of the skill."""
    return max(MIN_FOLD_STEPS, int(steps * CHOICE_STEP_SHARE / max(1, n_fits)))


def held_out_errors(demos: DemoSet, config: CNMPConfig, fit: Fit, seed: int = 0,
                    candidates: tuple[str, ...] = CANDIDATES,
                    folds: list[tuple[int, ...]] | None = None) -> tuple[dict[str, float], list[tuple[int, ...]]]:
    """Every candidate's held-out error at the edges of ``demos``' conditions (module docstring) and
    the folds. Candidates: "none" and "trend" (one network per fold, of ``config`` with weights
    seeded by ``seed``, trained by ``fit``, predicting alone or with the trend), and for studies
    "linear" (the linear path beside a network of its own) and "path" (the linear path alone,
    nothing trained). Empty errors when no fold exists."""
    demo_list = list(demos)
    params = demos.all_task_params()
    _, grid_values = _on_grid(demos)
    folds = edge_folds(params, grid_values) if folds is None else folds
    if not folds:
        return {}, []
    varying, std = varying_outputs(grid_values)
    if not varying.any():
        return {c: 0.0 for c in candidates}, folds
    trained = {"trend": "trend", "none": "trend", "linear": "linear"}  # the network each candidate's prediction uses
    n_fits = len(folds) * len({trained[c] for c in candidates if c in trained})
    errors: dict[str, list[float]] = {c: [] for c in candidates}
    for fold in folds:
        rest = demos.subset([i for i in range(len(demo_list)) if i not in fold])
        models: dict[str, CNMP] = {}
        for kind in sorted({trained.get(c, "path") for c in candidates}):
            model = CNMP(replace(config, prior="linear" if kind == "path" else kind, prior_choice=None), seed=seed)
            if kind == "path":
                model.fit_normalization(rest)
            else:
                fit(model, rest, n_fits)
            models[kind] = model
        for cand in candidates:
            model = models[trained.get(cand, "path")]
            if cand == "none":  # the same network without the trend: the paper's CNMP it is
                model = copy.deepcopy(model)
                model.config, model.prior = replace(model.config, prior="none"), None
            for k in fold:
                d = demo_list[k]
                marks = condition_marks(len(d.times), d.task_params.shape[0])
                query = model.make_query(d.times[marks], d.values[marks], d.task_params if d.task_params.size else None,
                                         d.times)
                pred = model.path_mean(query) if cand == "path" else model.predict_query(query).mean
                err = (pred - d.values) / np.where(varying, std, 1.0)
                errors[cand].append(float(np.sqrt(np.mean(err[:, varying] ** 2))))
    return {c: float(np.mean(e)) for c, e in errors.items()}, folds


def choose_prior(demos: DemoSet, config: CNMPConfig, fit: Fit, seed: int = 0) -> PriorChoice:
    """The model ``demos`` need (module docstring): :func:`held_out_errors` of the network alone and
    with the trend (its fold networks trained by ``fit``), the smaller wins (a tie: the network
    alone). Fewer than :data:`MIN_DEMOS` demonstrations, or no fold at the edges: the network alone."""
    n = len(demos)
    if n < MIN_DEMOS:
        return PriorChoice("none", {}, (), f"{n} demonstration(s): too few to hold any out and fit the rest "
                                           f"(at least {MIN_DEMOS}); the network alone (the paper's CNMP)")
    errors, folds = held_out_errors(demos, config, fit, seed)
    if not errors:
        return PriorChoice("none", {}, (), "no demonstration stands at an edge of the others' conditions to hold "
                                           "out; the network alone (the paper's CNMP)")
    chosen = min(CANDIDATES, key=lambda c: (round(errors[c], 9), CANDIDATES.index(c)))
    shown = ", ".join(f"{c} {errors[c]:.3g}" for c in CANDIDATES)
    return PriorChoice(chosen, errors, tuple(folds),
                       f"{NAMES[chosen]}: held-out error at the edges of the demonstrations' conditions {shown} "
                       f"({len(folds)} folds)")
