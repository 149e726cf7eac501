"""``wbc ros2 node`` (the DDS backend) seen by real rclpy on ROS 2 Kilted's default RMW (Fast DDS 3.2.3 on its
defaults, confined to 127.0.0.1; tests/ros2/kilted.py): the node is in the graph, and its topics arrive."""

import subprocess
import sys
from pathlib import Path

import pytest

for _mod in ("cyclonedds", "rosbags"):
    pytest.importorskip(_mod, reason=f"the optional extra wbc[ros2] is not installed ({_mod} missing)")

SAMPLES = 20
REPO = Path(__file__).resolve().parents[2]

# rclpy: wait (≤ 90 s) for /wbc_node, then publish /cmd_vel 0.2 m/s and count each topic until /joint_states and
# /odom have SAMPLES samples after the node was seen (≤ 60 s more)
CLIENT = """
import sys, time, rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile, DurabilityPolicy, ReliabilityPolicy
from sensor_msgs.msg import JointState
from nav_msgs.msg import Odometry
from std_msgs.msg import String
from geometry_msgs.msg import Twist
from action_msgs.msg import GoalStatusArray
rclpy.init()
node = Node("wbc_test_client")
want = int(sys.argv[1])
counts = {"joint_states": 0, "odom": 0, "robot_description": 0, "status": 0}
last = {}
def cb(name):
    def f(msg):
        counts[name] += 1
        last[name] = msg
    return f
latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE)
subs = [node.create_subscription(JointState, "joint_states", cb("joint_states"), 100),
        node.create_subscription(Odometry, "odom", cb("odom"), 100),
        node.create_subscription(String, "robot_description", cb("robot_description"), latched),
        node.create_subscription(GoalStatusArray, "navigate_to_pose/_action/status", cb("status"), latched)]
cmd = node.create_publisher(Twist, "cmd_vel", 10)
t0 = time.monotonic()
while time.monotonic() - t0 < 90 and ("wbc_node", "/") not in node.get_node_names_and_namespaces():
    rclpy.spin_once(node, timeout_sec=0.05)
print("NODES", sorted(node.get_node_names_and_namespaces()))
print("PUBS", sorted(t for t, _ in node.get_publisher_names_and_types_by_node("wbc_node", "/")))
t1 = time.monotonic()
twist = Twist()
twist.linear.x = 0.2
while time.monotonic() - t1 < 60 and min(counts["joint_states"], counts["odom"]) < want:
    cmd.publish(twist)
    rclpy.spin_once(node, timeout_sec=0.02)
print("COUNTS", counts)
if "joint_states" in last:
    print("JOINTS", len(last["joint_states"].name), len(last["joint_states"].position))
if "robot_description" in last:
    print("URDF", last["robot_description"].data.lstrip()[:5], len(last["robot_description"].data))
"""


def test_kilted_rclpy_sees_the_node_and_its_topics(kilted, robots):
    env = kilted.wbc_env()
    node = subprocess.Popen([sys.executable, "-m", "wbc", "ros2", "node", "--duration", "600"], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=str(REPO))
    try:
        out = kilted.run_client(CLIENT, timeout=300, args=[SAMPLES])
    finally:
        node.terminate()  # SIGTERM: the node stops as on Ctrl-C
        try:
            node_out, node_err = node.communicate(timeout=120)
        except subprocess.TimeoutExpired:
            node.kill()
            node_out, node_err = node.communicate()
            pytest.fail(f"wbc ros2 node did not stop within 120 s of SIGTERM:\n{node_out[-2000:]}\n{node_err[-2000:]}")
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert "NODES [('wbc_node', '/'), ('wbc_test_client', '/')]" in lines, (out.stdout, node_out, node_err)
    assert ("PUBS ['/joint_states', '/navigate_to_goal/_action/feedback', '/navigate_to_goal/_action/status', "
            "'/navigate_to_pose/_action/feedback', '/navigate_to_pose/_action/status', '/odom', "
            "'/robot_description', '/tf', '/tf_static']") in lines, out.stdout
    counts = eval(next(line for line in lines if line.startswith("COUNTS"))[len("COUNTS "):])
    assert counts["joint_states"] >= SAMPLES and counts["odom"] >= SAMPLES, (counts, node_out, node_err)
    assert counts["robot_description"] == 1 and counts["status"] == 1, counts
    nv = robots("humanoid15").model.nv - 6  # actuated joints of the node's default robot
    assert f"JOINTS {nv} {nv}" in lines, out.stdout
    assert any(line.startswith("URDF <") for line in lines), out.stdout
    assert "'cmd_vel': 0" not in node_out, node_out  # the node took rclpy's /cmd_vel
