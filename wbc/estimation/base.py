"""Floating-base state estimation from joint encoders, a base IMU and ankle force/torque sensors.

Per sample (period Δt), :meth:`FloatingBaseEstimator.update`:

1. **Joint velocities** (:class:`JointStateFilter`): a backward difference low-passed at f_c by default, or a
   fading-memory polynomial filter of degree 2
   (Morrison 1969, "Introduction to Sequential Smoothing and Prediction", McGraw-Hill; the critically damped
   g-h-k filter of Brookner 1998, "Tracking and Kalman Filtering Made Easy", Wiley, Ch. 1) on the encoder angles,
   with a state (q, q̇, q̈) per joint:
   predict q⁻ = q + q̇ Δt + ½ q̈ Δt², q̇⁻ = q̇ + q̈ Δt; with r = qₖ − q⁻: q = q⁻ + g r, q̇ = q̇⁻ + (h/Δt) r,
   q̈ = q̈ + (2k/Δt²) r, where g = 1 − θ³, h = 1.5 (1 − θ)² (1 + θ), k = 0.5 (1 − θ)³ for the memory θ ∈ [0, 1)
   (``velocity_memory``). Its velocity has no steady-state lag while a joint accelerates at a constant rate; a
   backward difference low-passed at f_c (``velocity_memory=None``, the default: v ← v + α ((qₖ − qₖ₋₁)/Δt − v),
   α = Δt / (Δt + 1/(2π f_c))) lags it by (½ Δt + 1/(2π f_c)) q̈. ``wbc sim jump`` uses θ = 0.5 (its take-off and
   landing need the lag-free velocity); the other scenarios the low-pass (the blind swing over rough ground lands
   2-5× farther from its foothold with θ = 0.5).
2. **Orientation**: :class:`~wbc.estimation.attitude.ComplementaryAttitudeFilter` (Mahony et al. 2008, eq. 32) on the
   gyro and on the accelerometer's specific force minus the base acceleration measured by the leg kinematics (the
   leg-odometry velocity of step 3, differenced and low-passed at ``accel_cutoff_hz``; without it the walking
   accelerations, ~1 m/s², tilt the estimated vertical) and, as a second reference direction of eq. 32, the forward
   axis of each sole in contact: its world direction v₀ is stored when the sole is anchored (step 3) and held while
   it stays in contact, its base-frame direction v comes from the leg kinematics, weighted by the sole's share of the
   normal force times ``heading_weight``, corrected with k_P about every axis and, as a heading direction of the
   filter, once more about the vertical with its own gains ``k_heading``, ``k_heading_bias`` (yaw has no other
   reference than the soles, and the gyro's yaw bias is learnt from them) — the sole does not turn while it carries
   load, which makes yaw and the gyro's yaw bias observable (leg odometry of the heading; on flat ground a sole that
   touches down while the other is anchored takes its v₀ from that sole's v₀ through the leg kinematics (on uneven
   ground its heading only, the tilt staying R̂'s), on every
   sample while both are in contact (it still turns as it settles, up to a few tenths of a degree in the first 0.1 s,
   while the other stays loaded and flat until it lifts off), so the heading passes from foot to foot without the yaw
   error of R̂, ``heading_handover``, ``handover_end_share``). A sole that turns on the ground with no still sole to
   hand over from — its world yaw rate, R̂ (ω + the leg kinematics' rate) low-passed at ``turn_cutoff_hz``, above
   ``turn_rate``, e.g. both feet pivoting under a jump's landing impact — is re-anchored from R̂ on every sample
   until it stops turning: its heading then follows the gyro instead of pulling R̂ back to the heading it had at
   touch-down. The base angular velocity is the bias-corrected gyro.
3. **Leg kinematics** (Pinocchio, base at the origin with orientation R̂): for each sole i its position rᵢ relative
   to the base (world axes), its orientation, and the velocity it would have if the base did not translate,
   uᵢ = ω × rᵢ + R̂ Jᵢ(q) q̇ (``getFrameVelocity``, ``LOCAL_WORLD_ALIGNED``). The F/T reading gives the foot's
   ground reaction (:class:`~wbc.estimation.contact.FootForceSensor`) and its normal force; a
   :class:`~wbc.estimation.contact.ContactDetector` (hysteresis) decides contact. A foot that becomes a contact is
   anchored: aᵢ = p̂ + rᵢ (its world position, held while it stays in contact), its height set to the ground's
   when the ground is flat and of known height (``ground_height``).
4. **Base position and velocity** (world), a Kalman filter per axis on x = (p, ṗ) with the IMU acceleration as
   input and the leg odometry as measurement — the estimator of Flayols, Del Prete, Wensing, Mifsud, Benallegue,
   Mansard 2017, "Experimental evaluation of simple estimators for humanoid robots", IEEE-RAS Humanoids (Sec.
   III-C: IMU-driven prediction corrected by the kinematics of the feet in contact; a linear Kalman filter whose
   steady state is a complementary filter):

       prediction   a = R̂ aʸ + g,   p ← p + ṗ Δt + ½ a Δt²,   ṗ ← ṗ + a Δt,   P ← A P Aᵀ + Q
       measurement  z_p = Σᵢ wᵢ (aᵢ − rᵢ),   z_v = −Σᵢ wᵢ uᵢ   (the feet in contact do not move),
                    wᵢ = f_z,ᵢ / Σ f_z (normal-force weights)
       update       K = P (P + R)⁻¹,   x ← x + K (z − x),   P ← (I − K) P

   with A = [[1, Δt], [0, 1]], Q = σ_a² [[Δt⁴/4, Δt³/2], [Δt³/2, Δt²]], R = diag(σ_p², σ_v²), the same 2 × 2
   covariance for the three axes (isotropic noises). Without a foot in contact (a flight phase) only the
   prediction runs.

The estimated configuration is q = (p̂, quaternion of R̂ (x, y, z, w), encoder angles) and
v = (R̂ᵀ ṗ̂ (base frame, Pinocchio's convention), Ωʸ − b̂, filtered joint velocities). Every array is preallocated;
one update costs one ``forwardKinematics`` with velocities and a few 3-vectors.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.constants import SIDES
from wbc.estimation.attitude import ComplementaryAttitudeFilter
from wbc.estimation.contact import GRAVITY_VECTOR, ContactDetector, FootForceSensor
from wbc.exceptions import InvalidInputError
from wbc.geometry import check_flag, check_scalar

__all__ = ["JointStateFilter", "BaseKalmanFilter", "FloatingBaseEstimator"]


def _nonneg(value, what: str, positive: bool = False) -> float:
    """``value`` as a float, finite and ≥ 0 (> 0 with ``positive``) (:func:`wbc.geometry.check_scalar`)."""
    return check_scalar(value, what, "SI units, see the docstring", strict=positive)


class JointStateFilter:
    """Joint velocities from encoder angles (module docstring, step 1): a degree-2 fading-memory (g-h-k) filter
    of memory ``memory``, or with ``memory=None`` a backward difference then a first-order low-pass of corner
    ``cutoff_hz``.

    Args:
        n: number of joints. dt: sample period (s). cutoff_hz: corner frequency f_c (Hz, > 0) of the low-pass
            (used with ``memory=None``). memory: θ in [0, 1) of the g-h-k filter (None: the low-pass).

    Attributes:
        velocity: (n,) filtered velocity (rad/s).

    Raises:
        InvalidInputError: bad numbers.
    """

    def __init__(self, n: int, dt: float, cutoff_hz: float = 80.0, memory: float | None = None):
        self.dt = _nonneg(dt, "dt", positive=True)
        self.cutoff_hz = _nonneg(cutoff_hz, "cutoff_hz", positive=True)
        self.alpha = self.dt / (self.dt + 1.0 / (2.0 * math.pi * self.cutoff_hz))
        if memory is not None:
            memory = _nonneg(memory, "memory")
            if memory >= 1.0:
                raise InvalidInputError(f"memory must be in [0, 1), got {memory!r}")
        self.memory = memory
        th = 0.0 if memory is None else memory
        self._g, self._h, self._k = 1.0 - th**3, 1.5 * (1.0 - th) ** 2 * (1.0 + th), 0.5 * (1.0 - th) ** 3
        self.velocity = np.zeros(int(n))
        self._prev = np.zeros(int(n))  # low-pass: last angles; g-h-k: filtered angles
        self._raw = np.zeros(int(n))
        self._acc = np.zeros(int(n))
        self._started = False

    def reset(self, angles=None, velocity=None) -> None:
        """Start from ``angles`` (n,) rad (default: the next sample) and ``velocity`` (n,) rad/s (default 0), at
        zero acceleration."""
        self.velocity[:] = 0.0 if velocity is None else velocity
        self._acc[:] = 0.0
        self._started = angles is not None
        if angles is not None:
            self._prev[:] = angles

    def update(self, angles: np.ndarray) -> np.ndarray:
        """One sample of encoder angles (n,) rad → filtered velocities (n,) rad/s (the :attr:`velocity` array)."""
        if not self._started:
            self._prev[:] = angles
            self._started = True
            return self.velocity
        dt = self.dt
        if self.memory is None:
            np.subtract(angles, self._prev, out=self._raw)
            self._raw /= dt
            self.velocity += self.alpha * (self._raw - self.velocity)
            self._prev[:] = angles
            return self.velocity
        x, v, a, r = self._prev, self.velocity, self._acc, self._raw
        x += v * dt + (0.5 * dt * dt) * a  # prediction
        v += a * dt
        np.subtract(angles, x, out=r)  # residual
        x += self._g * r
        v += (self._h / dt) * r
        a += (2.0 * self._k / (dt * dt)) * r
        return self.velocity


class BaseKalmanFilter:
    """Linear Kalman filter of the base position p and velocity ṗ (world, m and m/s), one (p, ṗ) pair per axis,
    driven by the IMU acceleration and corrected by the leg odometry (module docstring, step 4).

    Args:
        dt: period (s). sigma_acc: input noise σ_a (m/s²). sigma_pos: σ_p (m). sigma_vel: σ_v (m/s).

    Attributes:
        p: (3,) position. velocity: (3,) ṗ. P: (2, 2) covariance of (p, ṗ) of each axis.

    Raises:
        InvalidInputError: bad numbers.
    """

    def __init__(self, dt: float, sigma_acc: float = 0.5, sigma_pos: float = 0.002, sigma_vel: float = 0.02):
        h = _nonneg(dt, "dt", positive=True)
        for val, what in ((sigma_acc, "sigma_acc"), (sigma_pos, "sigma_pos"), (sigma_vel, "sigma_vel")):
            _nonneg(val, what, positive=True)
        self.dt = h
        self._Q = sigma_acc**2 * np.array([[h**4 / 4, h**3 / 2], [h**3 / 2, h**2]])
        self._R = np.diag([sigma_pos**2, sigma_vel**2])
        self._A = np.array([[1.0, h], [0.0, 1.0]])
        self._I = np.eye(2)
        self._Sinv = np.zeros((2, 2))
        self._half_h2 = 0.5 * h * h
        self.p, self.velocity = np.zeros(3), np.zeros(3)
        self.P = np.diag([1e-6, 1e-4])

    def reset(self, p, velocity, P=None) -> None:
        """Start at p (3,) m, ṗ (3,) m/s with covariance P (2, 2) (default diag(1e-6 m², 1e-4 m²/s²))."""
        self.p[:] = p
        self.velocity[:] = velocity
        self.P = np.diag([1e-6, 1e-4]) if P is None else np.array(P, dtype=float)

    def predict(self, a: np.ndarray) -> None:
        """Propagate over dt with the world acceleration a (3,) m/s²."""
        h = self.dt
        self.p += self.velocity * h + self._half_h2 * a
        self.velocity += a * h
        A = self._A
        self.P = A @ self.P @ A.T + self._Q

    def correct(self, z_p: np.ndarray, z_v: np.ndarray) -> None:
        """Update with a measured position z_p (3,) m and velocity z_v (3,) m/s."""
        (s00, s01), (s10, s11) = (self.P + self._R).tolist()
        det = s00 * s11 - s01 * s10
        Si = self._Sinv
        Si[:] = ((s11 / det, -s01 / det), (-s10 / det, s00 / det))
        K = self.P @ Si  # P S⁻¹ (2 × 2)
        (k00, k01), (k10, k11) = K.tolist()
        ep = z_p - self.p
        ev = z_v - self.velocity
        self.p += k00 * ep + k01 * ev
        self.velocity += k10 * ep + k11 * ev
        self.P = (self._I - K) @ self.P


class FloatingBaseEstimator:
    """Base pose and velocity of a humanoid from its encoders, IMU and ankle F/T sensors (module docstring).

    Args:
        robot: the :class:`~wbc.robot.Robot` (Pinocchio model, sole frames).
        dt: sample period (s).
        velocity_memory: memory θ in [0, 1) of the joint-velocity g-h-k filter (module docstring, step 1; None:
            the low-pass of corner ``velocity_cutoff_hz``, the default).
        velocity_cutoff_hz: joint-velocity low-pass corner (Hz), used with ``velocity_memory=None``.
        k_p, k_i, accel_gate: attitude filter gains (:class:`~wbc.estimation.attitude.ComplementaryAttitudeFilter`).
        contact_on, contact_off: contact hysteresis thresholds as fractions of the robot's weight
            (0 ≤ off < on).
        sigma_acc: IMU acceleration input noise σ_a (m/s², includes the tilt error of R̂ g).
        sigma_pos: leg-odometry position noise σ_p (m). sigma_vel: leg-odometry velocity noise σ_v (m/s).
        accel_cutoff_hz: corner (Hz) of the low-pass on the differenced leg-odometry velocity, the base
            acceleration removed from the accelerometer before the tilt correction.
        heading_weight: weight k of the anchored soles' forward axes in the attitude filter, as reference
            directions and as heading (yaw-only) directions there (≥ 0; 0: gravity alone, yaw then follows the gyro).
        k_heading, k_heading_bias: the attitude filter's yaw gains for those axes (rad/s and 1/s², ≥ 0;
            :class:`~wbc.estimation.attitude.ComplementaryAttitudeFilter`).
        heading_handover: a sole touching down while the other is anchored takes its heading (v₀) from that
            sole's through the leg kinematics while both are in contact (True), or from R̂ when it touches down
            (False: R̂'s yaw error, the integral of the gyro's yaw bias, is then locked into each new anchor). On
            flat ground (``ground_height`` not None) the soles' forward axes are horizontal and the hand-over
            turns the other sole's axis about the vertical. On uneven ground (None) the new sole's orientation is
            R̂'s (world ← sole: its tilt) turned about the vertical to the heading that the other sole's anchored
            orientation gives it through the two soles' relative orientation from the leg kinematics: the heading
            passes from sole to sole, the tilt does not (a sole rocking on a bump would pass its tilt on).
            ``wbc sim walk --blind`` turns it off (blind over rough ground the soles land on unknown bumps; the
            blind walks in benchmarks/README.md).
        handover_end_share: the hand-over also ends once the sole it comes from carries at most this share of the
            two soles' normal force (in [0, 1); default 0: it runs until that sole's contact ends. A sole that
            lands fast takes the larger share in its first sample, and ending there locked the yaw it still turned
            while settling, about 0.1° per step on Talos, into every later anchor).
        turn_rate: world yaw rate (rad/s, > 0) above which a sole in contact counts as turning on the ground and
            takes its heading from R̂ (module docstring, step 2).
        turn_cutoff_hz: corner (Hz, > 0) of the low-pass on that yaw rate (encoder differencing noise).
        ground_height: height (m, world) of flat ground: a sole becoming a contact is anchored at that height
            (its x, y come from the odometry). None: the anchor's height is odometry too (uneven ground) — it then
            drifts by the contact's compression under load at every step (≈ 1 mm per step on MuJoCo's soft
            contacts, Talos), as x and y do by the feet's rolling.

    Attributes (after :meth:`update`):
        q: (nq,) estimated configuration. v: (nv,) estimated velocity (Pinocchio conventions).
        contact: {side: bool}. turning: {side: bool}, the sole turns on the ground (``turn_rate``).
        sole_yaw_rate: (2,) low-passed world yaw rate of the (left, right) sole (rad/s).
        wrench: (2, 6) ground reaction per foot (sole frame, sole axes).
        sole: {side: pin.SE3} estimated world placement of each sole (overwritten by the next update).
        velocity_world: (3,) ṗ̂ (m/s, world).

    Raises:
        InvalidInputError: bad numbers (here and on :meth:`reset`).
    """

    def __init__(self, robot, dt: float, *, velocity_memory: float | None = None,
                 velocity_cutoff_hz: float = 80.0, k_p: float = 0.2, k_i: float = 0.01,
                 accel_gate: float = 2.0, contact_on: float = 0.2, contact_off: float = 0.08,
                 sigma_acc: float = 0.5, sigma_pos: float = 0.002, sigma_vel: float = 0.02,
                 accel_cutoff_hz: float = 10.0, ground_height: float | None = 0.0, heading_weight: float = 1.0,
                 heading_handover: bool = True, k_heading: float = 0.5, k_heading_bias: float = 0.1,
                 handover_end_share: float = 0.0, turn_rate: float = 0.05, turn_cutoff_hz: float = 10.0):
        self.robot = robot
        model = robot.model
        self.model, self.data = model, model.createData()
        self.dt = _nonneg(dt, "dt", positive=True)
        nj = model.nv - 6
        self.joints = JointStateFilter(nj, self.dt, velocity_cutoff_hz, velocity_memory)
        self.attitude = ComplementaryAttitudeFilter(self.dt, k_p=k_p, k_i=k_i, accel_gate=accel_gate,
                                                    k_heading=k_heading, k_heading_bias=k_heading_bias)
        weight = robot.mass * robot.gravity
        self.detectors = {s: ContactDetector(contact_on * weight, contact_off * weight) for s in SIDES}
        self.ft = {s: FootForceSensor(robot, getattr(robot, f"{s}_sole")) for s in SIDES}
        if ground_height is not None:
            ground_height = _nonneg(abs(ground_height), "ground_height") * np.sign(ground_height)
        self.ground_height = ground_height
        self.kf = BaseKalmanFilter(self.dt, sigma_acc, sigma_pos, sigma_vel)
        # joint angle → q maps (1-DoF joints; continuous joints as (cos, sin))
        one, cs_q, cs_j = [], [], []
        for i in range(2, model.njoints):
            jm = model.joints[i]
            if jm.nv != 1:
                raise InvalidInputError(f"joint {model.names[i]!r} has {jm.nv} DoF; the estimator needs 1-DoF joints")
            (one if jm.nq == 1 else cs_q).append(jm.idx_q)
            if jm.nq == 2:
                cs_j.append(jm.idx_v - 6)
        self._q_one = np.array(one, dtype=int)
        self._j_one = np.array([model.joints[i].idx_v - 6 for i in range(2, model.njoints)
                                if model.joints[i].nq == 1], dtype=int)
        self._q_cs, self._j_cs = np.array(cs_q, dtype=int), np.array(cs_j, dtype=int)
        self.q = pin.neutral(model)
        self.v = np.zeros(model.nv)
        self._qk = pin.neutral(model)  # kinematic configuration: base at the origin, identity orientation
        self._vk = np.zeros(model.nv)
        self.p = self.kf.p
        self.velocity_world = self.kf.velocity
        self.anchor = {s: np.zeros(3) for s in SIDES}
        self.anchor_axis = {s: np.array([1.0, 0.0, 0.0]) for s in SIDES}
        self._anchor_rotation = {s: np.eye(3) for s in SIDES}  # uneven ground: world ← sole of each anchor
        self.heading_weight = _nonneg(heading_weight, "heading_weight")
        self.heading_handover = check_flag(heading_handover, "heading_handover")
        self.handover_end_share = _nonneg(handover_end_share, "handover_end_share")
        if self.handover_end_share >= 1.0:
            raise InvalidInputError(f"handover_end_share must be in [0, 1), got {handover_end_share!r}")
        self.turn_rate = _nonneg(turn_rate, "turn_rate", positive=True)
        self._alpha_turn = self.dt / (self.dt + 1.0 / (2.0 * math.pi * _nonneg(turn_cutoff_hz, "turn_cutoff_hz", True)))
        self.sole_yaw_rate = np.zeros(2)  # low-passed world yaw rate of each sole (rad/s), gyro + leg kinematics
        self.turning = {s: False for s in SIDES}
        self.contact = {s: False for s in SIDES}
        self._handover_from = {s: None for s in SIDES}  # the anchored sole a new sole takes its heading from
        self.normal_force = {s: 0.0 for s in SIDES}
        self.wrench = np.zeros((2, 6))
        self.sole = {s: pin.SE3.Identity() for s in SIDES}
        self._X = pin.SE3.Identity()  # the estimated base rotation, for its quaternion (update)
        self._u = np.zeros((2, 3))
        self._zv, self._zv_prev, self._f_grav = np.zeros(3), np.zeros(3), np.zeros(3)
        self._have_zv = False
        self.acc_kin = np.zeros(3)
        self._beta = self.dt / (self.dt + 1.0 / (2.0 * math.pi * _nonneg(accel_cutoff_hz, "accel_cutoff_hz", True)))
        # per-sample work arrays (update)
        self._has_cs = len(self._q_cs) > 0
        self._vk_base, self._vk_joints = self._vk[3:6], self._vk[6:]
        self._sole_rot, self._sole_pos, self._r_world = [None, None], [None, None], [None, None]
        self._zp, self._zvw = np.zeros(3), np.zeros(3)

    def reset(self, q0, v0=None) -> None:
        """Start at configuration ``q0`` (nq,) (it defines the world frame of the odometry: its base position and
        orientation are taken as known) and velocity ``v0`` (nv,) (default at rest); contacts start open and are
        detected from the first F/T sample.

        Raises:
            InvalidInputError: wrong shapes or non-finite values.
        """
        model = self.model
        q0 = np.asarray(q0, dtype=float)
        if q0.shape != (model.nq,) or not np.all(np.isfinite(q0)):
            raise InvalidInputError(f"q0 must be a finite ({model.nq},) configuration, got shape {q0.shape}")
        v0 = np.zeros(model.nv) if v0 is None else np.asarray(v0, dtype=float)
        if v0.shape != (model.nv,) or not np.all(np.isfinite(v0)):
            raise InvalidInputError(f"v0 must be a finite ({model.nv},) velocity, got shape {v0.shape}")
        quat = q0[3:7] / np.linalg.norm(q0[3:7])
        R = pin.Quaternion(quat[3], quat[0], quat[1], quat[2]).toRotationMatrix()
        self.attitude.reset(R)
        self.kf.reset(q0[0:3], R @ v0[0:3])
        self.q[:] = q0
        self.v[:] = v0
        angles = np.empty(model.nv - 6)
        angles[self._j_one] = q0[self._q_one]
        if len(self._q_cs):
            angles[self._j_cs] = np.arctan2(q0[self._q_cs + 1], q0[self._q_cs])
        self.joints.reset(angles, v0[6:])
        self._have_zv = False
        self.acc_kin[:] = 0.0
        for s in SIDES:
            self.detectors[s].active = False
            self._handover_from[s] = None
            self.contact[s] = False
            self.turning[s] = False
        self.sole_yaw_rate[:] = 0.0

    def update(self, joint_q: np.ndarray, gyro: np.ndarray, accel: np.ndarray, ft: np.ndarray):
        """One sample of the sensors → ``(q, v)`` (the :attr:`q`, :attr:`v` arrays, overwritten next call).

        Args:
            joint_q: (nv − 6,) encoder angles (rad), Pinocchio's ``v[6:]`` order.
            gyro: (3,) rad/s and accel: (3,) m/s² (specific force), base axes.
            ft: (2, 6) (left, right) ankle F/T readings (:mod:`wbc.estimation.contact` convention).
        """
        model, data, dt = self.model, self.data, self.dt
        vj = self.joints.update(joint_q)
        att = self.attitude
        # Leg kinematics in the base frame (base at the origin, identity orientation, angular velocity ω of the
        # last sample, no base translation); world axes are R̂ times these.
        qk = self._qk
        qk[self._q_one] = joint_q[self._j_one]
        if self._has_cs:
            qk[self._q_cs] = np.cos(joint_q[self._j_cs])
            qk[self._q_cs + 1] = np.sin(joint_q[self._j_cs])
        np.subtract(gyro, att.bias, out=self._vk_base)
        self._vk_joints[:] = vj
        pin.forwardKinematics(model, data, qk, self._vk)
        R_prev = att.rotation
        fz_total, zv = 0.0, self._zv
        zv[:] = 0.0
        # each sole's placement in the base frame (views of data.oMf, valid until the next forwardKinematics)
        rot, pos = self._sole_rot, self._sole_pos
        contact, normal_force, yaw_rate = self.contact, self.normal_force, self.sole_yaw_rate
        for j, s in enumerate(SIDES):
            sensor = self.ft[s]
            X = pin.updateFramePlacement(model, data, sensor.frame_id)
            rot[j], pos[j] = X.rotation, X.translation
            Rw = R_prev @ rot[j]
            w = sensor.ground_wrench(ft[j], Rw)
            self.wrench[j] = w
            fz = float(Rw[2] @ w[0:3])
            normal_force[s] = fz
            vel = pin.getFrameVelocity(model, data, sensor.frame_id, pin.LOCAL_WORLD_ALIGNED)
            u = self._u[j]
            u[:] = vel.linear
            wz = float(R_prev[2] @ vel.angular)  # the sole's world yaw rate (base angular velocity included)
            y = float(yaw_rate[j])
            y += self._alpha_turn * (wz - y)
            yaw_rate[j] = y
            self.turning[s] = abs(y) > self.turn_rate
            if contact[s] and fz > 0:
                zv -= fz * u
                fz_total += fz
        # Base acceleration from the leg kinematics (differenced, low-passed): it is removed from the
        # accelerometer's specific force so that the attitude filter sees gravity alone.
        acc_kin = self.acc_kin
        if fz_total > 0:
            zv /= fz_total
            zw = R_prev @ zv
            if self._have_zv:
                beta = self._beta
                acc_kin[:] = [a + beta * ((z - z1) / dt - a)
                              for a, z, z1 in zip(acc_kin.tolist(), zw.tolist(), self._zv_prev.tolist())]
            self._zv_prev[:] = zw
            self._have_zv = True
        else:
            self._have_zv = False
            acc_kin *= 1.0 - self._beta
        self._f_grav[:] = accel - R_prev.T @ acc_kin
        dirs = []
        if self.heading_weight > 0 and fz_total > 0:  # the anchored soles' forward axes (leg kinematics)
            for j, s in enumerate(SIDES):
                fz = normal_force[s]
                if contact[s] and fz > 0:
                    dirs.append((self.anchor_axis[s], rot[j][:, 0], self.heading_weight * fz / fz_total))
        att.update(gyro, self._f_grav, dirs, heading=dirs)
        R = att.rotation
        omega = att.omega
        # Prediction with the IMU acceleration.
        kf = self.kf
        kf.predict(R @ accel + GRAVITY_VECTOR)
        p, pd = kf.p, kf.velocity
        # Contacts and leg odometry.
        zp, zvw, r_world = self._zp, self._zvw, self._r_world
        zp[:] = 0.0
        zvw[:] = 0.0
        total = 0.0
        newly = []
        for j, s in enumerate(SIDES):
            fz = normal_force[s]
            was = contact[s]
            now = self.detectors[s].update(fz)
            contact[s] = now
            r = r_world[j] = R @ pos[j]
            if now and not was:
                newly.append((s, j, r))
            if now and was:
                wgt = max(fz, 0.0)
                zp += wgt * (self.anchor[s] - r)
                zvw -= wgt * (R @ self._u[j])
                total += wgt
        if total > 0:
            zp /= total
            zvw /= total
            kf.correct(zp, zvw)
        for s, j, r in newly:
            self.anchor[s] = p + r
            self._handover_from[s] = None
            axis = R @ rot[j][:, 0]
            if self.ground_height is not None:
                self.anchor[s][2] = self.ground_height
                axis[2] = 0.0  # a sole flat on flat ground: its forward axis is horizontal
            else:
                np.matmul(R, rot[j], out=self._anchor_rotation[s])
            o = "right" if s == "left" else "left"
            if self.heading_handover and contact[o] and self._handover_from[o] is None:
                self._handover_from[s] = o
            self.anchor_axis[s] = axis / math.sqrt(axis @ axis)
        for j, s in enumerate(SIDES):
            if contact[s] and self.turning[s] and self._handover_from[s] is None:
                # A sole turning on the ground (a landing's impact pivots it; no still sole to hand over from):
                # its heading is re-anchored from R̂ (the gyro's) on every sample until it stops turning.
                axis = R @ rot[j][:, 0]
                if self.ground_height is not None:
                    axis[2] = 0.0
                else:
                    np.matmul(R, rot[j], out=self._anchor_rotation[s])
                self.anchor_axis[s] = axis / math.sqrt(axis @ axis)
        for j, s in enumerate(SIDES):
            o = self._handover_from[s]
            if o is None:
                continue
            if not (contact[s] and contact[o]):
                self._handover_from[s] = None
                continue
            # Heading handed over from the other anchored sole through the leg kinematics, not through R̂ (the
            # yaw error the gyro bias built up is then not locked into the new anchor), on every sample from
            # the first contact until the new sole carries the larger share of the load: a sole still turns as
            # it settles after its first contact, the one it takes over from is loaded and flat.
            axis = self.anchor_axis[s]
            Xo = rot[1 - j]  # the other sole o
            if self.ground_height is not None:  # both soles level: the other's anchored axis turned about z
                rel = Xo.T @ rot[j][:, 0]
                ca, sa = self.anchor_axis[o][0], self.anchor_axis[o][1]
                axis[0], axis[1], axis[2] = ca * rel[0] - sa * rel[1], sa * rel[0] + ca * rel[1], 0.0
            else:  # uneven ground: the tilt of R̂'s world ← sole s, turned about z to the heading of
                # (world ← sole o, anchored) (sole o ← sole s, leg kinematics)
                Xs = rot[j]
                chain = self._anchor_rotation[o] @ (Xo.T @ Xs[:, 0])
                Rs = self._anchor_rotation[s]
                np.matmul(R, Xs, out=Rs)
                turn = math.atan2(chain[1], chain[0]) - math.atan2(Rs[1, 0], Rs[0, 0])
                c, sn = math.cos(turn), math.sin(turn)
                Rs[0], Rs[1] = c * Rs[0] - sn * Rs[1], sn * Rs[0] + c * Rs[1]
                axis[:] = Rs[:, 0]
            axis /= math.sqrt(axis @ axis)
            fs, fo = max(normal_force[s], 0.0), max(normal_force[o], 0.0)
            if fo <= self.handover_end_share * (fs + fo):
                self._handover_from[s] = None  # the old sole has handed over its load: the new heading is held
        for j, s in enumerate(SIDES):
            X = self.sole[s]
            X.rotation = R @ rot[j]
            X.translation = r_world[j] + p
        # Outputs.
        q, v = self.q, self.v
        q[0:3] = p
        # (pin.Quaternion(R), built from a matrix, leaks 80 B of C heap per call with eigenpy 3.12: 2.4 MB per
        # minute at 500 Hz; SE3ToXYZQUAT gives the same (x, y, z, w) without it)
        X = self._X
        X.rotation = R
        q[3:7] = pin.SE3ToXYZQUAT(X)[3:]
        q[7:] = qk[7:]
        v[0:3] = R.T @ pd
        v[3:6] = omega
        v[6:] = vj
        return q, v
