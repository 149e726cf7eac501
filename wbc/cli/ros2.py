"""``wbc ros2 ...`` commands (the ROS 2 humanoid tutorial's nodes) and the ``--ros2``/``--bag`` options of runs.

- ``wbc ros2 joint-publisher --robot humanoid15 --rate 50``: publishes the controller's walking motion on
  /joint_states, /tf, /tf_static, /robot_description, looping until Ctrl-C; serves ``/reset_robot``
  (std_srvs/srv/Trigger) which restarts the motion.
- ``wbc ros2 echo-joint right_knee``: prints that joint's position from any /joint_states publisher.
- ``wbc ros2 topics``: lists the ROS 2 topics (and their types) on the domain.

Every command takes ``--backend auto|rclpy|dds`` (``wbc walk``: ``--ros2-backend``): ``rclpy`` is a real ROS 2 node
on the user's RMW (a sourced ROS 2 install or the ``ros-*`` wheels), ``dds`` wbc's own Cyclone DDS participant in ROS
2's wire format (extra ``wbc[ros2]``), ``auto`` (the default) rclpy when it imports, else dds
(:mod:`wbc.ros2.backend`). Every command honours ``ROS_DOMAIN_ID``. With the dds backend, DDS binds the loopback interface (127.0.0.1) by default;
``--ros2-interface NAME`` chooses another (``any``: Cyclone's default); a ``CYCLONEDDS_URI`` set by the user wins
(see :mod:`wbc.ros2.dds`).
"""

from __future__ import annotations

import os
import sys
import time
import uuid
from pathlib import Path

import numpy as np

from wbc.cli.validate import count, seconds
from wbc.ros2.backend import BACKENDS

__all__ = ["register", "add_run_options", "add_backend_option", "attach", "finish", "real_time", "RclpySession"]


def add_run_options(p) -> None:
    """Add ``--ros2 --ros2-rate --tf --bag --storage`` to a run's argument parser (e.g. ``wbc walk``)."""
    g = p.add_argument_group("ROS 2 (extra wbc[ros2])")
    g.add_argument("--ros2", action="store_true",
                   help="publish /joint_states, /tf, /tf_static, /robot_description on DDS (ROS_DOMAIN_ID)")
    g.add_argument("--ros2-rate", type=_positive_rate, default=50.0, help="publishing rate, Hz (default 50, max 500)")
    g.add_argument("--ros2-unpaced", action="store_true",
                   help="with --ros2, run as fast as possible instead of at real time (stamps stay the run's time)")
    g.add_argument("--tf", choices=("base", "all"), default="all",
                   help="/tf content: odom->root link only, or every link (default all)")
    g.add_argument("--bag", default=None, metavar="DIR", help="record the same topics as a rosbag2 in DIR")
    g.add_argument("--storage", choices=("mcap", "sqlite3"), default="mcap", help="rosbag2 storage (default mcap)")
    g.add_argument("--ros2-backend", choices=BACKENDS, default="auto",
                   help="with --ros2: rclpy (a ROS 2 node on your RMW), dds (wbc's Cyclone DDS participant), auto "
                        "(default: rclpy when it imports, else dds)")
    add_interface_option(g)


def real_time(args) -> bool:
    """Whether a run of ``args`` (:func:`add_run_options` and ``--live``) is paced to real time: ``--live``, or
    ``--ros2`` without ``--ros2-unpaced``. Read before :func:`attach` (which may clear ``args.ros2``): where time is
    real the controller's clock guard is on; elsewhere a run is a function of its inputs (logs reproducible)."""
    return bool(getattr(args, "live", False) or (getattr(args, "ros2", False)
                                                 and not getattr(args, "ros2_unpaced", False)))


def add_backend_option(p) -> None:
    """Add ``--backend auto|rclpy|dds`` (:mod:`wbc.ros2.backend`)."""
    p.add_argument("--backend", choices=BACKENDS, default="auto",
                   help="rclpy: a real ROS 2 node on your RMW (sourced ROS 2 or the ros-* wheels); dds: wbc's own "
                        "Cyclone DDS participant in ROS 2's wire format (extra wbc[ros2]); auto (default): rclpy "
                        "when it imports, else dds")


