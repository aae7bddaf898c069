"""RPC over zenoh queries: the one caller (:func:`call`) and the one server side (:func:`declare_rpc`).

A request is a message map (services/transport/wire.py) sent as a query's payload; the reply is
one message map, or a ``reply_err`` carrying ``{"error": {"code", "message"}}``. Both sides of
every request/reply exchange in the deployment go through this module: the learner's remote
evaluator asking workers, the model service's fetch of the latest weights aside (a wildcard query
with one reply per skill), and the Python client.
"""
from __future__ import annotations

import contextlib
import logging
import math
import threading
import time
import traceback
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, Callable, Sequence

import zenoh

from .errors import wire_error
from .keys import is_concrete
from .payload_limits import request_limit, too_large_message
from .wire import DEFAULT_MAX_BYTES, SCHEMA_VERSION, WireError, decode, encode, error_from_payload, error_payload

log = logging.getLogger(__name__)

#: A query that ends before this fraction of its timeout ended because nothing (or nothing more)
#: matched its key: ``unavailable``; later, it ran out of time: ``timeout``.
UNAVAILABLE_FRACTION = 0.9

#: The selector parameter that carries a query's timeout in seconds (``<key>?timeout=0.5``):
#: a server drops a query still waiting in its queue once this much time has passed since it arrived.
TIMEOUT_PARAMETER = "timeout"


def query_timeout(query: zenoh.Query) -> float | None:
    """The timeout a query carries in its selector (:data:`TIMEOUT_PARAMETER`), or None if it
    carries none or one that is not a finite number > 0."""
    try:
        text = query.parameters.get(TIMEOUT_PARAMETER)
        value = float(text) if text is not None else None
    except (TypeError, ValueError):
        return None
    return value if value is not None and math.isfinite(value) and value > 0 else None


def call(session: zenoh.Session, key: str, payload: dict | bytes | None = None, timeout: float = 5.0, *,
         expect_version: int | None = SCHEMA_VERSION, max_bytes: int = DEFAULT_MAX_BYTES) -> dict:
    """Send one query on ``key`` and return the first successful reply, decoded.

    ``payload`` is a message map (encoded here), raw bytes, or None. When several services answer
    (model processes each serving some skills), a successful reply wins over error replies: a
    catch-all ``unknown_skill`` from one process must not hide another's answer. With only error
    replies, the first is raised as the :class:`WireError` it carries; with none, WireError
    ``unavailable`` (the query ended early: nothing matched) or ``timeout``; a successful reply that
    cannot be decoded raises :class:`UnreadableReply` (a WireError). The query carries
    ``timeout`` as its selector parameter, so a server does not compute it after it has expired.
    """
    return _query(session, key, payload, timeout, gather=False, expect_version=expect_version,
                  max_bytes=max_bytes)[0]


def call_all(session: zenoh.Session, key: str, payload: dict | bytes | None = None, timeout: float = 5.0, *,
             expect_version: int | None = SCHEMA_VERSION, max_bytes: int = DEFAULT_MAX_BYTES) -> list[dict]:
    """Send one query on ``key`` to every service that serves it and return every successful reply,
    decoded, in the order they came, once the query ends (each service answered or dropped it, or
    ``timeout`` passed). For a question each of several services answers for its own part (every
    learner its jobs): replies on the same key are all kept, not consolidated into one. Errors as
    :func:`call`: raised only when no reply succeeded."""
    return _query(session, key, payload, timeout, gather=True, expect_version=expect_version, max_bytes=max_bytes)


def _query(session: zenoh.Session, key: str, payload: dict | bytes | None, timeout: float, *, gather: bool,
           expect_version: int | None, max_bytes: int) -> list[dict]:
    """The successful replies of one query on ``key`` (the first one only unless ``gather``); see
    :func:`call` and :func:`call_all`."""
    body = encode(payload) if isinstance(payload, dict) else payload
    limit = request_limit(key)
    if body is not None and len(body) > limit:  # zenoh would drop it unanswered: say so now
        raise WireError("too_large", too_large_message(key, len(body), limit))
    start = time.monotonic()
    first_err: WireError | None = None
    selector = zenoh.Selector(key, {TIMEOUT_PARAMETER: f"{timeout:g}"})
    # zenoh's default consolidation keeps one reply per key: several services answering on the
    # same key would reach a gathering caller as one
    every = {"target": zenoh.QueryTarget.ALL, "consolidation": zenoh.ConsolidationMode.NONE} if gather else {}
    ok: list[dict] = []
    for reply in session.get(selector, payload=body, timeout=timeout, **every):
        if reply.ok is not None:
            try:
                ok.append(decode(reply.ok.payload.to_bytes(), expect_version=expect_version, max_bytes=max_bytes))
            except WireError as exc:
                raise UnreadableReply(exc.code, f"reply on {key}: {exc.message}") from None
            if not gather:
                return ok
        elif first_err is None:
            first_err = error_from_payload(reply.err.payload.to_bytes())
    if ok:
        return ok
    if first_err is not None:
        raise first_err
    if time.monotonic() - start < UNAVAILABLE_FRACTION * timeout:
        raise WireError("unavailable", f"no service answered on {key}")
    raise WireError("timeout", f"no reply on {key} within {timeout}s")


