"""The controller node over DDS (no ROS 2 install): /cmd_vel, NavigateToPose actions, parameters, /reset_robot.

:class:`ControllerNode` is the DDS transport of :class:`wbc.ros2.node_core.NodeCore` (the behaviour below is the
core's, shared with the rclpy transport :class:`wbc.ros2.rclpy_node.RclpyNode`). It drives a :class:`wbc.scenarios.commanded_walk.CommandedWalk` (the kinematic walk
controller, 500 Hz) and speaks ROS 2 on the wire (names and types: :mod:`wbc.ros2.msgs`):

==========================================  ============================================  =========================
ROS 2 name                                  type                                          QoS
==========================================  ============================================  =========================
/joint_states (``update_rate`` Hz)          sensor_msgs/msg/JointState (position, velocity, reliable, volatile, last N
                                            effort with ``sim``)
/tf (``update_rate`` Hz)                    tf2_msgs/msg/TFMessage                        reliable, volatile, last N
/odom (``update_rate`` Hz)                  nav_msgs/msg/Odometry (odom → root link)      reliable, volatile, last N
/tf_static, /robot_description              tf2_msgs/msg/TFMessage, std_msgs/msg/String   reliable, transient local, last 1
/clock (``--time sim``, every 10 ms)        rosgraph_msgs/msg/Clock                       reliable, volatile, last 1
/cmd_vel (subscribed)                       geometry_msgs/msg/Twist                       best effort reader, last 10
/goal_pose (subscribed: RViz2 2D Goal Pose) geometry_msgs/msg/PoseStamped                 best effort reader, last 10
/navigate_to_pose, /navigate_to_goal        nav2_msgs/action/NavigateToPose (Jazzy)       services: reliable, last 10;
                                                                                          status: transient local
/reset_robot                                std_srvs/srv/Trigger                          reliable, volatile, last 10
/<node>/get_parameters, set_parameters,     rcl_interfaces/srv/...                        reliable, volatile, last 10
set_parameters_atomically, list_parameters,
describe_parameters, get_parameter_types
==========================================  ============================================  =========================

N is one second of samples at ``update_rate`` (at least 10), resized when ``update_rate`` is set.

Behaviour:

* ``/cmd_vel`` (linear.x, linear.y m/s, angular.z rad/s, walking frame) becomes the walk's velocity command; a
  value beyond the ``max_velocity`` / ``max_lateral`` / ``max_turn`` limits is saturated and reported on stdout
  (once per second). No sample for ``cmd_vel_timeout`` s (node time) → command zero → the robot closes its stance
  at the next touch-down and stands.
* NavigateToPose: the goal is the base pose (x, y, yaw about z) in the world frame (``odom``; the header's
  frame id is not transformed). **A new goal pre-empts the active one**: the new one is accepted, the old one ends
  ABORTED with ``error_msg`` "pre-empted by a new goal". Feedback every 0.1 s of node time (10 Hz): the base pose,
  ``distance_remaining`` (m, from where the base would stand over the current soles,
  :meth:`~wbc.scenarios.commanded_walk.CommandedWalk.footprint_pose`, to the goal: it does not sway with the CoM),
  navigation time, and the plan's time remaining. The goal ends
  SUCCEEDED (``error_code`` 0) when the robot stands with the base within 5 cm and 5° of the goal, else ABORTED
  (``error_code`` 9000, UNKNOWN) with the errors in ``error_msg``; a goal the gait cannot plan is ABORTED with the
  planner's message. Cancel → the robot stops with a closing step at the next touch-down; the goal ends CANCELED
  once it stands, ``error_msg`` giving where. A nonzero /cmd_vel aborts an active goal. A pose on ``/goal_pose``
  (RViz2's "2D Goal Pose" tool, as Nav2's bt_navigator takes it) starts a /navigate_to_pose goal.
* ``/reset_robot``: back to the reference stance; an active goal is ABORTED.
* Parameters (``ros2 param get/set/list/describe`` services): ``update_rate`` (Hz, double in [1, 500]),
  ``step_duration`` (s, [0.4, 3]), ``max_velocity`` (m/s, (0, 1]), ``cmd_vel_timeout`` (s, [0.05, 10]),
  ``use_sim_time`` (bool, read-only: ``--time sim``). An integer value is accepted for a double parameter. A wrong
  type, an out-of-range value or a read-only parameter is refused in the SetParametersResult with the reason, and
  nothing of that request is applied (set_parameters applies each valid parameter; set_parameters_atomically none
  if one is refused).
* Time: ``"real"`` paces the loop to the wall clock (:class:`wbc.viz.live.RealTimePacer`), stamps are the wall-clock
  time at the end of the first tick plus the node time (after a stall > 0.1 s they jump forward with the wall
  clock); ``"sim"`` runs as fast as it can (``max_rtf``: at most that many node
  seconds per wall-clock second), publishes /clock and stamps node time from 0.
* Services answer rmw_cyclonedds clients (the request id travels in the payload header). rmw_fastrtps clients are
  not answered: their request id is the request sample's RTPS identity (writer GUID, sequence number) and they take
  a reply only when its ``related_sample_identity`` inline QoS names them; Cyclone DDS's API (Python binding and C)
  exposes no received sequence number and writes no related sample identity.
* ``sim=True``: :class:`wbc.sim.commanded.SimCommandedWalk` (re-planned from the measured state in the double
  support after a touch-down: a command change takes effect at the next touch-down; a stop or cancel ends the
  walk there with one closing step); /joint_states effort is the applied torque, /odom and /tf the estimate; the
  plant's ground truth is printed at each walk/stand transition and at each re-plan.

Memory: the node keeps no run log; finished goals are kept in a ring of 16 for get_result. Every 10 s of node
time (between two ticks, after the tick's messages are out) the node returns the free memory of glibc's heap to the
system (``malloc_trim(0)`` through ctypes; nothing on a C library without it): start-up, each re-plan of the walk
(arrays of about 0.5 MB) and each tick's temporaries free memory that glibc keeps resident in a fragmented heap
(about 100 MB for the ``sim`` node); a trim gives the free pages back. A trim is one call of one or two
milliseconds; its count and the time of the last one are in the ``report_every`` line.
"""

