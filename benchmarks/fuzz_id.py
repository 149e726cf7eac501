"""Fuzz the inverse-dynamics controller: N ticks over talos, g1 and humanoid15 with random CoM/torso targets and
acceleration feed-forwards, gains, weights, friction coefficients (also re-assigned during an episode), per-corner
minimum normal forces, torque-limit scalings, force ramps that unload a foot to zero and release it, and start
states (joints spread inside their limits, random velocities). The state advances by the commanded v̇ (explicit
Euler, dt = 2 ms; v̇ = 0 on a fallback tick). Prints the counts and one PASS/FAIL line per acceptance item:

    python benchmarks/fuzz_id.py [--solver fast|daqp] [--ticks 1000000] [--jobs 2] [--episode 50] [--seed 0]
                                 [--chunk 50000] [--out DIR] [--clock-guard] [--replay EPISODE]

Checks, all computed in this script from Pinocchio and the numbers the script chose (not from the controller):
exceptions; non-finite commands; on ok ticks, bound violations beyond 1e-6 (relative to max(1, |bound|)): corner
normal force outside [min(f_min, f_max), f_max], corner tangential force outside the inscribed pyramid
|f_x|, |f_y| ≤ μ/√2 f_z with the μ last assigned (to 1e-6 of max(1, |f_t| + μ/√2 |f_z|), the size of the row's terms), |τ| above the scaled URDF effort (full-QP ticks), and the
floating-base rows of M v̇ + h − Sᵀτ − Σ J_kᵀ G_k f_k (RNEA, LOCAL sole Jacobians) above 1e-6 max(1, |h_u|);
failed full-QP ticks (relaxed or fallback) whose hard set HiGHS finds feasible (checked after the tick, off the
control path), those of them that took the gravity-compensation fallback, and the longest run of fallback ticks
(not ok) on full QPs HiGHS finds feasible (a spent budget holds the last solved command, ``LONGEST_FEASIBLE_RUN``);
failed ticks that name no conflicting constraint (the tick's own names, else
``InverseDynamicsController.diagnose()`` after the tick); tick CPU time (the budgeted quantity) and wall time,
p50/p99/max, against the budget (the control period); the route and path each tick took (``IDCommand.path``; a
route outside ``wbc.tick.ID_ROUTES`` fails the run).

Each slow tick is printed with the work the controller counted in it (``FallbackChain.tick_work``, in budgets)
and what else it contained (garbage collections, page faults, context switches, and a fixed-work canary timed just
before and after it as a ratio to its median: ``fuzz_common.TickProbe``); info lines count the ticks over 2 x budget
whose wall-clock interval overlaps a slow tick of the other process (a stall of the machine,
``fuzz_common.coincident_stalls``) and those with a canary over 1.5 x (``fuzz_common.slow_canary_ticks``). Before its first measured tick every process runs a warm-up, printed
and not counted: ``WARMUP_TICKS`` ticks of episodes drawn from ``WARMUP_SEED`` (the process's one-time costs — page
faults of the first allocations, the compiled kernels' first calls, the solvers' first set-ups — land there, as they
would in a real-time loop's start-up rather than in its ticks).

The ticks over 2 x budget are re-measured by replaying their episodes after the run, as in ``fuzz.py`` (its module
docstring; ``fuzz_common.replay_over``).
"""

from __future__ import annotations

import argparse
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

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from conftest import random_configuration  # noqa: E402
from fuzz_common import (acceptance_verdict, chunk_arguments, coincident_stalls, slow_canary_ticks,  # noqa: E402
                         collect_between_episodes, freeze_after_first, highs_feasible, load_robots, over_line,
                         record_over, replay_over, run_chunks, tick_probe)
from wbc.constants import SIDES  # noqa: E402
from wbc.dynamics.balance import IDBalanceController  # noqa: E402
from wbc.tick import ID_ROUTES, count_paths  # noqa: E402

