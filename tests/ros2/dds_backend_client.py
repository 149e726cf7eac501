"""An rclpy client of ``wbc ros2 node --backend dds`` (tests/ros2/test_node_dds_clients.py), run in a test venv's
Python by tests/ros2/kilted.py (it does not import wbc). Not a test module.

``python dds_backend_client.py SAMPLES``: wait (≤ 90 s) for the node ``wbc_node`` in the graph; subscribe to
/clock (the node runs ``--time sim``), /joint_states, /odom, /robot_description, /tf, /tf_static and /navigate_to_pose's action status and feedback topics
(the last three need tf2_msgs and nav2_msgs: when a venv lacks them, their counts stay absent); drive /cmd_vel at
0.2 m/s until /joint_states and /odom have SAMPLES samples and the node's /cmd_vel reader matched this writer (≤ 60 s),
then until /odom has the base 2 cm further forward (≤ 10 s more), then stop and, 3 s of /clock time later (≤ 30 s
of wall time), publish a /goal_pose
0.4 m ahead of the last /odom position and wait (≤ 60 s) for SAMPLES feedback messages and a status array whose goal
SUCCEEDED (4). Prints one line ``RESULT <json>``: ``nodes``, ``pubs`` (the node's publisher topics), ``counts``,
``joints`` (names, positions of the last JointState), ``urdf`` (first characters, length), ``tf_frames`` (child
frames seen on /tf), ``clock`` (the first 50 /clock times, s), ``tf_static_frames``, ``statuses`` (status codes of the last status array, in order of arrival:
one list per array), ``distance`` (first and last feedback distance_remaining, m), ``goal_x`` (m); then
``reset_service_seen`` (``wait_for_service`` of /reset_robot within 5 s) and ``reset_answered`` (a reply within 5 s).
"""

import json
import sys
import time

import rclpy
from action_msgs.msg import GoalStatusArray
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from std_srvs.srv import Trigger

try:
    from tf2_msgs.msg import TFMessage
except ImportError:  # a venv without the generated tf2_msgs
    TFMessage = None
try:
    from nav2_msgs.action import NavigateToPose
except ImportError:  # a venv without the generated nav2_msgs
    NavigateToPose = None

SUCCEEDED = 4


def main() -> None:
    want = int(sys.argv[1])
    rclpy.init()
    node = Node("wbc_test_client")
    counts = {"joint_states": 0, "odom": 0, "robot_description": 0, "status": 0, "clock": 0}
    last, out = {}, {"tf_frames": set(), "tf_static_frames": set(), "statuses": [], "distance": [], "clock": []}

    def cb(name):
        def f(msg):
            counts[name] += 1
            last[name] = msg
            if name in ("tf", "tf_static"):
                out[f"{name}_frames"].update(t.child_frame_id for t in msg.transforms)
            elif name == "status":
                out["statuses"].append([s.status for s in msg.status_list])
            elif name == "feedback":
                out["distance"].append(msg.feedback.distance_remaining)
            elif name == "clock" and len(out["clock"]) < 50:
                out["clock"].append(msg.clock.sec + 1e-9 * msg.clock.nanosec)
        return f

    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE)
    subs = [node.create_subscription(JointState, "joint_states", cb("joint_states"), 100),
            node.create_subscription(Odometry, "odom", cb("odom"), 100),
            node.create_subscription(String, "robot_description", cb("robot_description"), latched),
            node.create_subscription(GoalStatusArray, "navigate_to_pose/_action/status", cb("status"), latched),
            node.create_subscription(Clock, "clock", cb("clock"), QoSProfile(
                depth=10, reliability=ReliabilityPolicy.BEST_EFFORT))]
    if TFMessage is not None:
        counts.update(tf=0, tf_static=0)
        subs += [node.create_subscription(TFMessage, "tf", cb("tf"), 100),
                 node.create_subscription(TFMessage, "tf_static", cb("tf_static"), latched)]
    if NavigateToPose is not None:
        counts["feedback"] = 0
        subs.append(node.create_subscription(NavigateToPose.Impl.FeedbackMessage,
                                             "navigate_to_pose/_action/feedback", cb("feedback"), 10))
    cmd = node.create_publisher(Twist, "cmd_vel", 10)
    goal_pub = node.create_publisher(PoseStamped, "goal_pose", 10)
    t0 = time.monotonic()
    while time.monotonic() - t0 < 90 and ("wbc_node", "/") not in node.get_node_names_and_namespaces():
        rclpy.spin_once(node, timeout_sec=0.05)
    out["nodes"] = sorted(node.get_node_names_and_namespaces())
    out["pubs"] = sorted(t for t, _ in node.get_publisher_names_and_types_by_node("wbc_node", "/")) \
        if ("wbc_node", "/") in out["nodes"] else []

    def spin_for(seconds, until=lambda: False, each=lambda: None):
        t = time.monotonic()
        while time.monotonic() - t < seconds and not until():
            each()
            rclpy.spin_once(node, timeout_sec=0.02)

    twist = Twist()
    twist.linear.x = 0.2
    # /cmd_vel until the samples arrived AND the node's reader has matched this writer (discovery is not
    # symmetric: the node's writers can reach this client before its reader matches ours; publishing before that
    # match is lost, and the node counted 0 /cmd_vel under load), then until /odom says the base moved 2 cm forward
    # (at most 10 s more): this writer matching the node's reader does not mean the node's reader has matched this
    # writer yet (a CI run under load: 0.2 s of matched samples after the match and the node counted 0 /cmd_vel)
    spin_for(60, lambda: min(counts["joint_states"], counts["odom"]) >= want and cmd.get_subscription_count() > 0,
             lambda: cmd.publish(twist))
    x0 = last["odom"].pose.pose.position.x if "odom" in last else None
    spin_for(10.0, lambda: x0 is None or last["odom"].pose.pose.position.x >= x0 + 0.02,
             lambda: cmd.publish(twist))
    cmd.publish(Twist())
    # the robot stands again (its closing step) before the goal: 3 s of the node's time (/clock; slower than the
    # wall clock on a loaded machine), at most 30 s of wall time
    def node_time():
        c = last.get("clock")
        return None if c is None else c.clock.sec + 1e-9 * c.clock.nanosec

    t_stop = node_time()
    spin_for(30.0, lambda: t_stop is None or node_time() >= t_stop + 3.0)
    if "odom" in last:
        goal = PoseStamped()
        goal.header.frame_id = "odom"
        goal.pose.position.x = out["goal_x"] = last["odom"].pose.pose.position.x + 0.4
        goal.pose.orientation.w = 1.0
        goal_pub.publish(goal)
        done = (lambda: counts.get("feedback", want) >= want and bool(out["statuses"])
                and SUCCEEDED in out["statuses"][-1])
        spin_for(60, done)
    reset = node.create_client(Trigger, "reset_robot")
    out["reset_service_seen"] = reset.wait_for_service(timeout_sec=5.0)
    future = reset.call_async(Trigger.Request())
    spin_for(5.0, future.done)
    out["reset_answered"] = future.done()
    if "joint_states" in last:
        out["joints"] = [len(last["joint_states"].name), len(last["joint_states"].position)]
    if "robot_description" in last:
        out["urdf"] = [last["robot_description"].data.lstrip()[:5], len(last["robot_description"].data)]
    out["counts"] = counts
    out["tf_frames"], out["tf_static_frames"] = sorted(out["tf_frames"]), sorted(out["tf_static_frames"])
    print("RESULT " + json.dumps(out), flush=True)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