class RclpySession:
    """An rclpy context, one node named ``name`` in it and a single-threaded executor (the rclpy backend of the
    commands). ``spin(timeout)`` runs the callbacks that are ready (waiting up to ``timeout`` s for one)."""

    def __init__(self, name: str):
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node

        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = Node(name, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)

    def spin(self, timeout: float = 0.0) -> None:
        self.executor.spin_once(timeout_sec=timeout)

    def close(self) -> None:
        self.executor.shutdown(timeout_sec=0.0)
        self.node.destroy_node()
        self.context.try_shutdown()


def add_interface_option(p) -> None:
    """Add ``--ros2-interface`` (default ``lo``: DDS on 127.0.0.1 only)."""
    p.add_argument("--ros2-interface", default="lo", metavar="NAME", type=_interface,
                   help="network interface DDS binds: lo (default: 127.0.0.1 only, multicast off), an interface "
                        "name or IP (eth0) to reach other machines, or any (Cyclone's default); CYCLONEDDS_URI, "
                        "when set, wins")


class _Tee:
    """Forward ``update(q, t)`` to several viewers/publishers, then wait for ``t`` on ``pacer`` (if any)."""

    def __init__(self, *targets, pacer=None):
        self.targets = [t for t in targets if t is not None]
        self.pacer = pacer

    def update(self, q, t=None, *a, **k):
        for target in self.targets:
            target.update(q, t)
        if self.pacer is not None and t is not None:
            self.pacer.wait(t)


def attach(args, robot, viewer, dt: float):
    """(viewer to pass to the run, publisher or None) for ``args`` from :func:`add_run_options`.

    Stamps (DDS and bag) are the run's time: ``t`` from 0 for a bag alone, the wall-clock time of the start plus
    ``t`` with ``--ros2``. With ``--ros2`` the run is paced to real time (``--ros2-unpaced``: as fast as it goes).
    """
    if not getattr(args, "ros2", False) and getattr(args, "bag", None) is None:
        return viewer, None
    from wbc.ros2.backend import resolve
    from wbc.ros2.dds import use_interface

    live = None
    if args.ros2 and resolve(getattr(args, "ros2_backend", "auto")) == "rclpy":
        live = _RclpyLive(robot, args)
        if args.bag is None:
            return _Tee(viewer, live, pacer=live.pacer), live
        args.ros2 = False  # the bag alone through the dds publisher, without DDS
    from wbc.ros2.publisher import Ros2Publisher

    use_interface(args.ros2_interface)
    bag = None
    if args.bag is not None:  # written under a temporary name in its folder, renamed by finish()
        final = Path(args.bag)
        bag = final.with_name(f".{final.name}.{os.getpid()}-{uuid.uuid4().hex[:8]}.partial")
    pacer = None
    if args.ros2 and not getattr(args, "ros2_unpaced", False):
        from wbc.viz.live import RealTimePacer

        pacer = RealTimePacer()
    pub = Ros2Publisher(robot, rate=args.ros2_rate, tf=args.tf, dds=args.ros2, bag=bag,
                        storage=args.storage, dt=dt, clock="sim", epoch=time.time() if args.ros2 else 0.0)
    pub.final_bag = None if bag is None else Path(args.bag)
    if args.ros2:
        time.sleep(0.5)  # let DDS discovery match subscribers already running
    if live is not None:
        return _Tee(viewer, live, pub, pacer=live.pacer), _Both(live, pub)
    return _Tee(viewer, pub, pacer=pacer), pub


