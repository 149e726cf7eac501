"""wbc.ros2.endpoints: readers and writers announced without XTypes type information, so that ROS 2 Kilted's
default RMW (rmw_fastrtps_cpp, Fast DDS 3.2.3 on its defaults) exchanges samples with them.

The client is real rclpy 9.1.2 from the package index (tests/ros2/kilted.py), Fast DDS confined to 127.0.0.1 by its
XML profile; wbc's side is Cyclone on ``lo``. Before the fix, JointState, Odometry and GoalStatusArray writers of
wbc matched no Kilted reader (0 samples) and a wbc JointState reader no Kilted writer."""

import time

import pytest
from conftest import dds_domain_id

for _mod in ("cyclonedds", "rosbags"):
    pytest.importorskip(_mod, reason=f"the optional extra wbc[ros2] is not installed ({_mod} missing)")

from wbc.ros2 import dds, msgs  # noqa: E402
from wbc.ros2.endpoints import reader, writer  # noqa: E402

SAMPLES = 20  # samples each rclpy subscription must receive

# rclpy: subscribe to every topic in argv[1] (name:pkg.msg.Type:latched) until each has SAMPLES samples (or 60 s)
SUBSCRIBER = """
import importlib, sys, time, rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile, DurabilityPolicy, ReliabilityPolicy
rclpy.init()
node = Node("wbc_test_subscriber")
want = int(sys.argv[2])
counts, first = {}, {}
subs = []
for spec in sys.argv[1].split(","):
    name, typ, latched = spec.split(":")
    module, cls = typ.rsplit(".", 1)
    qos = (QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE)
           if latched == "1" else QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE))
    counts[name] = 0
    def cb(msg, name=name):
        counts[name] += 1
        first.setdefault(name, msg)
    subs.append(node.create_subscription(getattr(importlib.import_module(module), cls), name, cb, qos))
print("READY", flush=True)
t0 = time.monotonic()
while time.monotonic() - t0 < 60 and any(c < (1 if n.endswith("_latched") else want) for n, c in counts.items()):
    rclpy.spin_once(node, timeout_sec=0.05)
for name, c in counts.items():
    print("COUNT", name, c)
for name, m in first.items():
    print("FIRST", name, repr(m)[:300])
"""

# rclpy: publish JointState (left_knee 0.5, right_knee = k/1000 for sample k) every 20 ms for argv[1] s
JOINT_PUBLISHER = """
import sys, time, rclpy
from rclpy.node import Node
from sensor_msgs.msg import JointState
rclpy.init()
node = Node("wbc_test_joint_publisher")
pub = node.create_publisher(JointState, "joint_states", 10)
t0, k = time.monotonic(), 0
while time.monotonic() - t0 < float(sys.argv[1]):
    m = JointState()
    m.name = ["left_knee", "right_knee"]
    m.position = [0.5, k / 1000.0]
    pub.publish(m)
    k += 1
    time.sleep(0.02)
"""


def _counts(stdout: str) -> dict[str, int]:
    return {line.split()[1]: int(line.split()[2]) for line in stdout.splitlines() if line.startswith("COUNT")}


def test_endpoints_carry_no_type_information_and_the_topic_keeps_its_own():
    """Cyclone's own discovery data of the matched writer: no type identifier for an endpoints.writer, one for a
    plain writer created afterwards on a topic of the same type (the topic's type information was restored)."""
    from cyclonedds.pub import DataWriter
    from cyclonedds.sub import DataReader
    from cyclonedds.topic import Topic

    part = dds.participant(dds_domain_id())
    q = dds.qos_stream(10)
    w_bare = writer(part, "rt/wbc_test_bare", msgs.JointState, q)
    w_typed = DataWriter(part, Topic(part, "rt/wbc_test_typed", msgs.JointState, qos=q), qos=q)
    w_again = writer(part, "rt/wbc_test_again", msgs.JointState, q)  # a second topic of the type (/tf, /tf_static)
    found = {}
    for topic in ("rt/wbc_test_bare", "rt/wbc_test_typed", "rt/wbc_test_again"):
        r = DataReader(part, Topic(part, topic, msgs.JointState, qos=q), qos=q)
        t0 = time.monotonic()
        while not r.get_matched_publications() and time.monotonic() - t0 < 10:
            time.sleep(0.01)
        (handle,) = r.get_matched_publications()
        found[topic] = r.get_matched_publication_data(handle)
    assert found["rt/wbc_test_bare"].type_id is None
    assert found["rt/wbc_test_again"].type_id is None
    assert found["rt/wbc_test_typed"].type_id is not None
    assert {str(d.key) for d in found.values()} == {str(w.guid) for w in (w_bare, w_typed, w_again)}
    for d in found.values():
        assert d.type_name == "sensor_msgs::msg::dds_::JointState_"