class UnreadableReply(WireError):
    """A query was answered, but its reply could not be read (not msgpack, NaN in an array, a bad
    array map, ...): the answering service's fault, not the request's. The code is the decoding's."""


Handler = Callable[..., Any]


class Expired(Exception):
    """A deferred handler's result (see :func:`declare_rpc`) for a query whose deadline passed before
    it was computed: the query is dropped unanswered, like one that expired in the queue."""


class NotServed(Exception):
    """Raised by a handler for a query another service answers (e.g. a skill of another learner):
    the query is dropped unanswered, so the querier's ``call`` gets that service's reply alone."""


class RpcQueryable:
    """A queryable whose handler errors become ``reply_err`` payloads; see :func:`declare_rpc`.

    ``key_expr`` may be several key expressions: one zenoh queryable is declared on each, and they
    share this object's handler threads, queue bound and counters (one service's bound, whichever
    key its queries come on). Use as a context manager or call :meth:`close`; closing undeclares
    the queryables and waits for handlers in flight (when a thread pool is used).
    """

    def __init__(self, session: zenoh.Session, key_expr: str | Sequence[str], handler: Handler, *, workers: int = 0,
                 decode_payload: bool = True, expect_version: int | None = SCHEMA_VERSION,
                 max_bytes: int = DEFAULT_MAX_BYTES, complete: bool = True, max_queue: int | None = None,
                 default_timeout: float | None = None, pass_deadline: bool = False,
                 on_payload: Callable[[int], None] | None = None):
        keys = [key_expr] if isinstance(key_expr, str) else list(key_expr)
        if not keys:
            raise ValueError("key_expr: expected at least one key expression")
        self.key_expr = keys[0]
        self._handler = handler
        self._decode = decode_payload
        self._expect_version = expect_version
        self._max_bytes = max_bytes
        self._pool = ThreadPoolExecutor(workers, thread_name_prefix="rpc") if workers > 0 else None
        self.max_queue = max_queue
        self.default_timeout = default_timeout
        self._pass_deadline = pass_deadline
        self._on_payload = on_payload
        self.served = 0
        self.failed = 0
        self.overloaded = 0  # refused at once: the queue was full
        self.expired = 0     # dropped unanswered from the queue: their querier had given up
        self.refused_keys = 0  # dropped unanswered: asked on a wildcard, not on one concrete key
        self.waiting = 0     # queued, not started
        self._lock = threading.Lock()
        callback = self._dispatch if self._pool else self._serve_inline
        self._queryables = [session.declare_queryable(k, callback, complete=complete) for k in keys]

    def _deadline(self, query: zenoh.Query) -> float | None:
        timeout = query_timeout(query) or self.default_timeout
        return None if timeout is None else time.monotonic() + timeout

    def decode_request(self, query: zenoh.Query) -> dict | None:
        """The query's payload decoded as this queryable decodes it (None when it has none);
        WireError on a bad one (``too_large`` over its key's bound, from the length alone). For
        handlers declared with ``decode_payload=False`` that decode later, on another thread."""
        self._check_size(query)
        raw = query.payload.to_bytes() if query.payload is not None else b""
        return decode(raw, expect_version=self._expect_version, max_bytes=self._max_bytes) if raw else None

    def _check_size(self, query: zenoh.Query) -> None:
        """WireError ``too_large`` when the payload is over its key's bound
        (services/transport/payload_limits.py) or this queryable's ``max_bytes``; nothing is copied."""
        size = len(query.payload) if query.payload is not None else 0
        if self._on_payload is not None:
            self._on_payload(size)
        limit = min(self._max_bytes, request_limit(str(query.key_expr)))
        if size > limit:
            raise WireError("too_large", too_large_message(str(query.key_expr), size, limit))

    def _oversized(self, query: zenoh.Query) -> bool:
        # answered at once on zenoh's thread, never queued: the refusal costs no handler and no copy
        try:
            self._check_size(query)
            return False
        except WireError as exc:
            with query:
                self._fail(query, exc.code, exc.message)
            return True

    def _refused(self, query: zenoh.Query) -> bool:
        # a query on a wildcard (acnmp/NS/skill/e1/*, acnmp/**) is answered by nobody: a service
        # acts only on the one concrete key it serves (docs/PROTOCOL.md section 5)
        if is_concrete(query.key_expr):
            return False
        with self._lock:
            self.refused_keys += 1
        query.drop()
        return True

    def _serve_inline(self, query: zenoh.Query) -> None:
        if not self._refused(query) and not self._oversized(query):
            self._serve(query, self._deadline(query))

    def _dispatch(self, query: zenoh.Query) -> None:
        # hand the query to the pool so a slow handler never holds a zenoh runtime thread
        if self._refused(query) or self._oversized(query):
            return
        deadline = self._deadline(query)
        with self._lock:
            full = self.max_queue is not None and self.waiting >= self.max_queue
            if full:
                self.overloaded += 1
            else:
                self.waiting += 1
        if full:
            with contextlib.suppress(Exception):
                query.reply_err(error_payload("overloaded", f"{self.max_queue} queries are already waiting on "
                                                            f"{query.key_expr}; try again later"))
            query.drop()
            return
        try:
            self._pool.submit(self._serve_queued, query, deadline)
        except RuntimeError:  # pool shut down: we are closing
            with self._lock:
                self.waiting -= 1
            with contextlib.suppress(Exception):
                query.reply_err(error_payload("unavailable", "service is shutting down"))
            query.drop()

    def _serve_queued(self, query: zenoh.Query, deadline: float | None) -> None:
        with self._lock:
            self.waiting -= 1
        if deadline is not None and time.monotonic() > deadline:
            with self._lock:
                self.expired += 1
            query.drop()  # its querier has given up: nothing is computed and nobody waits for a reply
            return
        self._serve(query, deadline)

    def _serve(self, query: zenoh.Query, deadline: float | None = None) -> None:
        try:
            request = self.decode_request(query) if self._decode else None
            result = (self._handler(request, query, deadline) if self._pass_deadline
                      else self._handler(request, query))
        except NotServed:
            query.drop()
            return
        except Exception as exc:  # a raising callback would send no reply at all
            with query:
                self._fail_with(query, exc)
            return
        if isinstance(result, Future):  # answered when it completes, on the thread completing it
            result.add_done_callback(lambda fut: self._complete(query, fut))
        else:
            self._answer(query, result)

    def _complete(self, query: zenoh.Query, future: Future) -> None:
        exc = future.exception()
        if isinstance(exc, Expired):
            with self._lock:
                self.expired += 1
            query.drop()
        elif exc is not None:
            with query:
                self._fail_with(query, exc)
        else:
            self._answer(query, future.result())

    def _answer(self, query: zenoh.Query, result) -> None:
        # `with query` drops it at the end: the querier's get() only finishes once it is dropped
        with query:
            try:
                body = encode(result) if isinstance(result, dict) else bytes(result)
                query.reply(self._reply_key(query), body)
                with self._lock:
                    self.served += 1
            except Exception as exc:
                self._fail_with(query, exc)

    def _fail_with(self, query: zenoh.Query, exc: BaseException) -> None:
        err = wire_error(exc)
        if err.code == "internal":
            log.error("handler for %s failed:\n%s", query.key_expr,
                      "".join(traceback.format_exception(type(exc), exc, exc.__traceback__)))
        self._fail(query, err.code, err.message)

    def _reply_key(self, query: zenoh.Query) -> str:
        # replies must intersect the query's key; a concrete query key is always safe
        key = str(query.key_expr)
        return key if "*" not in key else self.key_expr

    def _fail(self, query: zenoh.Query, code: str, message: str) -> None:
        with self._lock:
            self.failed += 1
        try:
            query.reply_err(error_payload(code, message))
        except Exception:  # session closing under us: nothing left to tell
            log.debug("reply_err failed on %s", query.key_expr, exc_info=True)

    def close(self) -> None:
        """Undeclare the queryables, then let handlers in flight finish."""
        for queryable in self._queryables:
            with contextlib.suppress(Exception):
                queryable.undeclare()
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=False)

    def __enter__(self) -> "RpcQueryable":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def declare_rpc(session: zenoh.Session, key_expr: str | Sequence[str], handler: Handler, **kwargs) -> RpcQueryable:
    """Declare a queryable on ``key_expr`` (one key expression, or several sharing the handler
    threads and queue bound below) that answers every query exactly once.

    ``handler(request, query)`` gets the decoded request map (None when the query has no
    payload) and returns a reply map (encoded here) or bytes. A :class:`WireError` it raises
    (or that decoding raises) becomes ``reply_err`` with that code, a typed input error of the
    library the code of its type (services/transport/errors.py), any other exception code
    ``internal``; the queryable keeps serving. ``workers=N`` runs handlers on N threads; then a
    query waits in a queue: ``max_queue=M`` answers ``overloaded`` at once while M are waiting, and a
    query still waiting when its timeout (selector parameter ``timeout``, else ``default_timeout``
    seconds, else none) has passed is dropped without being computed (counted in ``expired``).
    A handler raising :class:`NotServed` leaves the query to another service (dropped unanswered).
    ``pass_deadline=True`` calls ``handler(request, query, deadline)`` with that deadline
    (``time.monotonic()`` seconds, or None). A handler may return a :class:`concurrent.futures.Future`
    instead of a reply: the query is answered when it completes (its result or exception, as
    above; :class:`Expired` drops the query unanswered), on the thread that completes it.
    ``on_payload(size)`` is told each query's payload size (bytes) as it arrives. With
    ``workers=0`` the handler runs on zenoh's callback thread, so it must only hand the query on
    (return a future at once); with ``decode_payload=False`` it gets None as the request and may
    decode later with :meth:`RpcQueryable.decode_request`.
    Other keyword arguments: see :class:`RpcQueryable`.
    """
    return RpcQueryable(session, key_expr, handler, **kwargs)

