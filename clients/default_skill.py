"""The skill ``acnmp up`` serves with no arguments: E1's via-point skill (paper Sec. 4.1).

:func:`default_demos` writes E1's six obstacle-avoidance demonstrations (times (T,) in [0, 1] s,
values (T, 2) = (x, y) in metres, the ones :func:`acnmp_core.experiments.viapoint.make_setup`
uses) as a demonstration file, so the learner trains skill ``e1`` from it at its first start
(``--demos e1=FILE``) and keeps the checkpoint in the state directory afterwards.
"""
from __future__ import annotations

from pathlib import Path

from acnmp_core.data.demo_io import load_demos, save_demos
from acnmp_core.tasks.viapoint.task import obstacle_demos
from services.learner.store import StateDir, demo_set_to_arrays, reason_of

#: The default skill's name (the same as ``acnmp experiment viapoint --distributed`` trains).
SKILL = "e1"


def default_demos(directory: str | Path) -> str:
    """Write ``<directory>/e1-demos.npz`` (if missing, or unreadable: then it is quarantined first,
    services/learner/store.py) and return the learner's ``--demos`` spec ``e1=<path>``."""
    path = Path(directory) / f"{SKILL}-demos.npz"
    if path.exists():
        try:
            load_demos(path)
        except ValueError as exc:  # the file is ours to write again; the bad one is kept aside
            StateDir(directory).quarantine(path, reason_of(exc))
    if not path.exists():
        save_demos(path, demo_set_to_arrays(obstacle_demos(), value_names=("x", "y")))
    return f"{SKILL}={path.resolve()}"
