"""Authenticated deployments with zenoh's own mechanisms: user/password authentication and ACL.

What is checked where (docs/SECURITY.md):

* every process of a secured deployment is a zenoh **client** of one **router** (the launcher's
  session, the anchor). The router has the deployment's dictionary (``users.txt``, one
  ``user:password`` per role, mode 0600) in ``transport/auth/usrpwd``, so a process without a
  password of the dictionary cannot open a link at all: no query, no put, no subscription.
* the router applies the **access control** of :mod:`.acl` (default deny, an allow list per role)
  to what comes in on each link, by the username that link authenticated with.

Why a router and not the peer mesh: zenoh's user/password exchange authenticates the side that
*opens* a link to the side that *accepts* it, and only the acceptor learns the username. In a
gossip mesh either side may open a link, and the ACL of a process that opened the link sees no
username (verified on loopback with zenoh 1.10: a denied user's puts passed over such a link).
With every process a client of the router, the router accepts every link and knows every
username, so the ACL applies to all traffic.

The ACL's key expressions use ``acnmp/*/...``: they hold for every namespace, so the same rules
go into the launcher's router (:func:`router_config`) and into the router config of a compose or
multi-host deployment (:func:`write_router_deployment`, ``acnmp credentials``).
"""
from __future__ import annotations

import contextlib
import json
import os
import secrets
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence

import zenoh

from .acl import ROLES, acl_config
from .payload_limits import low_pass_filters
from .session import MAX_MESSAGE_BYTES, make_config



@dataclass(frozen=True)
class Credentials:
    """A zenoh user/password pair (``transport/auth/usrpwd``)."""

    user: str
    password: str


def generate_credentials(roles: Sequence[str] = ROLES) -> dict[str, Credentials]:
    """A fresh random password (32 url-safe bytes of :mod:`secrets`) per role: {role: Credentials}."""
    return {role: Credentials(role, secrets.token_urlsafe(32)) for role in roles}


def write_private(path: Path, text: str) -> Path:
    """Write ``text`` to ``path`` readable only by its owner (mode 0600, created so, never widened)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    with contextlib.suppress(FileNotFoundError):
        tmp.unlink()
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        f.write(text)
    os.replace(tmp, path)
    return path


def dictionary_text(creds: Mapping[str, Credentials]) -> str:
    """The router's dictionary file: one ``user:password`` line per role."""
    return "".join(f"{c.user}:{c.password}\n" for c in creds.values())


def client_config(anchor: str, cred: Credentials) -> dict:
    """A zenoh client config (JSON-able) that connects to ``anchor`` as ``cred``: loopback, no
    multicast scouting, user/password authentication."""
    return {"mode": "client", "connect": {"endpoints": [anchor]},
            "scouting": {"multicast": {"enabled": False}},
            "transport": {"auth": {"usrpwd": {"user": cred.user, "password": cred.password}},
                          "link": {"rx": {"max_message_size": MAX_MESSAGE_BYTES}}},
            "low_pass_filter": low_pass_filters()}


def router_settings(listen: Sequence[str], dictionary_file: str | Path, own: Credentials) -> dict:
    """A router's zenoh config (JSON-able): listening on ``listen``, no multicast scouting,
    user/password required from ``dictionary_file``, :func:`acl_config`."""
    return {"mode": "router", "listen": {"endpoints": list(listen)}, "scouting": {"multicast": {"enabled": False}},
            "transport": {"auth": {"usrpwd": {"user": own.user, "password": own.password,
                                              "dictionary_file": str(dictionary_file)}},
                          "link": {"rx": {"max_message_size": MAX_MESSAGE_BYTES}}},
            "low_pass_filter": low_pass_filters(), "access_control": acl_config()}


def router_config(listen: Sequence[str], dictionary_file: str | Path, own: Credentials) -> zenoh.Config:
    """:func:`router_settings` as a zenoh Config for the launcher's own session (the anchor)."""
    cfg = make_config("router", list(listen), [], multicast=False)
    settings = router_settings(listen, dictionary_file, own)
    cfg.insert_json5("transport/auth/usrpwd", json.dumps(settings["transport"]["auth"]["usrpwd"]))
    cfg.insert_json5("access_control", json.dumps(settings["access_control"]))
    return cfg


