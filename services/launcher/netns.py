"""Hosts on one machine: Linux network namespaces joined in a star, links that can be cut.

:class:`HostNetwork` rehearses a deployment over several machines on one Linux machine (as root):

* every host is a network namespace ``acnmp-<owner pid>-<run>-<host>``; the first host (the
  router's) holds a bridge ``br0`` with ``198.18.0.1/24``, and every other host is joined to it by
  a veth pair (``eth0`` on the host, ``h<i>`` on the bridge) with ``198.18.0.<10+i>/24``. The
  addresses are from 198.18.0.0/15, the range set aside for benchmarking networks (RFC 2544); no
  address is added outside the namespaces, and nothing is created in the machine's own namespace
  (each veth pair is created directly inside its two namespaces);
* ``/etc/netns/<namespace>/hosts`` maps the hub's name (``router``) to its address, so processes
  connect to ``tls/router:7447`` as in docker-compose.yml (``ip netns exec`` mounts that file on
  ``/etc/hosts``);
* :meth:`HostNetwork.cut` takes a host's link down on the bridge side (every packet to and from
  the host is lost, as when a cable is pulled), :meth:`HostNetwork.heal` brings it back;
* :meth:`HostNetwork.remove` deletes every namespace (and with it its links) and its
  ``/etc/netns`` directory; a network whose owner process is gone (a killed test) is removed by
  :func:`remove_leftovers`, which :meth:`HostNetwork.create` calls first.

:func:`unavailable_reason` says in one line why namespaces cannot be made here (not root, no
``ip``), or None.
"""
from __future__ import annotations

import itertools
import os
import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

from services.transport.runfile import pid_alive

#: Every namespace this module makes starts with it.
PREFIX = "acnmp-"
#: The subnet of the star, and the hub's address on it.
SUBNET, HUB_ADDRESS = "198.18.0.0/24", "198.18.0.1"
NETNS_ETC = Path("/etc/netns")
_OWNED = re.compile(rf"^{re.escape(PREFIX)}(\d+)-\d+-")
_runs = itertools.count()


class NetworkError(RuntimeError):
    """An ``ip`` command failed: its command line and stderr."""


