"""The built-in trial: one physics walk (``wbc sim walk``'s scenario and controller) with the trial's push, plant
errors and gains, summarised into one flat row.

A trial function takes ``(spec, params)`` — the :class:`~wbc.campaign.spec.CampaignSpec` and the dict of
:func:`~wbc.campaign.spec.trial_params` — and returns a flat dict of scalars (``bool``, ``int``, ``float``,
``str``). :func:`walk_trial` is the one used for kinds ``push``, ``robustness`` and ``sweep``; a researcher's own
controller is campaigned by passing another function with the same signature to :func:`wbc.campaign.run`.

The robot model is loaded once per process (worker) and kept (:func:`cached_robot`); the numba kernels are compiled
or loaded from their cache once per process by the first controller built. The MuJoCo plant is built anew for each
trial (plant errors edit it in place).
"""

from __future__ import annotations

import math
import threading

import numpy as np

from wbc.exceptions import InvalidInputError

__all__ = ["walk_trial", "cached_robot", "outcome_of"]

_ROBOTS: dict = {}

#: Summary keys measured on the wall clock: they describe the machine, not the trial, and are left out of a row (a
#: trial's row is the same wherever it ran; its own run time is ``wall_s``).
WALL_CLOCK_KEYS = frozenset({"real_time_factor", "deadline_misses", "tick_time_p50_us", "tick_time_p99_us",
                             "tick_time_max_us", "wall_time_s"})

#: Walk scenario's initial double support (s) before the first step (``WalkScenario`` ``t_init`` default).
_T_INIT = 0.8


#: Set by the campaign's signal watch (:func:`wbc.campaign.run`) once a SIGINT or SIGTERM arrived, cleared when a
#: campaign starts: a trial running in this process stops at its next tick instead of at its end.
STOP_REQUESTED = threading.Event()


class _StopWatch:
    """The viewer of a trial's closed loop: draws nothing, reads no configuration, and raises KeyboardInterrupt at
    the first tick after :data:`STOP_REQUESTED` is set (a signal deferred while numba loaded a kernel would
    otherwise wait for the trial's end)."""

    reads_configuration = False

    def update(self, q, t=None, *args, **kwargs) -> None:
        if STOP_REQUESTED.is_set():
            raise KeyboardInterrupt

    def close(self) -> None:
        pass


def cached_robot(name: str):
    """The robot ``name`` (catalog name or robot file), loaded once per process."""
    robot = _ROBOTS.get(name)
    if robot is None:
        from wbc.robot import load_robot

        robot = _ROBOTS[name] = load_robot(name)
    return robot


def outcome_of(summary: dict) -> tuple[bool, str]:
    """(survived, what ended it) of a walk summary, as a robot's operator would sign it: survived = no fall
    (:mod:`wbc.sim.outcome`: the upper body's or pelvis' tilt, the base's drop over the terrain under the feet, a
    non-foot link on the ground, a foot strike), the walk completed and no plant joint past its speed limit
    (``joint_speed_exceedances`` = 0; the plant's drives cannot exceed their torque envelope,
    :mod:`wbc.sim.actuators`). The reason: the fall criterion that fired (``fall_reason``), ``"not completed"``,
    ``"joint speed past its limit: <joint> at <ratio>×"`` or ``""``."""
    if summary.get("fell"):
        return False, str(summary.get("fall_reason") or "fell")
    if not summary.get("completed", False):
        return False, "not completed"
    if summary.get("joint_speed_exceedances", 0):
        return False, (f"joint speed past its limit: {summary.get('max_joint_speed_joint', '?')} at "
                       f"{float(summary.get('max_joint_speed_ratio', math.nan)):.3g}×")
    return True, ""


