"""The state the controller reads in a closed loop: MuJoCo's ground truth, or an estimate from the plant's sensors.

:class:`EstimatedState` samples the sensors of :mod:`wbc.sim.sensors` (noise, bias, quantisation, rates) and runs
:class:`wbc.estimation.FloatingBaseEstimator` on them, once per control tick. :func:`estimation_errors` compares
a logged estimate with the logged ground truth.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
import pinocchio as pin

from wbc.compiled import CHECK_TYPES, once_per_process, specialise
from wbc.estimation import FloatingBaseEstimator
from wbc.exceptions import InvalidInputError
from wbc.sim.sensors import PlantSensors, SensorSpecs

__all__ = ["EstimatedState", "estimation_errors", "STATE_SOURCES"]

STATE_SOURCES = ("estimated", "ground-truth")  #: values of ``wbc sim --state``


@nb.njit(cache=True)
def _zmp_kernel(wrench, rot_left, pos_left, rot_right, pos_right, min_fz, height):
    """:func:`wbc.estimation.zmp_from_wrenches` of the two soles' wrenches ``wrench`` (2, 6) (sole axes) at the
    placements (``rot_*`` (3, 3), ``pos_*`` (3,)), element by element in its order: (found, x, y) (m, world), found
    False below ``min_fz`` N of total normal force."""
    F0 = F1 = F2 = M0 = M1 = M2 = 0.0
    for j in range(2):
        R = rot_left if j == 0 else rot_right
        t = pos_left if j == 0 else pos_right
        w = wrench[j]
        f0 = R[0, 0] * w[0] + R[0, 1] * w[1] + R[0, 2] * w[2]  # R f
        f1 = R[1, 0] * w[0] + R[1, 1] * w[1] + R[1, 2] * w[2]
        f2 = R[2, 0] * w[0] + R[2, 1] * w[1] + R[2, 2] * w[2]
        m0 = R[0, 0] * w[3] + R[0, 1] * w[4] + R[0, 2] * w[5]  # R m
        m1 = R[1, 0] * w[3] + R[1, 1] * w[4] + R[1, 2] * w[5]
        m2 = R[2, 0] * w[3] + R[2, 1] * w[4] + R[2, 2] * w[5]
        t0, t1, t2 = t[0], t[1], t[2]
        F0, F1, F2 = F0 + f0, F1 + f1, F2 + f2
        M0 += m0 + (t1 * f2 - t2 * f1)
        M1 += m1 + (t2 * f0 - t0 * f2)
        M2 += m2 + (t0 * f1 - t1 * f0)
    if F2 < min_fz:
        return False, 0.0, 0.0
    if height != 0.0:
        M0 += height * F1
        M1 -= height * F0
    return True, -M1 / F2, M0 / F2


@once_per_process
def _warm_up() -> None:
    """Load :func:`_zmp_kernel` (on-disk cache) once per process, for the estimator's sole rotations."""
    r = np.eye(3)
    _zmp_kernel(np.zeros((2, 6)), r, np.zeros(3), r, np.zeros(3), 10.0, 0.0)


