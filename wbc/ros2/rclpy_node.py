"""The controller node as a real ROS 2 node (rclpy): the rclpy transport of :class:`wbc.ros2.node_core.NodeCore`.

:class:`RclpyNode` offers the interfaces of :mod:`wbc.ros2.node` (same names, types and behaviour, written once in
the core) through rclpy, so it runs on whatever RMW the user's ROS 2 runs (Fast DDS by default, Cyclone DDS,
Zenoh), is listed in the ROS graph (``ros2 node list``), and its services and actions answer every client:

* parameters through rclpy's parameter API: each declared with a ``ParameterDescriptor`` (description, floating
  point range, read-only); rclpy refuses a value outside the range or of another type with its own reason; a pre-set
  callback turns an integer into a double for the double parameters (as the DDS node accepts it); the set-parameters
  callback refuses with the core's reasons (``use_sim_time`` is read-only: fixed by ``--time``); a post-set
  callback applies the values. ``ros2 param list/get/set/describe`` work as on any node.
* ``/reset_robot`` (``std_srvs/srv/Trigger``) a service; NavigateToPose through rclpy's ``ActionServer`` on
  ``/navigate_to_pose`` and ``/navigate_to_goal`` (goal → feedback → SUCCEEDED; cancel → CANCELED; a new goal
  pre-empts the active one, which ends ABORTED);
* ``use_sim_time`` is the node's parameter (True with ``--time sim``, when the node publishes /clock and rclpy's
  clock of the node follows it).

Message packages: ``sensor_msgs``, ``geometry_msgs``, ``nav_msgs``, ``std_msgs``, ``std_srvs``, ``rosgraph_msgs``
are needed (any ROS 2 install, or the ``ros-*`` wheels). ``tf2_msgs`` and ``nav2_msgs`` are optional: without
``tf2_msgs`` /tf and /tf_static are not published, without ``nav2_msgs`` the NavigateToPose actions are not offered
(/goal_pose still starts goals); each absence is one line on stdout naming the package and the fallback.

The executor runs in the control loop's thread, one ``spin_once`` without waiting per tick (at most one callback:
500 per second, far more than the node's inputs bring), so callbacks never run concurrently with a tick. It is
rclpy's ``EventsExecutor`` (``rclpy.experimental``, C++) where the installed rclpy has it, else the
``SingleThreadedExecutor``, whose ``spin_once`` rebuilds its wait set in Python (several times the cost, paid every
tick; benchmarks/records/31).
"""

from __future__ import annotations

from wbc.ros2.node_core import ABORTED, CANCELED, PARAMETERS, SUCCEEDED, Goal, NodeCore

__all__ = ["RclpyNode", "rclpy_available", "navigate_to_pose_type"]

_RCLPY_TYPES = {1: "PARAMETER_BOOL", 2: "PARAMETER_INTEGER", 3: "PARAMETER_DOUBLE", 4: "PARAMETER_STRING"}


def rclpy_available() -> bool:
    """True when rclpy and the message packages the node needs import (a sourced ROS 2, or the ``ros-*`` wheels)."""
    try:
        import geometry_msgs.msg  # noqa: F401
        import nav_msgs.msg  # noqa: F401
        import rclpy  # noqa: F401
        import rosgraph_msgs.msg  # noqa: F401
        import sensor_msgs.msg  # noqa: F401
        import std_srvs.srv  # noqa: F401
    except ImportError:
        return False
    return True


def navigate_to_pose_type():
    """``nav2_msgs.action.NavigateToPose``, or None after printing one line naming the package and the fallback."""
    try:
        from nav2_msgs.action import NavigateToPose
    except ImportError:
        print("rclpy backend: package nav2_msgs not found: no NavigateToPose action servers (/goal_pose still "
              "starts goals; source a ROS 2 install with Nav2's messages, or use --backend dds)", flush=True)
        return None
    return NavigateToPose


def _executor(context):
    """rclpy's EventsExecutor (C++; ``rclpy.experimental`` in the Jazzy and Kilted wheels) when it imports, else the
    SingleThreadedExecutor (module docstring)."""
    try:
        from rclpy.experimental import EventsExecutor
    except ImportError:
        from rclpy.executors import SingleThreadedExecutor

        return SingleThreadedExecutor(context=context)
    return EventsExecutor(context=context)


