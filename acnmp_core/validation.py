"""Input checks shared by every public function: clear ValueErrors naming the argument.

The errors are the typed subclasses of :mod:`acnmp_core.errors` (all ValueErrors): a wrong shape
raises :class:`ShapeError`, NaN/inf :class:`NonFiniteError`, anything else :class:`InputError`.
"""
from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from .errors import InputError, NonFiniteError, ShapeError


def check_array(
    name: str,
    value,
    *,
    ndim: int | Sequence[int] | None = None,
    shape: Sequence[int | None] | None = None,
    finite: bool = True,
    min_size: int = 0,
    dtype=np.float64,
) -> np.ndarray:
    """Convert ``value`` to a numpy array and check it.

    Parameters
    ----------
    name : the argument's name, used in the error message.
    ndim : expected number of dimensions (an int or a set of allowed ints).
    shape : expected shape; ``None`` entries accept any size on that axis.
    finite : reject NaN and inf.
    min_size : reject arrays with fewer elements.

    Returns the array as ``dtype``. Raises ValueError naming ``name`` and what was expected:
    :class:`ShapeError` (``ndim``, ``shape``, ``min_size``), :class:`NonFiniteError` (``finite``)
    or :class:`InputError` (not numeric, ragged).
    """
    try:
        arr = np.asarray(value, dtype=dtype)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: expected a numeric array, got {type(value).__name__} ({exc})") from None
    if ndim is not None:
        allowed = (ndim,) if isinstance(ndim, int) else tuple(ndim)
        if arr.ndim not in allowed:
            want = " or ".join(str(a) for a in allowed)
            raise ShapeError(f"{name}: expected a {want}-D array, got shape {arr.shape}")
    if shape is not None:
        if arr.ndim != len(shape) or any(s is not None and s != a for s, a in zip(shape, arr.shape)):
            want = "(" + ", ".join("*" if s is None else str(s) for s in shape) + ")"
            raise ShapeError(f"{name}: expected shape {want}, got {arr.shape}")
    if arr.size < min_size:
        raise ShapeError(f"{name}: expected at least {min_size} element(s), got {arr.size}")
    if finite and arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
        raise NonFiniteError(f"{name}: contains NaN or inf")
    return arr


def check_positive_int(name: str, value, *, minimum: int = 1) -> int:
    """Return ``value`` as int, raising :class:`InputError` unless it is an integer >= minimum."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise InputError(f"{name}: expected an integer >= {minimum}, got {value!r}")
    if value < minimum:
        raise InputError(f"{name}: expected an integer >= {minimum}, got {value}")
    return int(value)


def check_type(name: str, value, types: type | tuple[type, ...]) -> Any:
    """Return ``value`` if it is an instance of ``types``, else raise :class:`InputError`.

    ``bool`` is never accepted where ``int`` is asked (it is an int subclass in Python, not on the
    wire); an ``int`` is accepted where ``float`` is asked and returned as float.
    """
    types = types if isinstance(types, tuple) else (types,)
    if isinstance(value, bool) and bool not in types:
        raise InputError(f"{name}: expected {_names(types)}, got bool")
    if float in types and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if not isinstance(value, types):
        raise InputError(f"{name}: expected {_names(types)}, got {type(value).__name__}")
    return value


def _names(types: tuple[type, ...]) -> str:
    return " or ".join("None" if t is type(None) else t.__name__ for t in types)


def check_lr_final(lr: float, lr_final: float | None) -> None:
    """Refuse a final learning rate that is not a number in (0, lr] (None: no decay)."""
    if lr_final is None:
        return
    if isinstance(lr_final, bool) or not isinstance(lr_final, (int, float)) or not 0 < lr_final <= lr:
        raise ValueError(f"lr_final: expected None or a number in (0, lr = {lr}], got {lr_final!r}")
