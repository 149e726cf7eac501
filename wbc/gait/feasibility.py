"""Gait defaults a robot's legs can do: a nominal walk replayed on the robot's own kinematic model.

:func:`nominal_step_demand` plans a short straight walk with :func:`wbc.gait.plan_walk` from the robot's reference
posture and follows it with each leg by inverse kinematics (Pinocchio frame Jacobians, damped least squares,
joint position limits clipped), the base translated with the planned CoM and its orientation kept: the joint
speeds and accelerations a tracking controller must produce before any feedback, and whether the soles reach
their targets inside the joint ranges at all.

:func:`feasible_gait` shortens/lengthens a gait until that nominal demand fits a fraction of the URDF joint speed
limits and of the walk's joint-acceleration bound, and the soles are reached: durations are stretched first (joint
speed ∝ 1/T, acceleration ∝ 1/T² at a fixed path), the step length and clearance are shortened when the
durations reach their cap or the soles are not reachable. Every change is returned as a sentence.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from wbc.exceptions import GaitError
from wbc.gait.walk import plan_walk
from wbc.robot import Robot
from wbc.robot_inspect import reach_frame

__all__ = ["GaitDemand", "nominal_step_demand", "feasible_gait", "SPEED_FRACTION", "ACCELERATION_FRACTION",
           "MAX_T_SS", "REACH_TOLERANCE"]

#: Largest nominal joint speed, as a fraction of the URDF velocity limit, accepted by :func:`feasible_gait`
#: (the rest is left to the stabilizer, the swing landing and tracking transients).
SPEED_FRACTION = 0.35
#: Largest nominal joint acceleration (rad/s²) accepted by :func:`feasible_gait`: a fraction of the kinematic
#: walk's joint-acceleration bound (50 rad/s²).
ACCELERATION_FRACTION = 0.6
#: The kinematic walk's joint-acceleration bound (rad/s², :class:`wbc.scenarios.walk.WalkController` default).
WALK_ACCELERATION_BOUND = 50.0
#: Longest single support (s) :func:`feasible_gait` chooses before shortening the step instead.
MAX_T_SS = 1.4
#: Largest sole position error (m) of the inverse kinematics for a sole target to count as reached.
REACH_TOLERANCE = 0.003
#: Sample period (s) of the nominal replay.
_DT = 0.01


@dataclass(frozen=True)
class GaitDemand:
    """What a nominal walk asks of the legs.

    Attributes:
        speed_ratio: largest |q̇| / URDF velocity limit over the leg joints (1 = at the limit).
        speed_joint: the joint where it occurs.
        acceleration: largest |q̈| (rad/s²) over the leg joints; ``acceleration_joint`` where it occurs.
        reach_error: largest sole position error (m) of the inverse kinematics (joint ranges clipped).
        reach_joint: the leg joint closest to (or on) a position limit at that sample.
    """

    speed_ratio: float
    speed_joint: str
    acceleration: float
    acceleration_joint: str
    reach_error: float
    reach_joint: str


def _leg_chain(model: pin.Model, frame: str) -> list[int]:
    j = model.frames[model.getFrameId(frame)].parentJoint
    out = []
    while j > 1:
        if model.joints[j].nq == 1:
            out.append(j)
        j = model.parents[j]
    return out[::-1]


def nominal_step_demand(robot: Robot, gait: dict[str, float], n_steps: int = 3) -> GaitDemand:
    """Replay a nominal straight walk of ``n_steps`` with ``gait`` on the robot's legs (module docstring).

    Args:
        robot: the robot (its ``q_ref``, sole frames and rectangle, joint limits).
        gait: ``step_length``, ``step_height`` (m), ``t_ss``, ``t_ds`` (s): keyword arguments of
            :func:`wbc.gait.plan_walk`.
        n_steps: swing phases planned (≥ 2: one full stride from a stance foot ahead).

    Returns:
        the :class:`GaitDemand` (speeds relative to the URDF limits, accelerations in rad/s², reach error in m).

    Raises:
        GaitError: the gait cannot be planned (the planner's message).
    """
    model = robot.model
    data = model.createData()
    q = robot.q_ref.copy()
    pin.framesForwardKinematics(model, data, q)
    com0 = pin.centerOfMass(model, data, q).copy()
    lf, rf = model.getFrameId(robot.left_sole), model.getFrameId(robot.right_sole)
    plan = plan_walk(data.oMf[lf].homogeneous, data.oMf[rf].homogeneous, com0, n_steps=n_steps, dt=_DT,
                     sole_length=robot.sole_length, sole_width=robot.sole_width,
                     **{k: float(v) for k, v in gait.items()})
    legs = [(lf, _leg_chain(model, robot.left_sole), plan.left_sole),
            (rf, _leg_chain(model, robot.right_sole), plan.right_sole)]
    base0 = q[:3].copy()
    n = plan.n_samples
    track = np.zeros((n, model.nq))
    reach, reach_joint = 0.0, ""
    for k in range(n):
        q[:3] = base0 + plan.com[k] - com0
        for fid, chain, target in legs:
            iq = [model.joints[j].idx_q for j in chain]
            lo, hi = model.lowerPositionLimit[iq], model.upperPositionLimit[iq]
            goal = pin.SE3(target[k])
            reach_frame(model, data, q, fid, chain, goal, iterations=30, tolerance=1e-7, damping=1e-6)
            pin.framesForwardKinematics(model, data, q)
            e = float(np.linalg.norm(data.oMf[fid].translation - goal.translation))
            if e > reach:
                reach = e
                slack = np.minimum(q[iq] - lo, hi - q[iq])
                reach_joint = model.names[chain[int(np.argmin(slack))]]
        track[k] = q
    v = np.diff(track, axis=0) / _DT
    a = np.diff(v, axis=0) / _DT
    joints = sorted({j for _, chain, _ in legs for j in chain})
    iq = [model.joints[j].idx_q for j in joints]
    vmax = model.velocityLimit[[model.joints[j].idx_v for j in joints]]
    vmax = np.where((vmax > 0) & np.isfinite(vmax), vmax, np.inf)
    ratio = np.abs(v[:, iq]).max(axis=0) / vmax
    acc = np.abs(a[:, iq]).max(axis=0)
    return GaitDemand(speed_ratio=float(ratio.max()), speed_joint=model.names[joints[int(np.argmax(ratio))]],
                      acceleration=float(acc.max()), acceleration_joint=model.names[joints[int(np.argmax(acc))]],
                      reach_error=reach, reach_joint=reach_joint)


def feasible_gait(robot: Robot, gait: dict[str, float], max_rounds: int = 10) -> tuple[dict[str, float], GaitDemand,
                                                                                          list[str]]:
    """A gait derived from ``gait`` whose nominal demand fits the robot (module docstring).

    Args:
        robot: the robot.
        gait: the starting gait (``step_length``, ``step_height``, ``t_ss``, ``t_ds``).
        max_rounds: adjustments tried before giving up.

    Returns:
        ``(gait, demand, notes)``: the gait chosen, its :class:`GaitDemand`, one sentence per change (and the
        final demand). The gait is returned even when it does not fit after ``max_rounds``; the caller compares
        ``demand`` with :data:`SPEED_FRACTION`, :data:`ACCELERATION_FRACTION` and :data:`REACH_TOLERANCE`.

    Raises:
        GaitError: a gait the planner refuses (its message).
    """
    g = {k: float(v) for k, v in gait.items()}
    notes: list[str] = []
    a_max = ACCELERATION_FRACTION * WALK_ACCELERATION_BOUND
    d = nominal_step_demand(robot, g)
    stretched, stretch, excess = None, True, math.inf
    for _ in range(max_rounds):
        if d.reach_error > REACH_TOLERANCE:
            stretched = None
            old = (g["step_length"], g["step_height"])
            g["step_length"] = round(0.75 * g["step_length"], 3)
            g["step_height"] = round(max(0.8 * g["step_height"], 0.01), 3)
            notes.append(f"the soles miss their targets by {1000 * d.reach_error:.1f} mm ({d.reach_joint} at its "
                         f"limit): step length/height {old[0]}/{old[1]} → {g['step_length']}/{g['step_height']} m")
        elif d.speed_ratio > SPEED_FRACTION or d.acceleration > a_max:
            s = max(d.speed_ratio / SPEED_FRACTION, math.sqrt(d.acceleration / a_max), 1.0)
            why = (f"{d.speed_joint} at {d.speed_ratio:.2f} × its speed limit" if d.speed_ratio > SPEED_FRACTION
                   else f"{d.acceleration_joint} at {d.acceleration:.0f} rad/s²")
            if stretched is not None and max(d.speed_ratio / SPEED_FRACTION, d.acceleration / a_max) > excess:
                # the slower step asks more (a longer single support sways the CoM further over a straightening
                # leg): back to the durations before, shorten the step instead
                g, d = stretched
                stretched, stretch = None, False
                notes.append(f"nominal step: stretching the durations raised the demand ({why}): single/double "
                             f"support back to {g['t_ss']}/{g['t_ds']} s")
                continue
            excess = max(d.speed_ratio / SPEED_FRACTION, d.acceleration / a_max)
            if stretch and g["t_ss"] < MAX_T_SS - 1e-9:
                stretched = (dict(g), d)
                t_ss = round(min(g["t_ss"] * s * 1.05, MAX_T_SS), 3)
                f = t_ss / g["t_ss"]
                old = (g["t_ss"], g["t_ds"])
                g["t_ss"], g["t_ds"] = t_ss, round(g["t_ds"] * f, 3)
                notes.append(f"nominal step: {why}: single/double support {old[0]}/{old[1]} → "
                             f"{g['t_ss']}/{g['t_ds']} s")
            else:
                stretched = None
                old = (g["step_length"], g["step_height"])
                g["step_length"] = round(g["step_length"] / min(s * 1.05, 2.0), 3)
                g["step_height"] = round(max(g["step_height"] / min(math.sqrt(s * 1.05), 1.5), 0.01), 3)
                notes.append(f"nominal step: {why} (durations not stretched further): step "
                             f"length/height {old[0]}/{old[1]} → {g['step_length']}/{g['step_height']} m")
        else:
            break
        if g["step_length"] < 0.01:
            raise GaitError(f"{robot.name}: no step of at least 1 cm found whose nominal replay keeps the legs "
                            f"inside their joint ranges and speed limits ({notes[-1]})")
        d = nominal_step_demand(robot, g)
    notes.append(f"nominal step ({g}): peak joint speed {d.speed_ratio:.2f} × limit ({d.speed_joint}), peak "
                 f"acceleration {d.acceleration:.1f} rad/s² ({d.acceleration_joint}), soles reached within "
                 f"{1000 * d.reach_error:.1f} mm")
    return g, d, notes