class _RclpyLive:
    """``--ros2`` with the rclpy backend: an rclpy node ``wbc_walk`` publishing the run (the viewer interface)."""

    def __init__(self, robot, args):
        from wbc.ros2.rclpy_publisher import RclpyPublisher

        self.session = RclpySession("wbc_walk")
        self.pacer = None
        if not getattr(args, "ros2_unpaced", False):
            from wbc.viz.live import RealTimePacer

            self.pacer = RealTimePacer()
        self.pub = RclpyPublisher(self.session.node, robot, rate=args.ros2_rate, tf=args.tf, epoch=time.time())
        time.sleep(0.5)  # let discovery match subscribers already running

    def update(self, q, t=None, *a, **k):
        self.pub.update(q, t)

    def close(self) -> None:
        self.pub.close()
        self.session.close()


class _Both:
    """The rclpy live publisher and the bag's publisher, finished together."""

    def __init__(self, live, bag_pub):
        self.live, self.bag_pub = live, bag_pub


def finish(pub) -> None:
    """Close the publisher and print what it did."""
    if pub is None:
        return
    if isinstance(pub, _Both):
        finish(pub.live)
        finish(pub.bag_pub)
        return
    if isinstance(pub, _RclpyLive):
        p = pub.pub
        n = max(p.published, 1)
        pub.close()
        print(f"ros2 (rclpy): published {p.published} samples at {p.rate:g} Hz, mean publish "
              f"{1e6 * p.write_time / n:.0f} µs, stamps spanning {p.span_run[1] - p.span_run[0]:.2f} s in "
              f"{p.span_wall[1] - p.span_wall[0]:.2f} s of wall time")
        return
    n = max(pub.published, 1)
    pub.close()
    msg = (f"ros2: published {pub.published} samples at {pub.rate:g} Hz, mean write {1e6 * pub.write_time / n:.0f} µs, "
           f"stamps spanning {pub.span_run[1] - pub.span_run[0]:.2f} s in {pub.span_wall[1] - pub.span_wall[0]:.2f} s "
           "of wall time")
    bag = getattr(pub, "bag_path", None)
    if bag is not None:  # a closed, complete bag (up to the last published sample) under its final name
        final = getattr(pub, "final_bag", None) or bag
        if final != bag:
            os.replace(bag, final)
        size = sum(f.stat().st_size for f in final.rglob("*") if f.is_file())
        msg += f"; bag {final} ({size / 1e6:.2f} MB)"
    print(msg)


def _loopback(args) -> None:
    from wbc.ros2.dds import use_interface

    use_interface("lo" if getattr(args, "loopback", False) else getattr(args, "ros2_interface", "lo"))


def _dds_reset_service(pub):
    """dds backend: /reset_robot as a Cyclone-RMW service on ``pub``'s participant; returns ``answer(message_of)``
    which replies to the requests that arrived and returns their count."""
    from wbc.ros2 import dds, endpoints, msgs

    part = pub.participant
    qos = dds.qos_stream(10)
    req_reader = endpoints.reader(part, "rq/reset_robotRequest", msgs.TriggerRequest, qos)
    rep_writer = endpoints.writer(part, "rr/reset_robotReply", msgs.TriggerReply, qos)

    def answer(message_of) -> int:
        n = 0
        for req in req_reader.take(N=10):
            if isinstance(req, msgs.TriggerRequest):
                n += 1
                rep_writer.write(msgs.TriggerReply(req.client_guid, req.seq, True, message_of(n)))
        return n

    return answer


def _rclpy_reset_service(session):
    """rclpy backend: /reset_robot (std_srvs/srv/Trigger) on ``session``'s node; ``answer(message_of)`` runs the
    ready callbacks and returns how many resets they asked for."""
    from std_srvs.srv import Trigger

    asked = []
    state = {}

    def on_reset(request, response):
        asked.append(1)
        response.success, response.message = True, state["message_of"](len(asked))
        return response

    session.node.create_service(Trigger, "/reset_robot", on_reset)

    def answer(message_of) -> int:
        state["message_of"] = message_of
        session.spin(0.0)
        n = len(asked)
        asked.clear()
        return n

    return answer


