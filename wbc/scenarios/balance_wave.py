"""``wave`` behaviour: both arms wave for 5 s while the feet stay fixed and the CoM is held.

Arm motion in joint space: the arms first move (minimum jerk, ``raise_time``) from the standing posture to a
"hand up" pose (offsets ``raise`` added to q_ref), then the ``wave`` joints oscillate
q = q_up + A·e(t)·sin(2π f t) for ``duration`` seconds, e(t) a cosine envelope rising over the first and falling
over the last ``ramp`` seconds (so velocity starts and ends at 0), then the arms return to the standing posture.
Left and right arms are mirror images (the sign of each offset / amplitude is given per joint).

Joint choices are per robot (:data:`WAVE_JOINTS`, keyed by catalog name); any other robot gets a generic
choice: every joint whose name contains the side ("left"/"right") and "shoulder_pitch" or "elbow", waved by
±0.3 rad about its reference. Amplitudes are clipped to stay 0.05 rad inside the joint limits.
The arm joints are tracked by a joint task (weight 1, gain 50, velocity feed-forward); the posture task follows
the same reference, so nothing pulls against it.
"""

from __future__ import annotations

import math

import numpy as np

from wbc.configuration import Configuration
from wbc.exceptions import InvalidInputError
from wbc.robot import Robot
from wbc.scenarios.framework import Criterion
from wbc.scenarios.balance import Behaviour, BalanceController, BalanceRun, JointTrackingTask, MinJerkPath

__all__ = ["WaveBehaviour", "WAVE_JOINTS"]

#: robot name → {"raise": {joint: offset rad}, "wave": {joint: amplitude rad}} (left side; the right side
#: mirrors: "left" → "right" in the name, sign flipped where the joint axis is mirrored).
WAVE_JOINTS: dict[str, dict[str, list[tuple[str, float, float]]]] = {
    # (left joint, left value, right sign)
    "talos": {  # abduct the upper arm, bend the elbow, rotate the upper arm to swing the forearm
        "raise": [("arm_left_2_joint", 0.4, -1.0), ("arm_left_4_joint", -1.2, 1.0)],
        "wave": [("arm_left_3_joint", 0.5, -1.0)],
    },
    "g1": {  # arm forward (pitch) and out (roll), forearm up (elbow < 0), swung sideways by the shoulder yaw
        "raise": [("left_shoulder_pitch_joint", -0.5, 1.0), ("left_shoulder_roll_joint", 0.3, -1.0),
                  ("left_elbow_joint", -1.0, 1.0)],
        "wave": [("left_shoulder_yaw_joint", 0.5, -1.0)],
    },
    "humanoid15": {  # arm forward, forearm up; waved with shoulder pitch and elbow
        "raise": [("left_shoulder_pitch", -0.6, 1.0), ("left_elbow", 1.0, 1.0)],
        "wave": [("left_shoulder_pitch", 0.3, 1.0), ("left_elbow", 0.4, 1.0)],
    },
}


def _mirror(name: str) -> str:
    return name.replace("left", "right").replace("Left", "Right").replace("LEFT", "RIGHT")


def wave_joints(robot: Robot) -> tuple[dict[str, float], dict[str, float]]:
    """({joint: raise offset}, {joint: wave amplitude}) for both arms (rad); see the module docstring.

    Raises:
        InvalidInputError: the robot has no suitable arm joints.
    """
    spec = WAVE_JOINTS.get(robot.name)
    raise_, wave = {}, {}
    if spec is not None:
        for out, key in ((raise_, "raise"), (wave, "wave")):
            for name, value, sign in spec[key]:
                out[name] = value
                out[_mirror(name)] = sign * value
    else:
        for name in robot.joint_names:
            low = name.lower()
            if ("left" in low or "right" in low) and ("shoulder_pitch" in low or "elbow" in low):
                wave[name] = 0.3
    if not wave:
        raise InvalidInputError(f"robot {robot.name!r}: no arm joints to wave (add it to WAVE_JOINTS)")
    return raise_, wave


