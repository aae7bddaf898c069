"""The router deployment of `acnmp credentials` (what docker-compose.secure.yml runs) on loopback:
mutual TLS, a password per role and the router's ACL. The learner's weights reach a subscriber,
a client's do not, and a process with the certificate but no password cannot join."""
from __future__ import annotations

import json
import shutil
import subprocess
import threading

import pytest
import zenoh

from services.transport import free_port, open_session
from services.transport.auth import write_router_deployment
from tests.paths import ROOT

pytestmark = pytest.mark.skipif(shutil.which("openssl") is None, reason="needs openssl to make certificates")
WEIGHTS = "acnmp/tls-acl/skill/s/weights"


def test_router_deployment_applies_tls_passwords_and_acl(tmp_path):
    subprocess.run(["bash", str(ROOT / "scripts" / "make_tls_certs.sh"), str(tmp_path / "tls")], check=True,
                   capture_output=True, timeout=120)
    port = free_port()
    files = write_router_deployment(tmp_path / "secrets", f"tls/127.0.0.1:{port}", f"tls/localhost:{port}",
                                    tls_dir=str(tmp_path / "tls"))
    got: list[bytes] = []
    arrived = threading.Event()

    def on_weights(sample: zenoh.Sample) -> None:
        got.append(sample.payload.to_bytes())
        if got[-1] == b"learner":
            arrived.set()

    with open_session(None, config_file=files["router.json5"]) as _router, \
            open_session(None, config_file=files["model.json5"], open_timeout=5) as model:
        sub = model.declare_subscriber(WEIGHTS, on_weights)
        for role in ("client", "operator", "learner"):  # the learner last: its put is the one awaited
            with open_session(None, config_file=files[f"{role}.json5"], open_timeout=5) as s:
                s.declare_publisher(WEIGHTS)  # wait until the route exists, then put once
                s.put(WEIGHTS, role.encode())
        assert arrived.wait(10), got
        assert got == [b"learner"]
        # the certificate without a password of the dictionary: refused
        cfg = json.loads(files["client.json5"].read_text())
        del cfg["transport"]["auth"]
        nopass = tmp_path / "nopass.json5"
        nopass.write_text(json.dumps(cfg))
        with pytest.raises(ConnectionError):
            with open_session(None, config_file=nopass, open_timeout=1):
                pass
        sub.undeclare()
