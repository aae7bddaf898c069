"""The wire codec: msgpack maps with a schema version, numpy arrays as dtype + shape + raw bytes.

Every message on the bus is one msgpack map whose ``"v"`` key is the schema version
(:data:`SCHEMA_VERSION`). A numpy array travels as a map with exactly three keys::

    {"dtype": "float32", "shape": [200, 2], "data": <bin: 1600 bytes, little-endian, C order>}

Only the dtypes in :data:`ALLOWED_DTYPES` are accepted. Decoding never executes anything that came
over the wire: no pickle, no msgpack ext types, string keys only, bounded sizes and nesting. Every
failure raises :class:`WireError` whose ``code`` is one of :data:`ERROR_CODES`, so a service can turn
it into a ``reply_err`` (:func:`error_payload`) and a client back into an exception
(:func:`error_from_payload`).
"""
from __future__ import annotations

import math
from typing import Any, Iterable, Sequence

import msgpack
import numpy as np

SCHEMA_VERSION = 1

#: Default ceiling for one encoded message (requests, replies and events alike).
DEFAULT_MAX_BYTES = 64 * 1024 * 1024

#: Deepest nesting of maps/lists accepted; real messages are 3-4 levels deep.
MAX_DEPTH = 32

#: Most list items and map entries a message may hold in all (arrays sent as the binary array map
#: count as one map of three): lists of numbers are accepted for hand-written clients, but each
#: item costs a Python object, so a 57 MB list-encoded request would hold a service for seconds.
#: Counted while msgpack builds the containers, so decoding stops as soon as it is exceeded.
MAX_ITEMS = 1 << 18

#: Most dimensions an array may have.
MAX_NDIM = 8

#: Largest product of an array's non-zero sizes: no array that fits in a payload of
#: :data:`DEFAULT_MAX_BYTES` can be longer, and an empty array must not announce more
#: (``[0, 2**63-1]`` is refused with ``too_large`` instead of failing inside numpy).
MAX_ELEMENTS = DEFAULT_MAX_BYTES

#: Wire dtype name -> numpy dtype (always little-endian on the wire).
ALLOWED_DTYPES: dict[str, np.dtype] = {
    "float32": np.dtype("<f4"),
    "float64": np.dtype("<f8"),
    "int32": np.dtype("<i4"),
    "int64": np.dtype("<i8"),
    "bool": np.dtype("?"),
    "uint8": np.dtype("u1"),
}

#: Machine-readable error codes with their meaning (the table docs/PROTOCOL.md reproduces).
ERROR_CODES: dict[str, str] = {
    "malformed": "payload is not a msgpack map of the allowed types (or has ext types, bytes keys, ...)",
    "bad_version": "schema version 'v' missing or not the one this service speaks",
    "bad_request": "a required field is missing or has the wrong type or value",
    "bad_shape": "an array has the wrong number of dimensions or sizes, or shape and data disagree",
    "bad_dtype": "an array dtype is not one of float32/float64/int32/int64/bool/uint8 or not the one expected",
    "non_finite": "a float value or array element is NaN or infinite",
    "too_large": "the payload or an array exceeds the configured size bound",
    "unknown_skill": "no skill of that name is served here",
    "unknown_task": "no reward/task of that name is registered",
    "unknown_job": "no adaptation job with that id",
    "overloaded": "the service's queue for this key is full; nothing was computed, try again later",
    "busy": "the learner holds as many unfinished jobs as its limit allows; nothing was queued, try again later",
    "write_failed": "the service could not write its state (disk full, I/O error, permission); nothing was changed",
    "unavailable": "no service answered (nothing matched the key expression, or it went away)",
    "timeout": "the query timed out before a reply arrived",
    "internal": "the service failed while handling the request; the message says how",
}


class WireError(Exception):
    """A protocol error with a machine-readable ``code`` (see :data:`ERROR_CODES`) and a message."""

    def __init__(self, code: str, message: str):
        super().__init__(f"{code}: {message}")
        self.code = str(code)
        self.message = str(message)

    def to_dict(self) -> dict[str, str]:
        """Return ``{"code": ..., "message": ...}``, the body of an error reply."""
        return {"code": self.code, "message": self.message}


# --------------------------------------------------------------------------------------------
# encoding