class DeploymentSecrets:
    """The secrets of one running deployment in a private directory (mode 0700):
    ``users.txt`` (the router's dictionary) and ``<role>.json5`` (a client config per role, to
    pass as ``--config``), all mode 0600. :meth:`remove` deletes them when the deployment stops."""

    def __init__(self, directory: str | os.PathLike) -> None:
        self.directory = Path(directory)
        self.credentials: dict[str, Credentials] = {}

    @property
    def dictionary(self) -> Path:
        """The router's dictionary file."""
        return self.directory / "users.txt"

    def config_path(self, role: str) -> Path:
        """The client config file of ``role``."""
        if role not in ROLES:
            raise ValueError(f"unknown role {role!r}; roles: {', '.join(ROLES)}")
        return self.directory / f"{role}.json5"

    def create(self, anchor: str) -> "DeploymentSecrets":
        """Generate a password per role and write the dictionary and each role's config for
        ``anchor``; returns self."""
        self.directory.mkdir(parents=True, exist_ok=True, mode=0o700)
        os.chmod(self.directory, 0o700)
        self.credentials = generate_credentials()
        write_private(self.dictionary, dictionary_text(self.credentials))
        for role, cred in self.credentials.items():
            write_private(self.config_path(role), json.dumps(client_config(anchor, cred), indent=2) + "\n")
        return self

    def router_config(self, listen: Sequence[str]) -> zenoh.Config:
        """The anchor's config (:func:`router_config`) with these secrets."""
        return router_config(listen, self.dictionary, self.credentials["launcher"])

    def remove(self) -> None:
        """Delete the directory and its files (the passwords die with the deployment)."""
        shutil.rmtree(self.directory, ignore_errors=True)


def forget_secrets_when_launcher_dies(config_file: str | os.PathLike | None) -> bool:
    """When ``config_file`` (this process's ``--config``) is a role's config in a deployment's
    secrets directory (:class:`DeploymentSecrets`: ``users.txt`` beside it), remove that directory
    once this process's launcher is found dead (services/transport/lifetime.py): a launcher killed
    with -9 removes nothing, and the passwords must not outlive the deployment. Only while the file
    is still the one this process read (same inode: a deployment started since has written its own).
    Returns whether it will (a process not launched so, or with no such file, leaves everything)."""
    from .lifetime import PARENT_PID_ENV, on_launcher_gone

    if config_file is None or not os.environ.get(PARENT_PID_ENV):
        return False
    path = Path(config_file)
    try:
        inode = path.stat().st_ino
    except OSError:
        return False
    if not (path.parent / "users.txt").is_file():
        return False

    def forget() -> None:
        try:
            if path.stat().st_ino != inode:
                return
        except OSError:
            return
        DeploymentSecrets(path.parent).remove()

    on_launcher_gone(forget)
    return True


def authenticated_user(config_file: str | os.PathLike | None) -> str | None:
    """The zenoh username a process's config file authenticates with (``transport/auth/usrpwd/user``),
    or None without a file or without user/password authentication."""
    if config_file is None:
        return None
    try:
        user = json.loads(zenoh.Config.from_file(str(config_file)).get_json("transport/auth/usrpwd/user"))
    except (zenoh.ZError, ValueError):
        return None
    return user or None


def tls_link(cert_dir: str, *, listen: bool) -> dict:
    """The ``transport/link/tls`` section for mutual TLS with the certificates of
    scripts/make_tls_certs.sh in ``cert_dir`` (as seen by the process): the router's
    certificate for the listening side, the shared client certificate for the others."""
    side = ("listen", "router") if listen else ("connect", "client")
    return {"root_ca_certificate": f"{cert_dir}/ca.pem", f"{side[0]}_certificate": f"{cert_dir}/{side[1]}.pem",
            f"{side[0]}_private_key": f"{cert_dir}/{side[1]}-key.pem", "enable_mtls": True}


def write_router_deployment(directory: str | os.PathLike, listen: str, connect: str, *,
                            tls_dir: str | None = None, at: str | None = None) -> dict[str, Path]:
    """Write the configs of a router deployment (compose, several hosts) into ``directory``:
    ``users.txt`` (fresh passwords), ``router.json5`` (listening on ``listen``, the dictionary,
    :func:`acl_config`) and ``<role>.json5`` per role (client mode, connecting to ``connect``),
    all mode 0600; with ``tls_dir`` (certificate directory as the processes see it) mutual TLS on
    every link. ``at`` is where the processes see ``directory`` (default: ``directory`` itself,
    e.g. ``/etc/acnmp`` in a container). Returns {name: path written}."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True, mode=0o700)
    seen = at or str(directory.resolve())
    creds = generate_credentials()
    written = {"users.txt": write_private(directory / "users.txt", dictionary_text(creds))}
    router = router_settings([listen], f"{seen}/users.txt", creds["launcher"])
    if tls_dir is not None:
        router["transport"]["link"]["tls"] = tls_link(tls_dir, listen=True)
    written["router.json5"] = write_private(directory / "router.json5", json.dumps(router, indent=2) + "\n")
    for role, cred in creds.items():
        cfg = client_config(connect, cred)
        if tls_dir is not None:
            cfg["transport"]["link"]["tls"] = tls_link(tls_dir, listen=False)
        written[f"{role}.json5"] = write_private(directory / f"{role}.json5", json.dumps(cfg, indent=2) + "\n")
    return written
