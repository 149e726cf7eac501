"""Joint position / velocity / viability bounds on the joint accelerations of the inverse-dynamics QP (eq. 9 of
:mod:`wbc.formulations.acceleration`; del Prete 2018, IEEE RA-L 3(1):281–288, §III–IV), relaxable.
"""

from __future__ import annotations

from typing import NamedTuple

import numba as nb
import numpy as np

from wbc.compiled import CHECK_TYPES, once_per_process, specialise
from wbc.constraints.base import IDConstraint
from wbc.constraints.contact_acceleration import contact_acceleration_rows
from wbc.constraints.floating_base import contact_force_columns, floating_base_rows
from wbc.constraints.torque_limits import torque_limit_rows
from wbc.exceptions import InvalidInputError
from wbc.geometry import check_scalar
from wbc.robot import Robot
from wbc.state import DynamicsState

__all__ = ["JointAccelerationLimits", "JointRange", "drive_braking", "joint_acceleration_bounds", "joint_bounds_kernel"]


class JointAccelerationLimits(IDConstraint):
    """Joint position / velocity / viability bounds on the 1-DoF joint accelerations (eq. 9; rad/s²).

    Args:
        robot: the robot. braking_acceleration: a_brk (rad/s²), > 0.

    Attributes:
        braking_acceleration: a_brk (rad/s², finite, > 0), validated on assignment too.
        speed_horizon: h (ticks, finite, ≥ 1) of the velocity term, validated on assignment too.
        joint_braking: (dim,) per-joint braking accelerations (rad/s², > 0, default ∞): joint j brakes at
            min(a_brk, joint_braking[j]), validated on assignment too (:func:`drive_braking`).

    Raises:
        InvalidInputError: a_brk not a finite number > 0; on assignment, h not a finite number ≥ 1.
    """

    name = "joint_limits"
    kind = "bounds"
    relaxable = True

    def __init__(self, robot: Robot, braking_acceleration: float = 50.0):
        self.braking_acceleration = braking_acceleration
        model = robot.model
        iq, iv = [], []
        for j in range(2, model.njoints):
            jm = model.joints[j]
            if jm.nq == 1 and jm.nv == 1:
                iq.append(jm.idx_q)
                iv.append(jm.idx_v)
        self.iq, self.iv = np.array(iq, dtype=np.int64), np.array(iv, dtype=np.int64)
        self.indices = self.iv
        self.dim = int(self.iv.size)
        self.qmin = np.asarray(model.lowerPositionLimit, dtype=float)[self.iq].copy()
        self.qmax = np.asarray(model.upperPositionLimit, dtype=float)[self.iq].copy()
        vmax = np.asarray(model.velocityLimit, dtype=float)[self.iv]
        self.vmax = np.where(vmax > 0, vmax, np.inf)
        self.speed_horizon = 1.0  # (joint_acceleration_bounds)
        self._lo = np.empty(self.dim)
        self._hi = np.empty(self.dim)
        self._joint_braking = np.full(self.dim, np.inf)  # (joint_braking; read in place by the compiled tick)
        self._pos = {int(i): k for k, i in enumerate(self.iv)}
        self._joints = JointRange(self.iq, self.iv, self.qmin, self.qmax, self.vmax, self._joint_braking)
        _warm_up()
        # bounds' compiled call: these arrays, of fixed types, and a state's q, v of any strides
        # (wbc.compiled.specialise; with kernel type checks on, the dispatcher)
        self._kernel = joint_bounds_kernel if CHECK_TYPES else specialise(
            joint_bounds_kernel, _strided(1), _strided(1), self._joints, 1.0, 1e-3, 1.0, self._lo, self._hi)

    @property
    def joint_braking(self) -> np.ndarray:
        """(dim,) per-joint braking accelerations (rad/s², > 0; ``math.inf``: a_brk alone), in the order of
        ``iv``: joint j brakes at min(a_brk, joint_braking[j]). The array the compiled tick reads: an assignment
        is validated and copied into it.

        Raises:
            InvalidInputError: on assignment, another shape or an entry not > 0 (NaN included).
        """
        return self._joint_braking

    @joint_braking.setter
    def joint_braking(self, values) -> None:
        a = np.asarray(values, dtype=float)
        if a.shape != (self.dim,) or not (a > 0).all():
            raise InvalidInputError(f"joint_braking must be ({self.dim},) numbers > 0 rad/s² (math.inf: a_brk "
                                    f"alone), got {values!r}")
        self._joint_braking[:] = a

    def braking_at(self, iv: np.ndarray, cap: float = np.inf) -> np.ndarray:
        """(len(iv),) min(``cap``, a_brk, the joint's braking) (rad/s²) of the joints of velocity indices ``iv`` (each
        a joint of these limits): the floor with which the relaxed QP's speed bounds contain these bounds."""
        return np.minimum(min(cap, self._braking), self._joint_braking[[self._pos[int(i)] for i in iv]])

    @property
    def braking_acceleration(self) -> float:
        """a_brk (rad/s², finite, > 0): the viability bound's braking acceleration."""
        return self._braking

    @braking_acceleration.setter
    def braking_acceleration(self, value) -> None:
        self._braking = check_scalar(value, "braking_acceleration", "rad/s²", strict=True)

    @property
    def speed_horizon(self) -> float:
        """h (ticks, finite, ≥ 1) over which the velocity term lets a joint reach ±vmax (joint_acceleration_bounds)."""
        return self._horizon

    @speed_horizon.setter
    def speed_horizon(self, value) -> None:
        self._horizon = check_scalar(value, "speed_horizon", "ticks", minimum=1.0)

    def bounds(self, state: DynamicsState, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) (dim,) at ``state`` (arrays reused across calls): :func:`joint_acceleration_bounds`."""
        self._kernel(state.q, state.v, self._joints, float(self.braking_acceleration), float(dt),
                     float(self.speed_horizon), self._lo, self._hi)
        return self._lo, self._hi

    def write(self, ctx, _, lb, ub):
        lo, hi = self.bounds(ctx.state, ctx.dt)
        lb[:] = lo
        ub[:] = hi


class JointRange(NamedTuple):
    """The k limited 1-DoF joints of :func:`joint_bounds_kernel`."""

    iq: np.ndarray    #: (k,) int64 configuration indices
    iv: np.ndarray    #: (k,) int64 velocity indices
    qmin: np.ndarray  #: (k,) lower position limits (rad)
    qmax: np.ndarray  #: (k,) upper position limits (rad)
    vmax: np.ndarray  #: (k,) speed limits (rad/s, inf when unlimited)
    brake: np.ndarray  #: (k,) per-joint braking accelerations (rad/s², > 0; inf: the common a_brk alone)


@nb.njit(cache=True, nogil=True)
def joint_bounds_kernel(q, v, joints, a_max, dt, horizon, lo_out, hi_out):
    """Compiled :func:`joint_acceleration_bounds` (the numbers of eq. 9, joint by joint) of the ``joints``
    (:class:`JointRange`), written into lo_out, hi_out (k,); the velocity term approaches ±vmax over ``horizon``
    ticks; joint j brakes at min(``a_max``, its ``brake``)."""
    iq, iv, qmin, qmax, vmax, brake = joints
    dt2 = dt * dt
    dth = dt * horizon
    for j in range(iq.size):
        a = min(a_max, brake[j])
        qj = q[iq[j]]
        vj = v[iv[j]]
        q1 = qj + vj * dt
        d_hi = qmax[j] - q1
        d_lo = q1 - qmin[j]
        hi = min((vmax[j] - vj) / dth, 2.0 * d_hi / dt2)
        lo = max((-vmax[j] - vj) / dth, -2.0 * d_lo / dt2)
        # viability: larger root of dt² x² + B x + (w² − 2 a d) = 0, mirrored for the lower limit
        w = vj
        B = 2.0 * w * dt + a * dt2
        disc = max(B * B - 4.0 * dt2 * (w * w - 2.0 * a * d_hi), 0.0)
        hi = min(hi, (-B + np.sqrt(disc)) / (2.0 * dt2))
        w = -vj
        B = 2.0 * w * dt + a * dt2
        disc = max(B * B - 4.0 * dt2 * (w * w - 2.0 * a * d_lo), 0.0)
        lo = max(lo, -((-B + np.sqrt(disc)) / (2.0 * dt2)))
        hi = max(hi, -a)
        lo = min(lo, a)
        lo_out[j] = min(lo, hi)
        hi_out[j] = hi


def drive_braking(model, iv: np.ndarray, share: float, q: np.ndarray, tau_max: np.ndarray | None = None) -> np.ndarray:
    """(len(iv),) braking accelerations (rad/s²) the drives of the joints of velocity indices ``iv`` can give at the
    configuration ``q`` (nq,): ``share`` × τ_max / M_jj(q), the joint's torque limit (``tau_max`` (len(iv),) N·m, a
    QP's possibly scaled limits; default the URDF's) over its own inertia
    (the diagonal of the joint-space mass matrix, rotor armature included when ``model.armature`` has it; the other
    joints held); ``math.inf`` for a joint without a positive torque limit. The remaining 1 − ``share`` of the torque
    is left to gravity and to the other joints' accelerations. A viability bound that assumes more braking than the
    drive gives (eq. 9 with one a_brk for every joint; Talos's shoulder roll gives 16.5 rad/s² at most against the
    common 50) lets the joint reach a speed or a position from which the full QP cannot stop it within the torque
    limits: the full QP is infeasible and the relaxed one, without torque and joint limits, drives the joint on
    (benchmarks/records/75).

    Raises:
        InvalidInputError: ``share`` not in (0, 1].
    """
    import pinocchio as pin

    if isinstance(share, bool) or not isinstance(share, (int, float, np.floating)) or not 0.0 < share <= 1.0:
        raise InvalidInputError(f"share must be a number in (0, 1], got {share!r}")
    mii = np.diag(pin.crba(model, model.createData(), np.asarray(q, dtype=float)))[iv]
    tau = np.asarray(model.effortLimit if tau_max is None else tau_max, dtype=float)
    tau = tau[iv] if tau_max is None else tau
    return np.where(tau > 0, share * tau / np.where(tau > 0, mii, 1.0), np.inf)


def joint_acceleration_bounds(q, v, iq, iv, qmin, qmax, vmax, braking_acceleration: float, dt: float, *,
                              lo: np.ndarray | None = None, hi: np.ndarray | None = None, speed_horizon: float = 1.0,
                              joint_braking: np.ndarray | None = None):
    """(lo, hi) joint acceleration bounds (rad/s²) of eq. 9 (position, velocity and viability with braking
    acceleration a_brk; del Prete 2018, IEEE RA-L 3(1):281–288, §III–IV) for the 1-DoF joints with configuration
    indices ``iq`` and velocity indices ``iv`` (limits qmin, qmax (rad), vmax (rad/s, inf when unlimited)).
    The velocity term is (±vmax − v) / (h dt), h = ``speed_horizon`` (ticks, ≥ 1; 1: eq. 9's one-tick bound; see
    :class:`~wbc.constraints.joint_velocity.JointSpeedBounds` for h > 1); joint j brakes at min(a_brk,
    ``joint_braking[j]``) (rad/s²; None: a_brk). Written into ``lo``/``hi`` when given."""
    k = len(iq)
    lo = np.empty(k) if lo is None else lo
    hi = np.empty(k) if hi is None else hi
    brake = np.full(k, np.inf) if joint_braking is None else np.asarray(joint_braking, dtype=float)
    joint_bounds_kernel(q, v, JointRange(iq, iv, qmin, qmax, vmax, brake), float(braking_acceleration), float(dt),
                        float(speed_horizon), lo, hi)
    return lo, hi


@once_per_process
def _warm_up() -> None:
    """Load the compiled row bodies (on-disk cache) once per process, at construction of
    :class:`JointAccelerationLimits`, not inside a controller's first tick: on arrays of the types of a real call (M
    column-major as a :class:`~wbc.state.DynamicsState`'s, the rest C-contiguous)."""
    z, i = np.zeros(1), np.zeros(1, dtype=np.int64)
    joints = JointRange(i, i, -np.ones(1), np.ones(1), np.ones(1), np.ones(1))
    for q, v in ((z, z), (_strided(1), _strided(1))):  # (JointAccelerationLimits.bounds: q, v of any strides)
        joint_bounds_kernel(q, v, joints, 1.0, 1e-3, 1.0, np.empty(1), np.empty(1))
    nv = 7
    M, h, v = np.asfortranarray(np.eye(nv)), np.zeros(nv), np.zeros(nv)
    JcT, A, b = np.zeros((nv, 12)), np.zeros((12, nv + 12)), np.zeros(12)
    contact_force_columns(np.zeros((6, nv)), np.zeros((6, 12)), JcT, 0)
    floating_base_rows(M, h, JcT, A, b, 0)
    contact_acceleration_rows(np.zeros((6, nv)), np.zeros(6), 1.0, v, A, b, 6)
    torque_limit_rows(M, h, JcT, np.full(1, 6, dtype=np.int64), np.ones(1), A, b, b.copy(), 0)


def _strided(n: int) -> np.ndarray:
    """(max(n, 2),) zeros, strided (numba layout 'A': a version that reads arrays of any strides; numpy flags a
    strided array of one entry contiguous)."""
    return np.zeros(2 * max(n, 2))[::2]