DT = 0.002
TOL = 1e-6
COUNTS = ("ticks", "episodes", "exceptions", "nan", "bound_violations", "failed_full_qp", "fallback_ticks",
          "relaxed_ticks", "failed_feasible", "failed_feasible_cut", "gravity_feasible", "failed_unnamed",
          "over_budget", "ramps", "mu_changes")
#: the longest run of fallback ticks (not ok) whose full QP HiGHS finds feasible, of a spent budget or not
LONGEST_FEASIBLE_RUN = 5
EVENTS = ("exceptions", "nan", "bound_violations", "failed_feasible", "failed_unnamed", "over_budget")
MAX_EVENTS = 20
#: the per-process warm-up (module docstring): ticks, and the seed of its episodes (not a chunk's seed)
WARMUP_TICKS = 1000
WARMUP_SEED = 999_999_999
_WARMED: list = []  # the warm-up's line, once this process ran it


def log_uniform(rng, lo, hi):
    return float(10 ** rng.uniform(np.log10(lo), np.log10(hi)))


def draw_episode(robot, rng) -> dict:
    """An episode's random draws (gains, limits, start state, CoM target), in their fixed order: the same rng state
    gives the same episode, which :func:`build_episode` builds. A replay draws the episodes before its own without
    building them."""
    gains = {"com_kp": log_uniform(rng, 1, 1e4), "com_weight": log_uniform(rng, 1, 1e4),
             "torso_kp": log_uniform(rng, 1, 1e3), "posture_kp": log_uniform(rng, 1, 1e3),
             "posture_weight": log_uniform(rng, 1e-2, 10), "contact_kd": float(rng.uniform(0, 100))}
    gains["com_kd"] = 2 * np.sqrt(gains["com_kp"]) * rng.uniform(0.2, 2)
    d = {"gains": gains, "scale": float(rng.uniform(0.2, 1.0)), "mu": log_uniform(rng, 0.05, 1.5),
         "f_min": float(rng.choice([0.0, 1.0, 10.0, 30.0]))}
    q = random_configuration(robot, rng, spread=float(rng.uniform(0, 0.3)))
    if rng.random() < 0.7:
        q[:7] = robot.q_ref[:7]
    v = np.zeros(robot.nv)
    v[6:] = rng.normal(size=robot.nv - 6) * rng.uniform(0, 1.0)
    d["q"], d["v"] = q, v
    d["com_offset"] = rng.normal(size=3) * rng.choice([0.01, 0.05, 0.3])
    d["com_acceleration"] = rng.normal(size=3) * rng.choice([0.0, 1.0, 5.0])
    return d


def build_episode(robot, draws, solver, clock_guard=False):
    """The controller, q, v and torque-limit scale of the episode ``draws`` (:func:`draw_episode`)."""
    d = draws
    ctrl = IDBalanceController(robot, dt=DT, solver=solver, mu=d["mu"], f_min=d["f_min"], gains=d["gains"],
                               torque_limit_scale=d["scale"])
    ctrl.controller.clock_guard = clock_guard
    ctrl.reset(d["q"], d["v"])
    ctrl.set_com_reference(ctrl.com_ref + d["com_offset"], acceleration=d["com_acceleration"])
    return ctrl, d["q"], d["v"], d["scale"]


def corner_map(contact) -> np.ndarray:
    """(6, 12) corner forces → sole wrench (sole frame), from the corners, built here."""
    G = np.zeros((6, 12))
    for i, c in enumerate(contact.corners):
        G[:3, 3 * i:3 * i + 3] = np.eye(3)
        G[3:, 3 * i:3 * i + 3] = pin.skew(c)
    return G


