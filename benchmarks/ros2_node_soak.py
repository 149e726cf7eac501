"""Soak of `wbc ros2 node --time sim` (with ``--sim``: the MuJoCo closed loop) driven by /cmd_vel: memory (RSS)
and tick time over a long run.

Starts the node (``--robot``, default g1: humanoid15 has no hip yaw and cannot turn; loopback-only DDS, random
domain) with ``--report-every R`` (node time; default 30 s, 60 s with ``--sim``), drives it with a repeating
/cmd_vel pattern in node time (read from /clock): walk 0.3 m/s 10 s, walk-and-turn (0.1 m/s, 0.3 rad/s) 10 s,
side-step 0.05 m/s 10 s, stop 6 s — and samples the node's VmRSS (/proc/<pid>/status) every 10 s of wall time.
With ``--sim`` a fall (the node prints ``sim: FELL``) is answered by a /reset_robot call and counted.

    python benchmarks/ros2_node_soak.py --minutes 5
    python benchmarks/ros2_node_soak.py --sim --minutes 150 --node-minutes 61   # an hour of node time
    nice -n 10 python benchmarks/ros2_node_soak.py --sim --minutes 60 --node-log /tmp/node.log

Prints the RSS after the first minute (wall) and at the end, its growth, and the node's tick p50/p99 of its first
and last report (each over ``R`` s of node time: with ``--sim`` the first and the last minute of node time).
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
    ap.add_argument("--backend", choices=("auto", "rclpy", "dds"), default="dds",
                    help="the node's transport (default dds; rclpy: run this script with a Python that has rclpy, "
                         "and its RMW's loopback configuration, e.g. FASTDDS_DEFAULT_PROFILES_FILE)")
    args = ap.parse_args()
    report = args.report_every or (60.0 if args.sim else 30.0)
    os.environ["CYCLONEDDS_URI"] = loopback_uri()
    os.environ["ROS_DOMAIN_ID"] = str(random.randint(1, 200))
    cmd = [sys.executable, "-m", "wbc", "ros2", "node", "--robot", args.robot, "--time", "sim",
           "--report-every", f"{report:g}", "--backend", args.backend] + (["--sim"] if args.sim else [])
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

    from cyclonedds.core import Policy, Qos
    from cyclonedds.pub import DataWriter
    from cyclonedds.sub import DataReader
    from cyclonedds.topic import Topic
    from cyclonedds.util import duration

    from wbc.ros2 import dds, msgs

    part = dds.participant()
    q = dds.qos_stream(10)
    w = DataWriter(part, Topic(part, "rt/cmd_vel", msgs.Twist, qos=q), qos=q)
    be = Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(1))
    clock = DataReader(part, Topic(part, "rt/clock", msgs.Clock, qos=be), qos=be)
    srv = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(10), Policy.Durability.Volatile)
    reset_w = DataWriter(part, Topic(part, "rq/reset_robotRequest", msgs.TriggerRequest, qos=srv), qos=srv)
    reset_r = DataReader(part, Topic(part, "rr/reset_robotReply", msgs.TriggerReply, qos=srv), qos=srv)
    guid = random.getrandbits(63)
    falls, seen = 0, 0
    period = sum(d for _, d in PATTERN)
    t_node = None
    rss = []
    t0 = time.monotonic()
    next_sample = t0
    try:
        while time.monotonic() - t0 < 60 * args.minutes:
            if args.node_minutes is not None and t_node is not None and t_node >= 60 * args.node_minutes:
                break
            for s in clock.take(N=100):
                if isinstance(s, msgs.Clock):
                    t_node = s.clock.sec + 1e-9 * s.clock.nanosec
            if t_node is not None:
                phase = t_node % period
                for (vx, vy, wz), d in PATTERN:
                    if phase < d:
                        break
                    phase -= d
                if vx or vy or wz:
                    w.write(msgs.Twist(msgs.Vector3(vx, vy, 0.0), msgs.Vector3(0.0, 0.0, wz)))
            n_lines = len(lines)  # (appended by the reader thread)
            fell = [ln for ln in lines[seen:n_lines] if ln.startswith("sim: FELL")]
            seen = n_lines
            if fell:
                falls += len(fell)
                reset_w.write(msgs.TriggerRequest(client_guid=guid, seq=falls))
                print(f"{time.monotonic() - t0:.0f} s wall: {fell[-1]} -> /reset_robot", flush=True)
            reset_r.take(N=10)
            if time.monotonic() >= next_sample:
                rss.append((time.monotonic() - t0, t_node, rss_mb(node.pid)))
                next_sample += 10.0
            time.sleep(0.005)
    finally:
        node.terminate()
        node.wait(timeout=60)
    time.sleep(0.5)
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
    print(lines[-1] if lines else "")
    return 0


if __name__ == "__main__":
    sys.exit(main())
