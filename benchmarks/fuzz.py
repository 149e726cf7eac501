"""Fuzz the kinematic controller (issue 8): N ticks over talos, g1 and humanoid15 with random targets
(reachable, absurd, 1e6 m), gains, weights, strict levels and start states. Prints the counts:
exceptions, NaN commands, limit violations beyond 1e-9, failed ticks that an independent solver (scipy HiGHS
feasibility LP of the hard set) finds feasible, holds lasting past a feasible tick, stance-sole drift on ok ticks,
failure rates of weighted vs strict episodes.

    python benchmarks/fuzz.py [--ticks 1000000] [--jobs 2] [--episode 50] [--seed 0] [--chunk 50000] [--out DIR]
                              [--dts 0.002,0.005,0.01,0.02] [--past-limits 0.2] [--budget SECONDS] [--clock-guard]

``--dts``: each episode's control period drawn from this list (default 0.002). ``--past-limits``: fraction of
episodes that start with 2–5 leg joints 5–50 mrad past their limits (a "limit violation" is then a joint moving
further out, or a joint inside its range leaving it). ``--budget``: the controller's tick budget (default: None,
the tick's dt). ``--clock-guard``: the controllers' clock guard on (``KinematicController.clock_guard``: the
tick's CPU time also counts as work). Issue 29 lines: holds longer than 50 ticks on a state where a slower return is feasible (HiGHS
LP on the return-rate scale, checked once per such hold), the largest stance-sole displacement over any run of
failed ticks (forward kinematics, from where the run began), tick time p50/p99/max and the ticks past their
budget, the fallback rate, and the count of ticks per route and per path (``TickResult.path``; a route outside
``wbc.tick.KINEMATIC_ROUTES`` fails the run).

Chunks of ``--chunk`` ticks use seeds seed, seed + 1, ...; ``--jobs N`` runs them in N processes (each chunk its
own seed, results summed); with ``--out`` each finished chunk is saved there and skipped when the command is run
again (resume), and the totals are aggregated over all chunks. The independent solver check runs on failed ticks
only. Every episode is one stance (both soles in contact). Measured by forward kinematics in this script, not
read from the controller: "stance offset" is a sole's distance from its contact placement; "sole drift" over an
ok tick is the distance between where the sole ends and where its contact row sent it (the placement composed
with exp((1 − K dt) e), e the sole's 6-D error before the tick: the commanded drift correction is not drift);
"tick displacement" is the sole's whole motion over the tick (drift + commanded correction, reported for
information). The last lines print every acceptance item of issue 8 with its measured value and PASS/FAIL, and
the (seed, episode, tick) of every tick that broke one (first 20 of each kind). Each slow tick's record carries what
ran beside it (``fuzz_common.TickProbe``: collections, page faults, switches, and a fixed-work canary timed just
before and after it, as a ratio to its median: the machine's speed at that moment); the ticks over 2 x their
budget with a canary over 1.5 x are counted on an info line.

Every tick over 2 x its budget is re-measured after the run, in the main process: its episode is replayed
``fuzz_common.REPLAYS`` times (the same draws give the same ticks; episodes interleaved) and the tick-CPU acceptance
item passes when the median of each such tick's replays is at most 2 x (``fuzz_common.replay_over``). The run's
own maximum and counts stay on that line: a tick slow in the run and not in its replays was slowed by the machine
(a VM's stall, another process), one slow again is slow by its work. ``--aggregate-only`` replays too: give it the
run's options.

Start-up: each process (a ``--jobs`` worker, or the main process) runs a warm-up before its first chunk: one episode
of ``WARMUP_TICKS`` ticks per robot and per kind (weighted, strict), from its own seed (``WARMUP_SEED``: the chunks'
draws are unchanged), not counted in any line. A process's first ticks pay the first use of its memory and code
(minor page faults: 964 on the first tick of a worker of the 10^6-tick run, 2.2 x its budget), which a real-time loop
pays once at start-up. The warm-up's first tick and its slowest are printed when it runs and again on the
"info: start-up" line of the report (per process: CPU time, ratio to the budget, minor page faults).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import sys
import time
from collections import Counter
from pathlib import Path

# BLAS on the calling thread, as a real-time loop runs it: a BLAS worker thread that the scheduler has not placed
# makes the calling thread spin inside the tick (read before numpy loads BLAS)
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from conftest import random_configuration, standing_controller  # noqa: E402
from fuzz_common import (acceptance_verdict, coincident_stalls, collect_between_episodes, freeze_after_first,  # noqa: E402
                         highs_feasible, load_robots, over_line, record_over, replay_over, slow_canary_ticks,
                         tick_probe)
from wbc.configuration import Configuration  # noqa: E402
from wbc.constraints.limits import bounded_joints  # noqa: E402
from wbc.tasks import FrameTask, PostureTask  # noqa: E402
from wbc.tick import KINEMATIC_ROUTES, count_paths  # noqa: E402

DT = 0.002
HANDS = {"talos": "gripper_left_joint", "g1": "left_wrist_roll_joint", "humanoid15": None}


def hard_set_feasible(ctrl, config, dt=DT) -> bool:
    """Independent check (scipy HiGHS LP, tolerance 1e-7): does any v meet the hard rows at config?"""
    _, _, A, b, C, l, u, lb, ub = ctrl.assemble(config, dt)
    return highs_feasible(A, b, C, l, u, lb, ub, tol=1e-7)


def slower_return_feasible(ctrl, config, dt) -> bool:
    """Independent check (scipy HiGHS LP): with the joints outside their limits required to return at α times the
    rate of their position-limit bound, is some α ≥ 1e-3 feasible with every other hard row and bound?"""
    from wbc.constraints.limits import JointPositionLimit

    _, _, A, b, C, l, u, lb, ub = ctrl.assemble(config, dt)
    lims = [c for c in ctrl.constraints if isinstance(c, JointPositionLimit)]
    if not lims:
        return False
    lim = lims[0]
    q = config.q[lim.idx_q]
    idx = np.asarray(lim.indices)
    low, high = idx[(q < lim.q_min) & (lb[idx] > 0)], idx[(q > lim.q_max) & (ub[idx] < 0)]
    if not (low.size or high.size):
        return False
    lb, ub = lb.copy(), ub.copy()
    lb[low] *= 1e-3
    ub[high] *= 1e-3
    return highs_feasible(A, b, C, l, u, lb, ub, tol=1e-7)


def push_past_limits(robot, config, rng) -> None:
    """2–5 leg joints 5–50 mrad past their limits (in place; the soles' contacts are placed after)."""
    model = robot.model
    iq, _ = bounded_joints(model)
    joint_of = {model.joints[j].idx_q: model.names[j] for j in range(1, model.njoints)}
    legs = [k for k, i in enumerate(iq) if any(s in joint_of[i] for s in ("hip", "knee", "ankle", "leg"))]
    q = config.q.copy()
    for k in rng.choice(legs, int(rng.integers(2, 6)), replace=False):
        over = rng.uniform(0.005, 0.05)
        q[iq[k]] = model.upperPositionLimit[iq[k]] + over if rng.random() < 0.5 else \
            model.lowerPositionLimit[iq[k]] - over
    config.update(q)


def build_episode(robot, name, rng, kind, strict, past_limits=False, build=True):
    """An episode's configuration and controller from ``rng``, its draws made in a fixed order. With ``build`` False,
    the same draws are made but nothing is built, and it returns (None, None): a replay draws the episodes before
    its own this way."""
    config = Configuration(robot, random_configuration(robot, rng, spread=0.2) if rng.random() < 0.5 else None)
    config.q[:7] = robot.q_ref[:7]
    config.update(config.q)
    if past_limits:
        push_past_limits(robot, config, rng)
    com_gain, com_weight = float(10 ** rng.uniform(0, 6)), float(10 ** rng.uniform(-2, 3))  # CoM gain up to 1e6
    sole_gains = [float(10 ** rng.uniform(0, 3)) for _ in range(2)]  # drift correction 1..1000 1/s (capped at 1/dt)
    hand_gain, hand_weight = float(10 ** rng.uniform(-1, 4)), float(10 ** rng.uniform(-3, 3))
    d = rng.normal(size=3)
    com_shift = rng.uniform(-0.05, 0.05, 3) * (20 if kind != "reachable" else 1)
    # strict: the posture's weight, and whether the CoM task moves up to the top level (above the hand)
    posture_weight, com_on_top = (float(10 ** rng.uniform(-2, 1)), rng.random() < 0.5) if strict else (0.0, False)
    if not build:
        return None, None
    ctrl, com = standing_controller(robot, config)
    ctrl.tasks[0].gain, ctrl.tasks[0].weight = com_gain, com_weight
    for contact, gain in zip(ctrl.constraints[:2], sole_gains, strict=True):
        contact.gain = gain
    frame = HANDS[name] or robot.torso
    hand = FrameTask(robot, frame, gain=hand_gain, position_weight=hand_weight, orientation_weight=0.0, name="hand")
    target = config.frame_placement(hand.frame_id).copy()
    scale = {"reachable": 0.05, "absurd": 2.0, "far": 1e6}[kind]
    target.translation += scale * d / np.linalg.norm(d)
    hand.set_target(target)
    com.set_target(config.com + com_shift)
    if strict:
        ctrl.add_task(hand, level=0)
        ctrl.add_task(PostureTask(robot, weight=posture_weight), level=1)
        if com_on_top:
            com_task = ctrl.tasks[0]
            ctrl.remove_task(com_task)
            ctrl.add_task(com_task, level=0)
            ctrl.remove_task(hand)
            ctrl.add_task(hand, level=1)
    else:
        ctrl.add_task(hand)
    return config, ctrl


COUNTS = ("ticks", "episodes", "exceptions", "nan", "limit_violations", "failed", "failed_feasible",
          "failed_feasible_cut", "failed_confirmed_infeasible", "drift_failed", "holds_past_feasible",
          "holds_past_feasible_cut", "ok_sole_drift_over_0_05mm", "ok_tick_displacement_over_0_05mm",
          "stance_offset_over_1mm", "weighted_ticks", "weighted_failed",
          "strict_ticks", "strict_failed", "contact_corrected_ticks", "past_limit_episodes", "long_holds",
          "long_holds_slower_return_feasible", "failed_runs_over_1mm", "over_budget", "return_rate_relaxed_ticks")
MAXIMA = ("max_ok_sole_drift_fk_mm", "max_ok_tick_displacement_mm", "max_stance_offset_mm", "max_ok_sole_drift_mm",
          "max_failed_run_displacement_mm", "tick_time_max_ms", "max_dt_ms")
EVENTS = ("exceptions", "nan", "limit_violations", "failed_feasible", "holds_past_feasible",
          "ok_sole_drift_over_0_05mm", "stance_offset_over_1mm", "long_holds_slower_return_feasible",
          "failed_runs_over_1mm")
MAX_EVENTS = 20


def commanded_placement(contact, oMf, dt):
    """Where the contact row J v = −K e sends the sole over one tick: placement · exp((1 − K dt) e)."""
    e = pin.log6(contact.placement.actInv(oMf)).vector
    return contact.placement * pin.exp6(e * (1.0 - min(contact.gain, 1.0 / dt) * dt))


WARMUP_TICKS = 10
WARMUP_SEED = 2**31 - 1
_WARMED: list = []


def warm_up(robots, dt: float = DT, budget=None, clock_guard: bool = False) -> dict | None:
    """Start-up of this process (module docstring): once per process, one episode of ``WARMUP_TICKS`` ticks per
    robot and kind (weighted, strict) from ``WARMUP_SEED``, not counted; prints and returns its first tick and its
    slowest ({"pid", "ticks", "first": (CPU s, budget s, minor page faults), "max": (CPU s, budget s, "robot strict")}),
    None when this process already ran it."""
    if _WARMED:
        return None
    _WARMED.append(os.getpid())
    rng = np.random.default_rng(WARMUP_SEED)
    probe = tick_probe()
    first, worst, n = None, (0.0, dt, ""), 0
    for name, robot in robots.items():
        for strict in (False, True):
            config, ctrl = build_episode(robot, name, rng, "reachable", strict)
            ctrl.budget = budget
            ctrl.clock_guard = clock_guard
            freeze_after_first((name, strict))
            collect_between_episodes()
            b = dt if budget is None else budget
            for _ in range(WARMUP_TICKS):
                probe.start()
                t = time.thread_time()
                res = ctrl.solve(config, dt)
                cpu = time.thread_time() - t
                within = probe.stop()
                n += 1
                if first is None:
                    first = (cpu, b, int(within.split("minflt ")[1].split()[0]))
                if cpu / b > worst[0] / worst[1]:
                    worst = (cpu, b, f"{name} strict={strict}")
                config.update(config.integrate(res.v, dt))
    w = {"pid": os.getpid(), "ticks": n, "first": first, "max": worst}
    print(f"warm-up (start-up, not counted): pid {w['pid']}, {n} ticks; first tick of the process CPU "
          f"{1e3 * first[0]:.2f} ms ({first[0] / first[1]:.2f} x budget, {first[2]} minor page faults); slowest "
          f"{1e3 * worst[0]:.2f} ms ({worst[0] / worst[1]:.2f} x, {worst[2]})", flush=True)
    return w


def run_chunk(robots, limits, ticks: int, episode: int, seed: int, progress: str = "", dts=(DT,),
              past_limits: float = 0.0, budget=None, clock_guard: bool = False, replay: int | None = None,
              verbose: bool = False, warm: bool = False, quiet: bool = False) -> dict:
    """Fuzz ``ticks`` ticks from ``seed``; returns the counts and maxima (module docstring). ``replay``: run only
    that episode of the chunk (the others are drawn, not run); ``verbose``: print every tick's path, CPU time and
    message; ``warm``: run this process's warm-up first (:func:`warm_up`; its record in the result's "warmup"
    when it ran here); ``quiet``: no progress lines."""
    warmup = warm_up(robots, dts[0], budget, clock_guard) if warm else None
    rng = np.random.default_rng(seed)
    extra = np.random.default_rng(seed + 7_000_000)  # dt and past-limit draws: build_episode's stream unchanged
    c = dict.fromkeys(COUNTS, 0) | dict.fromkeys(MAXIMA, 0.0)
    c["events"] = {k: [] for k in EVENTS}
    c["warmup"] = warmup
    c["paths"] = {}
    c["tick_times"] = []
    c["tick_cpu"] = []  # CPU time of this thread per tick (time.thread_time: the controller's budgeted quantity)
    c["tick_budget"] = []  # each tick's budget (s): --budget, else its dt
    c["tick_paths"] = []  # each tick's TickResult.path (per-path CPU time in the report)
    c["worst_ticks"] = []  # (cpu / budget, "seed … episode … tick … path …") of the slowest ticks
    probe = tick_probe()  # what a slow tick contained besides its work (collections, page faults, switches)

    def event(kind: str, ep: int, tick: int, detail: str = "") -> None:
        if len(c["events"][kind]) < MAX_EVENTS:
            c["events"][kind].append(f"seed {seed} episode {ep} tick {tick} {detail}".rstrip())
    t0 = time.time()
    next_print = 0
    while c["ticks"] < ticks:
        name = str(rng.choice(list(robots)))
        robot = robots[name]
        kind = str(rng.choice(["reachable", "absurd", "far"]))
        strict = bool(rng.random() < 0.5)
        ep = c["episodes"]
        c["episodes"] += 1
        dt = float(extra.choice(dts))
        past = bool(extra.random() < past_limits)
        c["past_limit_episodes"] += int(past)
        c["max_dt_ms"] = max(c["max_dt_ms"], 1e3 * dt)
        try:
            # a replay draws the other episodes without building them: the rng moves on as in the run
            config, ctrl = build_episode(robot, name, rng, kind, strict, past_limits=past,
                                         build=replay is None or ep == replay)
            if replay is not None and ep != replay:
                c["ticks"] += episode
                continue
            ctrl.budget = budget
            ctrl.clock_guard = clock_guard
            freeze_after_first((name, strict))
            collect_between_episodes()
        except Exception as exc:  # noqa: BLE001
            c["exceptions"] += 1
            event("exceptions", ep, -1, f"build {type(exc).__name__}: {exc}")
            print("build exception:", type(exc).__name__, exc, flush=True)
            continue
        iq, lo, hi, vmax = limits[name]
        contacts = ctrl.constraints[:2]
        run_start, hold_run = None, 0
        q_prev = config.q[iq].copy()
        for tick in range(episode):
            c["ticks"] += 1
            c["strict_ticks" if strict else "weighted_ticks"] += 1
            try:
                before = [config.frame_placement(k.frame_id).copy() for k in contacts]
                probe.start()
                t_tick, cpu_tick = time.perf_counter(), time.thread_time()
                res = ctrl.solve(config, dt)
                c["tick_cpu"].append(time.thread_time() - cpu_tick)
                c["tick_times"].append(time.perf_counter() - t_tick)
                within = probe.stop()
                c["tick_budget"].append(dt if budget is None else budget)
                c["tick_paths"].append(str(res.path))  # (JSON chunk files)
                ratio = c["tick_cpu"][-1] / c["tick_budget"][-1]
                record_over(c, seed, ticks, ep, tick, ratio)
                if len(c["worst_ticks"]) < MAX_EVENTS or ratio > c["worst_ticks"][-1][0]:
                    c["worst_ticks"].append((ratio, f"seed {seed} episode {ep} tick {tick} {name} {kind} "
                                                    f"strict={strict} dt {1e3 * dt:g} ms at {time.time():.3f} s: "
                                                    f"{res.path}, CPU "
                                                    f"{1e3 * c['tick_cpu'][-1]:.2f} ms, wall "
                                                    f"{1e3 * c['tick_times'][-1]:.2f} ms; {within}"))
                    c["worst_ticks"] = sorted(c["worst_ticks"], key=lambda w: -w[0])[:MAX_EVENTS]
                if verbose:
                    print(f"episode {ep} tick {tick} {name} {kind} strict={strict} dt {1e3 * dt:g} ms {res.path} "
                          f"ok={res.ok} CPU {1e3 * c['tick_cpu'][-1]:.2f} ms ({ratio:.2f} x budget) "
                          f"{res.message[:300]}", flush=True)
            except Exception as exc:  # noqa: BLE001
                c["exceptions"] += 1
                event("exceptions", ep, tick, f"{type(exc).__name__}: {exc}")
                print("tick exception:", type(exc).__name__, exc, flush=True)
                break
            if not np.isfinite(res.v).all():
                c["nan"] += 1
                event("nan", ep, tick, name)
                break
            if np.any(np.abs(res.v[6:]) > vmax + 1e-9):
                c["limit_violations"] += 1
                event("limit_violations", ep, tick, f"{name} velocity")
            c["contact_corrected_ticks"] += int(ctrl.contact_corrections > 0)
            c["paths"][str(res.path)] = c["paths"].get(str(res.path), 0) + 1
            c["over_budget"] += int(res.over_budget)
            c["return_rate_relaxed_ticks"] += int(any(r.startswith("joint_position_limit return rate")
                                                      for r in res.relaxed))
            hold_run = hold_run + 1 if (not res.ok and res.fallback == "hold") else 0
            if hold_run == 51:
                c["long_holds"] += 1
                if slower_return_feasible(ctrl, config, dt):
                    c["long_holds_slower_return_feasible"] += 1
                    event("long_holds_slower_return_feasible", ep, tick, name)
            if not res.ok:
                c["failed"] += 1
                c["strict_failed" if strict else "weighted_failed"] += 1
                if getattr(res, "reason", "") == "sole_drift" or res.fallback == "trust_region":
                    # the QP solved; its least-drifting command still moves a sole > sole_drift_tolerance
                    # (second-order, not a linear feasibility question): counted apart, v is that command
                    c["drift_failed"] += 1
                else:
                    feasible = hard_set_feasible(ctrl, config, dt)  # independent check, failed QP ticks only
                    # the controller's own word that its budget stopped a stage (by count or clock guard: past the
                    # budget the tick takes the safe command, feasible or not): counted apart from a solver's wrong
                    # verdict
                    cut = "tick budget spent" in res.message
                    c["failed_feasible"] += int(feasible and not cut)
                    c["failed_feasible_cut"] += int(feasible and cut)
                    c["failed_confirmed_infeasible"] += int(not feasible)
                    if feasible:
                        event("failed_feasible", ep, tick, f"{name} {kind} strict={strict}"
                                                           f"{' (budget cut)' if cut else ''}: {res.message[:200]}")
                    if res.fallback == "hold" and feasible:
                        c["holds_past_feasible_cut" if cut else "holds_past_feasible"] += 1
                        event("holds_past_feasible", ep, tick, f"{name}{' (budget cut)' if cut else ''}")
            config.update(config.integrate(res.v, dt))
            q = config.q[iq]
            # a joint past a limit moving further out (one that starts outside may only come back)
            if np.any((q < lo - 1e-9) & (q < q_prev - 1e-9)) or np.any((q > hi + 1e-9) & (q > q_prev + 1e-9)):
                c["limit_violations"] += 1
                event("limit_violations", ep, tick, f"{name} position")
            q_prev = q.copy()
            if not res.ok:
                run_start = before if run_start is None else run_start
                after = [config.frame_placement(k.frame_id) for k in contacts]
                run = max(np.linalg.norm(a.translation - b.translation) for a, b in zip(after, run_start))
                if run > 1e-3 and c["max_failed_run_displacement_mm"] <= 1.0:
                    event("failed_runs_over_1mm", ep, tick, f"{name} {1e3 * run:.4f} mm")
                c["failed_runs_over_1mm"] += int(run > 1e-3)
                c["max_failed_run_displacement_mm"] = max(c["max_failed_run_displacement_mm"], float(1e3 * run))
            else:
                run_start = None
            if res.ok:
                after = [config.frame_placement(k.frame_id) for k in contacts]
                moved = max(np.linalg.norm(a.translation - b.translation) for a, b in zip(after, before))
                offset = max(np.linalg.norm(a.translation - k.placement.translation) for a, k in zip(after, contacts))
                drift = max(np.linalg.norm(a.translation - commanded_placement(k, b, dt).translation)
                            for a, b, k in zip(after, before, contacts))
                c["max_ok_sole_drift_fk_mm"] = max(c["max_ok_sole_drift_fk_mm"], float(1e3 * drift))
                c["max_ok_tick_displacement_mm"] = max(c["max_ok_tick_displacement_mm"], float(1e3 * moved))
                c["max_stance_offset_mm"] = max(c["max_stance_offset_mm"], float(1e3 * offset))
                c["max_ok_sole_drift_mm"] = max(c["max_ok_sole_drift_mm"], 1e3 * res.sole_drift)
                c["ok_sole_drift_over_0_05mm"] += int(drift > 5e-5)
                c["ok_tick_displacement_over_0_05mm"] += int(moved > 5e-5)
                c["stance_offset_over_1mm"] += int(offset > 1e-3)
                if drift > 5e-5:
                    event("ok_sole_drift_over_0_05mm", ep, tick, f"{name} {1e3 * drift:.4f} mm")
                if offset > 1e-3:
                    event("stance_offset_over_1mm", ep, tick, f"{name} {1e3 * offset:.4f} mm")
        if c["ticks"] >= next_print and not quiet:
            next_print += 10_000
            print(f"{progress}[{time.time() - t0:.0f} s] " + str({k: c[k] for k in (*COUNTS, *MAXIMA)}), flush=True)
    c["seconds"] = time.time() - t0
    t = np.asarray(c["tick_times"])
    c["tick_time_max_ms"] = float(1e3 * t.max()) if t.size else 0.0
    return c


def aggregate(chunks: list[dict]) -> dict:
    total = {k: sum(ch.get(k, 0) for ch in chunks) for k in COUNTS}
    total |= {k: max(ch.get(k, 0.0) for ch in chunks) for k in MAXIMA}
    total["seconds"] = sum(ch["seconds"] for ch in chunks)
    total["events"] = {k: [e for ch in chunks for e in ch.get("events", {}).get(k, [])][:MAX_EVENTS] for k in EVENTS}
    total["paths"] = {}
    for ch in chunks:
        for k, n in ch.get("paths", {}).items():
            total["paths"][k] = total["paths"].get(k, 0) + n
    times = np.concatenate([np.asarray(ch.get("tick_times", []), float) for ch in chunks]) if chunks else np.zeros(0)
    total["tick_time_ms"] = {q: float(1e3 * np.percentile(times, p)) if times.size else 0.0
                             for q, p in (("p50", 50), ("p99", 99), ("p999", 99.9))}
    cpu = np.concatenate([np.asarray(ch.get("tick_cpu", []), float) for ch in chunks]) if chunks else np.zeros(0)
    budget = np.concatenate([np.asarray(ch.get("tick_budget", []), float) for ch in chunks]) if chunks else np.zeros(0)
    total["tick_cpu_ms"] = {q: float(1e3 * np.percentile(cpu, p)) if cpu.size else 0.0
                            for q, p in (("p50", 50), ("p99", 99), ("p999", 99.9), ("max", 100))}
    ratio = cpu / budget if cpu.size and cpu.size == budget.size else np.zeros(0)
    paths = np.array([x for ch in chunks for x in ch.get("tick_paths", [])])
    total["path_cpu_ms"] = {}
    if paths.size == cpu.size:
        for path in sorted(set(paths.tolist())):
            sel = cpu[paths == path]
            total["path_cpu_ms"][path] = tuple(float(1e3 * np.percentile(sel, p)) for p in (50, 99, 100))
    total["worst_ticks"] = sorted((w for ch in chunks for w in ch.get("worst_ticks", [])),
                                  key=lambda w: -w[0])[:MAX_EVENTS]
    total["tick_cpu_over_budget"] = int(np.sum(ratio > 1.0))
    total["tick_cpu_over_2x_budget"] = int(np.sum(ratio > 2.0))
    total["tick_cpu_max_budget_ratio"] = float(ratio.max()) if ratio.size else float("nan")
    total["warmups"] = [ch["warmup"] for ch in chunks if ch.get("warmup")]
    total["over_2x"] = [o for ch in chunks for o in ch.get("over_2x", [])]
    total["over_2x_unkept"] = sum(ch.get("over_2x_unkept", 0) for ch in chunks)
    return total


def report(total: dict) -> str:
    """FINAL line (every count and maximum) and one line per acceptance item of issue 8: value, PASS/FAIL."""
    w = total["weighted_failed"] / max(total["weighted_ticks"], 1)
    s = total["strict_failed"] / max(total["strict_ticks"], 1)
    routes = count_paths(Counter(total["paths"]).elements())
    items = [
        ("ticks (talos, g1, humanoid15) >= 1e6", total["ticks"], total["ticks"] >= 1_000_000),
        ("exceptions == 0", total["exceptions"], total["exceptions"] == 0),
        ("NaN commands == 0", total["nan"], total["nan"] == 0),
        ("limit violations beyond 1e-9 == 0", total["limit_violations"], total["limit_violations"] == 0),
        ("failed ticks the independent solver (HiGHS) finds feasible, the tick budget not spent == 0",
         f"{total['failed_feasible']} ({total.get('failed_feasible_cut', 0)} more whose budget was spent, by count "
         f"or clock guard: a stage skipped, the safe command)", total["failed_feasible"] == 0),
        ("holds lasting past a feasible tick, the tick budget not spent == 0",
         f"{total['holds_past_feasible']} ({total.get('holds_past_feasible_cut', 0)} more whose budget was spent, "
         f"by count or clock guard)", total["holds_past_feasible"] == 0),
        ("max stance-sole drift per ok tick (forward kinematics) <= 0.05 mm",
         f"{total['max_ok_sole_drift_fk_mm']:.4f} mm ({total['ok_sole_drift_over_0_05mm']} ticks over)",
         total["ok_sole_drift_over_0_05mm"] == 0),
        ("max stance-sole offset from its placement on ok ticks (per stance) <= 1 mm",
         f"{total['max_stance_offset_mm']:.4f} mm ({total['stance_offset_over_1mm']} ticks over)",
         total["stance_offset_over_1mm"] == 0),
        ("holds longer than 50 ticks on a state where a slower return (1e-3 of the rate) is feasible (HiGHS) == 0",
         f"{total['long_holds_slower_return_feasible']} (of {total['long_holds']} holds > 50 ticks; "
         f"{total['past_limit_episodes']} episodes started past the limits, {total['return_rate_relaxed_ticks']} "
         f"ticks with a relaxed return rate)", total["long_holds_slower_return_feasible"] == 0),
        ("max stance-sole displacement over any run of failed ticks <= 1 mm (forward kinematics)",
         f"{total['max_failed_run_displacement_mm']:.4f} mm ({total['failed_runs_over_1mm']} ticks over)",
         total["failed_runs_over_1mm"] == 0),
        over_line(total, total["tick_cpu_max_budget_ratio"], total["tick_cpu_over_2x_budget"],
                  total["tick_cpu_over_budget"]),
        ("strict-level failure rate <= weighted failure rate",
         f"strict {s:.3e} ({total['strict_failed']}/{total['strict_ticks']}) vs weighted {w:.3e} "
         f"({total['weighted_failed']}/{total['weighted_ticks']})", s <= w),
        ("every tick took a declared route (wbc.tick.KINEMATIC_ROUTES)", str(routes["ticks_per_route"]),
         set(routes["ticks_per_route"]) <= set(KINEMATIC_ROUTES)),
    ]
    lines = ["FINAL " + str({k: total[k] for k in (*COUNTS, *MAXIMA, "seconds")})]
    lines += [f"ACCEPTANCE {'PASS' if ok else 'FAIL'}: {what}: {value}" for what, value, ok in items]
    lines.append(f"info: max sole displacement per ok tick (drift + commanded correction K e dt) "
                 f"{total['max_ok_tick_displacement_mm']:.4f} mm ({total['ok_tick_displacement_over_0_05mm']} ticks "
                 f"over 0.05 mm); controller-reported max sole_drift {total['max_ok_sole_drift_mm']:.4f} mm; "
                 f"failed {total['failed']} = {total['drift_failed']} drift (trust region) + "
                 f"{total['failed_confirmed_infeasible']} confirmed infeasible + {total['failed_feasible']} feasible")
    tt = total["tick_time_ms"]
    lines.append(f"info: tick time p50 {tt['p50']:.3f} ms, p99 {tt['p99']:.3f} ms, p99.9 {tt['p999']:.3f} ms, max "
                 f"{total['tick_time_max_ms']:.3f} ms; budget {total.get('budget', 'dt')} (dt up to "
                 f"{total['max_dt_ms']:g} ms); {total['over_budget']} ticks past their budget; fallback rate "
                 f"{total['failed'] / max(total['ticks'], 1):.3e} ({total['failed']}/{total['ticks']})")
    tc = total["tick_cpu_ms"]
    lines.append(f"info: tick CPU time p50 {tc['p50']:.3f} ms, p99 {tc['p99']:.3f} ms, p99.9 {tc['p999']:.3f} ms, "
                 f"max {tc['max']:.3f} ms (the budget's clock; the wall times above include other processes)")
    lines.append("info: ticks per route " + ", ".join(f"{k} {n}" for k, n in routes["ticks_per_route"].items()))
    lines.append("info: ticks per path " + ", ".join(f"{k} {n}" for k, n in sorted(total["paths"].items(),
                                                                                   key=lambda kv: -kv[1])))
    for path, (p50, p99, mx) in total.get("path_cpu_ms", {}).items():
        lines.append(f"info:   {path}: tick CPU p50 {p50:.3f} ms, p99 {p99:.3f} ms, max {mx:.3f} ms")
    warm = total.get("warmups", [])
    if warm:
        first = max(warm, key=lambda w: w["first"][0] / w["first"][1])
        slow = max(warm, key=lambda w: w["max"][0] / w["max"][1])
        lines.append(f"info: start-up (each process's warm-up before its first chunk, {warm[0]['ticks']} ticks, not "
                     f"counted above): {len(warm)} process(es); first tick of a process up to "
                     f"{1e3 * first['first'][0]:.2f} ms CPU ({first['first'][0] / first['first'][1]:.2f} x budget, "
                     f"{first['first'][2]} minor page faults); slowest warm-up tick {1e3 * slow['max'][0]:.2f} ms "
                     f"({slow['max'][0] / slow['max'][1]:.2f} x, {slow['max'][2]})")
    else:
        lines.append("info: start-up: no warm-up recorded in these chunks (each process's first ticks are counted "
                     "above)")
    for ratio, where in total.get("worst_ticks", [])[:10]:
        lines.append(f"info: slow tick {ratio:.2f} x budget: {where}")
    stalls = coincident_stalls(total.get("worst_ticks", []))
    lines.append(f"info: ticks over 2 x budget that overlap a slow tick of another process in wall-clock time (a "
                 f"stall of the machine): {len(stalls)} of {total['tick_cpu_over_2x_budget']}")
    slow = slow_canary_ticks(total.get("worst_ticks", []))
    lines.append(f"info: ticks over 2 x budget beside a slow machine (a canary before or after the tick over 1.5 x its "
                 f"median, fuzz_common.TickProbe): {len(slow)} of {total['tick_cpu_over_2x_budget']}")
    for record in total.get("replayed", {}).get("records", []):
        lines.append(f"info: replayed: {record}")
    lines.append(acceptance_verdict(items))
    for k, evs in total["events"].items():
        for e in evs:
            lines.append(f"event {k}: {e}")
    return "\n".join(lines)


def _run_job(job: tuple) -> tuple[int, dict]:
    """One chunk in a worker process: (index, result)."""
    i, ticks, episode, seed, n_chunks, out, dts, past_limits, budget, clock_guard = job
    if isinstance(clock_guard, float):  # --clock-weight
        from wbc.controllers.kinematic import KinematicController
        KinematicController.CLOCK_WEIGHT, clock_guard = clock_guard, True
    robots, limits = load_robots()
    ch = run_chunk(robots, limits, ticks, episode, seed, progress=f"chunk {i + 1}/{n_chunks} (seed {seed}) ",
                   dts=dts, past_limits=past_limits, budget=budget, clock_guard=clock_guard, warm=True)
    if out is not None:
        Path(out).write_text(json.dumps(ch))
    return i, ch


def replay_ratios(seed: int, chunk_ticks: int, ep: int, episode: int, dts: tuple, past_limits: float, budget,
                  clock_guard) -> list[float]:
    """Episode ``ep`` of the chunk (``seed``, ``chunk_ticks``) run again in this process: CPU / budget per tick."""
    robots, limits = load_robots()
    if isinstance(clock_guard, float):  # --clock-weight
        from wbc.controllers.kinematic import KinematicController
        KinematicController.CLOCK_WEIGHT, clock_guard = clock_guard, True
    c = run_chunk(robots, limits, chunk_ticks, episode, seed, dts=dts, past_limits=past_limits, budget=budget,
                  clock_guard=clock_guard, replay=ep, warm=True, quiet=True)
    return [cpu / b for cpu, b in zip(c["tick_cpu"], c["tick_budget"])]


def confirm_over(total: dict, a: argparse.Namespace, dts: tuple) -> None:
    """The run's ticks over 2 x budget re-measured (``fuzz_common.replay_over``) into ``total["replayed"]``."""
    if not total["over_2x"]:
        return
    guard = a.clock_weight if (a.clock_guard and a.clock_weight) else a.clock_guard
    t0 = time.time()
    total["replayed"] = replay_over(total["over_2x"], lambda seed, n, ep: replay_ratios(
        seed, n, ep, a.episode, dts, a.past_limits, a.budget, guard))
    print(f"replayed the {len(total['over_2x'])} ticks over 2 x budget in {time.time() - t0:.0f} s (load "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())})", flush=True)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--ticks", type=int, default=1_000_000, help="total ticks")
    p.add_argument("--jobs", type=int, default=1, help="processes (chunks run in parallel, results summed)")
    p.add_argument("--episode", type=int, default=50, help="ticks per episode (one stance)")
    p.add_argument("--seed", type=int, default=0, help="seed of the first chunk (chunk i uses seed + i)")
    p.add_argument("--chunk", type=int, default=50_000, help="ticks per chunk (one result file each)")
    p.add_argument("--out", type=Path, default=None,
                   help="folder of per-chunk results: finished chunks are skipped (resume), all are aggregated")
    p.add_argument("--dts", default="0.002", help="comma-separated control periods (s) drawn per episode")
    p.add_argument("--past-limits", type=float, default=0.0,
                   help="fraction of episodes starting with 2-5 leg joints 5-50 mrad past their limits")
    p.add_argument("--budget", type=float, default=None, help="tick budget (s); default: the tick's dt")
    p.add_argument("--clock-guard", action="store_true",
                   help="KinematicController(clock_guard=True): the tick's CPU time also counts as work")
    p.add_argument("--clock-weight", type=float, default=None,
                   help="with --clock-guard: KinematicController.CLOCK_WEIGHT (default: the class's)")
    p.add_argument("--replay", type=int, default=None,
                   help="run only this episode of the chunk of --seed (one chunk of --chunk ticks), verbose")
    p.add_argument("--aggregate-only", action="store_true",
                   help="run nothing: aggregate every finished chunk file in --out (e.g. of several processes)")
    a = p.parse_args()
    if a.aggregate_only:
        files = sorted(a.out.glob("chunk_*.json"))
        print(f"{len(files)} chunk files in {a.out}", flush=True)
        total = aggregate([json.loads(f.read_text()) for f in files])
        confirm_over(total, a, tuple(float(x) for x in a.dts.split(",")))
        print(report(total), flush=True)
        return
    t0 = time.time()
    dts = tuple(float(x) for x in a.dts.split(","))
    if a.replay is not None:
        robots, limits = load_robots()
        if a.clock_weight:
            from wbc.controllers.kinematic import KinematicController
            KinematicController.CLOCK_WEIGHT = a.clock_weight
        run_chunk(robots, limits, a.chunk, a.episode, a.seed, dts=dts, past_limits=a.past_limits, budget=a.budget,
                  clock_guard=a.clock_guard, replay=a.replay, verbose=True, warm=True)
        return
    n_chunks = max(1, -(-a.ticks // a.chunk))
    if a.out is not None:
        a.out.mkdir(parents=True, exist_ok=True)
    chunks: dict[int, dict] = {}
    jobs = []
    for i in range(n_chunks):
        ticks = min(a.chunk, a.ticks - i * a.chunk)
        tag = "" if (dts == (DT,) and not a.past_limits and a.budget is None) else \
            f"_dt{'-'.join(map(str, dts))}_pl{a.past_limits}_b{a.budget}"
        tag += (f"_clock{a.clock_weight or ''}" if a.clock_guard else "")
        f = a.out / f"chunk_{a.seed + i}_{ticks}_{a.episode}{tag}.json" if a.out is not None else None
        if f is not None and f.exists():
            chunks[i] = json.loads(f.read_text())
            print(f"chunk {i + 1}/{n_chunks} (seed {a.seed + i}) already done: {f}", flush=True)
            continue
        jobs.append((i, ticks, a.episode, a.seed + i, n_chunks, None if f is None else str(f), dts, a.past_limits,
                     a.budget, a.clock_weight if (a.clock_guard and a.clock_weight) else a.clock_guard))
    if a.jobs <= 1:
        results = map(_run_job, jobs)
    else:
        pool = multiprocessing.get_context("fork").Pool(a.jobs)
        results = pool.imap_unordered(_run_job, jobs)
    for i, ch in results:
        chunks[i] = ch
        so_far = aggregate(list(chunks.values()))
        print(f"chunk {i + 1}/{n_chunks} (seed {a.seed + i}) done; so far: "
              + str({k: so_far[k] for k in (*COUNTS, *MAXIMA)}), flush=True)
    if a.jobs > 1:
        pool.close()
        pool.join()
    print(f"wall time {time.time() - t0:.0f} s with {a.jobs} process(es)", flush=True)
    total = aggregate([chunks[i] for i in sorted(chunks)])
    total["budget"] = ("dt" if a.budget is None else f"{1e3 * a.budget:g} ms") + (", clock guard" if a.clock_guard else "")
    confirm_over(total, a, dts)
    print(report(total), flush=True)


if __name__ == "__main__":
    main()
