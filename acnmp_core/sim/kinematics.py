"""Analytic kinematics of a planar serial arm with revolute joints about the vertical axis.

Used by the scripted expert (inverse kinematics) and by tests to check the simulator's end effector.
Angles in radians, lengths in metres. The arm's base is at the world origin; joint ``i`` rotates
about +z and link ``i`` extends along its own x axis.
"""
from __future__ import annotations

import numpy as np

from ..validation import check_array


def planar_fk(q, link_lengths) -> np.ndarray:
    """Forward kinematics.

    Parameters
    ----------
    q : (..., N) joint angles (rad).
    link_lengths : (N,) link lengths (m).

    Returns
    -------
    (..., 3) end-effector pose ``[x, y, phi]``: tip position (m) and heading of the last link (rad),
    ``phi = sum(q)``.
    """
    q = check_array("q", q, ndim=None)
    lengths = check_array("link_lengths", link_lengths, ndim=1, min_size=1)
    if q.shape[-1] != lengths.shape[0]:
        raise ValueError(f"q: expected {lengths.shape[0]} joint angles on the last axis, got {q.shape[-1]}")
    cum = np.cumsum(q, axis=-1)
    x = np.sum(lengths * np.cos(cum), axis=-1)
    y = np.sum(lengths * np.sin(cum), axis=-1)
    return np.stack([x, y, cum[..., -1]], axis=-1)


def planar_jacobian(q, link_lengths) -> np.ndarray:
    """(3, N) Jacobian of ``planar_fk`` at one configuration ``q`` (N,)."""
    q = check_array("q", q, ndim=1)
    lengths = check_array("link_lengths", link_lengths, shape=(q.shape[0],))
    cum = np.cumsum(q)
    # Joint j moves every link from j on: the tip's velocity sums those links' contributions.
    sx = lengths * np.sin(cum)
    cx = lengths * np.cos(cum)
    jac = np.empty((3, q.shape[0]))
    jac[0] = -np.cumsum(sx[::-1])[::-1]
    jac[1] = np.cumsum(cx[::-1])[::-1]
    jac[2] = 1.0
    return jac


def wrap_angle(a):
    """Wrap angles (rad) to (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(a, dtype=np.float64), 2.0 * np.pi)


def planar_ik(
    pose,
    q0,
    link_lengths,
    joint_limits=None,
    *,
    q_rest=None,
    iters: int = 200,
    damping: float = 1e-3,
    tol: float = 1e-6,
    rest_gain: float = 0.05,
) -> np.ndarray:
    """Damped least-squares inverse kinematics for the pose ``[x, y, phi]``.

    Parameters
    ----------
    pose : (3,) target tip position (m) and heading (rad).
    q0 : (N,) initial guess (rad); warm-starting from the previous waypoint keeps a path smooth.
    link_lengths : (N,) link lengths (m).
    joint_limits : (N, 2) lower/upper limits (rad) or None; iterates are clipped into them.
    q_rest : (N,) preferred posture for redundant arms (N > 3), pulled towards in the null space.
    iters, damping, tol : solver iterations, Levenberg damping, and the pose error to stop at.
    rest_gain : step size of the null-space pull towards ``q_rest``.

    Returns
    -------
    (N,) joint angles. The caller checks the residual with :func:`planar_fk` when it matters.
    """
    pose = check_array("pose", pose, shape=(3,))
    q = check_array("q0", q0, ndim=1).copy()
    lengths = check_array("link_lengths", link_lengths, shape=(q.shape[0],))
    limits = None if joint_limits is None else check_array("joint_limits", joint_limits, shape=(q.shape[0], 2))
    rest = None if q_rest is None else check_array("q_rest", q_rest, shape=(q.shape[0],))
    n = q.shape[0]
    for _ in range(iters):
        err = pose - planar_fk(q, lengths)
        err[2] = wrap_angle(err[2])
        if np.linalg.norm(err) < tol:
            break
        jac = planar_jacobian(q, lengths)
        jjt = jac @ jac.T + damping * np.eye(3)
        dq = jac.T @ np.linalg.solve(jjt, err)
        if rest is not None and n > 3:
            # Null-space projection keeps the task pose while drifting the extra DoF to a rest posture.
            # The exact projector (pseudo-inverse, not the damped one) so the pull never moves the tip.
            null = np.eye(n) - np.linalg.pinv(jac) @ jac
            dq = dq + rest_gain * null @ (rest - q)
        q = q + dq
        if limits is not None:
            q = np.clip(q, limits[:, 0], limits[:, 1])
    return q
