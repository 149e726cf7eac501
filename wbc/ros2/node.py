"""A long-running ROS 2 controller node over DDS: /cmd_vel, NavigateToPose actions, parameters, /reset_robot.

:class:`ControllerNode` drives a :class:`wbc.scenarios.commanded_walk.CommandedWalk` (the kinematic walk
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

N is one second of samples at ``update_rate`` (at least 10).

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
  time at the start plus the node time; ``"sim"`` runs as fast as it can, publishes /clock and stamps node time
  from 0.
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

import math
import os
import time
from collections import deque
from collections.abc import Callable

import numpy as np

from wbc.exceptions import InvalidInputError

__all__ = ["ControllerNode", "PARAMETERS"]

# name → (ROS type code, description, (low, high) or None, read only)
PARAMETERS = {
    "update_rate": (3, "publishing rate of /joint_states, /tf and /odom, Hz", (1.0, 500.0), False),
    "step_duration": (3, "single + double support duration of a step, s", (0.4, 3.0), False),
    "max_velocity": (3, "forward walking speed limit (cmd_vel and goals), m/s", (0.01, 1.0), False),
    "cmd_vel_timeout": (3, "no /cmd_vel for this long (s, node time) stops the walk", (0.05, 10.0), False),
    "use_sim_time": (1, "stamps and /clock in simulated time (--time sim)", None, True),
}
_TYPE_NAMES = {1: "bool", 2: "integer", 3: "double", 4: "string"}
PENDING, ACCEPTED, EXECUTING, CANCELING, SUCCEEDED, CANCELED, ABORTED = range(7)
GOAL_TOLERANCE = (0.05, math.radians(5.0))  # m, rad: a goal ends SUCCEEDED within these


def _heap_trimmer():
    """``malloc_trim`` of the C library (returns 1 when memory was released), or None where there is none (a C
    library other than glibc)."""
    import ctypes
    import ctypes.util

    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        trim = libc.malloc_trim
    except (OSError, AttributeError):
        return None
    trim.argtypes, trim.restype = [ctypes.c_size_t], ctypes.c_int
    return trim


def _rss_mb() -> float:
    """Resident set size of this process, MB (Linux /proc/self/statm; nan elsewhere)."""
    import os

    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6
    except (OSError, ValueError):
        return float("nan")


def _yaw(qx, qy, qz, qw) -> float:
    return math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))


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


class _Goal:
    __slots__ = ("uuid", "server", "stamp", "status", "target", "result_code", "result_msg", "started", "waiting")

    def __init__(self, uuid, server, stamp, target, started):
        self.uuid, self.server, self.stamp, self.target, self.started = uuid, server, stamp, target, started
        self.status, self.result_code, self.result_msg = ACCEPTED, 0, ""
        self.waiting = []  # get_result requests to answer when the goal ends


class ControllerNode:
    """The node of the module docstring.

    Args:
        robot: a :class:`wbc.robot.Robot` (free flyer followed by 1-DoF joints).
        time_mode: ``"real"`` or ``"sim"``.
        update_rate: Hz, in [1, 500].
        name: node name (namespace of the parameter services), a ROS name without slashes.
        tf: ``"all"`` or ``"base"`` (:class:`wbc.ros2.publisher.Ros2Publisher`).
        step_duration, max_velocity: initial parameter values (None: the walk's defaults).
        sim: drive the MuJoCo closed loop with the inverse-dynamics controller
            (:class:`wbc.sim.commanded.SimCommandedWalk`, re-planned at each touch-down) instead of the kinematic walk:
            /joint_states carries the applied torques as effort, /odom and /tf the estimated state.
        sim_options: keyword arguments of :class:`~wbc.sim.commanded.SimCommandedWalk` (plant, state, seed, ...).

    Raises:
        InvalidInputError: a bad time mode, rate, name or parameter value.
        wbc.ros2.Ros2UnavailableError: cyclonedds/rosbags missing.
    """

    def __init__(self, robot, *, time_mode: str = "real", update_rate: float = 50.0, name: str = "wbc_node",
                 tf: str = "all", step_duration: float | None = None, max_velocity: float | None = None,
                 sim: bool = False, sim_options: dict | None = None):
        from wbc.ros2 import require

        require()
        if time_mode not in ("real", "sim"):
            raise InvalidInputError(f"time mode {time_mode!r} is invalid: valid are 'real', 'sim'")
        if not name or not name.replace("_", "a").isalnum() or name[0].isdigit():
            raise InvalidInputError(f"node name {name!r} is invalid: letters, digits and '_', not starting with a digit")
        if sim:
            from wbc.sim.commanded import SimCommandedWalk

            self.walk = SimCommandedWalk(robot, **(sim_options or {}))
        else:
            from wbc.scenarios.commanded_walk import CommandedWalk

            self.walk = CommandedWalk(robot)
        self.sim = bool(sim)
        self._was_walking = False
        self._fall_reported = False  # --sim: the current fall was printed (cleared when the robot is up again)
        self._replans_seen = 0  # --sim: touch-down re-plans already printed
        self.robot, self.name, self.time_mode = robot, name, time_mode
        self.params = {"update_rate": float(update_rate), "step_duration": self.walk.step_duration,
                       "max_velocity": self.walk.max_velocity, "cmd_vel_timeout": 0.5,
                       "use_sim_time": time_mode == "sim"}
        for key, value in (("update_rate", update_rate), ("step_duration", step_duration),
                           ("max_velocity", max_velocity)):
            if value is not None:
                reason = self._check(key, 3, value)
                if reason:
                    raise InvalidInputError(reason)
                self._apply(key, float(value))
        self._setup_dds(tf)
        self.finished: deque = deque(maxlen=16)
        self.active: _Goal | None = None
        self._last_cmd_t = None
        self._warned_t = -1e9
        self.ticks = 0
        self.pacer = None
        self.tick_time = deque(maxlen=30000)  # s per tick, a ring of the last minute at 500 Hz
        self.counts = {"cmd_vel": 0, "goals": 0, "resets": 0, "param_sets": 0}
        self.heap_trims, self.last_trim_s = 0, 0.0  # spin(trim_every): malloc_trim calls, s taken by the last

    # -- DDS ---------------------------------------------------------------------------------------------------
    def _setup_dds(self, tf: str) -> None:
        from cyclonedds.core import Policy, Qos
        from cyclonedds.util import duration

        from wbc.ros2 import dds, msgs
        from wbc.ros2.endpoints import reader, writer
        from wbc.ros2.publisher import Ros2Publisher

        self.m = msgs
        self.epoch = time.time() if self.time_mode == "real" else 0.0
        self.pub = Ros2Publisher(self.robot, rate=self.params["update_rate"], tf=tf, dt=self.walk.dt, clock="sim",
                                 epoch=self.epoch)
        part = self.part = self.pub.participant
        depth = max(10, int(self.params["update_rate"]))
        self._odom_w = writer(part, "rt/odom", msgs.Odometry, dds.qos_stream(depth))
        self._clock_w = None
        if self.time_mode == "sim":
            q1 = dds.qos_stream(1)
            self._clock_w = writer(part, "rt/clock", msgs.Clock, q1)
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
                "feedback": writer(part, f"rt/{a}/feedback", msgs.NavigateToPoseFeedbackMessage, srv),
                "status": writer(part, f"rt/{a}/status", msgs.GoalStatusArray, latched),
            }
        from wbc.ros2.discovery import GraphAnnouncement

        self.graph = GraphAnnouncement(part, self.name)  # in `ros2 node list`, with every reader and writer above

    # -- time --------------------------------------------------------------------------------------------------
    def _time(self, t: float | None = None):
        t = self.epoch + (self.walk.t if t is None else t)
        sec = int(math.floor(t))
        return self.m.Time(sec, min(int(round((t - sec) * 1e9)), 999_999_999))

    @staticmethod
    def _duration(s: float):
        from wbc.ros2 import msgs

        s = max(0.0, s)
        return msgs.Duration(int(s), min(int(round((s - int(s)) * 1e9)), 999_999_999))

    # -- parameters --------------------------------------------------------------------------------------------
    def _check(self, name: str, ptype: int, value) -> str:
        """'' if ``value`` (of ROS type code ``ptype``) may be set on ``name``, else the reason."""
        if name not in PARAMETERS:
            return f"parameter {name!r} does not exist; valid: {sorted(PARAMETERS)}"
        kind, _, rng, read_only = PARAMETERS[name]
        if read_only:
            return f"parameter {name!r} is read-only"
        if kind == 3 and ptype not in (2, 3):
            return f"parameter {name!r} is a double; got a {_TYPE_NAMES.get(ptype, ptype)}"
        if not (isinstance(value, (int, float)) and math.isfinite(value)) or not rng[0] <= value <= rng[1]:
            return f"{name} = {value!r} is out of range: valid is [{rng[0]:g}, {rng[1]:g}]"
        return ""

    def _apply(self, name: str, value: float) -> None:
        self.params[name] = value
        if name == "update_rate":
            if getattr(self, "pub", None) is not None:
                self.pub.rate = value
        elif name == "step_duration":
            self.walk.step_duration = value
        elif name == "max_velocity":
            self.walk.max_velocity = value

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
                reason = self._check(p.name, p.value.type, self._raw(p.value))
                if not reason:
                    self._apply(p.name, float(self._raw(p.value)))
                    self.counts["param_sets"] += 1
                    print(f"parameter {p.name} = {self.params[p.name]:g}", flush=True)
                results.append(m.SetParametersResult(successful=not reason, reason=reason))
            s["set"].reply(req, results=results)
        for req in s["atomic"].requests():
            reasons = [self._check(p.name, p.value.type, self._raw(p.value)) for p in req.parameters]
            bad = [r for r in reasons if r]
            if not bad:
                for p in req.parameters:
                    self._apply(p.name, float(self._raw(p.value)))
            s["atomic"].reply(req, result=m.SetParametersResult(successful=not bad, reason="; ".join(bad)))

    # -- actions -----------------------------------------------------------------------------------------------
    def _publish_status(self) -> None:
        m = self.m
        goals = list(self.finished) + ([self.active] if self.active is not None else [])
        for action, srv in self._actions.items():
            lst = [m.GoalStatus(m.GoalInfo(m.UUID(list(g.uuid)), g.stamp), g.status) for g in goals
                   if g.server == action]
            srv["status"].write(m.GoalStatusArray(lst))

    def _end(self, goal: _Goal, status: int, code: int, msg: str) -> None:
        goal.status, goal.result_code, goal.result_msg = status, code, msg
        result = self.m.NavigateToPoseResult(code, msg)
        srv = self._actions[goal.server]["result"]
        for req in goal.waiting:
            srv.reply(req, status=status, result=result)
        goal.waiting = []
        self.finished.append(goal)
        if self.active is goal:
            self.active = None
        print(f"goal {bytes(goal.uuid).hex()[:8]} {['', '', '', '', 'SUCCEEDED', 'CANCELED', 'ABORTED'][status]}: "
              f"{msg}", flush=True)
        self._publish_status()

    def _start_goal(self, uuid: bytes, action: str, stamp, target) -> None:
        self.counts["goals"] += 1
        if self.active is not None:
            self._end(self.active, ABORTED, 9000, "pre-empted by a new goal")
        goal = _Goal(uuid, action, stamp, target, self.walk.t)
        self.active = goal
        self.walk.set_goal(*target)
        self._failures0 = self.walk.replan_failures
        goal.status = EXECUTING
        print(f"goal {goal.uuid.hex()[:8]} on /{action}: x {target[0]:.3f} m, y {target[1]:.3f} m, "
              f"yaw {math.degrees(target[2]):.1f} deg", flush=True)
        self._publish_status()

    def _serve_actions(self) -> None:
        m = self.m
        for action, srv in self._actions.items():
            for req in srv["send"].requests():
                p = req.goal.pose.pose
                target = (p.position.x, p.position.y, _yaw(p.orientation.x, p.orientation.y, p.orientation.z,
                                                           p.orientation.w))
                ok = all(math.isfinite(v) for v in target)
                stamp = self._time()
                srv["send"].reply(req, accepted=ok, stamp=stamp)
                if not ok:
                    continue
                self._start_goal(bytes(req.goal_id.uuid), action, stamp, target)
            for req in srv["result"].requests():
                uid = bytes(req.goal_id.uuid)
                if self.active is not None and self.active.uuid == uid:
                    self.active.waiting.append(req)
                    continue
                done = next((g for g in self.finished if g.uuid == uid), None)
                if done is None:
                    srv["result"].reply(req, status=0, result=m.NavigateToPoseResult(9000, "unknown goal id"))
                else:
                    srv["result"].reply(req, status=done.status,
                                        result=m.NavigateToPoseResult(done.result_code, done.result_msg))
            for req in srv["cancel"].requests():
                uid = bytes(req.goal_info.goal_id.uuid)
                g = self.active
                if g is not None and g.status == EXECUTING and (uid == bytes(16) or uid == g.uuid):
                    g.status = CANCELING
                    self.walk.stop()
                    srv["cancel"].reply(req, return_code=0, goals_canceling=[m.GoalInfo(m.UUID(list(g.uuid)),
                                                                                       g.stamp)])
                    print(f"goal {g.uuid.hex()[:8]} canceling at t = {self.walk.t:.3f} s", flush=True)
                    self._publish_status()
                elif any(f.uuid == uid for f in self.finished):
                    srv["cancel"].reply(req, return_code=3, goals_canceling=[])
                else:
                    srv["cancel"].reply(req, return_code=2, goals_canceling=[])

    def _goal_progress(self) -> None:
        g, w = self.active, self.walk
        if g is None:
            return
        x, y, yaw = w.base_pose()
        dist = math.hypot(g.target[0] - x, g.target[1] - y)
        if not w.idle:
            return
        dyaw = abs((g.target[2] - yaw + math.pi) % (2 * math.pi) - math.pi)
        where = f"base at x {x:.4f} m, y {y:.4f} m, yaw {math.degrees(yaw):.2f} deg"
        err = f"position error {dist:.4f} m, heading error {math.degrees(dyaw):.2f} deg"
        if g.status == CANCELING:
            self._end(g, CANCELED, 0, f"canceled: standing in double support, {where}")
        elif w.replan_failures > self._failures0 and dist > GOAL_TOLERANCE[0]:
            self._end(g, ABORTED, 9000, f"cannot plan the walk: {w.last_error}")
        elif dist <= GOAL_TOLERANCE[0] and dyaw <= GOAL_TOLERANCE[1]:
            self._end(g, SUCCEEDED, 0, f"reached: {err}; {where}")
        else:
            self._end(g, ABORTED, 9000, f"stopped off the goal: {err}; {where}")

    def _feedback(self) -> None:
        g, m, w = self.active, self.m, self.walk
        if g is None:
            return
        x, y, _ = w.footprint_pose()
        q = w.q
        pose = m.PoseStamped(m.Header(self._time(), "odom"), m.Pose(m.Point(*map(float, q[:3])),
                                                                    m.Quaternion(*map(float, q[3:7]))))
        fb = m.NavigateToPoseFeedback(
            current_pose=pose, navigation_time=self._duration(w.t - g.started),
            estimated_time_remaining=self._duration(w.time_remaining()), number_of_recoveries=0,
            distance_remaining=float(math.hypot(g.target[0] - x, g.target[1] - y)))
        self._actions[g.server]["feedback"].write(m.NavigateToPoseFeedbackMessage(m.UUID(list(g.uuid)), fb))

    # -- cmd_vel, reset ----------------------------------------------------------------------------------------
    def _serve_commands(self) -> None:
        w = self.walk
        samples = [s for s in self._cmd_r.take(N=10) if isinstance(s, self.m.Twist)]
        if samples:
            s = samples[-1]
            cmd = np.array([s.linear.x, s.linear.y, s.angular.z], dtype=float)
            lim = np.array([w.max_velocity, w.max_lateral, w.max_turn])
            low = -lim
            low[0] = -getattr(w, "max_backward", w.max_velocity)  # the physics walk plans no backward step
            if not np.isfinite(cmd).all():
                print("cmd_vel ignored: non-finite value", flush=True)
            else:
                if (np.any(cmd > lim) or np.any(cmd < low)) and w.t - self._warned_t > 1.0:
                    self._warned_t = w.t
                    print(f"cmd_vel (vx, vy, wz) = {cmd.round(3).tolist()} beyond the limits "
                          f"[{low.round(3).tolist()}, {lim.round(3).tolist()}]: saturated", flush=True)
                cmd = np.clip(cmd, low, lim)
                self.counts["cmd_vel"] += len(samples)
                if self.active is not None and np.any(cmd):
                    self._end(self.active, ABORTED, 9000, "overridden by /cmd_vel")
                if self.active is None:
                    w.set_velocity(*cmd)
                    self._last_cmd_t = w.t
        for s in self._goal_pose_r.take(N=10):
            if isinstance(s, self.m.PoseStamped):  # RViz2's "2D Goal Pose" tool: a goal of /navigate_to_pose
                o = s.pose.orientation
                target = (s.pose.position.x, s.pose.position.y, _yaw(o.x, o.y, o.z, o.w))
                if all(math.isfinite(v) for v in target):
                    self._start_goal(os.urandom(16), "navigate_to_pose", self._time(), target)
        if self._last_cmd_t is not None and w.t - self._last_cmd_t > self.params["cmd_vel_timeout"]:
            self._last_cmd_t = None
            if self.active is None:
                w.set_velocity(0.0, 0.0, 0.0)
        for req in self._reset.requests():
            self.counts["resets"] += 1
            if self.active is not None:
                self._end(self.active, ABORTED, 9000, "robot reset")
            w.reset()
            self.pub.reset()
            self._reset.reply(req, success=True, message=f"robot reset to its reference stance "
                                                         f"(reset {self.counts['resets']})")
            print(f"/reset_robot: reset {self.counts['resets']}", flush=True)

    # -- loop --------------------------------------------------------------------------------------------------
    def _publish_state(self) -> None:
        w, m = self.walk, self.m
        if not self.pub.update(w.q, w.t, v=w.v, effort=w.tau if self.sim else None):
            return
        q, v = w.q, w.v
        odom = m.Odometry(
            m.Header(self._time(), "odom"), self.pub.root,
            m.PoseWithCovariance(m.Pose(m.Point(*map(float, q[:3])), m.Quaternion(*map(float, q[3:7])))),
            m.TwistWithCovariance(m.Twist(m.Vector3(*map(float, v[:3])), m.Vector3(*map(float, v[3:6])))))
        self._odom_w.write(odom)

    def spin(self, duration: float | None = None, report_every: float | None = None,
             trim_every: float | None = 10.0, interrupted: Callable[[], bool] | None = None) -> None:
        """Run until ``duration`` s of node time (None: until KeyboardInterrupt).

        ``report_every`` (s of node time): print a line with the tick time p50/p99 (µs) of the last
        ``report_every`` s and the resident memory (MB, /proc/self/statm) at that period.
        ``trim_every`` (s of node time, > 0; None: never): period of the heap trim of the module docstring
        ("Memory"), done after a tick's messages are published and timed within that tick.
        ``interrupted``: called before every tick; True raises KeyboardInterrupt there (a Ctrl-C whose
        KeyboardInterrupt a C callback swallowed, e.g. during the kernels' first compile, still stops the node).

        Raises:
            InvalidInputError: ``trim_every`` not a number > 0 (or None).

        Per control tick (``dt`` = 2 ms): every 5th tick the subscriptions and services are served and /clock is
        published (``--time sim``); one walk tick; /joint_states, /tf, /odom at ``update_rate``; action feedback
        every 0.1 s; with real time, a wait until the tick is due on the wall clock.
        """
        if trim_every is not None and (isinstance(trim_every, bool) or not isinstance(trim_every, (int, float))
                                       or not trim_every > 0 or not math.isfinite(trim_every)):
            raise InvalidInputError(f"trim_every must be a number of seconds > 0 or None; got {trim_every!r}")
        trim = None if trim_every is None else _heap_trimmer()
        trim_ticks = None if trim is None else max(1, int(round(trim_every / self.walk.dt)))
        pacer = None
        if self.time_mode == "real":
            from wbc.viz.live import RealTimePacer

            pacer = RealTimePacer()
        self.pacer = pacer  # (late_ticks: ticks that found the loop > 0.1 s behind the wall clock; re-anchored)
        self._publish_status()
        w = self.walk
        poll = 5
        fb_every = int(round(0.1 / w.dt))
        rep_every = None if report_every is None else max(1, int(round(report_every / w.dt)))
        window = deque(maxlen=rep_every or 1)
        window_cpu = deque(maxlen=rep_every or 1)  # the tick's thread CPU time: what load on the machine leaves out
        while duration is None or w.t < duration - 1e-9:
            if interrupted is not None and interrupted():
                raise KeyboardInterrupt
            t0 = time.perf_counter()
            c0 = time.thread_time()
            if self.ticks % poll == 0:
                if self._clock_w is not None:
                    self._clock_w.write(self.m.Clock(self._time()))
                self._serve_commands()
                self._serve_actions()
                self._serve_parameters()
            w.tick()
            self.ticks += 1
            if self.sim:
                self._report_sim()
            self._publish_state()
            if self.active is not None:
                if self.ticks % fb_every == 0:
                    self._feedback()
                self._goal_progress()
            if trim_ticks is not None and self.ticks % trim_ticks == 0:
                t_trim = time.perf_counter()
                trim(0)
                self.heap_trims += 1
                self.last_trim_s = time.perf_counter() - t_trim
            dt_tick = time.perf_counter() - t0
            self.tick_time.append(dt_tick)
            if rep_every is not None:
                window.append(dt_tick)
                window_cpu.append(time.thread_time() - c0)
                if self.ticks % rep_every == 0:
                    tt = np.asarray(window) * 1e6
                    tc = np.asarray(window_cpu) * 1e6
                    print(f"stats: node time {w.t:.1f} s, tick p50 {np.percentile(tt, 50):.0f} µs "
                          f"p99 {np.percentile(tt, 99):.0f} µs (CPU p50 {np.percentile(tc, 50):.0f} µs "
                          f"p99 {np.percentile(tc, 99):.0f} µs), RSS {_rss_mb():.1f} MB, replans {w.replans}, "
                          f"replan failures {w.replan_failures}, heap trims {self.heap_trims} (last "
                          f"{1e3 * self.last_trim_s:.1f} ms)", flush=True)
            if pacer is not None:
                pacer.wait(w.t)

    def _report_sim(self) -> None:
        """--sim: print the plant's ground truth beside the estimate when a walking segment starts and when the
        robot stands again (and once on a fall): the independent check of /odom."""
        w = self.walk
        walking = w.walking
        if walking != self._was_walking:
            self._was_walking = walking
            print(f"sim: {'walking' if walking else 'standing'} at t = {w.t:.3f} s; " + self.sim_state(), flush=True)
        if walking and w.touchdown_replans != self._replans_seen:
            self._replans_seen = w.touchdown_replans
            print(f"sim: re-planned at a touch-down at t = {w.t:.3f} s ({w.last_replan}); " + self.sim_state(),
                  flush=True)
        if w.fell and not self._fall_reported:
            self._fall_reported = True
            print(f"sim: FELL at t = {w.t:.3f} s ({w.monitor.fall_reason}); /reset_robot to restart", flush=True)
        elif not w.fell:
            self._fall_reported = False  # after /reset_robot: the next fall is printed too

    def sim_state(self) -> str:
        """--sim: one line with the plant's ground-truth base (x, y, yaw), the estimate's, and the feet's normal
        forces (MuJoCo contacts, N)."""
        w = self.walk
        qt = w.q_true
        yt = _yaw(*qt[3:7])
        x, y, yaw = w.base_pose()
        feet = ", ".join(f"{s} {f[2]:.1f} N" for s, f in w.sim.foot_contact_forces().items())
        return (f"ground truth base x {qt[0]:.4f} m, y {qt[1]:.4f} m, yaw {math.degrees(yt):.2f} deg; "
                f"estimate x {x:.4f} m, y {y:.4f} m, yaw {math.degrees(yaw):.2f} deg; feet normal force {feet}")

    def close(self) -> None:
        """Release the DDS entities."""
        self.pub.close()
