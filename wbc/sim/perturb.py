"""Plant ≠ model: perturb the simulated robot (MuJoCo) or the controller's measurements on purpose.

* :func:`perturb_plant` edits the **compiled MuJoCo model** after :func:`~wbc.sim.mujoco_model.build_mujoco_model`
  (the controller keeps the exact Pinocchio model): every link mass (and its inertia, scaled with it) multiplied by
  ``1 + e``, e ~ U(−mass_error, +mass_error) per body; a point ``payload`` (kg) added to the torso body at its
  origin (mass added, inertia unchanged, body CoM moved accordingly); joint dry friction (N·m, ``frictionloss``)
  and rotor armature (kg·m², ``armature``) added on every actuated DoF, on top of what the plant's drive model
  (:mod:`wbc.sim.actuators`) already has.
* :class:`PerturbedController` wraps a :class:`~wbc.dynamics.balance.IDBalanceController`: Gaussian noise on the
  measured q (joints, rad) and v (all DoF, rad/s or m/s) and a control delay of ``delay`` ticks (the torque applied
  at tick k is the one computed at tick k − delay; the first torque before).

All random draws come from ``numpy.random.default_rng(seed)``.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from wbc.dynamics.balance import IDBalanceController
from wbc.exceptions import InvalidInputError

__all__ = ["perturb_plant", "PerturbedController"]


def _nonneg(x, what):
    if not (np.isfinite(x) and x >= 0):
        raise InvalidInputError(f"{what} must be finite and ≥ 0, got {x!r}")
    return float(x)


def perturb_plant(sim, *, mass_error: float = 0.0, payload: float = 0.0, friction: float = 0.0,
                  armature: float = 0.0, seed: int = 0) -> dict:
    """Perturb the MuJoCo plant in place (module docstring).

    Args:
        sim: :class:`~wbc.sim.mujoco_runtime.MujocoModel`.
        mass_error: relative link-mass error bound (e.g. 0.05 for ±5 %), in [0, 1).
        payload: kg added at the torso body origin (≥ 0).
        friction: joint dry friction (N·m, ≥ 0). armature: rotor inertia (kg·m², ≥ 0).
        seed: random seed.

    Returns:
        ``{"plant_mass_kg", "model_mass_kg", "mass_factors"}``.

    Raises:
        InvalidInputError: bad numbers.
    """
    import mujoco

    mass_error = _nonneg(mass_error, "mass_error")
    if mass_error >= 1:
        raise InvalidInputError(f"mass_error must be < 1 (relative), got {mass_error}")
    payload, friction, armature = (_nonneg(payload, "payload"), _nonneg(friction, "friction"),
                                   _nonneg(armature, "armature"))
    m = sim.model
    rng = np.random.default_rng(seed)
    model_mass = float(m.body_mass.sum())
    factors = 1.0 + rng.uniform(-mass_error, mass_error, m.nbody)
    factors[0] = 1.0  # world
    m.body_mass[:] *= factors
    m.body_inertia[:] *= factors[:, None]
    if payload > 0:
        b = sim.body_id(sim.robot.torso)
        m0 = float(m.body_mass[b])
        m.body_ipos[b] = m.body_ipos[b] * m0 / (m0 + payload)  # payload at the body origin
        m.body_mass[b] = m0 + payload
    actuated = np.arange(6, m.nv)
    m.dof_frictionloss[actuated] += friction
    m.dof_armature[actuated] += armature
    mujoco.mj_setConst(m, sim.data)
    return {"plant_mass_kg": float(m.body_mass.sum()), "model_mass_kg": model_mass, "mass_factors": factors}


class PerturbedController(IDBalanceController):
    """An :class:`IDBalanceController` that sees noisy measurements and whose torques arrive ``delay`` ticks late.

    Args: as :class:`IDBalanceController`, plus
        q_noise: std of the Gaussian noise on the measured joint positions (rad).
        v_noise: std of the Gaussian noise on the measured velocities (every DoF).
        delay: control delay in ticks (integer ≥ 0).
        seed: random seed.

    Raises:
        InvalidInputError: bad numbers.
    """

    def __init__(self, robot, *, q_noise: float = 0.0, v_noise: float = 0.0, delay: int = 0, seed: int = 0,
                 **kwargs):
        super().__init__(robot, **kwargs)
        self.q_noise, self.v_noise = _nonneg(q_noise, "q_noise"), _nonneg(v_noise, "v_noise")
        if isinstance(delay, bool) or not isinstance(delay, (int, np.integer)) or delay < 0:
            raise InvalidInputError(f"delay must be an integer ≥ 0 (ticks), got {delay!r}")
        self.delay = int(delay)
        self.rng = np.random.default_rng(seed)
        self._queue: deque = deque()

    def solve(self, q, v):
        q = np.array(q, dtype=float)
        v = np.array(v, dtype=float)
        if self.q_noise > 0:
            q[7:] += self.rng.normal(0.0, self.q_noise, q.size - 7)
        if self.v_noise > 0:
            v += self.rng.normal(0.0, self.v_noise, v.size)
        cmd = super().solve(q, v)
        if self.delay == 0:
            return cmd
        self._queue.append(cmd.tau.copy())
        # the first delay ticks repeat the first torque (the plant starts at rest with it)
        cmd.tau = self._queue.popleft() if len(self._queue) > self.delay else self._queue[0].copy()
        return cmd
