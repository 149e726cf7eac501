"""Stance-sole drift per tick under aggressive targets (issue 8): the contact rows are linear in v, so a large
v dt moves the sole to second order. Prints the measured drift (actual sole displacement after pin.integrate) on
ok ticks for: no correction and no trust region (first-order contact rows only), the second-order contact
correction alone (KinematicController default contact_correction=1e-6 m, trust region off), and the defaults
(correction + trust region at sole_drift_tolerance=5e-5 m).

    python benchmarks/sole_drift.py [--robot g1] [--ticks 300]
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import wbc  # noqa: E402
from conftest import standing_controller  # noqa: E402
from wbc.configuration import Configuration  # noqa: E402
from wbc.tasks import FrameTask  # noqa: E402

DT = 0.002


def run(robot, ticks: int, options: dict, seed: int = 0):
    from wbc.controllers.kinematic import KinematicController

    rng = np.random.default_rng(seed)
    config = Configuration(robot)
    base, com = standing_controller(robot, config)
    ctrl = KinematicController(robot, base.tasks, base.constraints, **options)
    contacts = ctrl.constraints[:2]
    hand_frames = [f.name for f in robot.model.frames if "hand" in f.name.lower() or "wrist" in f.name.lower()]
    hand = FrameTask(robot, hand_frames[0], gain=1000.0, position_weight=100.0, name="hand")
    ctrl.add_task(hand)
    per_tick, ok_ticks = [], 0
    for k in range(ticks):
        if k % 50 == 0:  # a new, often unreachable, hand target every 0.1 s
            target = config.frame_placement(hand.frame_id).copy()
            target.translation += rng.uniform(-1.0, 1.0, 3)
            hand.set_target(target)
            com.set_target(config.com + rng.uniform(-0.1, 0.1, 3))
        before = [config.frame_placement(c.frame_id).translation.copy() for c in contacts]
        res = ctrl.solve(config, DT)
        config.update(config.integrate(res.v, DT))
        after = [config.frame_placement(c.frame_id).translation for c in contacts]
        if res.ok:
            ok_ticks += 1
            per_tick.append(max(np.linalg.norm(a - b) for a, b in zip(after, before)))
    total = max(np.linalg.norm(config.frame_placement(c.frame_id).translation - c.placement.translation)
                for c in contacts)
    return ok_ticks, np.array(per_tick), total, hand_frames[0]


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--robot", default="g1")
    p.add_argument("--ticks", type=int, default=300)
    a = p.parse_args()
    warnings.simplefilter("ignore")
    robot = wbc.load_robot(a.robot)
    variants = (("no correction, no trust region", dict(contact_correction=0.0, sole_drift_tolerance=None)),
                ("correction only", dict(sole_drift_tolerance=None)),
                ("defaults: correction + trust region 5e-5 m", {}))
    for label, options in variants:
        ok, d, total, frame = run(robot, a.ticks, options)
        print(f"{a.robot} [{label}] hand={frame}: ok ticks {ok}/{a.ticks}; sole displacement per ok tick: "
              f"max {1e3 * d.max():.4f} mm, p99 {1e3 * np.percentile(d, 99):.4f} mm, median "
              f"{1e3 * np.median(d):.5f} mm; sole offset from contact at end {1e3 * total:.4f} mm")


if __name__ == "__main__":
    main()
