"""The state the controller reads in a closed loop: MuJoCo's ground truth, or an estimate from the plant's sensors.

:class:`EstimatedState` samples the sensors of :mod:`wbc.sim.sensors` (noise, bias, quantisation, rates) and runs
:class:`wbc.estimation.FloatingBaseEstimator` on them, once per control tick. :func:`estimation_errors` compares
a logged estimate with the logged ground truth.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.estimation import FloatingBaseEstimator, zmp_from_wrenches
from wbc.exceptions import InvalidInputError
from wbc.sim.sensors import PlantSensors, SensorSpecs

__all__ = ["EstimatedState", "estimation_errors", "STATE_SOURCES"]

STATE_SOURCES = ("estimated", "ground-truth")  #: values of ``wbc sim --state``


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
        soles = [est.sole["left"], est.sole["right"]]
        h = 0.0
        if self.terrain is not None:  # on the plane of the loaded soles (force-weighted height)
            f = np.maximum([est.normal_force["left"], est.normal_force["right"]], 0.0)
            if f.sum() > 0:
                h = float(f @ [X.translation[2] for X in soles] / f.sum())
        return zmp_from_wrenches(est.wrench, soles, min_fz, h)


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
