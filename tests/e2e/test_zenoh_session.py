"""Zenoh sessions on loopback: RPC error handling, liveliness, peer mesh, router."""
from __future__ import annotations

import threading
import time

import numpy as np
import pytest
import zenoh

from acnmp_core.errors import ShapeError
from services.transport import (Keyspace, SessionOptions, WireError, alive_tokens, call, declare_rpc, encode,
                                free_port, loopback_endpoint, open_session, wait_for_liveliness, wait_for_liveliness_gone)
from services.transport.router import RouterConfig
from services.transport.rpc import call_all
from services.transport.wire import array_field, field

KEYS = Keyspace("test")


@pytest.fixture
def anchor():
    """A peer session listening on a fresh loopback port: the deployment's anchor."""
    port = free_port()
    with open_session("peer", [loopback_endpoint(port)]) as session:
        yield session, loopback_endpoint(port)


def peer(connect: str):
    return open_session("peer", None, [connect])


def _predict(request, _query):
    """A toy service: checks its input like a real one, fails on demand."""
    if request is None:
        raise WireError("bad_request", "payload required")
    skill = field(request, "skill", str)
    if skill != "reach":
        raise WireError("unknown_skill", f"no skill {skill!r}")
    x = array_field(request, "x", shape=(None, 2))
    if len(x) == 13:
        raise RuntimeError("unlucky batch")  # a bug in a handler: must still produce a reply
    if len(x) == 7:
        raise ShapeError("x: a library check, answered by its type")
    if len(x) == 8:
        raise ValueError("x: an untyped ValueError is the service's failure")
    return {"y": x * 2.0}


@pytest.mark.parametrize("workers", [0, 2])
def test_rpc_errors_become_reply_err_and_service_keeps_serving(anchor, workers):
    server, ep = anchor
    key = "acnmp/test/skill/reach/predict"
    with declare_rpc(server, key, _predict, workers=workers) as rpc, peer(ep) as client:
        ok = {"skill": "reach", "x": np.ones((3, 2))}
        deadline = time.monotonic() + 10
        while True:  # the queryable's declaration needs a moment to reach the client
            try:
                reply = call(client, key, ok, timeout=2)
                break
            except WireError as exc:
                assert exc.code in ("unavailable", "timeout") and time.monotonic() < deadline
                time.sleep(0.05)
        np.testing.assert_array_equal(reply["y"], np.full((3, 2), 2.0))

        cases = [
            (b"\xc1\x00", "malformed"),
            (encode({"skill": "reach"}, version=2), "bad_version"),
            ({"skill": "fly", "x": np.ones((3, 2))}, "unknown_skill"),
            ({"skill": "reach", "x": np.ones((3, 3))}, "bad_shape"),
            ({"skill": "reach"}, "bad_request"),
            (b"\x82\xa1v\x01\xa1x\xcb\x7f\xf8\x00\x00\x00\x00\x00\x00", "non_finite"),  # {"v":1,"x":NaN}
            ({"skill": "reach", "x": np.ones((13, 2))}, "internal"),
            ({"skill": "reach", "x": np.ones((7, 2))}, "bad_shape"),
            ({"skill": "reach", "x": np.ones((8, 2))}, "internal"),
            (None, "bad_request"),
        ]
        for payload, code in cases:  # each a reply with its code (no reply would be "timeout")
            with pytest.raises(WireError) as info:
                call(client, key, payload, timeout=5)
            assert info.value.code == code, info.value
            assert info.value.message
        # and it still serves good requests afterwards
        np.testing.assert_array_equal(call(client, key, ok, timeout=5)["y"], np.full((3, 2), 2.0))
        assert rpc.failed == len(cases) and rpc.served == 2


def test_zenohs_own_timeout_reply_is_the_timeout_code(anchor):
    server, ep = anchor
    held = []  # queries kept (not dropped): no reply until the querier's timeout passes
    queryable = server.declare_queryable("acnmp/test/slow", held.append)
    try:
        with peer(ep) as client:
            deadline = time.monotonic() + 10
            while True:  # "unavailable" until the queryable's declaration has reached the client
                with pytest.raises(WireError) as info:
                    call(client, "acnmp/test/slow", {}, timeout=0.5)
                if info.value.code != "unavailable" or time.monotonic() > deadline:
                    break
            assert info.value.code == "timeout", info.value
            assert held, "the query never reached the queryable"
    finally:
        for query in held:
            query.drop()
        queryable.undeclare()


def test_query_without_service_is_unavailable_not_a_timeout(anchor):
    session, _ = anchor
    with pytest.raises(WireError) as info:  # "unavailable": the query ended before its timeout
        call(session, "acnmp/test/nobody/home", {}, timeout=30)
    assert info.value.code == "unavailable"