def bound_violations(robot, data, ctrl, q, v, cmd, bounds, effort) -> list[str]:
    """Independent checks of an ok command (module docstring); names of the violated bounds."""
    out = []
    nv = robot.nv
    f = cmd.forces
    gen = pin.rnea(robot.model, data, q, v, cmd.dv).copy()
    gen[6:] -= cmd.tau
    pin.computeJointJacobians(robot.model, data, q)
    pin.updateFramePlacements(robot.model, data)
    for k, side in enumerate(SIDES):
        c = ctrl.contacts[side]
        fk = f[12 * k:12 * k + 12].reshape(4, 3)
        lo, hi, mu = bounds[side]
        if not c.active:
            lo = hi = 0.0
            if np.max(np.abs(fk)) > TOL:
                out.append(f"inactive {side} force {np.max(np.abs(fk)):.3g}")
        if np.any(fk[:, 2] < lo - TOL * max(1, abs(lo))) or np.any(fk[:, 2] > hi + TOL * max(1, abs(hi))):
            out.append(f"normal {side} {fk[:, 2]} not in [{lo}, {hi}]")
        # each pyramid side |f_t| ≤ μ/√2 f_z to TOL relative to the size of its terms, max(1, |f_t| + μ/√2 |f_z|)
        # (the row scale every QP solver's tolerance is relative to)
        cone = mu / np.sqrt(2) * fk[:, 2:3]
        if c.active and np.any(np.abs(fk[:, :2]) > cone + TOL * np.maximum(1, np.abs(fk[:, :2]) + np.abs(cone))):
            out.append(f"friction {side} mu {mu}")
        J = pin.getFrameJacobian(robot.model, data, c.frame_id, pin.LOCAL)
        gen -= J.T @ (corner_map(c) @ f[12 * k:12 * k + 12])
    scale = max(1.0, float(np.max(np.abs(pin.rnea(robot.model, data, q, v, np.zeros(nv))[:6]))))
    if np.max(np.abs(gen[:6])) > TOL * scale:
        out.append(f"dynamics residual {np.max(np.abs(gen[:6])):.3g}")
    if not cmd.relaxed:
        lim = np.isfinite(effort) & (effort > 0)
        if np.any(np.abs(cmd.tau[lim]) > effort[lim] + TOL * np.maximum(1, effort[lim])):
            out.append("torque")
    return out


def warm_up(solver: str, episode: int, clock_guard: bool) -> str:
    """The process's warm-up (module docstring), run once per process: its line ("warm-up of process P: …") when it
    ran in this call, printed by the caller and kept in that chunk's result (``warmup``); '' on the process's later
    calls (the line is printed and reported once per process)."""
    if _WARMED:
        return ""
    w = run_chunk(WARMUP_TICKS, WARMUP_SEED, solver=solver, episode=episode, clock_guard=clock_guard,
                  warm=False, quiet=True)
    cpu = np.array(w["cpu"])
    _WARMED.append(f"warm-up of process {os.getpid()} (not counted): {w['ticks']} ticks of seed {WARMUP_SEED}, "
                   f"paths {w['paths']}, tick CPU p50 {1e3 * np.median(cpu):.3f} ms, max {1e3 * cpu.max():.3f} ms "
                   f"(first tick {1e3 * cpu[0]:.3f} ms)")
    return _WARMED[0]


