"""wbc.ros2.discovery: a Cyclone participant in ROS 2's graph through ros_discovery_info, checked by real rclpy
(Kilted, Fast DDS 3.2.3 on its defaults; tests/ros2/kilted.py)."""

import pytest
from conftest import dds_domain_id

for _mod in ("cyclonedds", "rosbags"):
    pytest.importorskip(_mod, reason=f"the optional extra wbc[ros2] is not installed ({_mod} missing)")

from wbc.exceptions import InvalidInputError  # noqa: E402
from wbc.ros2 import dds, msgs  # noqa: E402
from wbc.ros2.discovery import GraphAnnouncement  # noqa: E402
from wbc.ros2.endpoints import reader, writer  # noqa: E402

# rclpy: wait (≤ 60 s) until node argv[1] is in the graph with a publisher and a subscription, then print the graph
GRAPH = """
import sys, time, rclpy
from rclpy.node import Node
rclpy.init()
node = Node("wbc_test_graph")
target = sys.argv[1]
t0 = time.monotonic()
pubs = subs = []
while time.monotonic() - t0 < 60:
    rclpy.spin_once(node, timeout_sec=0.05)
    if (target, "/") in node.get_node_names_and_namespaces():
        pubs = node.get_publisher_names_and_types_by_node(target, "/")
        subs = node.get_subscriber_names_and_types_by_node(target, "/")
        if pubs and subs:
            break
print("NODES", sorted(node.get_node_names_and_namespaces()))
print("PUBS", sorted(pubs))
print("SUBS", sorted(subs))
"""


def test_kilted_rclpy_lists_the_node_with_its_endpoints(kilted):
    part = dds.participant(kilted.domain_id)
    endpoints = [writer(part, "rt/joint_states", msgs.JointState, dds.qos_stream(10)),  # kept: a collected
                 reader(part, "rt/cmd_vel", msgs.Twist, dds.qos_stream(10))]                 # entity is deleted
    graph = GraphAnnouncement(part, "wbc_graph_test")
    out = kilted.run_client(GRAPH, timeout=90, args=["wbc_graph_test"])
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert "NODES [('wbc_graph_test', '/'), ('wbc_test_graph', '/')]" in lines
    assert "PUBS [('/joint_states', ['sensor_msgs/msg/JointState'])]" in lines
    assert "SUBS [('/cmd_vel', ['geometry_msgs/msg/Twist'])]" in lines
    assert len(graph.message().node_entities_info_seq[0].writer_gid_seq) == len(endpoints) - 1


def test_the_message_names_the_participant_and_every_endpoint_by_guid():
    part = dds.participant(dds_domain_id())
    w = writer(part, "rt/wbc_test_w", msgs.JointState, dds.qos_stream(10))
    r = reader(part, "rt/wbc_test_r", msgs.Twist, dds.qos_stream(10))
    graph = GraphAnnouncement(part, "wbc_guid_test", "/robot1")
    m = graph.message()
    assert bytes(m.gid.data) == part.guid.bytes
    (node,) = m.node_entities_info_seq
    assert (node.node_namespace, node.node_name) == ("/robot1", "wbc_guid_test")
    assert [bytes(g.data) for g in node.writer_gid_seq] == [w.guid.bytes]  # the announcement's own writer left out
    assert [bytes(g.data) for g in node.reader_gid_seq] == [r.guid.bytes]
    late = writer(part, "rt/wbc_test_late", msgs.String, dds.qos_latched())
    later = graph.message().node_entities_info_seq[0].writer_gid_seq  # Cyclone's child order, not creation order
    assert sorted(bytes(g.data) for g in later) == sorted([w.guid.bytes, late.guid.bytes])


@pytest.mark.parametrize("name, namespace", [("", "/"), ("1node", "/"), ("my-node", "/"), ("wbc", "robot1"),
                                             (None, "/")])
def test_invalid_names_raise_typed_errors(name, namespace):
    part = dds.participant(dds_domain_id())
    with pytest.raises(InvalidInputError, match="invalid: valid"):
        GraphAnnouncement(part, name, namespace)
