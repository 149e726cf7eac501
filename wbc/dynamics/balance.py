"""A humanoid balance controller: the inverse-dynamics QP with a standard task set.

Tasks (all at acceleration level, :mod:`wbc.tasks.acceleration`), weights relative to each other:

* CoM position (world), PD + feed-forward — the balance task (highest weight);
* torso orientation (the robot's ``torso`` frame), keeps the upper body upright;
* centroidal angular momentum regulated to zero with a moderate weight: it damps whole-body rotation but lets
  the upper body rotate (hip strategy) when the CoM task needs more horizontal force than the CoP alone
  gives (Lee & Goswami 2012);
* posture (every actuated joint, reference ``robot.q_ref``), lowest weight, regularises the redundancy;
* one pose task per foot, enabled only while that foot is released (swing).

Contacts: one :class:`~wbc.constraints.sole_contact.SoleContact` per sole (``left``/``right``), 4 corner forces each.
Push recovery comes from the CoM task alone: its desired acceleration (PD, Kp 100 /s², Kd 20 /s) exceeds what the
support polygon allows under a strong push, and the QP then puts the CoP on the polygon edge (corner-force
bounds) and uses the remaining freedom — upper-body rotation, limited by the angular-momentum and torso tasks —
to get closer to it; no explicit DCM/capture-point reference shaping is used (measured against the capture-point
bound in ``wbc sim push --sweep``).
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pinocchio as pin

from wbc.constants import SIDES
from wbc.constraints.joint_acceleration_bounds import drive_braking
from wbc.constraints.joint_velocity import JointSpeedBounds, speed_margins
from wbc.constraints.sole_contact import SoleContact
from wbc.dynamics.actuator_compensation import JointFrictionCompensation
from wbc.controllers.inverse_dynamics import InverseDynamicsController
from wbc.formulations.acceleration import IDCommand
from wbc.formulations.acceleration import InverseDynamicsQP
from wbc.formulations.reference import AccelerationReference
from wbc.exceptions import InvalidInputError
from wbc.robot import Robot
from wbc.tasks import AngularMomentumTask, ComTask, FrameTask, OrientationTask, PostureTask

__all__ = ["IDBalanceController", "DEFAULT_GAINS"]

#: Default gains (kp 1/s², kd 1/s or momentum gain 1/s) and weights.
DEFAULT_GAINS: dict[str, float] = {
    "com_kp": 100.0, "com_kd": 20.0, "com_weight": 1000.0,
    "torso_kp": 100.0, "torso_kd": 20.0, "torso_weight": 10.0,
    "momentum_gain": 10.0, "momentum_weight": 0.1,
    "posture_kp": 50.0, "posture_kd": 14.0, "posture_weight": 1.0,
    "foot_kp": 400.0, "foot_kd": 40.0, "foot_weight": 100.0,
    "contact_kd": 20.0,
}


class IDBalanceController:
    """Inverse-dynamics balance controller for a humanoid standing on its two soles (module docstring).

    Args:
        robot: the robot.
        dt: control period (s).
        solver: QP backend name (default ``fast``: the compiled ID tick of :mod:`wbc.formulations.idkernel`, DAQP as
            its fallback; ``daqp``: the general path).
        mu: friction coefficient of the controller's pyramids.
        f_min: minimum normal force per sole corner (N).
        sole_margin: the controller's contact rectangle is the sole shrunk by this much on every side (m), so
            the CoP it plans keeps this distance from the real sole's edges.
        gains: overrides of :data:`DEFAULT_GAINS`.
        compensation: joint friction/damping feed-forward added to every command's torques (clipped to the
            torque limits), evaluated at the commanded next-tick joint velocity v + v̇ dt
            (:class:`~wbc.dynamics.actuator_compensation.JointFrictionCompensation`); None: none.
        speed_margin: the joint speed limits the QP enforces on its accelerations, |v + v̇ dt| ≤ (1 − margin)
            q̇_max (URDF), in the full QP (eq. 9 of :mod:`wbc.formulations.acceleration`) and — as the
            non-relaxable :class:`~wbc.constraints.joint_velocity.JointSpeedBounds` — in the relaxed one; in [0, 1),
            one number or an (nv − 6,) array (one per actuated joint, Pinocchio's velocity order).
        speed_horizon: h (ticks, ≥ 1) of those speed bounds, in both QPs: v̇ h dt ≤ (1 − margin) q̇_max − v, so
            a joint approaches its limit as a first-order system of time constant h dt — robust to a lagging
            velocity measurement (:class:`~wbc.constraints.joint_velocity.JointSpeedBounds`); 1: the next tick's
            velocity is bounded.
        armature: (nv − 6,) rotor armature (kg·m², ≥ 0) of the actuated joints, Pinocchio's actuated order, added to
            the diagonal of the controller's mass matrix. The controller then works on its own copy of the robot
            (``self.robot``, its ``model.armature[6:]`` set); the ``robot`` passed in is left unchanged, so other
            controllers and plants built from it do not inherit the armature. None: the model's own armature.
        braking_share: the share of each joint's torque limit its joint bounds may count on to brake, in (0, 1]:
            joint j brakes at min(a_brk, share × τ_max,j / M_jj(q_ref)) (its own inertia, armature included;
            :func:`~wbc.constraints.joint_acceleration_bounds.drive_braking`) in the full QP's viability and speed
            terms, and in the relaxed QP's speed bounds. None: a_brk for every joint.

    Raises:
        InvalidInputError: unknown gain names or bad values, a compensation of the wrong type or size, a speed
            margin outside [0, 1), a speed horizon < 1, an armature of the wrong size or negative, a braking share
            outside (0, 1].
            UnknownSolverError: unknown solver.
    """


    def __init__(self, robot: Robot, *, dt: float = 0.002, solver: str = "fast", mu: float = 0.7,
                 f_min: float = 0.0, sole_margin: float = 0.0, gains: dict[str, float] | None = None,
                 compensation: JointFrictionCompensation | None = None, speed_margin=0.0,
                 speed_horizon: float = 1.0, armature=None, braking_share: float | None = None, **qp_options):
        if armature is not None:
            robot = _with_armature(robot, armature)
        unknown = set(gains or {}) - set(DEFAULT_GAINS)
        if unknown:
            raise InvalidInputError(f"unknown gains {sorted(unknown)}; known: {sorted(DEFAULT_GAINS)}")
        self.gains = {**DEFAULT_GAINS, **(gains or {})}
        gn = self.gains
        self.robot = robot
        self.dt = float(dt)
        self.com = AccelerationReference(ComTask(), kp=gn["com_kp"], kd=gn["com_kd"], weight=gn["com_weight"])
        self.torso = AccelerationReference(OrientationTask(robot, robot.torso), kp=gn["torso_kp"],
                                           kd=gn["torso_kd"], weight=gn["torso_weight"])
        # L̇ = L̇_ff − K (L − L*): Kp = 0 and Kd = K on the momentum task (e ≡ 0, ė_ff = its target L*)
        self.momentum = AccelerationReference(AngularMomentumTask(weight=gn["momentum_weight"]), kp=0.0,
                                              kd=gn["momentum_gain"], weight=gn["momentum_weight"],
                                              name=AngularMomentumTask.name)
        self.posture = AccelerationReference(PostureTask(robot), kp=gn["posture_kp"], kd=gn["posture_kd"],
                                             weight=gn["posture_weight"])
        self.base = None  # floating-base orientation task (set_base_orientation_weight), off by default
        soles = {"left": robot.left_sole, "right": robot.right_sole}
        length, width = robot.sole_length - 2 * sole_margin, robot.sole_width - 2 * sole_margin
        if not (length > 0 and width > 0):
            raise InvalidInputError(f"sole_margin {sole_margin} m leaves no contact area")
        self.contacts = {
            s: SoleContact(robot, soles[s], length=length, width=width, mu=mu, f_min=f_min, kd=gn["contact_kd"],
                           name=s) for s in SIDES
        }
        self.feet = {
            s: AccelerationReference(FrameTask(robot, soles[s]), kp=gn["foot_kp"], kd=gn["foot_kd"],
                                     weight=gn["foot_weight"], name=f"{s}_foot") for s in SIDES
        }
        self.qp = InverseDynamicsQP(robot, [self.com, self.torso, self.momentum, self.posture],
                                    list(self.contacts.values()), solver=solver, **qp_options)
        self.controller = InverseDynamicsController(self.qp, dt)
        margins = speed_margins(robot, speed_margin)
        jl = self.qp.joint_acceleration_limits
        speed = JointSpeedBounds(robot, margins, speed_horizon, jl.braking_acceleration)  # (the full QP's floor)
        self.qp.joint_speed_limits = speed
        jl.speed_horizon = speed.horizon
        if margins.any():
            jl.vmax[:] *= 1.0 - margins[jl.iv - 6]  # in place: the compiled tick reads it
        if braking_share is not None:
            jl.joint_braking = drive_braking(robot.model, jl.iv, braking_share, robot.q_ref, self.qp.tau_max[jl.iv - 6])
        if compensation is not None and (not isinstance(compensation, JointFrictionCompensation)
                                         or compensation.damping.size != robot.nv - 6):
            raise InvalidInputError(f"compensation must be a JointFrictionCompensation of size {robot.nv - 6}, "
                                    f"got {compensation!r}")
        self.compensation = compensation
        self._tau_max = np.where(np.isfinite(self.qp.tau_max) & (self.qp.tau_max > 0), self.qp.tau_max, np.inf)
        self._tau_min = -self._tau_max
        self.com_ref = np.zeros(3)
        self.com_vel_ref = np.zeros(3)
        self.com_acc_ref = np.zeros(3)

    @property
    def state(self):
        """The :class:`~wbc.state.DynamicsState` of the last tick."""
        return self.controller.state

    # -- references ------------------------------------------------------------------------------------------
    def reset(self, q: np.ndarray, v: np.ndarray | None = None) -> None:
        """Both feet in contact, CoM reference = current CoM, torso reference = current torso orientation,
        posture reference = ``robot.q_ref``.

        Raises:
            ConfigurationError: bad q / v.
        """
        st = self.controller.state
        st.update(q, np.zeros(self.robot.nv) if v is None else v)
        self.set_com_reference(st.com.copy())
        self.torso.set_target(st.data.oMf[self.torso.task.frame_id].copy())
        self.posture.set_target(self.robot.q_ref)
        for side in SIDES:
            self.contacts[side].activate(st)
            self.contacts[side].f_max = math.inf
            if self.feet[side] in self.qp.tasks:
                self.qp.remove_task(self.feet[side])

    def set_com_reference(self, position, velocity=None, acceleration=None) -> None:
        """CoM reference (3,) world (m), optional velocity (m/s) and acceleration (m/s²) feed-forwards.

        Raises:
            InvalidTargetError: wrong shape or NaN.
        """
        self.com.set_target(position, velocity)
        self.com.set_feedforward_acceleration(acceleration)
        self.com_ref = np.array(position, dtype=float)
        self.com_vel_ref = np.zeros(3) if velocity is None else np.array(velocity, dtype=float)
        self.com_acc_ref = np.zeros(3) if acceleration is None else np.array(acceleration, dtype=float)

    def set_com_reference_trusted(self, position: np.ndarray, velocity: np.ndarray,
                                  acceleration: np.ndarray) -> None:
        """:meth:`set_com_reference` without validation or copies, for a scenario's own loop feeding references it
        built and checked: (3,) float arrays, finite, world (m, m/s, m/s²), kept by reference until the next ones
        are set (the caller must not modify them). Malformed input is not detected here."""
        self.com.task.set_target_trusted(position, velocity)
        self.com.set_feedforward_acceleration_trusted(acceleration)
        self.com_ref, self.com_vel_ref, self.com_acc_ref = position, velocity, acceleration

    def set_max_normal_force(self, side: str, total: float) -> None:
        """Bound the total normal force of a sole (N, ≥ 0) — ramp it to 0 to unload a foot before lifting it.

        Each corner gets f_max = total / 4; below the contact's f_min the lower bound follows it down
        (:attr:`~wbc.constraints.sole_contact.SoleContact.normal_force_bounds`), so the bounds never cross.

        Raises:
            InvalidInputError: unknown side; total NaN or negative.
        """
        if side not in self.contacts:
            raise InvalidInputError(f"side must be one of {sorted(self.contacts)}, got {side!r}")
        try:
            total = float(total)
        except (TypeError, ValueError):
            raise InvalidInputError(f"total normal force must be a number of newtons ≥ 0, got {total!r}") from None
        if math.isnan(total) or total < 0:
            raise InvalidInputError(f"total normal force must be ≥ 0 (N), got {total!r}")
        self.contacts[side].f_max = total / 4.0

    def release_foot(self, side: str) -> None:
        """Deactivate a sole contact and track the foot pose with a frame task (target: current pose)."""
        contact = self.contacts[side]
        contact.deactivate()
        foot = self.feet[side]
        foot.set_target(self.controller.state.data.oMf[foot.task.frame_id].copy())
        if foot not in self.qp.tasks:
            self.qp.add_task(foot)

    def set_base_orientation_weight(self, weight: float, kp: float | None = None, kd: float | None = None,
                                    q: np.ndarray | None = None) -> None:
        """Track the floating base's (root body's, e.g. the pelvis) orientation, held at its world orientation at
        ``q`` (nq,) (default: the last tick's state), with ``weight`` (≥ 0; 0 removes the task) and the torso task's gains unless ``kp`` (1/s²) and
        ``kd`` (1/s) are given.

        The torso task holds only the body carrying ``robot.torso``; with waist joints between it and the root
        body, the pelvis is otherwise held by the posture task alone and rolls and yaws with a long swing leg (hip
        hiking). A robot whose torso frame is on the root body gets no extra task.

        Raises:
            InvalidInputError: a weight or gain that is not a finite number ≥ 0.
        """
        gn = self.gains
        kp = gn["torso_kp"] if kp is None else kp
        kd = gn["torso_kd"] if kd is None else kd
        for name, val in (("weight", weight), ("kp", kp), ("kd", kd)):
            if isinstance(val, bool) or not isinstance(val, (int, float)) or not (math.isfinite(val) and val >= 0):
                raise InvalidInputError(f"base orientation {name} must be a finite number ≥ 0, got {val!r}")
        model = self.robot.model
        if self.base is not None and self.base in self.qp.tasks:
            self.qp.remove_task(self.base)
        self.base = None
        root = next(i for i, f in enumerate(model.frames) if f.parentJoint == 1 and f.type == pin.FrameType.BODY)
        if weight == 0 or model.frames[root].parentJoint == model.frames[self.torso.task.frame_id].parentJoint:
            return
        self.base = AccelerationReference(OrientationTask(self.robot, model.frames[root].name), kp=float(kp),
                                          kd=float(kd), weight=float(weight), name="base_orientation")
        if q is None:
            target = self.controller.state.data.oMf[root].copy()
        else:
            data = model.createData()
            pin.framesForwardKinematics(model, data, np.asarray(q, dtype=float))
            target = data.oMf[root].copy()
        self.base.set_target(target)
        self.qp.add_task(self.base)

    def set_foot_reference(self, side: str, pose: pin.SE3, velocity=None, acceleration=None) -> None:
        """Swing foot reference: pose (world), spatial velocity (6,) and acceleration (6,) feed-forwards
        (linear then angular, world axes)."""
        foot = self.feet[side]
        foot.set_target(pose, velocity)
        foot.set_feedforward_acceleration(None if acceleration is None else np.asarray(acceleration)[foot.task.rows])

    def set_foot_reference_rows(self, side: str, rotation_t: np.ndarray, position: np.ndarray,
                                velocity: np.ndarray, acceleration: np.ndarray) -> None:
        """:meth:`set_foot_reference` without validation or copies, for a scenario's own loop feeding references
        it built and checked (e.g. the rows of a walk plan): ``rotation_t`` (3, 3) C-contiguous float array, the
        TRANSPOSED target rotation R*ᵀ (a rotation); ``position`` (3,) m; ``velocity`` and ``acceleration`` (6,)
        (linear then angular, world axes); all finite, world, kept by reference until the next reference is set (the
        caller must not modify them). Malformed input is not detected here."""
        foot = self.feet[side]
        task = foot.task
        ff = np.empty(6)
        ff[:3] = velocity[:3]
        ff[3:] = rotation_t @ velocity[3:]
        task.set_target_rows(rotation_t, position, ff)
        foot.set_feedforward_acceleration_trusted(acceleration if task.rows.size == 6 else acceleration[task.rows])

    # -- tick ------------------------------------------------------------------------------------------------
    def solve(self, q: np.ndarray, v: np.ndarray) -> IDCommand:
        """Torques for the measured state (see :meth:`InverseDynamicsController.solve`).

        Raises:
            ConfigurationError: bad q / v.
        """
        cmd = self.controller.solve(q, v)
        if self.compensation is not None:
            # (at the commanded next-tick joint velocity v[6:] + v̇[6:] dt; v validated by the solve above)
            cmd.tau = self.compensation.compensated(cmd.tau, np.asarray(v, dtype=float), cmd.dv, self.dt,
                                                    self._tau_min, self._tau_max)
        return cmd


def _with_armature(robot: Robot, armature) -> Robot:
    """A copy of ``robot`` whose Pinocchio model (a copy) has ``model.armature[6:] = armature``; ``robot`` unchanged."""
    n = robot.model.nv - 6
    try:
        arm = np.asarray(armature, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InvalidInputError(f"armature must be {n} numbers (kg·m², ≥ 0), got {armature!r}") from None
    if arm.size != n or not (np.all(np.isfinite(arm)) and np.all(arm >= 0)):
        raise InvalidInputError(f"armature must be {n} finite numbers ≥ 0 (kg·m², one per actuated joint), "
                                f"got shape {arm.shape} with min {arm.min() if arm.size else None}")
    model = robot.model.copy()
    model.armature[6:] = arm
    out = copy.copy(robot)  # not dataclasses.replace: it would read (and so build) the lazy visual_model
    out.model = model
    return out

