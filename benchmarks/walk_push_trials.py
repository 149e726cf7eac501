"""Seeded pushes during a physics walk (issue 11 acceptance): ``--trials`` walks of Talos in MuJoCo, each pushed once
at the torso with ``--force`` N for ``--push-duration`` s at a random time during the walking steps and in a random
horizontal direction (both drawn from ``numpy.random.default_rng(seed)``). A trial survives when the robot did not
fall (base drop, pelvis/torso tilt > 30°, non-foot contact: wbc.sim.outcome), no joint passed its URDF speed
limit, and it finished the walk (:class:`wbc.sim.walk.WalkScenario` summary). Prints one line per trial and the count.

``--state estimated`` runs each trial as ``wbc sim walk`` with its defaults (a subprocess: encoders, pelvis IMU and
ankle F/T sensors with noise seeded by the trial's seed, the floating-base estimator, the realistic plant and the
controller options of ``wbc sim walk``) and reads its JSON summary; the default ``--state ground-truth`` runs the
trial in this process on MuJoCo's exact state with ``make_controller``'s options (``--cli-options``: those of
``wbc sim walk``).

Also ``--standing``: pushes from the front (180 deg: towards −x) and from behind (0 deg) on the standing robot,
recovered by a capture step (:class:`wbc.sim.capture_step.CaptureStepScenario`, same as ``wbc sim push-step``).

Usage: python benchmarks/walk_push_trials.py [--robot talos] [--trials 20] [--force 300] [--steps 8]
       [--step-length 0.25] [--step-duration 0.6] [--seed0 0] [--no-step-adjust]
       [--adjust-timing on|off] [--seeds S ...] [--jobs N] [--cli-options] [--state ground-truth|estimated]
       [--contact-events]
"""

from __future__ import annotations

import argparse
import math

import numpy as np

import wbc
from wbc.sim.mujoco_model import build_mujoco_model
from wbc.sim.scenarios import make_controller, run_scenario
from wbc.sim.walk import WalkScenario


def _plant(robot, plant):
    """(MuJoCo model, controller options) for ``plant`` ("realistic": the drives of wbc.sim.actuators and the
    controller's compensation, as ``wbc sim``; "ideal": plant = model)."""
    from wbc.sim.actuators import actuator_model, compensation_options

    sim = build_mujoco_model(robot, plant=plant)
    return sim, (compensation_options(robot, actuator_model(robot)) if plant == "realistic" else {})


def trial(robot, *, force, duration, push_time, push_dir, steps, step_length, step_duration, step_adjust,
          adjust_timing, cli_options=False, plant="realistic", state="ground-truth", seed=0, contact_events=False):
    if state == "estimated":
        return _cli_trial(robot, force=force, duration=duration, push_time=push_time, push_dir=push_dir, steps=steps,
                          step_length=step_length, step_duration=step_duration, step_adjust=step_adjust,
                          adjust_timing=adjust_timing, plant=plant, seed=seed, contact_events=contact_events)
    if contact_events:
        raise SystemExit("--contact-events needs --state estimated (the ankle F/T sensors)")
    sim, comp = _plant(robot, plant)
    options = {}
    if cli_options:  # the controller `wbc sim walk` builds (soles shrunk, angular-momentum weight 1)
        from wbc.sim.physics_scenarios import walk_options_for

        options = walk_options_for(robot)
    controller = make_controller(robot, "id", dt=sim.timestep, **options, **comp)
    sc = WalkScenario(steps, step_length, step_duration, push=force, push_time=push_time, push_duration=duration,
                      push_dir=push_dir, step_adjust=step_adjust, adjust_timing=adjust_timing)
    _, s = run_scenario(sim, controller, sc)
    return s


