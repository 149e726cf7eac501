"""A real ROS 2 client of `wbc ros2 node` for tests/ros2/test_rclpy_node.py: rclpy (Kilted, Fast DDS) in the test
venv of tests/ros2/kilted.py. Does NOT import wbc. Prints one JSON line (the last line of stdout).

  python rclpy_client.py graph NODE                    the node names the ROS graph lists
  python rclpy_client.py rate SECONDS [RATE]           /joint_states samples per SECONDS of node time (/clock);
                                                       with RATE, update_rate is set to RATE first and back to 50
  python rclpy_client.py tf                            one /tf message and the /joint_states and /odom of its stamp
  python rclpy_client.py cmdvel VX SECONDS             /cmd_vel VX for SECONDS of node time; /odom before and after
  python rclpy_client.py late                          /robot_description received by a late joiner
  python rclpy_client.py clock                         50 /clock samples
  python rclpy_client.py reset                         /reset_robot answer and /odom after it
  python rclpy_client.py params NODE                   parameters listed, described, got, set and refused
  python rclpy_client.py goal X Y YAW_DEG [CANCEL_S]   NavigateToPose; cancelled CANCEL_S s of node time after accept
  python rclpy_client.py preempt                       a second goal while the first one runs
"""

import json
import math
import sys
import time

import rclpy
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

WALL_LIMIT = 120.0  # s: any wait of this script gives up after this much wall-clock time


def stamp(msg_stamp) -> float:
    return msg_stamp.sec + 1e-9 * msg_stamp.nanosec


class Client(Node):
    def __init__(self):
        super().__init__("wbc_test_client")
        self.clock = None
        self.odom = []
        self.create_subscription(Clock, "/clock", lambda m: setattr(self, "clock", stamp(m.clock)), 10)
        self.create_subscription(Odometry, "/odom", self._on_odom, 100)

    def _on_odom(self, m):
        p = m.pose.pose.position
        o = m.pose.pose.orientation
        self.odom.append([stamp(m.header.stamp), p.x, p.y, p.z, o.x, o.y, o.z, o.w, m.twist.twist.linear.x])

    def spin_until(self, done, limit=WALL_LIMIT):
        t_end = time.monotonic() + limit
        while not done():
            if time.monotonic() > t_end:
                raise TimeoutError("gave up waiting")
            rclpy.spin_once(self, timeout_sec=0.01)

    def wait_clock(self, seconds):
        """Spin until /clock has advanced by ``seconds`` from now."""
        self.spin_until(lambda: self.clock is not None)
        t0 = self.clock
        self.spin_until(lambda: self.clock >= t0 + seconds)
        return self.clock

    def call(self, srv_type, name, request, timeout=30.0):
        cli = self.create_client(srv_type, name)
        if not cli.wait_for_service(timeout_sec=timeout):
            raise TimeoutError(f"service {name} not available")
        fut = cli.call_async(request)
        self.spin_until(fut.done, timeout)
        return fut.result()


def set_params(c, node, **values):
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters

    req = SetParameters.Request()
    for name, value in values.items():
        if isinstance(value, bool):
            pv = ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=value)
        elif isinstance(value, int):
            pv = ParameterValue(type=ParameterType.PARAMETER_INTEGER, integer_value=value)
        else:
            pv = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=float(value))
        req.parameters.append(Parameter(name=name, value=pv))
    return [[r.successful, r.reason] for r in c.call(SetParameters, f"/{node}/set_parameters", req).results]


def cmd_graph(c, node):
    names = []

    def listed():
        names[:] = [f"{ns.rstrip('/')}/{n}" for n, ns in c.get_node_names_and_namespaces()]
        return f"/{node}" in names

    c.spin_until(listed, 30.0)
    return {"nodes": names}


