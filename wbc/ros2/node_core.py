"""The controller node's behaviour, written once for every transport: loop, commands, parameters, goals.

:class:`NodeCore` owns the walk (:class:`wbc.scenarios.commanded_walk.CommandedWalk`, or
:class:`wbc.sim.commanded.SimCommandedWalk` with ``sim=True``), the parameters and their rules, the
NavigateToPose goal logic and the control loop. A transport subclass says how the node talks: the DDS one
(:class:`wbc.ros2.node.ControllerNode`, Cyclone DDS in ROS 2's wire format) and the rclpy one
(:class:`wbc.ros2.rclpy_node.RclpyNode`, a real ROS 2 node). It implements the hooks ``_poll`` (take commands,
serve requests), ``_publish_state``, ``_publish_clock``, ``_send_feedback``, ``_goal_ended``, ``_goals_changed``,
``_rate_changed`` and ``close``; the behaviour the hooks report is in :mod:`wbc.ros2.node`'s docstring.

Time: ``"real"`` paces the loop to the wall clock (:class:`wbc.viz.live.RealTimePacer`) and stamps the wall-clock
time at the end of the first tick plus the node time since then (the epoch is taken in :meth:`NodeCore.spin` after
the first tick, past every import and one-off cost, where the pacer's clock starts: the first stamp is the wall
clock). A stall of the loop longer than 0.1 s is not caught up: the pacer re-anchors, the stamps jump forward
with the wall clock (``stamp_shift`` adds the jumps) and node time stays that far behind it. ``"sim"`` stamps node
time from 0 and runs as fast as it can or, with ``max_rtf``, at most ``max_rtf`` node seconds per wall second.
"""

from __future__ import annotations

import gc
import math
import time
from collections import deque
from collections.abc import Callable

import numpy as np

from wbc.exceptions import InvalidInputError

__all__ = ["NodeCore", "Goal", "PARAMETERS", "GOAL_TOLERANCE", "PENDING", "ACCEPTED", "EXECUTING", "CANCELING",
           "SUCCEEDED", "CANCELED", "ABORTED", "STATUS_NAMES", "history_depth", "quaternion_yaw"]

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
STATUS_NAMES = {SUCCEEDED: "SUCCEEDED", CANCELED: "CANCELED", ABORTED: "ABORTED"}
GOAL_TOLERANCE = (0.05, math.radians(5.0))  # m, rad: a goal ends SUCCEEDED within these


def history_depth(rate: float) -> int:
    """Depth of the keep-last history of a stream published at ``rate`` Hz: one second of samples, at least 10."""
    return max(10, int(math.ceil(rate)))


def quaternion_yaw(qx, qy, qz, qw) -> float:
    """Yaw (rad, about z) of the quaternion (x, y, z, w)."""
    return math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))


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
    """Resident set size of this process, MB (10^6 bytes; Linux /proc/self/statm; nan elsewhere)."""
    import os

    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6
    except (OSError, ValueError):
        return float("nan")


class Goal:
    """A NavigateToPose goal: 16-byte ``uuid``, the action it came on, its acceptance ``stamp`` (s), ``target``
    (x m, y m, yaw rad in ``odom``), ``status`` (the GoalStatus codes), result code/message, and ``handle``: what
    the transport keeps with it (e.g. rclpy's goal handle; None for a goal from /goal_pose)."""

    __slots__ = ("uuid", "server", "stamp", "status", "target", "result_code", "result_msg", "started", "handle")

    def __init__(self, uuid: bytes, server: str, stamp: float, target, started: float, handle=None):
        self.uuid, self.server, self.stamp, self.target, self.started = uuid, server, stamp, target, started
        self.status, self.result_code, self.result_msg = ACCEPTED, 0, ""
        self.handle = handle


