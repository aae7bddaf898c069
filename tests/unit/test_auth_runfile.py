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


def test_only_the_learner_may_put_weights_and_only_operator_or_learner_start_jobs():
    assert [r for r in auth.ROLES if auth.may(r, "put", "weights")] == ["learner"]
    assert [r for r in auth.ROLES if auth.may(r, "reply", "model-answers")] == ["model"]
    assert sorted(r for r in auth.ROLES if auth.may(r, "query", "start-jobs")) == ["learner", "operator"]
    assert not auth.may("client", "put", "events") and auth.may("worker", "put", "events")
    # the events' advanced pub/sub: caches only from event publishers, history queries only by the recorder
    assert sorted(r for r in auth.ROLES if auth.may(r, "declare_queryable", "event-caches")) == \
        ["learner", "operator", "worker"]
    assert [r for r in auth.ROLES if auth.may(r, "query", "event-history")] == ["recorder"]
    assert [r for r in auth.ROLES if auth.may(r, "liveliness_token", "event-subscribers")] == ["recorder"]
    acl = auth.acl_config()
    rules = {r["id"]: r for r in acl["rules"]}
    denied = {rid: set(s) for p in acl["policies"] for rid in p["rules"] for s in [p["subjects"]]}
    assert denied["weights"] == set(auth.ROLES) - {"learner"}
    assert rules["weights"]["key_exprs"] == ["acnmp/*/skill/*/weights"] and rules["weights"]["flows"] == ["ingress"]
    assert {s["id"]: s["usernames"] for s in acl["subjects"]} == {r: [r] for r in auth.ROLES}
    cfg = zenoh.Config()
    cfg.insert_json5("access_control", json.dumps(acl))  # zenoh 1.10 accepts every key of it


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