class RclpyNode(NodeCore):
    """The node of the module docstring (arguments of :class:`~wbc.ros2.node_core.NodeCore`, plus ``tf``).

    Args:
        tf: ``"all"`` (odom → root link plus every link) or ``"base"`` (odom → root link only).

    Raises:
        InvalidInputError: a bad time mode, rate, name, tf mode or parameter value.
        wbc.ros2.Ros2UnavailableError: rclpy or a message package it needs does not import.
    """

    def __init__(self, robot, *, tf: str = "all", **core):
        from wbc.exceptions import InvalidInputError
        from wbc.ros2 import Ros2UnavailableError

        if tf not in ("all", "base"):
            raise InvalidInputError(f"tf mode {tf!r} is invalid: valid are ('all', 'base')")
        if not rclpy_available():
            raise Ros2UnavailableError("the rclpy backend needs rclpy and the ROS 2 message packages (source a ROS 2 "
                                       "install, or pip install the ros-* wheels); or use --backend dds")
        super().__init__(robot, **core)
        import rclpy
        from rclpy.node import Node
        from rclpy.parameter import Parameter

        from wbc.ros2.rclpy_publisher import RclpyPublisher

        self._action_type = navigate_to_pose_type()
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = Node(self.name, context=self.context,
                         parameter_overrides=[Parameter("use_sim_time", value=self.time_mode == "sim")])
        self.executor = _executor(self.context)
        self.executor.add_node(self.node)
        self.pub = RclpyPublisher(self.node, robot, rate=self.params["update_rate"], tf=tf, odom=True)
        self._cmd = None  # (last Twist, samples) since the last poll
        self._open_topics()
        self._declare_parameters()
        self._open_actions()

    # -- set-up ------------------------------------------------------------------------------------------------
    def _open_topics(self) -> None:
        from geometry_msgs.msg import PoseStamped, Twist
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        from rosgraph_msgs.msg import Clock
        from std_srvs.srv import Trigger

        n = self.node
        self._clock = n.create_publisher(Clock, "/clock", 1) if self.time_mode == "sim" else None
        best_effort = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
        n.create_subscription(Twist, "/cmd_vel", self._on_cmd_vel, best_effort)
        n.create_subscription(PoseStamped, "/goal_pose", self._on_goal_pose, best_effort)
        n.create_service(Trigger, "/reset_robot", self._on_reset)

    def _rate_changed(self, rate: float) -> None:
        self.pub.set_rate(rate)

    def _declare_parameters(self) -> None:
        from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor, ParameterType

        for name, (kind, desc, rng, read_only) in PARAMETERS.items():
            if name == "use_sim_time":  # declared by rclpy itself; kept read-only by _on_set
                continue
            d = ParameterDescriptor(name=name, type=getattr(ParameterType, _RCLPY_TYPES[kind]), description=desc,
                                    read_only=read_only)
            if rng is not None:
                d.floating_point_range = [FloatingPointRange(from_value=rng[0], to_value=rng[1], step=0.0)]
            self.node.declare_parameter(name, float(self.params[name]), d)
        self.node.add_pre_set_parameters_callback(self._pre_set)
        self.node.add_on_set_parameters_callback(self._on_set)
        self.node.add_post_set_parameters_callback(self._post_set)

    def _open_actions(self) -> None:
        from rclpy.action import ActionServer

        action_type = self._action_type
        self._servers = []
        if action_type is None:
            return
        for action in ("navigate_to_pose", "navigate_to_goal"):
            self._servers.append(ActionServer(
                self.node, action_type, f"/{action}", execute_callback=self._execute,
                goal_callback=self._on_goal, handle_accepted_callback=lambda h, a=action: self._accepted(h, a),
                cancel_callback=self._on_cancel))

    # -- parameters --------------------------------------------------------------------------------------------
    @staticmethod
    def _pre_set(parameters):
        """An integer for a double parameter becomes that double (rclpy would refuse the type)."""
        from rclpy.parameter import Parameter

        out = []
        for p in parameters:
            if p.name in PARAMETERS and PARAMETERS[p.name][0] == 3 and p.type_ == Parameter.Type.INTEGER:
                p = Parameter(p.name, Parameter.Type.DOUBLE, float(p.value))
            out.append(p)
        return out

    def _on_set(self, parameters):
        from rcl_interfaces.msg import SetParametersResult

        for p in parameters:
            reason = self.check(p.name, int(p.type_), p.value)
            if reason:
                return SetParametersResult(successful=False, reason=reason)
        return SetParametersResult(successful=True)

    def _post_set(self, parameters) -> None:
        for p in parameters:
            if p.name in PARAMETERS and not PARAMETERS[p.name][3]:
                self.apply(p.name, float(p.value))

    # -- callbacks (run in the loop's thread, from _poll) ------------------------------------------------------
    def _on_cmd_vel(self, msg) -> None:
        self._cmd = (msg, 1 if self._cmd is None else self._cmd[1] + 1)

    def _on_goal_pose(self, msg) -> None:
        p, o = msg.pose.position, msg.pose.orientation
        self.goal_pose(p.x, p.y, o.x, o.y, o.z, o.w)

    def _on_reset(self, request, response):
        response.message = self.reset()
        self.pub.reset()
        response.success = True
        return response

    def _on_goal(self, request):
        from rclpy.action import GoalResponse

        return GoalResponse.ACCEPT if self._target(request) is not None else GoalResponse.REJECT

    def _target(self, request):
        p = request.pose.pose
        return self.goal_target(p.position.x, p.position.y, p.orientation.x, p.orientation.y, p.orientation.z,
                                p.orientation.w)

    def _accepted(self, handle, action: str) -> None:
        from rclpy.task import Future

        done = Future()
        self.start_goal(bytes(handle.goal_id.uuid), action, self._target(handle.request), handle=(handle, done))
        handle.execute()

    def _on_cancel(self, handle):
        from rclpy.action import CancelResponse

        return CancelResponse.ACCEPT if self.cancel(bytes(handle.goal_id.uuid)) == 0 else CancelResponse.REJECT

    async def _execute(self, handle):
        goal = self.active if self.active is not None and self.active.uuid == bytes(handle.goal_id.uuid) else \
            self.finished_goal(bytes(handle.goal_id.uuid))
        await goal.handle[1]
        {SUCCEEDED: handle.succeed, CANCELED: handle.canceled, ABORTED: handle.abort}[goal.status]()
        result = self._action_type.Result()
        result.error_code, result.error_msg = goal.result_code, goal.result_msg
        return result

    def _goal_ended(self, goal: Goal) -> None:
        if goal.handle is not None:
            goal.handle[1].set_result(goal.status)

    def _send_feedback(self, goal: Goal, fb: dict) -> None:
        if goal.handle is None:
            return
        msg = self._action_type.Feedback()
        pose = msg.current_pose
        pose.header.frame_id = "odom"
        pose.header.stamp.sec, pose.header.stamp.nanosec = self.sec_nsec(self.stamp_seconds())
        pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = fb["position"]
        o = pose.pose.orientation
        o.x, o.y, o.z, o.w = fb["orientation"]
        for key in ("navigation_time", "estimated_time_remaining"):
            field = getattr(msg, key)
            field.sec, field.nanosec = self.sec_nsec(fb[key])
        msg.distance_remaining = fb["distance_remaining"]
        goal.handle[0].publish_feedback(msg)

    # -- loop hooks --------------------------------------------------------------------------------------------
    def _spin_some(self) -> None:
        self.executor.spin_once(timeout_sec=0.0)

    def _poll(self) -> None:
        self.executor.spin_once(timeout_sec=0.0)
        if self._cmd is not None:
            msg, n = self._cmd
            self._cmd = None
            self.command_velocity(msg.linear.x, msg.linear.y, msg.angular.z, samples=n)

    def _publish_clock(self) -> None:
        from rosgraph_msgs.msg import Clock

        msg = Clock()
        msg.clock.sec, msg.clock.nanosec = self.sec_nsec(self.stamp_seconds())
        self._clock.publish(msg)

    def _publish_state(self) -> None:
        w = self.walk
        self.pub.epoch = self.epoch
        self.pub.update(w.q, w.t, v=w.v, effort=w.tau if self.sim else None)

    def close(self) -> None:
        """Destroy the node and shut its rclpy context down."""
        self.pub.close()
        for server in self._servers:
            server.destroy()
        self.executor.shutdown(timeout_sec=0.0)
        self.node.destroy_node()
        if self.context.ok():
            self.context.try_shutdown()
