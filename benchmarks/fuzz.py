"""Fuzz the kinematic controller (issue 8): N ticks over talos, g1 and humanoid15 with random targets
(reachable, absurd, 1e6 m), gains, weights, strict levels and start states. Prints the counts:
exceptions, NaN commands, limit violations beyond 1e-9, failed ticks that an independent solver (scipy HiGHS
feasibility LP of the hard set) finds feasible, holds lasting past a feasible tick, stance-sole drift on ok ticks,
failure rates of weighted vs strict episodes.

    python benchmarks/fuzz.py [--ticks 1000000] [--episode 50] [--seed 0] [--chunk 50000] [--out DIR]

Chunks of ``--chunk`` ticks use seeds seed, seed + 1, ...; with ``--out`` each finished chunk is saved there and
skipped when the command is run again (resume), and the totals are aggregated over all chunks. Several processes
may share one --out folder with different --seed (e.g. 0 and 100) and be aggregated by a final run over both.
The independent solver check runs on failed ticks only. Every episode is one stance (both soles in contact);
"stance offset" is the sole's distance from its contact placement, "tick displacement" its motion over one ok tick.
"""

from __future__ import annotations

import argparse
import json
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
    ctrl.tasks[0].gain = float(10 ** rng.uniform(0, 6))  # CoM gain up to 1e6
    ctrl.tasks[0].weight = float(10 ** rng.uniform(-2, 3))
    for contact in ctrl.constraints[:2]:
        contact.gain = float(10 ** rng.uniform(0, 3))  # drift-correction gain 1..1000 1/s (capped at 1/dt)
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
        ctrl.add_task(PostureTask(robot, weight=float(10 ** rng.uniform(-2, 1))), level=1)
        if rng.random() < 0.5:  # the CoM task moves up to the top level (above the hand)
            com_task = ctrl.tasks[0]
            ctrl.remove_task(com_task)
            ctrl.add_task(com_task, level=0)
            ctrl.remove_task(hand)
            ctrl.add_task(hand, level=1)
    else:
        ctrl.add_task(hand)
    return config, ctrl


COUNTS = ("ticks", "episodes", "exceptions", "nan", "limit_violations", "failed", "failed_feasible",
          "failed_confirmed_infeasible", "drift_failed", "holds_past_feasible", "ok_tick_displacement_over_0_05mm",
          "stance_offset_over_1mm", "weighted_ticks", "weighted_failed", "strict_ticks", "strict_failed",
          "contact_corrected_ticks")
MAXIMA = ("max_ok_tick_displacement_mm", "max_stance_offset_mm", "max_ok_sole_drift_mm")


def run_chunk(robots, limits, ticks: int, episode: int, seed: int, progress: str = "") -> dict:
    """Fuzz ``ticks`` ticks from ``seed``; returns the counts and maxima (module docstring)."""
    rng = np.random.default_rng(seed)
    c = dict.fromkeys(COUNTS, 0) | dict.fromkeys(MAXIMA, 0.0)
    t0 = time.time()
    next_print = 0
    while c["ticks"] < ticks:
        name = str(rng.choice(list(robots)))
        robot = robots[name]
        kind = str(rng.choice(["reachable", "absurd", "far"]))
        strict = bool(rng.random() < 0.5)
        c["episodes"] += 1
        try:
            config, ctrl = build_episode(robot, name, rng, kind, strict)
        except Exception as exc:  # noqa: BLE001
            c["exceptions"] += 1
            print("build exception:", type(exc).__name__, exc, flush=True)
            continue
        iq, lo, hi, vmax = limits[name]
        contacts = ctrl.constraints[:2]
        for _ in range(episode):
            c["ticks"] += 1
            c["strict_ticks" if strict else "weighted_ticks"] += 1
            try:
                before = [config.frame_placement(k.frame_id).translation.copy() for k in contacts]
                res = ctrl.solve(config, DT)
            except Exception as exc:  # noqa: BLE001
                c["exceptions"] += 1
                print("tick exception:", type(exc).__name__, exc, flush=True)
                break
            if not np.isfinite(res.v).all():
                c["nan"] += 1
                break
            if np.any(np.abs(res.v[6:]) > vmax + 1e-9):
                c["limit_violations"] += 1
            c["contact_corrected_ticks"] += int(ctrl.contact_corrections > 0)
            if not res.ok:
                c["failed"] += 1
                c["strict_failed" if strict else "weighted_failed"] += 1
                if res.fallback == "trust_region":
                    # the QP solved; its least-drifting command still moves a sole > sole_drift_tolerance
                    # (second-order, not a linear feasibility question): counted apart, v is that command
                    c["drift_failed"] += 1
                else:
                    feasible = hard_set_feasible(ctrl, config)  # independent check, failed QP ticks only
                    c["failed_feasible"] += int(feasible)
                    c["failed_confirmed_infeasible"] += int(not feasible)
                    if res.fallback == "hold" and feasible:
                        c["holds_past_feasible"] += 1
            config.update(config.integrate(res.v, DT))
            q = config.q[iq]
            if np.any(q < lo - 1e-9) or np.any(q > hi + 1e-9):
                c["limit_violations"] += 1
            if res.ok:
                moved = max(np.linalg.norm(config.frame_placement(k.frame_id).translation - p0)
                            for k, p0 in zip(contacts, before))
                offset = max(np.linalg.norm(config.frame_placement(k.frame_id).translation - k.placement.translation)
                             for k in contacts)
                c["max_ok_tick_displacement_mm"] = max(c["max_ok_tick_displacement_mm"], float(1e3 * moved))
                c["max_stance_offset_mm"] = max(c["max_stance_offset_mm"], float(1e3 * offset))
                c["max_ok_sole_drift_mm"] = max(c["max_ok_sole_drift_mm"], 1e3 * res.sole_drift)
                c["ok_tick_displacement_over_0_05mm"] += int(moved > 5e-5)
                c["stance_offset_over_1mm"] += int(offset > 1e-3)
        if c["ticks"] >= next_print:
            next_print += 10_000
            print(f"{progress}[{time.time() - t0:.0f} s] {c}", flush=True)
    c["seconds"] = time.time() - t0
    return c


