"""Soak of `wbc ros2 node` (with ``--sim``: the MuJoCo closed loop) driven by /cmd_vel: memory (RSS), tick time,
deadline misses and the /joint_states rate a subscriber receives over a long run.

Starts the node (``--robot``, default g1: humanoid15 has no hip yaw and cannot turn; loopback-only DDS, random
domain) with ``--report-every R`` (node time; default 30 s, 60 s with ``--sim``), drives it with a repeating
/cmd_vel pattern in node time (read from /clock): walk 0.3 m/s 10 s, walk-and-turn (0.1 m/s, 0.3 rad/s) 10 s,
side-step 0.05 m/s 10 s, stop 6 s — and samples the node's VmRSS (/proc/<pid>/status) every 10 s of wall time.
With ``--sim`` a fall (the node prints ``sim: FELL``) is answered by a /reset_robot call and counted.

    python benchmarks/ros2_node_soak.py --minutes 5
    python benchmarks/ros2_node_soak.py --sim --minutes 150 --node-minutes 61   # an hour of node time
    nice -n 10 python benchmarks/ros2_node_soak.py --sim --minutes 60 --node-log /tmp/node.log

``--time real`` runs the node on the wall clock (the pattern then in wall time): its deadline misses (ticks whose
compute overran the 2 ms period) are the real-time figure. ``--backend rclpy``: the node runs on rclpy, and this
script must run with a Python that has rclpy (the Kilted test venv of tests/ros2/kilted.py, ``PYTHONPATH`` = this
checkout) and with ``FASTDDS_DEFAULT_PROFILES_FILE`` naming a profile that confines Fast DDS to 127.0.0.1 (it
refuses to start Fast DDS without one); /cmd_vel, /clock, /reset_robot and the /joint_states count then go through
rclpy too. With the dds backend a Cyclone reader counts /joint_states.

    PYTHONPATH=. FASTDDS_DEFAULT_PROFILES_FILE=lo.xml ROS_AUTOMATIC_DISCOVERY_RANGE=SYSTEM_DEFAULT \
        ~/.cache/wbc-tests/ros2-kilted-<key>/bin/python benchmarks/ros2_node_soak.py --backend rclpy --time real \
        --minutes 10 [--sim]

Prints the RSS after the first minute (wall) and at the end, its growth, the node's tick p50/p99/max and deadline
misses of its first and last report (each over ``R`` s of node time: with ``--sim`` the first and the last minute
of node time), its end summary, the /joint_states samples received per 10 s window (min, median, max; the first
window left out: discovery) and the load average at the start and the end.
"""

import argparse
import os
import random
import subprocess
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from wbc.ros2.dds import loopback_uri  # noqa: E402

PATTERN = [((0.3, 0.0, 0.0), 10.0), ((0.1, 0.0, 0.3), 10.0), ((0.0, 0.05, 0.0), 10.0), ((0.0, 0.0, 0.0), 6.0)]


def rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return float("nan")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=5.0, help="wall-clock minutes (default 5)")
    ap.add_argument("--node-minutes", type=float, default=None,
                    help="stop earlier, once the node's clock (/clock) has run this many minutes")
    ap.add_argument("--robot", default="g1", help="a robot whose legs can turn (hip yaw; default g1)")
    ap.add_argument("--sim", action="store_true", help="the MuJoCo closed-loop node (wbc ros2 node --sim)")
    ap.add_argument("--report-every", type=float, default=None,
                    help="node-time period of the node's tick/RSS reports, s (default 30; 60 with --sim)")
    ap.add_argument("--node-log", type=Path, default=None, help="write the node's stdout to this file")
    ap.add_argument("--time", choices=("sim", "real"), default="sim",
                    help="the node's clock (default sim: as fast as it can; real: the wall clock, deadline misses)")
    ap.add_argument("--rate", type=float, default=50.0, help="/joint_states rate, Hz (default 50)")
    ap.add_argument("--backend", choices=("rclpy", "dds"), default="dds",
                    help="the node's transport (default dds; rclpy: run this script with a Python that has rclpy, "
                         "and its RMW's loopback configuration, e.g. FASTDDS_DEFAULT_PROFILES_FILE)")
    args = ap.parse_args()
    if args.backend == "rclpy" and not Path(os.environ.get("FASTDDS_DEFAULT_PROFILES_FILE", "")).is_file():
        print("ros2_node_soak: --backend rclpy needs FASTDDS_DEFAULT_PROFILES_FILE naming a Fast DDS profile that "
              "confines it to 127.0.0.1 (tests/ros2/kilted.py loopback_profile)", file=sys.stderr)
        return 2
    report = args.report_every or (60.0 if args.sim else 30.0)
    os.environ["CYCLONEDDS_URI"] = loopback_uri()
    os.environ["ROS_DOMAIN_ID"] = str(random.randint(1, 200))
    load0 = open("/proc/loadavg").read().strip()
    cmd = [sys.executable, "-m", "wbc", "ros2", "node", "--robot", args.robot, "--time", args.time,
           "--rate", f"{args.rate:g}", "--report-every", f"{report:g}", "--backend", args.backend] + (
        ["--sim"] if args.sim else [])
    print("node:", " ".join(cmd[1:]), flush=True)
    node = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True, cwd=str(ROOT))
    lines = []
    log = open(args.node_log, "w") if args.node_log else None

    def pump():
        for ln in node.stdout:
            lines.append(ln.rstrip())
            if log is not None:
                log.write(ln)
                log.flush()

    threading.Thread(target=pump, daemon=True).start()

    peer = RclpyPeer() if args.backend == "rclpy" else CyclonePeer()
    falls, seen = 0, 0
    period = sum(d for _, d in PATTERN)
    t_node = None
    rss, windows = [], []
    t0 = time.monotonic()
    next_sample = t0
    received = 0
    try:
        while time.monotonic() - t0 < 60 * args.minutes:
            if args.node_minutes is not None and t_node is not None and t_node >= 60 * args.node_minutes:
                break
            peer.spin()
            t_node = peer.clock if args.time == "sim" else time.monotonic() - t0
            if t_node is not None:
                phase = t_node % period
                for (vx, vy, wz), d in PATTERN:
                    if phase < d:
                        break
                    phase -= d
                if vx or vy or wz:
                    peer.twist(vx, vy, wz)
            n_lines = len(lines)  # (appended by the reader thread)
            fell = [ln for ln in lines[seen:n_lines] if ln.startswith("sim: FELL")]
            seen = n_lines
            if fell:
                falls += len(fell)
                peer.reset(falls)
                print(f"{time.monotonic() - t0:.0f} s wall: {fell[-1]} -> /reset_robot", flush=True)
            if time.monotonic() >= next_sample:
                rss.append((time.monotonic() - t0, t_node, rss_mb(node.pid)))
                windows.append(peer.joint_states - received)
                received = peer.joint_states
                next_sample += 10.0
            time.sleep(0.005)
    finally:
        node.terminate()
        node.wait(timeout=60)
        peer.close()
    time.sleep(0.5)
    load1 = open("/proc/loadavg").read().strip()
    after_1min = next(r for r in rss if r[0] >= 60.0)
    print("wall s, node s, RSS MB:")
    for r in rss:
        print(f"  {r[0]:6.0f} {r[1] or 0:8.1f} {r[2]:8.1f}")
    stats = [ln for ln in lines if ln.startswith("stats:")]
    print(f"RSS after the first minute {after_1min[2]:.1f} MB (node time {after_1min[1]:.0f} s), at the end "
          f"{rss[-1][2]:.1f} MB (node time {rss[-1][1]:.0f} s): growth {rss[-1][2] - after_1min[2]:+.1f} MB")
    print("node reports:")
    for ln in stats:
        print("  " + ln)
    if stats:
        print(f"first report ({report:g} s of node time):", stats[0])
        print(f"last report ({report:g} s of node time): ", stats[-1])
    if args.sim:
        print(f"falls (answered by /reset_robot): {falls}; walking segments started: "
              f"{sum(1 for ln in lines if ln.startswith('sim: walking'))}")
    for ln in lines:
        if ln.startswith("node: ") and ("ticks" in ln or "not kept" in ln):
            print(ln)
    full = sorted(windows[1:])
    if full:
        print(f"/joint_states received by the {args.backend} subscriber per 10 s window ({len(full)} windows after "
              f"the first): min {full[0]}, median {full[len(full) // 2]}, max {full[-1]} (expected "
              f"{10 * args.rate:g}); {peer.joint_states} in all; every window: {windows}")
    print(f"load average at the start: {load0}; at the end: {load1}")
    return 0


