"""The landing gate of a physics walk (:class:`wbc.sim.walk.WalkScenario`, :class:`WalkLanding`): a swing sole is
held off the floor while its touch-down would stop it hard enough to drive a leg joint past its speed limit.

At a touch-down the floor stops the sole within a tick or two (an impact); the rest of the robot moves on, so the
leg's joints take up the sole's velocity. With the sole's twist ``V`` (6, m/s and rad/s, at the sole origin, world
axes: ``J q̇``) stopped and the rest of ``q̇`` kept, the leg's joint rates become

    q̇_leg' = q̇_leg − J_leg⁺ V

(``J_leg`` the sole's frame Jacobian restricted to the joints that support it; its pseudo-inverse, the inverse for
a 6-joint leg). Near a straight knee ``J_leg`` is nearly singular: a sole still travelling along the leg when it
lands asks the knee for a rate of that speed over the knee's lever, far past the joint's limit (a leg landing far
out on a push, the body still moving towards the landing: the sole is carried along with the hip because the
straight knee cannot shorten the leg fast enough). ``q̇_leg'`` over the joints' URDF speed limits is the
*predicted impact speed ratio* ``ρ``. It over-predicts what the plant reaches (the impulse also slows the body);
it is below 1 wherever the swing task holds the sole still within the joint speed bounds.

The gate (flat walks, not blind or on terrain): from the last :data:`GATE_FROM` of a swing's planned duration, the
sole's height reference is kept at least :data:`HOVER_M` over the landing's ground while ``ρ > 1`` (velocity and
acceleration references of the height zeroed when raised), for at most :data:`MAX_HOLD_S`. The swing task then
holds the sole over its landing point while the hip comes over it and the knee bends (which gives the knee its
lever); once ``ρ ≤ 1`` (or the hold's time is up) the gate opens for the rest of the swing and the hover height is
lowered at :data:`OPEN_DESCENT` m/s to the plan's reference. The step waits for the late touch-down as for any late
landing (:class:`~wbc.sim.walk.WalkScenario`: the next swing is not released before the sole is down).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

__all__ = ["WalkLanding", "GATE_FROM", "HOVER_M", "MAX_HOLD_S", "OPEN_DESCENT"]

#: Fraction of the swing's planned duration from its end over which the gate acts (the final descent).
GATE_FROM = 0.3
#: Height over the landing's ground (m) at which a gated sole is held.
HOVER_M = 0.01
#: Longest time (s) a sole is held.
MAX_HOLD_S = 0.12
#: Speed (m/s) at which the hover height is lowered once the gate opens.
OPEN_DESCENT = 0.3


class WalkLanding:
    """The landing gate of :class:`wbc.sim.walk.WalkScenario` (module docstring; its state: the model, the soles'
    frames, the plan's swings)."""

    def _setup_landing(self) -> None:
        """Per walk: the leg columns of each sole (the joints supporting its frame, the free flyer excluded), their
        URDF speed limits, a Pinocchio data of its own, and the gate's per-side state."""
        model = self._model
        self._ldata = model.createData()
        self._leg_cols, self._leg_lim = {}, {}
        for side in ("left", "right"):
            joint = model.frames[self._fid[side]].parentJoint
            cols = []
            for j in model.supports[joint]:
                jm = model.joints[j]
                if j == 0 or jm.nq == 7:  # universe, free flyer
                    continue
                cols.extend(range(jm.idx_v, jm.idx_v + jm.nv))
            cols = np.array(cols, dtype=int)
            self._leg_cols[side] = cols
            self._leg_lim[side] = np.where(model.velocityLimit[cols] > 0, model.velocityLimit[cols], np.inf)
        self._gate = {"left": None, "right": None}  # per swing: [k_td, t_first_held or None, t_opened or None]
        self.landing_holds = 0  # swings whose sole was held by the gate
        self.landing_hold_time = 0.0  # longest hold (s)

    def impact_speed_ratio(self, side: str, q: np.ndarray, v: np.ndarray) -> float:
        """Predicted impact speed ratio ``ρ`` of ``side``'s sole (module docstring): the largest
        ``|q̇_leg − J_leg⁺ J q̇|`` of the leg's joints over their URDF speed limits, for state ``q`` (nq,), ``v`` (nv,)
        (dimensionless; 1 = a joint at its limit)."""
        model, data = self._model, self._ldata
        fid, cols = self._fid[side], self._leg_cols[side]
        J = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)
        twist = J @ v
        Jl = J[:, cols]
        if Jl.shape[1] == 6:
            try:
                dq = np.linalg.solve(Jl, twist)
            except np.linalg.LinAlgError:
                dq = np.linalg.lstsq(Jl, twist, rcond=None)[0]
        else:
            dq = np.linalg.lstsq(Jl, twist, rcond=None)[0]
        return float(np.max(np.abs(v[cols] - dq) / self._leg_lim[side]))

    def _gate_landing(self, side: str, t: float, kk: int, k_lift: int, k_td: int, q: np.ndarray, v: np.ndarray,
                      pos: np.ndarray, vel: np.ndarray, acc: np.ndarray) -> None:
        """Raise ``side``'s swing reference (``pos``, ``vel``, ``acc``: (3,) world, m, m/s, m/s², edited in place)
        to the hover height while the gate is closed (module docstring); ``kk`` the plan sample, ``k_lift``, ``k_td``
        the swing's lift-off and touch-down samples, ``t`` the sim time (s), ``q``, ``v`` the state read."""
        if self.terrain_walk is not None or self.blind:
            return
        g = self._gate[side]
        if g is None or g[0] != k_td:
            g = self._gate[side] = [k_td, None, None]
        if kk < k_td - GATE_FROM * (k_td - k_lift):
            return
        hover = float(self.poses[side][k_td][2, 3]) + HOVER_M  # (the plan's landing height: flat ground)
        if g[2] is None and (g[1] is None or t - g[1] < MAX_HOLD_S):
            if pos[2] >= hover or self.impact_speed_ratio(side, q, v) <= 1.0:
                if g[1] is None:
                    return  # never held: the plan's reference as it is
                g[2] = t  # opens
            else:
                if g[1] is None:
                    g[1] = t
                    self.landing_holds += 1
                self.landing_hold_time = max(self.landing_hold_time, t - g[1])
                pos[2] = hover
                vel[2] = 0.0
                acc[2] = 0.0
                return
        elif g[2] is None:
            g[2] = t  # the hold's time is up
        z = hover - OPEN_DESCENT * (t - g[2])
        if pos[2] < z:
            pos[2] = z
            vel[2] = -OPEN_DESCENT
            acc[2] = 0.0
