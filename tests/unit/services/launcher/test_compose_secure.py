"""docker-compose.secure.yml, checked without a Docker engine: it overrides every container of
docker-compose.yml, each process runs with the zenoh config of its own role from the mounted
secrets, and those configs are what `acnmp credentials` writes (they parse as zenoh configs)."""
from __future__ import annotations

import json
import shlex

import yaml
import zenoh

from clients.cli import build_parser
from services.transport.auth import ROLES, write_router_deployment
from tests.paths import ROOT

MOUNT = "./deploy/secrets:/etc/acnmp:ro"


def _command(service: dict) -> list[str]:
    cmd = service["command"]
    return shlex.split(cmd) if isinstance(cmd, str) else list(cmd)


def test_every_process_runs_with_the_config_of_its_role(tmp_path):
    base = yaml.safe_load((ROOT / "docker-compose.yml").read_text())["services"]
    secure = yaml.safe_load((ROOT / "docker-compose.secure.yml").read_text())["services"]
    assert set(secure) == set(base)
    assert _command(secure["router"]) == ["-c", "/etc/acnmp/router.json5"]
    written = write_router_deployment(tmp_path, "tls/0.0.0.0:7447", "tls/router:7447", tls_dir="/etc/acnmp/tls",
                                      at="/etc/acnmp")
    parser = build_parser()
    for name, service in secure.items():
        assert MOUNT in service["volumes"], name
        if name == "router":
            continue
        cmd = _command(service)
        kind = cmd[1]
        assert kind in ROLES and cmd[cmd.index("--config") + 1] == f"/etc/acnmp/{kind}.json5", name
        assert "--mode" not in cmd and "--connect" not in cmd, name  # both come from the role's config
        # the same process and options as the base file, apart from the connection
        plain = [a for a in _command(base[name]) if a not in ("--mode", "client", "--connect", "tcp/router:7447")]
        assert [a for a in cmd if a not in ("--config", f"/etc/acnmp/{kind}.json5")] == plain, name
        parser.parse_args(cmd)
        cfg = zenoh.Config.from_file(str(written[f"{kind}.json5"]))
        assert json.loads(cfg.get_json("transport/auth/usrpwd/user")) == kind
        assert json.loads(cfg.get_json("connect/endpoints")) == ["tls/router:7447"]
    router = zenoh.Config.from_file(str(written["router.json5"]))
    assert json.loads(router.get_json("transport/auth/usrpwd/dictionary_file")) == "/etc/acnmp/users.txt"
    assert json.loads(router.get_json("access_control/enabled")) is True
    assert json.loads(router.get_json("transport/link/tls/enable_mtls")) is True
