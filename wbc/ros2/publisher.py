"""Publish a humanoid's motion as ROS 2 traffic (/joint_states, /tf, /tf_static, /robot_description) and rosbag2.

:class:`Ros2Publisher` has the viewer interface of the scenarios (``update(q, t)``), so a walk publishes while it
runs. It decimates the 500 Hz control loop to ``rate`` Hz. Joint velocities are the finite difference of
consecutive control ticks (exact for the kinematic controller, which integrates ``q += v dt``); efforts are
published only when given.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from wbc.exceptions import InvalidInputError

__all__ = ["Ros2Publisher", "link_tree"]

TF_MODES = ("base", "all")
STORAGES = ("mcap", "sqlite3")
BAG_VERSION = 8  # rosbag2 metadata version written (see README: Jazzy reads 8 and 9)


def link_tree(model) -> tuple[str, list[tuple[int, int, bool]]]:
    """(root link name, [(parent BODY frame id, child BODY frame id, moving)]) of a Pinocchio model.

    ``moving`` is False when only fixed joints lie between parent and child (those go to /tf_static).
    """
    import pinocchio as pin

    frames = model.frames
    root = None
    edges = []
    for fid, f in enumerate(frames):
        if f.type != pin.FrameType.BODY:
            continue
        moving = False
        p = f.parentFrame
        while p != 0 and frames[p].type != pin.FrameType.BODY:
            if frames[p].type == pin.FrameType.JOINT:
                if frames[p].parentJoint == 1:  # the free flyer
                    break
                moving = True
            p = frames[p].parentFrame
        if frames[p].type != pin.FrameType.BODY:
            if root is None:
                root = fid
            continue
        edges.append((p, fid, moving))
    if root is None:
        raise InvalidInputError("the model has no root link under its floating base")
    return frames[root].name, edges, root


class Ros2Publisher:
    """Publish ``q`` (Pinocchio order, free flyer first, quaternion xyzw) as ROS 2 topics and/or a rosbag2.

    Args:
        robot: a :class:`wbc.robot.Robot` (1-DoF joints after the free flyer).
        rate: publishing rate, Hz, in (0, 500].
        tf: ``"all"`` (odom→root link plus every link) or ``"base"`` (odom→root link only).
        dds: publish on DDS (domain ``ROS_DOMAIN_ID``); False to only record.
        bag: directory of a rosbag2 to write (must not exist), or None.
        storage: ``"mcap"`` or ``"sqlite3"``.
        dt: control period, s (velocity finite difference when ``update`` is called every tick).
        clock: ``"wall"`` (header stamps and bag times are the wall clock at publication, as a ROS 2 node
            without sim time does) or ``"sim"`` (the run's time ``epoch + t``: a bag then plays back at the speed
            the run happened, whatever the run's own speed).
        epoch: s, added to the run's time ``t`` with ``clock="sim"`` (0: stamps start at 0 as under ``/clock``;
            the wall-clock time at the start of a run paced to real time: stamps close to the wall clock).

    Raises:
        InvalidInputError: bad rate, tf mode, storage, or an existing bag directory.
        wbc.ros2.Ros2UnavailableError: cyclonedds/rosbags missing.
    """

    def __init__(self, robot, *, rate: float = 50.0, tf: str = "all", dds: bool = True, bag=None,
                 storage: str = "mcap", dt: float = 0.002, clock: str = "wall",
                 epoch: float = 0.0):
        from wbc.ros2 import require

        require()
        import pinocchio as pin

        from wbc.ros2 import msgs

        if not (isinstance(rate, (int, float)) and 0 < rate <= 500):
            raise InvalidInputError(f"ros2 rate {rate!r} Hz is invalid: valid is 0 < rate <= 500")
        if tf not in TF_MODES:
            raise InvalidInputError(f"tf mode {tf!r} is invalid: valid are {TF_MODES}")
        if clock not in ("wall", "sim"):
            raise InvalidInputError(f"clock {clock!r} is invalid: valid are ('wall', 'sim')")
        if not (isinstance(epoch, (int, float)) and np.isfinite(epoch) and epoch >= 0):
            raise InvalidInputError(f"epoch {epoch!r} s is invalid: valid is a finite number >= 0")
        self.clock, self.epoch = clock, float(epoch)
        if storage not in STORAGES:
            raise InvalidInputError(f"bag storage {storage!r} is invalid: valid are {STORAGES}")
        model = robot.model
        if model.nq - 7 != model.nv - 6 or model.nq - 7 != len(robot.joint_names):
            raise InvalidInputError("Ros2Publisher needs a free flyer followed by 1-DoF joints only")
        self.robot, self.rate, self.tf_mode, self.dt = robot, float(rate), tf, float(dt)
        self._pin, self._msgs = pin, msgs
        self._data = model.createData()
        self.names = list(robot.joint_names)
        self.root, self._edges, self._root_fid = link_tree(model)
        if tf == "base":
            self._edges = [e for e in self._edges if not e[2]]
        self._moving = [(p, c) for p, c, m in self._edges if m]
        self._static = [(p, c) for p, c, m in self._edges if not m]
        self.description = Path(robot.urdf_path).read_text()
        from wbc.ros2.cdr import JointStatePacker, TFPacker

        frames = model.frames
        self._js_packer = JointStatePacker(self.names, self.root)
        self._tf_packer = TFPacker([("odom", self.root)]
                                   + [(frames[p].name, frames[c].name) for p, c in self._moving])
        self._tf_vals = np.zeros((1 + len(self._moving), 7))
        self._next_t = None
        self._q_prev = None
        self.published = 0
        self.write_time = 0.0
        self.span_wall = self.span_run = (0.0, 0.0)  # (first, last) publication: perf_counter s, stamp s
        self._writers = {}
        if dds:
            self._open_dds()
        self._bag = self._conn = None
        if bag is not None:
            self._open_bag(Path(bag), storage)
        self._latched(time.time() if clock == "wall" else self.epoch)

    # -- setup -------------------------------------------------------------------------------------------------
    def _open_dds(self):
        from wbc.ros2 import dds, endpoints

        m = self._msgs
        self.participant = dds.participant()
        depth = max(10, int(self.rate))  # one second of samples
        spec = {
            "/joint_states": (m.JointState, dds.qos_stream(depth)),
            "/tf": (m.TFMessage, dds.qos_stream(depth)),
            "/tf_static": (m.TFMessage, dds.qos_latched()),
            "/robot_description": (m.String, dds.qos_latched()),
        }
        for name, (typ, qos) in spec.items():
            self._writers[name] = endpoints.writer(self.participant, dds.ros_topic(name), typ, qos)

    def _open_bag(self, path: Path, storage: str):
        from rosbags.rosbag2 import StoragePlugin, Writer
        from rosbags.typesys import Stores, get_typestore

        if path.exists():
            raise InvalidInputError(f"bag directory {path} already exists: pass a new path")
        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        self._typestore = get_typestore(Stores.ROS2_HUMBLE)
        self._bag = Writer(path, version=BAG_VERSION, storage_plugin=plugin)
        self._bag.open()
        types = {"/joint_states": "sensor_msgs/msg/JointState", "/tf": "tf2_msgs/msg/TFMessage",
                 "/tf_static": "tf2_msgs/msg/TFMessage", "/robot_description": "std_msgs/msg/String"}
        self._conn = {t: self._bag.add_connection(t, typ, typestore=self._typestore) for t, typ in types.items()}
        self.bag_path = path

    # -- messages ----------------------------------------------------------------------------------------------
    def _stamp(self, t: float):
        sec = int(np.floor(t))
        return self._msgs.Time(sec, int(round((t - sec) * 1e9)) % 1_000_000_000)

    def _tf(self, t: float, pairs, q=None) -> object:
        m, pin = self._msgs, self._pin
        frames, oMf = self.robot.model.frames, self._data.oMf
        stamp = self._stamp(t)
        out = []
        if q is not None:
            out.append(self._ts(stamp, "odom", self.root, q[:3], q[3:7]))
        for p, c in pairs:
            xyzquat = pin.SE3ToXYZQUAT(oMf[p].actInv(oMf[c]))  # (not pin.Quaternion(R): it leaks, estimation.base)
            out.append(self._ts(stamp, frames[p].name, frames[c].name, xyzquat[:3], xyzquat[3:]))
        return m.TFMessage(out)

    def _ts(self, stamp, parent, child, xyz, xyzw):
        m = self._msgs
        return m.TransformStamped(
            m.Header(stamp, parent), child,
            m.Transform(m.Vector3(*map(float, xyz)), m.Quaternion(*map(float, xyzw))))

    def _send(self, topic: str, msg, t: float, data: bytes | None = None) -> None:
        """Write ``msg`` (or, when ``data`` is given, those CDR bytes as a ``msg``-typed sample)."""
        w = self._writers.get(topic)
        if w is not None:
            if data is not None:
                from wbc.ros2.cdr import prepacked

                msg = prepacked(msg, data)
            w.write(msg)
        if self._bag is not None:
            raw = data if data is not None else self._msgs.to_bytes(msg)
            self._bag.write(self._conn[topic], int(round(t * 1e9)), raw)

    def _latched(self, t: float) -> None:
        q = self.robot.q_ref
        self._pin.framesForwardKinematics(self.robot.model, self._data, q)
        self._send("/robot_description", self._msgs.String(self.description), t)
        self._send("/tf_static", self._tf(t, self._static), t)

    # -- the viewer interface ----------------------------------------------------------------------------------
    def update(self, q: np.ndarray, t: float | None = None, v: np.ndarray | None = None,
               effort: np.ndarray | None = None) -> bool:
        """Publish ``q`` (nq) at time ``t`` (s) if the decimation period has elapsed; returns True if published.

        ``v`` (nv) overrides the finite-difference velocity; ``effort`` (nv-6, N·m) fills JointState.effort.
        """
        q = np.asarray(q, dtype=float)
        if t is None:
            t = time.time()
        q_prev, self._q_prev = self._q_prev, q.copy()
        if self._next_t is not None and t < self._next_t - 1e-9:
            return False
        self._next_t = t + 1.0 / self.rate if self._next_t is None else max(self._next_t + 1.0 / self.rate, t)
        t0 = time.perf_counter()
        t = time.time() if self.clock == "wall" else self.epoch + t
        if v is not None:
            vel = np.asarray(v, dtype=float)[6:]
        elif q_prev is not None:
            vel = (q[7:] - q_prev[7:]) / self.dt
        else:
            vel = np.zeros(len(self.names))
        m, pin = self._msgs, self._pin
        stamp = self._stamp(t)
        if effort is None:
            data = self._js_packer.encode(stamp.sec, stamp.nanosec, q[7:], vel)
            self._send("/joint_states", m.JointState, t, data)
        else:
            js = m.JointState(m.Header(stamp, self.root), self.names, q[7:].tolist(), vel.tolist(),
                              np.asarray(effort, dtype=float).tolist())
            self._send("/joint_states", js, t)
        vals = self._tf_vals
        vals[0, :3] = q[:3]
        vals[0, 3:] = q[3:7]
        if self._moving:
            pin.framesForwardKinematics(self.robot.model, self._data, q)
            oMf = self._data.oMf
            for i, (p, c) in enumerate(self._moving, start=1):
                vals[i] = pin.SE3ToXYZQUAT(oMf[p].actInv(oMf[c]))  # (x, y, z, qx, qy, qz, qw)
        self._send("/tf", m.TFMessage, t, self._tf_packer.encode(stamp.sec, stamp.nanosec, vals))
        self.published += 1
        self.write_time += time.perf_counter() - t0
        self.span_wall = (self.span_wall[0] if self.published > 1 else t0, time.perf_counter())
        self.span_run = (self.span_run[0] if self.published > 1 else t, t)
        return True

    def reset(self) -> None:
        """Forget the decimation clock and the previous sample (after a motion restart)."""
        self._next_t = self._q_prev = None

    def close(self) -> None:
        """Finish the bag (if any) and release the DDS entities."""
        if self._bag is not None:
            self._bag.close()
            self._bag = None
        self._writers.clear()
