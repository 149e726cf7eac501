"""wbc.ros2.dds against a real ROS 2 client: rclpy (Kilted, Fast DDS 3.2.3 on its defaults) from
tests/ros2/kilted.py, Fast DDS confined to 127.0.0.1 by its XML profile."""

import pytest

for _mod in ("cyclonedds", "rosbags"):
    pytest.importorskip(_mod, reason=f"the optional extra wbc[ros2] is not installed ({_mod} missing)")

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