def _ip(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    out = subprocess.run(["ip", *args], capture_output=True, text=True, timeout=30)
    if check and out.returncode != 0:
        raise NetworkError(f"ip {' '.join(args)}: {out.stderr.strip()}")
    return out


def unavailable_reason() -> str | None:
    """Why network namespaces cannot be made here (one line), or None when they can: this
    needs Linux, root and the ``ip`` command of iproute2, and a namespace that can be made."""
    if not Path("/proc/self/ns/net").exists():
        return "network namespaces need Linux"
    if os.geteuid() != 0:
        return "network namespaces need root (ip netns)"
    if shutil.which("ip") is None:
        return "the ip command (iproute2) is not installed"
    probe = f"{PREFIX}{os.getpid()}-probe-{next(_runs)}"
    made = _ip("netns", "add", probe, check=False)
    if made.returncode != 0:
        return f"ip netns add failed: {made.stderr.strip()}"
    _ip("netns", "delete", probe, check=False)
    return None


def namespaces() -> list[str]:
    """The names of the network namespaces that exist now (``ip netns list``)."""
    return [line.split()[0] for line in _ip("netns", "list").stdout.splitlines() if line.strip()]


def remove_leftovers() -> list[str]:
    """Delete the namespaces (and ``/etc/netns`` directories) of networks whose owner process is
    no longer running (e.g. a test killed before its clean-up); returns their names."""
    gone = []
    candidates = set(namespaces()) | ({p.name for p in NETNS_ETC.iterdir()} if NETNS_ETC.is_dir() else set())
    for name in sorted(candidates):
        owner = _OWNED.match(name)
        if owner and not pid_alive(int(owner.group(1))):
            _ip("netns", "delete", name, check=False)
            shutil.rmtree(NETNS_ETC / name, ignore_errors=True)
            gone.append(name)
    return gone


@dataclass(frozen=True)
class Host:
    """One host of the network: its short ``name``, its namespace, its address, and the name of its
    link on the hub's bridge (None for the hub)."""

    name: str
    namespace: str
    address: str
    hub_link: str | None

    def exec_argv(self, argv: Sequence[str]) -> list[str]:
        """``argv`` run inside this host's namespace (``ip netns exec``)."""
        return ["ip", "netns", "exec", self.namespace, *argv]


class HostNetwork:
    """A star of hosts around the hub ``hosts[0]`` (see the module docstring):
    ``with HostNetwork(["router", "model", "worker-0"]) as net: net.hosts["model"].exec_argv(...)``.

    ``hub_name``: the name the other hosts resolve to the hub's address (``router``)."""

    def __init__(self, names: Sequence[str], *, hub_name: str = "router") -> None:
        if len(set(names)) != len(names) or not names:
            raise ValueError(f"hosts: expected distinct names, got {list(names)}")
        if len(names) > 200:
            raise ValueError("hosts: at most 200 on one /24")
        self.prefix = f"{PREFIX}{os.getpid()}-{next(_runs)}-"
        self.hub_name = hub_name
        self.hosts: dict[str, Host] = {}
        for i, name in enumerate(names):
            if not re.fullmatch(r"[a-z0-9][a-z0-9-]*", name):
                raise ValueError(f"host name {name!r}: lower-case letters, digits and '-'")
            address = HUB_ADDRESS if i == 0 else f"198.18.0.{10 + i}"
            self.hosts[name] = Host(name, self.prefix + name, address, None if i == 0 else f"h{i}")
        self.hub = self.hosts[names[0]]
        self.created = False

    def create(self) -> "HostNetwork":
        """Remove leftovers of dead runs, then make the namespaces, the bridge, the links and the
        hosts files; on failure remove what was made and raise :class:`NetworkError`."""
        remove_leftovers()
        try:
            self.created = True
            for host in self.hosts.values():
                _ip("netns", "add", host.namespace)
                _ip("-n", host.namespace, "link", "set", "lo", "up")
            hub = self.hub.namespace
            _ip("-n", hub, "link", "add", "br0", "type", "bridge")
            _ip("-n", hub, "addr", "add", f"{HUB_ADDRESS}/24", "dev", "br0")
            _ip("-n", hub, "link", "set", "br0", "up")
            for host in self.hosts.values():
                if host.hub_link is None:
                    continue
                _ip("link", "add", "eth0", "netns", host.namespace, "type", "veth",
                    "peer", "name", host.hub_link, "netns", hub)
                _ip("-n", hub, "link", "set", host.hub_link, "master", "br0")
                _ip("-n", hub, "link", "set", host.hub_link, "up")
                _ip("-n", host.namespace, "addr", "add", f"{host.address}/24", "dev", "eth0")
                _ip("-n", host.namespace, "link", "set", "eth0", "up")
            for host in self.hosts.values():
                etc = NETNS_ETC / host.namespace
                etc.mkdir(parents=True, exist_ok=True)
                (etc / "hosts").write_text(f"127.0.0.1 localhost\n{HUB_ADDRESS} {self.hub_name}\n")
        except BaseException:
            self.remove()
            raise
        return self

    def cut(self, name: str) -> None:
        """Take host ``name``'s link down at the hub: nothing reaches it or leaves it."""
        _ip("-n", self.hub.namespace, "link", "set", self._link(name), "down")

    def heal(self, name: str) -> None:
        """Bring host ``name``'s link back up."""
        _ip("-n", self.hub.namespace, "link", "set", self._link(name), "up")

    def _link(self, name: str) -> str:
        link = self.hosts[name].hub_link
        if link is None:
            raise ValueError(f"{name} is the hub: its processes would lose every host at once; cut the others")
        return link

    def remove(self) -> None:
        """Delete every namespace of this network and its ``/etc/netns`` directory (safe to call twice)."""
        if not self.created:
            return
        existing = set(namespaces())
        for host in self.hosts.values():
            if host.namespace in existing:
                _ip("netns", "delete", host.namespace, check=False)
            shutil.rmtree(NETNS_ETC / host.namespace, ignore_errors=True)
        self.created = False

    def __enter__(self) -> "HostNetwork":
        return self.create()

    def __exit__(self, *exc) -> None:
        self.remove()
