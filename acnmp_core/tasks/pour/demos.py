"""Scripted expert for the pouring experiment (E6) and its demonstration set.

The expert turns the wrist from upright (0 rad) to a tilt angle with a minimum-jerk profile, holds it
while the marbles run out, and turns back the same way (:func:`expert_pour_trajectory`). Each
trajectory has :data:`N_STEPS` = 240 rows, 4 s at the 60 Hz control rate of
:class:`~acnmp_core.sim.pour.PourSim`; times are the phase ``linspace(0, 1, 240)``.

Demonstrations (:func:`make_pour_demos`): 16 initial weights from 650 to 1200 g (:func:`demo_weights_g`,
each a whole number of marbles) with tilt angles spread over 85-95 deg (:data:`DEMO_ANGLES_DEG`, a
fixed shuffle, so weight and angle are not correlated). The task parameters of a demonstration are
``(initial weight g, poured g)``, the second being what that motion pours in this simulator: the
target amount it demonstrates. The cache file's name carries a fingerprint of the rig's
configuration, so demonstrations recorded on another rig are never loaded by mistake.
"""
from __future__ import annotations

import hashlib
import os

import numpy as np

from ...data.demo_io import DemoArrays, load_demos, save_demos
from ...sim.pour import PourConfig
from .task import PourTask
from ...validation import check_positive_int

#: Rows per demonstration (4 s at 60 Hz).
N_STEPS = 240
#: Default phase lengths (rows): tilt, hold, return; the rest of the rows hold the upright cup.
TILT_STEPS, HOLD_STEPS, RETURN_STEPS = 60, 120, 45
#: Nominal initial weights (g) of the 16 demonstrations (see :func:`demo_weights_g`).
NOMINAL_WEIGHTS_G = np.linspace(650.0, 1200.0, 16)
#: Tilt angles (deg) of the 16 demonstrations: 16 levels over 85-95 deg, shuffled by a stride of 7.
DEMO_ANGLES_DEG = 85.0 + 10.0 * ((7 * np.arange(16)) % 16) / 15.0
NOMINAL_WEIGHTS_G.setflags(write=False)
DEMO_ANGLES_DEG.setflags(write=False)


def _min_jerk(n: int) -> np.ndarray:
    """(n,) minimum-jerk profile from 0 to 1 (zero velocity and acceleration at both ends)."""
    s = np.linspace(0.0, 1.0, n)
    return 10 * s**3 - 15 * s**4 + 6 * s**5


def expert_pour_trajectory(angle_deg: float, *, tilt_steps: int = TILT_STEPS, hold_steps: int = HOLD_STEPS,
                           return_steps: int = RETURN_STEPS, n_steps: int = N_STEPS) -> np.ndarray:
    """The expert's wrist trajectory (n_steps, 1) rad: tilt to ``angle_deg``, hold, return upright.

    Parameters
    ----------
    angle_deg : the tilt (deg) held after ``tilt_steps`` rows; 0 is upright, 90 the cup on its side.
    tilt_steps, return_steps : rows of the minimum-jerk turn out and back (>= 2 each).
    hold_steps : rows at the tilt (>= 0).
    n_steps : total rows; the rows after the return hold the cup upright.

    Raises ValueError naming the argument when the phases do not fit in ``n_steps`` or the angle is
    not finite.
    """
    angle = float(angle_deg)
    if not np.isfinite(angle):
        raise ValueError(f"angle_deg: expected a finite angle, got {angle_deg!r}")
    tilt_steps = check_positive_int("tilt_steps", tilt_steps, minimum=2)
    return_steps = check_positive_int("return_steps", return_steps, minimum=2)
    hold_steps = check_positive_int("hold_steps", hold_steps, minimum=0)
    n_steps = check_positive_int("n_steps", n_steps, minimum=1)
    if tilt_steps + hold_steps + return_steps > n_steps:
        raise ValueError(f"n_steps: {n_steps} rows cannot hold {tilt_steps} + {hold_steps} + {return_steps} "
                         "rows of tilt, hold and return")
    a = np.deg2rad(angle)
    q = np.zeros(n_steps)
    q[:tilt_steps] = a * _min_jerk(tilt_steps)
    q[tilt_steps:tilt_steps + hold_steps] = a
    q[tilt_steps + hold_steps:tilt_steps + hold_steps + return_steps] = a * (1.0 - _min_jerk(return_steps))
    return q[:, None]


def demo_weights_g(config: PourConfig | None = None) -> np.ndarray:
    """(16,) initial weights (g) of the demonstrations: :data:`NOMINAL_WEIGHTS_G` rounded to whole
    marbles of ``config`` (the default rig: 75 g tare + 23..45 marbles of 25 g = 650..1200 g)."""
    config = config if config is not None else PourConfig()
    return np.array([config.weight_g(config.n_marbles(w)) for w in NOMINAL_WEIGHTS_G])


def make_pour_demos(config: PourConfig | None = None) -> DemoArrays:
    """Run the expert for the 16 (weight, angle) pairs of :func:`demo_weights_g` and :data:`DEMO_ANGLES_DEG`.

    Returns a :class:`~acnmp_core.data.demo_io.DemoArrays` with times (16, 240) phase, values (16, 240, 1)
    wrist angle (rad), task_params (16, 2) = (initial weight g, measured poured mass g), roles all
    "train". About 15 s of CPU (16 worlds settle, 16 roll-outs).
    """
    times = np.linspace(0.0, 1.0, N_STEPS)
    weights = demo_weights_g(config)
    values, poured = [], []
    with PourTask(config, max_worlds=1) as task:
        for weight, angle in zip(weights, DEMO_ANGLES_DEG):
            traj = expert_pour_trajectory(angle)
            batch = task.evaluate(traj[None], times, np.array([weight, 0.0]))
            values.append(traj)
            poured.append(float(batch.states["poured_g"][0]))
    n = len(values)
    return DemoArrays(
        times=np.tile(times, (n, 1)),
        values=np.stack(values),
        task_params=np.stack([weights, np.asarray(poured)], axis=1),
        task_param_names=np.array(["initial_weight_g", "target_g"]),
        value_names=np.array(["wrist"]),
        roles=np.array(["train"] * n),
    )


def config_fingerprint(config: PourConfig | None = None) -> str:
    """8 hex digits identifying a rig configuration (its dataclass repr)."""
    config = config if config is not None else PourConfig()
    return hashlib.sha256(repr(config).encode()).hexdigest()[:8]


def default_demo_path(config: PourConfig | None = None) -> str:
    """Where :func:`pour_demos` caches the set: ``$ACNMP_CACHE`` or ``~/.cache/acnmp``, named
    ``pour_demos_<fingerprint>.npz`` after the rig's configuration."""
    root = os.environ.get("ACNMP_CACHE") or os.path.join(os.path.expanduser("~"), ".cache", "acnmp")
    return os.path.join(root, f"pour_demos_{config_fingerprint(config)}.npz")


def pour_demos(path: str | None = None, *, config: PourConfig | None = None, regenerate: bool = False) -> DemoArrays:
    """The E6 demonstration set, loaded from ``path`` (default :func:`default_demo_path`) or generated
    with :func:`make_pour_demos` and saved there first."""
    path = path or default_demo_path(config)
    if not regenerate and os.path.exists(path):
        return load_demos(path)
    demos = make_pour_demos(config)
    save_demos(path, demos)
    return demos
