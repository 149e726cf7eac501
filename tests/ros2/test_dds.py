"""wbc.ros2.dds: the participant's interface configuration (checked with ``ss -uanp``), and a real ROS 2 client,
rclpy (Kilted, Fast DDS 3.2.3 on its defaults) from tests/ros2/kilted.py, confined to 127.0.0.1 by its XML profile."""

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import dds_domain_id

from .conftest import descendants

for _mod in ("cyclonedds", "rosbags"):
    pytest.importorskip(_mod, reason=f"the optional extra wbc[ros2] is not installed ({_mod} missing)")

REPO = Path(__file__).resolve().parents[2]

SOCKETS = """
import os, time, rclpy
from rclpy.node import Node
rclpy.init()
node = Node("wbc_probe")
t0 = time.monotonic()
while time.monotonic() - t0 < 1.0:
    rclpy.spin_once(node, timeout_sec=0.1)
print("NODES", sorted(n for n, _ in node.get_node_names_and_namespaces()))
pid = os.getpid()
links = []
for fd in os.listdir(f"/proc/{pid}/fd"):
    try:
        links.append(os.readlink(f"/proc/{pid}/fd/{fd}"))
    except OSError:  # the descriptor of the listing itself
        pass
inodes = {link[8:-1] for link in links if link.startswith("socket:[")}
for name in ("udp", "udp6", "tcp", "tcp6"):
    for row in open(f"/proc/{pid}/net/{name}").read().splitlines()[1:]:
        cols = row.split()
        if cols[9] in inodes:
            print("SOCKET", name, cols[1])
node.destroy_node()
rclpy.shutdown()
"""


def test_the_fastdds_client_binds_loopback_only(kilted):
    out = kilted.run_client(SOCKETS, timeout=60)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert "NODES ['wbc_probe']" in lines
    sockets = [line.split()[1:] for line in lines if line.startswith("SOCKET")]
    assert sockets, out.stdout
    # /proc/net/udp: local address as hex little-endian IPv4 ':' hex port; 127.0.0.1 is 0100007F
    assert all(kind == "udp" and addr.split(":")[0] == "0100007F" for kind, addr in sockets), sockets


def _ss_sockets(pid: int) -> list[str]:
    """Local addresses of the UDP sockets of process ``pid`` as ``ss -uanp`` prints them (iproute2)."""
    out = subprocess.run(["ss", "-uanp"], capture_output=True, text=True, check=True).stdout
    return [line.split()[3] for line in out.splitlines()[1:] if f"pid={pid}," in line]


PARTICIPANT = """
import os, sys
from wbc.ros2 import dds
dds.use_interface(sys.argv[1])
os.environ.pop("CYCLONEDDS_URI", None)  # removed after the choice (an earlier test, a user's script)
try:
    part = dds.participant()
except Exception as exc:
    print("ERROR", type(exc).__name__, exc, flush=True)
else:
    print("URI", os.environ.get("CYCLONEDDS_URI") == dds.loopback_uri(), flush=True)
sys.stdin.readline()  # the parent takes its ss snapshot now
"""