def cmd_rate(c, seconds, rate=None):
    seconds = float(seconds)
    if rate is not None:
        set_params(c, "wbc_node", update_rate=float(rate))
    got = []
    c.create_subscription(JointState, "/joint_states", lambda m: got.append(stamp(m.header.stamp)),
                          QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE))
    c.wait_clock(1.0)  # the subscription matched and the new rate in force
    t0 = c.clock
    c.spin_until(lambda: got and got[-1] >= t0 + seconds)  # every sample of the window received (in order)
    if rate is not None:
        set_params(c, "wbc_node", update_rate=50.0)
    window = [s for s in got if t0 <= s < t0 + seconds]
    return {"count": len(window), "seconds": seconds, "t0": t0, "gaps_max": max(
        (b - a for a, b in zip(window, window[1:])), default=None)}


def cmd_tf(c):
    from tf2_msgs.msg import TFMessage

    tfs, joints = [], {}
    c.create_subscription(TFMessage, "/tf", lambda m: tfs.append(m), 100)
    c.create_subscription(JointState, "/joint_states",
                          lambda m: joints.setdefault(stamp(m.header.stamp), (list(m.name), list(m.position))), 100)
    c.spin_until(lambda: len(tfs) >= 20)
    for m in tfs[5:]:
        s = stamp(m.transforms[0].header.stamp)
        odom = [o for o in c.odom if o[0] == s]
        if s in joints and odom:
            return {"stamp": s, "names": joints[s][0], "positions": joints[s][1], "odom": odom[0],
                    "transforms": [[t.header.frame_id, t.child_frame_id,
                                    [t.transform.translation.x, t.transform.translation.y, t.transform.translation.z],
                                    [t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
                                     t.transform.rotation.w]] for t in m.transforms]}
    raise RuntimeError("no /tf message matched a /joint_states and /odom stamp")


def cmd_cmdvel(c, vx, seconds):
    vx, seconds = float(vx), float(seconds)
    pub = c.create_publisher(Twist, "/cmd_vel", QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT))
    c.wait_clock(0.5)
    c.spin_until(lambda: len(c.odom) > 0)
    start = c.odom[-1]
    t0 = c.clock
    msg = Twist()
    msg.linear.x = vx
    sent = 0
    while c.clock < t0 + seconds:
        pub.publish(msg)
        sent += 1
        c.wait_clock(0.02)
    t_stop = c.clock
    c.wait_clock(3.0)  # cmd_vel_timeout, then the closing step
    return {"start": start, "end": c.odom[-1], "t_start": t0, "t_stop": t_stop, "sent": sent}


def cmd_late(c):
    from std_msgs.msg import String

    got = []
    t0 = time.monotonic()
    c.create_subscription(String, "/robot_description", lambda m: got.append(m.data),
                          QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                                     reliability=ReliabilityPolicy.RELIABLE))
    c.spin_until(lambda: got, 30.0)
    import hashlib

    return {"length": len(got[0]), "sha256": hashlib.sha256(got[0].encode()).hexdigest(),
            "wall_s": time.monotonic() - t0}


def cmd_clock(c):
    got = []
    c.create_subscription(Clock, "/clock", lambda m: got.append(stamp(m.clock)), 100)
    c.spin_until(lambda: len(got) >= 50)
    return {"clock": got}


def cmd_reset(c):
    from std_srvs.srv import Trigger

    r = c.call(Trigger, "/reset_robot", Trigger.Request())
    c.odom.clear()
    c.wait_clock(0.5)
    return {"success": r.success, "message": r.message, "odom": c.odom[-1]}


def cmd_params(c, node):
    from rcl_interfaces.srv import DescribeParameters, GetParameters, ListParameters

    out = {"list": sorted(c.call(ListParameters, f"/{node}/list_parameters", ListParameters.Request()).result.names)}
    names = ["update_rate", "step_duration", "max_velocity", "cmd_vel_timeout", "use_sim_time"]
    desc = c.call(DescribeParameters, f"/{node}/describe_parameters", DescribeParameters.Request(names=names))
    out["describe"] = {d.name: {"type": d.type, "read_only": d.read_only, "description": d.description,
                                "range": [[r.from_value, r.to_value] for r in d.floating_point_range]}
                       for d in desc.descriptors}

    def get(*ps):
        vals = c.call(GetParameters, f"/{node}/get_parameters", GetParameters.Request(names=list(ps))).values
        return [v.double_value if v.type == 3 else v.bool_value for v in vals]

    out["get"] = get(*names)
    out["set_ok"] = set_params(c, node, step_duration=1.0)
    out["after_set"] = get("step_duration")
    out["set_integer"] = set_params(c, node, step_duration=1)
    out["after_integer"] = get("step_duration")
    out["out_of_range"] = set_params(c, node, update_rate=1000.0)
    out["read_only"] = set_params(c, node, use_sim_time=False)
    out["wrong_type"] = set_params(c, node, max_velocity=True)
    out["after_refused"] = get("update_rate", "use_sim_time", "max_velocity")
    set_params(c, node, step_duration=out["get"][1])
    return out


