"""The outcome of a closed-loop run as an operator would judge it, checked every tick from MuJoCo's own data.

:class:`OutcomeMonitor` is fed the MuJoCo data once per control tick (after ``mj_step``: positions, contacts and
velocities of the new state) and decides:

* **fall** — the first of
  - base drop: the root body (the floating base, e.g. Talos' ``base_link`` = pelvis) lower than its initial height
    by more than :data:`FALL_HEIGHT_DROP` = 0.2 m (on a terrain, ``sim.terrain`` not None: its height above the
    lower of the two soles lower than at the start by more than that — walking down stairs lowers the base with
    the feet);
  - tilt: the **root body** (pelvis) or the **torso body** (the body carrying ``robot.torso``) tilted by more than
    :data:`FALL_TILT_DEG` = 30° from its nominal orientation. The nominal is the body's orientation at the start
    (``robot.q_ref``); tilt is the angle between the body-fixed axis that pointed up (world +z) at the start and
    world +z now — heading changes (yaw, a turning walk) are not a tilt. Read from MuJoCo's ``xmat``;
  - contact: any robot geom other than the foot contact geoms touching the floor (MuJoCo's ``data.contact``);
  - foot strike: a foot contact geom pressing on the ground (normal force > :data:`STRIKE_MIN_FORCE` = 20 N, from
    ``mj_contactForce``) along a contact normal more than :data:`STRIKE_DEG` = 45° from the sole's normal — a toe,
    heel or sole edge hitting a step's riser or nosing, not a sole standing on a tread, a slope or a rough patch
    (whose facets are at most a few tens of degrees from the sole plane). On a heightfield the normal is the
    terrain's (:meth:`wbc.terrain.Terrain.normal` at the contact point: the facet under it), not MuJoCo's: MuJoCo
    collides a heightfield as a union of triangular prisms, and a sole edge over a facet boundary can get the
    horizontal normal of a prism's side wall where the surface itself is continuous (google-deepmind/mujoco#236).
* **joint speed** — every tick, every actuated joint whose MuJoCo ``qvel`` exceeds its URDF velocity limit (the
  Pinocchio model's ``velocityLimit``, joints with a positive finite limit) is an exceedance; the count, the
  worst ratio |q̇|/q̇_max and its joint are reported (an operator requires 0 exceedances).
* **landing slide** — for each foot, the horizontal (world x, y) travel of the sole's contact points between the
  first contact of a support phase and its lift-off: a sole corner becomes a contact point at the first tick a
  MuJoCo foot–floor contact lies within :data:`CORNER_MATCH` of it, and its travel is measured from where it was at
  that tick while the foot keeps touching the floor. A support phase ends (lift-off) after :data:`LIFTOFF_TICKS`
  consecutive ticks without any foot–floor contact. The feet standing at t = 0 start a support phase too (their
  slide is measured from t = 0). Corners are the sole rectangle's (``robot.sole_corners_local``) in the sole
  frame, placed by MuJoCo's body pose.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

__all__ = ["OutcomeMonitor", "FALL_HEIGHT_DROP", "FALL_TILT_DEG", "STRIKE_DEG", "STRIKE_MIN_FORCE", "CORNER_MATCH",
           "LIFTOFF_TICKS"]

FALL_HEIGHT_DROP = 0.2  #: m, base height drop that counts as a fall
FALL_TILT_DEG = 30.0  #: deg, pelvis or torso tilt from its nominal orientation that counts as a fall
STRIKE_DEG = 45.0  #: deg, a foot contact normal this far from the sole's normal is a toe/heel/edge strike
STRIKE_MIN_FORCE = 20.0  #: N, normal force below which such a contact is a graze, not a strike
CORNER_MATCH = 0.02  #: m, a contact point this close to a sole corner makes that corner a contact point
LIFTOFF_TICKS = 10  #: consecutive ticks without foot contact that end a support phase


class OutcomeMonitor:
    """Per-tick fall, joint-speed and landing-slide checks of a run on ``sim`` (module docstring).

    Args:
        sim: :class:`~wbc.sim.mujoco_runtime.MujocoModel`, its data at the initial state (``mj_forward`` done):
            the nominal base height and orientations are read at construction.

    Attributes (updated by :meth:`update`):
        fell, fall_reason, fall_time: first fall (time in s).
        max_tilt_deg: {"pelvis": deg, "torso": deg} largest tilt so far (names of the bodies in ``tilt_bodies``).
        tilt_bodies: {"pelvis": MuJoCo body name, "torso": MuJoCo body name}.
        speed_exceedances: number of (tick, joint) pairs with |q̇| above the URDF limit.
        max_speed_ratio, max_speed_joint: worst |q̇| / q̇_max and its joint name.
        max_landing_slide_m: {"left": m, "right": m} largest contact-point travel in a support phase.
        touchdowns: {"left": n, "right": n} support phases started after t = 0.
    """

    def __init__(self, sim):
        robot = sim.robot
        model, d = sim.model, sim.data
        self.sim = sim
        pm = robot.model
        self.tilt_body_ids = np.array([sim.root_body, sim.body_id(_body_of_frame(robot, robot.torso))])
        self.tilt_bodies = {"pelvis": sim.body_name(self.tilt_body_ids[0]),
                            "torso": sim.body_name(self.tilt_body_ids[1])}
        # body-fixed axis that points up at the start: R0ᵀ e_z (row 2 of R0)
        self.up_local = np.array([np.array(d.xmat[b]).reshape(3, 3)[2, :] for b in self.tilt_body_ids])
        self.cos_tilt = math.cos(math.radians(FALL_TILT_DEG))
        self.z0 = float(d.qpos[2])
        sm = sim.state_map
        self.qvel_idx = sm.mj_qvel  # MuJoCo dof of Pinocchio's v[6 + i]
        vlim = np.array([pm.velocityLimit[pm.joints[i].idx_v] for i in range(2, pm.njoints)])
        self.vlim = np.where(np.isfinite(vlim) & (vlim > 0), vlim, np.inf)
        self.joint_names = list(pm.names[2:])
        self.is_foot = np.zeros(model.ngeom + 1, dtype=bool)
        self.geom_side = np.full(model.ngeom + 1, -1, dtype=int)
        for i, s in enumerate(("left", "right")):
            self.is_foot[sim.foot_geoms[s]] = True
            self.geom_side[sim.foot_geoms[s]] = i
        self.floor = sim.floor_geom
        self.is_ground = np.zeros(model.ngeom + 1, dtype=bool)  # the plane and the terrain's geoms
        self.is_ground[sim.floor_geom if sim.ground_geoms is None else sim.ground_geoms] = True
        self.is_hfield = np.zeros(model.ngeom + 1, dtype=bool)  # heightfield ground geoms (strike normal: terrain's)
        self.is_hfield[:model.ngeom] = self.is_ground[:model.ngeom] & (model.geom_type == mujoco.mjtGeom.mjGEOM_HFIELD)
        self.terrain = getattr(sim, "terrain", None)
        # the same lookups as Python lists, indexed by geom id (the per-tick contact pass reads them per contact)
        self._ground_list = self.is_ground.tolist()
        self._side_list = self.geom_side.tolist()
        self._hfield_list = self.is_hfield.tolist()
        self.corners_local = np.asarray(robot.sole_corners_local(), dtype=float)  # (4, 3) sole frame
        self.sole_body = [sim.sole_placements[s][0] for s in ("left", "right")]
        self.sole_off = [sim.sole_placements[s][1] for s in ("left", "right")]
        # (3, 4) sole corners in the frame of the body carrying each sole (constant: computed once)
        self._corners_body = [off.rotation @ self.corners_local.T + off.translation[:, None] for off in self.sole_off]
        self.cos_strike = math.cos(math.radians(STRIKE_DEG))
        self._sole_normal_body = [off.rotation[:, 2].copy() for off in self.sole_off]  # sole z in its body's frame
        self._force6 = np.zeros(6)
        self.fell, self.fall_reason, self.fall_time = False, "", None
        self.max_tilt_deg = {"pelvis": 0.0, "torso": 0.0}
        self.speed_exceedances = 0
        self.max_speed_ratio, self.max_speed_joint = 0.0, ""
        self.max_landing_slide_m = {"left": 0.0, "right": 0.0}
        self.touchdowns = {"left": 0, "right": 0}
        self._ref = np.full((2, 4, 2), np.nan)  # corner reference positions (xy) of the current support phase
        self._in_support = np.zeros(2, dtype=bool)
        self._n_known = [0, 0]  # corners of the current support phase with a reference position
        self._off_ticks = np.zeros(2, dtype=int)
        self._first = True
        # on terrain (stairs down) the base drop is measured relative to the lower sole (module docstring)
        self.on_terrain = getattr(sim, "terrain", None) is not None
        self.zf0 = self.support_height() if self.on_terrain else 0.0

    def support_height(self) -> float:
        """World height (m) of the lower of the two soles (mean of its corners), from MuJoCo's body poses."""
        return float(min(self.corners_world(0)[:, 2].mean(), self.corners_world(1)[:, 2].mean()))

    def corners_world(self, side: int) -> np.ndarray:
        """(4, 3) world positions (m) of the sole corners of ``side`` (0 left, 1 right) from MuJoCo's body pose."""
        d = self.sim.data
        b = self.sole_body[side]
        return (d.xmat[b].reshape(3, 3) @ self._corners_body[side]).T + d.xpos[b]

    def update(self, t: float) -> bool:
        """Check the state in ``sim.data`` (time ``t``, s). Returns whether the robot has fallen (so far)."""
        d = self.sim.data
        # -- joint speed ---------------------------------------------------------------------------------------
        ratio = np.abs(d.qvel[self.qvel_idx]) / self.vlim
        j = int(ratio.argmax())
        worst = ratio[j]
        if not worst <= 1.0:  # some |q̇| above its limit (or NaN): count them
            self.speed_exceedances += int(np.count_nonzero(ratio > 1.0))
        if worst > self.max_speed_ratio:
            self.max_speed_ratio, self.max_speed_joint = float(worst), self.joint_names[j]
        # -- tilt ----------------------------------------------------------------------------------------------
        tilted = []
        xmat = d.xmat
        for i, key in enumerate(("pelvis", "torso")):
            c = min(max(float(xmat[self.tilt_body_ids[i], 6:9] @ self.up_local[i]), -1.0), 1.0)  # e_zᵀ R u0
            deg = math.degrees(math.acos(c))
            if deg > self.max_tilt_deg[key]:
                self.max_tilt_deg[key] = deg
            if c < self.cos_tilt:
                tilted.append(f"{key} ({self.tilt_bodies[key]}) {deg:.1f}°")
        # -- contacts: one pass sorts the ground contacts into foot contacts (per side) and non-foot geoms -------
        ncon = d.ncon
        bad = []
        feet = ([], [])  # contact indices of each side's foot–ground contacts
        on_hfield = []  # foot–ground contacts on a heightfield
        con = d.contact
        if ncon:
            ground, side_of, hfield = self._ground_list, self._side_list, self._hfield_list
            for i, (g1, g2) in enumerate(zip(con.geom1[:ncon].tolist(), con.geom2[:ncon].tolist())):
                if ground[g1]:
                    g, other = g1, g2
                elif ground[g2]:
                    g, other = g2, g1
                else:
                    continue
                s = side_of[other]
                if s < 0:
                    bad.append(other)
                else:
                    feet[s].append(i)
                    if hfield[g]:
                        on_hfield.append(i)
        strike = self._strike(con, feet, on_hfield) if not self.fell and (feet[0] or feet[1]) else ""
        self._slide(con, feet)
        if not self.fell:
            if bad:
                names = sorted({self.sim.body_name(self.sim.model.geom_bodyid[g]) for g in bad})
                self.fall_reason = "non-foot contact with the ground: " + ", ".join(names)
            elif strike:
                self.fall_reason = strike
            elif d.qpos[2] - (self.support_height() if self.on_terrain else 0.0) < self.z0 - self.zf0 - FALL_HEIGHT_DROP:
                self.fall_reason = f"base height dropped by more than {FALL_HEIGHT_DROP} m"
            elif tilted:
                self.fall_reason = f"tilt > {FALL_TILT_DEG:g}° from nominal: " + ", ".join(tilted)
            if self.fall_reason:
                self.fell, self.fall_time = True, float(t)
        self._first = False
        return self.fell

    def _strike(self, con, feet, on_hfield) -> str:
        """The foot strike among this tick's foot–ground contacts ``feet`` (contact indices per side; those in
        ``on_hfield`` on a heightfield) (module docstring), described, or ""."""
        d = self.sim.data
        frame = con.frame
        for s in range(2):
            if not feet[s]:
                continue
            z0, z1, z2 = (d.xmat[self.sole_body[s]].reshape(3, 3) @ self._sole_normal_body[s]).tolist()  # sole z
            for i in feet[s]:
                if on_hfield and i in on_hfield and self.terrain is not None:
                    # the facet's normal, not a prism side wall's (module docstring)
                    n0, n1, n2 = self.terrain.normal(float(con.pos[i, 0]), float(con.pos[i, 1])).tolist()
                else:
                    n0, n1, n2 = frame[i, 0:3].tolist()
                cos = abs(n0 * z0 + n1 * z1 + n2 * z2)
                if cos < self.cos_strike:
                    mujoco.mj_contactForce(self.sim.model, d, i, self._force6)
                    if self._force6[0] > STRIKE_MIN_FORCE:
                        angle = math.degrees(math.acos(min(1.0, cos)))
                        x, y, z = (float(c) for c in con.pos[i])
                        return (f"foot strike: the {('left', 'right')[s]} foot hit the ground along a normal "
                                f"{angle:.0f}° from its sole's ({self._force6[0]:.0f} N at ({x:.3f}, {y:.3f}, "
                                f"{z:.3f}) m: a toe, heel or sole edge on a riser or nosing)")
        return ""

    def _slide(self, con, feet) -> None:
        for s in range(2):
            key = ("left", "right")[s]
            if feet[s]:
                self._off_ticks[s] = 0
                if not self._in_support[s]:
                    self._in_support[s] = True
                    self._ref[s] = np.nan
                    self._n_known[s] = 0
                    if not self._first:
                        self.touchdowns[key] += 1
                corners = self.corners_world(s)
                ref = self._ref[s]
                if self._n_known[s] < len(ref):
                    # (n, 3) contact points: each makes its nearest corner (≤ CORNER_MATCH) known
                    pts = con.pos[feet[s]]
                    diff = corners[None, :, :] - pts[:, None, :]
                    dist = np.sqrt(np.add.reduce(diff * diff, axis=2))
                    k = np.argmin(dist, axis=1)
                    near = k[dist[np.arange(len(k)), k] <= CORNER_MATCH]
                    new = near[np.isnan(ref[near, 0])]
                    ref[new] = corners[new, :2]
                    self._n_known[s] = int(np.count_nonzero(~np.isnan(ref[:, 0])))
                if self._n_known[s]:
                    # largest corner travel: the unknown corners (NaN) are skipped by fmax
                    diff = corners[:, :2] - ref
                    travel = math.sqrt(np.fmax.reduce(np.add.reduce(diff * diff, axis=1)))
                    if travel > self.max_landing_slide_m[key]:
                        self.max_landing_slide_m[key] = travel
            elif self._in_support[s]:
                self._off_ticks[s] += 1
                if self._off_ticks[s] >= LIFTOFF_TICKS:
                    self._in_support[s] = False

    def summary(self) -> dict:
        """The summary entries of the outcome (module docstring)."""
        return {
            "fell": self.fell, "fall_reason": self.fall_reason, "fall_time_s": self.fall_time,
            "max_tilt_deg": dict(self.max_tilt_deg), "tilt_bodies": dict(self.tilt_bodies),
            "joint_speed_exceedances": self.speed_exceedances,
            "max_joint_speed_ratio": self.max_speed_ratio, "max_joint_speed_joint": self.max_speed_joint,
            "max_landing_slide_m": max(self.max_landing_slide_m.values()),
            "landing_slide_m": dict(self.max_landing_slide_m), "touchdowns": dict(self.touchdowns),
        }


def _body_of_frame(robot, frame: str) -> str:
    """Name of the link (MuJoCo body) a Pinocchio frame is attached to: the frame itself when it is a body frame,
    else the BODY frame on the same joint closest up its parent chain."""
    import pinocchio as pin

    pm = robot.model
    fid = robot.frame_id(frame)
    f = pm.frames[fid]
    while f.type != pin.FrameType.BODY and f.parentFrame != fid:
        fid = f.parentFrame
        f = pm.frames[fid]
    return f.name
