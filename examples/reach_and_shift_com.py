"""Shift the CoM and move a hand while both Talos soles stay fixed (the README's API example).

Run: python examples/reach_and_shift_com.py [--quick]
"""

import argparse

import numpy as np
import wbc
from wbc.constraints import ContactConstraint, JointPositionLimit, JointVelocityLimit
from wbc.tasks import ComTask, PositionTask, PostureTask

parser = argparse.ArgumentParser(description=" ".join(__doc__.split("\n\n")[0].split()))  # the first paragraph
parser.add_argument("--quick", action="store_true", help="0.5 s instead of 2 s (CI)")
args = parser.parse_args()

robot = wbc.load_robot("talos")                       # free flyer, half_sitting, soles on z = 0
config = wbc.Configuration(robot)                     # q and Pinocchio's kinematics, updated per tick
feet = [ContactConstraint(robot, f) for f in (robot.left_sole, robot.right_sole)]
for foot in feet:
    foot.set_placement_from_configuration(config)     # hard constraint: J_foot v = 0
com = ComTask(weight=10.0, gain=50.0)                 # weight: trade-off between tasks; gain: 1/s
hand = PositionTask(robot, robot.right_hand, weight=10.0, gain=50.0)
com.set_target(config.com + [0.0, 0.03, -0.05])       # world frame, m
target = config.frame_placement(hand.frame_id).copy()
target.translation += [0.15, 0.0, 0.10]               # hand 15 cm forward, 10 cm up
hand.set_target(target)
ctrl = wbc.KinematicController(robot, [com, hand, PostureTask(robot)],
                               [*feet, JointPositionLimit(robot), JointVelocityLimit(robot)])
for _ in range(250 if args.quick else 1000):          # 2 s at 500 Hz
    v = ctrl.solve(config, dt=0.002).v                # QP → generalized velocity (nv,)
    config.step(v, dt=0.002)                          # q ← pin.integrate(q, v dt); kinematics updated
print(f"CoM error {np.linalg.norm(com.compute_error(config)) * 1e3:.2f} mm, "
      f"hand error {np.linalg.norm(hand.compute_error(config)) * 1e3:.2f} mm")