def _goal(x, y, yaw_deg):
    from nav2_msgs.action import NavigateToPose

    goal = NavigateToPose.Goal()
    goal.pose = PoseStamped()
    goal.pose.header.frame_id = "odom"
    goal.pose.pose.position.x, goal.pose.pose.position.y = float(x), float(y)
    goal.pose.pose.orientation.z = math.sin(math.radians(float(yaw_deg)) / 2)
    goal.pose.pose.orientation.w = math.cos(math.radians(float(yaw_deg)) / 2)
    return goal


def _send(c, client, goal, feedback):
    fut = client.send_goal_async(goal, feedback_callback=lambda f: feedback.append(
        [stamp(f.feedback.navigation_time), f.feedback.distance_remaining]))
    c.spin_until(fut.done, 30.0)
    return fut.result()


def _result(c, handle):
    fut = handle.get_result_async()
    c.spin_until(fut.done)
    r = fut.result()
    return {"status": r.status, "error_code": r.result.error_code, "error_msg": r.result.error_msg}


def cmd_goal(c, x, y, yaw_deg, cancel_after=None):
    from nav2_msgs.action import NavigateToPose
    from rclpy.action import ActionClient

    from std_srvs.srv import Trigger

    c.call(Trigger, "/reset_robot", Trigger.Request())
    client = ActionClient(c, NavigateToPose, "/navigate_to_pose")
    if not client.wait_for_server(timeout_sec=30.0):
        raise TimeoutError("no /navigate_to_pose server")
    feedback = []
    handle = _send(c, client, _goal(x, y, yaw_deg), feedback)
    out = {"accepted": handle.accepted}
    if cancel_after is not None:
        c.wait_clock(float(cancel_after))
        fut = handle.cancel_goal_async()
        c.spin_until(fut.done)
        out["cancel_return_code"] = fut.result().return_code
        out["goals_canceling"] = len(fut.result().goals_canceling)
    out["result"] = _result(c, handle)
    out["feedback"] = feedback
    c.odom.clear()
    c.wait_clock(0.2)
    out["odom"] = c.odom[-1]
    return out


def cmd_preempt(c):
    from nav2_msgs.action import NavigateToPose
    from rclpy.action import ActionClient

    from std_srvs.srv import Trigger

    c.call(Trigger, "/reset_robot", Trigger.Request())
    client = ActionClient(c, NavigateToPose, "/navigate_to_pose")
    if not client.wait_for_server(timeout_sec=30.0):
        raise TimeoutError("no /navigate_to_pose server")
    fa, fb = [], []
    a = _send(c, client, _goal(1.5, 0.5, 0.0), fa)
    c.wait_clock(1.0)
    b = _send(c, client, _goal(0.5, 0.0, 0.0), fb)
    out = {"accepted_a": a.accepted, "accepted_b": b.accepted, "a": _result(c, a), "b": _result(c, b)}
    c.odom.clear()
    c.wait_clock(0.2)
    out["odom"] = c.odom[-1]
    return out


def main():
    cmd, args = sys.argv[1], sys.argv[2:]
    rclpy.init()
    c = Client()
    try:
        out = globals()[f"cmd_{cmd}"](c, *args)
    finally:
        c.destroy_node()
        rclpy.try_shutdown()
    print(json.dumps(out))


if __name__ == "__main__":
    main()
