"""docker-compose.yml and the Dockerfile, checked without a Docker engine: the router is the pinned
eclipse/zenoh 1.10 image, every process has its container in client mode connected to the router,
and every container's command line parses with the ``acnmp`` CLI it will run."""
from __future__ import annotations

import argparse
import re
import shlex

import pytest
import yaml
from tests.paths import ROOT

PROCESSES = {"recorder", "learner", "model", "worker"}


@pytest.fixture(scope="module")
def compose() -> dict:
    return yaml.safe_load((ROOT / "docker-compose.yml").read_text())


def _command(service: dict) -> list[str]:
    cmd = service.get("command")
    return shlex.split(cmd) if isinstance(cmd, str) else list(cmd)


def _process_services(compose: dict) -> dict[str, list[str]]:
    return {name: _command(s) for name, s in compose["services"].items() if name != "router"}


def test_router_is_the_pinned_zenoh_1_10_image(compose):
    router = compose["services"]["router"]
    assert re.fullmatch(r"eclipse/zenoh:1\.10\.\d+", router["image"]), router["image"]
    assert "tcp/0.0.0.0:7447" in _command(router)
    # published on the host's loopback only
    assert all(str(p).startswith("127.0.0.1:") for p in router.get("ports", []))


def test_every_process_has_a_container_in_client_mode_connected_to_the_router(compose):
    commands = _process_services(compose)
    kinds = {cmd[1] for cmd in commands.values()}
    assert PROCESSES <= kinds, f"missing: {PROCESSES - kinds}"
    robots = set()
    for name, cmd in commands.items():
        assert cmd[0] == "serve", name
        assert cmd[cmd.index("--mode") + 1] == "client", name
        assert cmd[cmd.index("--connect") + 1] == "tcp/router:7447", name
        assert "router" in compose["services"][name].get("depends_on", []), name
        assert compose["services"][name].get("build") or compose["services"][name].get("image"), name
        if cmd[1] == "worker":
            robots.add(cmd[cmd.index("--robot") + 1])
    assert len(robots) >= 2, "two workers with different robots"


def test_checkpoints_and_recordings_are_on_volumes(compose):
    services = compose["services"]
    declared = set(compose.get("volumes", {}))
    assert {"checkpoints", "recordings"} <= declared
    rec = _command(services["recorder"])
    out = rec[rec.index("--out") + 1]
    mounts = [v.split(":") for v in services["recorder"]["volumes"]]
    assert any(m[0] == "recordings" and out.startswith(m[1]) for m in mounts)
    learner_mounts = {v.split(":")[0] for v in services["learner"]["volumes"]}
    assert learner_mounts & {"state", "checkpoints"}


def test_dockerfile_installs_cpu_torch_and_the_package():
    text = (ROOT / "Dockerfile").read_text()
    assert re.search(r"^FROM python:3\.11-slim", text, re.M)
    assert "torch==2.13.0" in text and "download.pytorch.org/whl/cpu" in text
    assert re.search(r"pip install \.", text)
    assert 'ENTRYPOINT ["acnmp"]' in text


def test_model_container_command_builds_the_model_config():
    from services.model.service import ModelConfig
    from services.transport.service import from_args, parser_for

    cmd = _command(yaml.safe_load((ROOT / "docker-compose.yml").read_text())["services"]["model"])
    config = from_args(ModelConfig, parser_for(ModelConfig).parse_args(cmd[2:]))
    assert config.session.mode == "client" and config.session.connect == ["tcp/router:7447"]


def test_every_container_command_parses_with_acnmp_serve(compose):
    from clients.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    serve_help = sub.choices["serve"].format_help()  # what `acnmp serve --help` prints
    for name, cmd in _process_services(compose).items():
        assert re.search(rf"\b{cmd[1]}\b", serve_help), f"{name}: `acnmp serve --help` lists no {cmd[1]!r}"
        try:
            parser.parse_args(cmd)
        except SystemExit as exc:  # argparse exits on an unknown option or process
            pytest.fail(f"{name}: `acnmp {' '.join(cmd)}` does not parse (exit {exc.code})")


def test_every_process_container_is_named_as_its_host(compose):
    """`acnmp status --config` and the recording name each process's host (services/transport/about.py):
    a container's own host name is its random id unless the file sets it."""
    for name, svc in compose["services"].items():
        if name != "router":
            assert svc.get("hostname") == name, name