def encode(obj: dict, *, max_bytes: int = DEFAULT_MAX_BYTES, allow_non_finite: bool = False,
           version: int = SCHEMA_VERSION) -> bytes:
    """Encode a message map to msgpack bytes.

    ``obj`` must be a dict with string keys; ``"v"`` is set to ``version`` if absent. Values may be
    None, bool, int, float, str, bytes, lists/tuples, dicts, numpy arrays (converted to the array
    map, little-endian, C order) and numpy scalars. Raises :class:`WireError` with code
    ``non_finite`` (NaN/inf, unless ``allow_non_finite``), ``bad_dtype`` (an array dtype outside
    :data:`ALLOWED_DTYPES`), ``too_large`` (result over ``max_bytes``) or ``bad_request`` (a value
    of another type).
    """
    if not isinstance(obj, dict):
        raise WireError("bad_request", f"a message must be a map, got {type(obj).__name__}")
    if "v" not in obj:
        obj = {"v": version, **obj}
    plain = _to_plain(obj, "", allow_non_finite, 0)
    try:
        # use_bin_type keeps bytes and str apart on the wire; no `default=` hook, so nothing
        # outside the plain types can ever be serialised.
        out = msgpack.packb(plain, use_bin_type=True)
    except (TypeError, ValueError, OverflowError) as exc:
        raise WireError("bad_request", f"cannot encode message: {exc}") from None
    if len(out) > max_bytes:
        raise WireError("too_large", f"encoded message is {len(out)} bytes, limit {max_bytes}")
    return out


def encode_array(arr: np.ndarray, *, allow_non_finite: bool = False, path: str = "array") -> dict:
    """Return the wire map ``{"dtype", "shape", "data"}`` of a numpy array (see module docstring)."""
    arr = np.asarray(arr)
    name = _dtype_name(arr.dtype)
    if name is None:
        raise WireError("bad_dtype", f"{path}: dtype {arr.dtype} is not one of {sorted(ALLOWED_DTYPES)}")
    if arr.ndim > MAX_NDIM:
        raise WireError("bad_shape", f"{path}: {arr.ndim} dimensions, at most {MAX_NDIM}")
    if not allow_non_finite and arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
        raise WireError("non_finite", f"{path}: contains NaN or inf")
    wire = np.asarray(arr, dtype=ALLOWED_DTYPES[name], order="C")  # keeps 0-d arrays 0-d
    return {"dtype": name, "shape": list(wire.shape), "data": wire.tobytes()}


def _dtype_name(dtype: np.dtype) -> str | None:
    """Wire name of ``dtype`` ignoring byte order, or None if it is not allowed."""
    for name, allowed in ALLOWED_DTYPES.items():
        if dtype.kind == allowed.kind and dtype.itemsize == allowed.itemsize:
            return name
    return None


def _map(value: dict, path: str, code: str, convert) -> dict:
    """``value`` with each entry converted by ``convert(v, its path)``; WireError ``code`` for a key
    that is not a string (msgpack allows any, the protocol does not)."""
    out = {}
    for k, v in value.items():
        if not isinstance(k, str):
            raise WireError(code, f"{path or 'message'}: map key {k!r} is not a string")
        out[k] = convert(v, f"{path}.{k}" if path else k)
    return out


def _to_plain(value: Any, path: str, allow_non_finite: bool, depth: int) -> Any:
    """Recursively turn ``value`` into msgpack-native types, checking as :func:`encode` says."""
    if depth > MAX_DEPTH:
        raise WireError("bad_request", f"{path or 'message'}: nested deeper than {MAX_DEPTH}")
    if value is None or isinstance(value, (bool, str, bytes)):
        return value
    if isinstance(value, int):
        return value
    if isinstance(value, float):
        if not allow_non_finite and not math.isfinite(value):
            raise WireError("non_finite", f"{path or 'value'}: {value}")
        return value
    if isinstance(value, np.ndarray):
        return encode_array(value, allow_non_finite=allow_non_finite, path=path or "array")
    if isinstance(value, np.generic):
        return _to_plain(value.item(), path, allow_non_finite, depth)
    if isinstance(value, dict):
        return _map(value, path, "bad_request", lambda v, where: _to_plain(v, where, allow_non_finite, depth + 1))
    if isinstance(value, (list, tuple)):
        return [_to_plain(v, f"{path}[{i}]", allow_non_finite, depth + 1) for i, v in enumerate(value)]
    raise WireError("bad_request", f"{path or 'value'}: cannot encode {type(value).__name__}")


# --------------------------------------------------------------------------------------------
# decoding


