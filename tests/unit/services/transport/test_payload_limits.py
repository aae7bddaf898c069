"""Per-key request bounds (issue 66): each key carries what it needs, a predict or a status query
far less than a train request; the bounds zenoh's own filter gets are the same, and the docs say
them."""
from __future__ import annotations

from pathlib import Path

import pytest

from services.transport import Keyspace
from services.transport.payload_limits import (QUERY_BYTES, REQUEST_LIMITS, SMALL_BYTES, low_pass_filters,
                                               request_limit)
from services.transport.session import make_config
from services.transport.wire import DEFAULT_MAX_BYTES

K = Keyspace("lab")


@pytest.mark.parametrize("key, bound", [
    (K.predict("e1"), QUERY_BYTES), (K.predict_at("e1", "a1b2"), QUERY_BYTES), (K.transfer("p"), QUERY_BYTES),
    (K.adapt("e1"), QUERY_BYTES), (K.info("e1"), SMALL_BYTES), (K.weights_latest("e1"), SMALL_BYTES),
    (K.job_status("e1-0123456789"), SMALL_BYTES), (K.job_cancel("e1-0123456789"), SMALL_BYTES),
    (K.jobs(), SMALL_BYTES), (K.recorder_status(), SMALL_BYTES), (K.process("model", "a1b2"), SMALL_BYTES),
    (K.train("e1"), DEFAULT_MAX_BYTES), (K.train_pair("p"), DEFAULT_MAX_BYTES),
    (K.worker_rollout("point2d", "w0"), DEFAULT_MAX_BYTES), ("acnmp/lab/something/else", DEFAULT_MAX_BYTES),
    (K.predict("e1") + "?timeout=5", QUERY_BYTES),
])
def test_every_key_has_the_bound_of_what_it_carries(key, bound):
    assert request_limit(key) == bound


def test_zenohs_filter_drops_queries_over_each_bound_in_every_session_the_deployment_opens():
    filters = low_pass_filters()
    by_key = {key: f["size_limit"] for f in filters for key in f["key_exprs"]}
    assert by_key == {lim.key: lim.max_bytes for lim in REQUEST_LIMITS if lim.max_bytes < DEFAULT_MAX_BYTES}
    assert all(f["messages"] == ["query"] and set(f["flows"]) == {"ingress", "egress"} for f in filters)
    import json

    in_config = json.loads(make_config("peer").get_json("low_pass_filter"))
    assert [{k: v for k, v in f.items() if v is not None} for f in in_config] == filters


def test_the_faults_page_states_every_bound():
    text = (Path(__file__).parents[4] / "docs" / "FAULTS.md").read_text()
    for lim in REQUEST_LIMITS:
        size = f"{lim.max_bytes // 2**20} MiB" if lim.max_bytes >= 2**20 else f"{lim.max_bytes // 1024} KiB"
        assert f"| `{lim.key}` | {size} |" in text, lim
