"""The launcher wing: which processes exist, and starting a whole deployment on one machine.

========================  =========================================================
module                    one job
========================  =========================================================
``processes``             the process table: name -> entry module and config class
``deployment``            :class:`LocalDeployment`: recorder, learner, model, workers as
                          child processes on a loopback peer mesh, or (``secure=True``)
                          as authenticated clients of the launcher's router
``announce``              a secured deployment's secrets and run file
========================  =========================================================
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from services.transport.lazy import lazy_exports

if TYPE_CHECKING:  # what a type checker sees; at run time the names come from __getattr__
    from .deployment import Child, ChildExited, LocalDeployment
    from .processes import PROCESSES, entry_module, options_class, service_class

__all__ = [
    "Child", "ChildExited", "LocalDeployment", "PROCESSES", "entry_module", "options_class", "service_class",
]
__getattr__ = lazy_exports(__name__, {
    "Child": "deployment", "ChildExited": "deployment", "LocalDeployment": "deployment",
    "PROCESSES": "processes", "entry_module": "processes", "options_class": "processes",
    "service_class": "processes",
})