def decode(data: bytes | bytearray | memoryview, expect_version: int | None = SCHEMA_VERSION, *,
           max_bytes: int = DEFAULT_MAX_BYTES, allow_non_finite: bool = False) -> dict:
    """Decode msgpack bytes into a message map, turning array maps back into numpy arrays.

    Checks, in order: size (``too_large``), msgpack validity and allowed types (``malformed``),
    top level is a map with an integer ``"v"`` equal to ``expect_version`` (``bad_version``; pass
    None to accept any), arrays (``bad_dtype``, ``bad_shape``), floats finite (``non_finite``,
    unless ``allow_non_finite``). Decoded arrays are writable copies. Raises only :class:`WireError`.
    """
    if not isinstance(data, (bytes, bytearray, memoryview)):
        raise WireError("malformed", f"payload must be bytes, got {type(data).__name__}")
    if len(data) > max_bytes:
        raise WireError("too_large", f"payload is {len(data)} bytes, limit {max_bytes}")
    if len(data) == 0:
        raise WireError("malformed", "empty payload")
    try:
        # raw=False: strings decode as str; strict_map_key: no non-string keys (checked again
        # below, since strict_map_key still lets bytes keys through); ext_hook refuses every ext
        # type, and max_*_len bound every container by the payload size so a 5-byte header
        # cannot announce a 4 GiB string.
        budget = [MAX_ITEMS]

        def counted(container):
            budget[0] -= len(container)
            if budget[0] < 0:
                raise WireError("too_large", f"more than {MAX_ITEMS} list items and map entries in one message; "
                                             "send large arrays as binary array maps (docs/PROTOCOL.md section 2)")
            return container

        obj = msgpack.unpackb(
            bytes(data), raw=False, strict_map_key=True, use_list=True,
            ext_hook=_refuse_ext, list_hook=counted, object_hook=counted,
            max_str_len=len(data), max_bin_len=len(data), max_array_len=min(len(data), MAX_ITEMS),
            max_map_len=min(len(data), MAX_ITEMS), max_ext_len=0,
        )
    except WireError:
        raise
    except ValueError as exc:
        if "exceeds max_array_len" in str(exc) or "exceeds max_map_len" in str(exc):  # msgpack refused one container
            raise WireError("too_large", f"{exc}: at most {MAX_ITEMS} list items and map entries in one message; "
                                         "send large arrays as binary array maps") from None
        raise WireError("malformed", f"not a valid msgpack message (ValueError: {exc})") from None
    except Exception as exc:  # msgpack raises a zoo of types (ExtraData, FormatError, ...)
        detail = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
        raise WireError("malformed", f"not a valid msgpack message ({detail})") from None
    if not isinstance(obj, dict):
        raise WireError("malformed", f"a message must be a map, got {type(obj).__name__}")
    if expect_version is not None:
        v = obj.get("v")
        if v is None:
            raise WireError("bad_version", f"missing schema version 'v' (this service speaks v{expect_version})")
        if isinstance(v, bool) or not isinstance(v, int) or v != expect_version:
            raise WireError("bad_version", f"schema version {v!r} not supported (this service speaks v{expect_version})")
    return _from_plain(obj, "", allow_non_finite, 0)


def _refuse_ext(code: int, data: bytes):
    """msgpack ext_hook: ext types are never part of this protocol."""
    raise WireError("malformed", f"msgpack ext type {code} is not allowed")


def _is_array_map(value: dict) -> bool:
    """True if ``value`` has exactly the keys of an encoded array."""
    return len(value) == 3 and "dtype" in value and "shape" in value and "data" in value


def _from_plain(value: Any, path: str, allow_non_finite: bool, depth: int) -> Any:
    """Recursively validate decoded msgpack data and rebuild arrays."""
    if depth > MAX_DEPTH:
        raise WireError("malformed", f"{path or 'message'}: nested deeper than {MAX_DEPTH}")
    if value is None or isinstance(value, (bool, int, str, bytes)):
        return value
    if isinstance(value, float):
        if not allow_non_finite and not math.isfinite(value):
            raise WireError("non_finite", f"{path or 'value'}: {value}")
        return value
    if isinstance(value, dict):
        if _is_array_map(value):
            return decode_array(value, path=path or "array", allow_non_finite=allow_non_finite)
        return _map(value, path, "malformed", lambda v, where: _from_plain(v, where, allow_non_finite, depth + 1))
    if isinstance(value, list):
        return [_from_plain(v, f"{path}[{i}]", allow_non_finite, depth + 1) for i, v in enumerate(value)]
    # e.g. msgpack.Timestamp (ext -1 is decoded natively, not through ext_hook)
    raise WireError("malformed", f"{path or 'value'}: type {type(value).__name__} is not allowed")