def run_chunk(ticks: int, seed: int, progress: str = "", solver: str = "fast", episode: int = 50,
              replay: int | None = None, verbose: bool = False, clock_guard: bool = False, warm: bool = True,
              quiet: bool = False) -> dict:
    """Fuzz ``ticks`` ticks from ``seed`` (module docstring); returns counts, timings and events. ``replay``: run
    only that episode (the others are drawn, not run); ``verbose``: print every tick's path, time and message;
    ``warm``: run the process's warm-up first (:func:`warm_up`); ``quiet``: no progress lines."""
    warmup = warm_up(solver, episode, clock_guard) if warm else ""
    if warmup:
        print(progress + warmup, flush=True)
    robots, _ = load_robots()
    rng = np.random.default_rng(seed)
    c = dict.fromkeys(COUNTS, 0)
    c["longest_feasible_run"], c["longest_feasible_run_at"] = 0, ""
    c["events"] = {k: [] for k in EVENTS}
    paths: Counter = Counter()
    conflicts: Counter = Counter()
    cpu, wall, tick_paths = [], [], []
    worst: list = []  # (CPU s, "seed … episode … tick … path …; what the tick contained") of the slowest ticks
    probe = tick_probe()

    def event(kind: str, ep: int, tick: int, detail: str = "") -> None:
        if len(c["events"][kind]) < MAX_EVENTS:
            c["events"][kind].append(f"seed {seed} episode {ep} tick {tick} {detail}".rstrip())
    t0 = time.time()
    next_print = 0
    while c["ticks"] < ticks:
        name = str(rng.choice(list(robots)))
        robot = robots[name]
        ep = c["episodes"]
        c["episodes"] += 1
        draws = draw_episode(robot, rng)
        skip = replay is not None and ep != replay  # drawn, not built: the rng moves on as in the run
        try:
            if not skip:
                ctrl, q, v, scale = build_episode(robot, draws, solver, clock_guard)
                freeze_after_first((name, solver))
                collect_between_episodes()
        except Exception as exc:  # noqa: BLE001
            c["exceptions"] += 1
            event("exceptions", ep, -1, f"build {type(exc).__name__}: {exc}")
            continue
        ramp_side = str(rng.choice(SIDES)) if rng.random() < 0.5 else None
        ramp_start, ramp_len = int(rng.integers(0, episode // 2)), int(rng.integers(1, 25))
        f0 = robot.mass * 9.81 * rng.uniform(0.3, 1.2)
        mu_tick = int(rng.integers(0, episode)) if rng.random() < 0.3 else -1
        mu_side, mu_new = str(rng.choice(SIDES)), log_uniform(rng, 0.02, 1.5)  # drawn up front: replayable
        if skip:
            c["ticks"] += episode
            continue
        data = robot.model.createData()
        effort = np.asarray(robot.model.effortLimit[6:]) * scale  # the URDF effort times the episode's scale
        f_min = ctrl.contacts["left"].f_min
        bounds = {s: (f_min, np.inf, ctrl.contacts[s].mu) for s in SIDES}
        c["ramps"] += int(ramp_side is not None)
        run = 0  # fallback ticks in a row on a full QP HiGHS finds feasible
        for tick in range(episode):
            c["ticks"] += 1
            if ramp_side is not None and ramp_start <= tick <= ramp_start + ramp_len:
                total = f0 * (1 - (tick - ramp_start) / ramp_len)
                if tick == ramp_start + ramp_len:
                    total = 0.0
                ctrl.set_max_normal_force(ramp_side, total)
                bounds[ramp_side] = (min(f_min, total / 4), total / 4, bounds[ramp_side][2])
                if total == 0.0:
                    ctrl.release_foot(ramp_side)
            if tick == mu_tick:
                ctrl.contacts[mu_side].mu = mu_new
                bounds[mu_side] = (*bounds[mu_side][:2], mu_new)
                c["mu_changes"] += 1
            probe.start()
            try:
                cmd = ctrl.solve(q, v)
            except Exception as exc:  # noqa: BLE001
                c["exceptions"] += 1
                event("exceptions", ep, tick, f"{name} {type(exc).__name__}: {exc}")
                break
            within = probe.stop()
            qp = ctrl.controller.qp
            cut = qp.chain.budget_cut  # the tick's counted work or its clock guard stopped a stage
            t_cpu = cmd.timings.get("cpu", np.nan)
            record_over(c, seed, ticks, ep, tick, t_cpu / DT)
            if len(worst) < MAX_EVENTS or t_cpu > worst[-1][0]:
                worst.append((t_cpu, f"seed {seed} episode {ep} tick {tick} {name} {cmd.path} at {time.time():.3f} s: "
                                     f"CPU {1e3 * t_cpu:.2f} ms, wall {1e3 * cmd.timings.get('total', np.nan):.2f} ms; "
                                     f"counted work {qp.chain.tick_work / qp.chain.tick_work_iterations:.2f} budgets; {within}"))
                worst = sorted(worst, key=lambda w: -w[0])[:MAX_EVENTS]
            paths[str(cmd.path)] += 1
            if verbose:
                print(f"episode {ep} tick {tick} {name} {cmd.path} ok={cmd.ok} cpu {1e3 * cmd.timings['cpu']:.2f} ms "
                      f"{cmd.message[:300]}", flush=True)
            cpu.append(cmd.timings.get("cpu", np.nan))
            tick_paths.append(str(cmd.path))
            wall.append(cmd.timings.get("total", np.nan))
            if cmd.over_budget:
                c["over_budget"] += 1
                event("over_budget", ep, tick, f"{name} {cmd.path} cpu {1e3 * cmd.timings['cpu']:.2f} ms")
            if not (np.isfinite(cmd.tau).all() and np.isfinite(cmd.dv).all() and np.isfinite(cmd.forces).all()):
                c["nan"] += 1
                event("nan", ep, tick, name)
                break
            if cmd.ok:
                bad = bound_violations(robot, data, ctrl, q, v, cmd, bounds, effort)
                if bad:
                    c["bound_violations"] += 1
                    event("bound_violations", ep, tick, f"{name} {cmd.path}: {'; '.join(bad)[:200]}")
            feasible = False
            if not cmd.ok or cmd.relaxed:
                # off the control path: the full QP's hard set at this state, checked by HiGHS; the names
                c["failed_full_qp"] += 1
                c["relaxed_ticks" if cmd.ok else "fallback_ticks"] += 1
                _, _, A, b, C, l, u, lb, ub = ctrl.qp.build(ctrl.state, DT)
                feasible = highs_feasible(A, b, C, l, u, lb, ub)
                if feasible:
                    # a stage skipped by the budget (count or clock guard): the safe command, feasible or not, apart
                    c["failed_feasible_cut" if cut else "failed_feasible"] += 1
                    c["gravity_feasible"] += int(cmd.path.fallback == "gravity")
                    event("failed_feasible", ep, tick, f"{name} {cmd.path}{' (budget cut)' if cut else ''}: "
                                                       f"{cmd.message[:200]}")
                # a tick the budget cut names its budget when the hard set has no conflict to name
                budget = [("tick budget (count or clock guard)", 0.0)] if cut else []
                names = cmd.conflicts or ctrl.controller.diagnose() or budget
                for n, _ in names[:3]:
                    conflicts[n.split(":")[0]] += 1
                if not names:
                    c["failed_unnamed"] += 1
                    event("failed_unnamed", ep, tick, f"{name} {cmd.path}: {cmd.message[:160]}")
            run = run + 1 if (feasible and not cmd.ok) else 0
            if run > c["longest_feasible_run"]:
                c["longest_feasible_run"] = run
                c["longest_feasible_run_at"] = f"seed {seed} episode {ep} ticks {tick - run + 1}..{tick} {name}"
            dv = cmd.dv if cmd.ok else np.zeros(robot.nv)
            v = v + dv * DT
            q = pin.integrate(robot.model, q, v * DT)
        if c["ticks"] >= next_print and not quiet:
            next_print += 5_000
            print(f"{progress}[{time.time() - t0:.0f} s] " + str({k: c[k] for k in COUNTS}), flush=True)
    c["seconds"] = time.time() - t0
    c["paths"] = dict(paths)
    c["conflicts"] = dict(conflicts)
    c["cpu"] = [float(x) for x in cpu]
    c["wall"] = [float(x) for x in wall]
    c["tick_paths"] = tick_paths
    c["worst_ticks"] = worst
    c["warmup"] = warmup
    return c


def aggregate(chunks: list[dict]) -> dict:
    total = {k: sum(ch.get(k, 0) for ch in chunks) for k in COUNTS}
    total["seconds"] = sum(ch["seconds"] for ch in chunks)
    longest = max(chunks, key=lambda ch: ch.get("longest_feasible_run", 0), default={})
    total["longest_feasible_run"] = longest.get("longest_feasible_run", 0)
    total["longest_feasible_run_at"] = longest.get("longest_feasible_run_at", "")
    for key in ("paths", "conflicts"):
        acc: Counter = Counter()
        for ch in chunks:
            acc.update(ch.get(key, {}))
        total[key] = dict(acc)
    for key in ("cpu", "wall"):
        total[key] = np.array([x for ch in chunks for x in ch.get(key, [])])
    total["tick_paths"] = np.array([x for ch in chunks for x in ch.get("tick_paths", [])])
    total["worst_ticks"] = sorted((w for ch in chunks for w in ch.get("worst_ticks", [])), key=lambda w: -w[0])
    total["events"] = {k: [e for ch in chunks for e in ch.get("events", {}).get(k, [])][:MAX_EVENTS] for k in EVENTS}
    total["warmup"] = sorted({ch["warmup"] for ch in chunks if ch.get("warmup")})
    total["over_2x"] = [o for ch in chunks for o in ch.get("over_2x", [])]
    total["over_2x_unkept"] = sum(ch.get("over_2x_unkept", 0) for ch in chunks)
    return total


def report(total: dict, budget: float = DT, episode: int = 50) -> str:
    cpu, wall = total["cpu"], total["wall"]

    def pct(x):
        return (f"p50 {1e3 * np.percentile(x, 50):.3f} ms, p99 {1e3 * np.percentile(x, 99):.3f} ms, "
                f"max {1e3 * x.max():.3f} ms" if x.size else "none")
    rate = total["fallback_ticks"] / max(total["ticks"], 1)
    routes = count_paths(Counter(total["paths"]).elements())
    items = [
        ("exceptions == 0", total["exceptions"], total["exceptions"] == 0),
        ("NaN commands == 0", total["nan"], total["nan"] == 0),
        ("bound violations beyond 1e-6 on ok ticks == 0", total["bound_violations"], total["bound_violations"] == 0),
        ("failed full-QP ticks HiGHS finds feasible, the tick budget not spent == 0",
         f"{total['failed_feasible']} of {total['failed_full_qp']} ({total.get('failed_feasible_cut', 0)} more whose "
         f"budget was spent, by count or clock guard: a stage skipped, the relaxed or safe command)",
         total["failed_feasible"] == 0),
        ("full QPs HiGHS finds feasible that end in the gravity-compensation fallback == 0",
         total["gravity_feasible"], total["gravity_feasible"] == 0),
        (f"longest run of fallback ticks on a full QP HiGHS finds feasible <= {LONGEST_FEASIBLE_RUN}",
         f"{total['longest_feasible_run']} ({total['longest_feasible_run_at'] or 'none'})",
         total["longest_feasible_run"] <= LONGEST_FEASIBLE_RUN),
        ("every failure names its conflict (failed ticks naming none == 0)", total["failed_unnamed"],
         total["failed_unnamed"] == 0),
        over_line(total, float(cpu.max() / budget) if cpu.size else float("nan"), int(np.sum(cpu > 2 * budget)),
                  int(np.sum(cpu > budget))),
        ("every tick took a declared route (wbc.tick.ID_ROUTES)", str(routes["ticks_per_route"]),
         set(routes["ticks_per_route"]) <= set(ID_ROUTES)),
    ]
    lines = ["FINAL " + str({k: total[k] for k in (*COUNTS, "seconds")})]
    lines.append(f"budget {1e3 * budget:.1f} ms (CPU time of the tick's thread); tick CPU {pct(cpu)}; "
                 f"tick wall {pct(wall)}; over budget {total['over_budget']} ticks, over 2 x budget "
                 f"{int(np.sum(cpu > 2 * budget))} ticks (CPU); fallback rate {rate:.3e} "
                 f"({total['fallback_ticks']}/{total['ticks']}), relaxed {total['relaxed_ticks']}")
    if total["exceptions"] == 0 and total["nan"] == 0 and cpu.size % episode == 0:
        later = np.arange(cpu.size) % episode != 0  # every episode has its full length: its first tick is i % episode
        lines.append(f"tick CPU without each new controller's first tick (its one-time set-up): {pct(cpu[later])}; "
                     f"first ticks: {pct(cpu[~later])}")
    lines.append("routes " + str(routes["ticks_per_route"]))
    lines.append("paths " + str(dict(sorted(total["paths"].items(), key=lambda kv: -kv[1]))))
    for path in sorted(total["paths"]):
        sel = total["tick_paths"] == path
        if sel.size == cpu.size and sel.any():
            lines.append(f"  {path}: tick CPU {pct(cpu[sel])}; wall {pct(wall[sel])}")
    lines.append("conflicts named (kind: count, first 3 per failed tick) " + str(total["conflicts"]))
    for t_cpu, where in total.get("worst_ticks", [])[:10]:
        lines.append(f"slow tick {t_cpu / budget:.2f} x budget: {where}")
    stalls = coincident_stalls([(t_cpu / budget, where) for t_cpu, where in total.get("worst_ticks", [])])
    lines.append(f"info: ticks over 2 x budget that overlap a slow tick of another process in wall-clock time (a stall "
                 f"of the machine): {len(stalls)} of {int(np.sum(cpu > 2 * budget))}" + "".join(
                     f"\n  stall: {w}" for w in stalls))
    slow = slow_canary_ticks([(t_cpu / budget, where) for t_cpu, where in total.get("worst_ticks", [])])
    lines.append(f"info: ticks over 2 x budget beside a slow machine (a canary before or after the tick over 1.5 x its "
                 f"median, fuzz_common.TickProbe): {len(slow)} of {int(np.sum(cpu > 2 * budget))}")
    lines += total.get("warmup", []) or ["no warm-up recorded in these chunks"]
    lines += [f"replayed: {record}" for record in total.get("replayed", {}).get("records", [])]
    lines += [f"ACCEPTANCE {'PASS' if ok else 'FAIL'}: {what}: {value}" for what, value, ok in items]
    lines.append(acceptance_verdict(items))
    for k, evs in total["events"].items():
        for e in evs:
            lines.append(f"event {k}: {e}")
    return "\n".join(lines)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    chunk_arguments(p, ticks=1_000_000)
    p.add_argument("--solver", default="fast", help="the ID QP's solver (fast, daqp, ...)")
    p.add_argument("--episode", type=int, default=50, help="ticks per episode")
    p.add_argument("--clock-guard", action="store_true",
                   help="InverseDynamicsController(clock_guard=True): the failure path ordered by cost and stopped "
                        "by the tick's CPU time")
    p.add_argument("--replay", type=int, default=None,
                   help="run only this episode of the chunk of --seed (one chunk of --chunk ticks), verbose")
    a = p.parse_args()
    if a.replay is not None:
        run_chunk(a.chunk, a.seed, solver=a.solver, episode=a.episode, replay=a.replay, verbose=True,
                  clock_guard=a.clock_guard)
        return
    def confirm(total: dict) -> None:  # the ticks over 2 x budget re-measured (fuzz_common.replay_over)
        if total["over_2x"]:
            t0 = time.time()
            total["replayed"] = replay_over(total["over_2x"], lambda seed, n, ep: [
                x / DT for x in run_chunk(n, seed, solver=a.solver, episode=a.episode, replay=ep,
                                          clock_guard=a.clock_guard, quiet=True)["cpu"]])
            print(f"replayed the {len(total['over_2x'])} ticks over 2 x budget in {time.time() - t0:.0f} s (load "
                  f"{' '.join(f'{x:.2f}' for x in os.getloadavg())})", flush=True)
    run_chunks(a, run_chunk, aggregate, report, tag=f"id_{a.solver}_{a.episode}{'_clock' if a.clock_guard else ''}",
               confirm=confirm, solver=a.solver, episode=a.episode, clock_guard=a.clock_guard)


if __name__ == "__main__":
    main()