def _participant_after_uri_removed(interface: str):
    env = {k: v for k, v in os.environ.items() if k != "CYCLONEDDS_URI"}
    env["ROS_DOMAIN_ID"] = str(dds_domain_id())
    proc = subprocess.Popen([sys.executable, "-c", PARTICIPANT, interface], env=env, stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=str(REPO))
    first = proc.stdout.readline().strip()
    sockets = _ss_sockets(proc.pid)
    try:
        _, err = proc.communicate("\n", timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
    return first, sockets, err


def test_participant_refuses_a_chosen_interface_whose_configuration_was_removed():
    """use_interface('eth0') then CYCLONEDDS_URI removed: participant() raises ConfigurationError naming the
    interface and the valid choices instead of creating a participant on Cyclone's all-interface default; no UDP
    socket is opened (ss -uanp)."""
    first, sockets, err = _participant_after_uri_removed("eth0")
    assert first.startswith("ERROR ConfigurationError DDS interface 'eth0' was chosen but CYCLONEDDS_URI is unset"), (
        first, err)
    assert "'lo'" in first and "'any'" in first, first
    assert sockets == [], sockets


def test_participant_falls_back_to_loopback_when_the_loopback_configuration_was_removed():
    """use_interface('lo') then CYCLONEDDS_URI removed: participant() sets the loopback configuration again; every
    UDP socket of the process, as ss -uanp shows it, is on 127.0.0.1 or bound to the lo device (0.0.0.0%lo)."""
    first, sockets, err = _participant_after_uri_removed("lo")
    assert first == "URI True", (first, err)
    assert sockets and all(a.startswith(("127.0.0.1:", "0.0.0.0%lo:")) for a in sockets), sockets


def test_the_loopback_guard_flags_a_wildcard_socket(loopback_guard):
    """The session's ss -uanp check (tests/ros2/conftest.py) flags a UDP socket bound to 0.0.0.0 without the lo
    device (a child process binding one; its rows are then taken out of the guard's findings so that this test's
    own guard does not fail it)."""
    from .conftest import udp_sockets_off_loopback

    script = ("import socket, time; s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM); s.bind(('0.0.0.0', 0)); "
              "print(s.getsockname()[1], flush=True); time.sleep(30)")
    child = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    try:
        port = child.stdout.readline().strip()
        bad, n = udp_sockets_off_loopback({child.pid})
    finally:
        child.kill()
        child.wait()
        loopback_guard.sample()
        loopback_guard.bad[:] = [row for row in loopback_guard.bad if f"pid={child.pid}," not in row]
    assert n == 1 and len(bad) == 1 and f" 0.0.0.0:{port} " in f" {bad[0]} ", (port, n, bad)


STRACE_CLIENT = """
import sys, time, rclpy
from rclpy.node import Node
from sensor_msgs.msg import JointState
rclpy.init()
node = Node("wbc_strace_client")
n = [0]
node.create_subscription(JointState, "joint_states", lambda m: n.__setitem__(0, n[0] + 1), 100)
t0 = time.monotonic()
while time.monotonic() - t0 < 90 and n[0] < 100:
    rclpy.spin_once(node, timeout_sec=0.05)
print("SAMPLES", n[0], flush=True)
node.destroy_node()
rclpy.shutdown()
"""
_CALL = re.compile(r"^(\d+) +(sendto|sendmsg|sendmmsg|connect|setsockopt)\((\d+), (.*)$")
_DEST = re.compile(r'sin_addr=inet_addr\("([0-9.]+)"\)|inet_pton\(AF_INET6, "([0-9a-fA-F:.]+)"')
LOOPBACK_MULTICAST_IF = "[16777343]"  # IP_MULTICAST_IF 127.0.0.1 (0x0100007F) as strace prints it


def send_destinations(trace: str) -> dict[str, int]:
    """{destination: count} of the IP sends and connects in an ``strace -f`` output. A send to a multicast group
    counts as ``"<group> on lo, TTL 0"`` when its socket was set to IP_MULTICAST_IF 127.0.0.1 and
    IP_MULTICAST_TTL 0 (Cyclone's multicast loopback probe at start-up), else as the bare group."""
    mcast_if, ttl0, found = set(), set(), {}
    for line in trace.splitlines():
        m = _CALL.match(line)
        if not m:
            continue
        pid, call, fd, rest = m.groups()
        key = (pid, fd)
        if call == "setsockopt":
            if "IP_MULTICAST_IF" in rest and LOOPBACK_MULTICAST_IF in rest:
                mcast_if.add(key)
            if "IP_MULTICAST_TTL" in rest and '"\\0"' in rest:
                ttl0.add(key)
            continue
        for v4, v6 in _DEST.findall(rest):
            addr = v4 or v6
            if v4 and 224 <= int(v4.split(".")[0]) <= 239 and key in mcast_if and key in ttl0:
                addr = f"{v4} on lo, TTL 0"
            found[addr] = found.get(addr, 0) + 1
    return found


_BIND = re.compile(r"^(\d+) +bind\((\d+), \{sa_family=(AF_INET6?), (.*)$")


def bind_addresses(trace: str) -> dict[str, int]:
    """{local address: count} of the IPv4/IPv6 ``bind`` calls in an ``strace -f`` output (a wildcard as 0.0.0.0 or
    ::)."""
    found = {}
    for line in trace.splitlines():
        m = _BIND.match(line)
        if m:
            for v4, v6 in _DEST.findall(m.group(4)):
                found[v4 or v6] = found.get(v4 or v6, 0) + 1
    return found


def test_no_dds_packet_leaves_lo(kilted, loopback_guard):
    """`wbc ros2 node` (DDS backend) and a Kilted rclpy client (Fast DDS on its defaults with the loopback profile)
    exchange 100 /joint_states under ``strace -f`` (bind, sendto, sendmsg, connect): every address either binds a
    socket to is 127.0.0.1 (Cyclone's receive sockets included, which Cyclone asks for on 0.0.0.0:
    wbc.ros2.loopback_bind), and every destination address of every send of both, the re-executed Python of the
    wheels' bootstrapper included, is 127.0.0.1 — but for Cyclone's start-up multicast loopback probe (16 bytes to
    239.255.0.1 on a socket set to IP_MULTICAST_IF 127.0.0.1 and TTL 0: it cannot leave the host); the session's
    ss guard has sampled the processes meanwhile."""
    trace = kilted.workdir / "strace"
    trace.mkdir(parents=True, exist_ok=True)
    strace = ["strace", "-f", "-qq", "-e", "trace=bind,sendto,sendmsg,sendmmsg,connect,setsockopt", "-o"]
    node = subprocess.Popen([*strace, str(trace / "node"), sys.executable, "-m", "wbc", "ros2", "node", "--backend",
                             "dds", "--duration", "600"], env=kilted.wbc_env(), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=str(REPO))
    try:
        client = subprocess.run([*strace, str(trace / "client"), str(kilted.client.build()), "-c", STRACE_CLIENT],
                                env=kilted.env, capture_output=True, text=True, timeout=180)
    finally:
        for pid in descendants(node.pid) - {node.pid}:  # the traced node (SIGTERM to strace would only detach it)
            os.kill(pid, signal.SIGTERM)
        try:
            node.communicate(timeout=120)
        except subprocess.TimeoutExpired:
            node.kill()
            node.communicate()
    assert "SAMPLES 100" in client.stdout, (client.stdout, client.stderr[-2000:])
    dests = {who: send_destinations((trace / who).read_text(errors="replace")) for who in ("node", "client")}
    print("send/connect destinations:", dests, f"ss snapshots {loopback_guard.snapshots}, sockets seen "
          f"{loopback_guard.sockets_seen}")
    binds = {who: bind_addresses((trace / who).read_text(errors="replace")) for who in ("node", "client")}
    print("bind addresses:", binds)
    assert binds["node"] and binds["client"] and set(binds["node"]) | set(binds["client"]) == {"127.0.0.1"}, binds
    assert sum(dests["node"].values()) > 100 and sum(dests["client"].values()) > 10, dests
    allowed = {"127.0.0.1", "239.255.0.1 on lo, TTL 0"}  # the second: Cyclone's probe, leaves no host
    assert set(dests["node"]) | set(dests["client"]) <= allowed and "127.0.0.1" in dests["client"], dests
    assert loopback_guard.snapshots > 0 and loopback_guard.bad == [], (loopback_guard.snapshots, loopback_guard.bad)
