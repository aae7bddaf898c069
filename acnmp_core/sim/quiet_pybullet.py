"""PyBullet, imported once without the build-time banner its C module prints on import.

Every module of the library imports PyBullet from here (``from .quiet_pybullet import pybullet as p``),
so no command, experiment or worker log starts with "pybullet build time: ...". The banner is
written by C to file descriptor 2, so that descriptor is pointed at /dev/null for the import only
(an import error still raises, with its message, once the descriptor is back).
"""
from __future__ import annotations

import os
import sys


def _import_quietly():
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError, AttributeError):  # no usable stderr: nothing to keep clean
        import pybullet

        return pybullet
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 2)
            import pybullet
    finally:
        os.dup2(saved, 2)
        os.close(saved)
    return pybullet


pybullet = _import_quietly()
