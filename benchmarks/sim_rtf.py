#!/usr/bin/env python
"""Real-time factor of the Talos physics walk: ``python benchmarks/sim_rtf.py [--steps 20] [--robot talos]``.

Runs ``wbc sim walk --robot talos --steps 20`` in this process with the command's defaults (realistic plant,
state estimated from the simulated encoders, IMU and ankle F/T, the ID controller at 500 Hz, one ``mj_step`` per
tick) and times the closed loop alone (``wbc.sim.closed_loop.run_closed_loop``: start-up — imports, robot and
MuJoCo model loading, controller construction, numba cache loading — and the summary afterwards are excluded),
after an untimed 2-step walk that compiles any numba kernel the on-disk cache lacks:

- simulated time / CPU time of the process over the loop (``time.process_time``): the real-time factor on one
  core, independent of how many other processes share the machine;
- simulated time / wall time over the loop (``time.perf_counter``), which a loaded machine lowers;
- ``/proc/loadavg`` before and after.

Issue 59 target: CPU real-time factor ≥ 6. Exit code 0 when met, 1 otherwise. ``--json FILE`` writes the numbers.
``--breakdown`` adds the CPU time per tick (``time.thread_time``) of each part of the loop — the controller
(``IDBalanceController.solve``: ID tick), MuJoCo (``mj_step1`` + ``mj_step2``), the simulated sensors and the state
estimator (``EstimatedState.measure``), the walk scenario (stabilizer, gait, references: ``WalkScenario.update``),
the outcome checks (``OutcomeMonitor.update``), reading the MuJoCo state (``MujocoModel.get_state``; on the estimated
state the log's ground truth is converted after the loop instead, inside the timed ``run_closed_loop``), writing the
torques (``MujocoModel.set_torques``) — and the rest (logging, foot wrenches, CoM of the log, that conversion); the
wrappers add about a microsecond per call. Indented lines are parts of the line above them: inside the ID tick the
state update (``DynamicsState.update``), the QP (``InverseDynamicsQP.solve``) and its rows' gathering
(``IDProblemRows.gather``), the actuator compensation; inside the estimated state the sensors.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")

TARGET_RTF = 6.0  #: issue 59 target: simulated time / CPU time of the loop


def loadavg() -> str:
    try:
        return Path("/proc/loadavg").read_text().strip()
    except OSError:
        return "n/a"


def install_timers() -> dict[str, float]:
    """Wrap the parts of the closed loop with CPU-time accumulators; returns {part: seconds}, filled as they run."""
    import mujoco

    import wbc.sim.closed_loop as closed_loop
    from wbc.dynamics.actuator_compensation import JointFrictionCompensation
    from wbc.dynamics.balance import IDBalanceController
    from wbc.formulations.acceleration import InverseDynamicsQP
    from wbc.formulations.id_rows import IDProblemRows
    from wbc.sim.sensors import PlantSensors
    from wbc.state import DynamicsState
    from wbc.sim.estimated_state import EstimatedState
    from wbc.sim.mujoco_runtime import MujocoModel
    from wbc.sim.outcome import OutcomeMonitor
    from wbc.sim.walk import WalkScenario

    parts: dict[str, float] = {}

    def timer(name, fn):
        parts[name] = 0.0

        def wrapped(*a, **kw):
            t0 = time.thread_time()
            try:
                return fn(*a, **kw)
            finally:
                parts[name] += time.thread_time() - t0
        return wrapped

    IDBalanceController.solve = timer("controller (ID tick)", IDBalanceController.solve)
    # inside the ID tick (indented: not added again into the rest of the loop)
    DynamicsState.update = timer("  state update (crba, nle, FK, Jacobians)", DynamicsState.update)
    InverseDynamicsQP.solve = timer("  InverseDynamicsQP.solve", InverseDynamicsQP.solve)
    IDProblemRows.gather = timer("    rows of the tasks and contacts (gather)", IDProblemRows.gather)
    JointFrictionCompensation.compensated = timer("  actuator compensation", JointFrictionCompensation.compensated)
    EstimatedState.measure = timer("sensors + estimator", EstimatedState.measure)
    PlantSensors.read = timer("  sensors (PlantSensors.read)", PlantSensors.read)
    WalkScenario.update = timer("walk scenario update", WalkScenario.update)
    OutcomeMonitor.update = timer("outcome checks", OutcomeMonitor.update)
    MujocoModel.get_state = timer("read MuJoCo state", MujocoModel.get_state)
    MujocoModel.set_torques = timer("set torques (drive envelope)", MujocoModel.set_torques)

    class TimedMujoco:  # the closed loop's view of the mujoco module: its steps timed
        mj_step1 = staticmethod(timer("MuJoCo mj_step1", mujoco.mj_step1))
        mj_step2 = staticmethod(timer("MuJoCo mj_step2", mujoco.mj_step2))

        def __getattr__(self, name):
            return getattr(mujoco, name)

    closed_loop.mujoco = TimedMujoco()
    return parts


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="talos")
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--json", type=Path, default=None, help="write the numbers to this file")
    parser.add_argument("--breakdown", action="store_true", help="CPU time per tick of each part of the loop")
    args = parser.parse_args(argv)
    parts = install_timers() if args.breakdown else None

    import contextlib
    import io

    import wbc.sim.closed_loop as closed_loop
    from wbc.cli import main as wbc_main

    run_closed_loop = closed_loop.run_closed_loop

    timed = {}

    def timed_loop(*a, **kw):
        c0, w0 = time.process_time(), time.perf_counter()
        run = run_closed_loop(*a, **kw)
        timed.update(cpu_s=time.process_time() - c0, wall_s=time.perf_counter() - w0,
                     sim_s=len(run.t) * run.dt, ticks=len(run.t))
        return run

    closed_loop.run_closed_loop = timed_loop  # run_scenario imports it from there when it is called
    # Warm-up, not timed: a 2-step walk first, so that numba kernels missing from the on-disk cache are compiled
    # here and not inside the timed loop (a cold cache once put seconds of compilation into it).
    c_warm = time.process_time()
    with contextlib.redirect_stdout(io.StringIO()):
        wbc_main(["sim", "walk", "--robot", args.robot, "--steps", "2", "--quiet"])
    c_warm = time.process_time() - c_warm
    timed.clear()
    load_before = loadavg()
    c_all, w_all = time.process_time(), time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()):  # the command's summary
        code = wbc_main(["sim", "walk", "--robot", args.robot, "--steps", str(args.steps), "--quiet"])
    c_all, w_all = time.process_time() - c_all, time.perf_counter() - w_all
    load_after = loadavg()
    if "cpu_s" not in timed:
        print("sim_rtf: the closed loop did not run", file=sys.stderr)
        return 1
    out = dict(timed, command=f"wbc sim walk --robot {args.robot} --steps {args.steps}", exit_code=code,
               rtf_cpu=timed["sim_s"] / timed["cpu_s"], rtf_wall=timed["sim_s"] / timed["wall_s"],
               cpu_per_tick_us=1e6 * timed["cpu_s"] / timed["ticks"], process_cpu_s=c_all, process_wall_s=w_all,
               loadavg_before=load_before, loadavg_after=load_after, target_rtf_cpu=TARGET_RTF, warm_up_cpu_s=c_warm,
               date=time.strftime("%Y-%m-%dT%H:%M:%S%z"))
    print(f"{out['command']}: {timed['ticks']} ticks, simulated {timed['sim_s']:.2f} s; loop CPU {timed['cpu_s']:.2f} s "
          f"({out['cpu_per_tick_us']:.0f} µs/tick), wall {timed['wall_s']:.2f} s; real-time factor CPU "
          f"{out['rtf_cpu']:.2f}, wall {out['rtf_wall']:.2f} (target CPU ≥ {TARGET_RTF:g}); whole process CPU "
          f"{c_all:.1f} s, wall {w_all:.1f} s (after an untimed 2-step warm-up walk, CPU {c_warm:.1f} s); loadavg before "
          f"{load_before} / after {load_after}")
    if parts is not None:
        total = 1e6 * timed["cpu_s"] / timed["ticks"]
        per_tick = {name: 1e6 * sec / timed["ticks"] for name, sec in parts.items()}
        per_tick["rest of the loop"] = total - sum(us for name, us in per_tick.items() if not name.startswith(" "))
        out["breakdown_cpu_us_per_tick"] = per_tick
        for name, us in per_tick.items():
            print(f"  {name:46s} {us:8.1f} µs/tick  {100 * us / total:5.1f} %")
    if args.json is not None:
        args.json.write_text(json.dumps(out, indent=1))
    return 0 if out["rtf_cpu"] >= TARGET_RTF and code == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