from __future__ import annotations

from wbc.ros2.node_core import GOAL_TOLERANCE, PARAMETERS, Goal, NodeCore, history_depth

__all__ = ["ControllerNode", "PARAMETERS", "GOAL_TOLERANCE"]


class _Service:
    """A Cyclone-RMW service: reader of ``rq/<name>Request``, writer of ``rr/<name>Reply``."""

    def __init__(self, part, name: str, req_type, rep_type, qos):
        from wbc.ros2.endpoints import reader, writer

        base = name.lstrip("/")
        self.reader = reader(part, f"rq/{base}Request", req_type, qos)
        self.writer = writer(part, f"rr/{base}Reply", rep_type, qos)
        self.req_type, self.rep_type = req_type, rep_type

    def requests(self):
        return [r for r in self.reader.take(N=16) if isinstance(r, self.req_type)]

    def reply(self, req, **fields) -> None:
        self.writer.write(self.rep_type(client_guid=req.client_guid, seq=req.seq, **fields))


class ControllerNode(NodeCore):
    """The node of the module docstring (arguments of :class:`~wbc.ros2.node_core.NodeCore`, plus ``tf``).

    Args:
        tf: ``"all"`` or ``"base"`` (:class:`wbc.ros2.publisher.Ros2Publisher`).

    Raises:
        InvalidInputError: a bad time mode, rate, name or parameter value.
        wbc.ros2.Ros2UnavailableError: cyclonedds/rosbags missing.
    """

    def __init__(self, robot, *, tf: str = "all", **core):
        from wbc.ros2 import require

        require()
        super().__init__(robot, **core)
        self._setup_dds(tf)
        self._waiting: dict[bytes, list] = {}  # goal uuid → get_result requests to answer when it ends

    # -- DDS ---------------------------------------------------------------------------------------------------
    def _setup_dds(self, tf: str) -> None:
        from cyclonedds.core import Policy, Qos
        from cyclonedds.util import duration

        from wbc.ros2 import dds, msgs
        from wbc.ros2.endpoints import reader
        from wbc.ros2.publisher import Ros2Publisher

        self.m = msgs
        self.pub = Ros2Publisher(self.robot, rate=self.params["update_rate"], tf=tf, dt=self.walk.dt, clock="sim",
                                 epoch=self.epoch)
        part = self.part = self.pub.participant
        self._odom_w = None
        self._rate_changed(self.params["update_rate"])
        self._clock_w = None
        if self.time_mode == "sim":
            self._clock_w = self._writer("rt/clock", msgs.Clock, dds.qos_stream(1))
        be = Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(10), Policy.Durability.Volatile)
        self._cmd_r = reader(part, "rt/cmd_vel", msgs.Twist, be)
        self._goal_pose_r = reader(part, "rt/goal_pose", msgs.PoseStamped, be)
        srv = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(10),
                  Policy.Durability.Volatile)
        self._reset = _Service(part, "reset_robot", msgs.TriggerRequest, msgs.TriggerReply, srv)
        n = self.name
        self._psrv = {
            "get": _Service(part, f"{n}/get_parameters", msgs.GetParametersRequest, msgs.GetParametersReply, srv),
            "set": _Service(part, f"{n}/set_parameters", msgs.SetParametersRequest, msgs.SetParametersReply, srv),
            "atomic": _Service(part, f"{n}/set_parameters_atomically", msgs.SetParametersAtomicallyRequest,
                               msgs.SetParametersAtomicallyReply, srv),
            "list": _Service(part, f"{n}/list_parameters", msgs.ListParametersRequest, msgs.ListParametersReply, srv),
            "describe": _Service(part, f"{n}/describe_parameters", msgs.DescribeParametersRequest,
                                 msgs.DescribeParametersReply, srv),
            "types": _Service(part, f"{n}/get_parameter_types", msgs.GetParameterTypesRequest,
                              msgs.GetParameterTypesReply, srv),
        }
        latched = dds.qos_latched()
        self._actions = {}
        for action in ("navigate_to_pose", "navigate_to_goal"):
            a = f"{action}/_action"
            self._actions[action] = {
                "send": _Service(part, f"{a}/send_goal", msgs.NavigateToPoseSendGoalRequest,
                                 msgs.NavigateToPoseSendGoalReply, srv),
                "result": _Service(part, f"{a}/get_result", msgs.NavigateToPoseGetResultRequest,
                                   msgs.NavigateToPoseGetResultReply, srv),
                "cancel": _Service(part, f"{a}/cancel_goal", msgs.CancelGoalRequest, msgs.CancelGoalReply, srv),
                "feedback": self._writer(f"rt/{a}/feedback", msgs.NavigateToPoseFeedbackMessage, srv),
                "status": self._writer(f"rt/{a}/status", msgs.GoalStatusArray, latched),
            }
        from wbc.ros2.discovery import GraphAnnouncement

        self.graph = GraphAnnouncement(part, self.name)  # in `ros2 node list`, with every reader and writer above

    def _writer(self, topic: str, typ, qos):
        from wbc.ros2.endpoints import writer

        return writer(self.part, topic, typ, qos)

    def _rate_changed(self, rate: float) -> None:
        """The publisher's rate, and /odom's history resized to one second of samples (a new writer)."""
        from wbc.ros2 import dds

        self.pub.rate = rate
        depth = history_depth(rate)
        if self._odom_w is None or self._odom_depth != depth:
            self._odom_w = self._writer("rt/odom", self.m.Odometry, dds.qos_stream(depth))
            self._odom_depth = depth

    # -- time --------------------------------------------------------------------------------------------------
    def _time(self, t: float | None = None):
        return self.m.Time(*self.sec_nsec(self.stamp_seconds(t)))

    def _duration(self, s: float):
        return self.m.Duration(*self.sec_nsec(max(0.0, s)))

    def _publish_clock(self) -> None:
        self._clock_w.write(self.m.Clock(self._time()))

    # -- parameters --------------------------------------------------------------------------------------------
    def _value(self, name: str):
        m = self.m
        if name not in self.params:
            return m.ParameterValue()
        v = self.params[name]
        if isinstance(v, bool):
            return m.ParameterValue(type=1, bool_value=v)
        return m.ParameterValue(type=3, double_value=float(v))

    @staticmethod
    def _raw(pv):
        return {1: pv.bool_value, 2: pv.integer_value, 3: pv.double_value, 4: pv.string_value}.get(pv.type)

    def _serve_parameters(self) -> None:
        m, s = self.m, self._psrv
        for req in s["get"].requests():
            s["get"].reply(req, values=[self._value(n) for n in req.names])
        for req in s["types"].requests():
            s["types"].reply(req, types=[PARAMETERS[n][0] if n in PARAMETERS else 0 for n in req.names])
        for req in s["list"].requests():
            names = [n for n in PARAMETERS if not req.prefixes or any(n.startswith(p) for p in req.prefixes)]
            s["list"].reply(req, result=m.ListParametersResult(names=names, prefixes=[]))
        for req in s["describe"].requests():
            out = []
            for n in req.names:
                if n not in PARAMETERS:
                    out.append(m.ParameterDescriptor(name=n))
                    continue
                kind, desc, rng, ro = PARAMETERS[n]
                fr = [m.FloatingPointRange(rng[0], rng[1], 0.0)] if rng else []
                out.append(m.ParameterDescriptor(name=n, type=kind, description=desc, read_only=ro,
                                                 floating_point_range=fr))
            s["describe"].reply(req, descriptors=out)
        for req in s["set"].requests():
            results = []
            for p in req.parameters:
                reason = self.check(p.name, p.value.type, self._raw(p.value))
                if not reason:
                    self.apply(p.name, float(self._raw(p.value)))
                results.append(m.SetParametersResult(successful=not reason, reason=reason))
            s["set"].reply(req, results=results)
        for req in s["atomic"].requests():
            reasons = [self.check(p.name, p.value.type, self._raw(p.value)) for p in req.parameters]
            bad = [r for r in reasons if r]
            if not bad:
                for p in req.parameters:
                    self.apply(p.name, float(self._raw(p.value)))
            s["atomic"].reply(req, result=m.SetParametersResult(successful=not bad, reason="; ".join(bad)))

    # -- actions -----------------------------------------------------------------------------------------------
    def _goals_changed(self) -> None:
        m = self.m
        goals = list(self.finished) + ([self.active] if self.active is not None else [])
        for action, srv in self._actions.items():
            lst = [m.GoalStatus(m.GoalInfo(m.UUID(list(g.uuid)), self._time(g.stamp - self.epoch)), g.status)
                   for g in goals if g.server == action]
            srv["status"].write(m.GoalStatusArray(lst))

    def _goal_ended(self, goal: Goal) -> None:
        result = self.m.NavigateToPoseResult(goal.result_code, goal.result_msg)
        srv = self._actions[goal.server]["result"]
        for req in self._waiting.pop(goal.uuid, []):
            srv.reply(req, status=goal.status, result=result)

    def _send_feedback(self, goal: Goal, fb: dict) -> None:
        m = self.m
        pose = m.PoseStamped(m.Header(self._time(), "odom"), m.Pose(m.Point(*fb["position"]),
                                                                    m.Quaternion(*fb["orientation"])))
        msg = m.NavigateToPoseFeedback(
            current_pose=pose, navigation_time=self._duration(fb["navigation_time"]),
            estimated_time_remaining=self._duration(fb["estimated_time_remaining"]), number_of_recoveries=0,
            distance_remaining=fb["distance_remaining"])
        self._actions[goal.server]["feedback"].write(m.NavigateToPoseFeedbackMessage(m.UUID(list(goal.uuid)), msg))

    def _serve_actions(self) -> None:
        m = self.m
        for action, srv in self._actions.items():
            for req in srv["send"].requests():
                p = req.goal.pose.pose
                target = self.goal_target(p.position.x, p.position.y, p.orientation.x, p.orientation.y,
                                          p.orientation.z, p.orientation.w)
                srv["send"].reply(req, accepted=target is not None, stamp=self._time())
                if target is not None:
                    self.start_goal(bytes(req.goal_id.uuid), action, target)
            for req in srv["result"].requests():
                uid = bytes(req.goal_id.uuid)
                if self.active is not None and self.active.uuid == uid:
                    self._waiting.setdefault(uid, []).append(req)
                    continue
                done = self.finished_goal(uid)
                if done is None:
                    srv["result"].reply(req, status=0, result=m.NavigateToPoseResult(9000, "unknown goal id"))
                else:
                    srv["result"].reply(req, status=done.status,
                                        result=m.NavigateToPoseResult(done.result_code, done.result_msg))
            for req in srv["cancel"].requests():
                uid = bytes(req.goal_info.goal_id.uuid)
                code = self.cancel(uid)
                g = self.active
                canceling = [m.GoalInfo(m.UUID(list(g.uuid)), self._time(g.stamp - self.epoch))] if code == 0 else []
                srv["cancel"].reply(req, return_code=code, goals_canceling=canceling)

    # -- cmd_vel, goal_pose, reset -----------------------------------------------------------------------------
    def _poll(self) -> None:
        samples = [s for s in self._cmd_r.take(N=10) if isinstance(s, self.m.Twist)]
        if samples:
            s = samples[-1]
            self.command_velocity(s.linear.x, s.linear.y, s.angular.z, samples=len(samples))
        for s in self._goal_pose_r.take(N=10):
            if isinstance(s, self.m.PoseStamped):  # RViz2's "2D Goal Pose" tool: a goal of /navigate_to_pose
                p, o = s.pose.position, s.pose.orientation
                self.goal_pose(p.x, p.y, o.x, o.y, o.z, o.w)
        for req in self._reset.requests():
            message = self.reset()
            self.pub.reset()
            self._reset.reply(req, success=True, message=message)
        self._serve_actions()
        self._serve_parameters()

    # -- state -------------------------------------------------------------------------------------------------
    def _publish_state(self) -> None:
        w, m = self.walk, self.m
        self.pub.epoch = self.epoch
        if not self.pub.update(w.q, w.t, v=w.v, effort=w.tau if self.sim else None):
            return
        q, v = w.q, w.v
        odom = m.Odometry(
            m.Header(self._time(), "odom"), self.pub.root,
            m.PoseWithCovariance(m.Pose(m.Point(*map(float, q[:3])), m.Quaternion(*map(float, q[3:7])))),
            m.TwistWithCovariance(m.Twist(m.Vector3(*map(float, v[:3])), m.Vector3(*map(float, v[3:6])))))
        self._odom_w.write(odom)

    def close(self) -> None:
        """Release the DDS entities."""
        self.pub.close()
