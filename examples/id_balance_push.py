"""Inverse-dynamics balance: Talos (or any catalog robot) standing in MuJoCo under the ID QP, pushed sideways.

The controller (wbc.dynamics.IDBalanceController) solves accelerations + sole corner forces with friction
pyramids, unilaterality and torque limits every 2 ms from MuJoCo's ground-truth state; the push is a lateral
force on the torso. Pass = no fall (base drop <= 0.2 m, only the soles touch the ground) and the scenario's criteria.

Run: python examples/id_balance_push.py [--robot talos] [--force 300] [--quick]
"""

import argparse

import wbc
from wbc.cli.output import format_value
from wbc.sim.actuators import joint_speed_margins
from wbc.sim.mujoco_model import build_mujoco_model
from wbc.sim.physics_scenarios import id_options_for
from wbc.sim.scenarios import PushScenario, make_controller, run_scenario

parser = argparse.ArgumentParser(description=" ".join(__doc__.split("\n\n")[0].split()))  # the first paragraph
parser.add_argument("--robot", default="talos", help="catalog robot (default talos)")
parser.add_argument("--force", type=float, default=300.0, help="lateral push on the torso, N (default 300)")
parser.add_argument("--quick", action="store_true", help="humanoid15, 1 s of settling after the push (CI)")
args = parser.parse_args()

robot = wbc.load_robot("humanoid15" if args.quick else args.robot)
sim = build_mujoco_model(robot)                          # the same URDF in MuJoCo, sole boxes, elliptic cones
# the joint speed bounds with `wbc sim`'s margins (legs 5 %, upper body 30 % below the URDF limits): the QP bounds
# the predicted next-tick speed, and the push it does not know of adds to it
controller = make_controller(robot, "id", dt=sim.timestep, speed_margin=joint_speed_margins(robot),
                             **id_options_for(robot))
force = 60.0 if args.quick else args.force
scenario = PushScenario(force, push_duration=0.1, settle=1.0 if args.quick else 2.5)
run, summary = run_scenario(sim, controller, scenario)   # closed loop at 500 Hz, one mj_step per tick

print(f"{robot.name}: pushed {force:.0f} N for 0.1 s, {len(run.t)} ticks")
for key in ("fell", "fall_reason", "max_com_deviation_m", "min_cop_margin_m", "min_friction_margin_n",
            "joint_speed_exceedances", "max_joint_speed_ratio", "max_joint_speed_joint", "solver_failures", "passed"):
    if summary.get(key) not in (None, ""):
        print(f"  {key}: {format_value(summary[key], key)}")  # rounded to the unit's resolution
for failed in summary["failed_criteria"]:  # the requirement, then what the run measured
    print(f"  failed: {failed}")
raise SystemExit(0 if summary["passed"] else 1)
