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
from .deployment import Child, ChildExited, LocalDeployment
from .processes import PROCESSES, entry_module, service_class

__all__ = ["Child", "ChildExited", "LocalDeployment", "PROCESSES", "entry_module", "service_class"]