def test_liveliness_wait_sees_tokens_before_and_after(anchor):
    session, ep = anchor
    pattern = KEYS.tokens("worker")
    with peer(ep) as w1, peer(ep) as w2:
        t1 = w1.liveliness().declare_token(KEYS.worker_token("planar3", "w1"))
        held = []  # a token is undeclared when its Python object is garbage collected: keep it
        later = threading.Timer(0.3, lambda: held.append(w2.liveliness().declare_token(
            KEYS.worker_token("planar3", "w2"))))
        later.start()
        try:
            found = wait_for_liveliness(session, pattern, count=2, timeout=10)
        finally:
            later.join()
        assert found == ["acnmp/test/worker/planar3/w1", "acnmp/test/worker/planar3/w2"]
        t1.undeclare()
        wait_for_liveliness_gone(session, KEYS.worker_token("planar3", "w1"), timeout=10)
        assert alive_tokens(session, pattern) == ["acnmp/test/worker/planar3/w2"]
        with pytest.raises(TimeoutError, match="still alive"):
            wait_for_liveliness_gone(session, pattern, timeout=0.5)
    with pytest.raises(TimeoutError):
        wait_for_liveliness(session, pattern, count=1, timeout=0.5)


def test_gossip_meshes_peers_that_only_know_the_anchor():
    port = free_port()
    got = []
    with open_session("peer", [loopback_endpoint(port)]) as anchor_session, \
            peer(loopback_endpoint(port)) as a, peer(loopback_endpoint(port)) as b:
        deadline = time.monotonic() + 10
        while str(b.zid()) not in {str(z) for z in a.info.peers_zid()}:
            assert time.monotonic() < deadline, "peers did not find each other through gossip"
            time.sleep(0.05)
        assert all("127.0.0.1" in link.dst for link in a.info.links())  # loopback only
        anchor_session.close()  # the mesh does not depend on the anchor any more
        sub = b.declare_subscriber("acnmp/test/mesh", lambda s: got.append(s.payload.to_bytes()))
        deadline = time.monotonic() + 10
        while not got and time.monotonic() < deadline:
            a.put("acnmp/test/mesh", b"hello")
            time.sleep(0.1)
        sub.undeclare()
    assert got and got[0] == b"hello"


def test_python_router_with_clients(serving):
    port = free_port()
    with serving(RouterConfig(SessionOptions("test", listen=[loopback_endpoint(port)]))) as line:
        assert line.startswith("router ")
        with open_session("client", None, [loopback_endpoint(port)]) as c1, \
                open_session("client", None, [loopback_endpoint(port)]) as c2:
            assert wait_for_liveliness(c1, KEYS.tokens("router"), timeout=10)
            with declare_rpc(c2, "acnmp/test/echo", lambda req, _q: {"echo": req["x"]}):
                deadline = time.monotonic() + 10
                while True:
                    try:
                        assert call(c1, "acnmp/test/echo", {"x": 5}, timeout=2)["echo"] == 5
                        break
                    except WireError:
                        assert time.monotonic() < deadline
                        time.sleep(0.05)


def test_client_gives_up_when_no_router():
    with pytest.raises(ConnectionError):
        with open_session("client", None, [loopback_endpoint(free_port())], open_timeout=0.5):
            pass


def test_open_session_closes_on_exception():
    with pytest.raises(KeyError):
        with open_session() as session:
            raise KeyError("boom")
    assert session.is_closed()
    assert isinstance(session, zenoh.Session)


def _blocking_service(server, key, **kwargs):
    """A one-thread RPC whose handler waits for ``release``; returns (rpc, entered, release, calls)."""
    entered, release, calls = threading.Event(), threading.Event(), []

    def handler(request, _query):
        calls.append(request)
        entered.set()
        release.wait(30)
        return {"n": len(calls)}

    return declare_rpc(server, key, handler, workers=1, **kwargs), entered, release, calls


def _wait_until(pred, timeout: float = 10.0) -> None:
    deadline = time.monotonic() + timeout
    while not pred():
        assert time.monotonic() < deadline, "condition not reached"
        time.sleep(0.01)


def _reachable(client, key: str) -> None:
    """Wait until a query on ``key`` reaches a queryable (an ``unavailable`` before that)."""
    deadline = time.monotonic() + 10
    while True:
        try:
            call(client, key, {"probe": True}, timeout=5)
            return
        except WireError as exc:
            assert exc.code == "unavailable" and time.monotonic() < deadline, exc


