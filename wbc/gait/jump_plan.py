"""Reference plan of a jump: crouch, push-off, ballistic flight, landing — shared by the MuJoCo jump
(:mod:`wbc.sim.jump`) and its kinematic preview (:mod:`wbc.scenarios.balance_jump`).

Method (Wensing & Orin 2013, "High-speed humanoid running through control with a 3D-SLIP model", IROS: the
flight phase of the SLIP, where the CoM is ballistic and the take-off velocity sets the apex and the landing
point). All positions are world (m), velocities m/s, accelerations m/s², g = 9.81 m/s² along −z.

* **take-off velocity**: vertical v_z = √(2 g h) for an apex CoM rise h above the take-off point; the flight
  from take-off back to the take-off height lasts T_f = 2 v_z / g.
* **forward hop** of the feet by D along world x: the feet land at the capture point of the linear inverted
  pendulum (ω = √(g / z_c), z_c the CoM height above the soles at landing; Pratt et al. 2006, "Capture point: a
  step toward humanoid push recovery", Humanoids), i.e. a distance v_x / ω ahead of the CoM, so the horizontal
  velocity can be absorbed with the CoP at the middle of the soles. With the CoM v_x T_p / 2 ahead of the
  feet at take-off (constant acceleration from rest over the push of duration T_p), the feet then move by
  D = v_x (T_p / 2 + T_f + 1/ω), which gives v_x = D / (T_p / 2 + T_f + 1/ω).
* **crouch**: the CoM goes down by ``crouch`` (minimum jerk over ``t_crouch``), then holds ``t_hold``.
* **push-off**: constant CoM acceleration a = (v_x / T_p, 0, v_z / T_p) from rest over the vertical stroke
  s = ``crouch`` + ``extension``: a_z = v_z² / (2 s), T_p = 2 s / v_z.
* **flight**: c(τ) = c_to + v_to τ − ½ g τ² e_z (ballistic: the only CoM motion without contact forces). The
  feet follow the CoM height with a tuck of ``tuck`` (minimum jerk up and down over T_f) and move in world xy
  (minimum jerk over 0.8 T_f) from their take-off position to the landing target; their orientation goes to flat.
* **landing**: from the touch-down CoM state, each axis follows the critically damped response
  x(τ) = (x₀ + (v₀ + w x₀) τ) e^{−w τ} (x relative to the target: stance height above the mid-sole point) with
  w = ``w_land``; its acceleration peak is ≈ 2 w v₀ and its undershoot v₀ / (w e).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from wbc.constants import GRAVITY
from wbc.profiles import min_jerk
from wbc.exceptions import InvalidInputError

__all__ = ["JumpPlan", "critically_damped"]

def critically_damped(x0: np.ndarray, v0: np.ndarray, w: float, tau: float):
    """(x, ẋ, ẍ) at τ ≥ 0 of ẍ = −2 w ẋ − w² x from (x0, v0) (arrays of any equal shape; module docstring)."""
    e = math.exp(-w * tau)
    b = v0 + w * x0
    x = (x0 + b * tau) * e
    dx = (v0 - w * b * tau) * e
    ddx = (-2 * w * v0 - w * w * x0 + w * w * b * tau) * e
    return x, dx, ddx


@dataclass(frozen=True)
class JumpPlan:
    """Timing and take-off velocity of one jump (module docstring).

    Args:
        height: apex CoM rise above the take-off point h (m, > 0).
        forward: foot displacement D along world x (m, ≥ 0; 0 for a vertical jump).
        com_height: CoM height above the soles when standing (m, > 0), for ω of the capture point.
        crouch: CoM drop before the push (m, > 0). extension: CoM rise above standing at take-off (m, ≥ 0).
        t_crouch: crouch duration (s). t_hold: pause crouched (s). tuck: foot lift relative to the CoM at
            mid-flight (m, ≥ 0). w_land: landing response rate (1/s, > 0).

    Raises:
        InvalidInputError: a value outside the ranges above.
    """

    height: float
    forward: float = 0.0
    com_height: float = 0.6
    crouch: float = 0.08
    extension: float = 0.02
    t_crouch: float = 0.6
    t_hold: float = 0.2
    tuck: float = 0.14
    w_land: float = 8.0

    def __post_init__(self):
        checks = {"height": self.height > 0, "forward": self.forward >= 0, "com_height": self.com_height > 0,
                  "crouch": self.crouch > 0, "extension": self.extension >= 0, "t_crouch": self.t_crouch > 0,
                  "t_hold": self.t_hold >= 0, "tuck": self.tuck >= 0, "w_land": self.w_land > 0}
        for name, ok in checks.items():
            value = getattr(self, name)
            if not (math.isfinite(value) and ok):
                raise InvalidInputError(f"jump plan: {name} = {value!r} is out of range (height, com_height, crouch, "
                                        "t_crouch, w_land > 0; forward, extension, t_hold, tuck ≥ 0)")

    @property
    def stroke(self) -> float:
        """Vertical push stroke s = crouch + extension (m)."""
        return self.crouch + self.extension

    @property
    def vz(self) -> float:
        """Planned vertical take-off velocity √(2 g h) (m/s)."""
        return math.sqrt(2 * GRAVITY * self.height)

    @property
    def t_push(self) -> float:
        """Push duration T_p = 2 s / v_z (s)."""
        return 2 * self.stroke / self.vz

    @property
    def t_flight(self) -> float:
        """Planned flight time back to the take-off height, 2 v_z / g (s)."""
        return 2 * self.vz / GRAVITY

    @property
    def omega(self) -> float:
        """ω = √(g / z_c) (1/s) of the landing capture point, z_c = standing CoM height + extension."""
        return math.sqrt(GRAVITY / (self.com_height + self.extension))

    @property
    def vx(self) -> float:
        """Planned forward take-off velocity D / (T_p/2 + T_f + 1/ω) (m/s)."""
        return self.forward / (0.5 * self.t_push + self.t_flight + 1.0 / self.omega)

    @property
    def takeoff_velocity(self) -> np.ndarray:
        """(3,) planned CoM take-off velocity (m/s, world)."""
        return np.array([self.vx, 0.0, self.vz])

    @property
    def push_acceleration(self) -> np.ndarray:
        """(3,) constant CoM acceleration of the push (m/s², world)."""
        return self.takeoff_velocity / self.t_push

    @property
    def t_push_start(self) -> float:
        """Time of the push start from the start of the crouch (s)."""
        return self.t_crouch + self.t_hold

    def crouch_reference(self, c_start: np.ndarray, tau: float):
        """(c, ċ, c̈) (3,) each, τ s after the crouch start from the standing CoM ``c_start``."""
        s, ds, dds = min_jerk(tau / self.t_crouch)
        d = np.array([0.0, 0.0, -self.crouch])
        return c_start + s * d, ds / self.t_crouch * d, dds / self.t_crouch**2 * d

    def push_reference(self, c_start: np.ndarray, tau: float):
        """(c, ċ, c̈) τ s after the push start (constant acceleration from rest at the crouched CoM)."""
        a = self.push_acceleration
        c_low = c_start + [0.0, 0.0, -self.crouch]
        return c_low + 0.5 * a * tau**2, a * tau, a.copy()

    @staticmethod
    def flight_reference(c_to: np.ndarray, v_to: np.ndarray, tau: float):
        """Ballistic (c, ċ, c̈) τ s after take-off from the CoM state (c_to, v_to)."""
        g = np.array([0.0, 0.0, -GRAVITY])
        return c_to + v_to * tau + 0.5 * g * tau**2, v_to + g * tau, g

    def foot_landing_target(self, foot_to: np.ndarray) -> np.ndarray:
        """(3,) world landing position of a sole that took off at ``foot_to`` (3,): D ahead, same height."""
        return np.asarray(foot_to, dtype=float) + [self.forward, 0.0, 0.0]

    def foot_flight_offset(self, foot_to: np.ndarray, target: np.ndarray, dz_com: float, vz_com: float,
                           az_com: float, tau: float, t_flight: float):
        """Sole (position, velocity, acceleration) (3,) each, τ s into a flight of duration ``t_flight`` (s):
        xy min-jerk from ``foot_to`` to ``target`` over 0.8 t_flight; z = take-off height + the CoM's rise
        ``dz_com`` (with its rate ``vz_com``, ``az_com``) + the tuck profile."""
        p = np.asarray(foot_to, dtype=float).copy()
        v, a = np.zeros(3), np.zeros(3)
        tx = 0.8 * t_flight
        s, ds, dds = min_jerk(tau / tx)
        dxy = (np.asarray(target) - foot_to)[:2]
        p[:2] += s * dxy
        v[:2] = ds / tx * dxy
        a[:2] = dds / tx**2 * dxy
        half = 0.5 * t_flight
        if tau <= half:
            s, ds, dds = min_jerk(tau / half)
        else:
            s, ds, dds = min_jerk(1.0 - (tau - half) / half)
            ds = -ds
        p[2] += dz_com + self.tuck * s
        v[2] = vz_com + self.tuck * ds / half
        a[2] = az_com + self.tuck * dds / half**2
        return p, v, a

    def landing_reference(self, c_td: np.ndarray, v_td: np.ndarray, target: np.ndarray, tau: float):
        """Critically damped (c, ċ, c̈) τ s after touch-down from the measured CoM state (c_td, v_td) to
        ``target`` (3,) (module docstring)."""
        x, dx, ddx = critically_damped(np.asarray(c_td) - target, np.asarray(v_td, dtype=float), self.w_land, tau)
        return target + x, dx, ddx
