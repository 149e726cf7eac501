"""A custom robot: humanoid15 carrying a 3 kg backpack, as a URDF of your own — the payload is a link fixed to
the torso — loaded by path with its frames named, checked by the loader, then walked under the kinematic QP.

Run: python examples/custom_robot.py [--payload 3.0] [--quick]
"""

import argparse
import tempfile
from pathlib import Path

import wbc
from wbc.scenarios.walk import plan_default_walk, run_walk, walk_summary

parser = argparse.ArgumentParser(description=" ".join(__doc__.split("\n\n")[0].split()))  # the first paragraph
parser.add_argument("--payload", type=float, default=3.0, help="backpack mass, kg (default 3)")
parser.add_argument("--quick", action="store_true", help="2 steps (CI)")
args = parser.parse_args()

base = wbc.load_robot("humanoid15")
urdf = Path(base.urdf_path).read_text()
m = args.payload
backpack = f"""
  <link name="backpack">
    <inertial><origin xyz="-0.12 0 0.05"/><mass value="{m}"/>
      <inertia ixx="{m * 0.01:.4f}" iyy="{m * 0.01:.4f}" izz="{m * 0.01:.4f}" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><origin xyz="-0.12 0 0.05"/><geometry><box size="0.1 0.25 0.3"/></geometry></visual>
  </link>
  <joint name="backpack_joint" type="fixed"><parent link="torso"/><child link="backpack"/></joint>
</robot>"""
folder = Path(tempfile.mkdtemp())
path = folder / "humanoid15_backpack.urdf"
path.write_text(urdf.replace("</robot>", backpack))
(folder / "humanoid15_backpack.srdf").write_text(Path(base.urdf_path).with_suffix(".srdf").read_text())

robot = wbc.load_robot(str(path), srdf=str(path.with_suffix(".srdf")), reference="standing",
                       left_sole="left_sole", right_sole="right_sole", torso="torso")
config = wbc.Configuration(robot)
print(f"{robot.name}: {robot.mass:.2f} kg (humanoid15 {base.mass:.2f} kg), CoM x {config.com[0] * 1e3:.1f} mm "
      f"(humanoid15 {wbc.Configuration(base).com[0] * 1e3:.1f} mm), sole {robot.sole_length} × {robot.sole_width} m")
plan = plan_default_walk(robot, config, n_steps=2 if args.quick else 6)
run = run_walk(robot, plan, config=config)
summary = walk_summary(robot, plan, run)
print(f"walked {summary['walked_distance_m']:.3f} of {summary['planned_distance_m']:.3f} m, executed ZMP margin "
      f"{summary['min_zmp_margin_m'] * 1e3:.1f} mm, passed: {summary['passed']} {summary['failed_criteria']}")
raise SystemExit(0 if summary["passed"] else 1)