def decode_array(value: dict, *, path: str = "array", allow_non_finite: bool = False) -> np.ndarray:
    """Rebuild a numpy array from its wire map; raises WireError (bad_dtype, bad_shape, malformed)."""
    dtype_name, shape, data = value.get("dtype"), value.get("shape"), value.get("data")
    if not isinstance(dtype_name, str) or dtype_name not in ALLOWED_DTYPES:
        raise WireError("bad_dtype", f"{path}: dtype {dtype_name!r} is not one of {sorted(ALLOWED_DTYPES)}")
    if not isinstance(data, bytes):
        raise WireError("malformed", f"{path}: 'data' must be binary, got {type(data).__name__}")
    if not isinstance(shape, list) or len(shape) > MAX_NDIM:
        raise WireError("bad_shape", f"{path}: shape must be a list of at most {MAX_NDIM} sizes, got {shape!r}")
    count, nonzero = 1, 1
    for s in shape:
        if isinstance(s, bool) or not isinstance(s, int) or s < 0:
            raise WireError("bad_shape", f"{path}: shape {shape!r} has a size that is not an integer >= 0")
        count *= s  # Python ints: no overflow, and absurd products fail the checks below
        nonzero *= max(s, 1)
    dtype = ALLOWED_DTYPES[dtype_name]
    if count * dtype.itemsize != len(data):
        raise WireError("bad_shape", f"{path}: shape {shape} of {dtype_name} needs {count * dtype.itemsize} bytes, got {len(data)}")
    if nonzero > MAX_ELEMENTS:  # an empty array announcing absurd sizes, e.g. [0, 2**63 - 1]
        raise WireError("too_large", f"{path}: shape {shape} announces more than {MAX_ELEMENTS} elements")
    try:
        arr = np.frombuffer(data, dtype=dtype).reshape(tuple(shape))
    except ValueError as exc:  # not reachable within the bounds above; never an internal error
        raise WireError("bad_shape", f"{path}: shape {shape}: {exc}") from None
    if dtype_name == "bool" and arr.size and int(np.frombuffer(data, dtype=np.uint8).max()) > 1:
        raise WireError("malformed", f"{path}: bool array bytes must be 0 or 1")
    if not allow_non_finite and arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
        raise WireError("non_finite", f"{path}: contains NaN or inf")
    # native byte order + writable copy, so torch.from_numpy and in-place ops just work
    return arr.astype(dtype.newbyteorder("="), copy=True)


# --------------------------------------------------------------------------------------------
# errors on the wire


def error_payload(code: str, message: str) -> bytes:
    """Encode an error reply ``{"v": 1, "error": {"code": code, "message": message}}``."""
    return msgpack.packb({"v": SCHEMA_VERSION, "error": {"code": str(code), "message": str(message)}},
                         use_bin_type=True)


#: The payload of the error reply zenoh itself delivers to a querier whose query timed out
#: (encoding ``zenoh/string``; not msgpack).
ZENOH_TIMEOUT_PAYLOAD = b"Timeout"


def error_from_payload(data: bytes) -> WireError:
    """Turn the payload of a ``reply_err`` back into a :class:`WireError` (never raises).

    Zenoh's own timeout reply (:data:`ZENOH_TIMEOUT_PAYLOAD`) yields ``timeout``. Any other payload
    that is not a well-formed error map yields code ``internal`` with what was received.
    """
    if bytes(data) == ZENOH_TIMEOUT_PAYLOAD:
        return WireError("timeout", "no reply before the query's timeout (zenoh timeout reply)")
    try:
        msg = decode(data, expect_version=None, max_bytes=1024 * 1024, allow_non_finite=True)
        err = msg.get("error")
        if isinstance(err, dict) and isinstance(err.get("code"), str):
            return WireError(err["code"], str(err.get("message", "")))
    except WireError:
        pass
    text = bytes(data[:200]).decode("utf-8", "replace")
    return WireError("internal", f"unrecognised error reply: {text!r}")


def is_error(msg: dict) -> bool:
    """True if a decoded message is an error map (has an ``"error"`` key)."""
    return isinstance(msg, dict) and isinstance(msg.get("error"), dict)


