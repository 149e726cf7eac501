"""MuJoCo closed loop written out: read the state, solve the inverse-dynamics QP, apply torques, step.

The CoM sways sideways (sinusoid, 2 cm) while both soles stay in contact; the script reports the CoM tracking
error measured on MuJoCo's state and the lowest base height.

Run: python examples/mujoco_closed_loop.py [--robot talos] [--seconds 4] [--quick]
"""

import argparse

import numpy as np
import pinocchio as pin

import wbc
from wbc.dynamics import IDBalanceController
from wbc.sim.mujoco_model import build_mujoco_model
from wbc.sim.physics_scenarios import id_options_for

parser = argparse.ArgumentParser(description=" ".join(__doc__.split("\n\n")[0].split()))  # the first paragraph
parser.add_argument("--robot", default="talos", help="catalog robot (default talos)")
parser.add_argument("--seconds", type=float, default=4.0, help="simulated time, s (default 4)")
parser.add_argument("--quick", action="store_true", help="humanoid15, 1 s (CI)")
args = parser.parse_args()

robot = wbc.load_robot("humanoid15" if args.quick else args.robot)
sim = build_mujoco_model(robot)
dt = sim.timestep                                        # 2 ms: one mj_step per control tick
ctrl = IDBalanceController(robot, dt=dt, **id_options_for(robot))
sim.set_state(robot.q_ref)
q, v = sim.get_state()                                   # Pinocchio conventions (quaternion x, y, z, w)
ctrl.reset(q, v)
data = robot.model.createData()
c0 = pin.centerOfMass(robot.model, data, q).copy()
amplitude, omega = 0.02, 2 * np.pi * 0.5                 # 2 cm at 0.5 Hz
n = int(round((1.0 if args.quick else args.seconds) / dt))
errors, base_z = np.empty(n), np.empty(n)
for k in range(n):
    t = k * dt
    s, c = np.sin(omega * t), np.cos(omega * t)
    ctrl.set_com_reference(c0 + [0.0, amplitude * s, 0.0], velocity=[0.0, amplitude * omega * c, 0.0],
                           acceleration=[0.0, -amplitude * omega**2 * s, 0.0])
    q, v = sim.get_state()                               # ground truth, no estimation
    cmd = ctrl.solve(q, v)                               # accelerations, sole forces, torques (nv − 6,)
    sim.set_torques(cmd.tau)
    sim.step()
    com = pin.centerOfMass(robot.model, data, q)
    errors[k] = np.linalg.norm(com[:2] - (c0[:2] + [0.0, amplitude * s]))
    base_z[k] = q[2]

print(f"{robot.name}: {n} ticks; CoM tracking error (xy) max {errors.max() * 1e3:.2f} mm, "
      f"mean {errors.mean() * 1e3:.2f} mm; base height {base_z.min():.3f}–{base_z.max():.3f} m")
fell = base_z.min() < robot.q_ref[2] - 0.2
raise SystemExit(1 if fell or errors.max() > 0.01 else 0)
