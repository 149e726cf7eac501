"""Standalone ROS 2 clients of `wbc ros2 node` for tests/ros2/test_node.py. Does NOT import wbc: it declares the
ROS 2 IDL itself (rosidl's DDS names, rmw_cyclonedds' service request header) with cyclonedds.idl.

Usage:
  python tests/ros2/ros2_node_client.py goal X Y YAW_DEG [CANCEL_AFTER_S]   /reset_robot, then NavigateToPose on
                                                                  /navigate_to_pose (cancel after that node time)
  python tests/ros2/ros2_node_client.py preempt                              a second goal while the first one runs
  python tests/ros2/ros2_node_client.py cmdvel VX SECONDS                    /cmd_vel for SECONDS of node time (/clock)
  python tests/ros2/ros2_node_client.py cmdvel-sim VX SECONDS SETTLE         the same, then SETTLE s more (/odom, /joint_states)
  python tests/ros2/ros2_node_client.py params NODE                          parameter services + /joint_states rate
Prints one JSON line with what it measured.
"""
import json
import math
import os
import random
import sys
import time
import types
from dataclasses import dataclass, field

from cyclonedds.core import Policy, Qos
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.annotations import final
from cyclonedds.idl.types import array, float32, float64, int8, int16, int32, int64, sequence, uint8, uint16, uint32, uint64
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration
from loopback_sockets import loopback_participant


