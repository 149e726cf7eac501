"""The whole benchmark suite, run in one process: kinematic tick (wbc / placo / Pink), wbc breakdown, wbc QP
backends, scaling over robots, inverse dynamics (wbc / placo), gait planning (wbc / placo), the walk tick, the cost
of an extra frame task and instruction counts.

:func:`run_suite` returns one JSON-serialisable dict (plus raw latency arrays under ``"_raw"``, for the plot);
:mod:`wbc.bench.report` turns it into JSON, markdown and a PNG.
"""

from __future__ import annotations

import contextlib
import cProfile
import logging
import pstats
import time
import warnings
from dataclasses import asdict, dataclass, replace

import numpy as np

from wbc.bench.kinematic import (
    KinematicRun,
    KinematicSpec,
    PinkRunner,
    PlacoRunner,
    SameWorkTolerance,
    WbcRunner,
    pink_available,
    same_work_check,
)
from wbc.bench.stats import machine_info, pooled_summary_us, summarize_us
from wbc.robot import load_robot

__all__ = ["SuiteConfig", "run_suite", "compare_libraries", "profile_wbc_tick"]

PINK_SOLVERS = ("quadprog", "daqp", "proxqp", "osqp")
OTHER = "other (targets, integrate, timers)"
#: the LLVM CPU of the second instruction count (``results["instructions_host"]``): x86-64 with AVX2, the nearest to
#: this project's hosts (AVX-512) that valgrind emulates; the first count is of generic x86-64 code
HOST_LIKE_CPU = "haswell"


@dataclass(frozen=True)
class SuiteConfig:
    """What to run. ``ticks``/``repeats`` apply to the kinematic and ID comparisons; the other sections run one
    timed run each with ``ticks`` ticks.

    Attributes:
        robot: robot of the comparisons (sections 1, 2, 3, 5, 6).
        ticks, repeats, warmup: timed ticks per run, interleaved repeats, untimed ticks before each run.
        pink_select_ticks: ticks of the pre-pass choosing Pink's fastest valid solver.
        scaling_robots: robots of section 4.
        gait_repeats, placo_gait_repeats: timed plans per planner.
        walk_steps: steps of the walk section's plan (``plan_default_walk``); its repeats are ``repeats``.
        callgrind_ticks: N of the instruction count (runs of N and 2N ticks under callgrind).
        sections: subset of {"kinematic", "breakdown", "solvers", "scaling", "dynamics", "gait", "walk",
            "frame_tasks", "instructions"}.
    """

    robot: str = "talos"
    ticks: int = 2000
    repeats: int = 5
    warmup: int = 100
    pink_select_ticks: int = 300
    scaling_robots: tuple[str, ...] = ("humanoid15", "g1", "talos")
    gait_repeats: int = 200
    placo_gait_repeats: int = 20
    walk_steps: int = 8
    callgrind_ticks: int = 200
    sections: tuple[str, ...] = ("kinematic", "breakdown", "solvers", "scaling", "dynamics", "gait", "walk",
                                 "frame_tasks", "instructions")

    @classmethod
    def quick(cls) -> "SuiteConfig":
        """A seconds-long configuration for smoke tests (numbers not meaningful). Pink's solver pre-pass runs as many
        ticks as the timed run, so the solver it picks passes the same-work check of that run (a shorter pre-pass let
        ProxQP, fastest under load, pass 20 ticks and overshoot a position limit by 1.84e-6 rad by tick 60)."""
        return cls(ticks=60, repeats=1, warmup=5, pink_select_ticks=60, gait_repeats=3, placo_gait_repeats=1,
                   walk_steps=2, callgrind_ticks=20)


@contextlib.contextmanager
def _quiet_qp_warnings():
    """Silence qpsolvers' dense-to-sparse conversion and osqp's deprecation warnings, and Pink's per-tick
    "out of limits" log lines (a solver that overshoots a limit is reported by the same-work check instead)."""
    previous = logging.root.manager.disable
    logging.disable(logging.WARNING)
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", module=r"(qpsolvers|osqp)(\..*)?")
            yield
    finally:
        logging.disable(previous)


def _log(msg: str) -> None:
    print(f"[bench {time.strftime('%H:%M:%S')}] {msg}", flush=True)


