"""Fuzz the kinematic controller (issue 8): N ticks over talos, g1 and humanoid15 with random targets
(reachable, absurd, 1e6 m), gains, weights, strict levels and start states. Prints the counts:
exceptions, NaN commands, limit violations beyond 1e-9, failed ticks that an independent solver (scipy HiGHS
feasibility LP of the hard set) finds feasible, holds lasting past a feasible tick, stance-sole drift on ok ticks,
failure rates of weighted vs strict episodes.

    python benchmarks/fuzz.py [--ticks 1000000] [--episode 50] [--seed 0]
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import scipy.optimize

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import wbc  # noqa: E402
from conftest import random_configuration, standing_controller  # noqa: E402
from wbc.configuration import Configuration  # noqa: E402
from wbc.constraints.limits import bounded_joints  # noqa: E402
from wbc.tasks import FrameTask, PostureTask  # noqa: E402

DT = 0.002
HANDS = {"talos": "gripper_left_joint", "g1": "left_wrist_roll_joint", "humanoid15": None}


def hard_set_feasible(ctrl, config) -> bool:
    """Independent check (scipy HiGHS LP, tolerance 1e-7): does any v meet the hard rows at config?"""
    H, g, A, b, C, l, u, lb, ub = ctrl.assemble(config, DT)
    n = H.shape[0]
    A_ub, b_ub = [], []
    for rows, hi, sign in ((C, u, 1.0), (C, l, -1.0)):
        m = np.isfinite(hi)
        if m.any():
            A_ub.append(sign * rows[m])
            b_ub.append(sign * hi[m])
    r = scipy.optimize.linprog(np.zeros(n), A_ub=np.vstack(A_ub) if A_ub else None,
                               b_ub=np.concatenate(b_ub) if b_ub else None, A_eq=A if A.shape[0] else None,
                               b_eq=b if A.shape[0] else None,
                               bounds=[(lo if np.isfinite(lo) else None, hi if np.isfinite(hi) else None)
                                       for lo, hi in zip(lb, ub)], method="highs",
                               options={"primal_feasibility_tolerance": 1e-7})
    return r.status == 0


def build_episode(robot, name, rng, kind, strict):
    config = Configuration(robot, random_configuration(robot, rng, spread=0.2) if rng.random() < 0.5 else None)
    config.q[:7] = robot.q_ref[:7]
    config.update(config.q)
    ctrl, com = standing_controller(robot, config)
    ctrl.sole_drift_tolerance = 5e-5  # contact trust region on (m per tick)
    ctrl.tasks[0].gain = float(10 ** rng.uniform(0, 6))  # CoM gain up to 1e6
    frame = HANDS[name] or robot.torso
    hand = FrameTask(robot, frame, gain=float(10 ** rng.uniform(-1, 4)),
                     position_weight=float(10 ** rng.uniform(-3, 3)), orientation_weight=0.0, name="hand")
    target = config.frame_placement(hand.frame_id).copy()
    scale = {"reachable": 0.05, "absurd": 2.0, "far": 1e6}[kind]
    d = rng.normal(size=3)
    target.translation += scale * d / np.linalg.norm(d)
    hand.set_target(target)
    com.set_target(config.com + rng.uniform(-0.05, 0.05, 3) * (20 if kind != "reachable" else 1))
    if strict:
        ctrl.add_task(hand, level=0)
        ctrl.add_task(PostureTask(robot, weight=1.0), level=1)
    else:
        ctrl.add_task(hand)
    return config, ctrl


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--ticks", type=int, default=1_000_000)
    p.add_argument("--episode", type=int, default=50)
    p.add_argument("--seed", type=int, default=0)
    a = p.parse_args()
    warnings.simplefilter("ignore")
    rng = np.random.default_rng(a.seed)
    robots = {n: wbc.load_robot(n) for n in ("talos", "g1", "humanoid15")}
    limits = {}
    for n, r in robots.items():
        iq, iv = bounded_joints(r.model)
        vmax = r.model.velocityLimit[6:]
        limits[n] = (iq, r.model.lowerPositionLimit[iq], r.model.upperPositionLimit[iq],
                     np.where(np.isfinite(vmax) & (vmax >= 0), vmax, np.inf))
    c = dict(ticks=0, exceptions=0, nan=0, limit_violations=0, failed=0, failed_feasible=0, drift_failed=0,
             holds_past_feasible=0, ok_drift_over_0_05mm=0, weighted_ticks=0, weighted_failed=0,
             strict_ticks=0, strict_failed=0)
    max_drift = 0.0
    t0 = time.time()
    while c["ticks"] < a.ticks:
        name = rng.choice(list(robots))
        robot = robots[name]
        kind = rng.choice(["reachable", "absurd", "far"])
        strict = bool(rng.random() < 0.5)
        try:
            config, ctrl = build_episode(robot, name, rng, kind, strict)
        except Exception as exc:  # noqa: BLE001
            c["exceptions"] += 1
            print("build exception:", type(exc).__name__, exc)
            continue
        iq, lo, hi, vmax = limits[name]
        contacts = ctrl.constraints[:2]
        prev_failed_feasible = False
        for _ in range(a.episode):
            c["ticks"] += 1
            c["strict_ticks" if strict else "weighted_ticks"] += 1
            try:
                before = [config.frame_placement(k.frame_id).translation.copy() for k in contacts]
                res = ctrl.solve(config, DT)
            except Exception as exc:  # noqa: BLE001
                c["exceptions"] += 1
                print("tick exception:", type(exc).__name__, exc)
                break
            if not np.isfinite(res.v).all():
                c["nan"] += 1
                break
            if np.any(np.abs(res.v[6:]) > vmax + 1e-9):
                c["limit_violations"] += 1
            if not res.ok:
                c["failed"] += 1
                c["strict_failed" if strict else "weighted_failed"] += 1
                if res.fallback == "trust_region":
                    c["drift_failed"] += 1
                else:
                    feasible = hard_set_feasible(ctrl, config)
                    c["failed_feasible"] += int(feasible)
                    if res.fallback == "hold" and prev_failed_feasible:
                        c["holds_past_feasible"] += 1
                    prev_failed_feasible = feasible
            config.update(config.integrate(res.v, DT))
            q = config.q[iq]
            if np.any(q < lo - 1e-9) or np.any(q > hi + 1e-9):
                c["limit_violations"] += 1
            if res.ok:
                drift = max(np.linalg.norm(config.frame_placement(k.frame_id).translation - p0)
                            for k, p0 in zip(contacts, before))
                max_drift = max(max_drift, drift)
                c["ok_drift_over_0_05mm"] += int(res.sole_drift > 5e-5)
        if c["ticks"] % 5000 < a.episode:
            print(f"[{time.time() - t0:.0f} s] {c} max sole displacement on ok ticks {1e3 * max_drift:.4f} mm",
                  flush=True)
    print(f"FINAL {c} max sole displacement on ok ticks {1e3 * max_drift:.4f} mm "
          f"({time.time() - t0:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