def cmd_joint_publisher(args) -> int:
    """Loop the walking motion on ROS 2 until Ctrl-C (or ``--duration`` s); serve /reset_robot."""
    from wbc.cli.output import sigint_received
    from wbc.cli.robots import robot_from_args
    from wbc.ros2.backend import resolve
    from wbc.scenarios.walk import plan_default_walk, run_walk

    backend = resolve(args.backend)
    _loopback(args)
    robot = robot_from_args(args)
    plan = plan_default_walk(robot, n_steps=args.steps)
    run = run_walk(robot, plan)
    session = None
    if backend == "rclpy":
        from wbc.ros2.rclpy_publisher import RclpyPublisher

        session = RclpySession("wbc_joint_publisher")
        pub = RclpyPublisher(session.node, robot, rate=args.rate, tf=args.tf)
        answer = _rclpy_reset_service(session)
        where = f"rclpy node /wbc_joint_publisher (domain {os.environ.get('ROS_DOMAIN_ID', '0')})"
    else:
        from wbc.ros2 import dds
        from wbc.ros2.publisher import Ros2Publisher

        pub = Ros2Publisher(robot, rate=args.rate, tf=args.tf, dt=run.dt)
        answer = _dds_reset_service(pub)
        where = f"dds, domain {dds.domain_id()}"
    stride = max(1, int(round(1.0 / (args.rate * run.dt))))
    print(f"wbc ros2 joint-publisher: {robot.name}, {len(run.t)} ticks looped at {args.rate:g} Hz "
          f"({where}); Ctrl-C to stop", flush=True)
    k, loops, resets = 0, 0, 0
    t_start = time.monotonic()
    period = 1.0 / args.rate
    next_wake = t_start
    try:
        while args.duration is None or time.monotonic() - t_start < args.duration:
            if sigint_received():  # a Ctrl-C swallowed by a C callback (see wbc.cli.output.on_sigint)
                break
            n = answer(lambda i: f"motion reset (reset {resets + i})")
            if n:
                k, resets = 0, resets + n
                pub.reset()
                print(f"/reset_robot: reset {resets}", flush=True)
            pub.update(run.q[k], time.time(), v=run.v[k])
            k += stride
            if k >= len(run.t):
                k, loops = 0, loops + 1
            next_wake += period
            time.sleep(max(0.0, next_wake - time.monotonic()))
    except KeyboardInterrupt:
        pass
    finally:
        pub.close()
        if session is not None:
            session.close()
    print(f"joint-publisher: {pub.published} samples, {loops} loops, {resets} resets", flush=True)
    return 0


def _joint_samples_dds():
    """dds backend: ``take()`` → list of (names, positions, sec, nanosec) from /joint_states."""
    from wbc.ros2 import dds, endpoints, msgs

    part = dds.participant()
    qos = dds.qos_stream(100)
    reader = endpoints.reader(part, dds.ros_topic("/joint_states"), msgs.JointState, qos)

    def take():
        out = [(list(s.name), s.position, s.header.stamp.sec, s.header.stamp.nanosec)
               for s in reader.take(N=100) if isinstance(s, msgs.JointState)]
        if not out:
            time.sleep(0.005)
        return out

    return take, None


def _joint_samples_rclpy():
    """rclpy backend: the same ``take()`` from an rclpy subscription (node ``wbc_echo_joint``)."""
    from sensor_msgs.msg import JointState

    session = RclpySession("wbc_echo_joint")
    got = []
    session.node.create_subscription(
        JointState, "/joint_states",
        lambda s: got.append((list(s.name), s.position, s.header.stamp.sec, s.header.stamp.nanosec)), 100)

    def take():
        session.spin(0.05)
        out = got[:]
        got.clear()
        return out

    return take, session


