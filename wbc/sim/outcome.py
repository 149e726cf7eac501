"""The outcome of a closed-loop run as an operator would judge it, checked every tick from MuJoCo's own data.

:class:`OutcomeMonitor` is fed the MuJoCo data once per control tick (after ``mj_step``: positions, contacts and
velocities of the new state) and decides:

* **fall** — the first of
  - base drop: the root body (the floating base, e.g. Talos' ``base_link`` = pelvis) lower over the terrain under
    the feet than at the start by more than :data:`FALL_HEIGHT_DROP` = 0.2 m — its height above the lower of the
    ground heights under the two soles' centres (``sim.terrain``; the plane z = 0 without a terrain), not above its
    start height: walking down stairs lowers the base with the ground the feet go to;
  - tilt: the **root body** (pelvis) or the **upper body** (the link above the waist joints,
    :func:`wbc.robot_inspect.upper_body_link`, whatever ``robot.torso`` names) tilted by more than
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
  that tick, at every tick a contact lies within :data:`CORNER_MATCH` of it again. A corner the sole lifts while it
  turns about another point of support (onto its toe, an edge or a bump under it) is not sliding: its displacement
  in the air is not counted, and it counts again if the corner touches down elsewhere. A support phase ends
  (lift-off) after :data:`LIFTOFF_TICKS` consecutive ticks without any foot–floor contact. The feet standing at
  t = 0 start a support phase too (their slide is measured from t = 0). Corners are the sole rectangle's
  (``robot.sole_corners_local``) in the sole frame, placed by MuJoCo's body pose.
* **MuJoCo warnings** — MuJoCo's own warnings (an unstable simulation, a contact buffer full...) are routed to
  Python from the first monitor on (:func:`route_mujoco_warnings`): reported as ``mujoco_warnings`` in the summary
  and as a :class:`RuntimeWarning`, instead of MuJoCo's default of printing them and appending them to
  ``MUJOCO_LOG.TXT`` in the current folder.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import mujoco
import numba as nb
import numpy as np

from wbc.compiled import CHECK_TYPES, once_per_process, specialise
from wbc.robot_inspect import upper_body_link

__all__ = ["OutcomeMonitor", "route_mujoco_warnings", "MUJOCO_WARNINGS", "FALL_HEIGHT_DROP", "FALL_TILT_DEG",
           "STRIKE_DEG", "STRIKE_MIN_FORCE", "CORNER_MATCH", "LIFTOFF_TICKS"]

FALL_HEIGHT_DROP = 0.2  #: m, base height drop that counts as a fall
FALL_TILT_DEG = 30.0  #: deg, pelvis or torso tilt from its nominal orientation that counts as a fall
STRIKE_DEG = 45.0  #: deg, a foot contact normal this far from the sole's normal is a toe/heel/edge strike
STRIKE_MIN_FORCE = 20.0  #: N, normal force below which such a contact is a graze, not a strike
CORNER_MATCH = 0.02  #: m, a contact point this close to a sole corner makes that corner a contact point
LIFTOFF_TICKS = 10  #: consecutive ticks without foot contact that end a support phase


#: Every MuJoCo warning text of this process since :func:`route_mujoco_warnings` was called, in order.
MUJOCO_WARNINGS: list[str] = []


def _on_mujoco_warning(text: str) -> None:
    MUJOCO_WARNINGS.append(text)
    import warnings

    warnings.warn(f"MuJoCo: {text}", RuntimeWarning, stacklevel=2)


def route_mujoco_warnings() -> None:
    """Make MuJoCo hand its warnings to Python (appended to :data:`MUJOCO_WARNINGS` and issued as a
    :class:`RuntimeWarning`) instead of writing ``MUJOCO_LOG.TXT`` in the current folder; process-wide, idempotent."""
    if mujoco.get_mju_user_warning() is not _on_mujoco_warning:
        mujoco.set_mju_user_warning(_on_mujoco_warning)


class _Checks(NamedTuple):
    """The model of :func:`_tick_kernel`'s checks and their state (:class:`OutcomeMonitor`'s arrays, built once)."""

    qvel_idx: np.ndarray          #: (nv − 6,) int64 MuJoCo dof of Pinocchio's v[6 + i]
    vlim: np.ndarray              #: (nv − 6,) joint speed limits (rad/s, inf: none)
    tilt_ids: np.ndarray          #: (2,) int64 bodies whose tilt is checked (pelvis, torso)
    up_local: np.ndarray          #: (2, 3) their body-fixed axis that points up at the start
    is_ground: np.ndarray         #: (ngeom + 1,) bool: the ground's geoms
    geom_side: np.ndarray         #: (ngeom + 1,) int64 foot side of each geom (0 left, 1 right, −1 none)
    is_hfield: np.ndarray         #: (ngeom + 1,) bool: heightfield ground geoms
    sole_body: np.ndarray         #: (2,) int64 the body of each sole
    corners_body: np.ndarray      #: (2, 3, 4) the sole corners in that body's frame (m)
    sole_normal_body: np.ndarray  #: (2, 3) the sole normal in that body's frame
    cos_strike: float             #: cosine of the largest angle of a foot contact's normal to its sole's
    ref: np.ndarray               #: (2, 4, 2) corner reference positions (xy) of the current support phase
    state: np.ndarray             #: (6,) int64 [n_known (2), in_support (2), off_ticks (2)] of the landing slide
    fo: np.ndarray                #: (5,) out: the float results


@nb.njit(cache=True)
def _tick_kernel(qvel, xmat, xpos, geom, pos, frame, checks, io):
    """One tick of :meth:`OutcomeMonitor.update`'s arithmetic (the checks' numbers; the verdicts stay in Python).

    ``geom`` (ncon, 2), ``pos`` (ncon, 3), ``frame`` (ncon, 9): MuJoCo's contacts. ``checks``: :class:`_Checks`,
    whose ``ref`` and ``state`` (the landing slide's per-side state) are updated in place.
    Writes ``fo`` (5,) = [worst |q̇|/q̇_max, cos tilt pelvis, cos tilt torso, slide travel left, right (NaN: none)]
    and ``io`` (≥ 8 + 3 ncon, int64) = [worst joint, exceedances, n bad, on a heightfield, n strike candidates, new
    support left, right, foot contacts, the bad geoms (n bad), the strike candidate contacts (n candidates), then
    from index 8 + 2 ncon the side of each contact (ncon): 0 left or 1 right (a foot on the ground), else -1].
    """
    (qvel_idx, vlim, tilt_ids, up_local, is_ground, geom_side, is_hfield, sole_body, corners_body, sole_normal_body,
     cos_strike, ref, state, fo) = checks
    ncon = geom.shape[0]
    io[:8] = 0
    # -- joint speed (numpy's argmax: the first maximum, or the first NaN)
    n = qvel_idx.size
    j = 0
    worst = abs(qvel[qvel_idx[0]]) / vlim[0]
    if worst == worst:
        for i in range(1, n):
            r = abs(qvel[qvel_idx[i]]) / vlim[i]
            if r != r:
                j, worst = i, r
                break
            if r > worst:
                j, worst = i, r
    count = 0
    if not worst <= 1.0:
        for i in range(n):
            if abs(qvel[qvel_idx[i]]) / vlim[i] > 1.0:
                count += 1
    fo[0] = worst
    io[0], io[1] = j, count
    # -- tilt: e_zᵀ R u0, clamped to [-1, 1]
    for i in range(2):
        b = tilt_ids[i]
        c = xmat[b, 6] * up_local[i, 0] + xmat[b, 7] * up_local[i, 1] + xmat[b, 8] * up_local[i, 2]
        c = -1.0 if -1.0 > c else c  # Python's max(c, -1.0), min(c, 1.0) (a NaN stays)
        fo[1 + i] = 1.0 if 1.0 < c else c
    # -- contacts: ground contacts sorted into foot contacts per side and non-foot geoms
    side_of = io[8 + 2 * ncon:8 + 3 * ncon]
    side_of[:] = -1
    n_bad = 0
    n_feet = np.zeros(2, dtype=np.int64)
    for i in range(ncon):
        g1, g2 = geom[i, 0], geom[i, 1]
        if is_ground[g1]:
            g, other = g1, g2
        elif is_ground[g2]:
            g, other = g2, g1
        else:
            continue
        s = geom_side[other]
        if s < 0:
            io[8 + n_bad] = other
            n_bad += 1
        else:
            side_of[i] = s
            n_feet[s] += 1
            if is_hfield[g]:
                io[3] = 1
    io[2] = n_bad
    io[7] = n_feet[0] + n_feet[1]
    # -- strike candidates: foot contacts whose normal is far from the sole's (side order, then contact order)
    n_cand = 0
    for s in range(2):
        if n_feet[s] == 0:
            continue
        b = sole_body[s]
        nb0, nb1, nb2 = sole_normal_body[s, 0], sole_normal_body[s, 1], sole_normal_body[s, 2]
        z0 = xmat[b, 0] * nb0 + xmat[b, 1] * nb1 + xmat[b, 2] * nb2
        z1 = xmat[b, 3] * nb0 + xmat[b, 4] * nb1 + xmat[b, 5] * nb2
        z2 = xmat[b, 6] * nb0 + xmat[b, 7] * nb1 + xmat[b, 8] * nb2
        for i in range(ncon):
            if side_of[i] == s:
                c = abs(frame[i, 0] * z0 + frame[i, 1] * z1 + frame[i, 2] * z2)
                if c < cos_strike:
                    io[8 + n_bad + n_cand] = i
                    n_cand += 1
    io[4] = n_cand
    # -- landing slide
    corners = np.empty((4, 3))
    for s in range(2):
        fo[3 + s] = np.nan
        if n_feet[s] == 0:
            if state[2 + s]:
                state[4 + s] += 1
                if state[4 + s] >= LIFTOFF_TICKS:
                    state[2 + s] = 0
            continue
        state[4 + s] = 0
        if not state[2 + s]:
            state[2 + s] = 1
            ref[s, :, :] = np.nan
            state[s] = 0
            io[5 + s] = 1
        b = sole_body[s]
        for c in range(4):  # R Cb + x
            for r in range(3):
                corners[c, r] = (xmat[b, 3 * r] * corners_body[s, 0, c] + xmat[b, 3 * r + 1] * corners_body[s, 1, c]
                                 + xmat[b, 3 * r + 2] * corners_body[s, 2, c]) + xpos[b, r]
        touching = 0  # bit c: a contact of this foot lies within CORNER_MATCH of corner c at this tick
        for i in range(ncon):
            if side_of[i] != s:
                continue
            k, dk = 0, 0.0
            for c in range(4):  # numpy's argmin: the first minimum, or the first NaN
                e0, e1, e2 = corners[c, 0] - pos[i, 0], corners[c, 1] - pos[i, 1], corners[c, 2] - pos[i, 2]
                dc = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
                if c == 0 or dc < dk or (dc != dc and dk == dk):
                    k, dk = c, dc
                if dc != dc:
                    break
            if dk <= CORNER_MATCH:
                touching |= 1 << k
                if ref[s, k, 0] != ref[s, k, 0]:
                    ref[s, k, 0], ref[s, k, 1] = corners[k, 0], corners[k, 1]
        known = 0
        for c in range(4):
            if ref[s, c, 0] == ref[s, c, 0]:
                known += 1
        state[s] = known
        m = np.nan
        for c in range(4):  # numpy.fmax over the touching corners: NaN (no contact at c) skipped
            if not (touching >> c) & 1:
                continue
            e0, e1 = corners[c, 0] - ref[s, c, 0], corners[c, 1] - ref[s, c, 1]
            dd = e0 * e0 + e1 * e1
            if dd == dd and not dd <= m:
                m = dd
        fo[3 + s] = math.sqrt(m)
    return fo, io


@once_per_process
def _warm_up() -> None:
    """Load :func:`_tick_kernel` (on-disk cache) once per process."""
    i1 = np.zeros(2, dtype=np.intp)
    checks = _Checks(i1, np.ones(2), i1, np.zeros((2, 3)), np.zeros(3, dtype=bool), np.full(3, -1, dtype=np.int64),
                     np.zeros(3, dtype=bool), np.zeros(2, dtype=np.int64), np.zeros((2, 3, 4)), np.zeros((2, 3)), 0.5,
                     np.zeros((2, 4, 2)), np.zeros(6, dtype=np.int64), np.zeros(5))
    for ncon, strided in ((1, False), (2, True)):
        _tick_kernel(np.zeros(3), np.zeros((3, 9)), np.zeros((3, 3)), *_contact_arrays(ncon, strided), checks,
                     np.zeros(8 + 3 * ncon, dtype=np.int64))


def _contact_arrays(ncon: int, strided: bool = False) -> tuple:
    """(geom (ncon, 2) int32, pos (ncon, 3), frame (ncon, 9)) of zeros, as MuJoCo's contact fields: strided views of
    its contact structs (numba layout 'A') when there are contacts, C-contiguous arrays when there are none."""
    return tuple(np.zeros((ncon, n + strided), dtype)[:, :n] for n, dtype in ((2, np.int32), (3, float), (9, float)))


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
        route_mujoco_warnings()
        self._warnings_from = len(MUJOCO_WARNINGS)
        robot = sim.robot
        model, d = sim.model, sim.data
        self.sim = sim
        pm = robot.model
        feet = [pm.frames[robot.frame_id(f)].parentJoint for f in (robot.left_sole, robot.right_sole)]
        self.tilt_body_ids = np.array([sim.root_body, sim.body_id(upper_body_link(pm, feet))])
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
        self._cos_min = [1.0, 1.0]  # the smallest tilt cosine so far (pelvis, torso): the largest tilt's
        self.speed_exceedances = 0
        self.max_speed_ratio, self.max_speed_joint = 0.0, ""
        self.max_landing_slide_m = {"left": 0.0, "right": 0.0}
        self.touchdowns = {"left": 0, "right": 0}
        self._ref = np.full((2, 4, 2), np.nan)  # corner reference positions (xy) of the current support phase
        self._first = True
        # the kernel's view of the above: [n_known (2), in_support (2), off_ticks (2)], and the soles' constants
        self._state = np.zeros(6, dtype=np.int64)
        self._sole_body_arr = np.array(self.sole_body, dtype=np.int64)
        self._corners_body_arr = np.ascontiguousarray(self._corners_body, dtype=float)  # (2, 3, 4)
        self._sole_normal_arr = np.ascontiguousarray(self._sole_normal_body, dtype=float)  # (2, 3)
        self.tilt_body_ids = np.asarray(self.tilt_body_ids, dtype=np.int64)
        self.geom_side = self.geom_side.astype(np.int64)
        self.qvel_idx = np.asarray(self.qvel_idx, dtype=np.int64)
        self._fo = np.empty(5)  # the kernel's outputs (io grows with the contact count)
        self._io = np.zeros(8 + 3 * 64, dtype=np.int64)
        self._views_of = None  # the MjData whose qvel, xmat, xpos views are kept in _qvel, _xmat, _xpos
        self._checks = _Checks(self.qvel_idx, self.vlim, self.tilt_body_ids, self.up_local, self.is_ground,
                               self.geom_side, self.is_hfield, self._sole_body_arr, self._corners_body_arr,
                               self._sole_normal_arr, self.cos_strike, self._ref, self._state, self._fo)
        _warm_up()
        # update's compiled call: MuJoCo's arrays (the contacts' strided, which reads the contiguous ones of a tick
        # without contact too) and this object's, of fixed types (wbc.compiled.specialise; with kernel type checks
        # on, the dispatcher)
        self._kernel = _tick_kernel if CHECK_TYPES else specialise(
            _tick_kernel, d.qvel, d.xmat, d.xpos, *_contact_arrays(2, strided=True), self._checks, self._io)
        # on terrain (stairs down) the base drop is measured over the ground under the feet (module docstring)
        self.on_terrain = getattr(sim, "terrain", None) is not None
        self.zf0 = self.support_height() if self.on_terrain else 0.0

    def support_height(self) -> float:
        """World height (m) of the ground under the feet: the lower of ``sim.terrain``'s heights under the two
        soles' centres (the mean of each sole's corners, from MuJoCo's body poses)."""
        x, y = np.array([self.corners_world(s)[:, :2].mean(axis=0) for s in (0, 1)]).T
        return float(np.min(self.terrain.height(x, y)))

    def corners_world(self, side: int) -> np.ndarray:
        """(4, 3) world positions (m) of the sole corners of ``side`` (0 left, 1 right) from MuJoCo's body pose."""
        d = self.sim.data
        b = self.sole_body[side]
        return (d.xmat[b].reshape(3, 3) @ self._corners_body[side]).T + d.xpos[b]

    def update(self, t: float) -> bool:
        """Check the state in ``sim.data`` (time ``t``, s). Returns whether the robot has fallen (so far)."""
        d = self.sim.data
        con = d.contact
        if d is not self._views_of:  # views of MuJoCo's arrays (fixed buffers of that MjData)
            self._qvel, self._xmat, self._xpos, self._qpos, self._views_of = d.qvel, d.xmat, d.xpos, d.qpos, d
        ints = self._io
        ncon = d.ncon
        if ints.shape[0] < 8 + 3 * ncon:
            ints = self._io = np.zeros(8 + 6 * ncon, dtype=np.int64)
        self._kernel(self._qvel, self._xmat, self._xpos, con.geom, con.pos, con.frame, self._checks, ints)
        j, n_over, n_bad, hfield, n_cand, new_left, new_right, n_feet = ints[:8].tolist()
        worst, c_pelvis, c_torso, travel_left, travel_right = self._fo.tolist()
        # -- joint speed ---------------------------------------------------------------------------------------
        self.speed_exceedances += n_over
        if worst > self.max_speed_ratio:
            self.max_speed_ratio, self.max_speed_joint = worst, self.joint_names[j]
        # -- tilt ----------------------------------------------------------------------------------------------
        # The kernel gives the cosines c; the angle acos(c) (degrees) grows as c falls, so only a cosine below the
        # smallest so far (_cos_min: a new largest tilt) or below the fall's (cos_tilt) can change max_tilt_deg or
        # the verdict. On every other tick (nearly all) acos is skipped: the same results, less work per tick. A NaN
        # cosine passes no comparison, as its NaN angle would not.
        max_tilt, cos_min, cos_tilt = self.max_tilt_deg, self._cos_min, self.cos_tilt
        tilted = []
        if c_pelvis < cos_min[0] or c_torso < cos_min[1] or c_pelvis < cos_tilt or c_torso < cos_tilt:
            for i, key, c in ((0, "pelvis", c_pelvis), (1, "torso", c_torso)):
                if c < cos_min[i] or c < cos_tilt:
                    deg = math.degrees(math.acos(c))
                    if deg > max_tilt[key]:
                        max_tilt[key] = deg
                    cos_min[i] = min(cos_min[i], c)
                    if c < cos_tilt:
                        tilted.append(f"{key} ({self.tilt_bodies[key]}) {deg:.1f}°")
        # -- landing slide (its state advanced by the kernel) --------------------------------------------------
        if (new_left or new_right) and not self._first:
            self.touchdowns["left"] += new_left
            self.touchdowns["right"] += new_right
        slide = self.max_landing_slide_m
        if travel_left > slide["left"]:
            slide["left"] = travel_left
        if travel_right > slide["right"]:
            slide["right"] = travel_right
        # -- contacts: non-foot geoms on the ground, foot strikes ----------------------------------------------
        strike = ""
        if not self.fell and n_feet:
            if hfield and self.terrain is not None:  # the facets' normals: the contact-by-contact pass
                strike = self._strike(con, *self._foot_contacts(con, ints[8 + 2 * ncon:8 + 3 * ncon].tolist()))
            elif n_cand:
                strike = self._strike_candidates(con, ints[8 + n_bad:8 + n_bad + n_cand].tolist())
        if not self.fell:
            if n_bad:
                bad = ints[8:8 + n_bad].tolist()
                names = sorted({self.sim.body_name(self.sim.model.geom_bodyid[g]) for g in bad})
                self.fall_reason = "non-foot contact with the ground: " + ", ".join(names)
            elif strike:
                self.fall_reason = strike
            elif self._qpos[2] - (self.support_height() if self.on_terrain else 0.0) \
                    < self.z0 - self.zf0 - FALL_HEIGHT_DROP:
                self.fall_reason = f"base height dropped by more than {FALL_HEIGHT_DROP} m"
            elif tilted:
                self.fall_reason = f"tilt > {FALL_TILT_DEG:g}° from nominal: " + ", ".join(tilted)
            if self.fall_reason:
                self.fell, self.fall_time = True, float(t)
        self._first = False
        return self.fell

    def _foot_contacts(self, con, side_of: list) -> tuple[tuple[list, list], list]:
        """This tick's foot–ground contacts from the side of each contact that :func:`_tick_kernel` sorted
        (``side_of``: 0 left, 1 right, -1 not a foot on the ground): (contact indices per side, those on a
        heightfield: the ground geom of a foot contact is the one of its two geoms that can be a heightfield)."""
        feet, on_hfield = ([], []), []
        hfield = self._hfield_list
        for i, (s, g1, g2) in enumerate(zip(side_of, con.geom1.tolist(), con.geom2.tolist())):
            if s >= 0:
                feet[s].append(i)
                if hfield[g1] or hfield[g2]:
                    on_hfield.append(i)
        return feet, on_hfield

    def _strike_candidates(self, con, candidates: list) -> str:
        """The first foot strike among the contacts ``candidates`` (foot contacts whose normal is more than
        :data:`STRIKE_DEG` from the sole's, in :meth:`_strike`'s order): the one pressing harder than
        :data:`STRIKE_MIN_FORCE`, described, or ""."""
        d = self.sim.data
        for i in candidates:
            mujoco.mj_contactForce(self.sim.model, d, i, self._force6)
            if self._force6[0] > STRIKE_MIN_FORCE:
                g1, g2 = int(con.geom1[i]), int(con.geom2[i])
                s = self._side_list[g2 if self._ground_list[g1] else g1]
                z0, z1, z2 = (d.xmat[self.sole_body[s]].reshape(3, 3) @ self._sole_normal_body[s]).tolist()
                n0, n1, n2 = con.frame[i, 0:3].tolist()
                return self._strike_text(s, abs(n0 * z0 + n1 * z1 + n2 * z2), con.pos[i])
        return ""

    def _strike_text(self, s: int, cos: float, p) -> str:
        angle = math.degrees(math.acos(min(1.0, cos)))
        x, y, z = (float(c) for c in p)
        return (f"foot strike: the {('left', 'right')[s]} foot hit the ground along a normal "
                f"{angle:.0f}° from its sole's ({self._force6[0]:.0f} N at ({x:.3f}, {y:.3f}, "
                f"{z:.3f}) m: a toe, heel or sole edge on a riser or nosing)")

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
                        return self._strike_text(s, cos, con.pos[i])
        return ""

    def summary(self) -> dict:
        """The summary entries of the outcome (module docstring)."""
        return {
            "fell": self.fell, "fall_reason": self.fall_reason, "fall_time_s": self.fall_time,
            "max_tilt_deg": dict(self.max_tilt_deg), "tilt_bodies": dict(self.tilt_bodies),
            "joint_speed_exceedances": self.speed_exceedances,
            "max_joint_speed_ratio": self.max_speed_ratio, "max_joint_speed_joint": self.max_speed_joint,
            "max_landing_slide_m": max(self.max_landing_slide_m.values()),
            "landing_slide_m": dict(self.max_landing_slide_m), "touchdowns": dict(self.touchdowns),
            "mujoco_warnings": MUJOCO_WARNINGS[self._warnings_from:] or None,
        }

