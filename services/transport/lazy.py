"""Package exports imported on first use (PEP 562), so importing one light module of a package
(``services.learner.config``, ``services.launcher.processes``) does not import what its other
modules need (torch, rerun: seconds of start-up for every command line and process)."""
from __future__ import annotations

import importlib
from typing import Callable


def lazy_exports(package: str, exports: dict[str, str]) -> Callable[[str], object]:
    """A module ``__getattr__`` for ``package``: ``exports`` maps a public name to the submodule
    (relative, e.g. ``"core"``) that defines it; the value is imported then cached in the package."""

    def __getattr__(name: str):
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f".{module}", package), name)
        setattr(importlib.import_module(package), name, value)
        return value

    return __getattr__
