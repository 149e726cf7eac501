#!/usr/bin/env python
"""Where does a wbc kinematic tick go? ``python benchmarks/profile_tick.py [--robot talos] [--ticks 2000]``.

Runs the benchmark scenario (:mod:`wbc.bench.kinematic`) once with wbc (the compiled tick's gather and kernel times
from ``TickResult.timings``), records the QPs of the general path (``KinematicController.assemble``) at its
configurations, then times on the recorded problems, one piece at a time (medians in µs):

* the Pinocchio update (``Configuration.update``) and the general path's ``KinematicController.assemble``;
* the wbc backend call (``QPBackend.solve``: solver + violation check + clip) for every backend;
* the raw solvers without wbc around them: proxsuite dense ``update`` + ``solve`` warm-started, and daqp's
  ``solve`` with bounds and equalities in its native form;
* the post-solve ``QPBackend.scaled_violation`` check alone.

Also prints placo's whole tick for scale. Read-only: nothing in wbc is modified (the backend is wrapped).
"""

from __future__ import annotations

import argparse
import os

for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(var, "1")

from time import perf_counter_ns  # noqa: E402

import numpy as np  # noqa: E402


def _median_us(fn, problems, repeat: int = 1) -> float:
    times = []
    for args in problems:
        for _ in range(repeat):
            t0 = perf_counter_ns()
            fn(*args)
            times.append(perf_counter_ns() - t0)
    return float(np.median(times)) / 1e3


def main() -> None:
    from wbc.bench.kinematic import KinematicSpec, PlacoRunner, WbcRunner
    from wbc.bench.stats import limit_blas_threads, summarize_us
    from wbc.solvers import make_backend, available_solvers
    from wbc.robot import load_robot

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="talos")
    parser.add_argument("--ticks", type=int, default=2000)
    args = parser.parse_args()
    limit_blas_threads(1)
    robot = load_robot(args.robot)
    spec = KinematicSpec(robot=args.robot, ticks=args.ticks)

    runner = WbcRunner(spec, robot)
    runner.reset()
    configs: list[np.ndarray] = []
    timings: list[dict] = []
    for k in range(spec.total_ticks):
        configs.append(runner.config.q.copy())
        runner.tick(k)
        timings.append(runner.controller.last_result.timings)
    ctrl0 = runner.controller
    print(f"compiled tick (solver {spec.solver!r}): gather (task/constraint rows, Pinocchio queries) "
          f"{np.median([t['assembly'] for t in timings[spec.warmup:]]) * 1e6:.1f} µs, kernel + contact drift check "
          f"{np.median([t['solve'] for t in timings[spec.warmup:]]) * 1e6:.1f} µs (TickResult.timings); "
          f"fast backend: {ctrl0.backend.kernel_solves} kernel solves, {ctrl0.backend.fallbacks} DAQP fallbacks")
    # The QPs of the general path (KinematicController.assemble) at the recorded configurations.
    from wbc.configuration import Configuration

    rec_cfg = Configuration(robot)
    recorded: list[tuple] = []
    for q in configs[spec.warmup:]:
        rec_cfg.update(q)
        recorded.append(tuple(np.array(a, copy=True) for a in ctrl0.assemble(rec_cfg, spec.dt)))
    backend = ctrl0.backend
    problems = recorded
    n, n_eq = problems[0][0].shape[0], problems[0][2].shape[0]
    print(f"{robot.name}: nv {n}, {n_eq} equality rows, {len(problems)} recorded QPs")

    # Whole tick, for reference.
    tick = summarize_us(WbcRunner(spec, robot).run().wall_ns)["median"]
    placo = summarize_us(PlacoRunner(spec, robot).run().wall_ns)["median"]
    print(f"tick median: wbc ({spec.solver}) {tick:.1f} µs, placo {placo:.1f} µs")

    # Pinocchio update and assembly, on the recorded configurations.
    fresh = WbcRunner(spec, robot)
    fresh.reset()
    cfg, ctrl = fresh.config, fresh.controller
    qs = [(q,) for q in configs[spec.warmup:]]
    print(f"Configuration.update (Pinocchio: joint Jacobians, frames, CoM Jacobian): {_median_us(cfg.update, qs):.1f} µs")

    def assemble(q):
        cfg.update(q)
        ctrl.assemble(cfg, spec.dt)

    print(f"KinematicController.assemble, general path (3 tasks, 2 contacts, 2 limit boxes): "
          f"{_median_us(assemble, qs) - _median_us(cfg.update, qs):.1f} µs")

    # wbc backends on the recorded problems (sequential, so warm starts see consecutive ticks).
    import warnings

    for name in available_solvers():
        b = make_backend(name)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            print(f"wbc backend {name:9s} QPBackend.solve: {_median_us(b.solve, problems):.1f} µs")
    print(f"QPBackend.scaled_violation check alone: "
          f"{_median_us(lambda *qp: backend.scaled_violation(np.zeros(n), np.zeros(n), *qp[2:]), problems):.1f} µs")

    # Raw proxsuite, warm-started like wbc's backend.
    import proxsuite

    H, g, A, b, C, l, u, lb, ub = problems[0]
    qp = proxsuite.proxqp.dense.QP(n, n_eq, 0, True)
    qp.settings.eps_abs, qp.settings.eps_rel, qp.settings.verbose = 1e-9, 0.0, False
    clip = lambda x: np.clip(x, -1e10, 1e10)  # noqa: E731
    qp.init(H, g, A, b, None, None, None, clip(lb), clip(ub))
    qp.solve()
    qp.settings.initial_guess = proxsuite.proxqp.InitialGuess.WARM_START_WITH_PREVIOUS_RESULT

    def prox(H, g, A, b, C, l, u, lb, ub):
        qp.update(H, g, A, b, None, None, None, clip(lb), clip(ub))
        qp.solve()

    print(f"raw proxsuite dense update+solve (warm, eps 1e-9): {_median_us(prox, problems):.1f} µs")

    # Raw daqp: bounds as the first rows of bupper/blower, equalities with sense 5 (daqp's equality flag).
    try:
        import daqp
        from ctypes import c_int

        def daqp_raw(H, g, A, b, C, l, u, lb, ub):
            bu = np.concatenate([np.minimum(ub, 1e30), b])
            bl = np.concatenate([np.maximum(lb, -1e30), b])
            sense = np.zeros(bu.size, dtype=c_int)
            sense[n:] = 5
            daqp.solve(H, g, A, bu, bl, sense)

        print(f"raw daqp solve (cold, bounds + equalities native): {_median_us(daqp_raw, problems):.1f} µs")
    except Exception as exc:  # pragma: no cover - diagnostic script
        print(f"raw daqp: {exc}")

    # Raw quadprog (Goldfarb-Idnani dual active set, the algorithm of placo's eiquadprog): equalities first,
    # finite bounds as inequality rows.
    try:
        import quadprog

        def quadprog_raw(H, g, A, b, C, l, u, lb, ub):
            lo, hi = np.isfinite(lb) & (lb > -1e29), np.isfinite(ub) & (ub < 1e29)
            eye = np.eye(n)
            Cm = np.vstack([A, eye[lo], -eye[hi]]).T
            bv = np.concatenate([b, lb[lo], -ub[hi]])
            quadprog.solve_qp(H, -g, Cm, bv, A.shape[0])

        print(f"raw quadprog solve (cold, {n_eq} equalities + bounds as rows): {_median_us(quadprog_raw, problems):.1f} µs")
    except Exception as exc:  # pragma: no cover - diagnostic script
        print(f"raw quadprog: {exc}")


if __name__ == "__main__":
    main()
