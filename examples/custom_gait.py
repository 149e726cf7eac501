"""A custom gait plan: a curved walk with lateral drift, planned with wbc.gait.plan_walk and tracked by the
kinematic QP. Prints where the feet landed against where the plan put them.

Run: python examples/custom_gait.py [--robot talos] [--steps 6] [--quick]
"""

import argparse
import math

import numpy as np

import wbc
from wbc.gait import plan_walk
from wbc.scenarios.walk import run_walk, walk_summary

parser = argparse.ArgumentParser(description=" ".join(__doc__.split("\n\n")[0].split()))  # the first paragraph
parser.add_argument("--robot", default="talos", help="catalog robot (default talos)")
parser.add_argument("--steps", type=int, default=6, help="number of steps (default 6)")
parser.add_argument("--quick", action="store_true", help="3 steps (CI)")
args = parser.parse_args()

robot = wbc.load_robot(args.robot)                   # a robot with hip yaw: humanoid15 cannot turn
config = wbc.Configuration(robot)
left = config.frame_placement(robot.frame_id(robot.left_sole))    # the current stance, world
right = config.frame_placement(robot.frame_id(robot.right_sole))
plan = plan_walk(
    left, right, config.com.copy(),
    n_steps=3 if args.quick else args.steps,
    step_length=0.6 * robot.gait["step_length"],      # m per step (the robot's default, shortened)
    turn=math.radians(8.0),                           # rad of heading per step
    step_lateral=0.01,                                # m per step to the left
    step_height=0.04, t_ss=0.8, t_ds=0.3,             # swing apex (m), single/double support (s)
    sole_length=robot.sole_length, sole_width=robot.sole_width,
)
print(f"plan: {len(plan.footsteps)} footsteps, {plan.t[-1]:.2f} s")
run = run_walk(robot, plan, config=config)            # one QP per tick, the plan's rows as targets
summary = walk_summary(robot, plan, run)
heading = math.degrees(math.atan2(run.left_sole[-1, 1, 0], run.left_sole[-1, 0, 0]))
print(f"walked {summary['walked_distance_m']:.3f} m of {summary['planned_distance_m']:.3f} m planned, "
      f"final left-sole heading {heading:.1f} deg")
print(f"max CoM error {summary['max_com_error_m'] * 1e3:.2f} mm, stance slip "
      f"{summary['max_stance_slip_m'] * 1e3:.3f} mm, passed: {summary['passed']} {summary['failed_criteria']}")
raise SystemExit(0 if summary["passed"] else 1)