def _cli_trial(robot, *, force, duration, push_time, push_dir, steps, step_length, step_duration, step_adjust,
               adjust_timing, plant, seed, contact_events=False):
    """The trial as ``wbc sim walk`` runs it (estimated state; module docstring): its JSON summary."""
    import json
    import subprocess
    import sys
    import tempfile

    if not step_adjust or not adjust_timing:
        raise SystemExit("--state estimated runs wbc sim walk as is: --no-step-adjust / --adjust-timing off do not apply")
    with tempfile.TemporaryDirectory() as tmp:
        out = f"{tmp}/summary.json"
        cmd = [sys.executable, "-m", "wbc", "sim", "walk", "--robot", robot.name, "--steps", str(steps),
               "--step-length", repr(step_length), "--step-duration", repr(step_duration), "--push", repr(force),
               "--push-time", repr(push_time), "--push-dir", repr(push_dir), "--push-duration", repr(duration),
               "--plant", plant, "--state", "estimated", "--seed", str(seed), "--quiet", "--json", out]
        cmd += ["--contact-events"] if contact_events else []
        done = subprocess.run(cmd, capture_output=True, text=True)
        if done.returncode not in (0, 1):
            raise RuntimeError(f"{' '.join(cmd)} exited {done.returncode}: {done.stderr[-2000:]}")
        with open(out) as f:
            return json.load(f)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", default="talos")
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--force", type=float, default=300.0)
    ap.add_argument("--push-duration", type=float, default=0.1)
    ap.add_argument("--steps", type=int, default=8)
    ap.add_argument("--step-length", type=float, default=0.25)
    ap.add_argument("--step-duration", type=float, default=0.6)
    ap.add_argument("--seed0", type=int, default=0)
    ap.add_argument("--seeds", type=int, nargs="+", help="these seeds instead of --seed0 .. --seed0 + --trials - 1")
    ap.add_argument("--jobs", type=int, default=1, help="trials run in parallel processes (default 1)")
    ap.add_argument("--no-step-adjust", action="store_true")
    ap.add_argument("--adjust-timing", choices=("on", "off"), default="on",
                    help="step timing adaptation (WalkScenario adjust_timing)")
    ap.add_argument("--cli-options", action="store_true",
                    help="the controller options of `wbc sim walk` (wbc.sim.physics_scenarios.walk_options_for: "
                         "sole rectangle shrunk, angular-momentum weight 1); default: make_controller's defaults")
    ap.add_argument("--plant", choices=("ideal", "realistic"), default="realistic",
                    help="plant drives as `wbc sim --plant` (default realistic, with the controller's compensation)")
    ap.add_argument("--standing", action="store_true", help="front and back pushes while standing (see docstring)")
    ap.add_argument("--state", choices=("ground-truth", "estimated"), default="ground-truth",
                    help="estimated: each trial is `wbc sim walk` with its defaults, sensor noise seeded by the trial's "
                         "seed (module docstring)")
    ap.add_argument("--contact-events", action="store_true",
                    help="with --state estimated: `wbc sim walk --contact-events` (the QP's contacts follow the "
                         "measured contact events, wbc.sim.walk_contacts)")
    args = ap.parse_args()
    robot = wbc.load_robot(args.robot)
    common = dict(force=args.force, duration=args.push_duration, step_duration=args.step_duration,
                  step_adjust=not args.no_step_adjust, adjust_timing=args.adjust_timing == "on",
                  cli_options=args.cli_options, plant=args.plant, state=args.state,
                  contact_events=args.contact_events)
    if args.standing:
        from wbc.sim.capture_step import CaptureStepScenario

        for name, d in (("front (push towards -x)", 180.0), ("behind (push towards +x)", 0.0)):
            sim, comp = _plant(robot, args.plant)
            controller = make_controller(robot, "id", dt=sim.timestep, **comp)
            _, s = run_scenario(sim, controller, CaptureStepScenario(args.force, args.push_duration, push_dir=d))
            print(f"standing, from the {name}: {args.force:.0f} N x {args.push_duration} s: fell {s['fell']}, "
                  f"completed {s['completed']}, stepped {s['stepped']}, first step shift "
                  f"{s.get('first_step_shift_m')}")
        return
    seeds = args.seeds if args.seeds else [args.seed0 + i for i in range(args.trials)]
    jobs = [(args.robot, seed, args.steps, args.step_length, common) for seed in seeds]
    survived, fell = 0, []
    if args.jobs > 1:
        import multiprocessing

        with multiprocessing.get_context("spawn").Pool(args.jobs) as pool:
            lines = pool.imap(_seeded_trial, jobs)
            for seed, ok, line in lines:
                survived += ok
                fell += [] if ok else [seed]
                print(line, flush=True)
    else:
        for job in jobs:
            seed, ok, line = _seeded_trial(job, robot)
            survived += ok
            fell += [] if ok else [seed]
            print(line, flush=True)
    print(f"survived {survived} of {len(seeds)} ({args.force:.0f} N x {args.push_duration} s, {args.robot}, "
          f"{args.steps} steps x {args.step_length} m at {args.step_duration} s/step, "
          f"{math.fsum([args.step_length]) / args.step_duration:.3f} m/s, controller options "
          f"{'of wbc sim walk' if args.cli_options or args.state == 'estimated' else 'default'}, "
          f"{args.state} state, {args.plant} plant{', contact events' if args.contact_events else ''}); "
          f"fell: seeds {fell}")


def _seeded_trial(job, robot=None):
    """One trial from its seed: push time uniform over the walking steps, direction uniform in [0, 360) deg."""
    name, seed, steps, step_length, common = job
    robot = robot if robot is not None else wbc.load_robot(name)
    t_init = 0.8  # WalkScenario's initial double support
    t_walk = (steps - 1) * common["step_duration"]
    rng = np.random.default_rng(seed)
    t = float(t_init + rng.uniform(0.0, t_walk - common["duration"]))
    d = float(rng.uniform(0.0, 360.0))
    s = trial(robot, push_time=t, push_dir=d, steps=steps, step_length=step_length, seed=seed, **common)
    ok = bool((not s["fell"]) and s["completed"] and s["joint_speed_exceedances"] == 0)
    line = (f"seed {seed:2d}: push {common['force']:.0f} N at t = {t:.3f} s, dir {d:6.1f} deg: "
            f"{'survived' if ok else 'FELL'}; walked {s['walked_distance_m']:.3f} m, "
            f"step adjustments {s['step_adjustments']} (max {s['max_step_adjustment_m']:.3f} m), "
            f"timing changes {[round(x, 3) for x in s['step_timing_changes_s']]} s, "
            f"solver failures {s['solver_failures']}, joint-speed exceedances {s['joint_speed_exceedances']}"
            f"{_worst(s)}"
            f"{' (' + s['fall_reason'] + ')' if s['fell'] else ''}")
    return seed, ok, line


def _worst(s: dict) -> str:
    """`` (worst R× joint)``: the largest joint speed over its URDF limit in the trial, when the summary has it."""
    r = s.get("max_joint_speed_ratio")
    return "" if r is None else f" (worst {r:.3f}x {s.get('max_joint_speed_joint', '?')})"


if __name__ == "__main__":
    main()
