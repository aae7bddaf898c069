"""The transport wing without a session: zenoh config, key expressions, error codes by type,
and the one service runner's command line."""
from __future__ import annotations

import argparse
import json
from dataclasses import dataclass
from typing import ClassVar

import pytest

from acnmp_core.errors import (InputError, NonFiniteError, ShapeError, TooLargeError, UnknownRobotError,
                               UnknownTaskError)
from services.transport import (ERROR_CODES, Keyspace, Service, SessionOptions, WireError, make_config, option,
                                wire_error)
from services.transport.keys import job_from_key, skill_from_key
from services.transport.service import add_arguments, from_args


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


def test_keyspace_builds_every_key_of_a_namespace():
    k = Keyspace("lab")
    assert k.predict("reach") == "acnmp/lab/skill/reach/predict"
    assert k.weights_latest("*") == "acnmp/lab/skill/*/weights/latest"
    assert k.job_status("reach-1") == "acnmp/lab/job/reach-1/status" and k.job_status() == "acnmp/lab/job/*/status"
    assert k.worker_rollout("planar3", "w0") == "acnmp/lab/worker/planar3/w0/rollout"
    assert k.worker_token("planar3") == "acnmp/lab/worker/planar3/*"
    assert k.event("rollout", "job-1") == "acnmp/lab/event/rollout/job-1" and k.events() == "acnmp/lab/event/**"
    assert k.model_service_token() == "acnmp/lab/service/model/*" and k.tokens("recorder") == "acnmp/lab/recorder/**"
    assert skill_from_key(k.predict("reach")) == "reach" and job_from_key(k.job_status("j1")) == "j1"
    for bad in (lambda: Keyspace("a/b"), lambda: k.predict("**"), lambda: k.event("nope", "x"),
                lambda: skill_from_key("acnmp/lab/job/x/status")):
        with pytest.raises(ValueError):
            bad()


@pytest.mark.parametrize("exc, code", [
    (ShapeError("x"), "bad_shape"), (NonFiniteError("x"), "non_finite"), (TooLargeError("x"), "too_large"),
    (UnknownTaskError("x"), "unknown_task"), (UnknownRobotError("x"), "bad_request"), (InputError("x"), "bad_request"),
    (WireError("timeout", "x"), "timeout"), (ValueError("x"), "internal"), (KeyError("x"), "internal"),
])
def test_errors_map_to_wire_codes_by_type(exc, code):
    err = wire_error(exc)
    assert err.code == code and err.code in ERROR_CODES


def test_a_subclass_takes_its_parents_code_and_untyped_value_errors_can_default():
    class Ragged(ShapeError):
        pass

    assert wire_error(Ragged("x")).code == "bad_shape"
    assert wire_error(ValueError("x"), default="bad_request").code == "bad_request"
    assert wire_error(RuntimeError("x"), default="bad_request").code == "internal"


@dataclass
class _Toy(Service):
    name: ClassVar[str] = "toy"
    summary: ClassVar[str] = "a service for this test"
    robot: str = option("a", "robot", choices=lambda: ("a", "b"))
    toy_id: str | None = option(None, "id", flag="--id")
    skills: list[str] | None = option(None, "skill (repeatable)", flag="--skill")
    paths: list[str] = option([], "paths")
    delay: float = option(0.5, "seconds")
    verbose: bool = option(False, "talk")


def test_a_service_config_is_its_command_line():
    parser = argparse.ArgumentParser()
    add_arguments(parser, _Toy)
    cfg = from_args(_Toy, parser.parse_args([]))
    assert (cfg.robot, cfg.toy_id, cfg.skills, cfg.paths, cfg.delay, cfg.verbose) == ("a", None, None, [], 0.5, False)
    assert cfg.session.namespace == "default" and cfg.session.mode is None
    cfg = from_args(_Toy, parser.parse_args(["--robot", "b", "--id", "t1", "--skill", "x", "--skill", "y",
                                             "--paths", "p", "--delay", "2", "--verbose", "-n", "lab",
                                             "--mode", "client", "--connect", "tcp/127.0.0.1:1"]))
    assert (cfg.robot, cfg.toy_id, cfg.skills, cfg.paths, cfg.delay, cfg.verbose) == \
        ("b", "t1", ["x", "y"], ["p"], 2.0, True)
    assert (cfg.session.namespace, cfg.session.mode, cfg.session.connect) == ("lab", "client", ["tcp/127.0.0.1:1"])
    assert _Toy().paths is not _Toy().paths  # list defaults are per instance
    with pytest.raises(SystemExit):
        parser.parse_args(["--robot", "c"])


def test_every_process_parses_its_options_into_its_config():
    from clients.cli import build_parser
    from services.launcher import PROCESSES, service_class

    parser = build_parser()
    argv = {"model": ["--skill", "reach", "--checkpoint", "reach=x.pt", "--workers", "3"],
            "learner": ["--state-dir", "s", "--id", "l1", "--demos", "e1=d.npz", "--wait-recorder", "5"],
            "worker": ["--robot", "planar4", "--id", "arm1", "--delay", "0.1"],
            "recorder": ["--out", "r.rrd"], "router": ["--listen", "tcp/127.0.0.1:7448"]}
    for name in PROCESSES:
        args = parser.parse_args(["serve", name, *argv[name], "--namespace", "lab"])
        cfg = from_args(service_class(name), args)
        assert cfg.session.namespace == "lab" and cfg.name == name
    model = from_args(service_class("model"), parser.parse_args(["serve", "model", "--batch-max", "1",
                                                                  "--batch-window", "0.002"]))
    assert (model.batch_max, model.batch_window) == (1, 0.002)
    worker = from_args(service_class("worker"), parser.parse_args(["serve", "worker", *argv["worker"]]))
    assert (worker.robot, worker.worker_id, worker.delay) == ("planar4", "arm1", 0.1)
    learner = from_args(service_class("learner"), parser.parse_args(["serve", "learner", *argv["learner"]]))
    assert (learner.state_dir, learner.learner_id, learner.demos, learner.wait_recorder) == ("s", "l1", ["e1=d.npz"], 5.0)
    with pytest.raises(SystemExit):  # robot kinds come from the registry
        parser.parse_args(["serve", "worker", "--robot", "ur11"])
    router = service_class("router")
    assert from_args(router, parser.parse_args(["serve", "router"])).session.listen == ["tcp/127.0.0.1:7447"]
    with pytest.raises(ValueError, match="router mode"):
        router(SessionOptions(mode="peer"))
