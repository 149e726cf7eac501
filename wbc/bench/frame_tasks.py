"""Cost of one extra 6-D frame task on the kinematic benchmark tick, wbc vs placo, interleaved in one process.

The benchmark tick (:mod:`wbc.bench.kinematic`) is run as is and with ``len(EXTRA_FRAMES)`` more soft 6-D frame
tasks (weight 1 on position and orientation, target = the frame's initial placement ``oMf``, dead-beat gain
1/dt); the cost of one task is (median tick with the extra tasks − median tick without) / number of tasks, per
interleaved repeat, then the median over repeats (the goal is in ``benchmarks/README.md``).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Callable

import numpy as np

from wbc.bench.kinematic import KinematicSpec, PlacoRunner, WbcRunner

__all__ = ["EXTRA_FRAMES", "FrameTaskSpec", "run_frame_task_benchmark"]

#: the extra frame tasks (Talos bodies spread over the kinematic tree)
EXTRA_FRAMES = ("leg_left_3_link", "leg_right_3_link", "arm_left_2_link", "arm_right_2_link", "arm_left_4_link",
                "arm_right_4_link", "arm_left_7_link", "arm_right_7_link", "head_2_link", "torso_1_link")


@dataclass(frozen=True)
class FrameTaskSpec:
    """ticks: timed ticks per run; repeats: interleaved repeats (A A+ B B+ …); frames: the extra tasks' frames."""

    ticks: int = 2000
    repeats: int = 5
    warmup: int = 100
    frames: tuple[str, ...] = EXTRA_FRAMES


class _WbcExtra(WbcRunner):
    frames: tuple[str, ...] = ()

    def reset(self) -> None:
        from wbc.tasks import FrameTask

        super().reset()
        for f in self.frames:
            t = FrameTask(self.robot, f, position_weight=1.0, orientation_weight=1.0, gain=1.0 / self.spec.dt)
            t.set_target_from_configuration(self.config)
            self.controller.add_task(t)


class _PlacoExtra(PlacoRunner):
    frames: tuple[str, ...] = ()

    def reset(self) -> None:
        super().reset()
        for f in self.frames:
            self.solver.add_frame_task(f, self.wrapper.get_T_world_frame(f)).configure(f, "soft", 1.0, 1.0)


def run_frame_task_benchmark(robot, spec: FrameTaskSpec = FrameTaskSpec(),
                             log: Callable[[str], None] = lambda _: None) -> dict[str, object]:
    """Measure the per-task cost of ``spec.frames`` extra frame tasks for wbc and placo on ``robot`` (Talos:
    the frame names are Talos's).

    Returns:
        {"frames", "ticks", "repeats", "load_before", "load_after",
        "tick_us": {run: [median wall µs per repeat]} for runs "wbc", "wbc+N", "placo", "placo+N",
        "per_task_us": {"wbc": µs, "placo": µs} (median over repeats of the per-repeat difference / N),
        "failures": {run: failed ticks}}.

    Raises:
        RuntimeError: a run had failed ticks (the comparison would not be of the same work).
    """
    n = len(spec.frames)
    ks = KinematicSpec(robot=robot.name, ticks=spec.ticks, warmup=spec.warmup)
    wbc_extra = type("WbcExtra", (_WbcExtra,), {"frames": tuple(spec.frames)})
    placo_extra = type("PlacoExtra", (_PlacoExtra,), {"frames": tuple(spec.frames)})
    runners = {"wbc": WbcRunner(ks, robot), f"wbc+{n}": wbc_extra(ks, robot), "placo": PlacoRunner(ks, robot),
               f"placo+{n}": placo_extra(ks, robot)}
    load_before = os.getloadavg()
    med: dict[str, list[float]] = {k: [] for k in runners}
    failures = {k: 0 for k in runners}
    for r in range(spec.repeats):
        for k, runner in runners.items():
            run = runner.run()
            failures[k] += runner.failures
            med[k].append(float(np.median(run.wall_ns)) / 1e3)
        log(f"frame tasks repeat {r + 1}/{spec.repeats}: " + ", ".join(f"{k} {v[-1]:.1f}" for k, v in med.items())
            + " µs")
    bad = {k: v for k, v in failures.items() if v}
    if bad:
        raise RuntimeError(f"frame-task benchmark: failed ticks {bad}")
    per = {lib: float(np.median([(a - b) / n for a, b in zip(med[f"{lib}+{n}"], med[lib])]))
           for lib in ("wbc", "placo")}
    return {"frames": list(spec.frames), "ticks": spec.ticks, "repeats": spec.repeats,
            "load_before": list(load_before), "load_after": list(os.getloadavg()), "tick_us": med,
            "per_task_us": per, "failures": failures}
