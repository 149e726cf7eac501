"""wbc.ros2.dds: the participant's interface configuration (checked with ``ss -uanp``), and a real ROS 2 client,
rclpy (Kilted, Fast DDS 3.2.3 on its defaults) from tests/ros2/kilted.py, confined to 127.0.0.1 by its XML profile."""

import os
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import dds_domain_id

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
    try:
        first = proc.stdout.readline().strip()
        sockets = _ss_sockets(proc.pid)
        proc.stdin.write("\n")
        proc.stdin.flush()
        proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    return first, sockets, proc.stderr.read()


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
