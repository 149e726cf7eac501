"""``wbc sim SCENARIO``: closed-loop MuJoCo simulation of a catalog robot under the inverse-dynamics controller
(or the joint-PD baseline), registered into ``wbc``'s command line by :func:`register`.

Scenarios and their acceptance criteria are in :mod:`wbc.sim.scenarios`. Exit code 0 when the run met them,
1 when not, 2 on bad input.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from wbc.cli.kernels import compile_for_command
from wbc.cli.output import add_deadline_misses, open_live, print_summary, progress, status, write_outputs
from wbc.cli.robots import add_plant_options, add_robot_options, robot_from_args
from wbc.cli.ros2 import add_run_options, attach, finish, real_time
from wbc.cli.validate import check_jump, check_ticks, count, finite, real, seconds, solver_name, video_size

__all__ = ["register", "cmd_sim"]

#: ``wbc sim jump --state estimated``: memory θ of the joint-velocity g-h-k filter (wbc.estimation.JointStateFilter):
#: take-off and landing need its lag-free velocity, the blind swing over rough ground the smoother low-pass of the
#: other scenarios (benchmarks/README.md, "The whole acceptance on b2acad8").
JUMP_VELOCITY_MEMORY = 0.5

#: What ``--mass-error`` accepts: the magnitude of a ± bound (a link keeps a positive mass below 100 %).
MASS_ERROR_VALID = ("0 <= value < 100: a ± bound in %, each link's mass scaled by 1 + e with e uniform in "
                    "[-value, +value] %; give its magnitude, e.g. --mass-error 10 for ±10 %")

def _trailing_release(text: str) -> float | str:
    """An argparse type: ``off``, or ρ in (0, 1] (a fraction of the joint speed limits)."""
    return "off" if text == "off" else finite(0.0, 1.0, lo_open=True, valid="0 < RHO <= 1, or off")(text)


_SCENARIO_CHOICES = ("stand", "sway", "one-leg", "push", "walk", "wave", "jump", "push-step")


#: ``wbc sim jump`` options: (flag, type, default, help).
JUMP_FLAGS = (
    ("--height", float, 0.08, "jump: planned apex CoM rise above take-off, m (default 0.08; tuned on g1; at most "
                              "0.9 m: push force <= 10 x weight)"),
    ("--count", int, 1, "jump: number of consecutive jumps (default 1)"),
    ("--forward", finite(0.0), 0.0, "jump: planned forward foot displacement per jump, m (default 0: vertical)"),
    ("--momentum-weight", finite(0.0), None,
     "jump: weight of the angular-momentum task during the jump (default 50)"),
    ("--landing-ramp", seconds, 0.06, "jump: normal-force ramp-in after a touch-down, s (default 0.06)"),
    ("--landing-crouch", finite(0.0, 0.1, unit=" m"), 0.04,
     "jump: CoM height below the take-off height at touch-down (feet raised relative to the CoM in flight), m "
     "(default 0.04; tuned on g1; 0..0.1, the crouch)"),
    ("--min-hop", finite(0.0), None, "jump: pass criterion, measured forward hop per jump >= this, m (default: none)"),
)


def check_sim_args(args) -> None:
    """``wbc sim`` checks before any run (called by :func:`wbc.cli.main`): the run's ticks fit in memory, the
    jump is within what legs can push, the velocity command gives a non-negative step.

    Raises:
        InvalidInputError: naming the option given.
    """
    from wbc.exceptions import InvalidInputError
    from wbc.sim.mujoco_model import MAX_TIMESTEP  # wbc sim's control period: one MuJoCo step per tick

    if isinstance(getattr(args, "terrain", None), str):
        from wbc.terrain import parse_terrain

        args.terrain = parse_terrain(args.terrain)
    if getattr(args, "blind", False) and (getattr(args, "terrain", None) is None or args.state != "estimated"):
        raise InvalidInputError("--blind needs --terrain (the plant's ground) and --state estimated (the F/T "
                                f"touch-down), got --terrain {getattr(getattr(args, 'terrain', None), 'name', None)} "
                                f"--state {args.state}")
    if getattr(args, "contact_events", False) is None:  # default: on for a standing push-step on estimated state
        args.contact_events = args.scenario == "push-step" and args.state == "estimated"
    if getattr(args, "contact_events", False) and (args.scenario not in ("walk", "push-step")
                                                    or args.state != "estimated"):
        raise InvalidInputError(f"--contact-events needs the ankle F/T of --state estimated and a stepping scenario "
                                f"(walk, push-step), got {args.scenario} --state {args.state}")
    if args.duration is not None:
        check_ticks(f"--duration {args.duration:g}", args.duration, MAX_TIMESTEP)
    if args.scenario == "walk" and args.step_duration is not None and args.steps is not None:
        # (else checked once the robot's gait is known, and the count chosen for the terrain)
        check_ticks(f"--steps {args.steps} --step-duration {args.step_duration:g}",
                    (args.steps + 2) * args.step_duration, MAX_TIMESTEP)
        if args.vx is not None and args.vx < 0:
            raise InvalidInputError(f"--vx {args.vx:g}: walking backwards is not planned (valid: vx >= 0 m/s)")
    if args.scenario != "walk":  # (a walk's are checked with the robot's range, _check_walk_reach)
        for option in ("vx", "vy", "wz"):
            value = getattr(args, option, None)
            if value is not None and not math.isfinite(value):
                raise InvalidInputError(f"--{option} {value:g} is not a finite number (valid: a finite number; "
                                        "it commands a walk: wbc sim walk)")
    if args.scenario == "jump":
        check_jump(args.height, 0.1, args.count, MAX_TIMESTEP)  # JumpScenario: crouch 0.1 m, extension 0
    else:  # a jump option given to another scenario would be read by nothing
        for flag, _, default, _ in JUMP_FLAGS:
            value = getattr(args, flag[2:].replace("-", "_"), default)
            if value != default:
                raise InvalidInputError(f"{flag} {value:g} applies to wbc sim jump only; the {args.scenario} "
                                        f"scenario has no {flag[2:]} (valid: wbc sim jump {flag} ..., or leave it out)")


def register(subparsers, add_outputs) -> None:
    """Add the ``sim`` sub-command (``add_outputs`` adds --json/--log/--out/--live)."""
    p = subparsers.add_parser(
        "sim", help="closed-loop MuJoCo simulation (inverse-dynamics QP at 500 Hz): " + ", ".join(_SCENARIO_CHOICES),
        description="Closed-loop MuJoCo simulation of a robot built from its URDF; the controller reads the "
                    "state estimated from the simulated sensors (or MuJoCo's ground truth, --state) and applies "
                    "joint torques at 500 Hz (one 2 ms mj_step per tick).")
    p.add_argument("scenario", choices=_SCENARIO_CHOICES, help="scenario to run")
    p.add_argument("--robot", default="talos", help="catalog name, robot file (.toml) or URDF path (default talos)")
    p.add_argument("--duration", type=seconds, default=None,
                   help="s (stand/sway: default 10; push: total time, default 0.5 + push + 2.5; one-leg: fixed)")
    p.add_argument("--force", type=finite(0.0), default=None,
                   help="push force, N (push: talos 450, g1 120, else half the capture-point bound along --push-dir; "
                        "push-step: talos 450, else the capture-point bound along --push-dir with the push's own moment "
                        "about the CoM counted)")
    p.add_argument("--push-duration", type=seconds, default=0.1, help="push duration, s (default 0.1)")
    p.add_argument("--sweep", action="store_true",
                   help="push: also find the largest force survived by the ID controller and by the joint-PD "
                        "baseline (bisection), and report the capture-point bound; jump: also find the highest "
                        "planned height within the torque limits (see wbc.sim.jump_sweep)")
    p.add_argument("--controller", choices=("id", "pd"), default="id",
                   help="id: inverse-dynamics QP (default); pd: joint PD + weight-sharing gravity compensation")
    p.add_argument("--solver", default="fast", type=solver_name, metavar="SOLVER",
                   help="QP backend: fast, daqp, proxqp or an installed qpsolvers backend (default fast: the compiled "
                        "ID tick, DAQP as its fallback; daqp: the general path)")
    add_plant_options(p)
    p.add_argument("--velocity-memory", type=finite(0.0, 0.99), default=None,
                   help="--state estimated: joint velocities from the encoders by the g-h-k fading-memory filter of "
                        "this memory θ in [0, 0.99] (no lag at constant joint acceleration; default for jump: 0.5) "
                        "instead of the backward difference low-passed at 80 Hz (default for every other scenario: "
                        "smoother, ~3 ms of lag); see wbc.estimation.JointStateFilter")
    p.add_argument("--no-load-factor", type=finite(0.0, 100.0, lo_open=True), default=None,
                   help="realistic plant: drive no-load speed / URDF velocity limit (default 1.2)")
    p.add_argument("--mu", type=finite(0.0, 10.0, lo_open=True), default=0.7, help="friction coefficient of the controller (MuJoCo floor: 1.0)")
    p.add_argument("--f-min", type=finite(0.0), default=0.0, help="minimum normal force per sole corner, N (default 0)")
    w = p.add_argument_group("walk (wbc sim walk: gait plan tracked by the ID controller, see wbc.sim.walk)")
    w.add_argument("--steps", type=count(2), default=None,
                   help="walk: number of steps (default 8; on a --terrain with an end, stairs or slope, the fewest "
                        "steps whose footholds put both heels past it; an explicit count is kept)")
    w.add_argument("--step-length", type=finite(0.0, unit=" m", valid="0 m <= value (walking backwards is not "
                                                                     "planned), at most the legs' reach"), default=None,
                   help="walk: step length, m (default: the robot's gait, talos 0.15)")
    w.add_argument("--step-width", type=finite(0.0, lo_open=True), default=None,
                   help="walk: lateral distance between the feet, m (default: the current feet distance; on stairs "
                        "the robot file's [stairs] step_width when it gives one)")
    w.add_argument("--step-duration", type=seconds, default=None,
                   help="walk: s per step, single + double support (20%%) (default: the robot's gait, talos 0.8)")
    w.add_argument("--turn", type=finite(-90.0, 90.0), default=0.0,
                   help="walk: yaw per step, deg (default 0; every angle option of wbc is in degrees)")
    w.add_argument("--vx", type=real, default=None,
                   help="walk: forward velocity command, m/s (sets --step-length = vx · step duration; with --vy/--wz alone: 0)")
    w.add_argument("--wz", type=real, default=None,
                   help="walk: turning velocity command, deg/s (sets --turn = wz · step duration)")
    w.add_argument("--vy", type=real, default=0.0,
                   help="walk: lateral velocity command, m/s, + left (side-steps of vy · step duration)")
    w.add_argument("--no-step-adjust", action="store_true",
                   help="walk: keep the planned footsteps (no step adjustment from the measured DCM)")
    w.add_argument("--terrain", default=None,
                   help="walk: ground, flat | stairs:RISE:TREAD:N[:up|down|updown] | slope:DEG[:LENGTH] | "
                        "rough:AMPLITUDE:SEED | FILE.json/.toml (see wbc.terrain); built into the MuJoCo plant and "
                        "planned on (no step adjustment off flat ground; default flat)")
    w.add_argument("--blind", action="store_true",
                   help="walk: the plant gets --terrain, the planner plans flat ground; touch-down from the ankle F/T "
                        "force (early contact), a late foot lowered up to 5 cm (needs --state estimated)")
    w.add_argument("--base-weight", type=finite(0.0), default=None,
                   help="walk on --terrain (planned or --blind): weight of the pelvis (floating-base) orientation task, "
                        "held level (default: the robot file's [stairs] base_weight on stairs, else 3; 0: none)")
    w.add_argument("--push", type=finite(), default=0.0, help="walk: push force at the torso, N (default 0: none)")
    w.add_argument("--push-time", type=finite(), default=0.0, help="walk: push start, s (sim clock)")
    w.add_argument("--push-dir", type=finite(), default=90.0,
                   help="walk, push-step, push: push direction, deg (0 forward, 90 left; default 90)")
    w.add_argument("--zmp-feedback", type=finite(0.0), default=None,
                   help="walk: gain of the stabilizer's feedback of the ZMP measured by the ankle F/T sensors "
                        "(DcmStabilizer k_z; needs --state estimated; default 0.5 with --state estimated, "
                        "0 with ground-truth)")
    w.add_argument("--no-stabilizer", action="store_true", help="walk: CoM PD tracking instead of the DCM stabilizer")
    w.add_argument("--sole-margin", type=finite(0.0), default=None,
                   help="walk: controller sole shrink per side, m (default 0.1 × sole width, see "
                        "wbc.sim.physics_scenarios.walk_options_for)")
    w.add_argument("--contact-events", action=argparse.BooleanOptionalAction, default=None,
                   help="walk, push-step: the QP's contacts follow the contact events measured from the ankle F/T and "
                        "the leg kinematics (a sole that lost contact gets no force until it is down again; "
                        "wbc.sim.walk_contacts; needs --state estimated; default: on for push-step with --state "
                        "estimated, off otherwise)")
    w.add_argument("--trailing-release", type=_trailing_release, default=None, metavar="RHO|off",
                   help="walk: in a double support after a touch-down, the sole of the next swing is released at once "
                        "when a joint of its leg moves at RHO or more of its speed limit (0 < RHO <= 1; off: never; "
                        "default: wbc.sim.walk_steps.TRAILING_RELEASE; WalkSteps._release_trailing)")
    w.add_argument("--seed", type=int, default=0, help="random seed (perturbations; default 0)")
    w.add_argument("--mass-error", type=finite(0.0, 100.0, valid=MASS_ERROR_VALID), default=0.0,
                   help="walk: plant link-mass error bound, %%: each link's mass scaled by 1 + e, e uniform in "
                        "±mass-error %% (a ± bound: give its magnitude, 0 <= mass-error < 100)")
    w.add_argument("--payload", type=finite(0.0), default=0.0, help="walk: unmodelled torso payload on the plant, kg")
    w.add_argument("--friction", type=finite(0.0), default=0.0,
                   help="walk: extra plant joint dry friction, N·m (unknown to the controller unless --friction-known)")
    w.add_argument("--friction-known", action="store_true",
                   help="walk, realistic plant: the controller's friction feed-forward includes the --friction extra "
                        "(an identified friction); default: it compensates the URDF friction only")
    w.add_argument("--armature", type=finite(0.0), default=0.0, help="walk: plant rotor armature, kg·m²")
    w.add_argument("--delay", type=count(0, 1000), default=0, help="walk: control delay, ticks")
    w.add_argument("--impratio", type=finite(0.0, lo_open=True), default=None,
                   help="plant: MuJoCo friction-to-normal impedance ratio of the elliptic friction cones (default 10, "
                        "see wbc.sim.mujoco_model; 1, MuJoCo's default, lets a loaded foot creep below the friction "
                        "limit)")
    w.add_argument("--friction-timeconst", type=finite(0.0), default=None,
                   help="plant: time constant (s) of the foot contacts' friction rows (default 2 timesteps, see "
                        "wbc.sim.mujoco_model; 0: the contact's own 0.02 s, MuJoCo's default, lets a stance sole "
                        "slide under a moving leg)")
    w.add_argument("--ground-timeconst", type=finite(0.0, lo_open=True), default=None,
                   help="plant: time constant (s) of the ground contacts' normal rows, a stiffer ground when "
                        "smaller (default: MuJoCo's 0.02; at least 2 timesteps, 0.004)")
    w.add_argument("--cone", choices=("elliptic", "pyramidal"), default="elliptic",
                   help="plant: MuJoCo friction cone (default elliptic; pyramidal is MuJoCo's default)")
    w.add_argument("--q-noise", type=finite(0.0), default=0.0, help="walk: Gaussian noise std on measured joint positions, deg")
    w.add_argument("--v-noise", type=finite(0.0), default=0.0, help="walk: Gaussian noise std on every measured velocity, SI units of v (base m/s, joints and base turn rate in radians per s)")
    for flag, kind, default, text in JUMP_FLAGS:
        p.add_argument(flag, type=kind, default=default, help=text)
    p.add_argument("--video", type=Path, metavar="FILE", help="write an MP4 rendered offscreen by MuJoCo")
    p.add_argument("--video-size", type=video_size, default=(640, 480), metavar="WxH",
                   help="video frame size in pixels, 16..4096 each (default 640x480)")
    add_outputs(p)
    add_robot_options(p)
    add_run_options(p)
    p.set_defaults(func=cmd_sim, check=check_sim_args)


def _gait_defaults(args, robot) -> None:
    """``--step-length`` / ``--step-duration`` not given: 0.15 m and 0.8 s for a catalog robot (the physics walk's
    tuned defaults), else the robot's gait (``[gait]`` of its robot file, or the scaled one): its step length and
    t_ss + t_ds."""
    from wbc.robot import catalog

    in_catalog = robot.name in catalog() and robot.spec is not None and robot.spec.source is not None \
        and robot.spec.source.parent.resolve() == Path(str(_catalog_dir())).resolve()
    gait = robot.gait
    if getattr(args, "step_length", None) is None:
        args.step_length = 0.15 if in_catalog else float(gait.get("step_length", 0.15))
    if getattr(args, "step_duration", None) is None:
        args.step_duration = 0.8 if in_catalog else float(gait.get("t_ss", 0.6) + gait.get("t_ds", 0.2))


def _catalog_dir():
    import importlib.resources

    return importlib.resources.files("wbc.robots")


def _scenario(args, robot):
    from wbc.exceptions import InvalidInputError
    from wbc.sim.scenarios import OneLegScenario, PushScenario, StandScenario, SwayScenario, default_push_force

    if args.scenario == "stand":
        return StandScenario(10.0 if args.duration is None else args.duration)
    if args.scenario == "sway":
        return SwayScenario(10.0 if args.duration is None else args.duration)
    if args.scenario == "one-leg":
        return OneLegScenario()
    if args.scenario == "walk":
        import math

        from wbc.sim.walk import WalkScenario

        if args.zmp_feedback is None:
            args.zmp_feedback = 0.5 if args.state == "estimated" else 0.0
        if args.zmp_feedback and args.state != "estimated":
            raise InvalidInputError("--zmp-feedback needs the F/T sensors of --state estimated, got --state "
                                    f"{args.state}")
        if args.vx is not None or args.vy or args.wz is not None:  # velocity command: what is not given is 0
            args.step_length = (args.vx or 0.0) * args.step_duration
            if args.wz is not None:
                args.turn = args.wz * args.step_duration
        return WalkScenario(args.steps, args.step_length, args.step_duration, turn=math.radians(args.turn),
                            push=args.push, push_time=args.push_time, push_duration=args.push_duration,
                            push_dir=args.push_dir, stabilizer=not args.no_stabilizer,
                            step_adjust=not args.no_step_adjust, step_lateral=args.vy * args.step_duration,
                            step_width=args.step_width, zmp_feedback=args.zmp_feedback,
                            terrain=None if args.blind else getattr(args, "terrain", None),
                            **({} if args.base_weight is None else {"base_weight": args.base_weight}),
                            blind=args.blind, contact_events=args.contact_events,
                            **({} if args.trailing_release is None else
                               {"trailing_release": None if args.trailing_release == "off" else args.trailing_release}),
                            await_load=robot.spec is not None and robot.spec.touchdown == "load")
    if args.scenario == "push-step":  # standing push recovered by a capture step (wbc.sim.capture_step)
        from wbc.sim.capture_step import CaptureStepScenario

        force = args.force
        if force is None:  # Talos: 450 N; any other robot: its capture-point bound (Talos's is 449 N for 0.1 s)
            force = default_push_force(robot, "push-step", args.push_duration, args.push_dir)
        return CaptureStepScenario(force, args.push_duration, push_dir=args.push_dir,
                                   contact_events=args.contact_events)
    if args.scenario == "wave":
        from wbc.sim.physics_scenarios import WaveScenario

        return WaveScenario()
    if args.scenario == "jump":
        from wbc.sim.jump import JumpScenario

        from wbc.sim.jump import JUMP_MOMENTUM_WEIGHT

        w = JUMP_MOMENTUM_WEIGHT if args.momentum_weight is None else args.momentum_weight
        return JumpScenario(height=args.height, forward=args.forward, count=args.count, min_hop=args.min_hop,
                            momentum_weight=w, t_ramp=args.landing_ramp, landing_crouch=args.landing_crouch)
    import math

    direction = (math.cos(math.radians(args.push_dir)), math.sin(math.radians(args.push_dir)), 0.0)
    force = args.force
    if force is None:
        force = default_push_force(robot, "push", args.push_duration, args.push_dir)
    settle = 2.5
    if args.duration is not None:
        settle = args.duration - 0.5 - args.push_duration
        if settle <= 0:
            raise InvalidInputError(f"push --duration must exceed 0.5 + push duration = {0.5 + args.push_duration} s")
    return PushScenario(force, args.push_duration, settle=settle, direction=direction)


def cmd_sim(args) -> int:
    """Run ``wbc sim`` (see the module docstring). Returns the exit code."""
    from wbc.sim.mujoco_model import build_mujoco_model
    from wbc.sim.scenarios import capture_point_bound, make_controller, push_sweep, run_scenario

    from wbc.sim.actuators import (NO_LOAD_SPEED_FACTOR, SPEED_MARGIN, UPPER_BODY_SPEED_MARGIN, actuator_model,
                                   apply_actuators)
    from wbc.sim.actuators import compensation_options

    status(args, f"wbc sim {args.scenario}: loading {args.robot} and building its MuJoCo model ...")
    robot = robot_from_args(args)
    terrain = getattr(args, "terrain", None)
    if terrain is not None:  # stairs: one foot per tread, and the robot file's [stairs] values
        from wbc.scenarios.terrain_walk import stair_defaults

        for key, value in stair_defaults(robot, terrain).items():
            if getattr(args, key, None) is None and not (key == "step_length" and getattr(args, "vx", None) is not None):
                setattr(args, key, value)
    _gait_defaults(args, robot)
    if args.scenario == "walk":
        check_sim_args(args)  # again, with the robot's own step duration
        _check_walk_reach(args, robot)
        if terrain is not None:
            from wbc.cli.walk import check_terrain_for_robot

            check_terrain_for_robot(terrain, robot)
        if args.steps is None:
            from wbc.cli.walk import choose_steps

            choose_steps(args, robot, terrain, blind=args.blind, prog="wbc sim")
            check_sim_args(args)  # (the count's run length)
    _check_push_force(args, robot)
    factor = NO_LOAD_SPEED_FACTOR if args.no_load_factor is None else args.no_load_factor
    drives = actuator_model(robot, args.plant, no_load_factor=factor)
    foot = robot.spec.mujoco.foot if robot.spec is not None else "box"
    sim = build_mujoco_model(robot, cone=args.cone, foot_contact=foot,
                             **({} if args.impratio is None else {"impratio": args.impratio}),
                             **({} if args.friction_timeconst is None
                                else {"friction_timeconst": args.friction_timeconst}),
                             **({} if args.ground_timeconst is None else {"ground_timeconst": args.ground_timeconst}),
                             **({} if getattr(args, "terrain", None) is None else {"terrain": args.terrain}))
    apply_actuators(sim, drives)
    compensation = {}
    if args.plant == "realistic":
        # the controller knows the nominal drives: armature in its model (M includes it), friction/damping
        # feed-forward, joint speed limits with a 5 % margin (wbc.dynamics.balance.IDBalanceController)
        known = drives
        if args.friction_known and args.scenario == "walk" and args.friction > 0:
            known = actuator_model(robot, args.plant, extra_friction=args.friction, no_load_factor=factor)
        compensation = compensation_options(robot, known, SPEED_MARGIN,
                                            delay=args.delay if args.scenario == "walk" else 0)
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

            return PerturbedController(robot, dt=sim.timestep, mu=args.mu, f_min=args.f_min,
                                       q_noise=math.radians(args.q_noise),
                                       v_noise=args.v_noise, delay=args.delay, seed=args.seed, **options)
        if args.scenario == "jump":
            from wbc.sim.jump import JUMP_OPTIONS

            options.update(JUMP_OPTIONS)
        return make_controller(robot, kind, dt=sim.timestep, mu=args.mu, f_min=args.f_min, **options)

    viewer = pacer = None
    if args.live:  # the plant's ground (with --blind too: the viewer shows the world, not the plan)
        viewer, pacer = open_live(robot, args.live_start_now, terrain=getattr(args, "terrain", None))
        if args.scenario == "walk":  # the plan is made when the run starts
            from wbc.viz.live_overlays import LiveOverlays

            viewer.set_overlays(LiveOverlays(robot, lambda: scenario.plan))
    compile_for_command("sim", quiet=getattr(args, "quiet", False))  # a first run: its kernels, in parallel, now
    viewer = progress(args, getattr(scenario, "duration", None), viewer, desc=f"wbc sim {scenario.name}")
    clock_guard = real_time(args)  # before attach (which may clear args.ros2)
    target, ros2_pub = attach(args, robot, viewer, sim.timestep)  # publisher only with --ros2/--bag
    controller = make()
    if clock_guard and args.controller == "id":
        controller.controller.clock_guard = True  # time is real: the ID controller's clock guard (else reproducible)
    state = None
    if args.state == "estimated":
        from wbc.sim.estimated_state import EstimatedState

        memory = args.velocity_memory
        if memory is None and args.scenario == "jump":
            memory = JUMP_VELOCITY_MEMORY
        # blind over unknown ground: no heading hand-over between soles (FloatingBaseEstimator heading_handover)
        blind = {"heading_handover": False} if getattr(args, "blind", False) else {}
        state = EstimatedState(sim, seed=args.seed, velocity_memory=memory, **blind)
    try:
        run, summary = run_scenario(sim, controller, scenario, after_fall=0.5, viewer=target, pacer=pacer,
                                    state=state)
    finally:
        if viewer is not None:
            viewer.close()
        finish(ros2_pub)
    summary["solver"] = args.solver if args.controller == "id" else None
    if args.scenario == "walk" and terrain is not None and getattr(scenario, "poses", None) is not None:
        _check_crossing(summary, terrain, scenario.poses, robot.sole_length)
    if args.scenario == "walk" and terrain is not None:  # the legs' margin to the step edges (plant's state)
        from wbc.sim.leg_clearance import leg_terrain_clearance

        summary.update(leg_terrain_clearance(sim, run.q))
    if state is None:
        summary["state_source"] = "MuJoCo ground truth (qpos/qvel), no estimation"
    else:
        from dataclasses import asdict

        from wbc.sim.estimated_state import estimation_errors

        summary["state_source"] = ("estimated: encoders + pelvis IMU + ankle F/T (wbc.sim.sensors), "
                                   "wbc.estimation.FloatingBaseEstimator")
        summary["sensors"] = {k: asdict(v) for k, v in vars(state.sensors.specs).items()}
        jf = state.estimator.joints
        summary["joint_velocity_filter"] = (f"g-h-k fading memory, theta {jf.memory:g}" if jf.memory is not None
                                            else f"backward difference + low-pass {jf.cutoff_hz:g} Hz")
        n = len(run.t) if run.fall_time is None else int(round(run.fall_time / run.dt)) + 1  # until the fall
        summary["estimation_error"] = estimation_errors(run.q[:n], run.v[:n], run.extra["q_est"][:n],
                                                        run.extra["v_est"][:n], summary.get("walked_distance_m"))
        summary["estimation_error"]["until_s"] = float(run.t[n - 1])
    summary["plant_drives"] = {"plant": args.plant, **drives.summary()}
    summary["controller_compensation"] = (
        f"armature in M, URDF damping + dry friction{' + the --friction extra' if args.friction_known else ''} "
        "feed-forward, joint speed limits at "
        f"{1 - SPEED_MARGIN:.0%} of URDF on the legs and {1 - UPPER_BODY_SPEED_MARGIN:.0%} elsewhere, reached over "
        f"{compensation.get('speed_horizon', 1):g} ticks "
        "(also in the relaxed QP), the joint bounds counting on braking each joint at no more than "
        f"{compensation.get('braking_share', 1):.0%} of its torque limit over its inertia"
        if compensation and args.controller == "id"
        else "none")
    summary["mujoco_impratio"] = float(sim.model.opt.impratio)
    summary["mujoco_cone"] = args.cone
    summary["mujoco_ground_timeconst_s"] = float(sim.model.geom_solref[sim.floor_geom, 0])
    summary["mujoco_foot_friction_timeconst_s"] = float(sim.model.pair_solreffriction[0, 0]) if sim.model.npair else 0.0
    if args.scenario == "walk" and args.controller == "id":
        walk_opts = walk_options_for(robot, args.solver, args.sole_margin)
        summary["controller_sole_margin_m"] = walk_opts["sole_margin"]
        summary["controller_momentum_weight"] = walk_opts["gains"]["momentum_weight"]
    add_deadline_misses(summary, run.tick_time, run.dt)
    if plant is not None:
        summary["plant"] = {"plant_mass_kg": plant["plant_mass_kg"], "model_mass_kg": plant["model_mass_kg"],
                            "delay_ticks": args.delay, "q_noise_deg": args.q_noise, "v_noise": args.v_noise,
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
    # standing metrics (CoM drift from the start) do not apply to a scenario that moves the robot on purpose
    moving = {"com_drift_m", "max_com_deviation_m"} if args.scenario in ("walk", "push-step", "jump") else set()
    print_summary({k: v for k, v in summary.items() if k != "sweep_trials"}, hide=moving)
    scene = {}
    if args.out:
        from wbc.viz.overlays import sim_overlays

        scene = sim_overlays(run, robot, getattr(scenario, "plan", None))
        if getattr(sim, "terrain", None) is not None:
            scene["terrain"] = sim.terrain
    write_outputs(args, summary, run, robot, overlays=scene.get("points"), scene=scene)
    if args.video:
        from wbc.sim.video import render_video

        from wbc.cli.output import atomic_output

        w, h = args.video_size
        with atomic_output(args.video) as tmp:
            render_video(sim, run.t, run.q, tmp, width=w, height=h)
        print(f"video written to {args.video} ({args.video.stat().st_size / 1e6:.2f} MB)")
    return 0 if summary["passed"] else 1


#: Largest push accepted, as a multiple of the robot's capture-point bound for a finite push of the same duration
#: and direction (:func:`wbc.sim.scenarios.capture_point_bound`, ``f_max_finite_n``): beyond the bound a standing
#: robot cannot stay on its soles whatever its controller does, and a capture step gains a few times it; a trial
#: ten times beyond it only measures how far the robot is thrown.
TRIAL_LIMIT_IN_CAPTURE_BOUNDS = 10


def _check_push_force(args, robot) -> None:
    """Refuse a push (``--force`` of push and push-step, ``--push`` of walk) beyond :data:`TRIAL_LIMIT_IN_CAPTURE_BOUNDS`
    times the robot's capture-point bound, before the model is built; the message gives the bound.

    Raises:
        InvalidInputError: naming the option, the force and the largest accepted force.
    """
    from wbc.exceptions import InvalidInputError

    option, force = {"push": ("--force", args.force), "push-step": ("--force", args.force),
                     "walk": ("--push", abs(args.push))}.get(args.scenario, (None, None))
    if not force:
        return
    limit, bound = push_force_limit(robot, args.push_duration, [args.push_dir])
    if force > limit:
        raise InvalidInputError(
            f"{option} {force:g} N for {args.push_duration:g} s is beyond what a trial can mean (valid: <= "
            f"{math.floor(limit):.0f} N, {TRIAL_LIMIT_IN_CAPTURE_BOUNDS:g} × {robot.name}'s capture-point bound of "
            f"{bound:.0f} N for this duration and direction, beyond which it falls whatever the "
            "controller does)")


def push_force_limit(robot, push_duration: float, directions_deg) -> tuple[float, float]:
    """The largest push force a trial can mean: :data:`TRIAL_LIMIT_IN_CAPTURE_BOUNDS` times the robot's
    capture-point bound (:func:`wbc.sim.scenarios.capture_point_bound`, finite push of ``push_duration`` s at the
    robot's reference posture), the largest over ``directions_deg`` (deg, 0 = +x forward, 90 = +y left).

    Returns:
        (limit N, the capture-point bound N it is a multiple of).
    """
    from wbc.sim.scenarios import capture_point_bound

    bound = max(capture_point_bound(robot, push_duration, (math.cos(math.radians(a)), math.sin(math.radians(a)),
                                                           0.0))["f_max_finite_n"] for a in directions_deg)
    return TRIAL_LIMIT_IN_CAPTURE_BOUNDS * bound, bound


def _check_crossing(summary: dict, terrain, poses: dict, sole_length: float) -> None:
    """A walk on a terrain with an end: whether the commanded footsteps (the last planned or adjusted sole poses)
    end past it (:func:`wbc.cli.walk.terrain_crossing`); a failed criterion when not, ``passed`` updated."""
    from wbc.cli.walk import crossing_criterion, terrain_crossing
    from wbc.scenarios.framework import evaluate

    summary.update(terrain_crossing(terrain, float(poses["left"][-1][0, 3]), float(poses["right"][-1][0, 3]),
                                    sole_length))
    if "terrain_shortfall_m" in summary:
        ok, failed = evaluate(summary, [crossing_criterion()])
        summary["failed_criteria"] = list(summary["failed_criteria"]) + failed
        summary["passed"] = bool(summary["passed"]) and ok


def _check_walk_reach(args, robot) -> None:
    """``wbc sim walk``: the per-step command (from ``--step-length``/``--turn`` or ``--vx/--vy/--wz``) within the
    legs' reach, before the model is built; messages name the option given.

    Raises:
        InvalidInputError: see :func:`wbc.cli.walk.check_step_command`; a step length beyond the reach.
    """
    from wbc.cli.walk import check_command_values, check_step_command, leg_reach
    from wbc.exceptions import InvalidInputError

    period = args.step_duration
    reach = leg_reach(robot)
    check_command_values(args, robot.name, reach, period)
    turn, length = args.turn, args.step_length
    if args.vx is not None or args.vy or args.wz is not None:  # what _scenario will command
        length = (args.vx or 0.0) * period
        if args.wz is not None:
            turn = args.wz * period
    saved = args.turn
    args.turn = turn
    try:
        check_step_command(args, reach, period)
    finally:
        args.turn = saved
    if length > reach:
        source = f"--vx {args.vx:g} m/s gives a {length:.3g} m step" if args.vx is not None else \
            f"--step-length {length:g} m"
        raise InvalidInputError(f"{source}: beyond the reach of {robot.name}'s legs (valid: step length <= "
                                f"{reach:.3f} m, vx <= {reach / period:.3f} m/s at --step-duration {period:g} s)")


def _jump_sweep(args, robot, sim, make, summary) -> None:
    """``wbc sim jump --sweep``: highest planned height within the torque limits (:mod:`wbc.sim.jump_sweep`)."""
    from wbc.sim.jump_sweep import sweep_report

    summary["sweep"], summary["sweep_trials"] = sweep_report(robot, sim, make, log=print)
    if summary["sweep"]["max_planned_height_m"] is None:
        summary["failed_criteria"].append("sweep: no planned height succeeded")
    summary["passed"] = not summary["failed_criteria"]