def _worst_metrics(runs: list[KinematicRun]) -> dict[str, object]:
    """Metrics of a library over its repeats: the worst value of each error, the first run's final CoM."""
    out = dict(runs[0].metrics)
    for key in ("final_com_error", "max_com_error", "feet_drift", "feet_rotation", "position_limit_violation",
                "velocity_limit_violation"):
        out[key] = max(float(r.metrics[key]) for r in runs)
    out["finite"] = all(bool(r.metrics["finite"]) for r in runs)
    return out


def compare_libraries(runners: dict[str, object], repeats: int, reference: str = "placo",
                      tol: SameWorkTolerance = SameWorkTolerance(), label: str = "",
                      breakdown: bool = False) -> dict[str, object]:
    """Run ``runners`` (library -> runner) interleaved, A B C A B C …, ``repeats`` times (with per-phase timers
    when ``breakdown``: then each library also gets "phases_us", pooled phase summaries).

    Returns:
        {"libraries": {lib: {"wall_us": pooled summary, "cpu_us": ..., "repeat_medians_us": [...],
        "solver", "failures", "metrics" (worst over repeats), "note"}}, "ratios_to_<reference>":
        {lib: {"median", "per_repeat"}}, "same_work": same_work_check output, "_raw": {lib: wall ns}}.
    """
    runs: dict[str, list[KinematicRun]] = {lib: [] for lib in runners}
    for r in range(repeats):
        for lib, runner in runners.items():
            t0 = time.perf_counter()
            runs[lib].append(runner.run(breakdown=breakdown))
            _log(f"{label} repeat {r + 1}/{repeats} {lib}: median "
                 f"{summarize_us(runs[lib][-1].wall_ns)['median']:.1f} µs ({time.perf_counter() - t0:.1f} s)")
    libs: dict[str, dict] = {}
    for lib, rs in runs.items():
        libs[lib] = {"solver": rs[0].solver, "failures": int(sum(r.failures for r in rs)),
                     "wall_us": pooled_summary_us([r.wall_ns for r in rs]),
                     "cpu_us": pooled_summary_us([r.cpu_ns for r in rs]),
                     "repeat_medians_us": [summarize_us(r.wall_ns)["median"] for r in rs],
                     "metrics": _worst_metrics(rs), "note": rs[0].note,
                     "first_error": next((r.first_error for r in rs if r.first_error), "")}
        if breakdown and rs[0].breakdown_ns is not None:
            phases = {k: pooled_summary_us([r.breakdown_ns[k] for r in rs]) for k in rs[0].breakdown_ns}
            phases[OTHER] = pooled_summary_us([r.wall_ns - sum(r.breakdown_ns.values()) for r in rs])
            libs[lib]["phases_us"] = phases
    ratios: dict[str, dict] = {}
    if reference in runs:
        for lib, rs in runs.items():
            per = [float(np.median(a.wall_ns) / np.median(b.wall_ns)) for a, b in zip(rs, runs[reference])]
            per_cpu = [float(np.median(a.cpu_ns) / np.median(b.cpu_ns)) for a, b in zip(rs, runs[reference])]
            ratios[lib] = {"median": float(np.median(per)), "per_repeat": per, "cpu_median": float(np.median(per_cpu))}
    check = same_work_check({lib: v["metrics"] for lib, v in libs.items()}, reference, tol,
                            {lib: v["failures"] for lib, v in libs.items()})
    return {"libraries": libs, f"ratios_to_{reference}": ratios, "same_work": check,
            "tolerance": asdict(tol), "_raw": {lib: np.concatenate([r.wall_ns for r in rs]) for lib, rs in runs.items()}}