class EstimatedState:
    """Sensors + estimator: ``measure(sim, t) -> (q, v)`` in Pinocchio conventions.

    Args:
        sim: a :class:`~wbc.sim.mujoco_runtime.MujocoModel` built with sensors.
        specs: sensor models (default :class:`~wbc.sim.sensors.SensorSpecs`).
        seed: noise seed.
        **estimator_options: passed to :class:`~wbc.estimation.FloatingBaseEstimator`.

    Raises:
        InvalidInputError: as :class:`~wbc.sim.sensors.PlantSensors` and the estimator.
    """

    name = "estimated"

    def __init__(self, sim, specs: SensorSpecs | None = None, *, seed: int = 0, **estimator_options):
        self.sensors = PlantSensors(sim, specs, seed=seed)
        self.terrain = getattr(sim, "terrain", None)
        if getattr(sim, "terrain", None) is not None and "ground_height" not in estimator_options:
            estimator_options["ground_height"] = None  # uneven ground: the contact anchors' heights are odometry
        self.estimator = FloatingBaseEstimator(sim.robot, sim.timestep, **estimator_options)
        est = self.estimator
        # the estimator's sole placements (its arrays, overwritten in place by every update): _zmp_kernel's inputs
        self._zmp_views = (est.sole_rotation[0], est.sole_position[0], est.sole_rotation[1], est.sole_position[1])
        _warm_up()
        # measured_zmp's compiled call: the estimator's arrays, of fixed types (wbc.compiled.specialise; with kernel
        # type checks on, the dispatcher)
        self._zmp = _zmp_kernel if CHECK_TYPES else specialise(_zmp_kernel, est.wrench, *self._zmp_views, 10.0, 0.0)

    def reset(self, q0, v0=None) -> None:
        """Restart the sensors' noise and the estimator at the known initial state (q0, v0)."""
        self.sensors.reset()
        self.estimator.reset(q0, v0)

    def measure(self, sim, t: float):
        """Sample the sensors (after ``mj_step1``) and update the estimate → ``(q (nq,), v (nv,))`` (overwritten
        by the next call)."""
        r = self.sensors.read(t, sim.data)
        return self.estimator.update(r.joint_q, r.gyro, r.accel, r.ft)

    def measured_normal_force(self) -> np.ndarray:
        """(2,) normal force (N) of the (left, right) sole measured by the ankle F/T sensors at the last sample
        (world vertical component of the foot's ground reaction, :attr:`FloatingBaseEstimator.normal_force`)."""
        nf = self.estimator.normal_force
        return np.array([nf["left"], nf["right"]])

    def measured_zmp(self, min_fz: float = 10.0) -> np.ndarray | None:
        """ZMP (2,) (m, world) of the last sample's F/T ground reactions at the estimated sole placements
        (:func:`wbc.estimation.zmp_from_wrenches`), None below ``min_fz`` N of total normal force. On a terrain
        plant, on the plane at the force-weighted height of the soles (else z = 0)."""
        est = self.estimator
        h = 0.0
        if self.terrain is not None:  # on the plane of the loaded soles (force-weighted height)
            f = np.maximum([est.normal_force["left"], est.normal_force["right"]], 0.0)
            if f.sum() > 0:
                h = float(f @ [est.sole_position[0, 2], est.sole_position[1, 2]] / f.sum())
        found, x, y = self._zmp(est.wrench, *self._zmp_views, float(min_fz), h)
        return np.array([x, y]) if found else None


def estimation_errors(q_true: np.ndarray, v_true: np.ndarray, q_est: np.ndarray, v_est: np.ndarray,
                      distance: float | None = None) -> dict:
    """Estimate vs ground truth over a run.

    Args:
        q_true, q_est: (N, nq) configurations; v_true, v_est: (N, nv) velocities (Pinocchio conventions).
        distance: distance walked (m) for the relative drift (None: not reported).

    Returns:
        ``base_position_drift_m`` (final ‖p̂ − p‖), ``max_base_position_error_m``, ``base_position_drift_percent``
        (of ``distance``), ``max_orientation_error_deg`` (angle of R̂ᵀR), ``final_orientation_error_deg``,
        ``max_tilt_error_deg`` (angle between the estimated and true vertical), ``base_velocity_rms_error_mps``
        and ``max_base_velocity_error_mps`` (world-frame base linear velocity), ``joint_velocity_rms_error``
        (rad/s, all joints and ticks).
    """
    n = len(q_true)
    if q_est.shape != q_true.shape or v_est.shape != v_true.shape or n == 0:
        raise InvalidInputError("estimate and ground truth must have the same non-empty shapes")
    ang = np.empty(n)
    tilt = np.empty(n)
    dv = np.empty(n)
    for k in range(n):
        R = pin.Quaternion(q_true[k, 6], *q_true[k, 3:6]).toRotationMatrix()
        Re = pin.Quaternion(q_est[k, 6], *q_est[k, 3:6]).normalized().toRotationMatrix()
        ang[k] = np.linalg.norm(pin.log3(Re.T @ R))
        tilt[k] = math.acos(min(1.0, float(R[2] @ Re[2]) / (np.linalg.norm(R[2]) * np.linalg.norm(Re[2]))))
        dv[k] = np.linalg.norm(R @ v_true[k, 0:3] - Re @ v_est[k, 0:3])
    dp = np.linalg.norm(q_est[:, 0:3] - q_true[:, 0:3], axis=1)
    out = {
        "base_position_drift_m": float(dp[-1]),
        "max_base_position_error_m": float(dp.max()),
        "max_orientation_error_deg": float(np.degrees(ang.max())),
        "final_orientation_error_deg": float(np.degrees(ang[-1])),
        "max_tilt_error_deg": float(np.degrees(tilt.max())),
        "base_velocity_rms_error_mps": float(np.sqrt(np.mean(dv**2))),
        "max_base_velocity_error_mps": float(dv.max()),
        "joint_velocity_rms_error": float(np.sqrt(np.mean((v_est[:, 6:] - v_true[:, 6:]) ** 2))),
    }
    if distance is not None and distance > 0:
        out["base_position_drift_percent"] = 100.0 * out["base_position_drift_m"] / distance
    return out
