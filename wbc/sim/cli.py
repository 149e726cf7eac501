"""``wbc sim SCENARIO``: closed-loop MuJoCo simulation of a catalog robot under the inverse-dynamics controller
(or the joint-PD baseline), registered into ``wbc``'s command line by :func:`register`.

Scenarios and their acceptance criteria are in :mod:`wbc.sim.scenarios`. Exit code 0 when the run met them,
1 when not, 2 on bad input.
"""

from __future__ import annotations

import json
from pathlib import Path

__all__ = ["register", "cmd_sim"]

_SCENARIOS = ("stand", "sway", "one-leg", "push", "wave", "jump")


def register(subparsers, add_outputs) -> None:
    """Add the ``sim`` sub-command (``add_outputs`` adds --json/--log/--out/--live)."""
    from wbc.qp import available_solvers

    p = subparsers.add_parser(
        "sim", help="closed-loop MuJoCo simulation (inverse-dynamics QP at 500 Hz): stand, sway, one-leg, push, wave",
        description="Closed-loop MuJoCo simulation of a robot built from its URDF; the controller reads the "
                    "ground-truth state from MuJoCo and applies joint torques at 500 Hz (one 2 ms mj_step per tick).")
    p.add_argument("scenario", choices=_SCENARIOS, help="scenario to run")
    p.add_argument("--robot", default="talos", help="catalog name (default talos)")
    p.add_argument("--duration", type=float, default=None,
                   help="s (stand/sway: default 10; push: total time, default 0.5 + push + 2.5; one-leg: fixed)")
    p.add_argument("--force", type=float, default=None,
                   help="push force, N (default: talos 450, g1 120, else half the capture-point bound)")
    p.add_argument("--push-duration", type=float, default=0.1, help="push duration, s (default 0.1)")
    p.add_argument("--sweep", action="store_true",
                   help="push: also find the largest force survived by the ID controller and by the joint-PD "
                        "baseline (bisection), and report the capture-point bound")
    p.add_argument("--controller", choices=("id", "pd"), default="id",
                   help="id: inverse-dynamics QP (default); pd: joint PD + weight-sharing gravity compensation")
    p.add_argument("--solver", default="daqp", choices=available_solvers(), help="QP backend (default daqp)")
    p.add_argument("--mu", type=float, default=0.7, help="friction coefficient of the controller (MuJoCo floor: 1.0)")
    p.add_argument("--f-min", type=float, default=0.0, help="minimum normal force per sole corner, N (default 0)")
    p.add_argument("--height", type=float, default=0.08,
                   help="jump: planned apex CoM rise above take-off, m (default 0.08; tuned on g1)")
    p.add_argument("--count", type=int, default=1, help="jump: number of consecutive jumps (default 1; experimental: G1 does not yet survive a series)")
    p.add_argument("--video", type=Path, metavar="FILE", help="write an MP4 rendered offscreen by MuJoCo")
    p.add_argument("--video-size", default="320x240", help="video frame size WxH (default 320x240)")
    add_outputs(p)
    p.set_defaults(func=cmd_sim)


def _scenario(args, robot):
    from wbc.exceptions import InvalidInputError
    from wbc.sim.scenarios import DEFAULT_PUSH_FORCE, OneLegScenario, PushScenario, StandScenario, SwayScenario
    from wbc.sim.scenarios import capture_point_bound

    if args.scenario == "stand":
        return StandScenario(10.0 if args.duration is None else args.duration)
    if args.scenario == "sway":
        return SwayScenario(10.0 if args.duration is None else args.duration)
    if args.scenario == "one-leg":
        return OneLegScenario()
    if args.scenario == "wave":
        from wbc.sim.physics_scenarios import WaveScenario

        return WaveScenario()
    if args.scenario == "jump":
        from wbc.sim.jump import JumpScenario

        return JumpScenario(height=args.height, count=args.count)
    force = args.force
    if force is None:
        force = DEFAULT_PUSH_FORCE.get(robot.name)
        if force is None:
            force = 0.5 * capture_point_bound(robot, args.push_duration)["f_max_impulse_n"]
    settle = 2.5
    if args.duration is not None:
        settle = args.duration - 0.5 - args.push_duration
        if settle <= 0:
            raise InvalidInputError(f"push --duration must exceed 0.5 + push duration = {0.5 + args.push_duration} s")
    return PushScenario(force, args.push_duration, settle=settle)


