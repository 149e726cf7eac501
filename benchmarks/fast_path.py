"""The compiled hot path (``solver="fast"``: :mod:`wbc.solvers.fast`, :mod:`wbc.formulations.velocity_kernel`)
against wbc's general DAQP path and placo.

Timing: the ``wbc bench`` kinematic scenario (Talos, feet hard, CoM sway, torso, posture, position + velocity
limits; :mod:`wbc.bench.kinematic`) run interleaved A B C A B C ... in this one process, ``--repeats`` times;
medians over the repeats of each run's median CPU tick, ratios against placo, machine load (``os.getloadavg``)
printed before and after. Then the walk tick (:mod:`wbc.bench.walk`: wbc vs placo with both feet hard on the same
plan and placo's own soft-feet ``WalkTasks``), median and p99.

Extra tasks (``--extra-tasks``): the same scenario with 10 more soft 6-D frame tasks, per-task cost per library.

Instructions (``--callgrind N``): :mod:`wbc.bench.instructions` — wbc and placo under callgrind, instruction counts
after N and 2N ticks in one instrumented run, differenced: instructions per tick, independent of machine load.

Usage: python benchmarks/fast_path.py [--repeats 5] [--ticks 2000] [--walk-steps 8] [--extra-tasks] [--callgrind 100]
       [--callgrind-walk 2] [--only-callgrind]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

LIBS = ("wbc-fast", "wbc-daqp", "placo")


def _runner(lib: str, ticks: int, robot):
    from wbc.bench.kinematic import KinematicSpec, PlacoRunner, WbcRunner

    if lib == "placo":
        return PlacoRunner(KinematicSpec(ticks=ticks), robot)
    return WbcRunner(KinematicSpec(ticks=ticks, solver=lib.split("-")[1]), robot)


def _load() -> str:
    return "load " + " ".join(f"{x:.2f}" for x in os.getloadavg())


def timing(repeats: int, ticks: int) -> dict[str, float]:
    import wbc
    from wbc.bench.stats import limit_blas_threads
    from wbc.formulations import velocity_kernel
    from wbc.solvers import active_set

    limit_blas_threads(1)
    t0 = time.perf_counter()
    active_set.load_active_set_kernels()
    velocity_kernel.load_kinematic_kernels()
    seconds = time.perf_counter() - t0
    print(f"numba kernel first call (compile or on-disk cache load): {seconds * 1e3:.0f} ms")
    robot = wbc.load_robot("talos")
    runners = {lib: _runner(lib, ticks, robot) for lib in LIBS}
    med: dict[str, list[float]] = {lib: [] for lib in LIBS}
    finals = {}
    print(f"kinematic tick, Talos, {ticks} ticks x {repeats} repeats, interleaved; {_load()}")
    for _ in range(repeats):
        for lib, r in runners.items():
            run = r.run()
            assert r.failures == 0, (lib, r.first_error)
            med[lib].append(float(np.median(run.cpu_ns)) / 1e3)
            finals[lib] = np.asarray(run.metrics["final_com"])
    out = {lib: float(np.median(v)) for lib, v in med.items()}
    for lib in LIBS:
        print(f"  {lib:9s} median CPU tick {out[lib]:7.1f} us  (per repeat: "
              f"{', '.join(f'{v:.1f}' for v in med[lib])})  / placo {out[lib] / out['placo']:.2f}")
    fast = runners["wbc-fast"].controller.backend
    print(f"  fast backend: {fast.kernel_solves} kernel solves, {fast.fallbacks} DAQP fallbacks; "
          f"final CoM fast vs daqp {np.abs(finals['wbc-fast'] - finals['wbc-daqp']).max():.1e} m; {_load()}")
    return out


def walk(repeats: int, steps: int) -> dict:
    """The walk section of ``wbc bench`` (:mod:`wbc.bench.walk`): wbc vs placo hard-feet and soft-feet walks."""
    import wbc
    from wbc.bench.walk import WalkBenchSpec, run_walk_benchmark

    robot = wbc.load_robot("talos")
    out = run_walk_benchmark(robot, WalkBenchSpec(n_steps=steps, repeats=repeats), log=lambda _: None)
    print(f"walk tick, Talos, {steps} steps ({out['ticks']} ticks) x {repeats} repeats, interleaved; {_load()}")
    for lib, v in out["libraries"].items():
        print(f"  {lib:10s} median {v['wall_us']['median_of_repeat_medians']:7.1f} us  p99 {v['p99_us']:8.1f} us  "
              f"/ placo-hard {out['ratios_to_placo-hard'][lib]:.2f}  failures {v['failures']}  "
              f"max CoM error {v['max_com_error'] * 1e3:.2f} mm")
    return out


#: the extra frame tasks of :func:`extra_tasks` (Talos bodies spread over the tree)
EXTRA_FRAMES = ("leg_left_3_link", "leg_right_3_link", "arm_left_2_link", "arm_right_2_link", "arm_left_4_link",
                "arm_right_4_link", "arm_left_7_link", "arm_right_7_link", "head_2_link", "torso_1_link")


def extra_tasks(repeats: int, ticks: int) -> dict:
    """Cost of one extra 6-D frame task (soft, weight 1, target = its initial placement): the benchmark tick with
    the 10 ``EXTRA_FRAMES`` tasks minus without, divided by 10, per library, interleaved."""
    import wbc
    from wbc.bench.kinematic import KinematicSpec, PlacoRunner, WbcRunner
    from wbc.tasks import FrameTask

    class WbcExtra(WbcRunner):
        def reset(self):
            super().reset()
            dt = self.spec.dt
            for f in EXTRA_FRAMES:
                t = FrameTask(self.robot, f, position_weight=1.0, orientation_weight=1.0, gain=1.0 / dt)
                t.set_target_from_configuration(self.config)
                self.controller.add_task(t)

    class PlacoExtra(PlacoRunner):
        def reset(self):
            super().reset()
            for f in EXTRA_FRAMES:
                self.solver.add_frame_task(f, self.wrapper.get_T_world_frame(f)).configure(f, "soft", 1.0, 1.0)

    robot = wbc.load_robot("talos")
    spec = KinematicSpec(ticks=ticks)
    runners = {"wbc": WbcRunner(spec, robot), "wbc+10": WbcExtra(spec, robot), "placo": PlacoRunner(spec, robot),
               "placo+10": PlacoExtra(spec, robot)}
    med: dict[str, list[float]] = {k: [] for k in runners}
    for _ in range(repeats):
        for k, r in runners.items():
            run = r.run()
            assert r.failures == 0, (k, r.first_error)
            med[k].append(float(np.median(run.cpu_ns)) / 1e3)
    per = {lib: float(np.median([(a - b) / len(EXTRA_FRAMES) for a, b in zip(med[lib + "+10"], med[lib])]))
           for lib in ("wbc", "placo")}
    print(f"extra 6-D frame task, Talos, {len(EXTRA_FRAMES)} tasks, {ticks} ticks x {repeats} repeats; {_load()}")
    for lib, v in per.items():
        print(f"  {lib:6s} +{v:5.1f} us per task  (tick {np.median(med[lib]):.1f} -> {np.median(med[lib + '+10']):.1f} us)")
    return per


def callgrind(n: int) -> dict:
    """Instructions per kinematic tick, wbc (default backend) vs placo (:mod:`wbc.bench.instructions`)."""
    from wbc.bench.instructions import instructions_per_tick

    out = instructions_per_tick(n, log=lambda m: print("  " + m, flush=True))
    print(f"instructions per kinematic tick (callgrind, {n} vs {2 * n} ticks differenced, load-independent):")
    for lib, v in out["instructions"].items():
        print(f"  {lib:6s} {v / 1e3:8.0f} k   / placo {v / out['instructions']['placo']:.2f}")
    return out


def callgrind_walk(n_steps: int) -> dict:
    """Instructions per walk tick, wbc vs placo with both feet hard (:func:`wbc.bench.instructions.walk_instructions_per_tick`)."""
    from wbc.bench.instructions import walk_instructions_per_tick

    out = walk_instructions_per_tick(n_steps, log=lambda m: print("  " + m, flush=True))
    print(f"instructions per walk tick (callgrind, {n_steps}-step walk, {out['ticks']} ticks each, load-independent):")
    for lib, v in out["instructions"].items():
        print(f"  {lib:6s} {v / 1e3:8.0f} k   / placo {v / out['instructions']['placo']:.2f}")
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--ticks", type=int, default=2000)
    p.add_argument("--walk-steps", type=int, default=8, help="steps of the walk (0: skip the walk)")
    p.add_argument("--extra-tasks", action="store_true", help="also measure the cost of an extra frame task")
    p.add_argument("--callgrind", type=int, default=0, help="N ticks for the instruction count (0: skip)")
    p.add_argument("--callgrind-walk", type=int, default=0, help="steps of the walk counted by callgrind (0: skip)")
    p.add_argument("--only-callgrind", action="store_true", help="skip the timing sections")
    a = p.parse_args()
    if not a.only_callgrind:
        timing(a.repeats, a.ticks)
        if a.walk_steps:
            walk(a.repeats, a.walk_steps)
        if a.extra_tasks:
            extra_tasks(a.repeats, a.ticks)
    if a.callgrind:
        callgrind(a.callgrind)
    if a.callgrind_walk:
        callgrind_walk(a.callgrind_walk)


if __name__ == "__main__":
    main()
