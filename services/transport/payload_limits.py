"""How large a request may be, per key: what each key carries, not one cap for all.

Every zenoh message of a deployment is capped at the transport (``transport/link/rx/max_message_size``,
:data:`services.transport.session.MAX_MESSAGE_BYTES`), and a payload at 64 MiB
(:data:`services.transport.wire.DEFAULT_MAX_BYTES`). That cap fits the keys that carry
demonstrations, roll-out batches and weights; a predict request, a status query or a job list
carries kilobytes. Letting 60 MB through to a model service cost it 1.6 GB of memory it did not
give back (issue 66), so each key kind has its own bound here, enforced three times:

1. by zenoh itself: every session the deployment opens (:func:`services.transport.session.make_config`)
   and the routers it writes configs for carry :func:`low_pass_filters`, zenoh's per-key size
   filter (``low_pass_filter``): a query over its key's bound is dropped by the receiving
   session's zenoh, before any Python code sees it, and a router drops it before forwarding it;
2. by the caller (:func:`services.transport.rpc.call`): a request over its key's bound is refused
   with ``too_large`` before it is sent, so a client sees the refusal at once rather than the
   silence of a dropped query (measured: a 500 MB predict waited the whole 60 s timeout);
3. by the server (:class:`services.transport.rpc.RpcQueryable`, the model service's batcher): a
   payload over the bound is answered ``too_large`` from its length alone, before it is copied
   or decoded, for a session opened with a config file that leaves the filter out.

The table is docs/PROTOCOL.md's ("Bounds"); ``tests/unit/services/transport/test_payload_limits.py``
checks that it is.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import zenoh

from .wire import DEFAULT_MAX_BYTES

#: A request that carries no data, or a few fields (a status, a job list, an info): 64 KiB.
SMALL_BYTES = 64 * 1024
#: A predict, a transfer or an adapt request: 16 MiB. A predict's cost bound (services/model/handlers.py)
#: is 100 000 points Σ(N + T) per query; an observation point of D outputs is 8 + 9 D bytes (its time,
#: D float64 values, D mask bytes), so every predict the model service can compute fits for D <= 16.
#: An adapt target is at most 1 M observed values and 100 000 query times (about 10 MB).
QUERY_BYTES = 16 * 1024 * 1024


@dataclass(frozen=True)
class RequestLimit:
    """The largest request payload (bytes) on the keys matching ``key`` (a key expression whose
    first two chunks are ``acnmp/*``: any namespace), and why it is that large."""

    key: str
    max_bytes: int
    carries: str


#: Every queryable key of the deployment and its request bound, most specific first.
REQUEST_LIMITS: tuple[RequestLimit, ...] = (
    RequestLimit("acnmp/*/skill/*/predict", QUERY_BYTES, "conditions and query times of up to 64 predicts"),
    RequestLimit("acnmp/*/skill/*/predict/*", QUERY_BYTES, "the same, to one model process"),
    RequestLimit("acnmp/*/skill/*/transfer", QUERY_BYTES, "one predict request of robot A"),
    RequestLimit("acnmp/*/skill/*/adapt", QUERY_BYTES, "a target (at most 1 M observed values) and settings"),
    RequestLimit("acnmp/*/skill/*/info", SMALL_BYTES, "nothing"),
    RequestLimit("acnmp/*/skill/*/weights/latest", SMALL_BYTES, "nothing"),
    RequestLimit("acnmp/*/job/*/status", SMALL_BYTES, "nothing"),
    RequestLimit("acnmp/*/job/*/cancel", SMALL_BYTES, "nothing"),
    RequestLimit("acnmp/*/jobs", SMALL_BYTES, "a limit"),
    RequestLimit("acnmp/*/recorder/status", SMALL_BYTES, "nothing, or the job ids whose roll-outs it holds"),
    RequestLimit("acnmp/*/process/**", SMALL_BYTES, "nothing"),
    RequestLimit("acnmp/*/skill/*/train", DEFAULT_MAX_BYTES, "demonstrations (up to 10 M values)"),
    RequestLimit("acnmp/*/skill/*/train_pair", DEFAULT_MAX_BYTES, "two robots' demonstrations"),
    RequestLimit("acnmp/*/worker/*/*/rollout", DEFAULT_MAX_BYTES, "a batch of trajectories"),
)

_EXPRS = tuple((zenoh.KeyExpr(limit.key), limit) for limit in REQUEST_LIMITS)


@functools.lru_cache(maxsize=1024)
def request_limit(key: str) -> int:
    """The largest request payload (bytes) a query on the concrete ``key`` may carry: its key's
    bound in :data:`REQUEST_LIMITS`, else the payload cap (:data:`~services.transport.wire.DEFAULT_MAX_BYTES`)."""
    try:
        expr = zenoh.KeyExpr(str(key).split("?", 1)[0])
    except zenoh.ZError:
        return DEFAULT_MAX_BYTES
    for pattern, limit in _EXPRS:
        if pattern.includes(expr):
            return limit.max_bytes
    return DEFAULT_MAX_BYTES


def too_large_message(key: str, size: int, limit: int) -> str:
    """The ``too_large`` message of a request of ``size`` bytes over ``key``'s ``limit``."""
    return (f"request on {key} is {size} bytes; a request on this key carries at most {limit} bytes "
            "(docs/PROTOCOL.md, 'Bounds')")


def low_pass_filters() -> list[dict]:
    """zenoh's ``low_pass_filter`` config: per bound below the payload cap, one filter dropping
    queries over it on the keys it bounds, on the way in (what a session receives) and out (what
    it sends or forwards)."""
    by_size: dict[int, list[str]] = {}
    for limit in REQUEST_LIMITS:
        if limit.max_bytes < DEFAULT_MAX_BYTES:
            by_size.setdefault(limit.max_bytes, []).append(limit.key)
    return [{"id": f"acnmp-requests-{size}", "flows": ["ingress", "egress"], "messages": ["query"],
             "key_exprs": keys, "size_limit": size} for size, keys in sorted(by_size.items())]