# --------------------------------------------------------------------------------------------
# field helpers for request handlers (raise WireError with a code the client can act on)

_MISSING = object()


def require_payload(msg: dict | None, what: str) -> dict:
    """``msg`` if the query carried a payload; WireError ``malformed`` (empty payload) if not.

    A queryable declared with :func:`services.transport.rpc.declare_rpc` hands its handler None for
    an empty payload; a request that needs fields calls this first.
    """
    if msg is None:
        raise WireError("malformed", f"empty payload: {what} needs a message map")
    return msg


def field(msg: dict, key: str, types: type | tuple[type, ...], *, default: Any = _MISSING) -> Any:
    """Return ``msg[key]`` if it has one of ``types``; ``default`` if absent (when given).

    Raises ``bad_request`` if absent without a default or of the wrong type. ``bool`` is never
    accepted where ``int`` is asked (msgpack keeps them apart; so do we). An ``int`` is accepted
    where ``float`` is asked, and returned as float.
    """
    types = types if isinstance(types, tuple) else (types,)
    if key not in msg or msg[key] is None:
        if default is not _MISSING:
            return default
        raise WireError("bad_request", f"missing field '{key}'")
    value = msg[key]
    if isinstance(value, bool) and bool not in types:
        raise WireError("bad_request", f"field '{key}': expected {_names(types)}, got bool")
    if float in types and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if not isinstance(value, types):
        raise WireError("bad_request", f"field '{key}': expected {_names(types)}, got {type(value).__name__}")
    return value


def array_field(msg: dict, key: str, *, shape: Sequence[int | None] | None = None,
                ndim: int | Iterable[int] | None = None, kinds: str = "f", default: Any = _MISSING,
                max_elements: int | None = None) -> np.ndarray:
    """Return ``msg[key]`` as a decoded array, checked against ``shape``/``ndim`` and dtype ``kinds``.

    ``shape`` entries of None accept any size; ``kinds`` is a string of numpy kind letters
    (``"f"`` floats, ``"i"`` ints, ``"b"`` bool, ``"u"`` uint8). Plain lists of numbers are
    accepted too (converted with numpy), so hand-written clients may send them. Raises
    ``bad_request`` (missing), ``bad_dtype``, ``bad_shape`` or ``too_large``.
    """
    if key not in msg or msg[key] is None:
        if default is not _MISSING:
            return default
        raise WireError("bad_request", f"missing array field '{key}'")
    value = msg[key]
    if isinstance(value, list):
        try:
            value = np.asarray(value, dtype=np.float64 if "f" in kinds else None)
        except (TypeError, ValueError) as exc:
            raise WireError("bad_request", f"field '{key}': not a numeric array ({exc})") from None
        if value.dtype == object:
            raise WireError("bad_shape", f"field '{key}': ragged or non-numeric list")
        if value.dtype.kind == "f" and not np.all(np.isfinite(value)):
            raise WireError("non_finite", f"field '{key}': contains NaN or inf")
    if not isinstance(value, np.ndarray):
        raise WireError("bad_request", f"field '{key}': expected an array, got {type(value).__name__}")
    if value.dtype.kind not in kinds:
        raise WireError("bad_dtype", f"field '{key}': dtype {value.dtype} not accepted here (kinds '{kinds}')")
    if ndim is not None:
        allowed = (ndim,) if isinstance(ndim, int) else tuple(ndim)
        if value.ndim not in allowed:
            raise WireError("bad_shape", f"field '{key}': expected {' or '.join(map(str, allowed))}-D, got shape {value.shape}")
    if shape is not None:
        if value.ndim != len(shape) or any(s is not None and s != a for s, a in zip(shape, value.shape)):
            want = "(" + ", ".join("*" if s is None else str(s) for s in shape) + ")"
            raise WireError("bad_shape", f"field '{key}': expected shape {want}, got {tuple(value.shape)}")
    if max_elements is not None and value.size > max_elements:
        raise WireError("too_large", f"field '{key}': {value.size} elements, at most {max_elements}")
    return value


def _names(types: tuple[type, ...]) -> str:
    return " or ".join(t.__name__ for t in types)


# --------------------------------------------------------------------------------------------
# JSON


def jsonable(value: Any) -> Any:
    """A decoded message (or any map of plain values and arrays) with every numpy array and scalar
    turned into nested lists and Python numbers, ready for ``json.dumps``: the one helper for
    job records on disk and ``--json`` output."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, dict):
        return {k: jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    return value
