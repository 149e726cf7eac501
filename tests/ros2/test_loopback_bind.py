"""wbc.ros2.loopback_bind: Cyclone's receive sockets are bound to 127.0.0.1 from their creation, read back from the
kernel's socket tables (/proc/<pid>/net/udp) and from ``ss``; a bind error reaches Cyclone as it was. Each case runs
in a fresh process, whose first participant creates its DDS domain (and sockets)."""

import os
import subprocess
import sys
import time

import pytest
from conftest import dds_domain_id

pytest.importorskip("cyclonedds", reason="the optional extra wbc[ros2] is not installed (cyclonedds missing)")
pytest.importorskip("elftools", reason="pyelftools (a dependency of wbc[ros2]) is not installed")

# the process's IPv4/IPv6 UDP sockets (local address as /proc/net/udp prints it: hex little-endian IPv4 ':' hex port)
OWN_SOCKETS = """
import os
def own_sockets():
    inodes = set()
    for fd in os.listdir("/proc/self/fd"):
        try:
            link = os.readlink(f"/proc/self/fd/{fd}")
        except OSError:
            continue
        if link.startswith("socket:["):
            inodes.add(link[8:-1])
    rows = []
    for name in ("udp", "udp6"):
        for row in open(f"/proc/self/net/{name}").read().splitlines()[1:]:
            cols = row.split()
            if cols[9] in inodes:
                rows.append((name, cols[1].split(":")[0], int(cols[1].split(":")[1], 16)))
    return sorted(rows, key=lambda r: r[2])
"""


def _python(code: str, domain: int) -> subprocess.CompletedProcess:
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
    env.pop("CYCLONEDDS_URI", None)
    return subprocess.run([sys.executable, "-c", OWN_SOCKETS + code], capture_output=True, text=True, timeout=120,
                          env=env)


def test_participant_receive_sockets_are_bound_to_127_0_0_1():
    domain = dds_domain_id()
    out = _python("from wbc.ros2 import dds, loopback_bind\n"
                  "p = dds.participant()\n"
                  "print('INSTALLED', loopback_bind.installed())\n"
                  "print('SOCKETS', own_sockets())\n", domain)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "INSTALLED True" in out.stdout, out.stdout
    sockets = eval(out.stdout.split("SOCKETS ", 1)[1])
    # RTPS (DDSI-RTPS 2.5, 9.6.1.1): discovery unicast 7400 + 250 d + 10 + 2 i, user unicast + 1 (index i = 0)
    ports = {port for _, _, port in sockets}
    assert {7410 + 250 * domain, 7411 + 250 * domain} <= ports, sockets
    assert all(kind == "udp" and addr == "0100007F" for kind, addr, _ in sockets), sockets  # 127.0.0.1, none 0.0.0.0
    assert "could not be redirected" not in out.stderr


def test_a_port_in_use_moves_cyclone_to_the_next_participant_index():
    """The index-0 ports held by another socket: Cyclone's bind() fails with EADDRINUSE through the redirection, and
    Cyclone takes participant index 1 (ports + 2), as it does without it."""
    domain = dds_domain_id()
    out = _python("import socket\n"
                  f"base = 7410 + 250 * {domain}\n"
                  "held = []\n"
                  "for port in (base, base + 1):\n"
                  "    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)\n"
                  "    s.bind(('127.0.0.1', port))\n"
                  "    held.append(s)\n"
                  "from wbc.ros2 import dds\n"
                  "p = dds.participant()\n"
                  "print('SOCKETS', [r for r in own_sockets() if r[2] not in (base, base + 1)])\n", domain)
    assert out.returncode == 0, out.stderr[-2000:]
    sockets = eval(out.stdout.split("SOCKETS ", 1)[1])
    ports = {port for _, _, port in sockets}
    assert {7412 + 250 * domain, 7413 + 250 * domain} <= ports, sockets
    assert all(addr == "0100007F" for _, addr, _ in sockets), sockets


def test_the_node_never_has_a_wildcard_socket_while_it_starts(loopback_guard):
    """`wbc ros2 node --backend dds` sampled with ``ss -uanp`` every few milliseconds from its start until its DDS
    sockets have been up for a second: every UDP socket it ever shows is bound to 127.0.0.1."""
    domain = dds_domain_id()
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
    env.pop("CYCLONEDDS_URI", None)
    node = subprocess.Popen([sys.executable, "-m", "wbc", "ros2", "node", "--backend", "dds", "--robot", "humanoid15",
                             "--duration", "30"], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True)
    seen, up_since, t0 = set(), None, time.monotonic()
    try:
        while time.monotonic() - t0 < 90 and node.poll() is None:
            rows = [row.split() for row in subprocess.run(["ss", "-uanp"], capture_output=True, text=True,
                                                           timeout=10).stdout.splitlines()[1:]
                    if f"pid={node.pid}," in row]
            seen |= {cols[3] for cols in rows if len(cols) > 4}
            if rows and up_since is None:
                up_since = time.monotonic()
            if up_since is not None and time.monotonic() - up_since > 1.0:
                break
    finally:
        node.terminate()
        _, err = node.communicate(timeout=60)
    assert up_since is not None, err[-2000:]
    assert seen and all(addr.startswith("127.0.0.1:") for addr in seen), seen
    assert f"{7410 + 250 * domain}" in " ".join(seen), seen