class CyclonePeer:
    """The driver's side on wbc's Cyclone DDS: /cmd_vel writer, /clock and /joint_states readers, /reset_robot
    (rmw_cyclonedds' request convention)."""

    def __init__(self):
        from cyclonedds.core import Policy, Qos
        from cyclonedds.pub import DataWriter
        from cyclonedds.sub import DataReader
        from cyclonedds.topic import Topic
        from cyclonedds.util import duration

        from wbc.ros2 import dds, msgs

        self.msgs = msgs
        part = dds.participant()
        q = dds.qos_stream(10)
        self.w = DataWriter(part, Topic(part, "rt/cmd_vel", msgs.Twist, qos=q), qos=q)
        be = Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(1))
        self.clock_r = DataReader(part, Topic(part, "rt/clock", msgs.Clock, qos=be), qos=be)
        js = dds.qos_stream(500)
        self.js_r = DataReader(part, Topic(part, "rt/joint_states", msgs.JointState, qos=js), qos=js)
        srv = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(10),
                  Policy.Durability.Volatile)
        self.reset_w = DataWriter(part, Topic(part, "rq/reset_robotRequest", msgs.TriggerRequest, qos=srv), qos=srv)
        self.reset_r = DataReader(part, Topic(part, "rr/reset_robotReply", msgs.TriggerReply, qos=srv), qos=srv)
        self.guid = random.getrandbits(63)
        self.clock, self.joint_states = None, 0

    def spin(self) -> None:
        for s in self.clock_r.take(N=100):
            if isinstance(s, self.msgs.Clock):
                self.clock = s.clock.sec + 1e-9 * s.clock.nanosec
        self.joint_states += sum(isinstance(s, self.msgs.JointState) for s in self.js_r.take(N=500))
        self.reset_r.take(N=10)

    def twist(self, vx: float, vy: float, wz: float) -> None:
        m = self.msgs
        self.w.write(m.Twist(m.Vector3(vx, vy, 0.0), m.Vector3(0.0, 0.0, wz)))

    def reset(self, seq: int) -> None:
        self.reset_w.write(self.msgs.TriggerRequest(client_guid=self.guid, seq=seq))

    def close(self) -> None:
        pass


class RclpyPeer:
    """The driver's side on rclpy (its RMW, Fast DDS with the wheels): /cmd_vel publisher, /clock and
    /joint_states subscriptions, a /reset_robot client."""

    def __init__(self):
        import rclpy
        from geometry_msgs.msg import Twist
        from rclpy.node import Node
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        from rosgraph_msgs.msg import Clock
        from sensor_msgs.msg import JointState
        from std_srvs.srv import Trigger

        rclpy.init()
        self.rclpy, self.Twist, self.Trigger = rclpy, Twist, Trigger
        self.node = Node("wbc_soak_driver")
        self.pub = self.node.create_publisher(Twist, "cmd_vel", 10)
        be = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
        self.clock, self.joint_states = None, 0
        self.node.create_subscription(Clock, "clock", self._clock, be)
        self.node.create_subscription(JointState, "joint_states", self._joint_states, 500)
        self.reset_c = self.node.create_client(Trigger, "reset_robot")

    def _clock(self, msg) -> None:
        self.clock = msg.clock.sec + 1e-9 * msg.clock.nanosec

    def _joint_states(self, msg) -> None:
        self.joint_states += 1

    def spin(self) -> None:
        for _ in range(50):  # what arrived, without blocking the loop
            before = self.joint_states
            self.rclpy.spin_once(self.node, timeout_sec=0)
            if self.joint_states == before:
                break

    def twist(self, vx: float, vy: float, wz: float) -> None:
        t = self.Twist()
        t.linear.x, t.linear.y, t.angular.z = float(vx), float(vy), float(wz)
        self.pub.publish(t)

    def reset(self, seq: int) -> None:
        self.reset_c.call_async(self.Trigger.Request())

    def close(self) -> None:
        self.node.destroy_node()
        self.rclpy.shutdown()


if __name__ == "__main__":
    sys.exit(main())