@dataclass
@final
class Time_(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32 = 0
    nanosec: uint32 = 0


@dataclass
@final
class Duration_(IdlStruct, typename="builtin_interfaces::msg::dds_::Duration_"):
    sec: int32 = 0
    nanosec: uint32 = 0


@dataclass
@final
class Header_(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time_ = field(default_factory=Time_)
    frame_id: str = ""


@dataclass
@final
class Vector3_(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
@final
class Point_(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
@final
class Quaternion_(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0
    w: float64 = 1.0


@dataclass
@final
class Pose_(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point_ = field(default_factory=Point_)
    orientation: Quaternion_ = field(default_factory=Quaternion_)


@dataclass
@final
class PoseStamped_(IdlStruct, typename="geometry_msgs::msg::dds_::PoseStamped_"):
    header: Header_ = field(default_factory=Header_)
    pose: Pose_ = field(default_factory=Pose_)


@dataclass
@final
class Twist_(IdlStruct, typename="geometry_msgs::msg::dds_::Twist_"):
    linear: Vector3_ = field(default_factory=Vector3_)
    angular: Vector3_ = field(default_factory=Vector3_)


@dataclass
@final
class PoseWithCovariance_(IdlStruct, typename="geometry_msgs::msg::dds_::PoseWithCovariance_"):
    pose: Pose_ = field(default_factory=Pose_)
    covariance: array[float64, 36] = field(default_factory=lambda: [0.0] * 36)


@dataclass
@final
class TwistWithCovariance_(IdlStruct, typename="geometry_msgs::msg::dds_::TwistWithCovariance_"):
    twist: Twist_ = field(default_factory=Twist_)
    covariance: array[float64, 36] = field(default_factory=lambda: [0.0] * 36)


@dataclass
@final
class Odometry_(IdlStruct, typename="nav_msgs::msg::dds_::Odometry_"):
    header: Header_ = field(default_factory=Header_)
    child_frame_id: str = ""
    pose: PoseWithCovariance_ = field(default_factory=PoseWithCovariance_)
    twist: TwistWithCovariance_ = field(default_factory=TwistWithCovariance_)


@dataclass
@final
class JointState_(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    header: Header_ = field(default_factory=Header_)
    name: sequence[str] = field(default_factory=list)
    position: sequence[float64] = field(default_factory=list)
    velocity: sequence[float64] = field(default_factory=list)
    effort: sequence[float64] = field(default_factory=list)


@dataclass
@final
class Clock_(IdlStruct, typename="rosgraph_msgs::msg::dds_::Clock_"):
    clock: Time_ = field(default_factory=Time_)


@dataclass
@final
class UUID_(IdlStruct, typename="unique_identifier_msgs::msg::dds_::UUID_"):
    uuid: array[uint8, 16] = field(default_factory=lambda: [0] * 16)


@dataclass
@final
class GoalInfo_(IdlStruct, typename="action_msgs::msg::dds_::GoalInfo_"):
    goal_id: UUID_ = field(default_factory=UUID_)
    stamp: Time_ = field(default_factory=Time_)


@dataclass
@final
class GoalStatus_(IdlStruct, typename="action_msgs::msg::dds_::GoalStatus_"):
    goal_info: GoalInfo_ = field(default_factory=GoalInfo_)
    status: int8 = 0


@dataclass
@final
class GoalStatusArray_(IdlStruct, typename="action_msgs::msg::dds_::GoalStatusArray_"):
    status_list: sequence[GoalStatus_] = field(default_factory=list)


@dataclass
@final
class CancelGoal_Request_(IdlStruct, typename="action_msgs::srv::dds_::CancelGoal_Request_"):
    client_guid: uint64 = 0
    seq: int64 = 0
    goal_info: GoalInfo_ = field(default_factory=GoalInfo_)


@dataclass
@final
class CancelGoal_Response_(IdlStruct, typename="action_msgs::srv::dds_::CancelGoal_Response_"):
    client_guid: uint64 = 0
    seq: int64 = 0
    return_code: int8 = 0
    goals_canceling: sequence[GoalInfo_] = field(default_factory=list)


@dataclass
@final
class Goal_(IdlStruct, typename="nav2_msgs::action::dds_::NavigateToPose_Goal_"):
    pose: PoseStamped_ = field(default_factory=PoseStamped_)
    behavior_tree: str = ""


@dataclass
@final
class Result_(IdlStruct, typename="nav2_msgs::action::dds_::NavigateToPose_Result_"):
    error_code: uint16 = 0
    error_msg: str = ""


@dataclass
@final
class Feedback_(IdlStruct, typename="nav2_msgs::action::dds_::NavigateToPose_Feedback_"):
    current_pose: PoseStamped_ = field(default_factory=PoseStamped_)
    navigation_time: Duration_ = field(default_factory=Duration_)
    estimated_time_remaining: Duration_ = field(default_factory=Duration_)
    number_of_recoveries: int16 = 0
    distance_remaining: float32 = 0.0


@dataclass
@final
class FeedbackMessage_(IdlStruct, typename="nav2_msgs::action::dds_::NavigateToPose_FeedbackMessage_"):
    goal_id: UUID_ = field(default_factory=UUID_)
    feedback: Feedback_ = field(default_factory=Feedback_)


@dataclass
@final
class SendGoal_Request_(IdlStruct, typename="nav2_msgs::action::dds_::NavigateToPose_SendGoal_Request_"):
    client_guid: uint64 = 0
    seq: int64 = 0
    goal_id: UUID_ = field(default_factory=UUID_)
    goal: Goal_ = field(default_factory=Goal_)


@dataclass
@final
class SendGoal_Response_(IdlStruct, typename="nav2_msgs::action::dds_::NavigateToPose_SendGoal_Response_"):
    client_guid: uint64 = 0
    seq: int64 = 0
    accepted: bool = False
    stamp: Time_ = field(default_factory=Time_)


@dataclass
@final
class GetResult_Request_(IdlStruct, typename="nav2_msgs::action::dds_::NavigateToPose_GetResult_Request_"):
    client_guid: uint64 = 0
    seq: int64 = 0
    goal_id: UUID_ = field(default_factory=UUID_)


@dataclass
@final
class GetResult_Response_(IdlStruct, typename="nav2_msgs::action::dds_::NavigateToPose_GetResult_Response_"):
    client_guid: uint64 = 0
    seq: int64 = 0
    status: int8 = 0
    result: Result_ = field(default_factory=Result_)


@dataclass
@final
class ParameterValue_(IdlStruct, typename="rcl_interfaces::msg::dds_::ParameterValue_"):
    type: uint8 = 0
    bool_value: bool = False
    integer_value: int64 = 0
    double_value: float64 = 0.0
    string_value: str = ""
    byte_array_value: sequence[uint8] = field(default_factory=list)
    bool_array_value: sequence[bool] = field(default_factory=list)
    integer_array_value: sequence[int64] = field(default_factory=list)
    double_array_value: sequence[float64] = field(default_factory=list)
    string_array_value: sequence[str] = field(default_factory=list)


@dataclass
@final
class Parameter_(IdlStruct, typename="rcl_interfaces::msg::dds_::Parameter_"):
    name: str = ""
    value: ParameterValue_ = field(default_factory=ParameterValue_)


@dataclass
@final
class SetParametersResult_(IdlStruct, typename="rcl_interfaces::msg::dds_::SetParametersResult_"):
    successful: bool = False
    reason: str = ""


@dataclass
@final
class ListParametersResult_(IdlStruct, typename="rcl_interfaces::msg::dds_::ListParametersResult_"):
    names: sequence[str] = field(default_factory=list)
    prefixes: sequence[str] = field(default_factory=list)


@dataclass
@final
class FloatingPointRange_(IdlStruct, typename="rcl_interfaces::msg::dds_::FloatingPointRange_"):
    from_value: float64 = 0.0
    to_value: float64 = 0.0
    step: float64 = 0.0


@dataclass
@final
class IntegerRange_(IdlStruct, typename="rcl_interfaces::msg::dds_::IntegerRange_"):
    from_value: int64 = 0
    to_value: int64 = 0
    step: uint64 = 0


@dataclass
@final
class ParameterDescriptor_(IdlStruct, typename="rcl_interfaces::msg::dds_::ParameterDescriptor_"):
    name: str = ""
    type: uint8 = 0
    description: str = ""
    additional_constraints: str = ""
    read_only: bool = False
    dynamic_typing: bool = False
    floating_point_range: sequence[FloatingPointRange_, 1] = field(default_factory=list)
    integer_range: sequence[IntegerRange_, 1] = field(default_factory=list)


@dataclass
@final
class Trigger_Request_(IdlStruct, typename="std_srvs::srv::dds_::Trigger_Request_"):
    client_guid: uint64 = 0
    seq: int64 = 0
    structure_needs_at_least_one_member: uint8 = 0


@dataclass
@final
class Trigger_Response_(IdlStruct, typename="std_srvs::srv::dds_::Trigger_Response_"):
    client_guid: uint64 = 0
    seq: int64 = 0
    success: bool = False
    message: str = ""


def _srv(name, fields_req, fields_rep):
    """(request, reply) classes of rcl_interfaces/srv/<name> with rmw_cyclonedds' header."""
    out = []
    for kind, fields in (("Request", fields_req), ("Response", fields_rep)):
        ns = {"__annotations__": {"client_guid": uint64, "seq": int64, **{k: t for k, (t, _) in fields.items()}},
              "client_guid": 0, "seq": 0}
        for k, (_, d) in fields.items():
            ns[k] = field(default_factory=d)
        # types.new_class passes typename to IdlStruct's metaclass (type(...) ignored it: the DDS type name was
        # "<name>_<kind>_", which only matched while both ends announced XTypes type information)
        typename = f"rcl_interfaces::srv::dds_::{name}_{kind}_"
        cls = types.new_class(f"{name}_{kind}_", (IdlStruct,), {"typename": typename}, lambda body: body.update(ns))
        out.append(dataclass(final(cls)))
    return out


GetReq, GetRep = _srv("GetParameters", {"names": (sequence[str], list)}, {"values": (sequence[ParameterValue_], list)})
SetReq, SetRep = _srv("SetParameters", {"parameters": (sequence[Parameter_], list)},
                      {"results": (sequence[SetParametersResult_], list)})
ListReq, ListRep = _srv("ListParameters", {"prefixes": (sequence[str], list), "depth": (uint64, int)},
                        {"result": (ListParametersResult_, ListParametersResult_)})
DescReq, DescRep = _srv("DescribeParameters", {"names": (sequence[str], list)},
                        {"descriptors": (sequence[ParameterDescriptor_], list)})

RELIABLE = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(10),
               Policy.Durability.Volatile)
DEEP = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(1000),
           Policy.Durability.Volatile)
LATCHED = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(1),
              Policy.Durability.TransientLocal)
DP = loopback_participant(int(os.environ.get("ROS_DOMAIN_ID", "0")))  # on 127.0.0.1 only (conftest.py checks)
GUID = random.getrandbits(63)


def reader(name, typ, qos=DEEP):
    return DataReader(DP, Topic(DP, name, typ, qos=qos), qos=qos)


def writer(name, typ, qos=RELIABLE):
    return DataWriter(DP, Topic(DP, name, typ, qos=qos), qos=qos)


class Client:
    """A service client in rmw_cyclonedds' convention (request id in the payload header)."""

    def __init__(self, name, req, rep):
        self.w = writer(f"rq/{name}Request", req)
        self.r = reader(f"rr/{name}Reply", rep, RELIABLE)
        self.req, self.rep, self.seq = req, rep, 0

    def wait_matched(self):
        deadline = time.monotonic() + 20.0
        while not self.w.get_matched_subscriptions() or not self.r.get_matched_publications():
            if time.monotonic() > deadline:
                raise RuntimeError("service not matched")
            time.sleep(0.05)
        time.sleep(0.2)
        self.matched = True

    def call(self, timeout=60.0, **fields):
        if not getattr(self, "matched", False):
            self.wait_matched()
        self.seq += 1
        self.w.write(self.req(client_guid=GUID, seq=self.seq, **fields))
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for s in self.r.take(N=10):
                if isinstance(s, self.rep) and s.client_guid == GUID and s.seq == self.seq:
                    return s
            time.sleep(0.002)
        raise RuntimeError("no reply")


class Clock:
    def __init__(self):
        self.r = reader("rt/clock", Clock_, Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(1)))
        self.t = None

    def now(self):
        for s in self.r.take(N=100):
            if isinstance(s, Clock_):
                self.t = s.clock.sec + 1e-9 * s.clock.nanosec
        return self.t


def stamp_s(h):
    return h.stamp.sec + 1e-9 * h.stamp.nanosec


def yaw_of(o):
    return math.atan2(2.0 * (o.w * o.z + o.x * o.y), 1.0 - 2.0 * (o.y * o.y + o.z * o.z))


def main_goal(x, y, yaw_deg, cancel_after):
    reset = Client("reset_robot", Trigger_Request_, Trigger_Response_).call()
    assert reset.success, reset.message
    send = Client("navigate_to_pose/_action/send_goal", SendGoal_Request_, SendGoal_Response_)
    result = Client("navigate_to_pose/_action/get_result", GetResult_Request_, GetResult_Response_)
    cancel = Client("navigate_to_pose/_action/cancel_goal", CancelGoal_Request_, CancelGoal_Response_)
    fb_r = reader("rt/navigate_to_pose/_action/feedback", FeedbackMessage_)
    st_r = reader("rt/navigate_to_pose/_action/status", GoalStatusArray_, LATCHED)
    js_r = reader("rt/joint_states", JointState_)
    od_r = reader("rt/odom", Odometry_)
    uid = [random.getrandbits(8) for _ in range(16)]
    h = math.radians(yaw_deg) / 2
    goal = Goal_(PoseStamped_(Header_(Time_(), "odom"), Pose_(Point_(x, y, 0.0),
                                                               Quaternion_(0.0, 0.0, math.sin(h), math.cos(h)))))
    cancel.wait_matched()
    result.wait_matched()
    rep = send.call(goal_id=UUID_(uid), goal=goal)
    out = {"accepted": rep.accepted, "feedback": [], "joints": [], "odom": [], "status_seen": []}
    canceled_at = None
    # get_result is answered when the goal ends: call it in the background by polling our own reader
    result.seq += 1
    result.w.write(GetResult_Request_(client_guid=GUID, seq=result.seq, goal_id=UUID_(uid)))
    deadline = time.monotonic() + 600
    res = None
    while res is None and time.monotonic() < deadline:
        for f in fb_r.take(N=100):
            if isinstance(f, FeedbackMessage_) and list(f.goal_id.uuid) == uid:
                fb = f.feedback
                nav_t = fb.navigation_time.sec + 1e-9 * fb.navigation_time.nanosec
                out["feedback"].append([nav_t, float(fb.distance_remaining), stamp_s(fb.current_pose.header)])
                if cancel_after is not None and canceled_at is None and nav_t >= cancel_after:
                    c = cancel.call(goal_info=GoalInfo_(UUID_(uid), Time_()))
                    canceled_at = stamp_s(fb.current_pose.header)
                    out["cancel_return_code"] = c.return_code
                    out["cancel_stamp"] = canceled_at
        for s in js_r.take(N=200):
            if isinstance(s, JointState_):
                out["joints"].append([stamp_s(s.header)] + list(s.position))
                out["joint_names"] = list(s.name)
        for s in od_r.take(N=200):
            if isinstance(s, Odometry_):
                p = s.pose.pose
                out["odom"].append([stamp_s(s.header), p.position.x, p.position.y, p.position.z, p.orientation.x,
                                    p.orientation.y, p.orientation.z, p.orientation.w])
        for s in st_r.take(N=10):
            if isinstance(s, GoalStatusArray_):
                out["status_seen"] += [g.status for g in s.status_list if list(g.goal_info.goal_id.uuid) == uid]
        for s in result.r.take(N=10):
            if isinstance(s, GetResult_Response_) and s.client_guid == GUID and s.seq == result.seq:
                res = s
        time.sleep(0.002)
    time.sleep(0.5)
    for s in od_r.take(N=200):
        if isinstance(s, Odometry_):
            p = s.pose.pose
            out["odom"].append([stamp_s(s.header), p.position.x, p.position.y, p.position.z, p.orientation.x,
                                p.orientation.y, p.orientation.z, p.orientation.w])
    out["result"] = None if res is None else {"status": res.status, "error_code": res.result.error_code,
                                              "error_msg": res.result.error_msg}
    print(json.dumps(out), flush=True)


def main_preempt():
    """Goal A (1.5, 0.5); after 1 s of its feedback, goal B (0.5, 0.0): both results."""
    assert Client("reset_robot", Trigger_Request_, Trigger_Response_).call().success
    send = Client("navigate_to_pose/_action/send_goal", SendGoal_Request_, SendGoal_Response_)
    result = Client("navigate_to_pose/_action/get_result", GetResult_Request_, GetResult_Response_)
    fb_r = reader("rt/navigate_to_pose/_action/feedback", FeedbackMessage_)
    od_r = reader("rt/odom", Odometry_)

    def goal(x, y):
        return Goal_(PoseStamped_(Header_(Time_(), "odom"), Pose_(Point_(x, y, 0.0), Quaternion_())))

    a, b = [random.getrandbits(8) for _ in range(16)], [random.getrandbits(8) for _ in range(16)]
    out = {"accepted_a": send.call(goal_id=UUID_(a), goal=goal(1.5, 0.5)).accepted}
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        fb = [f for f in fb_r.take(N=100) if isinstance(f, FeedbackMessage_) and list(f.goal_id.uuid) == a]
        if fb and fb[-1].feedback.navigation_time.sec >= 1:
            break
        time.sleep(0.002)
    out["accepted_b"] = send.call(goal_id=UUID_(b), goal=goal(0.5, 0.0)).accepted
    ra = result.call(goal_id=UUID_(a))
    rb = result.call(goal_id=UUID_(b), timeout=300)
    out["a"] = [ra.status, ra.result.error_code, ra.result.error_msg]
    out["b"] = [rb.status, rb.result.error_code, rb.result.error_msg]
    time.sleep(0.5)
    odom = [s for s in od_r.take(N=1000) if isinstance(s, Odometry_)]
    out["final"] = [odom[-1].pose.pose.position.x, odom[-1].pose.pose.position.y]
    print(json.dumps(out), flush=True)


def main_cmdvel(vx, seconds):
    clock = Clock()
    pub = writer("rt/cmd_vel", Twist_)
    od_r = reader("rt/odom", Odometry_)
    deadline = time.monotonic() + 60
    while clock.now() is None or not pub.get_matched_subscriptions() or not od_r.get_matched_publications():
        if time.monotonic() > deadline:
            raise RuntimeError("node not found")
        time.sleep(0.01)
    time.sleep(0.3)
    odom = []

    def drain():
        for s in od_r.take(N=500):
            if isinstance(s, Odometry_):
                p, v = s.pose.pose.position, s.twist.twist
                odom.append([stamp_s(s.header), p.x, p.y, abs(v.linear.x) + abs(v.linear.y) + abs(v.angular.z)])

    t0 = clock.now()
    sent = 0
    while clock.now() < t0 + seconds:
        pub.write(Twist_(Vector3_(vx, 0.0, 0.0), Vector3_()))
        sent += 1
        drain()
        time.sleep(0.01)
    t1 = clock.now()
    # wait for the robot to stand: 1 s of node time with zero odometry twist
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline:
        drain()
        still = [o for o in odom if o[0] > t1]
        if still and still[-1][3] < 1e-9:
            run = [o for o in still if o[3] >= 1e-9]
            if run and still[-1][0] - run[-1][0] > 1.0:
                break
        time.sleep(0.01)
    before = [o for o in odom if o[0] <= t0]
    print(json.dumps({"t_start": t0, "t_stop": t1, "sent": sent, "odom": odom,
                      "start": before[-1] if before else odom[0]}), flush=True)


def main_cmdvel_sim(vx, seconds, settle):
    """/cmd_vel for SECONDS of /clock, then SETTLE more seconds (the physics walk ends its segment); /odom and the
    /joint_states it saw (the estimate's twist is never exactly zero: no stand detection here)."""
    clock = Clock()
    pub = writer("rt/cmd_vel", Twist_)
    od_r = reader("rt/odom", Odometry_)
    js_r = reader("rt/joint_states", JointState_)
    deadline = time.monotonic() + 120
    while clock.now() is None or not pub.get_matched_subscriptions() or not od_r.get_matched_publications():
        if time.monotonic() > deadline:
            raise RuntimeError("node not found")
        time.sleep(0.01)
    time.sleep(0.3)
    odom, joints = [], []

    def drain():
        for s in od_r.take(N=500):
            if isinstance(s, Odometry_):
                p = s.pose.pose.position
                odom.append([stamp_s(s.header), p.x, p.y, p.z])
        for s in js_r.take(N=500):
            if isinstance(s, JointState_):
                joints.append([stamp_s(s.header), len(s.name), len(s.position), len(s.velocity), len(s.effort),
                               max((abs(e) for e in s.effort), default=0.0)])

    t0 = clock.now()
    sent = 0
    while clock.now() < t0 + seconds:
        pub.write(Twist_(Vector3_(vx, 0.0, 0.0), Vector3_()))
        sent += 1
        drain()
        time.sleep(0.01)
    t1 = clock.now()
    deadline = time.monotonic() + 300
    while clock.now() < t1 + settle and time.monotonic() < deadline:
        drain()
        time.sleep(0.01)
    drain()
    before = [o for o in odom if o[0] <= t0]
    print(json.dumps({"t_start": t0, "t_stop": t1, "t_end": clock.now(), "sent": sent, "odom": odom,
                      "joints": joints, "start": before[-1] if before else odom[0]}), flush=True)


def main_params(node):
    get = Client(f"{node}/get_parameters", GetReq, GetRep)
    set_ = Client(f"{node}/set_parameters", SetReq, SetRep)
    lst = Client(f"{node}/list_parameters", ListReq, ListRep)
    desc = Client(f"{node}/describe_parameters", DescReq, DescRep)
    clock = Clock()
    js_r = reader("rt/joint_states", JointState_)
    out = {}
    out["list"] = list(lst.call(prefixes=[], depth=0).result.names)
    d = desc.call(names=["update_rate"]).descriptors[0]
    out["describe"] = {"name": d.name, "type": d.type, "description": d.description,
                       "range": [[r.from_value, r.to_value] for r in d.floating_point_range]}
    out["before"] = get.call(names=["update_rate"]).values[0].double_value
    ok = set_.call(parameters=[Parameter_("update_rate", ParameterValue_(type=3, double_value=50.0))]).results[0]
    out["set_50"] = [ok.successful, ok.reason]
    bad = set_.call(parameters=[Parameter_("update_rate", ParameterValue_(type=3, double_value=1000.0)),
                                Parameter_("max_velocity", ParameterValue_(type=4, string_value="fast"))]).results
    out["set_bad"] = [[r.successful, r.reason] for r in bad]
    vals = get.call(names=["update_rate", "max_velocity"]).values
    out["after_bad"] = [v.double_value for v in vals]
    # /joint_states rate: header stamps over 10 s of node time, from the first sample after the change
    while js_r.take(N=1000):
        pass
    t0 = clock.now()
    stamps, arrivals = [], []
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and (clock.now() is None or clock.now() < t0 + 10.5):
        for s in js_r.take(N=1000):
            if isinstance(s, JointState_):
                stamps.append(stamp_s(s.header))
                arrivals.append(time.monotonic())
        time.sleep(0.005)
    out["stamps"] = stamps
    out["arrivals"] = arrivals
    print(json.dumps(out), flush=True)


if __name__ == "__main__":
    mode = sys.argv[1]
    if mode == "goal":
        main_goal(float(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]),
                  float(sys.argv[5]) if len(sys.argv) > 5 else None)
    elif mode == "preempt":
        main_preempt()
    elif mode == "cmdvel":
        main_cmdvel(float(sys.argv[2]), float(sys.argv[3]))
    elif mode == "cmdvel-sim":
        main_cmdvel_sim(float(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]))
    elif mode == "params":
        main_params(sys.argv[2])
    else:
        raise SystemExit(__doc__)