WIRE_TOPICS = {  # ROS name: (wbc type, sample, rclpy type, latched) — every message type wbc's DDS backend publishes
    "joint_states": (msgs.JointState, msgs.JointState(name=["left_knee", "right_knee"], position=[0.5, -0.25]),
                     "sensor_msgs.msg.JointState", False),
    "odom": (msgs.Odometry, msgs.Odometry(child_frame_id="base_link"), "nav_msgs.msg.Odometry", False),
    "clock": (msgs.Clock, msgs.Clock(), "rosgraph_msgs.msg.Clock", False),
    "robot_description_latched": (msgs.String, msgs.String(data="<robot name='r'/>"), "std_msgs.msg.String", True),
    "navigate_to_pose/_action/status": (msgs.GoalStatusArray, msgs.GoalStatusArray(status_list=[msgs.GoalStatus(
        status=4)]), "action_msgs.msg.GoalStatusArray", False),
}


def test_kilted_rclpy_receives_every_message_type_on_fastdds_defaults(kilted):
    """wbc writers → rclpy subscriptions on Kilted's Fast DDS (no type_propagation setting): every type arrives,
    with its content. (TFMessage and NavigateToPose's feedback message have no rclpy type here: tf2_msgs and
    nav2_msgs have no wheels; they go through the same endpoints.writer.)"""
    spec = ",".join(f"{name}:{typ}:{int(latched)}" for name, (_, _, typ, latched) in WIRE_TOPICS.items())
    client = kilted.start_client(SUBSCRIBER, args=[spec, SAMPLES])
    part = dds.participant(kilted.domain_id)
    writers = {name: writer(part, dds.ros_topic("/" + name), typ,
                            dds.qos_latched() if latched else dds.qos_stream(100))
               for name, (typ, _, _, latched) in WIRE_TOPICS.items()}
    streams = [name for name, spec in WIRE_TOPICS.items() if not spec[3]]
    writers["robot_description_latched"].write(WIRE_TOPICS["robot_description_latched"][1])  # once, as wbc does
    t0 = time.monotonic()
    while client.poll() is None and time.monotonic() - t0 < 90:
        for name in streams:
            writers[name].write(WIRE_TOPICS[name][1])
        time.sleep(0.02)
    out, err = client.communicate(timeout=30)
    counts = _counts(out)
    assert counts["robot_description_latched"] == 1, (counts, err)
    assert all(counts[name] >= SAMPLES for name in streams), (counts, err)
    assert "name=['left_knee', 'right_knee'], position=[0.5, -0.25]" in out
    assert "child_frame_id='base_link'" in out
    assert "data=\"<robot name='r'/>\"" in out
    assert "status=4" in out


def test_kilted_rclpy_joint_states_reach_a_wbc_reader(kilted):
    """rclpy JointState writer (Fast DDS defaults) → endpoints.reader: samples arrive with their content."""
    client = kilted.start_client(JOINT_PUBLISHER, args=[60])
    part = dds.participant(kilted.domain_id)
    r = reader(part, dds.ros_topic("/joint_states"), msgs.JointState, dds.qos_stream(100))
    got = []
    t0 = time.monotonic()
    while len(got) < SAMPLES and time.monotonic() - t0 < 60 and client.poll() is None:
        got += [s for s in r.take(N=100) if isinstance(s, msgs.JointState)]
        time.sleep(0.01)
    assert len(got) >= SAMPLES, client.stderr.read() if client.poll() is not None else "client still running"
    assert all(s.name == ["left_knee", "right_knee"] and s.position[0] == 0.5 for s in got)
    steps = {round(b.position[1] * 1000) - round(a.position[1] * 1000) for a, b in zip(got, got[1:])}
    assert steps == {1}, steps  # consecutive samples, none lost (reliable, depth 100)


def test_the_services_notice_is_one_line_naming_what_answers_whom():
    from wbc.ros2.endpoints import services_notice

    line = services_notice("my_node")
    assert "\n" not in line
    for part in ("/reset_robot", "/my_node/", "rmw_cyclonedds_cpp", "--backend rclpy", "ros-kilted-rclpy"):
        assert part in line, part