def cmd_echo_joint(args) -> int:
    """Print ``<stamp> <joint> <position>`` for every /joint_states sample carrying the joint; with ``--timeout``,
    a line saying so when no sample came."""
    from wbc.cli.output import sigint_received
    from wbc.exceptions import UnknownJointError
    from wbc.ros2.backend import resolve

    backend = resolve(args.backend)
    _loopback(args)
    take, session = _joint_samples_rclpy() if backend == "rclpy" else _joint_samples_dds()
    got = 0
    t_end = None if args.timeout is None else time.monotonic() + args.timeout
    try:
        while ((args.count is None or got < args.count) and (t_end is None or time.monotonic() < t_end)
               and not sigint_received()):
            for names, position, sec, nanosec in take():
                if args.joint not in names:
                    raise UnknownJointError(f"/joint_states has no joint {args.joint!r}; valid: {names}")
                print(f"{sec}.{nanosec:09d} {args.joint} {position[names.index(args.joint)]:.6f}", flush=True)
                got += 1
                if args.count is not None and got >= args.count:
                    break
    except KeyboardInterrupt:
        pass
    finally:
        if session is not None:
            session.close()
    if not got and args.timeout is not None:
        print(f"echo-joint: no /joint_states sample in {args.timeout:g} s ({backend} backend, domain "
              f"{os.environ.get('ROS_DOMAIN_ID', '0')})", flush=True)
    return 0 if got else 1


def cmd_topics(args) -> int:
    """List ROS 2 topics seen on the domain during ``--wait`` s (from DDS built-in publication/subscription data)."""
    from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsPublication, BuiltinTopicDcpsSubscription

    from wbc.ros2 import dds

    _loopback(args)
    part = dds.participant()
    readers = [BuiltinDataReader(part, BuiltinTopicDcpsPublication),
               BuiltinDataReader(part, BuiltinTopicDcpsSubscription)]
    seen: dict[str, set[str]] = {}
    t_end = time.monotonic() + args.wait
    while time.monotonic() < t_end:
        for r in readers:
            for s in r.take(N=100):
                name = getattr(s, "topic_name", None)
                if name and not name.startswith("DCPS"):  # skip DDS built-in topics
                    seen.setdefault(name, set()).add(_ros_type(getattr(s, "type_name", "")))
        time.sleep(0.05)
    for name in sorted(seen):
        ros = "/" + name[3:] if name[:3] in ("rt/", "rq/", "rr/") else name
        print(f"{ros} [{', '.join(sorted(seen[name]))}]" + ("" if name.startswith("rt/") else f"  (DDS {name})"))
    return 0


def cmd_node(args) -> int:
    """``wbc ros2 node``: the controller node until Ctrl-C (exit 130), SIGTERM (exit 143) or ``--duration`` s (0)."""
    import signal

    from wbc.cli.output import sigint_received, sigterm_received
    from wbc.exceptions import InvalidInputError
    from wbc.robot import load_robot
    from wbc.ros2.backend import resolve

    if args.duration is not None and not args.duration > 0:
        raise InvalidInputError(f"--duration {args.duration}: valid is a number of seconds > 0")
    if args.report_every is not None and not args.report_every > 0:
        raise InvalidInputError(f"--report-every {args.report_every}: valid is a number of seconds > 0")
    if args.max_rtf is not None and args.time != "sim":
        raise InvalidInputError(f"--max-rtf {args.max_rtf:g} needs --time sim (real time runs at 1)")
    backend = resolve(args.backend)
    _loopback(args)
    robot = load_robot(args.robot)
    sim_options = {"plant": args.plant, "state": args.state, "seed": args.seed} if args.sim else None
    core = dict(time_mode=args.time, update_rate=args.rate, name=args.name, tf=args.tf, sim=args.sim,
                sim_options=sim_options, max_rtf=args.max_rtf)
    if backend == "rclpy":
        from rclpy.utilities import get_rmw_implementation_identifier

        from wbc.ros2.rclpy_node import RclpyNode

        node = RclpyNode(robot, **core)
        where = (f"domain {node.context.get_domain_id()}, "
                 f"backend rclpy on {get_rmw_implementation_identifier()}")
    else:
        from wbc.ros2 import dds
        from wbc.ros2.endpoints import services_notice
        from wbc.ros2.node import ControllerNode

        node = ControllerNode(robot, **core)
        where = f"domain {dds.domain_id()}, backend dds"
    node.walk.clock_guard = True  # a real-time loop: the controller's tick bounded by its CPU time too
    what = (f"MuJoCo closed loop (ID controller, {args.plant} plant, {args.state} state)" if args.sim
            else "kinematic walk")
    speed = "" if args.max_rtf is None else f" (at most {args.max_rtf:g}x real time)"
    print(f"wbc ros2 node: {robot.name} as /{args.name} on {where}, {what}, time {args.time}{speed}, "
          f"/joint_states at {args.rate:g} Hz; /cmd_vel, /navigate_to_pose, /navigate_to_goal, /reset_robot; "
          "Ctrl-C to stop", flush=True)
    if backend == "dds":
        print(services_notice(args.name), flush=True)
    stopped_by = []

    def _terminate(signum, frame):
        stopped_by.append(signum)
        raise KeyboardInterrupt  # SIGTERM stops the node like Ctrl-C: entities released, summary printed

    signal.signal(signal.SIGTERM, _terminate)
    wall0 = time.monotonic()
    code = 0
    try:
        # a signal that came while the node was built, inside a callback that swallowed it, stops it at its 1st tick
        node.spin(args.duration, report_every=args.report_every,
                  interrupted=lambda: sigint_received() or sigterm_received())
    except KeyboardInterrupt:
        code = 143 if stopped_by or sigterm_received() else 130
    finally:
        node.close()
    _node_summary(node, args, time.monotonic() - wall0)
    if code:  # the same last line as every other command stopped by a signal
        print("wbc ros2: terminated (SIGTERM)" if code == 143 else "wbc ros2: interrupted (Ctrl-C)", file=sys.stderr)
    return code


