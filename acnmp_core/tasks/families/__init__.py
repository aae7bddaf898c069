"""Path families whose demonstrations are not linear in their condition.

Each family is a function ``path(t, c)`` of the phase ``t`` in [0, 1] and a task parameter vector
``c``; its demonstrations are the family's paths at conditions spread over a training region, and
its task is to follow the family's path at a new condition through a few checkpoints
(:class:`FamilyTask`). A linear-Gaussian conditioning (a ProMP's) extrapolates such a family
poorly, which is why the comparison of record has them beside E2:

* :data:`BUMP`: a bump whose time moves with the parameter (:mod:`.bump`);
* :data:`ARC`: a planar reach along a circle whose sweep is the parameter, so its points are the
  sine and cosine of it (:mod:`.arc`).
"""
from __future__ import annotations

from ...errors import InputError
from .arc import ARC
from .bump import BUMP
from .family import FamilyTask, PathFamily

#: every family by name
FAMILIES = {f.name: f for f in (BUMP, ARC)}


def family(name: str) -> PathFamily:
    """The family called ``name`` (a key of :data:`FAMILIES`); InputError otherwise."""
    if name not in FAMILIES:
        raise InputError(f"family: expected one of {', '.join(FAMILIES)}, got {name!r}")
    return FAMILIES[name]


__all__ = ["ARC", "BUMP", "FAMILIES", "FamilyTask", "PathFamily", "family"]