def walk_trial(spec, params: dict) -> dict:
    """Run one physics walk for trial ``params`` of ``spec`` (module docstring): the plant's drives
    (``scenario.plant``, realistic by default as in ``wbc sim walk``: :mod:`wbc.sim.actuators`, compensated by the
    controller) and the state the controller reads (``scenario.state``) are those of ``wbc sim walk``.

    The walk swings ``first_side`` first (``left`` when absent). The push (when ``force`` > 0) starts at ``t_init + phase · (t_walk − push_duration)`` s, ``t_walk`` the walking
    steps' time ``(steps − 1) · step_duration``, in direction ``direction_deg`` (world, 0 = +x); plant errors
    (``mass_error`` %, ``payload`` kg, ``friction`` N·m, ``armature`` kg·m², ``ground_timeconst`` s: the ground's
    stiffness, :func:`wbc.sim.mujoco_model.build_mujoco_model`; MuJoCo's 0.02 s when absent) are applied to the
    MuJoCo model and
    sensor errors (``q_noise_deg`` deg, ``v_noise`` rad/s, ``delay`` ticks) to the controller
    (:mod:`wbc.sim.perturb`), seeded by the trial index. The controller reads ``scenario.state`` (``estimated``, as
    ``wbc sim walk`` by default: :class:`wbc.sim.estimated_state.EstimatedState`, its sensor noise seeded by the trial
    index; or ``ground-truth``).

    Returns:
        ``{"survived", "outcome", "fell", "completed", "passed", "failed_criteria", "push_time_s", ...}`` plus the
        summary's scalar metrics (``spec.keep``, or all of them).

    Raises:
        InvalidInputError: a parameter of the wrong range (from the scenario or controller constructors).
    """
    from wbc.sim.actuators import SPEED_MARGIN, actuator_model, apply_actuators, compensation_options
    from wbc.sim.mujoco_model import build_mujoco_model
    from wbc.sim.physics_scenarios import walk_options_for
    from wbc.sim.scenarios import make_controller, run_scenario
    from wbc.sim.walk import WalkScenario

    sc = spec.scenario
    robot = cached_robot(sc["robot"])
    sim = build_mujoco_model(robot, ground_timeconst=params.get("ground_timeconst"))
    drives = actuator_model(robot, sc["plant"])  # the plant's drives, as wbc sim walk (--plant)
    apply_actuators(sim, drives)
    force = float(params.get("force", 0.0))
    duration = float(params.get("push_duration", 0.1))
    t_walk = max(0.0, (sc["steps"] - 1) * sc["step_duration"] - duration)
    push_time = _T_INIT + float(params.get("phase", 0.0)) * t_walk
    gains = {k: params[k] for k in ("k_xi", "k_i") if k in params}
    walk_kw = {k: params[k] for k in ("cop_margin", "cmp_offset", "adjust_dead_band", "impact_window") if k in params}
    estimated = sc["state"] == "estimated"
    zmp = sc["zmp_feedback"] if sc["zmp_feedback"] is not None else (0.5 if estimated else 0.0)  # wbc sim walk's
    walk_kw["zmp_feedback"] = params.get("k_z", zmp)  # the stabilizer's measured-ZMP feedback gain
    if walk_kw["zmp_feedback"] and not estimated:
        raise InvalidInputError("the measured-ZMP feedback (zmp_feedback, k_z) needs scenario.state = estimated")
    scenario = WalkScenario(sc["steps"], sc["step_length"], sc["step_duration"], push=force, push_time=push_time,
                            push_duration=duration, push_dir=float(params.get("direction_deg", 90.0)),
                            step_adjust=sc["step_adjust"], stabilizer_gains=gains,
                            first_side=params.get("first_side", "left"), contact_events=sc["contact_events"],
                            **walk_kw)
    options = walk_options_for(robot, sc["solver"], sc["sole_margin"])
    seed = int(params["trial"])
    plant_errors = {k: float(params.get(k, 0.0)) for k in ("mass_error", "payload", "friction", "armature")}
    sensor_errors = {"q_noise": math.radians(float(params.get("q_noise_deg", 0.0))),
                     "v_noise": float(params.get("v_noise", 0.0)),
                     "delay": params.get("delay", 0)}
    delay = sensor_errors["delay"]
    if isinstance(delay, float):
        if not delay.is_integer():
            raise InvalidInputError(f"delay must be a whole number of ticks, got {delay!r}")
        sensor_errors["delay"] = int(delay)
    if sc["plant"] == "realistic":  # the controller knows the nominal drives (wbc sim walk's compensation)
        options.update(compensation_options(robot, drives, SPEED_MARGIN, delay=int(sensor_errors["delay"])))
    if any(plant_errors.values()):
        from wbc.sim.perturb import perturb_plant

        perturb_plant(sim, mass_error=plant_errors["mass_error"] / 100.0, payload=plant_errors["payload"],
                      friction=plant_errors["friction"], armature=plant_errors["armature"], seed=seed)
    if any(sensor_errors.values()):
        from wbc.sim.perturb import PerturbedController

        controller = PerturbedController(robot, dt=sim.timestep, seed=seed, **sensor_errors, **options)
    else:
        controller = make_controller(robot, "id", dt=sim.timestep, **options)
    state = None
    if estimated:  # what the controller reads, as in wbc sim walk: sensors fused by the floating-base estimator
        from wbc.sim.estimated_state import EstimatedState

        state = EstimatedState(sim, seed=seed)
    _, summary = run_scenario(sim, controller, scenario, state=state, viewer=_StopWatch())
    survived, reason = outcome_of(summary)
    row = {"survived": survived, "outcome": "survived" if survived else "fell" if summary.get("fell") else "failed",
           "fall_reason": reason, "push_time_s": push_time,
           "failed_criteria": "; ".join(summary.get("failed_criteria", []))}
    keys = spec.keep or [k for k, v in summary.items() if _scalar(v)]
    for k in keys:
        if k in row or k in params or k in WALL_CLOCK_KEYS:
            continue
        row[k] = _plain(summary.get(k))
    return row


def _scalar(v) -> bool:
    """A value a Parquet column can hold as is: bool, int, float, str or a numpy scalar."""
    return isinstance(v, (bool, int, float, str, np.generic))


def _plain(v):
    """Python scalar of ``v`` (numpy scalars unwrapped), or None for anything else."""
    if isinstance(v, np.generic):
        return v.item()
    return v if isinstance(v, (bool, int, float, str)) else None