def _node_summary(node, args, wall: float) -> None:
    import resource

    if args.sim:
        print(f"node: end at t = {node.walk.t:.3f} s; {node.sim_state()}; segments {node.walk.segments}, "
              f"fell {node.walk.fell}", flush=True)
    tt = np.asarray(node.tick_time) * 1e6
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 / 1e6  # Linux: KiB → MB (10^6 bytes)
    p50, p99 = (np.percentile(tt, 50), np.percentile(tt, 99)) if len(tt) else (float("nan"),) * 2
    print(f"node: {node.ticks} ticks, node time {node.walk.t:.3f} s in {wall:.1f} s wall; "
          f"tick p50 {p50:.0f} µs p99 {p99:.0f} µs (last {len(tt)}) max {1e6 * node.tick_max:.0f} µs; "
          f"deadline misses {node.deadline_misses} of {node.ticks} ticks (compute > {1e3 * node.walk.dt:g} ms); "
          f"max RSS {rss:.0f} MB; {node.counts}", flush=True)
    pacer = node.pacer
    if pacer is not None and pacer.late_ticks:
        then = (f"stamps jumped {node.stamp_shift:.3f} s forward with the wall clock, node time is that far behind it"
                if args.time == "real" else "node time then runs slower than --max-rtf")
        print(f"node: {'real time' if args.time == 'real' else '--max-rtf'} not kept: {pacer.late_ticks} ticks found "
              f"the loop > {pacer.max_lag:g} s behind the wall clock (re-anchored: {then})", flush=True)


def _ros_type(dds_type: str) -> str:
    """``sensor_msgs::msg::dds_::JointState_`` → ``sensor_msgs/msg/JointState``."""
    parts = dds_type.split("::")
    if len(parts) == 4 and parts[2] == "dds_" and parts[3].endswith("_"):
        return f"{parts[0]}/{parts[1]}/{parts[3][:-1]}"
    return dds_type


def _interface(text: str) -> str:
    import argparse

    from wbc.exceptions import InvalidInputError
    from wbc.ros2.dds import interface_uri

    try:
        interface_uri(text)
    except InvalidInputError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def _positive_float(text: str) -> float:
    import argparse

    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not (np.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"{text!r} is invalid: valid is a finite number > 0")
    return value


def _positive_rate(text: str) -> float:
    import argparse

    value = float(text)
    if not 0 < value <= 500:
        raise argparse.ArgumentTypeError(f"rate {value} Hz is invalid: valid is 0 < rate <= 500")
    return value


