r"""Walks on terrain: footholds on treads, soles on the surface, swings over the edges, CoM height on the VRP.

:func:`plan_terrain_walk` starts from the flat-ground plan of :func:`wbc.gait.plan_walk` (footstep convention,
timing, xy LIPM/DCM) and fits it to a :class:`wbc.terrain.Terrain`:

1. **Footholds.** Steps are placed one after the other: each nominal landing (``step_length`` ahead of the stance
   foot, ``step_width`` beside it, :mod:`wbc.gait.footsteps`) is moved along the walking heading by the smallest
   shift (5 mm grid, at most ``max_shift``) for which the sole rectangle grown by ``edge_margin`` on every side
   lies on one planar surface (:meth:`wbc.terrain.Terrain.sole_support` ≤ 2 mm): full sole support, clear of the
   step edges. When the supported shifts around it are bounded by edges on both sides (a stair tread), a step
   down goes to the middle of them instead — centred on the tread, the same distance from the nosing behind and
   the one ahead, so that a foot landing a few centimetres short or long (an estimated base that drifts, a stance
   sole that creeps) still lands wholly on its tread —, a level step halfway there, and a step up to the back of
   them: the heel ``edge_margin`` in front of the nosing behind, the toe as far from the next riser as the tread
   allows. Going up, the stance leg is bent while the CoM rises over it and its shin leans forward over the nosing
   of the next tread, at the height of the rise above the sole: every millimetre the foot stands further back is
   margin between that shin and the nosing (record 49; a foot landing long moves towards the middle of its tread,
   one landing short has ``edge_margin``). The next step is measured from the shifted one — a step up's from
   halfway between its nominal landing and the middle of its tread, so that moving it back does not carry over to
   the steps after the climb (the footholds on the landing and down the stairs stay where they were). The xy plan
   is then re-solved for these footholds (:meth:`wbc.gait.WalkPlan.replan` at sample 0 from the same CoM state).
2. **Sole poses.** A foothold's sole origin sits at the terrain height under it; its z axis is the terrain
   normal there (the smallest rotation taking ``e_z`` to the normal, applied to the heading's yaw rotation), so
   soles lie flat on slopes.
3. **Swings** (:func:`wbc.gait.sample_feet` between the 3-D footholds; the height change made by a minimum-jerk
   blend over the first :data:`VERTICAL_LEAD` of the swing going up, over its last :data:`VERTICAL_LAG` going
   down, a step down moving horizontally over the first :data:`HORIZONTAL_LEAD` only — the foot rises before it moves
   over the next tread and leaves its tread before it descends —, a step up moving horizontally on a minimum-jerk
   profile that starts after :data:`STEP_UP_DELAY` of the swing, while the toe rises above the riser just ahead —,
   plus a clearance lift of height ``h``: level, the bump ``h · 64 s³ (1 − s)³`` of :mod:`wbc.gait.swing`;
   up or down, a lift by ``h`` over the first :data:`LIFT` of the swing (minimum jerk), held, and set down over its
   last :data:`LIFT` (the bump rises as ``s³`` while a step down already moves the foot over its own tread, and
   decays as ``(1 − s)³`` while a step up, moving forward late, brings its heel over the nosing of its tread: in
   both cases clearing the edge asked for a bump several times the clearance, and such a swing's momentum tips
   the robot): the swing
   sole's path is checked against the terrain
   (:meth:`wbc.terrain.Terrain.swing_clearance`, the underside 5 × 3 points, away from the lift-off and touch-down
   footholds by ``approach``); while its clearance is below ``clearance`` the apex ``h`` of that swing is raised
   by 1 cm, up to ``max_apex``.
4. **Step timing** (with ``max_sole_speed``): a swing's profiles are functions of its phase ``s = τ / T``, so its
   sole's peak speed ``v`` scales as ``1 / T``. A step whose swing would peak above ``max_sole_speed`` gets a time
   scale ``k = v / v_max``: its single support and the double support after it last ``k`` times longer (the
   swing rounded up to a whole sample), so its sole peaks at the bound. On stairs these are the steps with a height
   change: a swing from one tread to the tread after next covers two treads and the rise, and moves forward over
   only part of the swing (:data:`STEP_UP_DELAY`, :data:`HORIZONTAL_LEAD`); level steps keep ``t_ss``. Footholds
   and apexes do not depend on the timing; the xy plan is re-solved for it.
5. **CoM height**: the three-dimensional DCM of Englsberger, Ott & Albu-Schäffer ("Three-dimensional bipedal
   walking control based on divergent component of motion", IEEE T-RO 31(2), 2015, Sec. III): with the virtual
   repellent point (VRP) ``v = r_eCMP + (0, 0, Δz)``, ``Δz = g / ω²``, the CoM obeys ``c̈ = ω² (c − v)`` and the DCM
   ``ξ = c + ċ/ω`` obeys ``ξ̇ = ω (ξ − v)`` in all three axes with one constant ω. The xy part is the plan's LIPM
   (eCMP = ZMP reference); the z part is solved by the same exact piecewise-linear recursion
   (:func:`wbc.gait.plan_lipm`) for ``v_z`` = the stance sole's height + ``Δz`` in single support, linear between
   the two stance heights in double support (the schedule of :mod:`wbc.gait.schedule` applied to heights; before a
   step down the single support already goes linearly to the lower height, so that the stance leg bends and the
   swing leg reaches the lower tread), so the
   CoM stays ``Δz`` (the initial CoM height) above the supporting ground at rest and moves between levels along
   the DCM plan.

On the flat terrain (:attr:`wbc.terrain.Terrain.is_flat`) the plan is :func:`wbc.gait.plan_walk`'s, unchanged.
A terrain plan is not meant for :meth:`wbc.gait.WalkPlan.replan` (which keeps a constant CoM height).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from wbc.exceptions import GaitError
from wbc.gait.com_plan import plan_lipm
from wbc.gait.footsteps import Footstep, plan_footsteps, pose_to_xy_yaw
from wbc.gait.schedule import RIGHT_SUPPORT, zmp_segments
from wbc.gait.swing import sample_feet
from wbc.gait.walk import WalkPlan, plan_walk
from wbc.profiles import min_jerk
from wbc.terrain import Terrain, parse_terrain

__all__ = ["TerrainWalk", "plan_terrain_walk", "steps_to_cross", "foothold_pose", "SUPPORT_TOL"]

VERTICAL_LEAD = 0.6  #: fraction of a swing, at its start, over which a step up rises
HORIZONTAL_LEAD = 0.7  #: fraction of a step-down swing, at its start, over which it moves horizontally
#: fraction of a step-up swing, at its start, before it moves forward: the toe rises first (in the plant the sole
#: lags its vertical plan early in the swing, so a toe moving forward at once passes the riser ahead too low)
STEP_UP_DELAY = 0.2
LIFT = 0.3  #: fraction of a swing, at its start and at its end, over which the clearance lift rises and falls
VERTICAL_LAG = 0.35  #: fraction of a swing, at its end, over which a step down descends (the heel first clears the edge)
SUPPORT_TOL = 0.002  #: m: largest gap under a sole (grown by the edge margin) that counts as full support
_SHIFT_STEP = 0.005  # m: grid of the foothold search


@dataclass(frozen=True, eq=False)
class TerrainWalk:
    """A walk plan fitted to a terrain.

    Attributes:
        plan: the :class:`wbc.gait.WalkPlan` (3-D sole poses and CoM).
        terrain: the terrain it was planned on.
        footholds: (m, 4, 4) world landing poses of the sole frames, in step order (``plan.footsteps`` order).
        shifts: (m,) shift (m) of each foothold along the heading from its nominal position.
        apex: (m,) clearance bump ``h`` (m) of each swing.
        planned_clearance: (m,) minimum clearance (m) of each planned swing over the terrain
            (:meth:`wbc.terrain.Terrain.swing_clearance`; inf when the swing is too short to be counted).
        approach: distance (m) from the footholds within which clearance is not counted.
    """

    plan: WalkPlan
    terrain: Terrain
    footholds: np.ndarray
    shifts: np.ndarray
    apex: np.ndarray
    planned_clearance: np.ndarray
    approach: float


def foothold_pose(terrain: Terrain, x: float, y: float, yaw: float) -> np.ndarray:
    """(4, 4) world pose of a sole frame standing at ``(x, y)`` with heading ``yaw`` (rad) on the terrain: origin at
    the terrain height, z axis along the terrain normal (the smallest rotation from ``e_z``), x axis the heading
    tilted with the surface."""
    n = terrain.normal(x, y)
    c, s = math.cos(yaw), math.sin(yaw)
    Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    axis = np.cross([0.0, 0.0, 1.0], n)
    sin_a, cos_a = float(np.linalg.norm(axis)), float(n[2])
    if sin_a < 1e-12:
        R = Rz
    else:
        k = axis / sin_a
        K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
        R = (np.eye(3) + sin_a * K + (1.0 - cos_a) * K @ K) @ Rz
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = (x, y, terrain.height(x, y))
    return T


def _place(terrain: Terrain, x: float, y: float, yaw: float, length: float, width: float, margin: float,
           max_shift: float, below: float | None = None) -> tuple[float, float] | None:
    """(Shift along the heading (m) giving full sole support, the shift the next step is measured from), or None.
    ``d``: the smallest supported shift (5 mm grid, within ``max_shift``); when edges bound the run of supported
    shifts holding ``d`` on both sides (a tread), its middle ``m`` (the sole centred on the tread) for a foothold
    lower than ``below`` (m, the stance sole's height: a step down), its lowest end (the back of the tread) for a
    foothold higher than ``below`` (a step up; the next step measured from ``(d + m) / 2``), else ``(d + m) / 2``;
    ``d`` when the run is not bounded (a landing, the floor)."""
    c, s = math.cos(yaw), math.sin(yaw)
    n = int(max_shift / _SHIFT_STEP)
    ok = [terrain.sole_support(x + c * k * _SHIFT_STEP, y + s * k * _SHIFT_STEP, yaw, length, width, margin)
          <= SUPPORT_TOL for k in range(-n, n + 1)]
    best = min((k for k in range(-n, n + 1) if ok[k + n]), key=lambda i: (abs(i), i), default=None)
    if best is None:
        return None
    d = best * _SHIFT_STEP
    lo, hi = best, best
    while lo - 1 >= -n and ok[lo - 1 + n]:
        lo -= 1
    while hi + 1 <= n and ok[hi + 1 + n]:
        hi += 1
    if lo == -n or hi == n:
        return d, d
    mid = 0.5 * (lo + hi) * _SHIFT_STEP
    z = terrain.height(x + c * mid, y + s * mid)
    if below is not None and z > below + 1e-3:  # a step up: the back of the tread
        return lo * _SHIFT_STEP, 0.5 * (d + mid)
    if below is not None and z >= below - 1e-3:
        return 0.5 * (d + mid), 0.5 * (d + mid)
    return mid, mid


def _footholds(terrain: Terrain, footsteps, left: np.ndarray, right: np.ndarray, length: float, width: float,
               edge_margin: float, max_shift: float | None, step_length: float) -> tuple[list[Footstep], list[float]]:
    """Step 1 of the module docstring: the flat plan's ``footsteps`` placed one after the other on ``terrain`` from
    the sole poses ``left``, ``right`` ((4, 4), world). Returns (the shifted footsteps, their shifts in m).

    Raises:
        GaitError: a step without a foothold of full sole support within ``max_shift`` (default: half the step
            length, at least half the sole length).
    """
    pos = {"left": (float(left[0, 3]), float(left[1, 3])), "right": (float(right[0, 3]), float(right[1, 3]))}
    steps, shifts = [], []
    for i, fs in enumerate(footsteps):
        step, d, ref = _foothold(terrain, i, fs, footsteps[i - 1] if i else None, pos, length, width, edge_margin,
                                 max_shift, step_length)
        steps.append(step)
        shifts.append(d)
        pos[fs.side] = ref
    return steps, shifts


def _foothold(terrain: Terrain, i: int, fs: Footstep, prev: Footstep | None, pos: dict, length: float, width: float,
              edge_margin: float, max_shift: float | None, step_length: float) -> tuple[Footstep, float, tuple]:
    """Footstep ``i`` (``fs``, after the flat footstep ``prev``) placed from the xy ``pos`` (by side) the next steps
    are measured from: (the shifted footstep, its shift in m, the xy the next step is measured from); see
    :func:`_footholds`."""
    if max_shift is None:
        max_shift = max(0.5 * abs(step_length), 0.5 * length)
    stance = "right" if fs.side == "left" else "left"
    if prev is None:
        x, y = fs.x, fs.y
    else:  # the nominal offset from the (shifted) stance foot
        x, y = pos[stance][0] + (fs.x - prev.x), pos[stance][1] + (fs.y - prev.y)
    placed = _place(terrain, x, y, fs.yaw, length, width, edge_margin, max_shift, terrain.height(*pos[stance]))
    if placed is None:
        raise GaitError(f"step {i + 1} ({fs.side}): no foothold with the whole sole ({length} x {width} m) on one "
                        f"surface and {edge_margin} m from its edges within {max_shift:.3f} m of ({x:.3f}, "
                        f"{y:.3f}) m; change step_length (now {step_length} m) or edge_margin")
    (d, r), c, s = placed, math.cos(fs.yaw), math.sin(fs.yaw)
    return Footstep(fs.side, x + c * d, y + s * d, fs.yaw), d, (x + c * r, y + s * r)


def steps_to_cross(terrain: Terrain | str, left_sole, right_sole, *, step_length: float,
                   step_width: float | None = None, sole_length: float = 0.21, sole_width: float = 0.13,
                   first_side: str = "left", edge_margin: float = 0.02, max_shift: float | None = None,
                   on_terrain: bool = True, max_steps: int = 200) -> int | None:
    """The number of steps a straight walk needs to cross ``terrain``: the smallest ``n_steps`` ≥ 2 whose footholds
    (step 1 of the module docstring, as :func:`plan_terrain_walk` places them; ``on_terrain=False``: the flat plan's
    footsteps, a walk planned blind) put both heels past :attr:`wbc.terrain.Terrain.end_x`, i.e.
    ``min(x_left, x_right) − sole_length / 2 ≥ end_x`` for the last two footholds.

    Args:
        terrain: a :class:`wbc.terrain.Terrain` or its description. left_sole, right_sole: (4, 4) world poses of the
            sole frames at the start. step_length: m per step (> 0 to cross anything). step_width: m (default the
            current lateral distance of the soles). sole_length, sole_width: m. first_side: the foot that swings
            first. edge_margin, max_shift: as :func:`plan_terrain_walk`. max_steps: the largest count tried.

    Returns:
        The count, or None when the terrain has no end (``end_x`` None), ``step_length`` ≤ 0, or no count up to
        ``max_steps`` crosses it.

    Raises:
        GaitError: a step without a foothold (as :func:`plan_terrain_walk`). TerrainError: a bad description.
    """
    terrain = parse_terrain(terrain)
    end = terrain.end_x
    if end is None or not step_length > 0:
        return None
    L, R = np.asarray(left_sole, dtype=float), np.asarray(right_sole, dtype=float)
    lft, rgt = pose_to_xy_yaw(L), pose_to_xy_yaw(R)
    if step_width is None:  # as plan_walk: the current lateral distance along the mean heading
        heading = math.atan2(math.sin(lft[2]) + math.sin(rgt[2]), math.cos(lft[2]) + math.cos(rgt[2]))
        step_width = -(lft[0] - rgt[0]) * math.sin(heading) + (lft[1] - rgt[1]) * math.cos(heading)
    # the walking steps 1 .. n - 1 of every count are the same: place them once, one after the other; count n adds
    # its closing step, which lands beside the last walking foot, so never past it: its heel decides first
    walking = plan_footsteps(lft, rgt, max_steps + 1, step_length, step_width, 0.0, first_side)[:-1]
    pos = {"left": (lft[0], lft[1]), "right": (rgt[0], rgt[1])}
    args = (sole_length, sole_width, edge_margin, max_shift, step_length)
    for n in range(2, max_steps + 1):
        i = n - 2  # the last walking step of count n
        fs = walking[i]
        step, _, ref = (_foothold(terrain, i, fs, walking[i - 1] if i else None, pos, *args) if on_terrain
                        else (fs, 0.0, (fs.x, fs.y)))
        pos[fs.side] = ref
        if end > step.x - 0.5 * sole_length:
            continue
        close = plan_footsteps(lft, rgt, n, step_length, step_width, 0.0, first_side)[-1]
        last = _foothold(terrain, n - 1, close, fs, pos, *args)[0] if on_terrain else close
        if end <= min(step.x, last.x) - 0.5 * sole_length:
            return n
    return None


def plan_terrain_walk(terrain: Terrain | str, left_sole, right_sole, com, *, edge_margin: float = 0.02,
                      clearance: float = 0.05, max_apex: float = 0.35, max_shift: float | None = None,
                      approach: float | None = None, max_sole_speed: float | None = None, **walk) -> TerrainWalk:
    """Plan a walk on ``terrain`` (module docstring).

    Args:
        terrain: a :class:`wbc.terrain.Terrain` or its description (:func:`wbc.terrain.parse_terrain`).
        left_sole, right_sole, com: as :func:`wbc.gait.plan_walk` (the robot starts on ``z = 0``).
        edge_margin: distance (m, ≥ 0) between every sole edge and the edge of its tread.
        clearance: smallest height (m, ≥ 0) of the swing sole above the terrain away from the footholds.
        max_apex: largest clearance bump (m) tried per swing.
        max_shift: largest foothold shift (m) along the heading (default: half the step length, at least half the
            sole length).
        approach: distance (m) from the footholds within which swing clearance is not counted (default half the
            sole length).
        max_sole_speed: largest speed (m/s, > 0) of a swing sole's origin; a step whose swing would be faster
            gets a longer single support (step timing, module docstring). None: every step lasts ``t_ss``.
        **walk: keywords of :func:`wbc.gait.plan_walk` (``n_steps``, ``step_length``, ``t_ss`` ...); ``turn`` and
            ``step_lateral`` must be 0 off flat ground.

    Returns:
        A :class:`TerrainWalk`.

    Raises:
        GaitError: a bad argument, a step for which no foothold with full sole support exists within
            ``max_shift`` (the message gives the step and its nominal position), or a swing that cannot clear the
            terrain by ``clearance`` with an apex up to ``max_apex``.
        TerrainError: a bad terrain description.
    """
    terrain = parse_terrain(terrain)
    for name, val in (("edge_margin", edge_margin), ("clearance", clearance), ("max_apex", max_apex)):
        if not (isinstance(val, (int, float)) and math.isfinite(val) and val >= 0):
            raise GaitError(f"{name} must be a finite number >= 0 (m); got {val!r}")
    if max_sole_speed is not None and not (isinstance(max_sole_speed, (int, float)) and
                                            math.isfinite(max_sole_speed) and max_sole_speed > 0):
        raise GaitError(f"max_sole_speed must be None or a finite number > 0 (m/s); got {max_sole_speed!r}")
    plan = plan_walk(left_sole, right_sole, com, **walk)
    if terrain.is_flat:
        return TerrainWalk(plan, terrain, np.array([fs.pose() for fs in plan.footsteps]).reshape(-1, 4, 4),
                           np.zeros(len(plan.footsteps)), np.full(len(plan.footsteps), float(walk.get(
                               "step_height", 0.05))), np.full(len(plan.footsteps), math.inf), 0.0)
    if walk.get("turn", 0.0) or walk.get("step_lateral", 0.0):
        raise GaitError("turn and step_lateral must be 0 on terrain (straight walks only)")
    length, width = plan.sole_length, plan.sole_width
    approach = 0.5 * length if approach is None else float(approach)

    # 1. footholds, one after the other
    steps, shifts = _footholds(terrain, plan.footsteps, plan.left_sole[0], plan.right_sole[0], length, width,
                               edge_margin, max_shift, float(walk.get("step_length", 0.15)))
    com = np.asarray(com, dtype=float)
    vel = np.zeros(3) if walk.get("com_velocity") is None else np.asarray(walk["com_velocity"], dtype=float)
    plan = plan.replan(0, com, vel, steps, check_start=walk.get("check_start", True))

    # 2. sole poses on the surface; 3. swings over the edges; step timing
    holds = np.array([foothold_pose(terrain, f.x, f.y, f.yaw) for f in steps])
    h0 = float(walk.get("step_height", 0.05))
    args = (terrain, steps, holds, h0, length, width, approach, clearance, max_apex)
    poses, vels, apex, planned = _fit_swings(plan, *args)
    if max_sole_speed is not None:
        scale = _step_timing(plan, vels, max_sole_speed)
        if max(scale) > 1.0:  # the step (its single support and the double support after it) k times longer
            t_ss, t_ds = float(walk.get("t_ss", 0.8)), float(walk.get("t_ds", 0.3))
            up = [math.ceil(t_ss * k / plan.dt - 1e-9) * plan.dt for k in scale]  # (whole samples, not shorter)
            timing = {"t_ss": up, "t_ds": [t_ds * k for k in scale[:-1]] + [t_ds]}
            plan = plan_walk(left_sole, right_sole, com, **{**walk, **timing})
            plan = plan.replan(0, com, vel, steps, check_start=walk.get("check_start", True))
            poses, vels, apex, planned = _fit_swings(plan, *args)
    n, dt = plan.n_samples, plan.dt
    initial = np.array([plan.left_sole[0], plan.right_sole[0]])

    # 5. CoM height from the VRP (Englsberger et al. 2015): heights scheduled as the ZMP reference
    seg = plan.segments
    zl, zr = float(initial[0][2, 3]), float(initial[1][2, 3])
    zsteps = [Footstep(f.side, float(H[2, 3]), float(H[2, 3]), f.yaw) for f, H in zip(steps, holds)]
    zseg = zmp_segments(list(plan.phases), zsteps, (zl, zl), (zr, zr), int(seg.count[-2]))
    zseg = _lower_before_stepping_down(zseg, list(plan.phases), holds)
    dz = float(com[2]) - 0.5 * (zl + zr)
    zstart = zseg.start[:, :1].repeat(2, axis=1) + dz
    zend = zseg.end[:, :1].repeat(2, axis=1) + dz
    zl_plan = plan_lipm(zseg.first, zseg.count, zstart, zend, np.full(2, float(com[2])), np.full(2, float(vel[2])),
                        plan.omega, dt)
    zs = zl_plan.sample(0.0)
    buf = np.empty((n, 13))
    buf[:, 0:3], buf[:, 3:6], buf[:, 6:9] = plan.com, plan.com_vel, plan.com_acc
    buf[:, 9:11], buf[:, 11:13] = plan.zmp, plan.dcm
    buf[:, 2], buf[:, 5], buf[:, 8] = zs.com[:, 0], zs.com_vel[:, 0], zs.com_acc[:, 0]
    buf.flags.writeable = False
    for a in (poses, vels):
        a.flags.writeable = False
    plan = dataclasses.replace(plan, com=buf[:, 0:3], com_vel=buf[:, 3:6], com_acc=buf[:, 6:9], zmp=buf[:, 9:11],
                               dcm=buf[:, 11:13], left_sole=poses[0], right_sole=poses[1], left_sole_vel=vels[0],
                               right_sole_vel=vels[1])
    holds.flags.writeable = False
    return TerrainWalk(plan, terrain, holds, np.array(shifts), apex, planned, approach)



def _lower_before_stepping_down(zseg, phases, holds: np.ndarray):
    """Height schedule with every step down anticipated: in the single support of a swing landing lower than its
    stance foot, the height reference goes linearly from the stance height to the landing height (the stance leg
    bends, so that the swing leg reaches the lower tread), and the double support after it stays there."""
    start, end = zseg.start.copy(), zseg.end.copy()
    for j in range(len(start)):
        ph = phases[int(zseg.phase[j])]
        if ph.step < 0:
            continue
        z_land = float(holds[ph.step][2, 3])
        if z_land < start[j, 0] - 1e-9:
            end[j] = z_land
            if j + 1 < len(start):
                start[j + 1] = z_land
    return type(zseg)(zseg.first, zseg.count, start, end, zseg.phase)


def _swing_profiles(n_ss: int, T: float) -> dict:
    """Profiles of ``s = 0, 1/n, ..., (n-1)/n`` for a swing of ``n_ss`` samples lasting ``T`` s (steps 2–3 of the
    module docstring): (value, time derivative in 1/s) pairs."""
    s = np.arange(n_ss) / n_ss
    sm = s * (1.0 - s)
    r_b, r_db, _ = min_jerk(np.minimum(s / LIFT, 1.0))
    f_b, f_db, _ = min_jerk(np.minimum((1.0 - s) / LIFT, 1.0))
    up_b, up_db, _ = min_jerk(np.minimum(s / VERTICAL_LEAD, 1.0))
    dn_b, dn_db, _ = min_jerk(np.maximum((s - 1.0 + VERTICAL_LAG) / VERTICAL_LAG, 0.0))
    fw_b, fw_db, _ = min_jerk(np.minimum(s / HORIZONTAL_LEAD, 1.0))
    up_xy_b, up_xy_db, _ = min_jerk(np.maximum((s - STEP_UP_DELAY) / (1.0 - STEP_UP_DELAY), 0.0))
    return {
        "bump": (64.0 * sm**3, 192.0 * sm**2 * (1.0 - 2.0 * s) / T),  # level: the bump of wbc.gait.swing
        # up or down: clearance lift up by h over the first LIFT of the swing, held, set down over its last LIFT
        "lift": (r_b * f_b, (r_db * f_b - r_b * f_db) / (LIFT * T)),
        "up": (up_b, up_db / (VERTICAL_LEAD * T)),  # height rising over the first VERTICAL_LEAD
        "down": (dn_b, dn_db / (VERTICAL_LAG * T)),  # height descending over the last VERTICAL_LAG
        "forward_down": (fw_b, fw_db / (HORIZONTAL_LEAD * T)),
        "forward_up": (up_xy_b, up_xy_db / ((1.0 - STEP_UP_DELAY) * T)),
    }


def _fit_swings(plan: WalkPlan, terrain: Terrain, steps: list[Footstep], holds: np.ndarray, h0: float,
                length: float, width: float, approach: float, clearance: float, max_apex: float):
    """Steps 2–3 of the module docstring on ``plan``'s timing: (poses (2, N, 4, 4), velocities (2, N, 6), apex (m,),
    planned clearance (m,))."""
    swings = [ph for ph in plan.phases if ph.step >= 0]
    foot = [0 if steps[ph.step].side == "left" else 1 for ph in swings]
    n, dt = plan.n_samples, plan.dt
    initial = np.array([plan.left_sole[0], plan.right_sole[0]])
    poses, vels = sample_feet(n, initial, holds[[ph.step for ph in swings]], foot, [ph.first for ph in swings],
                              [ph.count for ph in swings], dt, 0.0)
    apex, planned = np.zeros(len(steps)), np.full(len(steps), math.inf)
    latest = [initial[0], initial[1]]
    for ph, f in zip(swings, foot):
        a, b = ph.first, ph.first + ph.count
        pr = _swing_profiles(ph.count, ph.count * dt)
        start, land = latest[f][:3, 3].copy(), holds[ph.step][:3, 3]
        z0, z1 = float(latest[f][2, 3]), float(holds[ph.step][2, 3])
        zb, zdb = pr["up"] if z1 >= z0 else pr["down"]
        poses[f, a:b, 2, 3] = z0 + (z1 - z0) * zb
        vels[f, a:b, 2] = (z1 - z0) * zdb
        dxy = holds[ph.step][:2, 3] - latest[f][:2, 3]
        if z1 < z0 - 1e-3:  # step down: over the lower tread first, then down
            xb, xdb = pr["forward_down"]
            poses[f, a:b, :2, 3] = latest[f][:2, 3] + np.outer(xb, dxy)
            vels[f, a:b, :2] = np.outer(xdb, dxy)
        elif z1 > z0 + 1e-3:  # step up: forward only after STEP_UP_DELAY, while the toe rises above the riser ahead
            xb, xdb = pr["forward_up"]
            poses[f, a:b, :2, 3] = latest[f][:2, 3] + np.outer(xb, dxy)
            vels[f, a:b, :2] = np.outer(xdb, dxy)
        prof, dprof = pr["bump"] if abs(z1 - z0) <= 1e-3 else pr["lift"]
        base = poses[f, a:b].copy()
        h = h0
        while True:
            seg = base.copy()
            seg[:, 2, 3] += h * prof
            c = terrain.swing_clearance(seg, start, land, length, width, approach)
            if c >= clearance - 1e-12:
                break
            if h + 0.01 > max_apex + 1e-12:
                raise GaitError(f"step {ph.step + 1} ({steps[ph.step].side}): the swing clears the terrain by only "
                                f"{c:.3f} m with an apex of {h:.2f} m (needs {clearance} m; max_apex {max_apex} m)")
            h += 0.01
        poses[f, a:b, 2, 3] += h * prof
        vels[f, a:b, 2] += h * dprof
        apex[ph.step], planned[ph.step] = h, c
        latest[f] = holds[ph.step]
    return poses, vels, apex, planned


def _step_timing(plan: WalkPlan, vels: np.ndarray, max_sole_speed: float) -> list[float]:
    """Time scale ``k ≥ 1`` of each step: 1, or ``v_peak / v_max`` when the swing sole's peak speed ``v_peak``
    (``vels``, the swing of ``plan``) exceeds ``max_sole_speed``. Every profile of a swing is a function of its
    phase ``s = τ / T``, so the sole's speed scales as ``1 / T``: a swing ``k`` times longer peaks at ``v_max``."""
    out = []
    for ph in plan.phases:
        if ph.step < 0:
            continue
        f = 0 if ph.support == RIGHT_SUPPORT else 1
        v = float(np.linalg.norm(vels[f, ph.first:ph.end, :3], axis=1).max())
        out.append(max(1.0, v / max_sole_speed))
    return out