class WaveBehaviour(Behaviour):
    """Both arms wave, feet fixed, CoM and torso held.

    Args:
        robot, config: see :class:`~wbc.scenarios.balance.Behaviour`.
        wave_time: waving time (s), the issue's 5 s.
        frequency: wave frequency (Hz).
        raise_time: time (s) to raise / lower the arms.
        ramp: envelope rise / fall time (s) within ``wave_time``.
        settle: pause (s) at the end.
    """

    name = "wave"

    def __init__(self, robot: Robot, config: Configuration, *, wave_time: float = 5.0, frequency: float = 1.0,
                 raise_time: float = 1.0, ramp: float = 0.5, settle: float = 0.3):
        super().__init__(robot, config)
        if min(wave_time, frequency, raise_time, settle) <= 0 or not 0 < 2 * ramp <= wave_time:
            raise InvalidInputError("wave durations and frequency must be > 0, with 2·ramp ≤ wave_time")
        model = robot.model
        self.q0 = config.q.copy()
        raise_, wave = wave_joints(robot)
        self.joints = sorted(set(raise_) | set(wave), key=robot.joint_names.index)
        q_up = self.q0.copy()
        for name, off in raise_.items():
            q_up[model.joints[robot.joint_id(name)].idx_q] += off
        self.idx_q = np.array([model.joints[robot.joint_id(n)].idx_q for n in wave])
        self.idx_v = np.array([model.joints[robot.joint_id(n)].idx_v for n in wave])
        lo = model.lowerPositionLimit[self.idx_q] + 0.05
        hi = model.upperPositionLimit[self.idx_q] - 0.05
        q_up = np.clip(q_up, model.lowerPositionLimit + 0.05, model.upperPositionLimit - 0.05)
        q_up[:7] = self.q0[:7]
        centre = q_up[self.idx_q]
        amp = np.array(list(wave.values()))
        self.amplitude = np.sign(amp) * np.minimum(np.abs(amp), np.minimum(hi - centre, centre - lo).clip(0))
        self.wave_names = list(wave)
        self.frequency, self.ramp, self.wave_time = frequency, ramp, wave_time
        self.t_wave = raise_time
        self.arm_path = MinJerkPath(self.q0[7:], [(raise_time, wave_time, q_up[7:]), (raise_time, settle, self.q0[7:])])
        self.duration = self.arm_path.end_time
        self.tracking: JointTrackingTask | None = None
        self._q = self.q0.copy()
        self._dq = np.zeros(model.nv)

    def setup(self, ctrl: BalanceController) -> None:
        self.tracking = JointTrackingTask(self.robot, joints=self.joints, weight=1.0, gain=50.0, name="arms")
        ctrl.controller.add_task(self.tracking)

    def _envelope(self, t: float) -> tuple[float, float]:
        tau = t - self.t_wave
        if tau <= 0 or tau >= self.wave_time:
            return 0.0, 0.0
        w = math.pi / self.ramp
        if tau < self.ramp:
            return 0.5 - 0.5 * math.cos(w * tau), 0.5 * w * math.sin(w * tau)
        if tau > self.wave_time - self.ramp:
            r = self.wave_time - tau
            return 0.5 - 0.5 * math.cos(w * r), -0.5 * w * math.sin(w * r)
        return 1.0, 0.0

    def reference(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(q* (nq,), q̇* (nv,)) of the arms at time t (other joints: the start posture, zero velocity)."""
        qa, dqa = self.arm_path(t)
        self._q[7:] = qa
        self._dq[6:] = dqa
        e, de = self._envelope(t)
        if e > 0 or de != 0:
            phase = 2 * math.pi * self.frequency * (t - self.t_wave)
            s, c = math.sin(phase), math.cos(phase)
            self._q[self.idx_q] += self.amplitude * e * s
            self._dq[self.idx_v] += self.amplitude * (de * s + e * 2 * math.pi * self.frequency * c)
        return self._q, self._dq

    def update(self, ctrl: BalanceController, t: float, config: Configuration) -> None:
        q, dq = self.reference(t)
        self.tracking.set_trajectory(q, dq)
        ctrl.posture.set_target(q)

    def summary(self, run: BalanceRun) -> dict:
        wave = (run.t >= self.t_wave + self.ramp) & (run.t <= self.t_wave + self.wave_time - self.ramp)
        q = run.q[wave][:, self.idx_q]
        achieved = 0.5 * (q.max(axis=0) - q.min(axis=0))
        return {
            "wave_joints": self.wave_names,
            "wave_amplitude_rad": {n: float(a) for n, a in zip(self.wave_names, np.abs(self.amplitude))},
            "wave_amplitude_ratio": float(np.min(achieved / np.abs(self.amplitude))),
            "wave_time_s": self.wave_time,
        }

    def criteria(self):
        return [
            Criterion("arms wave with ≥ 95% of the commanded amplitude", "wave_amplitude_ratio", ">=", 0.95),
            Criterion("arm joints tracked within 0.05 rad", "max_task_error_rad.arms", "<=", 0.05),
        ]