def register(subparsers, add_outputs) -> None:
    """Add ``wbc ros2 {joint-publisher, echo-joint, topics}`` (``add_outputs`` unused)."""
    ros2 = subparsers.add_parser("ros2", help="ROS 2 nodes: through rclpy, or on DDS without ROS 2 (extra wbc[ros2])")
    sub = ros2.add_subparsers(dest="ros2_command", required=True)
    jp = sub.add_parser("joint-publisher", help="publish the walking motion until Ctrl-C; /reset_robot service")
    jp.add_argument("--robot", default="humanoid15",
                    help="catalog name, robot file (.toml) or URDF path (default humanoid15)")
    jp.add_argument("--rate", type=_positive_rate, default=50.0, help="Hz (default 50, max 500)")
    jp.add_argument("--steps", type=count(2, 1000), default=4, help="walking steps in the looped motion (default 4)")
    jp.add_argument("--tf", choices=("base", "all"), default="all", help="/tf content (default all)")
    jp.add_argument("--duration", type=seconds, default=None, help="stop after this many seconds (default: Ctrl-C)")
    from wbc.cli.robots import add_plant_options, add_robot_options

    add_robot_options(jp)
    jp.set_defaults(func=cmd_joint_publisher)
    ej = sub.add_parser("echo-joint", help="print a joint's position from /joint_states")
    ej.add_argument("joint", help="joint name, e.g. right_knee")
    ej.add_argument("--count", type=count(1), default=None, help="exit after this many samples")
    ej.add_argument("--timeout", type=seconds, default=None, help="exit after this many seconds")
    ej.set_defaults(func=cmd_echo_joint)
    nd = sub.add_parser("node", help="the controller node: /cmd_vel, NavigateToPose, parameters, /reset_robot")
    nd.add_argument("--robot", default="humanoid15",
                    help="catalog name or robot file (.toml) (default humanoid15)")
    nd.add_argument("--rate", type=_positive_rate, default=50.0,
                    help="/joint_states, /tf, /odom rate, Hz (parameter update_rate; default 50, max 500)")
    nd.add_argument("--time", choices=("real", "sim"), default="real",
                    help="real: paced to the wall clock (default); sim: as fast as possible, /clock, sim stamps")
    nd.add_argument("--sim", action="store_true",
                    help="MuJoCo closed loop with the inverse-dynamics controller (wbc sim walk's plant and "
                         "estimator, --plant and --state as there, /odom and /tf from the state the controller "
                         "reads; re-planned at each touch-down, a stop takes effect within one step; see "
                         "wbc.sim.commanded)")
    add_plant_options(nd, scope="--sim: ")
    nd.add_argument("--seed", type=int, default=0, help="--sim: sensor noise seed (default 0)")
    nd.add_argument("--name", default="wbc_node", help="node name (parameter services /NAME/...; default wbc_node)")
    nd.add_argument("--tf", choices=("base", "all"), default="all", help="/tf content (default all)")
    nd.add_argument("--duration", type=seconds, default=None, help="stop after this many seconds of node time")
    nd.add_argument("--max-rtf", type=_positive_float, default=None, metavar="X",
                    help="--time sim: at most X node seconds per wall-clock second (default: as fast as it can)")
    nd.add_argument("--report-every", type=seconds, default=None, metavar="S",
                    help="print tick time p50/p99 and RSS every S seconds of node time")
    nd.set_defaults(func=cmd_node)
    tp = sub.add_parser("topics", help="list the ROS 2 topics on the domain")
    tp.add_argument("--wait", type=seconds, default=2.0, help="discovery time, s (default 2)")
    tp.set_defaults(func=cmd_topics)
    for p in (jp, ej, nd):
        add_backend_option(p)
    for p in (jp, ej, tp, nd):
        p.add_argument("--loopback", action="store_true",
                       help="confine DDS to 127.0.0.1 (the default; kept for scripts that pass it)")
        add_interface_option(p)
