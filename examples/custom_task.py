"""A custom task: keep both hands at the same height (one row, e = z_left_hand − z_right_hand), added to the
kinematic QP next to the library's tasks while the right hand is raised. A task only has to give its error
e(q) and Jacobian J = ∂e/∂q; the script checks J against a finite difference first.

Run: python examples/custom_task.py [--robot talos] [--quick]
"""

import argparse

import numpy as np
import pinocchio as pin

import wbc
from wbc.constraints import ContactConstraint, JointPositionLimit, JointVelocityLimit
from wbc.tasks import PositionTask, PostureTask, Task


class HandsLevelTask(Task):
    """e = z_left − z_right (m, world), J = the difference of the two hands' vertical Jacobian rows (1, nv)."""

    dim = 1

    def __init__(self, robot, *, weight=1.0, gain: float = 50.0):
        super().__init__(gain=gain, weight=weight, name="hands_level")
        self.left, self.right = robot.frame_id(robot.left_hand), robot.frame_id(robot.right_hand)

    def compute(self, config):
        z = config.frame_placement(self.left).translation[2] - config.frame_placement(self.right).translation[2]
        jac = config.frame_jacobian(self.left)[2] - config.frame_jacobian(self.right)[2]  # LOCAL_WORLD_ALIGNED
        return np.array([z]), jac[None, :]


parser = argparse.ArgumentParser(description=" ".join(__doc__.split("\n\n")[0].split()))  # the first paragraph
parser.add_argument("--robot", default="talos", help="catalog robot (default talos)")
parser.add_argument("--quick", action="store_true", help="humanoid15, 0.5 s (CI)")
args = parser.parse_args()
robot = wbc.load_robot("humanoid15" if args.quick else args.robot)
config = wbc.Configuration(robot)
level = HandsLevelTask(robot, weight=10.0)

dv = 1e-6 * np.random.default_rng(0).standard_normal(robot.model.nv)   # J dv ≈ e(q ⊕ dv) − e(q)
e0, jac = level.compute(config)
moved = wbc.Configuration(robot, pin.integrate(robot.model, config.q, dv))
print(f"Jacobian vs finite difference: {abs((level.compute(moved)[0] - e0)[0] - (jac @ dv)[0]):.1e} m")

feet = [ContactConstraint(robot, f) for f in (robot.left_sole, robot.right_sole)]
for foot in feet:
    foot.set_placement_from_configuration(config)
hand = PositionTask(robot, robot.right_hand, weight=10.0, gain=20.0)
target = config.frame_placement(hand.frame_id).copy()
target.translation += [0.0, 0.0, 0.10]                   # raise the right hand 10 cm
hand.set_target(target)
ctrl = wbc.KinematicController(robot, [hand, level, PostureTask(robot)],
                               [*feet, JointPositionLimit(robot), JointVelocityLimit(robot)])
for _ in range(250 if args.quick else 1500):
    config.step(ctrl.solve(config, dt=0.002).v, dt=0.002)
lift = config.frame_placement(level.left).translation[2] - target.translation[2] + 0.10
print(f"right hand error {np.linalg.norm(hand.compute_error(config)) * 1e3:.1f} mm, hands level within "
      f"{abs(level.compute_error(config)[0]) * 1e3:.1f} mm: the left hand followed up by {lift * 1e3:.1f} mm")
raise SystemExit(0 if abs(level.compute_error(config)[0]) < 0.02 else 1)