def _hold_first(client, key: str, entered: threading.Event, release: threading.Event):
    """Once ``key`` is reachable, send query 1 and wait until the handler holds it; its reply handler."""
    release.set()
    _reachable(client, key)
    release.clear()
    entered.clear()
    first = client.get(key, payload=encode({"i": 1}), timeout=30)
    assert entered.wait(10)
    return first


def test_a_full_queue_answers_overloaded_at_once_and_queued_queries_still_complete(anchor):
    server, ep = anchor
    key = "acnmp/test/queue/full"
    rpc, entered, release, calls = _blocking_service(server, key, max_queue=2)
    try:
        with peer(ep) as client:
            first = _hold_first(client, key, entered, release)  # runs, held by the handler
            queued = [client.get(key, payload=encode({"i": i}), timeout=30) for i in (2, 3)]
            _wait_until(lambda: rpc.waiting == 2)
            with pytest.raises(WireError) as info:
                call(client, key, {"i": 4}, timeout=10)
            assert info.value.code == "overloaded" and rpc.overloaded == 1
            release.set()
            for handler in (first, *queued):
                assert [r.ok is not None for r in handler] == [True]
            assert len(calls) == 1 + 3  # the probe, then 1, 2, 3; never 4
    finally:
        release.set()
        rpc.close()


def test_one_rpc_on_two_keys_shares_one_queue_bound(anchor):
    """The model service's predict answers on the skill's key and on its own: --max-queue bounds
    the process, not each key (two bounds let twice the queries wait)."""
    server, ep = anchor
    key_a, key_b = "acnmp/test/shared/a", "acnmp/test/shared/b"
    rpc, entered, release, calls = _blocking_service(server, [key_a, key_b], max_queue=1)
    try:
        with peer(ep) as client:
            release.set()
            _reachable(client, key_b)
            first = _hold_first(client, key_a, entered, release)  # runs, held by the one handler thread
            queued = client.get(key_b, payload=encode({"i": 2}), timeout=30)
            _wait_until(lambda: rpc.waiting == 1)
            for key in (key_a, key_b):
                with pytest.raises(WireError) as info:
                    call(client, key, {"i": 3}, timeout=10)
                assert info.value.code == "overloaded" and key in info.value.message
            assert rpc.overloaded == 2
            release.set()
            for handler in (first, queued):
                assert [r.ok is not None for r in handler] == [True]
            assert [c["i"] for c in calls if "i" in c] == [1, 2]
    finally:
        release.set()
        rpc.close()


def test_a_query_whose_timeout_passed_in_the_queue_is_dropped_without_computing(anchor):
    server, ep = anchor
    key = "acnmp/test/queue/deadline"
    rpc, entered, release, calls = _blocking_service(server, key)
    try:
        with peer(ep) as client:
            first = _hold_first(client, key, entered, release)
            with pytest.raises(WireError) as info:  # waits in the queue behind the first, gives up
                call(client, key, {"i": 2}, timeout=0.3)
            assert info.value.code == "timeout"
            # the server's deadline is its arrival + 0.3 s: release the first query only once the
            # second is queued and that deadline has surely passed (on a loaded machine the query
            # can arrive late; releasing at once then had it computed, in time by the server's clock)
            _wait_until(lambda: rpc.waiting == 1)
            queued_by = time.monotonic()
            _wait_until(lambda: time.monotonic() > queued_by + 0.3)
            release.set()
            assert [r.ok is not None for r in first] == [True]
            _wait_until(lambda: rpc.expired == 1)
            assert [c["i"] for c in calls if "i" in c] == [1]  # the expired query was never computed
    finally:
        release.set()
        rpc.close()


def test_call_all_gets_every_services_reply_on_one_key_where_call_gets_one(anchor):
    server, ep = anchor
    key = "acnmp/test/jobs"
    # two services (as two learners) each answering for their own part, on the same key; not
    # complete, so every one of them gets the query
    rpcs = [declare_rpc(server, key, lambda _r, _q, name=name: {"jobs": [name]}, complete=False)
            for name in ("a", "b")]
    try:
        with peer(ep) as client:
            deadline = time.monotonic() + 10
            while True:  # the queryables' declarations need a moment to reach the client
                replies = call_all(client, key, {}, timeout=2)
                if len(replies) == 2 or time.monotonic() > deadline:
                    break
                time.sleep(0.05)
            assert sorted(r["jobs"][0] for r in replies) == ["a", "b"]
            assert call(client, key, {}, timeout=2)["jobs"][0] in ("a", "b")
            with pytest.raises(WireError) as err:
                call_all(client, "acnmp/test/nobody", {}, timeout=2)
            assert err.value.code == "unavailable"
    finally:
        for rpc in rpcs:
            rpc.close()
