"""Input checks shared by every public function: clear ValueErrors naming the argument."""
from __future__ import annotations

from typing import Sequence

import numpy as np


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

    Returns the array as ``dtype``. Raises ValueError naming ``name`` and what was expected.
    """
    try:
        arr = np.asarray(value, dtype=dtype)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected a numeric array, got {type(value).__name__} ({exc})") from None
    if ndim is not None:
        allowed = (ndim,) if isinstance(ndim, int) else tuple(ndim)
        if arr.ndim not in allowed:
            want = " or ".join(str(a) for a in allowed)
            raise ValueError(f"{name}: expected a {want}-D array, got shape {arr.shape}")
    if shape is not None:
        if arr.ndim != len(shape) or any(s is not None and s != a for s, a in zip(shape, arr.shape)):
            want = "(" + ", ".join("*" if s is None else str(s) for s in shape) + ")"
            raise ValueError(f"{name}: expected shape {want}, got {arr.shape}")
    if arr.size < min_size:
        raise ValueError(f"{name}: expected at least {min_size} element(s), got {arr.size}")
    if finite and arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: contains NaN or inf")
    return arr


def check_positive_int(name: str, value, *, minimum: int = 1) -> int:
    """Return ``value`` as int, raising ValueError unless it is an integer >= minimum."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name}: expected an integer >= {minimum}, got {value!r}")
    if value < minimum:
        raise ValueError(f"{name}: expected an integer >= {minimum}, got {value}")
    return int(value)
