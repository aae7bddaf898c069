"""Zenoh sessions on loopback: config defaults, RPC error handling, liveliness, peer mesh, router."""
from __future__ import annotations

import json
import threading
import time

import numpy as np
import pytest
import zenoh

from services import keys
from services.session import (alive_tokens, declare_rpc, free_port, loopback_endpoint, make_config,
                              open_session, query, wait_for_liveliness)
from services.wire import WireError, array_field, encode, field


@pytest.fixture
def anchor():
    """A peer session listening on a fresh loopback port: the deployment's anchor."""
    port = free_port()
    with open_session("peer", [loopback_endpoint(port)]) as session:
        yield session, loopback_endpoint(port)


def peer(connect: str):
    return open_session("peer", None, [connect])


def test_defaults_are_loopback_without_multicast():
    cfg = make_config()
    assert json.loads(cfg.get_json("mode")) == "peer"
    assert json.loads(cfg.get_json("listen/endpoints")) == ["tcp/127.0.0.1:0"]
    assert json.loads(cfg.get_json("scouting/multicast/enabled")) is False
    assert json.loads(cfg.get_json("scouting/gossip/enabled")) is True
    assert json.loads(make_config("router").get_json("listen/endpoints")) == ["tcp/127.0.0.1:7447"]
    assert json.loads(make_config("client").get_json("listen/endpoints")) == []
    with pytest.raises(ValueError):
        make_config("bogus")


def test_config_file_is_merged_under_explicit_arguments(tmp_path):
    path = tmp_path / "zenoh.json5"
    path.write_text('{ // a comment: JSON5\n mode: "client", connect: { endpoints: ["tcp/127.0.0.1:1234"] },\n'
                    ' scouting: { multicast: { enabled: false } }, }\n')
    cfg = make_config(None, config_file=path)
    assert json.loads(cfg.get_json("mode")) == "client"
    assert json.loads(cfg.get_json("connect/endpoints")) == ["tcp/127.0.0.1:1234"]
    cfg = make_config("peer", connect=["tcp/127.0.0.1:999"], config_file=path)
    assert json.loads(cfg.get_json("mode")) == "peer"
    assert json.loads(cfg.get_json("connect/endpoints")) == ["tcp/127.0.0.1:999"]
    bad = tmp_path / "bad.json5"
    bad.write_text("{ mode: ")
    with pytest.raises(ValueError):
        make_config(None, config_file=bad)


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
                reply = query(client, key, ok, timeout=2)
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
            (None, "bad_request"),
        ]
        for payload, code in cases:
            t0 = time.monotonic()
            with pytest.raises(WireError) as info:
                query(client, key, payload, timeout=5)
            assert info.value.code == code, info.value
            assert info.value.message
            assert time.monotonic() - t0 < 2.0, "an error must be a prompt reply, not a timeout"
        # and it still serves good requests afterwards
        np.testing.assert_array_equal(query(client, key, ok, timeout=5)["y"], np.full((3, 2), 2.0))
        assert rpc.failed == len(cases) and rpc.served == 2


def test_query_without_service_is_unavailable_quickly(anchor):
    session, _ = anchor
    t0 = time.monotonic()
    with pytest.raises(WireError) as info:
        query(session, "acnmp/test/nobody/home", {}, timeout=3)
    assert info.value.code == "unavailable"
    assert time.monotonic() - t0 < 1.0


def test_liveliness_wait_sees_tokens_before_and_after(anchor):
    session, ep = anchor
    pattern = keys.liveliness_pattern("test", "worker")
    with peer(ep) as w1, peer(ep) as w2:
        t1 = w1.liveliness().declare_token(keys.liveliness_key("test", "worker", "planar3", "w1"))
        held = []  # a token is undeclared when its Python object is garbage collected: keep it
        later = threading.Timer(0.3, lambda: held.append(w2.liveliness().declare_token(
            keys.liveliness_key("test", "worker", "planar3", "w2"))))
        later.start()
        try:
            found = wait_for_liveliness(session, pattern, count=2, timeout=10)
        finally:
            later.join()
        assert found == ["acnmp/test/worker/planar3/w1", "acnmp/test/worker/planar3/w2"]
        t1.undeclare()
        deadline = time.monotonic() + 5
        while "acnmp/test/worker/planar3/w1" in alive_tokens(session, pattern) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert alive_tokens(session, pattern) == ["acnmp/test/worker/planar3/w2"]
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


def test_python_router_with_clients():
    from services.router import run

    port = free_port()
    stop = threading.Event()
    ready = threading.Event()
    thread = threading.Thread(target=run, args=([loopback_endpoint(port)],),
                              kwargs={"namespace": "test", "stop": stop, "ready": lambda _zid: ready.set()})
    thread.start()
    try:
        assert ready.wait(10)
        with open_session("client", None, [loopback_endpoint(port)]) as c1, \
                open_session("client", None, [loopback_endpoint(port)]) as c2:
            assert wait_for_liveliness(c1, keys.liveliness_pattern("test", "router"), timeout=10)
            with declare_rpc(c2, "acnmp/test/echo", lambda req, _q: {"echo": req["x"]}):
                deadline = time.monotonic() + 10
                while True:
                    try:
                        assert query(c1, "acnmp/test/echo", {"x": 5}, timeout=2)["echo"] == 5
                        break
                    except WireError:
                        assert time.monotonic() < deadline
                        time.sleep(0.05)
    finally:
        stop.set()
        thread.join(10)
    assert not thread.is_alive()


def test_client_gives_up_when_no_router():
    t0 = time.monotonic()
    with pytest.raises(ConnectionError):
        with open_session("client", None, [loopback_endpoint(free_port())], open_timeout=0.5):
            pass
    assert time.monotonic() - t0 < 5


def test_open_session_closes_on_exception():
    with pytest.raises(KeyError):
        with open_session() as session:
            raise KeyError("boom")
    assert session.is_closed()
    assert isinstance(session, zenoh.Session)