def _select_pink_solver(robot, spec: KinematicSpec, ticks: int, reference_metrics: dict | None,
                        rounds: int = 3, full_reference: dict | None = None) -> dict[str, object]:
    """Short runs of Pink with every installed solver, interleaved over ``rounds`` rounds: the solver with the
    lowest median of per-round medians, among those without failures whose motion passes the same-work check
    (against a placo run of the same length), is used. With ``full_reference`` (placo's metrics over the timed run's
    ``spec.ticks``) and ``ticks`` < ``spec.ticks``, the candidates are then run once over ``spec.ticks``, fastest
    first, and the first that passes the same-work check against it is used: a solver that passes a short run can
    still overshoot a limit later in the timed run."""
    import qpsolvers

    solvers = [s for s in PINK_SOLVERS if s in qpsolvers.available_solvers]
    rows: dict[str, dict] = {}
    medians: dict[str, list[float]] = {s: [] for s in solvers}
    for _ in range(rounds):
        for solver in solvers:
            if "error" in rows.get(solver, {}):
                continue
            try:
                with _quiet_qp_warnings():
                    run = PinkRunner(replace(spec, solver=solver, ticks=ticks), robot).run()
            except Exception as exc:  # a backend that raises is reported, not fatal
                rows[solver] = {"error": f"{type(exc).__name__}: {exc}"}
                continue
            medians[solver].append(summarize_us(run.wall_ns)["median"])
            rows[solver] = {"failures": run.failures, "metrics": run.metrics}
    valid = {}
    for solver, row in rows.items():
        if "error" in row:
            continue
        row["median_us"] = float(np.median(medians[solver]))
        row["round_medians_us"] = medians[solver]
        metrics = {"pink": row["metrics"]}
        if reference_metrics is not None:
            metrics["placo"] = reference_metrics
        check = same_work_check(metrics, "placo", failures={"pink": row["failures"]})
        row["same_work"] = check["pink"]["verdict"]
        if check["pink"]["passed"]:
            valid[solver] = row["median_us"]
        _log(f"pink solver pre-pass {solver}: {row['median_us']:.1f} µs, {row['same_work']}")
    best = None
    for solver in sorted(valid, key=valid.get):
        if full_reference is None or ticks >= spec.ticks:
            best = solver
            break
        with _quiet_qp_warnings():
            run = PinkRunner(replace(spec, solver=solver), robot).run()
        check = same_work_check({"pink": run.metrics, "placo": full_reference}, "placo",
                                failures={"pink": run.failures})
        rows[solver]["same_work_full_run"] = check["pink"]["verdict"]
        _log(f"pink solver pre-pass {solver} over {spec.ticks} ticks: {check['pink']['verdict']}")
        if check["pink"]["passed"]:
            best = solver
            break
    return {"ticks": ticks, "rounds": rounds, "solvers": rows, "selected": best}


def profile_wbc_tick(robot, spec: KinematicSpec, top: int = 12) -> list[dict[str, object]]:
    """cProfile of the wbc ticks of one run (the ticks only: no evaluation): the ``top`` functions by own time,
    µs per tick (profiling inflates Python-level costs; read the ranking, not the absolute values)."""
    runner = WbcRunner(spec, robot)
    runner.reset()
    n = spec.total_ticks
    prof = cProfile.Profile()
    prof.enable()
    for k in range(n):
        runner.tick(k)
    prof.disable()
    stats = pstats.Stats(prof).stats  # (file, line, func) -> (cc, nc, tt, ct, callers)
    rows = []
    for (path, line, func), (_, ncalls, tt, ct, _) in stats.items():
        if path.endswith("kinematic.py") and func == "tick" or "_lsprof" in path or func.startswith("<method 'disable'"):
            continue
        short = path.split("site-packages/")[-1].split("/work/main/")[-1]
        rows.append({"function": f"{short}:{line}({func})", "calls_per_tick": ncalls / n,
                     "own_us_per_tick": tt / n * 1e6, "cumulative_us_per_tick": ct / n * 1e6})
    rows.sort(key=lambda r: r["own_us_per_tick"], reverse=True)
    return rows[:top]


def _breakdown_section(cfg: SuiteConfig, robot, spec: KinematicSpec) -> dict[str, object]:
    """wbc with per-phase timers, interleaved with placo (for scale) over ``cfg.repeats`` repeats; phase medians
    are medians of the per-repeat medians; plus a cProfile ranking."""
    runners = {"wbc": WbcRunner(spec, robot), "placo": PlacoRunner(spec, robot)}
    res = compare_libraries(runners, cfg.repeats, label="breakdown", breakdown=True)
    wbc = res["libraries"]["wbc"]
    phases = dict(wbc["phases_us"])
    out = {"tick_us": wbc["wall_us"], "phases_us": phases, "placo_tick_us": res["libraries"]["placo"]["wall_us"],
           "profile_top": profile_wbc_tick(robot, spec)}
    _log("breakdown: " + ", ".join(f"{k} {v['median']:.1f}" for k, v in phases.items()) + " µs")
    return out