def cmd_sim(args) -> int:
    """Run ``wbc sim`` (see the module docstring). Returns the exit code."""
    from wbc.robot import load_robot
    from wbc.sim.mujoco_model import build_mujoco_model
    from wbc.sim.scenarios import capture_point_bound, make_controller, push_sweep, run_scenario

    robot = load_robot(args.robot)
    sim = build_mujoco_model(robot)
    scenario = _scenario(args, robot)

    from wbc.sim.physics_scenarios import id_options_for

    def make(kind=args.controller):
        # robots with near rank-deficient two-sole contact rows (humanoid15): DAQP primal_tol 1e-6, 1 cm margin
        if kind != "id":
            return make_controller(robot, kind, dt=sim.timestep, solver=args.solver)
        extra = {}
        if args.scenario == "jump":
            from wbc.sim.jump import JUMP_GAINS

            extra["gains"] = JUMP_GAINS
        return make_controller(robot, kind, dt=sim.timestep, mu=args.mu, f_min=args.f_min,
                               **id_options_for(robot, args.solver), **extra)

    viewer = pacer = None
    if args.live:
        from wbc.cli import _live

        viewer, pacer = _live(robot)
    controller = make()
    try:
        run, summary = run_scenario(sim, controller, scenario, after_fall=0.5, viewer=viewer, pacer=pacer)
    finally:
        if viewer is not None:
            viewer.close()
    if args.scenario == "wave":
        from wbc.sim.physics_scenarios import wave_acceptance

        summary["failed_criteria"] = wave_acceptance(summary)
        summary["passed"] = not summary["failed_criteria"]
    if args.scenario == "jump":
        from wbc.sim.jump import jump_acceptance

        summary["failed_criteria"] = jump_acceptance(summary)
        summary["passed"] = not summary["failed_criteria"]
    summary["solver"] = args.solver if args.controller == "id" else None
    summary["state_source"] = "MuJoCo ground truth (qpos/qvel), no estimation"
    print(f"wbc sim {scenario.name}: {robot.name}, controller {args.controller}, {len(run.t)} ticks at "
          f"{1 / sim.timestep:.0f} Hz (one mj_step of {sim.timestep * 1e3:.0f} ms per tick)")
    if args.scenario == "push" and args.sweep:
        cp = capture_point_bound(robot, args.push_duration)
        summary["capture_point"] = cp
        sweep = {}
        for kind in ("id", "pd"):
            print(f"  sweep ({kind}):")
            sweep[kind] = push_sweep(sim, lambda k=kind: make(k), push_duration=args.push_duration,
                                     f_hi=cp["f_max_finite_n"], log=print)
        summary["sweep"] = {k: {"max_survived_n": v["max_survived_n"], "min_failed_n": v["min_failed_n"]}
                            for k, v in sweep.items()}
        summary["sweep_trials"] = {k: v["trials"] for k, v in sweep.items()}
        best = sweep["id"]["max_survived_n"]
        if best < scenario.force:
            summary["failed_criteria"].append(f"sweep: ID max {best:.0f} N < {scenario.force:.0f} N")
        if best <= sweep["pd"]["max_survived_n"]:
            summary["failed_criteria"].append("sweep: ID does not beat the PD baseline")
        summary["passed"] = not summary["failed_criteria"]
    _print(summary)
    if args.json:
        args.json.write_text(json.dumps(summary, indent=2, default=_jsonable) + "\n")
        print(f"summary written to {args.json}")
    if args.log:
        run.save(args.log)
        print(f"log written to {args.log}")
    if args.out:
        from wbc.viz import record_html

        path = record_html(robot, run.t, run.q, args.out, overlays={"com": run.com})
        print(f"meshcat recording written to {path} ({path.stat().st_size / 1e6:.1f} MB)")
    if args.video:
        from wbc.sim.video import render_video

        w, h = (int(x) for x in args.video_size.lower().split("x"))
        path = render_video(sim, run.t, run.q, args.video, width=w, height=h)
        print(f"video written to {path} ({path.stat().st_size / 1e6:.2f} MB)")
    return 0 if summary["passed"] else 1


def _jsonable(x):
    import numpy as np

    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    raise TypeError(type(x).__name__)


def _print(summary: dict) -> None:
    from wbc.cli import _print_summary

    short = {k: v for k, v in summary.items() if k != "sweep_trials"}
    _print_summary(short)
