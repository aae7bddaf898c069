"""E4's demonstrations: proxy skills shown by both arms, and the new skill shown by the 3-DoF arm only.

A scripted expert plans tip paths ``(x, y, heading)`` over :data:`N_STEPS` = 300 rows (phase
``linspace(0, 1, 300)`` is the only input of the models) and converts them to joint angles with
damped least-squares IK on each arm (:func:`~acnmp_core.tasks.push.demos.follow_poses`), so both
arms' demonstration i follow the same tip path and pair up row by row.

Every path starts from the same home pose, 10 cm in front of the gap of the E4 scene
(:class:`~acnmp_core.tasks.transfer.scene.CubeGapScene`), paddle facing it, and has the phases of
the pushing demonstrations: hold (rows 0-20), move to an approach pose (20-140), settle (140-150),
the skill's own motion (150-280), hold. The proxy skills (after the authors' reach, push and peg
insertion), 4 demonstrations each:

* **reach**: move to one of 4 poses around the gap and stay there;
* **wipe**: from an approach pose 6 cm in front of the wall line, sweep 8 cm along the wall;
* **insert**: from 4 cm in front of the wall line at 4 lateral offsets (+-3, +-9 cm from the gap),
  move 6 cm straight towards the wall. The proxy skills are shown in free space (no walls), as
  kinematic paths, like the authors' proxy demonstrations recorded in their own scenes.

The **new skill** (3-DoF arm only): from home, put the paddle behind the cube and push it through
the gap to the goal; the aim is corrected over a few simulated trials on :class:`CubeGapSim`
(:func:`~acnmp_core.tasks.push.demos.expert_push`'s rule: aim past a miss by the miss).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...sim.urdf import ArmGeometry
from ..push.demos import PHASES, _min_jerk, follow_poses, ik_from_seeds
from .scene import CubeGapScene, CubeGapSim, transfer_geometry

#: Rows per demonstration.
N_STEPS = 300
#: The proxy skills, in row order of the demonstration arrays (4 rows each).
PROXY_SKILLS = ("reach", "wipe", "insert")
#: Distance (m) of the home pose in front of the gap.
HOME_OFFSET = 0.10


@dataclass
class TransferDemos:
    """E4's demonstrations (rad, phase times).

    times (300,); proxy_a (12, 300, 3) and proxy_b (12, 300, 4), row i of one pairs with row i of the
    other; skill_names (12,) str; new_a (300, 3) the new skill on the 3-DoF arm; home_a (3,),
    home_b (4,) the arms' postures at the common home pose; new_a_error the cube's final distance (m)
    to the goal when new_a is executed.
    """

    times: np.ndarray
    proxy_a: np.ndarray
    proxy_b: np.ndarray
    skill_names: np.ndarray
    new_a: np.ndarray
    home_a: np.ndarray
    home_b: np.ndarray
    new_a_error: float


def _heading(v: np.ndarray) -> float:
    return float(np.arctan2(v[1], v[0]))


def home_pose(scene: CubeGapScene) -> np.ndarray:
    """(3,) tip pose ``[x, y, heading]`` every demonstration starts from."""
    n = scene.wall_normal
    return np.array([*(scene.gap_centre - HOME_OFFSET * n), _heading(n)])


def _blend(a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
    """(n, 3) poses from ``a`` to ``b`` (3,) with a minimum-jerk profile."""
    return a + (b - a) * _min_jerk(n)[:, None]


def _path(scene: CubeGapScene, approach: np.ndarray, end: np.ndarray) -> np.ndarray:
    """(N_STEPS, 3) poses: hold home, move to ``approach``, settle, move to ``end``, hold."""
    h0, h1, h2, h3, _ = PHASES
    home = home_pose(scene)
    poses = np.empty((N_STEPS, 3))
    poses[:h0] = home
    poses[h0:h1] = _blend(home, approach, h1 - h0)
    poses[h1:h2] = approach
    poses[h2:h3] = _blend(approach, end, h3 - h2)
    poses[h3:] = end
    return poses


def proxy_paths(scene: CubeGapScene | None = None) -> list[tuple[str, np.ndarray]]:
    """The 12 proxy tip paths as ``(skill name, poses (N_STEPS, 3))``, 4 per skill of :data:`PROXY_SKILLS`."""
    scene = scene or CubeGapScene()
    c, n, d = scene.gap_centre, scene.wall_normal, scene.wall_direction
    hn = _heading(n)

    def pose(xy, dh=0.0):
        return np.array([*xy, hn + dh])

    out = []
    for dn, dd, dh in ((-0.08, 0.12, 0.3), (-0.08, -0.12, -0.3), (-0.15, 0.06, 0.15), (-0.15, -0.06, -0.15)):
        target = pose(c + dn * n + dd * d, dh)
        out.append(("reach", _path(scene, target, target)))
    for dd0, sweep, dh in ((0.10, -0.08, 0.2), (-0.10, 0.08, -0.2), (0.04, 0.08, 0.0), (-0.04, -0.08, 0.0)):
        a = pose(c - 0.06 * n + dd0 * d, dh)
        out.append(("wipe", _path(scene, a, a + np.array([*(sweep * d), 0.0]))))
    for dd in (-0.09, -0.03, 0.03, 0.09):
        a = pose(c - 0.04 * n + dd * d)
        out.append(("insert", _path(scene, a, a + np.array([*(0.06 * n), 0.0]))))
    return out


def new_skill_path(scene: CubeGapScene, aim_xy, geometry: ArmGeometry) -> np.ndarray:
    """(N_STEPS, 3) poses pushing the cube from its start towards ``aim_xy`` (2,) through the gap."""
    cube = np.asarray(scene.cube_xy, dtype=np.float64)
    u = (np.asarray(aim_xy, dtype=np.float64) - cube)
    u /= np.linalg.norm(u)
    face = scene.cube_size / 2 + geometry.paddle_thickness / 2  # tip-to-cube-centre distance at contact
    h = _heading(u)
    approach = np.array([*(cube - (face + 0.01) * u), h])
    end = np.array([*(np.asarray(aim_xy) - face * u), h])
    return _path(scene, approach, end)


def expert_new_skill(sim: CubeGapSim, trials: int = 5) -> tuple[np.ndarray, float]:
    """The 3-DoF (or any) arm's demonstration of the new skill on ``sim``: joint trajectory
    (N_STEPS, N) rad, corrected over ``trials`` simulated attempts, and its final cube error (m)."""
    scene, geometry = sim.scene, sim.geometry
    goal = np.asarray(scene.goal_xy, dtype=np.float64)
    q_home = ik_from_seeds(home_pose(scene), geometry)
    aim, best = goal.copy(), None
    for _ in range(max(1, trials)):
        traj = follow_poses(new_skill_path(scene, aim, geometry), geometry, q_home)
        err_v = goal - sim.rollout(traj)["object_xy"][-1]
        err = float(np.linalg.norm(err_v))
        if best is None or err < best[1]:
            best = (traj, err)
        if err < 2e-3:
            break
        aim = aim + err_v
    return best


def make_transfer_demos(scene: CubeGapScene | None = None, *, trials: int = 5) -> TransferDemos:
    """Generate E4's demonstrations (about 2 s): the 12 proxy demonstrations on both arms and the new
    skill on the 3-DoF arm. Raises ValueError if a path leaves an arm's reach."""
    scene = scene or CubeGapScene()
    ga, gb = transfer_geometry(3), transfer_geometry(4)
    home = home_pose(scene)
    home_a, home_b = ik_from_seeds(home, ga), ik_from_seeds(home, gb)
    paths = proxy_paths(scene)
    proxy_a = np.stack([follow_poses(poses, ga, home_a) for _, poses in paths])
    proxy_b = np.stack([follow_poses(poses, gb, home_b) for _, poses in paths])
    with CubeGapSim(3, scene) as sim:
        new_a, err = expert_new_skill(sim, trials)
    return TransferDemos(times=np.linspace(0.0, 1.0, N_STEPS), proxy_a=proxy_a, proxy_b=proxy_b,
                         skill_names=np.array([name for name, _ in paths]), new_a=new_a,
                         home_a=home_a, home_b=home_b, new_a_error=err)
