"""Actuator models of the simulated plant (``--plant ideal|realistic``): what a real joint drive adds to an ideal
torque source.

``plant="ideal"``: every joint is an ideal torque source clamped to its URDF effort limit, no damping, friction or
armature beyond the Pinocchio model's (the plant equals the controller's model; exact-model tests use it).

``plant="realistic"`` (:func:`actuator_model`), per actuated joint i:

* **viscous damping** d_i (N·m·s/rad) and **dry friction** f_i (N·m) from the URDF ``<dynamics damping friction>``
  (Talos: 0.5–1 and 1 on 20 joints; G1 and humanoid15: none), plus ``extra_damping`` / ``extra_friction`` on every
  joint; applied by MuJoCo (``dof_damping``, ``dof_frictionloss``: dry friction as a constraint force bounded by
  f_i, i.e. static and kinetic friction equal);
* **rotor armature** a_i (kg·m², the reflected rotor inertia I_rotor · N², added to the joint's diagonal of the mass
  matrix; MuJoCo ``dof_armature``) from :func:`nominal_armature`: the SRDF ``<rotor_params>`` when the robot has
  them (Pinocchio ``loadRotorParameters``: a_i = rotor inertia × gear ratio²; Talos: 1e-5 kg·m² × 100² = 0.1 kg·m²
  on every joint), else :data:`ROTOR_ARMATURE` (G1: 0.01 kg·m², the joint default of the MuJoCo Menagerie
  ``unitree_g1/g1.xml``; humanoid15: 0.01 kg·m², assumed — a teaching robot with no drive data); ``armature``
  overrides it for all joints;
* **torque limit** τ_max,i: the URDF effort limit (MuJoCo ``forcerange``);
* **drive velocity behaviour: a linear torque–speed envelope** (a DC motor at its voltage limit): while the drive
  is motoring (τ q̇ > 0) the torque it can deliver falls linearly from τ_max at rest to zero at the no-load speed
  ω₀,i = ``no_load_factor`` × the URDF velocity limit (default :data:`NO_LOAD_SPEED_FACTOR`); braking (τ q̇ ≤ 0)
  keeps τ_max. So a drive cannot drive its joint above ω₀, whatever torque is commanded. Applied where the
  torques enter the plant (:meth:`~wbc.sim.mujoco_runtime.MujocoModel.set_torques`, with the velocity at the start
  of the step).

The controller's compensation of these effects is :mod:`wbc.dynamics.actuator_compensation`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba as nb
import numpy as np

from wbc.compiled import once_per_process
from wbc.exceptions import InvalidInputError

__all__ = ["ActuatorModel", "actuator_model", "nominal_armature", "apply_actuators", "compensation_options",
           "PLANTS", "ROTOR_ARMATURE", "NO_LOAD_SPEED_FACTOR", "SPEED_MARGIN", "UPPER_BODY_SPEED_MARGIN",
           "SPEED_HORIZON", "leg_joints", "joint_speed_margins",
           "SPEED_HORIZON_PER_DELAY_TICK", "speed_horizon", "BRAKING_SHARE"]

PLANTS = ("ideal", "realistic")
#: Fraction of the URDF joint speed limits the controller keeps free on a realistic plant, on the leg joints (the
#: joints that carry the soles).
SPEED_MARGIN = 0.05
#: Fraction of the URDF speed limits kept free on the other joints (torso, arms, head): light distal chains that the
#: body's own accelerations drive as much as their drives do — a touch-down or a stance foot rolling under a pushed
#: walk accelerates a wrist or shoulder by tens of rad/s² beyond the command, faster than the lagging estimated
#: velocity reveals (benchmarks/README.md, pushed walks on the realistic plant). They do not carry the robot, so a
#: lower bound on their speed costs the gait nothing.
UPPER_BODY_SPEED_MARGIN = 0.3
#: Share of each joint's torque limit the controller's joint bounds may count on to brake that joint on a realistic
#: plant (:func:`wbc.constraints.joint_acceleration_bounds.drive_braking`: min(a_brk, share × τ_max / M_jj(q_ref)), the
#: joint's inertia with the rotor armature): 1, no more than the drive gives on the joint's own inertia. On Talos the
#: shoulder rolls brake at 16.5 rad/s² instead of the common 50, the waist at 27 and 35, the elbows at 42, the forearm
#: rolls at 28 and the head pitch at 38; the legs keep 50. Half the torque (0.5) also cut the shoulder pitches to 42
#: and lost more survivors to their speed than it saved (benchmarks/records/75).
BRAKING_SHARE = 1.0
#: Ticks over which the controller's joint speed bounds let a joint reach the bound on a realistic plant, with no
#: control delay (:class:`wbc.constraints.joint_velocity.JointSpeedBounds`: h ≳ e × the ~1.5-tick lag of the
#: estimated joint velocities); :func:`speed_horizon` adds :data:`SPEED_HORIZON_PER_DELAY_TICK` per tick of delay.
SPEED_HORIZON = 4.0
SPEED_HORIZON_PER_DELAY_TICK = 2.0
#: No-load speed of the drives as a multiple of the URDF velocity limit (an assumption: the URDF limit is taken
#: as the drive's rated speed, below its no-load speed).
NO_LOAD_SPEED_FACTOR = 1.2
#: Rotor armature (kg·m², every actuated joint) of the catalog robots without SRDF ``<rotor_params>``: (value,
#: source).
ROTOR_ARMATURE = {
    "g1": (0.01, "MuJoCo Menagerie unitree_g1/g1.xml, default class 'g1' joint armature"),
    "humanoid15": (0.01, "assumed (no drive data for this teaching robot)"),
}


@nb.njit(cache=True)
def _drive_kernel(tau, qvel, qvel_idx, effort_limit, no_load_speed, ctrl, ctrl_idx):
    """``ctrl[ctrl_idx] =`` :meth:`ActuatorModel.available_torque` ``(tau, qvel[qvel_idx])``, the same arithmetic
    (numpy's NaN-propagating minimum/maximum). Returns False, writing nothing, when an entry of ``tau`` is not
    finite."""
    n = tau.size
    for i in range(n):
        if not math.isfinite(tau[i]):
            return False
    for i in range(n):
        qd, t, lim = qvel[qvel_idx[i]], tau[i], effort_limit[i]
        if t * qd > 0:
            f = 1.0 - abs(qd) / no_load_speed[i]
            f = f if (f >= 0.0 or f != f) else 0.0  # numpy.maximum(f, 0)
            f = f if (f <= 1.0 or f != f) else 1.0  # numpy.minimum(f, 1)
            cap = lim * f
        else:
            cap = lim
        lo = -cap
        x = t if (t >= lo or t != t) else lo  # numpy.maximum(tau, -cap): NaN propagates
        if lo != lo:
            x = lo
        y = x if (x <= cap or x != x) else cap  # numpy.minimum(x, cap)
        if cap != cap:
            y = cap
        ctrl[ctrl_idx[i]] = y
    return True


@once_per_process
def _warm_up() -> None:
    """Load :func:`_drive_kernel` (on-disk cache) once per process."""
    idx = np.zeros(1, dtype=np.intp)
    _drive_kernel(np.zeros(1), np.zeros(1), idx, np.ones(1), np.ones(1), np.zeros(1), idx)


@dataclass
class ActuatorModel:
    """Per-joint drive parameters, (nv − 6,) arrays in Pinocchio's actuated order (module docstring).

    Attributes:
        damping: viscous damping (N·m·s/rad). friction: dry friction (N·m). armature: rotor armature (kg·m²).
        effort_limit: τ_max (N·m; inf when unlimited). no_load_speed: ω₀ (rad/s; inf: no envelope).
        armature_source: where the armature values come from.
    """

    damping: np.ndarray
    friction: np.ndarray
    armature: np.ndarray
    effort_limit: np.ndarray
    no_load_speed: np.ndarray
    armature_source: str = ""

    def available_torque(self, tau: np.ndarray, qdot: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """The torque the drives deliver for the command ``tau`` (nv − 6,) N·m at joint speeds ``qdot`` (nv − 6,)
        rad/s: clamped to ±τ_max, and while motoring (τ q̇ > 0) to τ_max (1 − |q̇|/ω₀)⁺ (module docstring)."""
        out = np.empty_like(tau) if out is None else out
        cap = self.effort_limit * np.minimum(np.maximum(1.0 - np.abs(qdot) / self.no_load_speed, 0.0), 1.0)
        cap = np.where(tau * qdot > 0, cap, self.effort_limit)
        np.minimum(np.maximum(tau, -cap), cap, out=out)  # (numpy.clip's bounds, without its Python-level wrapper)
        return out

    def write_available_torque(self, tau: np.ndarray, qvel: np.ndarray, qvel_idx: np.ndarray, ctrl: np.ndarray,
                               ctrl_idx: np.ndarray) -> bool:
        """``ctrl[ctrl_idx] = available_torque(tau, qvel[qvel_idx])`` in one compiled pass: ``tau`` (nv − 6,) float
        array (N·m), ``qvel`` and ``ctrl`` float arrays (e.g. MuJoCo's ``qvel`` and ``ctrl``), the index arrays
        (nv − 6,) ints. Returns False, writing nothing, when an entry of ``tau`` is not finite (the caller's checked
        path raises).

        Raises:
            InvalidInputError: ``tau`` not a float array of this model's size.
        """
        if not (type(tau) is np.ndarray and tau.dtype == float and tau.shape == self.effort_limit.shape):
            raise InvalidInputError(f"tau must be a float array of shape {self.effort_limit.shape}, got {tau!r}")
        return _drive_kernel(tau, qvel, qvel_idx, self.effort_limit, self.no_load_speed, ctrl, ctrl_idx)

    def __post_init__(self) -> None:
        _warm_up()

    def summary(self) -> dict:
        """Ranges of the parameters (for run summaries)."""
        def rng(a):
            a = np.asarray(a)
            return [float(a.min()), float(a.max())] if a.size else [0.0, 0.0]
        return {"damping_nms_per_rad": rng(self.damping), "friction_nm": rng(self.friction),
                "armature_kgm2": rng(self.armature), "armature_source": self.armature_source,
                "no_load_speed_rad_s": rng(self.no_load_speed)}


def nominal_armature(robot) -> tuple[np.ndarray, str]:
    """(nv − 6,) rotor armature (kg·m²) of ``robot`` and its source (module docstring): the SRDF
    ``<rotor_params>`` (rotor inertia × gear ratio²) when present, else the armature already in the Pinocchio
    model (a robot file's ``[mujoco] armature``), else :data:`ROTOR_ARMATURE`, else zeros."""
    import pinocchio as pin

    n = robot.model.nv - 6
    if robot.srdf_path is not None and "rotor_params" in open(robot.srdf_path).read():
        m = robot.model.copy()
        pin.loadRotorParameters(m, str(robot.srdf_path), False)
        arm = np.asarray(m.rotorInertia[6:]) * np.asarray(m.rotorGearRatio[6:]) ** 2
        if np.any(arm > 0):
            source = f"SRDF rotor_params (rotor inertia × gear ratio²) of {robot.srdf_path.name}"
            fill = np.asarray(robot.model.armature[6:], dtype=float)
            if np.any((arm == 0) & (fill > 0)):  # joints the SRDF has no rotor data for: the robot file's value
                arm = np.where(arm == 0, fill, arm)
                source += "; joints it has no rotor data for: the robot file's [mujoco] armature"
            return arm, source
    if np.any(np.asarray(robot.model.armature[6:]) > 0):
        return np.asarray(robot.model.armature[6:], dtype=float).copy(), "the robot file's [mujoco] armature"
    if robot.name in ROTOR_ARMATURE:
        value, source = ROTOR_ARMATURE[robot.name]
        return np.full(n, value), source
    return np.zeros(n), "none known (0)"


def _check(x, what, allow_inf=False):
    x = float(x)
    if not ((np.isfinite(x) or (allow_inf and x == np.inf)) and x >= 0):
        raise InvalidInputError(f"{what} must be a finite number ≥ 0, got {x!r}")
    return x


def actuator_model(robot, plant: str = "realistic", *, extra_friction: float = 0.0, extra_damping: float = 0.0,
                   armature: float | None = None, no_load_factor: float = NO_LOAD_SPEED_FACTOR) -> ActuatorModel:
    """The drives of ``robot`` for ``plant`` (module docstring).

    Args:
        robot: the robot (URDF damping/friction/limits from its Pinocchio model).
        plant: ``"ideal"`` (zeros, effort limits only, no envelope) or ``"realistic"``.
        extra_friction: N·m added to every joint's dry friction (≥ 0). extra_damping: N·m·s/rad (≥ 0).
        armature: kg·m² for every joint instead of :func:`nominal_armature` (≥ 0; None: nominal).
        no_load_factor: ω₀ / URDF velocity limit (> 0; inf: no envelope).

    Raises:
        InvalidInputError: unknown plant or a bad number.
    """
    if plant not in PLANTS:
        raise InvalidInputError(f"plant must be one of {PLANTS}, got {plant!r}")
    extra_friction, extra_damping = _check(extra_friction, "extra_friction"), _check(extra_damping, "extra_damping")
    no_load_factor = _check(no_load_factor, "no_load_factor", allow_inf=True)
    if no_load_factor == 0:
        raise InvalidInputError("no_load_factor must be > 0")
    m = robot.model
    n = m.nv - 6
    effort = np.asarray(m.effortLimit[6:], dtype=float)
    effort = np.where((effort > 0) & np.isfinite(effort), effort, np.inf)
    if plant == "ideal":
        return ActuatorModel(np.zeros(n), np.zeros(n), np.asarray(m.armature[6:], dtype=float).copy(), effort,
                             np.full(n, np.inf), "Pinocchio model.armature")
    if armature is None:
        arm, source = nominal_armature(robot)
    else:
        arm, source = np.full(n, _check(armature, "armature")), "set for all joints"
    vlim = np.asarray(m.velocityLimit[6:], dtype=float)
    w0 = np.where((vlim > 0) & np.isfinite(vlim), vlim * no_load_factor, np.inf)
    return ActuatorModel(np.asarray(m.damping[6:], dtype=float) + extra_damping,
                         np.asarray(m.friction[6:], dtype=float) + extra_friction, arm, effort, w0, source)


def apply_actuators(sim, act: ActuatorModel) -> None:
    """Write ``act`` into the compiled MuJoCo model of ``sim`` (damping, frictionloss, armature of the actuated
    DoFs) and install its torque–speed envelope in ``sim.set_torques`` (``sim.drive``)."""
    import mujoco

    dofs = sim.state_map.mj_qvel
    m = sim.model
    m.dof_damping[dofs] = act.damping
    m.dof_frictionloss[dofs] = act.friction
    m.dof_armature[dofs] = act.armature
    mujoco.mj_setConst(m, sim.data)
    sim.drive = act if np.any(np.isfinite(act.no_load_speed)) else None


def speed_horizon(delay: int = 0) -> float:
    """Speed horizon (ticks) of the controller's joint speed bounds for a control delay of ``delay`` ticks (≥ 0):
    :data:`SPEED_HORIZON` + :data:`SPEED_HORIZON_PER_DELAY_TICK` × delay.

    Raises:
        InvalidInputError: a negative or non-integer delay.
    """
    if isinstance(delay, bool) or not isinstance(delay, (int, np.integer)) or delay < 0:
        raise InvalidInputError(f"delay must be an integer ≥ 0 (ticks), got {delay!r}")
    return SPEED_HORIZON + SPEED_HORIZON_PER_DELAY_TICK * int(delay)


def leg_joints(robot, sides: tuple[str, ...] = ("left", "right")) -> np.ndarray:
    """(nv − 6,) bool, Pinocchio's actuated velocity order: True for the joints on the kinematic chains from the
    floating base to the sole frames of ``sides`` (the legs; default both).

    Raises:
        InvalidInputError: a side other than "left" or "right".
    """
    if isinstance(sides, str) or any(s not in ("left", "right") for s in sides):
        raise InvalidInputError(f"sides must be a tuple of 'left' and/or 'right', got {sides!r}")
    model = robot.model
    mask = np.zeros(model.nv - 6, dtype=bool)
    for sole in (robot.left_sole if s == "left" else robot.right_sole for s in sides):
        for j in model.supports[model.frames[robot.frame_id(sole)].parentJoint]:
            jm = model.joints[j]
            if jm.idx_v >= 6:
                mask[jm.idx_v - 6:jm.idx_v - 6 + jm.nv] = True
    return mask


def joint_speed_margins(robot, speed_margin: float = SPEED_MARGIN,
                        upper_body_margin: float = UPPER_BODY_SPEED_MARGIN) -> np.ndarray:
    """(nv − 6,) speed margins of the controller's joint speed bounds: ``speed_margin`` on the leg joints
    (:func:`leg_joints`), ``upper_body_margin`` on the others (each in [0, 1)).

    Raises:
        InvalidInputError: a margin outside [0, 1) or not finite.
    """
    for val, what in ((speed_margin, "speed_margin"), (upper_body_margin, "upper_body_margin")):
        if isinstance(val, bool) or not isinstance(val, (int, float, np.floating)) \
                or not (np.isfinite(val) and 0.0 <= val < 1.0):
            raise InvalidInputError(f"{what} must be a number in [0, 1), got {val!r}")
    return np.where(leg_joints(robot), float(speed_margin), float(upper_body_margin))


def compensation_options(robot, act: ActuatorModel, speed_margin: float = SPEED_MARGIN, *, delay: int = 0,
                         upper_body_margin: float = UPPER_BODY_SPEED_MARGIN) -> dict:
    """The :class:`~wbc.dynamics.balance.IDBalanceController` options that make the controller know the nominal
    drives ``act``: ``{"armature": (nv − 6,) kg·m² (its mass matrix includes it, on the controller's own copy of the
    model), "compensation": friction/damping feed-forward, "speed_margin": (nv − 6,) per-joint margins
    (:func:`joint_speed_margins`: ``speed_margin`` on the legs, ``upper_body_margin`` elsewhere), "speed_horizon":
    speed_horizon(delay), "braking_share": BRAKING_SHARE}`` (``delay``: the control delay in ticks the controller runs
    with). ``robot`` is not modified.

    Raises:
        InvalidInputError: a drive model of another size, a margin outside [0, 1).
    """
    from wbc.dynamics.actuator_compensation import JointFrictionCompensation

    if act.armature.size != robot.model.nv - 6:
        raise InvalidInputError(f"drive model of {act.armature.size} joints for a robot with {robot.model.nv - 6}")
    return {"armature": act.armature.copy(), "compensation": JointFrictionCompensation(act.damping, act.friction),
            "speed_margin": joint_speed_margins(robot, speed_margin, upper_body_margin),
            "speed_horizon": speed_horizon(delay), "braking_share": BRAKING_SHARE}
