"""``wbc sim SCENARIO``: closed-loop MuJoCo simulation of a catalog robot under the inverse-dynamics controller
(or the joint-PD baseline), registered into ``wbc``'s command line by :func:`register`.

Scenarios and their acceptance criteria are in :mod:`wbc.sim.scenarios`. Exit code 0 when the run met them,
1 when not, 2 on bad input.
"""

from __future__ import annotations

from pathlib import Path

from wbc.cli.output import deadline_misses, open_live, print_summary, progress, write_outputs
from wbc.cli.ros2 import add_run_options, attach, finish

__all__ = ["register", "cmd_sim"]

_SCENARIOS = ("stand", "sway", "one-leg", "push", "walk", "wave", "jump", "push-step")


#: ``wbc sim jump`` options: (flag, type, default, help).
JUMP_OPTIONS = (
    ("--height", float, 0.08, "jump: planned apex CoM rise above take-off, m (default 0.08; tuned on g1)"),
    ("--count", int, 1, "jump: number of consecutive jumps (default 1)"),
    ("--forward", float, 0.0, "jump: planned forward foot displacement per jump, m (default 0: vertical)"),
    ("--momentum-weight", float, None,
     "jump: weight of the angular-momentum task during the jump (default 50; 1 for G1 series)"),
    ("--landing-ramp", float, 0.06, "jump: normal-force ramp-in after a touch-down, s (default 0.06)"),
    ("--min-hop", float, None, "jump: pass criterion, measured forward hop per jump >= this, m (default: none)"),
)


def register(subparsers, add_outputs) -> None:
    """Add the ``sim`` sub-command (``add_outputs`` adds --json/--log/--out/--live)."""
    from wbc.backends import available_solvers

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
                        "baseline (bisection), and report the capture-point bound; jump: also find the highest "
                        "planned height within the torque limits (see wbc.sim.jump_sweep)")
    p.add_argument("--controller", choices=("id", "pd"), default="id",
                   help="id: inverse-dynamics QP (default); pd: joint PD + weight-sharing gravity compensation")
    p.add_argument("--solver", default="fast", choices=available_solvers(),
                   help="QP backend (default fast: the compiled ID tick, DAQP as its fallback; daqp: the general path)")
    p.add_argument("--plant", choices=("ideal", "realistic"), default="realistic",
                   help="plant drives (wbc.sim.actuators): realistic (default: URDF joint damping and dry friction, "
                        "rotor armature, torque-speed envelope) or ideal (torque sources; plant = model). "
                        "--friction/--armature/--mass-error/... add on top")
    p.add_argument("--no-load-factor", type=float, default=None,
                   help="realistic plant: drive no-load speed / URDF velocity limit (default 1.2)")
    p.add_argument("--mu", type=float, default=0.7, help="friction coefficient of the controller (MuJoCo floor: 1.0)")
    p.add_argument("--f-min", type=float, default=0.0, help="minimum normal force per sole corner, N (default 0)")
    w = p.add_argument_group("walk (wbc sim walk: gait plan tracked by the ID controller, see wbc.sim.walk)")
    w.add_argument("--steps", type=int, default=8, help="walk: number of steps (default 8)")
    w.add_argument("--step-length", type=float, default=0.15, help="walk: step length, m (default 0.15)")
    w.add_argument("--step-duration", type=float, default=0.8,
                   help="walk: s per step, single + double support (20%%) (default 0.8)")
    w.add_argument("--turn", type=float, default=0.0, help="walk: yaw per step, deg (default 0)")
    w.add_argument("--vx", type=float, default=None,
                   help="walk: forward velocity command, m/s (sets --step-length = vx · step duration; with --vy/--wz alone: 0)")
    w.add_argument("--wz", type=float, default=None,
                   help="walk: turning velocity command, deg/s (sets --turn = wz · step duration)")
    w.add_argument("--vy", type=float, default=0.0,
                   help="walk: lateral velocity command, m/s, + left (side-steps of vy · step duration)")
    w.add_argument("--no-step-adjust", action="store_true",
                   help="walk: keep the planned footsteps (no step adjustment from the measured DCM)")
    w.add_argument("--push", type=float, default=0.0, help="walk: push force at the torso, N (default 0: none)")
    w.add_argument("--push-time", type=float, default=0.0, help="walk: push start, s (sim clock)")
    w.add_argument("--push-dir", type=float, default=90.0,
                   help="walk, push-step, push: push direction, deg (0 forward, 90 left; default 90)")
    w.add_argument("--no-stabilizer", action="store_true", help="walk: CoM PD tracking instead of the DCM stabilizer")
    w.add_argument("--sole-margin", type=float, default=None,
                   help="walk: controller sole shrink per side, m (default 0.1 × sole width, see "
                        "wbc.sim.physics_scenarios.walk_options_for)")
    w.add_argument("--seed", type=int, default=0, help="random seed (perturbations; default 0)")
    w.add_argument("--mass-error", type=float, default=0.0, help="walk: plant link-mass error bound, %% (uniform ±)")
    w.add_argument("--payload", type=float, default=0.0, help="walk: unmodelled torso payload on the plant, kg")
    w.add_argument("--friction", type=float, default=0.0,
                   help="walk: extra plant joint dry friction, N·m (unknown to the controller unless --friction-known)")
    w.add_argument("--friction-known", action="store_true",
                   help="walk, realistic plant: the controller's friction feed-forward includes the --friction extra "
                        "(an identified friction); default: it compensates the URDF friction only")
    w.add_argument("--armature", type=float, default=0.0, help="walk: plant rotor armature, kg·m²")
    w.add_argument("--delay", type=int, default=0, help="walk: control delay, ticks")
    w.add_argument("--impratio", type=float, default=None,
                   help="plant: MuJoCo friction-to-normal impedance ratio of the elliptic friction cones (default 10, "
                        "see wbc.sim.mujoco_model; 1, MuJoCo's default, lets a loaded foot creep below the friction "
                        "limit)")
    w.add_argument("--cone", choices=("elliptic", "pyramidal"), default="elliptic",
                   help="plant: MuJoCo friction cone (default elliptic; pyramidal is MuJoCo's default)")
    w.add_argument("--q-noise", type=float, default=0.0, help="walk: Gaussian noise std on measured joints, rad")
    w.add_argument("--v-noise", type=float, default=0.0, help="walk: Gaussian noise std on measured v")
    for flag, kind, default, text in JUMP_OPTIONS:
        p.add_argument(flag, type=kind, default=default, help=text)
    p.add_argument("--video", type=Path, metavar="FILE", help="write an MP4 rendered offscreen by MuJoCo")
    p.add_argument("--video-size", default="640x480", help="video frame size WxH (default 640x480)")
    add_outputs(p)
    add_run_options(p)
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
    if args.scenario == "walk":
        import math

        from wbc.sim.walk import WalkScenario

        if args.vx is not None or args.vy or args.wz is not None:  # velocity command: what is not given is 0
            args.step_length = (args.vx or 0.0) * args.step_duration
            if args.wz is not None:
                args.turn = args.wz * args.step_duration
        return WalkScenario(args.steps, args.step_length, args.step_duration, turn=math.radians(args.turn),
                            push=args.push, push_time=args.push_time, push_duration=args.push_duration,
                            push_dir=args.push_dir, stabilizer=not args.no_stabilizer,
                            step_adjust=not args.no_step_adjust, step_lateral=args.vy * args.step_duration)
    if args.scenario == "push-step":  # standing push recovered by a capture step (wbc.sim.capture_step)
        from wbc.sim.capture_step import CaptureStepScenario

        force = 450.0 if args.force is None else args.force
        return CaptureStepScenario(force, args.push_duration, push_dir=args.push_dir)
    if args.scenario == "wave":
        from wbc.sim.physics_scenarios import WaveScenario

        return WaveScenario()
    if args.scenario == "jump":
        from wbc.sim.jump import JumpScenario

        from wbc.sim.jump import JUMP_MOMENTUM_WEIGHT

        w = JUMP_MOMENTUM_WEIGHT if args.momentum_weight is None else args.momentum_weight
        return JumpScenario(height=args.height, forward=args.forward, count=args.count, min_hop=args.min_hop,
                            momentum_weight=w, t_ramp=args.landing_ramp)
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
    import math

    direction = (math.cos(math.radians(args.push_dir)), math.sin(math.radians(args.push_dir)), 0.0)
    return PushScenario(force, args.push_duration, settle=settle, direction=direction)


