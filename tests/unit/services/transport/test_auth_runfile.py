"""The secrets, the ACL and the run file of an authenticated deployment, without a zenoh session:
file modes, which role may do what, how a client finds a running deployment."""
from __future__ import annotations

import json
import os
import subprocess
import sys


import pytest
import zenoh

from services.transport import auth
from services.transport.runfile import DeploymentNotFound, ProcessEntry, RunFile, find, running, runtime_dir
from tests.paths import ROOT


def _mode(path) -> int:
    return os.stat(path).st_mode & 0o777


def test_secrets_are_private_fresh_per_deployment_and_parse_as_zenoh_configs(tmp_path):
    a = auth.DeploymentSecrets(tmp_path / "a").create("tcp/127.0.0.1:7000")
    b = auth.DeploymentSecrets(tmp_path / "b").create("tcp/127.0.0.1:7000")
    assert _mode(a.directory) == 0o700 and _mode(a.dictionary) == 0o600
    lines = a.dictionary.read_text().splitlines()
    assert sorted(line.split(":")[0] for line in lines) == sorted(auth.ROLES)
    for role in auth.ROLES:
        path = a.config_path(role)
        assert _mode(path) == 0o600
        cfg = zenoh.Config.from_file(str(path))
        assert json.loads(cfg.get_json("mode")) == "client"
        assert json.loads(cfg.get_json("transport/auth/usrpwd/user")) == role
        assert auth.authenticated_user(path) == role
        # another deployment's password for the same role is different (and long)
        pa, pb = a.credentials[role].password, b.credentials[role].password
        assert pa != pb and len(pa) >= 32
    a.remove()
    assert not a.directory.exists()


def test_access_is_denied_by_default_and_granted_per_role_on_concrete_keys_only():
    from services.transport import acl
    who = lambda message, key: [r for r in acl.ROLES if acl.may(r, message, key)]  # noqa: E731
    assert who("put", "acnmp/ns/skill/e1/weights") == ["learner"]
    assert who("reply", "acnmp/ns/skill/e1/predict") == ["model"]
    assert who("query", "acnmp/ns/skill/e1/adapt") == ["operator"]
    assert who("query", "acnmp/ns/job/j1/cancel") == ["operator"]
    assert who("query", "acnmp/ns/skill/e1/predict") == ["operator", "client"]
    assert who("query", "acnmp/ns/worker/ur10/w1/rollout") == ["learner", "operator"]
    assert who("put", "acnmp/ns/event/rollout/j1") == ["learner", "operator"]
    assert who("declare_subscriber", "acnmp/ns/event/**") == ["recorder"]
    assert who("declare_subscriber", "acnmp/ns/skill/e1/weights") == ["model"]
    assert who("liveliness_token", "acnmp/ns/worker/ur10/w1") == ["worker"]
    # the wider expressions of the attacks in issue 31 are included in no grant: nobody may
    for message, key in [("put", "acnmp/ns/**"), ("query", "acnmp/ns/skill/e1/*"), ("query", "acnmp/ns/job/j1/*"),
                         ("liveliness_token", "acnmp/ns/**"), ("put", "acnmp/**"), ("query", "**"),
                         ("declare_subscriber", "acnmp/ns/**"), ("put", "acnmp/ns/skill/*/*")]:
        assert who(message, key) == [], (message, key)
    cfg = acl.acl_config()
    assert cfg["default_permission"] == "deny" and {s["id"]: s["usernames"] for s in cfg["subjects"]} == \
        {r: [r] for r in acl.ROLES}
    assert all(r["permission"] == "allow" for r in cfg["rules"])
    zcfg = zenoh.Config()
    zcfg.insert_json5("access_control", json.dumps(cfg))  # zenoh 1.10 accepts every key of it


def test_the_security_page_shows_exactly_the_access_table_the_router_enforces():
    from services.transport import acl
    page = (ROOT / "docs" / "SECURITY.md").read_text()
    begin, end = "<!-- BEGIN report:access-table -->\n", "<!-- END report:access-table -->"
    assert begin in page and end in page, "docs/SECURITY.md lost the report block of the access table"
    shown = page.split(begin, 1)[1].split(end, 1)[0]
    assert shown == acl.grants_markdown(), "regenerate: python benchmarks/report.py"


def _run_file(namespace: str, pid: int) -> RunFile:
    run = RunFile(namespace, "tcp/127.0.0.1:1", pid, credentials="/x/client.json5",
                  processes=[ProcessEntry("model", pid, f"acnmp/{namespace}/service/model/*")])
    run.write()
    return run


def test_run_files_are_found_by_namespace_and_stale_ones_ignored(monkeypatch, tmp_path):
    monkeypatch.setenv("ACNMP_RUNTIME_DIR", str(tmp_path / "rt"))
    with pytest.raises(DeploymentNotFound, match="start one with `acnmp up`"):
        find()
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                          text=True).stdout.strip()
    stale = _run_file("gone", int(dead))
    live = _run_file("lab", os.getpid())
    assert _mode(runtime_dir()) == 0o700 and _mode(live.path) == 0o600
    assert RunFile.read(live.path) == live
    assert [r.namespace for r in running()] == ["lab"]
    assert not stale.path.parent.exists()  # stale: removed with its directory (its secrets)
    assert find().namespace == "lab" and find("default").namespace == "lab"  # the only one running
    _run_file("default", os.getpid())
    assert find().namespace == "default" and find("lab").namespace == "lab"
    _run_file("other", os.getpid())
    with pytest.raises(DeploymentNotFound, match="running: default, lab, other"):
        find("nope")
    live.remove()
    assert not live.path.exists()


def test_every_session_refuses_messages_over_the_request_limit_at_the_transport(tmp_path):
    """Issue 31: the router's config, every role's config and every session built by make_config cap
    zenoh's rx message size at the request limit + 1 MiB (zenoh's default is 1 GiB)."""
    from services.transport.session import MAX_MESSAGE_BYTES, make_config
    from services.transport.wire import DEFAULT_MAX_BYTES

    assert MAX_MESSAGE_BYTES == DEFAULT_MAX_BYTES + (1 << 20)
    written = auth.write_router_deployment(tmp_path / "d", "tcp/0.0.0.0:7447", "tcp/router:7447")
    for name in ("router.json5", "client.json5", "worker.json5"):
        cfg = zenoh.Config.from_file(str(written[name]))
        assert json.loads(cfg.get_json("transport/link/rx/max_message_size")) == MAX_MESSAGE_BYTES, name
    for mode in ("peer", "client", "router"):
        cfg = make_config(mode, listen=[] if mode != "peer" else None)
        assert json.loads(cfg.get_json("transport/link/rx/max_message_size")) == MAX_MESSAGE_BYTES, mode
