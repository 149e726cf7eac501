"""More closed-loop MuJoCo scenarios (``wbc sim wave``) and the ID-QP options of robots whose two-foot contact
constraints are near rank deficient (``humanoid15``).

``wave`` (:class:`WaveScenario`): both arms go (minimum jerk, ``raise_time``) from the standing posture to the
"hand up" pose of :func:`wbc.scenarios.balance_wave.wave_joints`, the wave joints oscillate
q = q_up + A e(t) sin(2π f t) for ``wave_time`` s (e(t) a cosine envelope rising / falling over ``ramp`` s, so
the velocity starts and ends at 0), then the arms return (``raise_time``) and the robot holds ``settle`` s. The
reference goes, as position + acceleration feed-forward, to the balance controller's posture task and to an
extra joint task on the arm joints (``arms``: Kp ``arm_kp`` = 400 /s², Kd 2√Kp, weight ``arm_weight`` = 10, above
the posture and angular-momentum tasks, which would otherwise damp the swing); the CoM and the feet are held.
Pass: no fall, each sole within 2 cm of its start (MuJoCo ground truth), and the measured wave joints swept at
least half their commanded peak-to-peak range (the arms did wave).

Rank-deficient contacts: a robot without hip yaw joints (``humanoid15``) can hardly rotate one flat foot about
the vertical relative to the other (only through roll-pitch coupling), so the 12 rows of the two
sole-acceleration equalities are near rank deficient (smallest singular value 2e-18 at ``q_ref``). With the ID
QP's DAQP ``primal_tol`` of 1e-9, DAQP stops with exit flag -6 (overdetermined initial working set) on every
tick once the robot moves and the controller falls back to gravity compensation. :func:`id_options_for` gives
such robots DAQP with ``primal_tol`` 1e-6 and a 2 cm sole margin (``primal_tol`` alone tips the robot over the
sole edge at the unload; the runs behind the margin, which is marginal, are in ``benchmarks/README.md``,
"Measurement history moved out of docstrings").
Walking: at a touch-down the right-hand side of the two soles' rows is inconsistent along the dependent direction
(a relative foot yaw acceleration the legs cannot produce), which makes the QP infeasible. The ID QP keeps only
the well-conditioned directions of the two soles' rows (:func:`wbc.constraints.contact_acceleration.independent_contact_rows`,
σ < 1e-2 σ_max counts as dependent): a nearly dependent row kept as an equality, even with a consistent right-hand
side, forbids pitching or rolling the pelvis over the fixed feet (the direction of that row).

Walking sole margin (:func:`walk_options_for`): the walk's DCM stabilizer keeps its commanded CoP 1.5 cm inside the
soles, but it commands a CoM acceleration, and the QP's contact forces also carry the rate of the centroidal
angular momentum (swing leg, torso; the momentum task's weight is low): the CoP of the QP's forces — which the
plant's contact forces follow — differs from the stabilizer's and, with the controller's contact rectangle the
whole sole, sits on the sole edge (QP CoP margin 0, a corner force at 0: the foot on the verge of tipping). The
controller's sole rectangle is therefore shrunk by ``WALK_SOLE_MARGIN_FRACTION`` × the sole width per side while
walking, so the CoP it commands keeps that distance from the real sole's edges. That margin alone leaves a narrow
sole (G1's) no room for the swing leg's uncompensated angular momentum, so the centroidal angular-momentum task's
weight is raised from 0.1 to ``WALK_MOMENTUM_WEIGHT`` = 1 while walking (the upper body counters the swing leg,
Lee & Goswami 2012), which keeps the realised CoP nearer the stabilizer's. The walks behind both values are in
``benchmarks/README.md``, "Measurement history moved out of docstrings".
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.dynamics.balance import IDBalanceController
from wbc.formulations.reference import AccelerationReference
from wbc.exceptions import InvalidInputError
from wbc.profiles import min_jerk
from wbc.scenarios.framework import Criterion, evaluate
from wbc.sim.scenarios import FEET_STILL, NO_FALL
from wbc.solvers import make_backend
from wbc.scenarios.balance_wave import wave_joints
from wbc.tasks import PostureTask

__all__ = ["contacts_rank_deficient", "id_options_for", "walk_options_for", "WALK_SOLE_MARGIN_FRACTION",
           "WALK_MOMENTUM_WEIGHT", "WaveScenario", "wave_acceptance"]

#: DAQP settings of the ID QP for robots with near rank-deficient contact rows (module docstring).
DAQP_RANK_DEFICIENT = {"primal_tol": 1e-6, "warm_start": "dual"}


def contacts_rank_deficient(robot, tol: float = 1e-9) -> bool:
    """True when the stacked 12 × nv Jacobian of both soles (LOCAL) at ``robot.q_ref`` has a smallest singular
    value below ``tol`` × its largest."""
    model = robot.model
    data = model.createData()
    pin.computeJointJacobians(model, data, robot.q_ref)
    pin.framesForwardKinematics(model, data, robot.q_ref)
    J = np.vstack([pin.getFrameJacobian(model, data, robot.frame_id(f), pin.LOCAL)
                   for f in (robot.left_sole, robot.right_sole)])
    s = np.linalg.svd(J, compute_uv=False)
    return bool(s[-1] < tol * s[0])


def id_options_for(robot, solver: str = "fast") -> dict:
    """Keyword options (``solver``, maybe ``sole_margin``) of :class:`~wbc.dynamics.balance.IDBalanceController`
    for ``robot``: ``{"solver": solver}``, or for near rank-deficient two-sole contacts with DAQP or ``fast`` (whose
    compiled tick would fall back on the dependent contact rows anyway) a DAQP backend
    with ``primal_tol`` 1e-6 and ``sole_margin`` 0.02 m (module docstring)."""
    if solver not in ("daqp", "fast") or not contacts_rank_deficient(robot):
        return {"solver": solver}
    return {"solver": make_backend("daqp", **DAQP_RANK_DEFICIENT), "sole_margin": 0.02}


#: Controller sole shrink per side while walking, as a fraction of the sole width (module docstring).
WALK_SOLE_MARGIN_FRACTION = 0.1
#: Weight of the balance controller's centroidal angular-momentum task while walking (module docstring).
WALK_MOMENTUM_WEIGHT = 1.0


def walk_options_for(robot, solver: str = "fast", sole_margin: float | None = None) -> dict:
    """:func:`id_options_for` for walking (ProxQP for near rank-deficient contacts): the controller's contact
    rectangle shrunk by ``sole_margin`` (m) per
    side, by default ``WALK_SOLE_MARGIN_FRACTION`` × ``robot.sole_width`` (or the rank-deficient robots' margin
    when larger), so the CoP of the QP's contact forces keeps that distance from the sole edges, and the
    angular-momentum task's weight ``WALK_MOMENTUM_WEIGHT`` (``gains``; module docstring).

    Raises:
        InvalidInputError: a negative or non-finite ``sole_margin``.
    """
    options = id_options_for(robot, solver)
    if solver in ("daqp", "fast") and contacts_rank_deficient(robot):
        # walking on nearly dependent two-sole rows: DAQP declares many of the walk's QPs infeasible (full and
        # relaxed alike) that ProxQP, a proximal method, solves to 1e-7 (standing keeps DAQP: module docstring)
        options["solver"] = make_backend("proxqp", eps_abs=1e-7)
    if sole_margin is None:
        sole_margin = max(options.get("sole_margin", 0.0), WALK_SOLE_MARGIN_FRACTION * robot.sole_width)
    elif not (np.isfinite(sole_margin) and sole_margin >= 0):
        raise InvalidInputError(f"sole_margin must be finite and ≥ 0 m, got {sole_margin!r}")
    options["sole_margin"] = float(sole_margin)
    options["gains"] = {"momentum_weight": WALK_MOMENTUM_WEIGHT}
    return options


class WaveScenario:
    """Both arms wave in MuJoCo while the robot stands (module docstring). Needs the ID controller.

    Args:
        wave_time: s. frequency: Hz. raise_time: s. ramp: envelope rise/fall (s), 2·ramp ≤ wave_time.
        settle: s held at the end. t_start: s before the arms start moving.

    Raises:
        InvalidInputError: non-positive durations / frequency or 2·ramp > wave_time.
    """

    name = "wave"
    needs_id = True

    def __init__(self, wave_time: float = 5.0, frequency: float = 1.0, raise_time: float = 1.0,
                 ramp: float = 0.5, settle: float = 1.0, t_start: float = 0.2, arm_kp: float = 400.0,
                 arm_weight: float = 10.0):
        vals = (wave_time, frequency, raise_time, settle)
        if not all(np.isfinite(x) and x > 0 for x in vals) or not (0 < 2 * ramp <= wave_time) or t_start < 0:
            raise InvalidInputError("wave: durations and frequency must be finite and > 0, 0 < 2·ramp ≤ wave_time, "
                                    f"t_start ≥ 0; got {vals + (ramp, t_start)}")
        self.wave_time, self.frequency, self.raise_time = float(wave_time), float(frequency), float(raise_time)
        self.ramp, self.settle, self.t_start = float(ramp), float(settle), float(t_start)
        self.t_wave = self.t_start + self.raise_time
        self.t_lower = self.t_wave + self.wave_time
        self.duration = self.t_lower + self.raise_time + self.settle
        self.com0 = np.zeros(3)
        self.arm_kp, self.arm_weight = float(arm_kp), float(arm_weight)

    def setup(self, controller, sim, q, v) -> None:
        robot = sim.robot
        model = robot.model
        self.com0 = pin.centerOfMass(model, model.createData(), q).copy()
        raise_, wave = wave_joints(robot)
        self.q0 = robot.q_ref.copy()
        self.q_up = self.q0.copy()
        for name, off in raise_.items():
            self.q_up[model.joints[robot.joint_id(name)].idx_q] += off
        self.q_up[7:] = np.clip(self.q_up[7:], model.lowerPositionLimit[7:] + 0.05,
                                model.upperPositionLimit[7:] - 0.05)
        self.wave_names = list(wave)
        self.iq = np.array([model.joints[robot.joint_id(n)].idx_q for n in wave])
        self.iv = np.array([model.joints[robot.joint_id(n)].idx_v for n in wave])
        lo = model.lowerPositionLimit[self.iq] + 0.05
        hi = model.upperPositionLimit[self.iq] - 0.05
        c = self.q_up[self.iq]
        amp = np.array(list(wave.values()))
        self.amplitude = np.sign(amp) * np.minimum(np.abs(amp), np.minimum(hi - c, c - lo).clip(0))
        self._q = self.q0.copy()
        self._a = np.zeros(model.nv)
        self.wave_q = []
        arm = sorted(set(raise_) | set(wave), key=robot.joint_names.index)
        self.arm = AccelerationReference(PostureTask(robot, joints=arm), kp=self.arm_kp, kd=2 * math.sqrt(self.arm_kp),
                                          weight=self.arm_weight, name="arms")
        self.arm_iv = self.arm.task.rows
        if isinstance(controller, IDBalanceController):
            controller.qp.add_task(self.arm)

    def com_reference(self, t: float) -> np.ndarray:
        return self.com0

    def _envelope(self, tau: float) -> tuple[float, float, float]:
        if tau <= 0 or tau >= self.wave_time:
            return 0.0, 0.0, 0.0
        w = math.pi / self.ramp
        if tau < self.ramp:
            return 0.5 - 0.5 * math.cos(w * tau), 0.5 * w * math.sin(w * tau), 0.5 * w * w * math.cos(w * tau)
        if tau > self.wave_time - self.ramp:
            r = self.wave_time - tau
            return 0.5 - 0.5 * math.cos(w * r), -0.5 * w * math.sin(w * r), 0.5 * w * w * math.cos(w * r)
        return 1.0, 0.0, 0.0

    def reference(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(posture reference q (nq,), acceleration feed-forward (nv,)) at time t (s)."""
        q, a = self._q, self._a
        a[:] = 0.0
        if t < self.t_lower:
            s, _, dds = min_jerk((t - self.t_start) / self.raise_time)
            q[7:] = self.q0[7:] + s * (self.q_up[7:] - self.q0[7:])
            a[6:] = dds / self.raise_time**2 * (self.q_up[7:] - self.q0[7:])
        else:
            s, _, dds = min_jerk((t - self.t_lower) / self.raise_time)
            q[7:] = self.q_up[7:] + s * (self.q0[7:] - self.q_up[7:])
            a[6:] = dds / self.raise_time**2 * (self.q0[7:] - self.q_up[7:])
        e, de, dde = self._envelope(t - self.t_wave)
        if e > 0:
            w = 2 * math.pi * self.frequency
            tau = t - self.t_wave
            sn, cs = math.sin(w * tau), math.cos(w * tau)
            q[self.iq] += self.amplitude * e * sn
            a[self.iv] += self.amplitude * (dde * sn + 2 * de * w * cs - e * w * w * sn)
        return q, a

    def update(self, t, controller, sim, q, v):
        qr, a = self.reference(t)
        controller.posture.set_target(qr)
        controller.posture.set_feedforward_acceleration(a[6:])
        self.arm.set_target(qr)
        self.arm.set_feedforward_acceleration(a[self.arm_iv])
        if self.t_wave <= t < self.t_lower:
            self.wave_q.append(q[self.iq].copy())
        return None

    @staticmethod
    def criteria() -> list[Criterion]:
        """No fall, the wave completed, feet still, every waving joint swept at least |A| (half the commanded
        peak-to-peak 2|A|)."""
        return [NO_FALL, Criterion("the wave was completed", "wave_completed", "==", True), FEET_STILL,
                Criterion("each waving joint swept ≥ |A| (half the commanded peak-to-peak)", "wave_swept_rad", ">=",
                          threshold_key="wave_amplitude_rad")]

    def extra_summary(self, run) -> dict:
        moved = np.linalg.norm(run.sole_pos[:, :, :2] - run.sole_pos[0, :, :2], axis=2).max()
        wq = np.array(self.wave_q) if self.wave_q else np.zeros((1, len(self.iq)))
        swept = wq.max(axis=0) - wq.min(axis=0)
        return {"wave_joints": self.wave_names, "wave_amplitude_rad": self.amplitude.tolist(),
                "wave_swept_rad": swept.tolist(), "feet_moved_m": float(moved),
                "wave_completed": bool(run.t[-1] >= self.duration - 1.5 * run.dt)}


def wave_acceptance(summary: dict) -> list[str]:
    """Failed criteria of a wave summary (module docstring); empty when it passed."""
    return evaluate(summary, WaveScenario.criteria())[1]