def cmd_sim(args) -> int:
    """Run ``wbc sim`` (see the module docstring). Returns the exit code."""
    from wbc.robot import load_robot
    from wbc.sim.mujoco_model import build_mujoco_model
    from wbc.sim.scenarios import capture_point_bound, make_controller, push_sweep, run_scenario

    from wbc.exceptions import InvalidInputError
    from wbc.sim.actuators import NO_LOAD_SPEED_FACTOR, SPEED_MARGIN, actuator_model, apply_actuators
    from wbc.sim.actuators import compensation_options

    robot = load_robot(args.robot)
    factor = NO_LOAD_SPEED_FACTOR if args.no_load_factor is None else args.no_load_factor
    if not factor > 0:
        raise InvalidInputError(f"--no-load-factor must be > 0, got {factor}")
    drives = actuator_model(robot, args.plant, no_load_factor=factor)
    sim = build_mujoco_model(robot, cone=args.cone, **({} if args.impratio is None else {"impratio": args.impratio}))
    apply_actuators(sim, drives)
    compensation = {}
    if args.plant == "realistic":
        # the controller knows the nominal drives: armature in its model (M includes it), friction/damping
        # feed-forward, joint speed limits with a 5 % margin (wbc.dynamics.balance.IDBalanceController)
        known = drives
        if args.friction_known and args.scenario == "walk" and args.friction > 0:
            known = actuator_model(robot, args.plant, extra_friction=args.friction, no_load_factor=factor)
        compensation = compensation_options(robot, known, SPEED_MARGIN)
    scenario = _scenario(args, robot)

    perturbed = args.scenario == "walk" and any(
        (args.mass_error, args.payload, args.friction, args.armature, args.delay, args.q_noise, args.v_noise))
    plant = None
    if perturbed:
        from wbc.sim.perturb import perturb_plant

        plant = perturb_plant(sim, mass_error=args.mass_error / 100.0, payload=args.payload, friction=args.friction,
                              armature=args.armature, seed=args.seed)
    from wbc.sim.physics_scenarios import id_options_for, walk_options_for

    def make(kind=args.controller):
        if kind != "id":
            return make_controller(robot, kind, dt=sim.timestep, solver=args.solver)
        # robots with near rank-deficient two-sole contact rows (humanoid15): DAQP primal_tol 1e-6, 2 cm margin;
        # walking: the controller's soles shrunk (walk_options_for)
        if args.scenario == "walk":
            options = walk_options_for(robot, args.solver, args.sole_margin)
        else:
            options = id_options_for(robot, args.solver)
        options.update(compensation)
        if perturbed:
            from wbc.sim.perturb import PerturbedController

            return PerturbedController(robot, dt=sim.timestep, mu=args.mu, f_min=args.f_min, q_noise=args.q_noise,
                                       v_noise=args.v_noise, delay=args.delay, seed=args.seed, **options)
        if args.scenario == "jump":
            from wbc.sim.jump import JUMP_OPTIONS

            options.update(JUMP_OPTIONS)
        return make_controller(robot, kind, dt=sim.timestep, mu=args.mu, f_min=args.f_min, **options)

    viewer = pacer = None
    if args.live:
        viewer, pacer = open_live(robot)
        if args.scenario == "walk":  # the plan is made when the run starts
            from wbc.viz.live_overlays import LiveOverlays

            viewer.set_overlays(LiveOverlays(robot, lambda: scenario.plan))
    viewer = progress(args, getattr(scenario, "duration", None), viewer, desc=f"wbc sim {scenario.name}")
    target, ros2_pub = attach(args, robot, viewer, sim.timestep)  # publisher only with --ros2/--bag
    controller = make()
    try:
        run, summary = run_scenario(sim, controller, scenario, after_fall=0.5, viewer=target, pacer=pacer)
    finally:
        if viewer is not None:
            viewer.close()
        finish(ros2_pub)
    summary["solver"] = args.solver if args.controller == "id" else None
    summary["state_source"] = "MuJoCo ground truth (qpos/qvel), no estimation"
    summary["plant_drives"] = {"plant": args.plant, **drives.summary()}
    summary["controller_compensation"] = (
        f"armature in M, URDF damping + dry friction{' + the --friction extra' if args.friction_known else ''} "
        "feed-forward, joint speed limits at "
        f"{1 - SPEED_MARGIN:.0%} of URDF (also in the relaxed QP)" if compensation and args.controller == "id"
        else "none")
    summary["mujoco_impratio"] = float(sim.model.opt.impratio)
    summary["mujoco_cone"] = args.cone
    if args.scenario == "walk" and args.controller == "id":
        walk_opts = walk_options_for(robot, args.solver, args.sole_margin)
        summary["controller_sole_margin_m"] = walk_opts["sole_margin"]
        summary["controller_momentum_weight"] = walk_opts["gains"]["momentum_weight"]
    summary["deadline_misses"] = deadline_misses(run.tick_time, run.dt)
    if plant is not None:
        summary["plant"] = {"plant_mass_kg": plant["plant_mass_kg"], "model_mass_kg": plant["model_mass_kg"],
                            "delay_ticks": args.delay, "q_noise": args.q_noise, "v_noise": args.v_noise,
                            "friction": args.friction, "armature": args.armature, "seed": args.seed}
    print(f"wbc sim {scenario.name}: {robot.name}, controller {args.controller}, {len(run.t)} ticks at "
          f"{1 / sim.timestep:.0f} Hz (one mj_step of {sim.timestep * 1e3:.0f} ms per tick)")
    if args.scenario == "jump" and args.sweep:
        _jump_sweep(args, robot, sim, make, summary)
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
    print_summary({k: v for k, v in summary.items() if k != "sweep_trials"})
    scene = {}
    if args.out:
        from wbc.viz.overlays import sim_overlays

        scene = sim_overlays(run, robot, getattr(scenario, "plan", None))
    write_outputs(args, summary, run, robot, overlays=scene.get("points"), scene=scene)
    if args.video:
        from wbc.sim.video import render_video

        w, h = (int(x) for x in args.video_size.lower().split("x"))
        path = render_video(sim, run.t, run.q, args.video, width=w, height=h)
        print(f"video written to {path} ({path.stat().st_size / 1e6:.2f} MB)")
    return 0 if summary["passed"] else 1


def _jump_sweep(args, robot, sim, make, summary) -> None:
    """``wbc sim jump --sweep``: highest planned height within the torque limits (:mod:`wbc.sim.jump_sweep`)."""
    from wbc.sim.jump_sweep import sweep_report

    summary["sweep"], summary["sweep_trials"] = sweep_report(robot, sim, make, log=print)
    if summary["sweep"]["max_planned_height_m"] is None:
        summary["failed_criteria"].append("sweep: no planned height succeeded")
    summary["passed"] = not summary["failed_criteria"]

