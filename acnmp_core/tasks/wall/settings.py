"""The two E3 task settings: the paper's text as the project reads it, and the authors' notebook.

A :class:`WallSetting` fixes everything the setting changes: the wall's geometry, when a generated
trajectory is accepted without adaptation (the *trigger*), when an adaptation stops (the *goal*),
and whether the reward's clearance term is squared.

* ``paper`` (the default, unchanged): wall 0.2 thick, hole 1.0 high; a trajectory is good when it
  starts and ends within 0.25 of the start and the goal and clears the wall (clearance > 0); the
  same criterion triggers the adaptation and stops it; the reward's clearance term is the margin.
  A stricter stop than the trigger (the authors' hysteresis) was measured at 300 environments
  (``benchmarks/studies/e3_wall/results/e3_stop.json``, errors <= 0.10 ... 0.20): it lowered ACNMP's test success
  (by 1-15 points) for 1.5-3.2x the trajectories, so the paper setting keeps stop = trigger.
* ``authors`` (``Experiment3/ACNMP - ThirdExperiment.ipynb`` in mtuluhanakbulut/ACNMP): the wall
  spans ``x_c +- 1`` (thickness 2), the hole ``y_c +- 1`` (height 2). The clearance is the
  signed *squared* distance to the nearer hole edge. RL is triggered when the start or goal error
  is > 0.15 or the squared clearance < 0.2 (a clearance below 0.447); it stops when both errors are
  < 0.05 and the squared clearance > 0.4 (a clearance above 0.632). Their reward's clearance term
  is that signed squared clearance.

Where we differ from the notebook in both settings: the clearance is measured on the polyline (a
segment between two samples cannot skip the wall), not on the samples only; trajectories have 100
samples, theirs 200.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from . import task as W

#: Setting names, the default first.
SETTING_NAMES = ("paper", "authors")


@dataclass(frozen=True)
class WallSetting:
    """One E3 task setting (world units).

    name : "paper" or "authors".
    wall_thickness, hole_width : the geometry.
    goal_tolerance : an adaptation stops when the start and goal errors are at most this ...
    goal_clearance : ... and the tightest clearance is above this.
    trigger_tolerance, trigger_clearance : a generated trajectory is accepted (no adaptation) when
        its start and goal errors are at most ``trigger_tolerance`` and its clearance above
        ``trigger_clearance``.
    squared_clearance : the reward's clearance term is the signed squared clearance.
    """

    name: str
    wall_thickness: float
    hole_width: float
    goal_tolerance: float
    goal_clearance: float
    trigger_tolerance: float
    trigger_clearance: float
    squared_clearance: bool

    def task(self) -> W.WallTask:
        """The evaluator the adaptations run on: success = the adaptation's stopping criterion."""
        return W.WallTask(hole_width=self.hole_width, wall_thickness=self.wall_thickness,
                          start_tolerance=self.goal_tolerance, goal_tolerance=self.goal_tolerance,
                          min_clearance=self.goal_clearance, squared_clearance=self.squared_clearance)

    def trigger(self) -> W.WallTask:
        """The same task with the trigger's criterion: success = accepted without adaptation."""
        return W.WallTask(hole_width=self.hole_width, wall_thickness=self.wall_thickness,
                          start_tolerance=self.trigger_tolerance, goal_tolerance=self.trigger_tolerance,
                          min_clearance=self.trigger_clearance, squared_clearance=self.squared_clearance)

    @property
    def same_criteria(self) -> bool:
        """Whether the trigger and the stopping criterion are the same (the paper setting)."""
        return (self.goal_tolerance, self.goal_clearance) == (self.trigger_tolerance, self.trigger_clearance)


PAPER = WallSetting(
    name="paper",
    wall_thickness=W.WALL_THICKNESS,
    hole_width=W.HOLE_WIDTH,
    goal_tolerance=W.GOAL_TOLERANCE,
    goal_clearance=0.0,
    trigger_tolerance=W.GOAL_TOLERANCE,
    trigger_clearance=0.0,
    squared_clearance=False,
)

AUTHORS = WallSetting(
    name="authors",
    wall_thickness=2.0,
    hole_width=2.0,
    goal_tolerance=0.05,
    goal_clearance=math.sqrt(0.4),  # squared clearance > 0.4
    trigger_tolerance=0.15,
    trigger_clearance=math.sqrt(0.2),  # RL when the squared clearance < 0.2
    squared_clearance=True,
)

_SETTINGS = {s.name: s for s in (PAPER, AUTHORS)}


def wall_setting(name: str) -> WallSetting:
    """The :class:`WallSetting` called ``name`` (one of :data:`SETTING_NAMES`); ValueError otherwise."""
    if name not in _SETTINGS:
        raise ValueError(f"setting: expected one of {', '.join(SETTING_NAMES)}, got {name!r}")
    return _SETTINGS[name]