def aggregate(chunks: list[dict]) -> dict:
    total = {k: sum(ch[k] for ch in chunks) for k in COUNTS}
    total |= {k: max(ch[k] for ch in chunks) for k in MAXIMA}
    total["seconds"] = sum(ch["seconds"] for ch in chunks)
    return total


def report(total: dict) -> str:
    w = total["weighted_failed"] / max(total["weighted_ticks"], 1)
    s = total["strict_failed"] / max(total["strict_ticks"], 1)
    return (f"FINAL {total}\nfailure rate weighted {w:.3e}, strict {s:.3e} "
            f"(strict ≤ weighted: {s <= w})")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--ticks", type=int, default=1_000_000, help="total ticks")
    p.add_argument("--episode", type=int, default=50, help="ticks per episode (one stance)")
    p.add_argument("--seed", type=int, default=0, help="seed of the first chunk (chunk i uses seed + i)")
    p.add_argument("--chunk", type=int, default=50_000, help="ticks per chunk (one result file each)")
    p.add_argument("--out", type=Path, default=None,
                   help="folder of per-chunk results: finished chunks are skipped (resume), all are aggregated")
    p.add_argument("--aggregate-only", action="store_true",
                   help="run nothing: aggregate every finished chunk file in --out (e.g. of several processes)")
    a = p.parse_args()
    if a.aggregate_only:
        files = sorted(a.out.glob("chunk_*.json"))
        print(f"{len(files)} chunk files in {a.out}", flush=True)
        print(report(aggregate([json.loads(f.read_text()) for f in files])), flush=True)
        return
    warnings.simplefilter("ignore")
    robots = {n: wbc.load_robot(n) for n in ("talos", "g1", "humanoid15")}
    limits = {}
    for n, r in robots.items():
        iq, iv = bounded_joints(r.model)
        vmax = r.model.velocityLimit[6:]
        limits[n] = (iq, r.model.lowerPositionLimit[iq], r.model.upperPositionLimit[iq],
                     np.where(np.isfinite(vmax) & (vmax >= 0), vmax, np.inf))
    n_chunks = max(1, -(-a.ticks // a.chunk))
    chunks = []
    if a.out is not None:
        a.out.mkdir(parents=True, exist_ok=True)
    for i in range(n_chunks):
        ticks = min(a.chunk, a.ticks - i * a.chunk)
        f = a.out / f"chunk_{a.seed + i}_{ticks}_{a.episode}.json" if a.out is not None else None
        if f is not None and f.exists():
            chunks.append(json.loads(f.read_text()))
            print(f"chunk {i + 1}/{n_chunks} (seed {a.seed + i}) already done: {f}", flush=True)
            continue
        ch = run_chunk(robots, limits, ticks, a.episode, a.seed + i, progress=f"chunk {i + 1}/{n_chunks} ")
        chunks.append(ch)
        if f is not None:
            f.write_text(json.dumps(ch))
        print(f"chunk {i + 1}/{n_chunks} done; so far: {aggregate(chunks)}", flush=True)
    print(report(aggregate(chunks)), flush=True)


if __name__ == "__main__":
    main()
