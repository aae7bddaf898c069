"""Hostile requests for every queryable of a local deployment, shared by the hostile-input suite
(tests/e2e/test_hostile.py) and its 10,000-request benchmark (benchmarks/performance/bench_hostile.py).

Requests written by hypothesis: random bytes, msgpack of arbitrary shapes, hand-made array maps
(bad dtypes, absurd shapes, short data), NaN, unknown versions, and valid requests with one to
three fields replaced or deleted. :func:`hostile_deployment` starts the deployment they are sent to
(learner, model service, one point2d worker, recorder) with skill ``e1`` trained and served.
"""
from __future__ import annotations

import contextlib
import time
from pathlib import Path
from typing import Iterator

import msgpack
import numpy as np
from hypothesis import strategies as st

from acnmp_core.experiments.viapoint import make_setup
from services.launcher import LocalDeployment
from services.transport import Keyspace, WireError, call

NS = "hostile"
#: The architecture of the models the suite trains: small, so a valid train request is cheap.
SMALL = {"encoder_widths": [32, 32], "decoder_widths": [32, 32]}
#: A good predict's observations (E1's time range is [0, 1]).
OBS = {"obs_times": np.array([0.0, 1.0]), "obs_values": np.array([[0.0, 0.0], [1.0, 0.0]])}
#: Peak resident set of the model service allowed under hostile input, bytes.
MODEL_RSS_BOUND = 1 << 30

_leaf = (st.none() | st.booleans() | st.integers(-(2**63), 2**64 - 1) | st.floats() | st.text(max_size=16)
         | st.binary(max_size=32))
_tree = st.recursive(_leaf, lambda kids: st.lists(kids, max_size=4) | st.dictionaries(st.text(max_size=8), kids, max_size=4),
                     max_leaves=16)
_array_map = st.fixed_dictionaries({
    "dtype": st.sampled_from(["float32", "float64", "int32", "int64", "bool", "uint8", "complex64", ">f8", ""]) | _leaf,
    "shape": st.lists(st.integers(0, 3) | st.integers(-(2**63), 2**64 - 1), max_size=9) | _leaf,
    "data": st.binary(max_size=64) | _leaf,
})
_value = _tree | _array_map | st.lists(st.lists(st.floats(), max_size=3), max_size=3)
_headers = st.sampled_from([b"\x81\xa1v\xdb\xff\xff\xff\xff", b"\xdf\xff\xff\xff\xff", b"\xdd\xff\xff\xff\xff",
                            b"\xc6\xff\xff\xff\xff", b"\x81\xa1v\x01\x82", b"\xc1"])


def valid_requests() -> dict[str, dict]:
    """One valid request per operation (plain lists), the starting point of the mutations; a
    mutation that stays valid is cheap (1 training step, a 2-roll-out job)."""
    setup = make_setup()
    tg, demos = setup.target, setup.demos
    return {
        "predict": {"obs_times": [0.0, 1.0], "obs_values": [[0.0, 0.0], [1.0, 0.0]], "n_steps": 20},
        "train": {"times": np.stack([d.times for d in demos])[:, ::10].tolist(),
                  "values": np.stack([d.values for d in demos])[:, ::10].tolist(), "model": SMALL,
                  "train": {"steps": 1, "max_obs": 2}},
        "adapt": {"target": {"obs_times": tg.obs_times.tolist(), "obs_values": tg.obs_values.tolist(),
                             "query_times": tg.query_times.tolist()},
                  "task": "viapoint", "task_config": dict(setup.task_config), "robot": "point2d",
                  "config": {"max_rollouts": 2, "noisy_per_iter": 1}},
        "rollout": {"task": "viapoint", "task_config": dict(setup.task_config),
                    "trajectories": np.zeros((1, 5, 2)).tolist(), "times": np.linspace(0, 1, 5).tolist()},
        "none": {},
    }


@st.composite
def _mutated(draw, base: dict):
    msg = {"v": draw(st.just(1) | _leaf), **base}
    for _ in range(draw(st.integers(1, 3))):
        key = draw(st.sampled_from(sorted(msg)) | st.text(max_size=8)) if msg else draw(st.text(max_size=8))
        if draw(st.booleans()) and key in msg:
            del msg[key]
        else:
            msg[key] = draw(_value)
    return msg


def payloads(base: dict) -> st.SearchStrategy:
    """A strategy of hostile payloads (bytes, or None for no payload) built from ``base``, a valid
    request map of the queryable they are for."""
    packed = lambda obj: msgpack.packb(obj, use_bin_type=True)  # noqa: E731
    return st.one_of(
        st.none(),
        st.binary(max_size=256),
        st.builds(lambda h, tail: h + tail, _headers, st.binary(max_size=16)),
        _tree.map(packed),
        st.dictionaries(st.text(max_size=8), _value, max_size=4).map(lambda d: packed({"v": 1, **d})),
        _mutated(base).map(packed),
    )


def queryables(keys: Keyspace, valid: dict[str, dict] | None = None) -> dict[str, tuple[str, dict]]:
    """Name -> (key, valid request) of every queryable of a :func:`hostile_deployment`."""
    valid = valid_requests() if valid is None else valid
    return {"predict": (keys.predict("e1"), valid["predict"]), "info": (keys.info("e1"), valid["none"]),
            "train": (keys.train("fz"), valid["train"]), "adapt": (keys.adapt("e1"), valid["adapt"]),
            "status": (keys.job_status("e1-0"), valid["none"]),
            "weights_latest": (keys.weights_latest("e1"), valid["none"]),
            "rollout": (keys.worker_rollout("point2d", "point2d-0"), valid["rollout"]),
            "recorder_status": (keys.recorder_status(), valid["none"])}


def served(dep: LocalDeployment, timeout: float = 30.0) -> dict:
    """A good predict once the model service serves ``e1`` (polled, with a liveness deadline);
    returns the reply map. Raises WireError if it is not served within ``timeout`` seconds."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            return call(dep.session, dep.keys.predict("e1"), {**OBS, "n_steps": 20}, timeout=10)
        except WireError as exc:
            if exc.code not in ("unknown_skill", "unavailable") or time.monotonic() > deadline:
                raise
            time.sleep(0.1)


@contextlib.contextmanager
def hostile_deployment(tmp: Path) -> Iterator[LocalDeployment]:
    """learner + model + one point2d worker + recorder in ``tmp`` (recording, state), with skill
    ``e1`` trained (small architecture, 50 steps) and served; stopped on exit."""
    setup = make_setup()
    # tight learner limits: a generated request that happens to be valid trains or adapts briefly
    with LocalDeployment(NS, workers=1, record=tmp / "run.rrd", state_dir=tmp / "state",
                         learner_args=["--max-train-steps", "50", "--max-rollouts", "4"]) as dep:
        train = {"times": np.stack([d.times for d in setup.demos]),
                 "values": np.stack([d.values for d in setup.demos]), "model": SMALL, "train": {"steps": 50}}
        if call(dep.session, dep.keys.train("e1"), train, timeout=60)["version"] != 0:
            raise RuntimeError("the first training of e1 did not make version 0")
        served(dep)
        yield dep


def peak_rss(pid: int) -> int:
    """Peak resident set size of process ``pid`` in bytes (the kernel's VmHWM)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) * 1024
    raise RuntimeError(f"no VmHWM for pid {pid}")
