"""The documented TLS deployment works: deploy/tls/*.json5 with certificates from
scripts/make_tls_certs.sh let a client with the right certificate and password in, and keep a
client with a wrong password or without a certificate out. Loopback only."""
from __future__ import annotations

import re
import shutil
import subprocess
import time
from pathlib import Path

import pytest

from services.transport import free_port, open_session
from tests.paths import ROOT

pytestmark = pytest.mark.skipif(shutil.which("openssl") is None, reason="needs openssl to make certificates")


@pytest.fixture(scope="module")
def tls(tmp_path_factory):
    """(directory, port, make) where make(example, **edits) writes a config for this test."""
    d = tmp_path_factory.mktemp("tls")
    subprocess.run(["bash", str(ROOT / "scripts" / "make_tls_certs.sh"), str(d / "certs")], check=True,
                   capture_output=True, timeout=120)
    shutil.copy(ROOT / "deploy" / "tls" / "users.txt", d / "users.txt")
    port = free_port()

    def make(example: str, name: str, password: str | None = None, drop_client_cert: bool = False) -> Path:
        text = (ROOT / "deploy" / "tls" / example).read_text()
        text = text.replace("/etc/acnmp/tls", str(d / "certs")).replace("/etc/acnmp/users.txt", str(d / "users.txt"))
        text = text.replace("tls/0.0.0.0:7447", f"tls/127.0.0.1:{port}")
        text = text.replace("tls/router-host:7447", f"tls/localhost:{port}")
        if password is not None:
            text = text.replace('password: "change-me-too"', f'password: "{password}"')
        if drop_client_cert:
            text = re.sub(r"\n\s*connect_(certificate|private_key): [^\n]*", "", text)
        path = d / name
        path.write_text(text)
        return path

    return make


def _received_by_router(router_cfg: Path, client_cfg: Path) -> list[bytes]:
    got: list[bytes] = []
    with open_session(None, config_file=router_cfg) as router:
        router.declare_subscriber("acnmp/tls-test/**", lambda s: got.append(s.payload.to_bytes()))
        with open_session(None, config_file=client_cfg, open_timeout=3) as client:
            deadline = time.monotonic() + 5
            while not got and time.monotonic() < deadline:
                client.put("acnmp/tls-test/x", b"hello")
                time.sleep(0.1)
    return got


def test_client_with_certificate_and_password_gets_through(tls):
    got = _received_by_router(tls("router.json5", "router.json5"), tls("client.json5", "client.json5"))
    assert got and got[0] == b"hello"


@pytest.mark.parametrize("edit", [{"password": "wrong"}, {"drop_client_cert": True}], ids=["bad-password", "no-cert"])
def test_client_without_credentials_is_refused(tls, edit):
    router = tls("router.json5", "router.json5")
    bad = tls("client.json5", "bad.json5", **edit)
    with pytest.raises(ConnectionError):
        _received_by_router(router, bad)
