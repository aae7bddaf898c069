"""The network namespaces of the multi-host harness (services/launcher/netns.py): made inside
198.18.0.0/15 only, a cut link carries nothing until healed, and a network whose owner was killed
(-9, no clean-up) is removed by the next one's start."""
from __future__ import annotations

import signal
import subprocess
import sys

import pytest

from services.launcher import netns

WHY_NOT = netns.unavailable_reason()
pytestmark = pytest.mark.skipif(WHY_NOT is not None, reason=f"no network namespaces here: {WHY_NOT}")

OWNER = """
import sys, time
from services.launcher.netns import HostNetwork
net = HostNetwork(["hub", "a"]).create()
print(net.prefix, flush=True)
time.sleep(600)
"""


def reachable(net: netns.HostNetwork, src: str, dst: str) -> bool:
    """A TCP connect from ``src`` to port 9 of ``dst`` is answered (refused counts: the host is there)."""
    probe = ("import socket,sys\ntry:\n    socket.create_connection((sys.argv[1], 9), timeout=1)\nexcept ConnectionRefusedError:\n"
             "    sys.exit(0)\nexcept OSError:\n    sys.exit(1)\n")
    out = subprocess.run(net.hosts[src].exec_argv([sys.executable, "-c", probe, net.hosts[dst].address]), timeout=30)
    return out.returncode == 0


def test_hosts_reach_the_hub_by_name_only_inside_the_benchmark_range_and_a_cut_link_carries_nothing():
    with netns.HostNetwork(["hub", "a", "b"], hub_name="router") as net:
        assert all(h.address.startswith("198.18.") for h in net.hosts.values())
        assert reachable(net, "a", "hub") and reachable(net, "b", "a")
        hosts = subprocess.run(net.hosts["a"].exec_argv(["getent", "hosts", "router"]), capture_output=True, text=True)
        assert hosts.stdout.split()[0] == netns.HUB_ADDRESS
        net.cut("a")
        assert not reachable(net, "a", "hub") and reachable(net, "b", "hub")
        net.heal("a")
        assert reachable(net, "a", "hub")
        with pytest.raises(ValueError, match="is the hub"):
            net.cut("hub")
        made = [h.namespace for h in net.hosts.values()]
        assert set(made) <= set(netns.namespaces())
    assert not set(made) & set(netns.namespaces())
    assert not any((netns.NETNS_ETC / n).exists() for n in made)


def test_a_network_left_by_a_killed_owner_is_removed_by_the_next_start():
    owner = subprocess.Popen([sys.executable, "-c", OWNER], stdout=subprocess.PIPE, text=True)
    prefix = owner.stdout.readline().strip()
    assert any(n.startswith(prefix) for n in netns.namespaces())
    owner.send_signal(signal.SIGKILL)
    owner.wait(timeout=10)
    with netns.HostNetwork(["hub", "a"]) as net:  # create() removes what dead owners left
        assert not any(n.startswith(prefix) for n in netns.namespaces())
        assert any(n.startswith(net.prefix) for n in netns.namespaces())
    assert not any((netns.NETNS_ETC / n).exists() for n in (f"{prefix}hub", f"{prefix}a"))
