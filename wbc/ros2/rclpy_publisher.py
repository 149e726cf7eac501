"""The robot's state on ROS 2 through rclpy: /joint_states, /tf, /tf_static, /robot_description (and /odom).

:class:`RclpyPublisher` is the rclpy counterpart of :class:`wbc.ros2.publisher.Ros2Publisher` (same topics, frames
and stamps; the viewer interface ``update(q, t)``), publishing through an rclpy node the caller owns: the controller
node (:class:`wbc.ros2.rclpy_node.RclpyNode`), ``wbc ros2 joint-publisher`` and ``wbc walk --ros2`` with the rclpy
backend. Without the ``tf2_msgs`` package /tf and /tf_static are not published (one line says so, see
:func:`tf_message_type`).

QoS: /joint_states, /tf, /odom reliable, volatile, keep last one second of samples (:func:`history_depth`, re-created
when :attr:`RclpyPublisher.rate` changes through :meth:`RclpyPublisher.set_rate`); /tf_static and
/robot_description reliable, transient local, keep last 1 (late joiners get them).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from wbc.exceptions import InvalidInputError
from wbc.ros2.node_core import history_depth

__all__ = ["RclpyPublisher", "tf_message_type"]


def tf_message_type():
    """``tf2_msgs.msg.TFMessage``, or None after printing one line naming the package and the fallback."""
    try:
        from tf2_msgs.msg import TFMessage
    except ImportError:
        print("rclpy backend: package tf2_msgs not found: /tf and /tf_static are not published (source a ROS 2 "
              "install that has it, or use --backend dds)", flush=True)
        return None
    return TFMessage


class RclpyPublisher:
    """Publish ``q`` (Pinocchio order, free flyer first, quaternion xyzw) through the rclpy ``node``.

    Args:
        node: an ``rclpy.node.Node``.
        robot: a :class:`wbc.robot.Robot` (1-DoF joints after the free flyer).
        rate: publishing rate, Hz, in (0, 500].
        tf: ``"all"`` (odom → root link plus every link) or ``"base"`` (odom → root link only).
        odom: also publish ``nav_msgs/msg/Odometry`` on /odom (odom → root link, twist from ``v``).
        epoch: s added to the run's time ``t`` in stamps (0: stamps are ``t``, as under /clock).

    Raises:
        InvalidInputError: a bad rate or tf mode, or a robot with other than 1-DoF joints after the free flyer.
    """

    def __init__(self, node, robot, *, rate: float = 50.0, tf: str = "all", odom: bool = False, epoch: float = 0.0):
        import pinocchio as pin
        from nav_msgs.msg import Odometry
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState
        from std_msgs.msg import String

        from wbc.ros2.publisher import link_tree

        if isinstance(rate, bool) or not (isinstance(rate, (int, float)) and 0 < rate <= 500):
            raise InvalidInputError(f"ros2 rate {rate!r} Hz is invalid: valid is 0 < rate <= 500")
        if tf not in ("all", "base"):
            raise InvalidInputError(f"tf mode {tf!r} is invalid: valid are ('all', 'base')")
        model = robot.model
        if model.nq - 7 != model.nv - 6 or model.nq - 7 != len(robot.joint_names):
            raise InvalidInputError("RclpyPublisher needs a free flyer followed by 1-DoF joints only")
        self.node, self.robot, self._pin = node, robot, pin
        self.model, self.data = model, model.createData()
        self.names = list(robot.joint_names)
        self.root, edges, _ = link_tree(model)
        if tf == "base":
            edges = [e for e in edges if not e[2]]
        self.moving = [(p, c) for p, c, moves in edges if moves]
        self.static = [(p, c) for p, c, moves in edges if not moves]
        self.epoch, self.odom = float(epoch), bool(odom)
        self.tf_type = tf_message_type()
        self.rate = 0.0
        self._pubs: dict = {}
        self.set_rate(float(rate))
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
        self._latched = [node.create_publisher(String, "/robot_description", latched)]
        self._latched[0].publish(String(data=Path(robot.urdf_path).read_text()))
        if self.tf_type is not None:
            self._latched.append(node.create_publisher(self.tf_type, "/tf_static", latched))
            pin.framesForwardKinematics(model, self.data, robot.q_ref)
            self._latched[1].publish(self.tf_type(transforms=self._pairs(self.static, self._stamp(0.0))))
        # the published messages, built once and refilled in place (building ~30 TransformStamped per publication
        # cost ~0.3 ms of CPU, most of a publication; rclpy serialises a message when it is published)
        self._js = JointState(name=self.names)
        self._js.header.frame_id = self.root
        self._odom_msg = Odometry() if self.odom else None
        if self._odom_msg is not None:
            self._odom_msg.header.frame_id, self._odom_msg.child_frame_id = "odom", self.root
        self._tf_msg = None
        if self.tf_type is not None:
            names = [("odom", self.root)] + [(model.frames[p].name, model.frames[c].name) for p, c in self.moving]
            identity = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
            self._tf_msg = self.tf_type(transforms=[self._transform((0, 0), p, c, identity) for p, c in names])
        self._next_t = None
        self.published = 0
        self.write_time = 0.0
        self.span_wall = self.span_run = (0.0, 0.0)  # (first, last) publication: perf_counter s, stamp s

    def set_rate(self, rate: float) -> None:
        """Publish at ``rate`` Hz; the streams' history is re-created when one second of samples changes size."""
        from nav_msgs.msg import Odometry
        from sensor_msgs.msg import JointState

        self.rate = float(rate)
        depth = history_depth(rate)
        if self._pubs.get("depth") == depth:
            return
        for key, pub in self._pubs.items():
            if key != "depth" and pub is not None:
                self.node.destroy_publisher(pub)
        n = self.node
        self._pubs = {"depth": depth, "joint_states": n.create_publisher(JointState, "/joint_states", depth),
                      "odom": n.create_publisher(Odometry, "/odom", depth) if self.odom else None,
                      "tf": None if self.tf_type is None else n.create_publisher(self.tf_type, "/tf", depth)}

    @property
    def depth(self) -> int:
        """History depth of /joint_states, /tf and /odom (samples)."""
        return self._pubs["depth"]

    def _stamp(self, t: float) -> tuple[int, int]:
        s = self.epoch + t
        sec = int(np.floor(s))
        return sec, min(int(round((s - sec) * 1e9)), 999_999_999)

    @staticmethod
    def _transform(stamp, parent: str, child: str, xyzquat):
        from geometry_msgs.msg import TransformStamped

        ts = TransformStamped()
        ts.header.stamp.sec, ts.header.stamp.nanosec = stamp
        ts.header.frame_id, ts.child_frame_id = parent, child
        tr, rot = ts.transform.translation, ts.transform.rotation
        tr.x, tr.y, tr.z, rot.x, rot.y, rot.z, rot.w = (float(v) for v in xyzquat)
        return ts

    def _pairs(self, pairs, stamp) -> list:
        """parent → child transforms of ``pairs`` (frame ids) from the last forward kinematics."""
        pin, frames, oMf = self._pin, self.model.frames, self.data.oMf
        return [self._transform(stamp, frames[p].name, frames[c].name, pin.SE3ToXYZQUAT(oMf[p].actInv(oMf[c])))
                for p, c in pairs]

    def update(self, q: np.ndarray, t: float | None = None, v: np.ndarray | None = None,
               effort: np.ndarray | None = None) -> bool:
        """Publish ``q`` (nq) at run time ``t`` (s; None: the wall clock) if the period has elapsed; returns True
        if published. ``v`` (nv, default zero) fills JointState.velocity and /odom's twist; ``effort`` (nv − 6,
        N·m) JointState.effort."""
        if t is None:
            t = time.time() - self.epoch
        if self._next_t is not None and t < self._next_t - 1e-9:
            return False
        self._next_t = t + 1.0 / self.rate if self._next_t is None else max(self._next_t + 1.0 / self.rate, t)
        t0 = time.perf_counter()
        q = np.asarray(q, dtype=float)
        v = np.zeros(self.model.nv) if v is None else np.asarray(v, dtype=float)
        stamp = self._stamp(t)
        js = self._js
        js.header.stamp.sec, js.header.stamp.nanosec = stamp
        js.position = q[7:].tolist()
        js.velocity = v[6:].tolist()
        js.effort = [] if effort is None else np.asarray(effort, dtype=float).tolist()
        self._pubs["joint_states"].publish(js)
        if self._pubs["odom"] is not None:
            self._pubs["odom"].publish(self._odometry(q, v, stamp))
        if self._pubs["tf"] is not None:
            self._pin.framesForwardKinematics(self.model, self.data, q)
            self._fill_tf(stamp, q[:7])
            self._pubs["tf"].publish(self._tf_msg)
        self.published += 1
        self.write_time += time.perf_counter() - t0
        self.span_wall = (self.span_wall[0] if self.published > 1 else t0, time.perf_counter())
        self.span_run = (self.span_run[0] if self.published > 1 else self.epoch + t, self.epoch + t)
        return True

    def _fill_tf(self, stamp, base_xyzquat) -> None:
        """Refill the /tf message in place: odom → root from ``base_xyzquat`` (7), every moving pair from the last
        forward kinematics, all stamped ``stamp``."""
        pin, oMf = self._pin, self.data.oMf
        transforms = self._tf_msg.transforms
        for k, ts in enumerate(transforms):
            if k == 0:
                x = [float(v) for v in base_xyzquat]
            else:
                p, c = self.moving[k - 1]
                x = pin.SE3ToXYZQUAT(oMf[p].actInv(oMf[c])).tolist()
            ts.header.stamp.sec, ts.header.stamp.nanosec = stamp
            tr, rot = ts.transform.translation, ts.transform.rotation
            tr.x, tr.y, tr.z, rot.x, rot.y, rot.z, rot.w = x

    def _odometry(self, q, v, stamp):
        msg = self._odom_msg
        msg.header.stamp.sec, msg.header.stamp.nanosec = stamp
        p, o = msg.pose.pose.position, msg.pose.pose.orientation
        p.x, p.y, p.z = (float(x) for x in q[:3])
        o.x, o.y, o.z, o.w = (float(x) for x in q[3:7])
        lin, ang = msg.twist.twist.linear, msg.twist.twist.angular
        lin.x, lin.y, lin.z = (float(x) for x in v[:3])
        ang.x, ang.y, ang.z = (float(x) for x in v[3:6])
        return msg

    def reset(self) -> None:
        """Forget the decimation clock (after a motion restart)."""
        self._next_t = None

    def close(self) -> None:
        """Destroy the publishers (the node stays the caller's)."""
        for key, pub in self._pubs.items():
            if key != "depth" and pub is not None:
                self.node.destroy_publisher(pub)
        for pub in self._latched:
            self.node.destroy_publisher(pub)
        self._pubs = {"depth": self._pubs.get("depth")}
        self._latched = []