def _kinematic_section(cfg: SuiteConfig, robot, spec: KinematicSpec) -> dict[str, object]:
    placo_runner = PlacoRunner(spec, robot)
    ref_short = PlacoRunner(replace(spec, ticks=cfg.pink_select_ticks), robot).run().metrics
    runners: dict[str, object] = {"wbc": WbcRunner(spec, robot), "placo": placo_runner}
    pink_sel = None
    if pink_available():
        pink_sel = _select_pink_solver(robot, spec, cfg.pink_select_ticks, ref_short,
                                       full_reference=placo_runner.run().metrics)
        if pink_sel["selected"]:
            runners["pink"] = PinkRunner(replace(spec, solver=pink_sel["selected"]), robot)
    out = compare_libraries(runners, cfg.repeats, label="kinematic")
    out["pink_selection"] = pink_sel if pink_sel is not None else {"error": "pin-pink not installed"}
    out["spec"] = asdict(spec)
    out["nv"] = robot.nv
    return out


def _solvers_section(cfg: SuiteConfig, robot, spec: KinematicSpec, reference: dict | None) -> dict[str, object]:
    """wbc with every installed backend, interleaved over ``cfg.repeats`` rounds, per-phase timers on."""
    from wbc.solvers import available_solvers

    rows: dict[str, dict] = {}
    runners: dict[str, object] = {}
    for solver in available_solvers():
        try:  # a backend that cannot run the scenario is reported, not fatal
            with _quiet_qp_warnings():
                WbcRunner(replace(spec, solver=solver, ticks=2, warmup=1), robot).run()
            runners[solver] = WbcRunner(replace(spec, solver=solver), robot)
        except Exception as exc:
            rows[solver] = {"error": f"{type(exc).__name__}: {exc}"}
    with _quiet_qp_warnings():
        res = compare_libraries(runners, cfg.repeats, reference="", label="wbc solvers", breakdown=True)
    for solver, v in res["libraries"].items():
        m = v["metrics"]
        held = bool(m["finite"] and m["position_limit_violation"] <= 0.0 and m["velocity_limit_violation"] <= 0.0)
        metrics = {"wbc": m} if reference is None else {"wbc": m, "placo": reference}
        check = same_work_check(metrics, "placo", failures={"wbc": v["failures"]})["wbc"]
        rows[solver] = {**v, "limits_held_exactly": held, "same_work": check}
    return {"solvers": dict(sorted(rows.items())), "spec": asdict(spec), "repeats": cfg.repeats}


def _scaling_section(cfg: SuiteConfig, spec: KinematicSpec, pink_solver: str | None) -> dict[str, object]:
    rows = {}
    for name in cfg.scaling_robots:
        robot = load_robot(name)
        s = replace(spec, robot=name)
        runners: dict[str, object] = {"wbc": WbcRunner(s, robot)}
        try:
            runners["placo"] = PlacoRunner(s, robot)
        except Exception as exc:
            _log(f"placo cannot load {name}: {exc}")
        if pink_solver and pink_available():
            runners["pink"] = PinkRunner(replace(s, solver=pink_solver), robot)
        res = compare_libraries(runners, cfg.repeats, label=f"scaling {name}")
        res.pop("_raw")
        rows[name] = {"nv": robot.nv, **res}
    return {"robots": rows, "spec": asdict(spec)}


def _dynamics_section(cfg: SuiteConfig, robot) -> dict[str, object]:
    from wbc.bench.dynamics import DynamicsSpec, PlacoDynamicsRunner, WbcDynamicsRunner, wbc_dynamics_available

    spec = DynamicsSpec(robot=robot.name, ticks=cfg.ticks, warmup=cfg.warmup)
    runners: dict[str, object] = {}
    ok, reason = wbc_dynamics_available()
    if ok:
        try:
            runners["wbc"] = WbcDynamicsRunner(spec, robot)
        except Exception as exc:
            ok, reason = False, f"wbc ID controller failed to build ({type(exc).__name__}: {exc})"
    runners["placo"] = PlacoDynamicsRunner(spec, robot)
    try:
        out = compare_libraries(runners, cfg.repeats, label="dynamics", breakdown=True)
    except Exception as exc:
        if "wbc" not in runners:
            raise
        ok, reason = False, f"wbc ID run failed ({type(exc).__name__}: {exc})"
        runners.pop("wbc")
        out = compare_libraries(runners, cfg.repeats, label="dynamics", breakdown=True)
    if "wbc" in out["libraries"] and "phases_us" in out["libraries"]["wbc"]:
        out["wbc_breakdown_us"] = {"tick": out["libraries"]["wbc"]["wall_us"], **out["libraries"]["wbc"]["phases_us"]}
    out["wbc_available"] = ok
    out["wbc_unavailable_reason"] = reason
    out["spec"] = asdict(spec)
    return out


