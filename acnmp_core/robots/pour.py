"""The ``pour`` robot kind: the pouring rig's wrist joint, its drawing and its simulator."""
from __future__ import annotations

from ..sim.pour import TEST_WEIGHT_G, PourConfig, PourSim, cup_boxes, receiver_boxes


def pour_body():
    """The registry's description of the ``pour`` robot kind (:mod:`acnmp_core.robots.registry`).

    Joints: the one wrist joint (``"wrist"``, limits :attr:`PourConfig.wrist_limits` rad); drawing:
    a :class:`~acnmp_core.robots.spec.PointSetDrawing` of the marbles (their radius, m), the cup
    turning about the wrist axis and the receiving cup;
    simulator: a :class:`PourSim` of the default rig loaded with :data:`TEST_WEIGHT_G` (the
    heaviest load of the experiments; :class:`PourTask` builds one world per load itself).
    """
    from functools import partial

    from .spec import Joint, PointSetDrawing, RobotBody

    cfg = PourConfig()
    lo, hi = cfg.wrist_limits
    drawing = PointSetDrawing(cfg.marbles.radius, tuple(cup_boxes(cfg.cup)), tuple(receiver_boxes(cfg.receiver)),
                              (0.0, 0.0, cfg.axis_height))
    return RobotBody((Joint("wrist", float(lo), float(hi)),), drawing, partial(PourSim, cfg.n_marbles(TEST_WEIGHT_G), cfg))
