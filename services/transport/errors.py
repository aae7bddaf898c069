"""From an exception to the wire error code it is answered with: by type, never by message.

The library raises the typed input errors of :mod:`acnmp_core.errors` (all ValueErrors); a request
handler lets them propagate and :func:`wire_error` picks the code from the class (the most
specific listed class wins, so a subclass added later falls back to its parent's code).
"""
from __future__ import annotations

from acnmp_core.errors import (InputError, NonFiniteError, ShapeError, TooLargeError, UnknownRobotError,
                               UnknownTaskError)

from .wire import WireError

#: Library error type -> wire code (docs/PROTOCOL.md, "Errors"). Order does not matter: the
#: exception's own class is looked up first, then its bases in method resolution order.
CODES: dict[type[BaseException], str] = {
    InputError: "bad_request",
    ShapeError: "bad_shape",
    NonFiniteError: "non_finite",
    TooLargeError: "too_large",
    UnknownTaskError: "unknown_task",
    UnknownRobotError: "bad_request",
}


def wire_error(exc: BaseException, *, default: str = "internal") -> WireError:
    """The :class:`WireError` that answers ``exc``.

    A WireError is returned as it is; a typed input error gets its code from :data:`CODES`; any
    other exception gets ``default`` (``internal``: the service failed, not the request). Pass
    ``default="bad_request"`` where every ValueError of a library call is about the request.
    """
    if isinstance(exc, WireError):
        return exc
    for cls in type(exc).__mro__:
        if cls in CODES:
            return WireError(CODES[cls], str(exc))
    if default != "internal" and isinstance(exc, ValueError):
        return WireError(default, str(exc))
    return WireError("internal", f"{type(exc).__name__}: {exc}")
