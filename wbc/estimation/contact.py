"""Ground reaction of each foot from an ankle 6-axis force/torque sensor, contact detection with hysteresis, and
the measured CoP/ZMP.

**Sensor model.** The sensor sits at the origin of the link moved by the joint that carries the sole frame (the
ankle roll link), with the sole frame's axes (the convention of :mod:`wbc.sim.sensors`). It reads the force F_s
and the moment τ_s about its origin that the leg exerts on the foot below it (sensor axes). Newton–Euler on that
foot (mass m, CoM c; Pinocchio's ``model.inertias`` of the joint, which holds every link fixed to it), with the
ground reaction (f, τ_p) at the sole origin p and gravity g (world, (0, 0, −9.81)) expressed in the sensor axes
as g_s = Rᵀ g, neglecting the foot's own acceleration (static compensation; the foot is still while it carries
load):

    f   = −F_s − m g_s
    τ_p = −τ_s + p × F_s − (c − p) × m g_s              (p, c in sensor axes, from the sensor origin)

**CoP** of a foot in its sole frame: (−τ_y / f_z, τ_x / f_z) (the sole plane is z = 0 of the sole frame);
**ZMP** of both feet on flat ground: the point where the moment of the summed ground reaction about it has no
horizontal component, p_x = −M_y / F_z, p_y = M_x / F_z with M the moment about the world origin (Sardain,
Bessonnet 2004, "Forces acting on a biped robot. Center of pressure—zero moment point", IEEE T-SMC A 34(5)).

**Contact**: a foot is in contact once its normal force exceeds ``on`` and until it falls below ``off`` < ``on``
(hysteresis: a Schmitt trigger, so noise on a threshold does not chatter).
"""

from __future__ import annotations

import numpy as np

from wbc.constants import GRAVITY
from wbc.exceptions import InvalidInputError

__all__ = ["FootForceSensor", "ContactDetector", "zmp_from_wrenches", "GRAVITY_VECTOR"]

GRAVITY_VECTOR = np.array([0.0, 0.0, -GRAVITY])  #: m/s², world


class FootForceSensor:
    """Converts one ankle F/T reading into the ground reaction at the sole (module docstring).

    Args:
        robot: the :class:`~wbc.robot.Robot`.
        sole: name of the sole frame (e.g. ``robot.left_sole``).

    Attributes:
        frame_id: the sole frame id. joint_id: the joint carrying it. mass: m (kg) below the sensor.
        sole_in_sensor: (3,) p (m, sensor axes). com_in_sensor: (3,) c (m, sensor axes).

    Raises:
        UnknownFrameError: no such frame.
    """

    def __init__(self, robot, sole: str):
        model = robot.model
        self.frame_id = robot.frame_id(sole)
        frame = model.frames[self.frame_id]
        self.joint_id = frame.parentJoint
        inertia = model.inertias[self.joint_id]
        R = frame.placement.rotation  # sensor axes = sole axes; sensor origin = joint origin
        self.mass = float(inertia.mass)
        self.sole_in_sensor = R.T @ frame.placement.translation
        self.com_in_sensor = R.T @ inertia.lever
        self._f = np.zeros(6)

    def ground_wrench(self, ft: np.ndarray, rotation: np.ndarray) -> np.ndarray:
        """Ground reaction (6,) on the foot at the sole origin, sole axes: force (N), moment (N·m).

        Args:
            ft: (6,) sensor reading: force (N), moment about the sensor origin (N·m), sensor (= sole) axes.
            rotation: (3, 3) world ← sole rotation (from the estimated base orientation and the leg kinematics).

        Returns:
            A preallocated (6,) array, overwritten by the next call.
        """
        f0, f1, f2, t0, t1, t2 = ft.tolist()
        m0, m1, m2 = (self.mass * (rotation.T @ GRAVITY_VECTOR)).tolist()
        p0, p1, p2 = self.sole_in_sensor.tolist()
        c0, c1, c2 = self.com_in_sensor.tolist()
        d0, d1, d2 = c0 - p0, c1 - p1, c2 - p2  # c − p
        out = self._f
        out[:] = (-f0 - m0, -f1 - m1, -f2 - m2,
                  -t0 + (p1 * f2 - p2 * f1) - (d1 * m2 - d2 * m1),
                  -t1 + (p2 * f0 - p0 * f2) - (d2 * m0 - d0 * m2),
                  -t2 + (p0 * f1 - p1 * f0) - (d0 * m1 - d1 * m0))
        return out


class ContactDetector:
    """Schmitt trigger on a normal force (module docstring).

    Args:
        on: force (N) above which a foot not in contact becomes in contact.
        off: force (N) below which a foot in contact leaves it (0 ≤ off < on).

    Raises:
        InvalidInputError: not 0 ≤ off < on (finite).
    """

    def __init__(self, on: float, off: float):
        if not (np.isfinite(on) and np.isfinite(off) and 0.0 <= off < on):
            raise InvalidInputError(f"contact thresholds must satisfy 0 ≤ off < on (N), got on={on!r}, off={off!r}")
        self.on, self.off = float(on), float(off)
        self.active = False

    def update(self, normal_force: float) -> bool:
        """New state from the normal force (N); returns it."""
        if self.active:
            self.active = normal_force >= self.off
        else:
            self.active = normal_force > self.on
        return self.active


def zmp_from_wrenches(wrenches: np.ndarray, placements, min_fz: float = 10.0,
                      height: float = 0.0) -> np.ndarray | None:
    """ZMP (2,) (m, world, on the plane z = ``height``) of foot wrenches given in their sole frames (module
    docstring).

    With the total force F and moment M about the world origin, the moment about (0, 0, h) is
    M_h = M − (0, 0, h) × F, and the point of that plane where the horizontal moment vanishes is
    p = (−M_h,y / F_z, M_h,x / F_z) (Sardain & Bessonnet 2004). On a stair tread at height h the plane z = 0 puts
    the ZMP ``h F_xy / F_z`` away from the CoP (6 cm for G1 at 0.6 m): give the tread's height.

    Args:
        wrenches: (k, 6) ground reaction per foot at its sole origin, sole axes (force N, moment N·m).
        placements: k ``pin.SE3`` world placements of the soles.
        min_fz: total vertical force (N) below which there is no ZMP (returns None).
        height: height (m, world) of the plane of the ZMP (default the floor z = 0).
    """
    F0 = F1 = F2 = M0 = M1 = M2 = 0.0  # F, M
    for w, X in zip(wrenches, placements):
        R = X.rotation
        f0, f1, f2 = (R @ w[0:3]).tolist()
        m0, m1, m2 = (R @ w[3:6]).tolist()
        t0, t1, t2 = X.translation.tolist()
        F0, F1, F2 = F0 + f0, F1 + f1, F2 + f2
        M0 += m0 + (t1 * f2 - t2 * f1)
        M1 += m1 + (t2 * f0 - t0 * f2)
        M2 += m2 + (t0 * f1 - t1 * f0)
    if F2 < min_fz:
        return None
    if height:
        M0 += height * F1
        M1 -= height * F0
    return np.array([-M1 / F2, M0 / F2])