def run_suite(cfg: SuiteConfig = SuiteConfig()) -> dict[str, object]:
    """Run the sections of ``cfg`` and return the results (module docstring)."""
    from wbc.formulations import velocity_kernel
    from wbc.solvers import active_set

    t_start = time.perf_counter()
    results: dict[str, object] = {"machine": machine_info(), "config": asdict(cfg)}
    active_set.load_active_set_kernels()  # numba kernels: compiled, or loaded from the on-disk cache
    velocity_kernel.load_kinematic_kernels()
    results["jit_first_call_s"] = time.perf_counter() - t_start
    _log(f"numba kernels first call (compile or on-disk cache load): {results['jit_first_call_s']:.2f} s")
    robot = load_robot(cfg.robot)
    spec = KinematicSpec(robot=cfg.robot, ticks=cfg.ticks, warmup=cfg.warmup)
    raw: dict[str, dict] = {}
    reference = None
    pink_solver = None
    if "kinematic" in cfg.sections:
        kin = _kinematic_section(cfg, robot, spec)
        raw["kinematic"] = kin.pop("_raw")
        results["kinematic"] = kin
        reference = kin["libraries"]["placo"]["metrics"]
        pink_solver = (kin.get("pink_selection") or {}).get("selected")
    if "breakdown" in cfg.sections:
        results["breakdown"] = _breakdown_section(cfg, robot, spec)
    if "solvers" in cfg.sections:
        results["solvers"] = _solvers_section(cfg, robot, spec, reference)
    if "scaling" in cfg.sections:
        results["scaling"] = _scaling_section(cfg, spec, pink_solver)
    if "dynamics" in cfg.sections:
        dyn = _dynamics_section(cfg, robot)
        raw["dynamics"] = dyn.pop("_raw")
        results["dynamics"] = dyn
    if "gait" in cfg.sections:
        from wbc.bench.gait import GaitSpec, run_gait_benchmark

        results["gait"] = run_gait_benchmark(robot, GaitSpec(repeats=cfg.gait_repeats,
                                                             placo_repeats=cfg.placo_gait_repeats))
        _log(f"gait: wbc plan {results['gait']['wbc']['plan_us']['median']:.1f} µs")
    if "walk" in cfg.sections:
        from wbc.bench.walk import WalkBenchSpec, run_walk_benchmark

        walk = run_walk_benchmark(robot, WalkBenchSpec(n_steps=cfg.walk_steps, repeats=cfg.repeats), log=_log)
        raw["walk"] = walk.pop("_raw")
        results["walk"] = walk
    if "frame_tasks" in cfg.sections:
        from wbc.bench.frame_tasks import FrameTaskSpec, run_frame_task_benchmark

        results["frame_tasks"] = run_frame_task_benchmark(
            robot, FrameTaskSpec(ticks=cfg.ticks, repeats=cfg.repeats, warmup=cfg.warmup), log=_log)
    if "instructions" in cfg.sections:
        from wbc.bench.instructions import callgrind_available, instructions_per_tick

        if callgrind_available():
            results["instructions"] = instructions_per_tick(cfg.callgrind_ticks, cfg.robot, log=_log)
            # wbc's kernels as the host compiles them (numba targets the CPU it runs on), at the most valgrind
            # emulates: x86-64 with AVX2 (haswell); placo's wheel is the generic code either way
            results["instructions_host"] = instructions_per_tick(cfg.callgrind_ticks, cfg.robot, log=_log,
                                                                 cpu=HOST_LIKE_CPU)
        else:
            results["instructions"] = {"error": "valgrind is not installed: instruction counts not measured"}
            _log(results["instructions"]["error"])
    results["runtime_s"] = time.perf_counter() - t_start
    results["machine"]["load_average_after"] = machine_info()["load_average_1_5_15"]
    results["_raw"] = raw
    return results
