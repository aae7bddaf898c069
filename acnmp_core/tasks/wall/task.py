"""The 2D wall-with-a-hole task (the paper's experiment E3, Akbulut et al., CoRL 2020, Sec. 4.2).

Geometry
--------
The world is the square [0, 10] x [0, 10] (world units). Every trajectory should start at
``START = (0, 5)``. A vertical wall of thickness ``WALL_THICKNESS = 0.2`` occupies the band
``x_c - 0.1 <= x <= x_c + 0.1`` for *every* y (it extends beyond the world's edges, so the only way
past it is the hole). The hole is the gap ``y_c - 0.5 <= y <= y_c + 0.5`` (``HOLE_WIDTH = 1.0``) through
the whole thickness of the wall. The goal is the point ``(x_g, y_g)``.

Task parameters are ``(x_c, y_c, x_g, y_g)``, drawn by :func:`sample_environments` with
``x_c ~ U[2, 8]``, ``y_c ~ U[1, 9]``, then ``x_g ~ U[x_c + 1.5, 10]`` and ``y_g ~ U[0, 10]``.

A trajectory is a sequence of T points ``(x, y)``; between samples the robot moves in a straight line,
so the wall test looks at the polyline, not only at the samples (a path cannot jump over the wall
between two samples). See :func:`wall_rewards` for the reward and :func:`wall_success` for success.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, NamedTuple

import numpy as np

from ...rollout import RolloutBatch
from ...validation import check_array, check_positive_int

WORLD_LOW = 0.0
WORLD_HIGH = 10.0
START = (0.0, 5.0)
#: Thickness of the wall along x (world units); the wall occupies ``|x - x_c| <= WALL_THICKNESS / 2``.
WALL_THICKNESS = 0.2
#: Width of the hole along y (world units); the hole is ``|y - y_c| <= HOLE_WIDTH / 2``.
HOLE_WIDTH = 1.0
#: Largest start / goal distance (world units) that still counts as a success.
START_TOLERANCE = 0.25
GOAL_TOLERANCE = 0.25
#: Weight of the goal error relative to the start error, as in the authors' reward.
GOAL_WEIGHT = 2.0
#: Seed of the fixed test set of 1000 environments (the paper's Fig. 5 d, e).
TEST_SEED = 20201116

N_TASK_PARAMS = 4
X_C_RANGE = (2.0, 8.0)
Y_C_RANGE = (1.0, 9.0)
GOAL_X_GAP = 1.5  # x_g >= x_c + GOAL_X_GAP
Y_G_RANGE = (0.0, 10.0)


# --------------------------------------------------------------------------------------------------
# Environments
# --------------------------------------------------------------------------------------------------


def sample_environments(n: int, rng: np.random.Generator) -> np.ndarray:
    """Draw ``n`` random environments.

    ``x_c ~ U[2, 8]``, ``y_c ~ U[1, 9]``, ``y_g ~ U[0, 10]`` independently, then
    ``x_g ~ U[x_c + 1.5, 10]`` given ``x_c`` (sequential sampling; the region is not a box).

    Parameters
    ----------
    n : number of environments, >= 1.
    rng : numpy Generator.

    Returns
    -------
    (n, 4) float64 array of ``(x_c, y_c, x_g, y_g)`` in world units.
    """
    n = check_positive_int("n", n)
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng: expected a numpy.random.Generator, got {type(rng).__name__}")
    # One (n, 4) block of uniforms, filled row by row, so the first k environments drawn from a
    # given seed do not depend on n (test sets of different sizes share a prefix).
    u = rng.random((n, N_TASK_PARAMS))
    x_c = X_C_RANGE[0] + u[:, 0] * (X_C_RANGE[1] - X_C_RANGE[0])
    y_c = Y_C_RANGE[0] + u[:, 1] * (Y_C_RANGE[1] - Y_C_RANGE[0])
    x_lo = x_c + GOAL_X_GAP
    x_g = x_lo + u[:, 2] * (WORLD_HIGH - x_lo)
    y_g = Y_G_RANGE[0] + u[:, 3] * (Y_G_RANGE[1] - Y_G_RANGE[0])
    return np.stack([x_c, y_c, x_g, y_g], axis=1)


def test_environments(n: int = 1000, seed: int = TEST_SEED) -> np.ndarray:
    """The fixed test set: the first ``n`` environments drawn with ``seed``. Returns (n, 4).

    The same ``seed`` always gives the same environments, and a smaller ``n`` gives a prefix of a
    larger one, so curves measured on fewer test environments stay comparable.
    """
    n = check_positive_int("n", n)
    return sample_environments(n, np.random.default_rng(seed))


test_environments.__test__ = False  # keep pytest from collecting it when imported into a test module


def wall_rectangles(
    task_params, *, hole_width: float = HOLE_WIDTH, wall_thickness: float = WALL_THICKNESS
) -> list[tuple[float, float, float, float]]:
    """The two solid parts of the wall inside the world, as ``(x, y, width, height)`` for plotting."""
    p = check_array("task_params", task_params, shape=(N_TASK_PARAMS,))
    x0 = p[0] - wall_thickness / 2
    lo, hi = p[1] - hole_width / 2, p[1] + hole_width / 2
    return [
        (x0, WORLD_LOW, wall_thickness, max(lo - WORLD_LOW, 0.0)),
        (x0, hi, wall_thickness, max(WORLD_HIGH - hi, 0.0)),
    ]


# --------------------------------------------------------------------------------------------------
# Scoring
# --------------------------------------------------------------------------------------------------


class WallScores(NamedTuple):
    """Per-trajectory components of the score, all (B,) arrays in world units.

    start_error : distance of the first point from ``START``.
    goal_error : distance of the last point from the goal ``(x_g, y_g)``.
    min_margin : signed clearance to the hole's edges at the tightest point of the path inside the
        wall's x band: ``min(y - (y_c - w/2), (y_c + w/2) - y)``, positive inside the hole, negative
        when that point is inside the wall; ``+inf`` when the path never enters the band.
    margin_step : index (int) of the sample nearest to that tightest point; -1 when never in the band.
    reaches_wall : whether any part of the polyline lies inside the wall's x band.
    """

    start_error: np.ndarray
    goal_error: np.ndarray
    min_margin: np.ndarray
    margin_step: np.ndarray
    reaches_wall: np.ndarray


def _check_inputs(trajectories, task_params) -> tuple[np.ndarray, np.ndarray]:
    """Validate and broadcast: returns trajectories (B, T, 2) and task_params (B, 4)."""
    traj = check_array("trajectories", trajectories, ndim=3, min_size=1)
    if traj.shape[2] != 2 or traj.shape[1] < 2:
        raise ValueError(f"trajectories: expected shape (B, T>=2, 2), got {traj.shape}")
    params = check_array("task_params", task_params, ndim=(1, 2))
    if params.shape[-1] != N_TASK_PARAMS:
        raise ValueError(f"task_params: expected shape (4,) or (B, 4), got {params.shape}")
    b = traj.shape[0]
    if params.ndim == 1:
        params = np.broadcast_to(params, (b, N_TASK_PARAMS))
    elif params.shape[0] != b:
        raise ValueError(f"task_params: expected {b} rows (one per trajectory), got {params.shape[0]}")
    return traj, params


def _hole_margin(y: np.ndarray, y_c: np.ndarray, half_width: float) -> np.ndarray:
    """Signed distance of height ``y`` to the nearer hole edge: > 0 inside the hole."""
    return half_width - np.abs(y - y_c)


def _segment_margins(
    traj: np.ndarray, params: np.ndarray, hole_width: float, wall_thickness: float
) -> tuple[np.ndarray, np.ndarray]:
    """Tightest clearance on each straight segment between consecutive samples.

    Each segment is clipped to the wall's x band; the clearance ``w/2 - |y - y_c|`` is concave in y
    and y is linear along the segment, so its minimum over the clipped piece lies at one of the
    piece's two ends. This is exact for the polyline and catches a segment that jumps over the wall.

    Returns
    -------
    margin : (B, T-1) clearance per segment, ``+inf`` for segments that miss the band.
    at_end : (B, T-1) bool, whether the tightest point is nearer the segment's end sample than its
        start sample.
    """
    x0, y0 = traj[:, :-1, 0], traj[:, :-1, 1]
    dx, dy = traj[:, 1:, 0] - x0, traj[:, 1:, 1] - y0
    x_c, y_c = params[:, 0:1], params[:, 1:2]
    lo, hi = x_c - wall_thickness / 2, x_c + wall_thickness / 2

    vertical = dx == 0.0
    safe_dx = np.where(vertical, 1.0, dx)
    s_lo, s_hi = (lo - x0) / safe_dx, (hi - x0) / safe_dx
    s_a = np.maximum(np.minimum(s_lo, s_hi), 0.0)
    s_b = np.minimum(np.maximum(s_lo, s_hi), 1.0)
    # A vertical segment is either wholly in the band or wholly out of it.
    in_band_vertical = (x0 >= lo) & (x0 <= hi)
    s_a = np.where(vertical, 0.0, s_a)
    s_b = np.where(vertical, 1.0, s_b)
    overlaps = np.where(vertical, in_band_vertical, s_a <= s_b)

    half = hole_width / 2
    m_a = _hole_margin(y0 + s_a * dy, y_c, half)
    m_b = _hole_margin(y0 + s_b * dy, y_c, half)
    tight_s = np.where(m_a <= m_b, s_a, s_b)
    margin = np.where(overlaps, np.minimum(m_a, m_b), np.inf)
    return margin, tight_s >= 0.5


def wall_scores(
    trajectories,
    task_params,
    *,
    hole_width: float = HOLE_WIDTH,
    wall_thickness: float = WALL_THICKNESS,
) -> WallScores:
    """Score components of B trajectories, each in its own environment.

    Parameters
    ----------
    trajectories : (B, T, 2) positions (world units), T >= 2.
    task_params : (4,) one environment for all trajectories, or (B, 4) one per trajectory.
    hole_width, wall_thickness : geometry (world units).

    Returns
    -------
    :class:`WallScores` of (B,) arrays.
    """
    traj, params = _check_inputs(trajectories, task_params)
    b = traj.shape[0]
    rows = np.arange(b)
    start_error = np.linalg.norm(traj[:, 0] - np.asarray(START), axis=1)
    goal_error = np.linalg.norm(traj[:, -1] - params[:, 2:4], axis=1)

    margin, at_end = _segment_margins(traj, params, hole_width, wall_thickness)
    seg = np.argmin(margin, axis=1)
    min_margin = margin[rows, seg]
    reaches_wall = np.isfinite(min_margin)
    margin_step = np.where(reaches_wall, seg + at_end[rows, seg].astype(np.int64), -1)
    return WallScores(start_error, goal_error, min_margin, margin_step, reaches_wall)


def wall_rewards(
    trajectories,
    task_params,
    *,
    hole_width: float = HOLE_WIDTH,
    wall_thickness: float = WALL_THICKNESS,
) -> np.ndarray:
    """Per-step rewards of B trajectories (the authors' form, on the polyline).

    For a trajectory ``p_0 .. p_{T-1}`` in environment ``(x_c, y_c, x_g, y_g)``::

        r_0       += -|p_0 - START|                       (start error)
        r_k*      += min over the path inside the wall band of  w/2 - |y - y_c|
        r_{T-1}   += -2 |p_{T-1} - (x_g, y_g)|            (goal error)

    all other steps 0. The middle term is the signed margin to the hole's edges at the tightest
    in-wall point (positive when the path passes inside the hole with that much clearance, negative
    by the penetration depth when it hits the wall); ``k*`` is the sample nearest that point. The
    path between samples is the straight segment, so a segment crossing the band is interpolated.
    A path that never enters the wall's x band gets no margin term (it cannot reach the goal, which
    lies beyond the wall, so the goal term penalises it). The return ``sum_t r_t`` is
    ``-start_error + margin - 2 goal_error``.

    Parameters
    ----------
    trajectories : (B, T, 2) positions (world units), T >= 2.
    task_params : (4,) or (B, 4) ``(x_c, y_c, x_g, y_g)``.
    hole_width, wall_thickness : geometry (world units).

    Returns
    -------
    (B, T) float64 rewards.
    """
    traj, params = _check_inputs(trajectories, task_params)
    s = wall_scores(traj, params, hole_width=hole_width, wall_thickness=wall_thickness)
    return _rewards_from_scores(s, traj.shape[0], traj.shape[1])


def _rewards_from_scores(s: WallScores, b: int, t: int, squared_clearance: bool = False) -> np.ndarray:
    rewards = np.zeros((b, t))
    rewards[:, 0] -= s.start_error
    rows = np.flatnonzero(s.reaches_wall)
    m = s.min_margin[rows]
    # The authors' notebook scores the signed *squared* clearance (sign kept: negative inside the wall).
    rewards[rows, s.margin_step[rows]] += m * np.abs(m) if squared_clearance else m
    rewards[:, -1] -= GOAL_WEIGHT * s.goal_error
    return rewards


def _success_from_scores(s: WallScores, start_tolerance: float, goal_tolerance: float,
                         min_clearance: float = 0.0) -> np.ndarray:
    # Strictly more than the clearance asked for: with 0, touching an edge counts as touching the wall.
    return (
        (s.start_error <= start_tolerance)
        & (s.goal_error <= goal_tolerance)
        & s.reaches_wall
        & (s.min_margin > min_clearance)
    )


def _errors_from_scores(s: WallScores, min_clearance: float = 0.0) -> np.ndarray:
    # How far the margin falls short of the clearance asked for: with 0, how deep the path goes into
    # the wall (the test metric's penetration).
    shortfall = np.where(s.reaches_wall, np.maximum(min_clearance - s.min_margin, 0.0), 0.0)
    return s.start_error + s.goal_error + shortfall


def wall_success(
    trajectories,
    task_params,
    *,
    start_tolerance: float = START_TOLERANCE,
    goal_tolerance: float = GOAL_TOLERANCE,
    hole_width: float = HOLE_WIDTH,
    wall_thickness: float = WALL_THICKNESS,
) -> np.ndarray:
    """Whether each trajectory solves its environment.

    Success = start error <= ``start_tolerance`` and goal error <= ``goal_tolerance`` and the
    polyline enters the wall band only inside the hole with strictly positive clearance (it never
    touches the wall, also between samples).

    Parameters and shapes as :func:`wall_rewards`. Returns (B,) bool.
    """
    s = wall_scores(trajectories, task_params, hole_width=hole_width, wall_thickness=wall_thickness)
    return _success_from_scores(s, start_tolerance, goal_tolerance)


def wall_errors(
    trajectories,
    task_params,
    *,
    hole_width: float = HOLE_WIDTH,
    wall_thickness: float = WALL_THICKNESS,
) -> np.ndarray:
    """Scalar error per trajectory for the test metric (world units, 0 is perfect).

    ``error = start_error + goal_error + max(0, -min_margin)``: the distances from start and goal
    plus how deep the path goes into the wall (0 when it passes through the hole). A trajectory
    that never reaches the wall is charged its (large) goal error only.

    Parameters and shapes as :func:`wall_rewards`. Returns (B,) float64.
    """
    s = wall_scores(trajectories, task_params, hole_width=hole_width, wall_thickness=wall_thickness)
    return _errors_from_scores(s)


# --------------------------------------------------------------------------------------------------
# Demonstrations
# --------------------------------------------------------------------------------------------------


def _ease(u: np.ndarray, blend: float) -> np.ndarray:
    """Monotone ease from 0 to 1 on u in [0, 1] with zero slope at both ends.

    A blend of smoothstep (``blend=0``) and smootherstep (``blend=1``); both have zero end slopes, so
    any blend joins the flat stretch through the hole without a kink.
    """
    u = np.clip(u, 0.0, 1.0)
    smooth = u * u * (3 - 2 * u)
    smoother = u**3 * (u * (6 * u - 15) + 10)
    return (1 - blend) * smooth + blend * smoother


def _demo_height(x: np.ndarray, knots: tuple[float, ...], blends: tuple[float, float]) -> np.ndarray:
    """Height y(x) of the demonstration: ease from the start to the hole, flat through it, ease to the goal."""
    x_in, x_out, y_start, y_hole, x_g, y_g = knots
    y = np.full_like(x, y_hole)
    before, after = x < x_in, x > x_out
    y[before] = y_start + (y_hole - y_start) * _ease(x[before] / x_in, blends[0])
    y[after] = y_hole + (y_g - y_hole) * _ease((x[after] - x_out) / (x_g - x_out), blends[1])
    return y


def demonstrate(
    task_params, n_steps: int = 200, rng: np.random.Generator | None = None, *, n_dense: int = 4000,
    wall_thickness: float = WALL_THICKNESS, hole_width: float = HOLE_WIDTH,
) -> tuple[np.ndarray, np.ndarray]:
    """A smooth demonstration from ``START`` through the hole to the goal, at uniform speed.

    The path is the graph of a C1 function y(x): an ease curve from ``(0, 5)`` to the hole's height,
    a straight horizontal stretch ``x_c - a <= x <= x_c + a`` through the hole, and an ease curve to
    the goal (zero slope where the pieces join). It is sampled at equal arc-length steps, so the
    wall is crossed at a time that depends on the environment (and on the random variation): the
    demonstrations are not time-aligned.

    Parameters
    ----------
    task_params : (4,) ``(x_c, y_c, x_g, y_g)``; needs ``0 < x_c < x_g``.
    n_steps : number of samples T >= 2.
    rng : if given, small random variation: the crossing height ``y_c + U(-0.15, 0.15) * w``,
        the half-length ``a ~ U(0.3, 0.8)`` of the flat stretch and the shapes of the two ease
        curves. Without it, the path crosses at the hole's centre with ``a = 0.5``.
    n_dense : points of the dense polyline used to measure arc length.
    wall_thickness, hole_width : the geometry (world units). The crossing offset scales with the
        hole's width. A wall thicker than the default one (the authors' 2.0) gets a flat stretch that
        covers it: half-length ``wall_thickness / 2 + 0.05 + 0.4 u`` (u in [0, 1] from the same draw
        as ``a``; the authors' demonstrations use ``x_c +- 1.45``), at most 0.02 short of the start
        and of the goal's x, so the last piece may be steep, as theirs.

    Returns
    -------
    times : (T,) ``linspace(0, 1, T)`` (normalised time).
    path : (T, 2) positions (world units); ``path[0] = START``, ``path[-1] = (x_g, y_g)``.
    """
    p = check_array("task_params", task_params, shape=(N_TASK_PARAMS,))
    n_steps = check_positive_int("n_steps", n_steps, minimum=2)
    n_dense = check_positive_int("n_dense", n_dense, minimum=100)
    x_c, y_c, x_g, y_g = p
    if not (0.0 < x_c < x_g):
        raise ValueError(f"task_params: expected 0 < x_c < x_g, got x_c={x_c}, x_g={x_g}")
    if rng is None:
        a, offset, blends = 0.5, 0.0, (0.0, 0.0)
    else:
        a = rng.uniform(0.3, 0.8)
        offset = rng.uniform(-0.15, 0.15) * hole_width
        blends = (rng.uniform(), rng.uniform())
    if wall_thickness > WALL_THICKNESS:
        # A thick wall: the flat stretch must span it (an ease curve inside the band would clip it).
        a = min(wall_thickness / 2 + 0.05 + 0.4 * (a - 0.3) / 0.5, x_c - 0.02, x_g - x_c - 0.02)
    else:
        # Keep the flat stretch inside (0, x_g) for environments outside the training ranges, and at
        # least as long as the wall is thick.
        room = 0.45 * min(x_c, x_g - x_c)
        a = max(min(a, room), min(WALL_THICKNESS, room))
    knots = (x_c - a, x_c + a, START[1], y_c + offset, x_g, y_g)

    # Arc length on a dense polyline; x increases strictly along the path, so x(s) is invertible
    # and y is evaluated exactly on the curve at the resampled x.
    xd = np.linspace(START[0], x_g, n_dense)
    yd = _demo_height(xd, knots, blends)
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(xd), np.diff(yd)))])
    x = np.interp(np.linspace(0.0, arc[-1], n_steps), arc, xd)
    x[0], x[-1] = START[0], x_g
    path = np.stack([x, _demo_height(x, knots, blends)], axis=1)
    return np.linspace(0.0, 1.0, n_steps), path


def make_demo_set(
    n_envs: int, rng: np.random.Generator, *, n_steps: int = 200, task_params=None,
    wall_thickness: float = WALL_THICKNESS, hole_width: float = HOLE_WIDTH,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Demonstrations for ``n_envs`` random environments (one each, with random variation).

    Parameters
    ----------
    n_envs : number of environments N >= 1.
    rng : numpy Generator, used for the environments and the variation.
    n_steps : samples per demonstration T.
    task_params : optional (N, 4) environments to demonstrate instead of sampling new ones.
    wall_thickness, hole_width : the geometry the demonstrations avoid (see :func:`demonstrate`).

    Returns
    -------
    times : (N, T) normalised time, values : (N, T, 2) positions, task_params : (N, 4).
    Ready for ``DemoSet.from_arrays(times, values, task_params)``.
    """
    n_envs = check_positive_int("n_envs", n_envs)
    if task_params is None:
        params = sample_environments(n_envs, rng)
    else:
        params = check_array("task_params", task_params, shape=(n_envs, N_TASK_PARAMS))
    demos = [demonstrate(params[i], n_steps, rng, wall_thickness=wall_thickness, hole_width=hole_width)
             for i in range(n_envs)]
    times = np.stack([d[0] for d in demos])
    values = np.stack([d[1] for d in demos])
    return times, values, params


# --------------------------------------------------------------------------------------------------
# Roll-out evaluator
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class WallTask:
    """The wall task as a :class:`~acnmp_core.rollout.RolloutEvaluator` (analytic, no simulation).

    Executing a trajectory is the identity: the executed path is the commanded one. Geometry and
    tolerances are in world units and default to the module constants. ``min_clearance`` (world
    units): success needs the tightest in-wall clearance strictly above it (default 0: not touching).
    ``squared_clearance``: the reward's clearance term is ``m |m|`` instead of the margin ``m`` (the
    authors' notebook). The defaults are the task as it always was.
    """

    hole_width: float = HOLE_WIDTH
    wall_thickness: float = WALL_THICKNESS
    start_tolerance: float = START_TOLERANCE
    goal_tolerance: float = GOAL_TOLERANCE
    min_clearance: float = 0.0
    squared_clearance: bool = False

    #: Task parameters per environment and position dimensions per step.
    n_task_params: ClassVar[int] = N_TASK_PARAMS
    output_dim: ClassVar[int] = 2

    def evaluate(self, trajectories, times, task_params=None) -> RolloutBatch:
        """Score B trajectories in one environment.

        Parameters
        ----------
        trajectories : (B, T, 2) positions (world units).
        times : (T,) their times (unused by the reward, which is per step, but checked).
        task_params : (4,) ``(x_c, y_c, x_g, y_g)``.

        Returns
        -------
        RolloutBatch with rewards (B, T) (see :func:`wall_rewards`), success (B,),
        ``states={"path": trajectories}`` and errors (B,): how far each roll-out is from this task's
        success, start error + goal error + the margin's shortfall below ``min_clearance`` (with
        ``min_clearance`` 0, the paper's, the test metric :func:`wall_errors`).
        """
        if task_params is None:
            raise ValueError("task_params: the wall task needs (x_c, y_c, x_g, y_g), got None")
        check_array("task_params", task_params, shape=(N_TASK_PARAMS,))
        return self.evaluate_batch(trajectories, times, task_params)

    def evaluate_batch(self, trajectories, times, task_params) -> RolloutBatch:
        """Score B trajectories, each in its own environment: task_params (B, 4) (or (4,) for all)."""
        traj, params = _check_inputs(trajectories, task_params)
        check_array("times", times, shape=(traj.shape[1],))
        s = wall_scores(traj, params, hole_width=self.hole_width, wall_thickness=self.wall_thickness)
        return RolloutBatch(
            rewards=_rewards_from_scores(s, traj.shape[0], traj.shape[1], self.squared_clearance),
            success=_success_from_scores(s, self.start_tolerance, self.goal_tolerance, self.min_clearance),
            states={"path": traj},
            errors=_errors_from_scores(s, self.min_clearance),
        )

    def scores(self, trajectories, task_params) -> WallScores:
        """:func:`wall_scores` in this task's geometry: trajectories (B, T, 2), task_params (4,) or (B, 4)."""
        return wall_scores(trajectories, task_params, hole_width=self.hole_width, wall_thickness=self.wall_thickness)

    def success(self, trajectories, task_params) -> np.ndarray:
        """(B,) bool: this task's success criterion, trajectories (B, T, 2), task_params (4,) or (B, 4)."""
        return _success_from_scores(self.scores(trajectories, task_params), self.start_tolerance,
                                    self.goal_tolerance, self.min_clearance)

    def errors(self, trajectories, task_params) -> np.ndarray:
        """(B,) test-metric error, see :func:`wall_errors`."""
        return wall_errors(
            trajectories, task_params, hole_width=self.hole_width, wall_thickness=self.wall_thickness
        )