class NodeCore:
    """The transport-independent node (module docstring).

    Args:
        robot: a :class:`wbc.robot.Robot` (free flyer followed by 1-DoF joints).
        time_mode: ``"real"`` or ``"sim"``.
        update_rate: Hz, in [1, 500].
        name: node name, a ROS name without slashes.
        step_duration, max_velocity: initial parameter values (None: the walk's defaults).
        sim: drive the MuJoCo closed loop (:class:`wbc.sim.commanded.SimCommandedWalk`) instead of the kinematic walk.
        sim_options: keyword arguments of :class:`~wbc.sim.commanded.SimCommandedWalk`.
        max_rtf: ``"sim"`` time only: at most this many node seconds per wall-clock second (None: as fast as it can).

    Raises:
        InvalidInputError: a bad time mode, rate, name, ``max_rtf`` or parameter value.
    """

    def __init__(self, robot, *, time_mode: str = "real", update_rate: float = 50.0, name: str = "wbc_node",
                 step_duration: float | None = None, max_velocity: float | None = None, sim: bool = False,
                 sim_options: dict | None = None, max_rtf: float | None = None):
        if time_mode not in ("real", "sim"):
            raise InvalidInputError(f"time mode {time_mode!r} is invalid: valid are 'real', 'sim'")
        if not isinstance(name, str) or not name or not name.replace("_", "a").isalnum() or name[0].isdigit():
            raise InvalidInputError(f"node name {name!r} is invalid: letters, digits and '_', not starting with a digit")
        if max_rtf is not None:
            if time_mode != "sim":
                raise InvalidInputError("max_rtf applies to time mode 'sim' only (real time runs at 1)")
            if isinstance(max_rtf, bool) or not isinstance(max_rtf, (int, float)) or not (
                    math.isfinite(max_rtf) and max_rtf > 0):
                raise InvalidInputError(f"max_rtf {max_rtf!r} is invalid: valid is a finite number > 0")
        if sim:
            from wbc.sim.commanded import SimCommandedWalk

            self.walk = SimCommandedWalk(robot, **(sim_options or {}))
        else:
            from wbc.scenarios.commanded_walk import CommandedWalk

            self.walk = CommandedWalk(robot)
        from wbc.viz.live import RealTimePacer  # imported here: spin() takes the epoch after every import

        self._pacer_type = RealTimePacer
        self.max_rtf = None if max_rtf is None else float(max_rtf)
        self.sim = bool(sim)
        self._was_walking = False
        self._fall_reported = False  # --sim: the current fall was printed (cleared when the robot is up again)
        self._replans_seen = 0  # --sim: touch-down re-plans already printed
        self.robot, self.name, self.time_mode = robot, name, time_mode
        self.epoch = 0.0  # s added to node time in stamps: the wall clock at the first tick with real time
        self.params = {"update_rate": float(update_rate), "step_duration": self.walk.step_duration,
                       "max_velocity": self.walk.max_velocity, "cmd_vel_timeout": 0.5,
                       "use_sim_time": time_mode == "sim"}
        for key, value in (("update_rate", update_rate), ("step_duration", step_duration),
                           ("max_velocity", max_velocity)):
            if value is not None:
                reason = self.check(key, 3, value)
                if reason:
                    raise InvalidInputError(reason)
                self.params[key] = float(value)
                self._apply_to_walk(key, float(value))
        self.finished: deque = deque(maxlen=16)
        self.active: Goal | None = None
        self._failures0 = 0
        self._last_cmd_t = None
        self._warned_t = -1e9
        self.ticks = 0
        self.pacer = None
        self.tick_time = deque(maxlen=30000)  # s per tick, a ring of the last minute at 500 Hz
        self.deadline_misses = 0  # ticks whose compute (poll, walk tick, publication) took longer than the period
        self.tick_max = 0.0  # s, the longest tick since the start
        self.counts = {"cmd_vel": 0, "goals": 0, "resets": 0, "param_sets": 0}
        self.heap_trims, self.last_trim_s = 0, 0.0  # spin(trim_every): malloc_trim calls, s taken by the last
        self.stamp_shift = 0.0  # real time: s the stamps jumped forward over stalls (node time is that far behind)

    # -- transport hooks ---------------------------------------------------------------------------------------
    def _poll(self) -> None:
        """Take the commands and serve the requests that arrived (every 5th tick)."""
        raise NotImplementedError

    def _spin_some(self) -> None:
        """Take at most one pending transport event (every tick; for transports whose polling is costly, so that
        :meth:`_poll` finds the inputs already taken and no tick pays for a batch of them)."""

    def _publish_state(self) -> None:
        """Publish /joint_states, /tf, /odom when the ``update_rate`` period has elapsed (every tick)."""
        raise NotImplementedError

    def _publish_clock(self) -> None:
        """Publish /clock (``"sim"`` time, every 5th tick)."""

    def _send_feedback(self, goal: Goal, feedback: dict) -> None:
        """Publish the feedback of :meth:`feedback` for the active goal (every 0.1 s of node time)."""

    def _goal_ended(self, goal: Goal) -> None:
        """``goal`` reached a terminal status (``goal.status``, ``result_code``, ``result_msg``)."""

    def _goals_changed(self) -> None:
        """A goal was accepted, is canceling or ended (the status array changed)."""

    def _rate_changed(self, rate: float) -> None:
        """``update_rate`` changed to ``rate`` Hz (resize the stream histories: :func:`history_depth`)."""

    def close(self) -> None:
        """Release the transport."""

    # -- time --------------------------------------------------------------------------------------------------
    def stamp_seconds(self, t: float | None = None) -> float:
        """The stamp (s) of node time ``t`` (None: now): epoch + node time."""
        return self.epoch + (self.walk.t if t is None else t)

    @staticmethod
    def sec_nsec(s: float) -> tuple[int, int]:
        """(sec, nanosec) of ``s`` seconds (builtin_interfaces Time/Duration fields)."""
        sec = int(math.floor(s))
        return sec, min(int(round((s - sec) * 1e9)), 999_999_999)

    # -- parameters --------------------------------------------------------------------------------------------
    def check(self, name: str, ptype: int, value) -> str:
        """'' if ``value`` (of ROS parameter type code ``ptype``: 1 bool, 2 integer, 3 double, 4 string) may be set
        on ``name``, else the reason."""
        if name not in PARAMETERS:
            return f"parameter {name!r} does not exist; valid: {sorted(PARAMETERS)}"
        kind, _, rng, read_only = PARAMETERS[name]
        if read_only:
            return f"parameter {name!r} is read-only"
        if kind == 3 and ptype not in (2, 3):
            return f"parameter {name!r} is a double; got a {_TYPE_NAMES.get(ptype, ptype)}"
        if (isinstance(value, bool) or not (isinstance(value, (int, float)) and math.isfinite(value))
                or not rng[0] <= value <= rng[1]):
            return f"{name} = {value!r} is out of range: valid is [{rng[0]:g}, {rng[1]:g}]"
        return ""

    def apply(self, name: str, value: float) -> None:
        """Set parameter ``name`` (checked with :meth:`check`) to ``value`` and print it."""
        self.params[name] = float(value)
        self._apply_to_walk(name, float(value))
        if name == "update_rate":
            self._rate_changed(float(value))
        self.counts["param_sets"] += 1
        print(f"parameter {name} = {self.params[name]:g}", flush=True)

    def _apply_to_walk(self, name: str, value: float) -> None:
        if name == "step_duration":
            self.walk.step_duration = value
        elif name == "max_velocity":
            self.walk.max_velocity = value

    # -- commands ----------------------------------------------------------------------------------------------
    def command_velocity(self, vx: float, vy: float, wz: float, samples: int = 1) -> None:
        """A /cmd_vel (m/s, m/s, rad/s in the walking frame; ``samples`` received since the last poll): saturated to
        the limits (reported once per second), aborts an active goal when nonzero."""
        w = self.walk
        cmd = np.array([vx, vy, wz], dtype=float)
        lim = np.array([w.max_velocity, w.max_lateral, w.max_turn])
        low = -lim
        low[0] = -w.max_backward  # (0 for the physics walk: it plans no backward step)
        if not np.isfinite(cmd).all():
            print("cmd_vel ignored: non-finite value", flush=True)
            return
        if (np.any(cmd > lim) or np.any(cmd < low)) and w.t - self._warned_t > 1.0:
            self._warned_t = w.t
            print(f"cmd_vel (vx, vy, wz) = {cmd.round(3).tolist()} beyond the limits "
                  f"[{low.round(3).tolist()}, {lim.round(3).tolist()}]: saturated", flush=True)
        cmd = np.clip(cmd, low, lim)
        self.counts["cmd_vel"] += samples
        if self.active is not None and np.any(cmd):
            self.end_goal(self.active, ABORTED, 9000, "overridden by /cmd_vel")
        if self.active is None:
            w.set_velocity(*cmd)
            self._last_cmd_t = w.t

    def goal_pose(self, x: float, y: float, qx: float, qy: float, qz: float, qw: float) -> None:
        """A /goal_pose (RViz2's "2D Goal Pose"): a goal of /navigate_to_pose without a client."""
        import os

        target = (x, y, quaternion_yaw(qx, qy, qz, qw))
        if all(math.isfinite(v) for v in target):
            self.start_goal(os.urandom(16), "navigate_to_pose", target)

    def reset(self) -> str:
        """/reset_robot: abort an active goal, back to the reference stance; returns the reply's message."""
        self.counts["resets"] += 1
        if self.active is not None:
            self.end_goal(self.active, ABORTED, 9000, "robot reset")
        self.walk.reset()
        self._last_cmd_t = None
        print(f"/reset_robot: reset {self.counts['resets']}", flush=True)
        return f"robot reset to its reference stance (reset {self.counts['resets']})"

    # -- goals -------------------------------------------------------------------------------------------------
    @staticmethod
    def goal_target(x: float, y: float, qx: float, qy: float, qz: float, qw: float):
        """(x, y, yaw) of a goal pose, or None when a value is not finite (the goal is then rejected)."""
        target = (x, y, quaternion_yaw(qx, qy, qz, qw))
        return target if all(math.isfinite(v) for v in target) else None

    def start_goal(self, uuid: bytes, action: str, target, handle=None) -> Goal:
        """Accept and execute a goal (``target`` from :meth:`goal_target`); an active goal ends ABORTED
        ("pre-empted by a new goal"), or CANCELED when its cancel was already accepted (it was closing its walk)."""
        self.counts["goals"] += 1
        if self.active is not None and self.active.status == CANCELING:
            self.end_goal(self.active, CANCELED, 0, "canceled: a new goal arrived during its closing step")
        elif self.active is not None:
            self.end_goal(self.active, ABORTED, 9000, "pre-empted by a new goal")
        goal = Goal(bytes(uuid), action, self.stamp_seconds(), target, self.walk.t, handle)
        self.active = goal
        self.walk.set_goal(*target)
        self._failures0 = self.walk.replan_failures
        goal.status = EXECUTING
        print(f"goal {goal.uuid.hex()[:8]} on /{action}: x {target[0]:.3f} m, y {target[1]:.3f} m, "
              f"yaw {math.degrees(target[2]):.1f} deg", flush=True)
        self._goals_changed()
        return goal

    def cancel(self, uuid: bytes) -> int:
        """Cancel the active goal ``uuid`` (all zeros: any): the robot stops with a closing step and the goal ends
        CANCELED once it stands. Returns CancelGoal's code: 0 accepted, 2 unknown goal, 3 goal terminated."""
        g = self.active
        if g is not None and g.status == EXECUTING and (uuid == bytes(16) or uuid == g.uuid):
            g.status = CANCELING
            self.walk.stop()
            print(f"goal {g.uuid.hex()[:8]} canceling at t = {self.walk.t:.3f} s", flush=True)
            self._goals_changed()
            return 0
        return 3 if any(f.uuid == uuid for f in self.finished) else 2

    def finished_goal(self, uuid: bytes) -> Goal | None:
        """The goal ``uuid`` among the last 16 that ended, or None."""
        return next((g for g in self.finished if g.uuid == uuid), None)

    def end_goal(self, goal: Goal, status: int, code: int, msg: str) -> None:
        """End ``goal`` with ``status`` (SUCCEEDED, CANCELED or ABORTED), Nav2 ``error_code`` and message."""
        goal.status, goal.result_code, goal.result_msg = status, code, msg
        self.finished.append(goal)
        if self.active is goal:
            self.active = None
        print(f"goal {goal.uuid.hex()[:8]} {STATUS_NAMES[status]}: {msg}", flush=True)
        self._goal_ended(goal)
        self._goals_changed()

    def feedback(self) -> dict:
        """The active goal's NavigateToPose feedback: ``position`` (3,) m and ``orientation`` (4,) xyzw of the base
        in ``odom``, ``navigation_time`` and ``estimated_time_remaining`` (s), ``distance_remaining`` (m, from the
        pose over the soles, :meth:`~wbc.scenarios.commanded_walk.CommandedWalk.footprint_pose`)."""
        g, w = self.active, self.walk
        x, y, _ = w.footprint_pose()
        q = w.q
        return {"position": [float(v) for v in q[:3]], "orientation": [float(v) for v in q[3:7]],
                "navigation_time": max(0.0, w.t - g.started), "estimated_time_remaining": max(0.0, w.time_remaining()),
                "distance_remaining": float(math.hypot(g.target[0] - x, g.target[1] - y))}

    def _goal_progress(self) -> None:
        g, w = self.active, self.walk
        if g is None or not w.idle:
            return
        x, y, yaw = w.base_pose()
        dist = math.hypot(g.target[0] - x, g.target[1] - y)
        dyaw = abs((g.target[2] - yaw + math.pi) % (2 * math.pi) - math.pi)
        where = f"base at x {x:.4f} m, y {y:.4f} m, yaw {math.degrees(yaw):.2f} deg"
        err = f"position error {dist:.4f} m, heading error {math.degrees(dyaw):.2f} deg"
        if g.status == CANCELING:
            self.end_goal(g, CANCELED, 0, f"canceled: standing in double support, {where}")
        elif w.replan_failures > self._failures0 and dist > GOAL_TOLERANCE[0]:
            self.end_goal(g, ABORTED, 9000, f"cannot plan the walk: {w.last_error}")
        elif dist <= GOAL_TOLERANCE[0] and dyaw <= GOAL_TOLERANCE[1]:
            self.end_goal(g, SUCCEEDED, 0, f"reached: {err}; {where}")
        else:
            self.end_goal(g, ABORTED, 9000, f"stopped off the goal: {err}; {where}")

    def _command_timeout(self) -> None:
        w = self.walk
        if self._last_cmd_t is not None and w.t - self._last_cmd_t > self.params["cmd_vel_timeout"]:
            self._last_cmd_t = None
            if self.active is None:
                w.set_velocity(0.0, 0.0, 0.0)

    # -- loop --------------------------------------------------------------------------------------------------
    def spin(self, duration: float | None = None, report_every: float | None = None,
             trim_every: float | None = 10.0, interrupted: Callable[[], bool] | None = None) -> None:
        """Run until ``duration`` s of node time (None: until KeyboardInterrupt).

        ``report_every`` (s of node time): print a line with the tick time p50/p99/max (µs) of the last
        ``report_every`` s, the deadline misses since the start and the resident memory (MB) at that period.
        Every tick's compute time (poll, walk tick, publication, heap trim; not the wait) is kept in
        :attr:`tick_time` (the last 30000) and :attr:`tick_max`; a tick longer than the control period ``dt``
        counts in :attr:`deadline_misses`.
        ``trim_every`` (s of node time, > 0; None: never): period of the heap trim (``malloc_trim(0)``, glibc),
        done after a tick's messages are published and timed within that tick.
        ``interrupted``: called before every tick; True raises KeyboardInterrupt there (a Ctrl-C whose
        KeyboardInterrupt a C callback swallowed still stops the node).

        At the end of the first tick the objects alive then (the robot, the controller, the loaded kernels) are
        moved out of the garbage collector's reach (``gc.collect()`` then ``gc.freeze()``): a full collection over
        them would stall a tick for many periods; afterwards a collection walks only the objects made since.

        Raises:
            InvalidInputError: ``trim_every`` not a number > 0 (or None).

        Per control tick (``dt`` = 2 ms): every 5th tick /clock is published (``"sim"`` time) and the transport
        polled (commands, services, actions, parameters), on the other ticks at most one pending transport event
        taken (:meth:`_spin_some`); one walk tick; the state at ``update_rate``; action
        feedback every 0.1 s; a wait until the tick is due on the wall clock (real time, or ``max_rtf``).
        """
        if trim_every is not None and (isinstance(trim_every, bool) or not isinstance(trim_every, (int, float))
                                       or not trim_every > 0 or not math.isfinite(trim_every)):
            raise InvalidInputError(f"trim_every must be a number of seconds > 0 or None; got {trim_every!r}")
        trim = None if trim_every is None else _heap_trimmer()
        w = self.walk
        trim_ticks = None if trim is None else max(1, int(round(trim_every / w.dt)))
        pacer = None
        take_epoch = False
        if self.time_mode == "real":
            pacer = self._pacer_type()
            take_epoch = self.ticks == 0  # at the end of the first tick, where the pacer's clock starts too
        elif self.max_rtf is not None:
            pacer = self._pacer_type(speed=self.max_rtf)
        self.pacer = pacer  # (late_ticks: ticks that found the loop > 0.1 s behind the wall clock; re-anchored)
        self._goals_changed()
        poll = 5
        fb_every = int(round(0.1 / w.dt))
        rep_every = None if report_every is None else max(1, int(round(report_every / w.dt)))
        window = deque(maxlen=rep_every or 1)
        window_cpu = deque(maxlen=rep_every or 1)  # the tick's thread CPU time: what load on the machine leaves out
        first_tick = True
        while duration is None or w.t < duration - 1e-9:
            if interrupted is not None and interrupted():
                raise KeyboardInterrupt
            t0 = time.perf_counter()
            c0 = time.thread_time()
            if self.ticks % poll == 0:
                if self.time_mode == "sim":
                    self._publish_clock()
                self._poll()
                self._command_timeout()
            else:
                self._spin_some()
            w.tick()
            self.ticks += 1
            if first_tick:  # its one-off costs (kernel loading) are behind: what lives now is frozen (below)
                first_tick = False
                gc.collect()
                gc.freeze()
            if take_epoch:  # the first tick's one-off costs (kernel loading) are behind: stamps = the wall clock
                self.epoch, take_epoch = time.time() - w.t, False
            if self.sim:
                self._report_sim()
            self._publish_state()
            if self.active is not None:
                if self.ticks % fb_every == 0:
                    self._send_feedback(self.active, self.feedback())
                self._goal_progress()
            if trim_ticks is not None and self.ticks % trim_ticks == 0:
                t_trim = time.perf_counter()
                trim(0)
                self.heap_trims += 1
                self.last_trim_s = time.perf_counter() - t_trim
            dt_tick = time.perf_counter() - t0
            self.tick_time.append(dt_tick)
            if dt_tick > w.dt:
                self.deadline_misses += 1
            self.tick_max = max(self.tick_max, dt_tick)
            if rep_every is not None:
                window.append(dt_tick)
                window_cpu.append(time.thread_time() - c0)
                if self.ticks % rep_every == 0:
                    self._report(np.asarray(window) * 1e6, np.asarray(window_cpu) * 1e6)
            if pacer is not None:
                late = pacer.late_ticks
                lag = pacer.wait(w.t)
                if pacer.late_ticks > late and self.time_mode == "real":
                    self.epoch += lag  # re-anchored after a stall: stamps stay on the wall clock
                    self.stamp_shift += lag

    def _report(self, tt: np.ndarray, tc: np.ndarray) -> None:
        w = self.walk
        print(f"stats: node time {w.t:.1f} s, tick p50 {np.percentile(tt, 50):.0f} µs "
              f"p99 {np.percentile(tt, 99):.0f} µs max {tt.max():.0f} µs, deadline misses {self.deadline_misses} "
              f"(> {1e3 * w.dt:g} ms) (CPU p50 {np.percentile(tc, 50):.0f} µs "
              f"p99 {np.percentile(tc, 99):.0f} µs), RSS {_rss_mb():.1f} MB, replans {w.replans}, "
              f"replan failures {w.replan_failures}, heap trims {self.heap_trims} (last "
              f"{1e3 * self.last_trim_s:.1f} ms)", flush=True)

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
        yt = quaternion_yaw(*qt[3:7])
        x, y, yaw = w.base_pose()
        feet = ", ".join(f"{s} {f[2]:.1f} N" for s, f in w.sim.foot_contact_forces().items())
        return (f"ground truth base x {qt[0]:.4f} m, y {qt[1]:.4f} m, yaw {math.degrees(yt):.2f} deg; "
                f"estimate x {x:.4f} m, y {y:.4f} m, yaw {math.degrees(yaw):.2f} deg; feet normal force {feet}")
