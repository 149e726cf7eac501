"""ROS 2 publishing: a walk's joint states and transforms on DDS (loopback only) and in a rosbag2, then the bag
read back with rosbags. Needs the ros2 extra (pip install -e ".[ros2]"), no ROS 2 install.

Run: python examples/ros2_publish.py [--robot humanoid15] [--bag DIR] [--quick]
"""

import argparse
import tempfile
from pathlib import Path

import wbc
from wbc.ros2 import Ros2UnavailableError, require

parser = argparse.ArgumentParser(description=" ".join(__doc__.split("\n\n")[0].split()))  # the first paragraph
parser.add_argument("--robot", default="humanoid15", help="catalog robot (default humanoid15)")
parser.add_argument("--bag", type=Path, default=None, help="rosbag2 folder to create (default: a temporary one)")
parser.add_argument("--quick", action="store_true", help="2 steps (CI)")
args = parser.parse_args()
try:
    require()                                            # before any work: one line when the extra is missing
except Ros2UnavailableError as exc:
    raise SystemExit(f"ros2_publish.py: {exc}") from None

from wbc.ros2.dds import domain_id, use_loopback  # noqa: E402
from wbc.ros2.publisher import Ros2Publisher  # noqa: E402
from wbc.scenarios.walk import plan_default_walk, run_walk  # noqa: E402

use_loopback()                                           # CYCLONEDDS_URI: interface lo, multicast off
robot = wbc.load_robot(args.robot)
run = run_walk(robot, plan_default_walk(robot, n_steps=2 if args.quick else 6))
bag = args.bag or Path(tempfile.mkdtemp()) / "walk_bag"

# /joint_states and /tf at 100 Hz of the run's time; /tf_static and /robot_description latched
pub = Ros2Publisher(robot, rate=100.0, tf="all", bag=bag, storage="mcap", dt=run.dt, clock="sim")
for k in range(len(run.t)):
    pub.update(run.q[k], run.t[k], v=run.v[k])
pub.close()
print(f"{robot.name}: published {pub.published} samples on ROS_DOMAIN_ID {domain_id()}, bag {bag}")

from rosbags.highlevel import AnyReader  # noqa: E402

with AnyReader([bag]) as reader:
    counts = {c.topic: c.msgcount for c in reader.connections}
    conn = next(c for c in reader.connections if c.topic == "/joint_states")
    first = next(reader.messages(connections=[conn]))
    msg = reader.deserialize(first[2], conn.msgtype)
print("bag topics:", counts)
print(f"first /joint_states: {len(msg.name)} joints, {msg.name[0]} = {msg.position[0]:.4f} rad")
raise SystemExit(0 if counts.get("/joint_states") == pub.published else 1)
