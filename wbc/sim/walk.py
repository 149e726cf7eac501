"""``wbc sim walk``: the gait plan tracked closed loop by the inverse-dynamics controller in MuJoCo (500 Hz).

Per control tick (the scenario's :meth:`WalkScenario.update`, then the controller, then one ``mj_step``):

* **Plan** (:func:`wbc.gait.plan_walk`, sampled at the control period): footsteps, LIPM CoM/DCM trajectory
  (Englsberger et al. 2015), swing-foot poses and velocities. The swing-foot **acceleration feed-forward** is
  the plan's sole velocity differentiated by central differences (``np.gradient``, the plan being sampled at dt).
* **Contacts**: the stance soles are the QP's contacts; contact switching (force ramp-out before lift-off,
  state-based touch-down, ramp-in) by :class:`wbc.dynamics.contact_switching.ContactSwitcher`. The ramp-out
  starts ``ramp_time`` before the planned lift-off so the foot is released unloaded at the planned time.
  Touch-down is detected **from the measured state: sole height ≤ 3 mm and vertical sole velocity ≤ 0.05 m/s**,
  or, with an estimated state, **from the ankle F/T sensors: measured normal force ≥ 5 % of the weight**
  (``touchdown_load``), armed from mid-swing. Late touch-down: after the planned landing the foot reference keeps descending at
  ``descent_speed`` (default 0.1 m/s, at most 2 cm below the floor; on terrain and blind at least 0.3 m/s, at most
  5 cm below the planned landing: the estimated heights drift there) until the detection fires; early touch-down
  switches the contact on at once. Blind (``blind``), the swing sole rises to its clearance height over the first
  ``BLIND_LIFT`` of the swing, is over its foothold by ``BLIND_XY_END`` of the swing and descends vertically, aimed
  at the stance sole's measured height (:func:`wbc.gait.blind.blind_swing_into`); a loaded stance sole rotating about a
  line of its sole has its contact cut to a band about that line (partial footholds,
  :meth:`WalkScenario._partial_footholds`). Blind and on planned terrain the planned CoM height is raised by the
  supporting soles' measured − planned height (:meth:`WalkScenario._support_offset`).
* **Swing tracking**: the swing foot's task weighs the sole's height ``swing_height_weight`` (default 3) times its
  horizontal position, so a swing faster than the legs can follow lags horizontally and keeps its clearance.
* **CoM / DCM**: with ``stabilizer=False`` the CoM task tracks the planned CoM (PD + acceleration feed-forward).
  With ``stabilizer=True`` (default) the horizontal CoM acceleration comes from a DCM tracking law with CoP
  feedback and integral action (:class:`DcmStabilizer`); the CoM height keeps its PD task.

* **Step adjustment** (``step_adjust``, default on): during the single support of a released swing foot, the
  landing point follows the measured DCM (:class:`wbc.gait.step_adjustment.StepAdjuster`: Khadiv et al. 2016
  eq. 6–7, dead band 2 cm on the DCM error, reach box and minimum width between the feet); when it moves by
  more than 1 cm the DCM plan and the swing are replanned from the new footstep and the measured CoM state
  (:meth:`wbc.gait.WalkPlan.replan` with ``footsteps``), the remaining footsteps moving with it. No change in the
  last ``adjust_freeze`` s of a swing. After the last step, a DCM outside the soles' hull (shrunk 2 cm) starts a
  capture step (a 2-step walk planned from the measured state). Step timing adjustment (``adjust_timing``, default
  on): a swing whose landing correction the reach clips by more than 5 cm is cut short (eq. 2), no more than its foot
  can still travel at ``max_swing_speed``; late in a swing, a landing the foot can no longer reach in time lengthens
  the swing instead (``WalkScenario._stretch``). The stabilizer may put the CMP outside the support area by
  ``cmp_offset`` (hip strategy, :class:`DcmStabilizer`).

Summary (``extra_summary``): walked vs commanded distance (feet mid-point, m) and final heading (rad), per-step
landing error (m, sole xy vs planned footstep at touch-down), stance slip per stance interval (m, max xy
displacement of a loaded stance sole from its position when fully loaded until its ramp-out begins), minimum
measured CoP margin (m, the CoP of the plant's foot contact wrenches to the edge of the convex hull of the
loaded soles, ≥ 10 N each; negative outside), touch-down times vs plan, ``support_cuts`` (blind: ticks at which a
sole's contact band was set or moved, :meth:`WalkScenario._partial_footholds`). Falls, solver failures and the
real-time factor come from :func:`wbc.sim.scenarios.summarize` (its QP CoP margin uses each contact's rectangle at
the end of the run, not a band cut meanwhile).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
import pinocchio as pin

from wbc.compiled import once_per_process
from wbc.dynamics.contact_switching import ContactSwitcher
from wbc.estimation import zmp_from_wrenches
from wbc.exceptions import GaitError, InvalidInputError
from wbc.geometry import convex_hull, mean_heading, polygon_margin, projected_sole_corners
from wbc.geometry import hull as hull_vertices
from wbc.gait import Footstep, plan_walk
from wbc.gait.blind import BLIND_CUT_LOAD, BLIND_XY_END, blind_swing_into, clip_band_range, roll_band
from wbc.gait.commands import feet_can_yaw
from wbc.gait.stabilizer import DcmStabilizer, closest_point_xy, stabilizer_kernel, support_kernel
from wbc.gait.step_adjustment import StepAdjuster, StretchLimits
from wbc.profiles import min_jerk
from wbc.scenarios.framework import Criterion, evaluate
from wbc.sim.physics_scenarios import contacts_rank_deficient
from wbc.sim.scenarios import NO_FALL, timed_push

__all__ = ["WalkScenario", "TOUCHDOWN_CONFIRM_LOAD", "measured_cop", "walk_acceptance", "walk_criteria"]

_CODE_SWING = {1: "right", 2: "left"}  # plan support code → swinging side
_PHASE_CODE = {"stance": 0, "unloading": 1, "swing": 2, "loading": 3}  # contact phase → its code in the log


def measured_cop(wrench: np.ndarray, sole_pos: np.ndarray, min_fz: float = 10.0,
                 height: float = 0.0) -> np.ndarray | None:
    """CoP (2,) on the plane z = ``height`` (m, world) of the plant's foot wrenches.

    Args:
        wrench: (2, 6) ground reaction per foot: force (N), moment (N·m) about the sole origin, world axes.
        sole_pos: (2, 3) sole origins (m, world).
        min_fz: total normal force (N) below which there is no CoP (None).
        height: height (m, world) of the plane: 0 on flat ground, the loaded treads' height on terrain (on the plane
            z = 0 a tread at height h moves the point by h F_xy / F_z).

    With the total force F and the moment about (0, 0, h) M = Σ (τ_i + o_i × f_i) − (0, 0, h) × F, a force F at
    p = (p_x, p_y, h) has moment (p − (0, 0, h)) × F, so p_x = −M_y / F_z, p_y = M_x / F_z (Sardain & Bessonnet 2004,
    ZMP = CoP on a plane contact); computed by :func:`wbc.estimation.zmp_from_wrenches` with world-aligned sole
    frames.
    """
    eye = np.eye(3)
    return zmp_from_wrenches(wrench, [pin.SE3(eye, np.asarray(o, dtype=float)) for o in sole_pos], min_fz, height)


def _sole_tracks(model, q: np.ndarray, fid: dict) -> tuple[np.ndarray, np.ndarray]:
    """(N, 2, 2) sole xy (m, world) and (N, 2) sole yaw (rad) of (left, right) along the configurations q (N, nq)."""
    data = model.createData()
    xy, yaw = np.zeros((len(q), 2, 2)), np.zeros((len(q), 2))
    for k in range(len(q)):
        pin.forwardKinematics(model, data, q[k])
        for j, s in enumerate(("left", "right")):
            M = pin.updateFramePlacement(model, data, fid[s])
            xy[k, j] = M.translation[:2]
            yaw[k, j] = math.atan2(M.rotation[1, 0], M.rotation[0, 0])
    return xy, yaw


@nb.njit(cache=True, nogil=True)
def _squares_finite(pos, vel, acc):
    """Whether pos · pos + vel · vel + acc · acc is finite (every entry finite and none so large its square
    overflows): the test of a swing reference before its trusted setter."""
    total = 0.0
    for i in range(pos.shape[0]):
        total += pos[i] * pos[i]
    for i in range(vel.shape[0]):
        total += vel[i] * vel[i]
    for i in range(acc.shape[0]):
        total += acc[i] * acc[i]
    return math.isfinite(total)


@once_per_process
def _warm_up() -> None:
    """Load :func:`support_kernel`, :func:`stabilizer_kernel` and :func:`_squares_finite` (on-disk cache) once per
    process, at :meth:`WalkScenario.setup`."""
    support_kernel(np.zeros((4, 6)), 0.0, 0.0, 0.0, 0.0, 2, 0.0, 0.0)
    _squares_finite(np.zeros(3), np.zeros(6), np.zeros(6))
    z3, z2, zr = np.zeros(3), np.zeros(2), np.zeros((1, 2))
    stabilizer_kernel(np.zeros((4, 6)), 2, z3, z3, z3, z3, zr, zr, 0, 1.0, 1.0, 1.0, 0.0, z2.copy(), 1.0, 1.0, 1.0,
                       z2.copy(), z2.copy(), z2.copy())



#: Fraction of the robot weight the measured normal force of a swing sole must reach to confirm the height test of
#: touch-down before the swing's planned landing time, on a walk that is not blind
#: (:class:`~wbc.dynamics.contact_switching.ContactSwitcher` ``contact_force``); 0: the height test alone. The
#: height test alone fires while the sole is still 1–2 mm above the floor (0 N in the plant); from the planned
#: landing time on, the height test alone sets the sole down (waiting for the load there left it hovering:
#: benchmarks/README.md, "Touch-down confirmed by load"). A blind walk confirms with 3 % throughout.
TOUCHDOWN_CONFIRM_LOAD = 0.03

#: default weight of the swing-foot task's vertical position row relative to its horizontal rows (class docstring,
#: ``swing_height_weight``)
SWING_HEIGHT_WEIGHT = 3.0

#: Step timing on planned terrain: the swing sole's peak speed is kept at or below ``SWING_FROUDE · √(g z_c)``
#: (``z_c`` the CoM height at the start, a proxy for the leg length ``l``), longer steps where it would be faster
#: (:func:`wbc.gait.terrain_walk.plan_terrain_walk` ``max_sole_speed``). The bound is a Froude number
#: ``v / √(g l)``: under dynamic similarity (Alexander & Jayes, "A dynamic similarity hypothesis for the gaits of
#: quadrupedal mammals", J. Zool. 201, 1983) robots of different size move alike at equal Froude numbers. The value
#: is measured, not derived (benchmarks/README.md, "Step timing on stairs").
SWING_FROUDE = 0.6

#: Blind walk: time constant (s) of the low-pass filter on the supporting soles' measured − planned height that is
#: added to the planned CoM height (:meth:`WalkScenario._support_offset`).
BLIND_SUPPORT_TAU = 0.2


class WalkScenario:
    """Walk ``n_steps`` with the ID controller (module docstring). Needs the ID controller.

    Args:
        n_steps: number of steps (≥ 1). step_length: m. step_duration: s per step (single + double support;
            double support is 20 % of it, at least 0.08 s). step_height: swing clearance (m). turn: yaw per
            step (rad). step_width: lateral feet distance (m, default the current one).
        push: force (N) at the torso origin, 0 = none; push_time (s, sim clock), push_duration (s), push_dir
            (deg, world, 0 = +x forward, 90 = +y left).
        stabilizer: use :class:`DcmStabilizer` (else CoM PD tracking of the plan).
        ramp_time: force ramps (s). settle: time after the plan ends (s). descent_speed: late touch-down (m/s).
        cop_margin: stabilizer CoP margin (m).
        step_adjust: adapt the landing point of the swing foot from the measured DCM
            (:class:`wbc.gait.step_adjustment.StepAdjuster`, Khadiv et al. 2016 eq. 6–7; the DCM plan and the swing
            trajectory are replanned from the new step by :meth:`wbc.gait.WalkPlan.replan`); the remaining
            footsteps move with it. ``adjust_dead_band`` (m): dead band on the DCM error;
            ``adjust_freeze`` (s): no change in the last part of a swing. Reach (stance heading frame): forward
            ``forward_reach z_c``, backward ``0.35 z_c``, lateral from ``sole width + 0.05`` to ``step width + lateral_reach z_c``
            (``z_c`` the CoM height).
        adjust_timing: step timing adjustment (Khadiv et al. 2016, Sec. III–IV: when the location saturates at the
            reach, the step time is the remaining means of capture; default on). The swing in progress is cut
            short (by at most ``max_cut`` s, to no less than ``min_time_left`` s before landing; eq. 2 of
            :mod:`wbc.gait.step_adjustment`, :meth:`wbc.gait.WalkPlan.replan` ``skip``) when the reach clips the
            landing's DCM correction by more than 5 cm (``StepAdjuster.correction_clip``: the nominal landing's own
            clip not counted): landing sooner, the DCM has diverged less when the new stance
            starts (eq. 2 with ``τ' < τ``), and the next step comes sooner — the step by the other foot when this one
            cannot cross the stance leg. Not while the measured DCM is inside the stance sole (0-step capturable,
            ``_capturable``). Once per swing, and never more than the swing foot can still travel:
            the remaining time is kept ≥ (distance from the foot to its new landing) / ``max_swing_speed`` (m/s,
            default 2.5; touch-down is armed at mid-swing in sim time, so a hurried swing does not touch down on its
            way). Defaults ``max_cut`` 0.3 s, ``max_swing_speed`` 2.5 m/s, ``lateral_reach`` 0.7, ``cmp_offset``
            0.04 m, tuned on the pushed walks of ``benchmarks/walk_push_trials.py`` (``benchmarks/README.md``): a push
            towards the stance leg needs two quick steps (the inner foot, which cannot cross, then the outer one)
            and the DCM diverges from the stance CoP meanwhile. The swing in progress is **lengthened** instead (by
            at most
            ``max_stretch`` s) when, in its last ``stretch_window`` s, the adjusted landing is farther from the foot
            than ``stretch_speed`` (m/s) times the time left (``_stretch``: a push late in a swing towards the swing
            side; the foot lands later and further out, ``adjust_freeze`` notwithstanding).
        cmp_offset: hip strategy of :class:`DcmStabilizer` (m, CMP outside the support area).
        stabilizer_gains: :class:`DcmStabilizer` gains ``{"k_xi": 1/s, "k_i": 1/s}`` (either or both; default the
            stabilizer's own). Its CoP feedback gain k_z is ``zmp_feedback``.
        zmp_feedback: gain k_z of :class:`DcmStabilizer`'s feedback of the measured ZMP (≥ 0; 0: off). The measured
            ZMP is the attribute ``measured_zmp`` ((2,) m, world, or None), which the closed loop sets every tick
            from the ankle F/T sensors when the controller reads an estimated state
            (:meth:`wbc.sim.estimated_state.EstimatedState.measured_zmp`).
        swing_height_weight: weight of the swing foot task's vertical position row relative to its horizontal
            rows (> 0; None, the default: :data:`SWING_HEIGHT_WEIGHT`, or 1 for a robot whose two-sole contact
            Jacobian is rank-deficient, :func:`~wbc.sim.physics_scenarios.contacts_rank_deficient`, e.g. legs
            without hip yaw). When the QP cannot track the whole swing reference (a fast adjusted or cut step
            with the leg joints at their speed bounds), it keeps the sole's clearance and lets the horizontal
            travel lag, so the foot does not scuff the floor mid-swing (set in :meth:`setup` on the controller's
            ``feet`` tasks; 1: every position row weighs the same).
        touchdown_load: with measured sole forces (attribute ``measured_normal_force``, (2,) N, set by the closed
            loop from the ankle F/T sensors with an estimated state), an armed swing foot whose measured normal
            force reaches this fraction of the robot's weight has touched down, whatever its estimated height
            (:class:`~wbc.dynamics.contact_switching.ContactSwitcher` ``touchdown_force``; default 0.05). With
            measured sole forces and :data:`TOUCHDOWN_CONFIRM_LOAD` > 0, the height test (sole within 3 mm of the
            floor, not rising) counts before the swing's planned landing time only once the sole carries that
            fraction of the weight.
        await_load: a sole the height test sets down after its planned landing time at a measured force below
            that fraction waits for it before its load ramp starts (``ContactSwitcher`` ``await_load``; the robot
            file's ``touchdown = "load"``; default False).
        min_time_left, max_cut, max_swing_speed, max_stretch, stretch_speed, stretch_min, stretch_window: step
            timing adjustment bounds (s, s, m/s, s, m/s, m, s) described under ``adjust_timing``.
        from_state: plan from the measured CoM velocity (not from rest) and place the first step from the measured
            DCM (eq. 1 of :mod:`wbc.gait.step_adjustment` with no dead band, the time left being the time to the
            first touch-down) — a capture step started by :class:`wbc.sim.capture_step.CaptureStepScenario`.
        from_motion: plan the CoM from the measured CoM position and velocity (:meth:`wbc.gait.WalkPlan.replan` at
            sample 0, the ZMP start point solved so that the plan's DCM starts at the measured one) and keep the
            planned footsteps — a walk re-planned in the double support after a touch-down, the robot moving
            (a closing step, or steps of a new length). Not with ``from_state``.
        first_side: the foot that swings first. step_lateral: lateral displacement of the feet mid-point per
            step (m, + left; :func:`wbc.gait.plan_footsteps`).
        terrain: a :class:`wbc.terrain.Terrain` or its description (None / flat: the flat walk, unchanged);
            the walk is planned by :func:`wbc.gait.terrain_walk.plan_terrain_walk`.
        base_weight: on terrain (planned, or ``blind``), weight (≥ 0; 0: none) of a floating-base (pelvis)
            orientation task held at the start orientation
            (:meth:`wbc.dynamics.balance.IDBalanceController.set_base_orientation_weight`): the high, long swings of
            a stair climb otherwise roll and yaw a pelvis hung below waist joints, and a blind walk's pelvis rolls
            and pitches with a stance sole rocking on a bump (the CoM and the swing foot's reach move with it).
        blind: the ground is not flat but the walk is planned flat (the plant has the terrain, the planner does
            not): touch-down is detected from ``measured_normal_force`` ((2,) N, set by the closed loop from the
            ankle F/T sensors; :class:`wbc.dynamics.contact_switching.ContactSwitcher`'s force rule: a foot meeting
            a bump early switches to stance, the height rule needs a force, so a foot over a hole is not loaded in
            the air) and a late foot keeps descending up to 5 cm below its planned landing. The swing sole reaches
            its foothold's xy and heading by :data:`BLIND_XY_END` of the swing and descends vertically from there
            (:func:`wbc.gait.blind.blind_swing_into`: an early contact lands on the foothold, with no horizontal speed; the sole rises to
            ``step_height`` over the first :data:`BLIND_LIFT` of the swing, so that its toe clears the bumps ahead
            while it has barely moved forward). The step adjustment leaves the foothold of the vertical descent alone
            (frozen over the last ``1 − BLIND_XY_END`` of the swing, which may end on a bump at any tick), and a
            timing cut keeps the foot's travel to its landing at ``max_swing_speed`` or less within the part of the
            swing before that descent. Its
            height follows the stance sole's measured − planned height as on planned terrain
            (:meth:`_relative_ground`, :meth:`_swing_offset`: the foot aims at the height the stance sole stands
            at, not at the planned flat ground under it). The CoM height reference is likewise the planned one plus
            the supporting soles' measured − planned height (:meth:`_support_offset`; also on planned terrain). A
            loaded stance sole rotating about a line of its sole (measured CoP, angular velocity) has its QP contact
            and stabilizer support cut to a band about that line (:meth:`_partial_footholds`; ``measured_wrench``).

        swing_froude: step timing on planned terrain: the swing sole's peak speed is kept at or below
            ``swing_froude · √(g z_c)`` (m/s, ``z_c`` the start CoM height; default :data:`SWING_FROUDE`), a step
            whose swing would be faster lasting longer (:func:`wbc.gait.terrain_walk.plan_terrain_walk`
            ``max_sole_speed``). The run lasts the plan (``duration`` is set at :meth:`setup`).

    Torso heading: in a turning plan (a footstep yaw more than 0.01 rad from the start feet's mean heading) the ID
    controller's torso orientation reference turns with the feet: at each tick it is the reference held at
    :meth:`setup` rotated about the world z axis by the change of the mean heading of the planned soles
    (:func:`wbc.geometry.mean_heading`) since the plan's start. A reference held at the start heading instead is
    pulled against by the turning legs, and once the torso has turned half a turn from it the orientation error
    (SO(3) log) flips sign and the torso task twists the robot the other way (a fall at the pelvis's 160–165 deg).

    Raises:
        InvalidInputError / GaitError: bad numbers; GaitError at :meth:`setup` for a turning plan (footstep yaws
            differing by > 0.01 rad) on a robot whose legs cannot yaw one sole relative to the other (no hip yaw
            joint, humanoid15: the soles' relative yaw rate has a zero Jacobian at the start state).
    """

    name = "walk"
    needs_id = True

    def __init__(self, n_steps: int = 4, step_length: float = 0.15, step_duration: float = 0.8, *,
                 step_height: float = 0.05, turn: float = 0.0, step_width: float | None = None,
                 push: float = 0.0, push_time: float = 0.0, push_duration: float = 0.1, push_dir: float = 90.0,
                 stabilizer: bool = True, ramp_time: float = 0.04, settle: float = 1.0,
                 descent_speed: float = 0.1, cop_margin: float = 0.015, t_init: float = 0.8,
                 step_adjust: bool = True, adjust_dead_band: float = 0.02, adjust_freeze: float = 0.05,
                 first_side: str | None = None, step_lateral: float = 0.0, from_state: bool = False,
                 from_motion: bool = False,
                 adjust_timing: bool = True, min_time_left: float = 0.15, max_cut: float = 0.3,
                 lateral_reach: float = 0.7, forward_reach: float = 0.65, max_swing_speed: float = 2.5,
                 cmp_offset: float = 0.04, max_stretch: float = 0.15, stretch_speed: float = 1.0,
                 stretch_min: float = 0.03, stretch_window: float = 0.2, zmp_feedback: float = 0.0,
                 stabilizer_gains: dict | None = None, terrain=None, base_weight: float = 3.0,
                 blind: bool = False, touchdown_load: float = 0.05, await_load: bool = False,
                 swing_froude: float | None = None, swing_height_weight: float | None = None):
        from wbc.terrain import parse_terrain

        self.terrain = None if terrain is None else parse_terrain(terrain)
        if isinstance(base_weight, bool) or not isinstance(base_weight, (int, float)) \
                or not (math.isfinite(base_weight) and base_weight >= 0):
            raise InvalidInputError(f"base_weight must be a finite number ≥ 0, got {base_weight!r}")
        self.base_weight = float(base_weight)
        swing_froude = SWING_FROUDE if swing_froude is None else swing_froude
        if isinstance(swing_froude, bool) or not isinstance(swing_froude, (int, float)) \
                or not (math.isfinite(swing_froude) and swing_froude > 0):
            raise InvalidInputError(f"swing_froude must be a finite number > 0, got {swing_froude!r}")
        self.swing_froude = float(swing_froude)
        # late touch-down: how far (m) below its planned landing the swing foot may descend (terrain: the
        # estimated heights drift by centimetres, touch-down is then detected by the F/T force)
        self.blind = bool(blind)
        self.max_descent = 0.02 if self.terrain is None and not self.blind else 0.05
        if self.terrain is not None and self.terrain.is_flat:
            self.terrain = None
        if self.terrain is not None:
            step_adjust = False  # (replanning keeps a constant CoM height; footholds must stay on their treads)
        gains = {} if stabilizer_gains is None else stabilizer_gains
        if not isinstance(gains, dict) or set(gains) - {"k_xi", "k_i"}:
            raise InvalidInputError(f"stabilizer_gains must be a dict with keys among k_xi, k_i (k_z is zmp_feedback), "
                                    f"got {gains!r}")
        for key, val in gains.items():
            if isinstance(val, bool) or not isinstance(val, (int, float)) or not (np.isfinite(val) and val >= 0):
                raise InvalidInputError(f"stabilizer_gains[{key!r}] must be finite and ≥ 0, got {val!r}")
        self.stabilizer_gains = {k: float(v) for k, v in gains.items()}
        if not (np.isfinite(zmp_feedback) and zmp_feedback >= 0):
            raise InvalidInputError(f"zmp_feedback must be finite and ≥ 0, got {zmp_feedback!r}")
        self.zmp_feedback = float(zmp_feedback)
        self.measured_zmp = None  # (2,) m, world: set by the closed loop from the F/T sensors (estimated state)
        if not (np.isfinite(touchdown_load) and 0 < touchdown_load < 1):
            raise InvalidInputError(f"touchdown_load must be a fraction of the robot weight in (0, 1), "
                                    f"got {touchdown_load!r}")
        self.touchdown_load = float(touchdown_load)
        self.await_load = bool(await_load)
        #: (2,) N, (left, right) normal force measured by the ankle F/T sensors, set by the closed loop every tick
        #: when the controller reads an estimated state (None: touch-down from the state alone)
        self.measured_normal_force = None
        #: (2, 6) ground reactions (N, N·m) of the (left, right) soles at their origins, sole axes, measured by the
        #: ankle F/T sensors; set by the closed loop every tick on an estimated state (None: not measured)
        self.measured_wrench = None
        if not (np.isfinite(step_duration) and step_duration > 0.2):
            raise InvalidInputError(f"step_duration must be finite and > 0.2 s, got {step_duration!r}")
        if not (np.isfinite(max_swing_speed) and max_swing_speed > 0):
            raise InvalidInputError(f"max_swing_speed must be finite and > 0 m/s, got {max_swing_speed!r}")
        if not (np.isfinite(push) and push >= 0):
            raise InvalidInputError(f"push force must be finite and ≥ 0 N, got {push!r}")
        if swing_height_weight is not None and not (np.isfinite(swing_height_weight) and swing_height_weight > 0):
            raise InvalidInputError(f"swing_height_weight must be a finite ratio > 0 (1: the swing foot's height "
                                    f"weighs as its horizontal position) or None, got {swing_height_weight!r}")
        self.swing_height_weight = None if swing_height_weight is None else float(swing_height_weight)
        self.n_steps, self.step_length, self.step_duration = int(n_steps), float(step_length), float(step_duration)
        self.t_ds = max(0.08, 0.2 * self.step_duration)
        self.t_ss = self.step_duration - self.t_ds
        self.step_height, self.turn, self.step_width = float(step_height), float(turn), step_width
        self.push, self.push_time, self.push_duration = float(push), float(push_time), float(push_duration)
        a = math.radians(push_dir)
        self.push_vec = np.array([math.cos(a), math.sin(a), 0.0])
        self.stabilizer_on, self.ramp_time, self.settle = bool(stabilizer), float(ramp_time), float(settle)
        self.descent_speed, self.cop_margin, self.t_init = float(descent_speed), float(cop_margin), float(t_init)
        if self.blind or self.terrain is not None:  # a foot over a hole must find the ground before the stance leg
            # gives way; on planned terrain the estimate's height drifts (a foot stops short of its tread)
            self.descent_speed = max(self.descent_speed, 0.3)
        self.t_final = 1.0
        self.step_adjust, self.adjust_dead_band = bool(step_adjust), float(adjust_dead_band)
        self.adjust_freeze, self.step_lateral = float(adjust_freeze), float(step_lateral)
        if first_side is None:
            first_side = "right" if self.step_lateral < 0 else "left"
        self.first_side = first_side
        self.from_state = bool(from_state)
        self.from_motion = bool(from_motion)
        if self.from_state and self.from_motion:
            raise InvalidInputError("from_state and from_motion are exclusive: from_state also places the first "
                                    "step from the measured DCM; choose one")
        self.adjust_timing, self.min_time_left = bool(adjust_timing), float(min_time_left)
        self.max_cut = float(max_cut)
        self.max_swing_speed = float(max_swing_speed)
        self.cmp_offset = float(cmp_offset)
        self.max_stretch, self.stretch_speed, self.stretch_min = float(max_stretch), float(stretch_speed), \
            float(stretch_min)
        self.stretch_window = float(stretch_window)
        self.recovery_margin = 0.02
        if self.push > 0 and self.step_adjust:  # time for a recovery step after the walk
            self.settle = max(self.settle, 2.5)
            self.duration = self.t_init + self.n_steps * self.step_duration + self.t_final + self.settle
        self.lateral_reach, self.forward_reach = float(lateral_reach), float(forward_reach)
        # Duration estimate (refined in setup from the plan): init + steps + final + settle.
        self.duration = self.t_init + self.n_steps * self.step_duration + self.t_final + self.settle
        self.plan = None

    # -- setup ---------------------------------------------------------------------------------------------
    def setup(self, controller, sim, q, v):
        robot = sim.robot
        ratio = self.swing_height_weight
        if ratio is None:  # swing clearance first (class docstring)
            ratio = 1.0 if contacts_rank_deficient(robot) else SWING_HEIGHT_WEIGHT
        for foot in (getattr(controller, "feet", None) or {}).values():
            w = np.array(foot.weight, dtype=float)
            if w.size == 6:
                w[2] = ratio * w[0]
                foot.weight = w
        self.com0 = pin.centerOfMass(robot.model, robot.model.createData(), q).copy()
        self.robot = robot
        self.dt = sim.timestep
        self._model = robot.model
        self._data = robot.model.createData()
        pin.framesForwardKinematics(self._model, self._data, q)
        self._fid = {"left": robot.frame_id(robot.left_sole), "right": robot.frame_id(robot.right_sole)}
        L = self._data.oMf[self._fid["left"]].copy()
        R = self._data.oMf[self._fid["right"]].copy()
        walk_kw = dict(n_steps=self.n_steps, step_length=self.step_length,
                       step_width=self.step_width, turn=self.turn, step_height=self.step_height, t_ss=self.t_ss,
                       t_ds=self.t_ds, t_init=self.t_init, t_final=self.t_final, dt=self.dt,
                       sole_length=robot.sole_length, sole_width=robot.sole_width,
                       first_side=self.first_side, check_start=not (self.from_state or self.from_motion),
                       **({"step_lateral": self.step_lateral} if self.step_lateral else {}))
        self.terrain_walk = None
        if self.terrain is None:
            plan = plan_walk(L, R, self.com0, **walk_kw)
        else:  # footholds on the treads, 3-D swings, CoM height from the VRP (wbc.gait.terrain_walk)
            from wbc.gait.terrain_walk import plan_terrain_walk

            # step timing (SWING_FROUDE)
            v_max = self.swing_froude * math.sqrt(self.robot.gravity * float(self.com0[2]))
            self.terrain_walk = plan_terrain_walk(self.terrain, L.homogeneous, R.homogeneous, self.com0,
                                                  max_sole_speed=v_max, **walk_kw)
            plan = self.terrain_walk.plan
        zc = float(self.com0[2])
        w0 = abs(float((L.translation - R.translation) @ L.rotation[:, 1]))
        self.adjuster = StepAdjuster(plan.omega, max_forward=self.forward_reach * zc, max_backward=0.35 * zc,
                                     min_width=robot.sole_width + 0.05, max_width=w0 + self.lateral_reach * zc,
                                     dead_band=self.adjust_dead_band, sole_length=robot.sole_length,
                                     sole_width=robot.sole_width)
        yaws = [fs.yaw for fs in plan.footsteps]
        if yaws and max(yaws) - min(yaws) > 0.01 and not feet_can_yaw(robot, q):  # > 0.6 deg
            raise GaitError(f"{robot.name}'s legs cannot yaw one sole relative to the other (no hip yaw joint: the "
                            "relative yaw rate of the soles has a zero Jacobian), so its feet cannot turn; the plan "
                            f"turns them by {math.degrees(max(yaws) - min(yaws)):.1f} deg")
        self._torso_turn = None
        torso = getattr(controller, "torso", None)
        if torso is not None and yaws and self.terrain is None:
            h0 = mean_heading(L, R)
            if max(abs(math.remainder(y - h0, 2 * math.pi)) for y in yaws) > 0.01:
                # (R0 = the held torso reference, h0 = the start heading, a buffer for the per-tick R*ᵀ, position)
                tgt = torso.task.target
                self._torso_turn = (tgt.rotation.copy(), h0, np.empty((3, 3)), np.array(tgt.translation))
        if self.from_state:
            plan = self._capture_plan(plan, q, v)
        elif self.from_motion:
            data = self._model.createData()
            pin.centerOfMass(self._model, data, q, v)
            plan = plan.replan(0, data.com[0].copy(), data.vcom[0].copy(), check_start=False)
        self.plan = plan
        # the run length: the plan's (a terrain plan's step timing may lengthen steps) and the settling time
        self.duration = max(self.duration, plan.duration + self.settle)
        self.acc = {"left": np.gradient(plan.left_sole_vel, self.dt, axis=0),
                    "right": np.gradient(plan.right_sole_vel, self.dt, axis=0)}
        # Writable references (indexed by the original plan's samples; step adjustment rewrites them from the
        # replanning sample on).
        self.poses = {"left": plan.left_sole.copy(), "right": plan.right_sole.copy()}
        self.vels = {"left": plan.left_sole_vel.copy(), "right": plan.right_sole_vel.copy()}
        self.ref_dcm, self.ref_zmp = plan.dcm.copy(), plan.zmp.copy()
        # Swings: (side, lift-off sample, touch-down sample, footstep).
        self.swings = []
        for ph in plan.phases:
            if ph.step >= 0:
                side = _CODE_SWING[int(ph.support)]
                self.swings.append((side, ph.first, ph.end, plan.footsteps[ph.step]))
        self._rp, self._rp_k0 = plan, 0  # latest (re)plan and the original sample of its sample 0
        self._skipped = -1  # swing whose timing was changed (cut short)
        self._stretched = -1  # swing that was lengthened
        self._base = None  # (swing index, footstep, DCM reference) at the start of the current swing
        self.adjustments: list[tuple[float, str, float, float]] = []  # (t, side, dx, dy) vs the nominal step
        self.replan_failures = 0
        self._recovery, self._t_recovery = None, None
        self.recovery_failures = 0
        self.recovery_swapped = False  # the capture step was taken by the foot away from the DCM (_start_recovery)
        self._shift = 0  # samples by which the plan clock runs ahead of the sim clock (step timing adjustment)
        #: True: the next swing is not released (its ramp-out does not begin) — set by a caller about to re-plan
        #: the walk in this double support (:meth:`between_steps`), for the few ticks until the landed sole is loaded
        self.hold_next_swing = False
        self.timing_changes: list[tuple[float, str, float]] = []  # (t, side, s earlier)
        self._next = 0  # next swing to start
        self._t_unload = {"left": -1.0, "right": -1.0}
        self._land_z = {"left": 0.0, "right": 0.0}  # planned landing height of the current swing per side
        # terrain: measured − planned height (m) of a swing foot's sole at its release and of the stance sole
        # (_relative_ground); the swing reference goes from the first to the second (_swing_offset)
        self._dz_lift = {"left": 0.0, "right": 0.0}
        self._dz_stance = {"left": 0.0, "right": 0.0}
        self._gdata = self._model.createData()
        # Views into self._data (eigenpy: they follow every update of it): the CoM and its velocity, and the soles'
        # rotation and translation (the placements updated in update)
        self._com_view, self._vcom_view = self._data.com[0], self._data.vcom[0]
        oMf = {s: self._data.oMf[self._fid[s]] for s in ("left", "right")}
        self._sole_views = {s: (oMf[s], oMf[s].rotation, oMf[s].translation) for s in ("left", "right")}
        # _hull: the shrunk sole corners per shrink, and a buffer of the transposed sole rotations per sole count
        self._corners: dict[float, np.ndarray] = {}
        self._rot_t = {1: np.empty((3, 3)), 2: np.empty((3, 6))}
        self._xy0 = np.zeros((4, 6))  # (_stabilize's corners when no sole is in contact: not read)
        self._no_cop = np.full(2, np.nan)  # (_stabilize's measured CoP when there is none)
        _warm_up()
        # plan sample → index of the swing whose [lift-off, touch-down) holds it, -1 none (_adjust_step; the swings'
        # samples never change, only their footsteps)
        swing_at = np.full(plan.n_samples + 1, -1, dtype=int)
        for i in range(len(self.swings) - 1, -1, -1):  # the first swing holding a sample wins
            swing_at[max(self.swings[i][1], 0):max(self.swings[i][2], 0)] = i
        self._swing_at = swing_at.tolist()
        # blind and planned terrain: measured − planned height (m) of the supporting soles, low-passed, and its rate
        # (m/s); added to the planned CoM height (_support_offset)
        self._dz_support, self._dz_support_rate = 0.0, 0.0
        self._active: dict[str, tuple] = {}
        weight = robot.mass * robot.gravity
        self._weight = weight
        #: blind: per side, the cut (x_lo, x_hi, y_lo, y_hi) (m, sole frame) of the sole's contact rectangle
        #: (:meth:`_partial_footholds`; ±inf: not cut), and the number of cuts made
        self._cut = {"left": None, "right": None}
        self._cut_until = {"left": [-np.inf, -np.inf], "right": [-np.inf, -np.inf]}  # (x, y) cut expiry (s)
        self.support_cuts = 0
        if self.blind:  # the ground may be higher or lower than planned: a load confirms the height test (late
            # contact) and a load alone within 5 cm of the planned landing is a touch-down (early contact)
            self.switcher = ContactSwitcher(controller, ramp_time=self.ramp_time, touchdown_force=0.1 * weight,
                                            touchdown_force_height=0.05, contact_force=0.03 * weight,
                                            confirm_when_due=True)
        else:  # before the planned landing time a load confirms the height test (TOUCHDOWN_CONFIRM_LOAD)
            self.switcher = ContactSwitcher(controller, ramp_time=self.ramp_time,
                                            touchdown_force=self.touchdown_load * weight,
                                            contact_force=(TOUCHDOWN_CONFIRM_LOAD * weight
                                                           if TOUCHDOWN_CONFIRM_LOAD > 0 else None),
                                            await_load=self.await_load)
        self.controller = controller
        if (self.terrain is not None or self.blind) and self.base_weight > 0 \
                and hasattr(controller, "set_base_orientation_weight"):
            controller.set_base_orientation_weight(self.base_weight, q=q)
        self.stab = DcmStabilizer(plan.omega, margin=self.cop_margin, dt=self.dt, cmp_offset=self.cmp_offset,
                                  k_z=self.zmp_feedback, **self.stabilizer_gains)
        self._push_body = robot.torso
        if self.push > 0:
            sim.body_id(self._push_body)
        n = int(round(max(self.duration, plan.duration + self.settle) / self.dt)) + 2
        self.log = {"phase": np.zeros((n, 2), dtype=np.int8), "dcm": np.full((n, 2), np.nan),
                    "dcm_ref": np.full((n, 2), np.nan), "cop_cmd": np.full((n, 2), np.nan),
                    "sole_xy": np.zeros((n, 2, 2)), "sole_yaw": np.zeros((n, 2))}
        self._k = 0
        self._pushing = False

    def _capture_plan(self, plan, q, v):
        """The plan from rest ``plan`` replanned from the measured CoM state, its first step placed from the
        measured DCM and the closing step moved with it (``from_state``)."""
        data = self._model.createData()
        pin.centerOfMass(self._model, data, q, v)
        c, cd = data.com[0].copy(), data.vcom[0].copy()
        xi = c[:2] + cd[:2] / plan.omega
        first = next(ph for ph in plan.phases if ph.step == 0)
        fs = plan.footsteps[0]
        other = "right" if fs.side == "left" else "left"
        M = self._data.oMf[self._fid[other]]
        stance = (M.translation[0], M.translation[1], math.atan2(M.rotation[1, 0], M.rotation[0, 0]))
        e = xi - plan.dcm[0]
        corr = math.exp(plan.omega * first.end * self.dt) * e
        land = self.adjuster.landing(fs, stance, corr)
        d = (land.x - fs.x, land.y - fs.y)
        new = [Footstep(f.side, f.x + d[0], f.y + d[1], f.yaw) for f in plan.footsteps]
        self.capture_landing = (float(d[0]), float(d[1]))
        return plan.replan(0, c, cd, new, check_start=False)

    @property
    def reads_measured_zmp(self) -> bool:
        """Whether :meth:`update` reads ``measured_zmp``: only for the stabilizer's ZMP feedback (``zmp_feedback``
        > 0, also passed to a capture step); the closed loop does not compute the measured ZMP otherwise."""
        return self.zmp_feedback > 0

    @property
    def steps_done(self) -> int:
        """Swings released so far (a capture step started after the plan not counted)."""
        return self._next

    @property
    def steps_left(self) -> int:
        """Swings of the plan not yet released (the closing step included)."""
        return len(self.swings) - self._next

    @property
    def next_side(self) -> str | None:
        """The foot of the next swing of the plan (``"left"``/``"right"``), None when every swing was released."""
        return self.swings[self._next][0] if self._next < len(self.swings) else None

    def between_steps(self) -> bool:
        """True in a double support where both soles are fully loaded (contact ``"stance"``: touch-down and
        ramp-in over, the next swing's ramp-out not begun) and no capture step runs: the state from which
        :class:`WalkScenario` ``from_motion`` re-plans a walk."""
        return self._recovery is None and not self._active and self.switcher.phase("left") == "stance" \
            and self.switcher.phase("right") == "stance"

    def com_reference(self, t):
        plan = self.plan
        n = plan.n_samples
        # plan.index(t) (which raises GaitError for a time that is not a finite number)
        k = int(min(max(round(t / plan.dt), 0), n - 1)) if type(t) is float and math.isfinite(t) else plan.index(t)
        return plan.com[min(k + self._shift, n - 1)]

    @property
    def ends_at(self) -> float:
        """Time (s, scenario clock) at which the walk ends in double support: the plan's end, or the end of the
        capture step started after it (:meth:`_start_recovery`), whichever is later."""
        end = self.plan.duration - self._shift * self.dt
        if self._recovery is not None:
            end = max(end, self._t_recovery + self._recovery.ends_at)
        return end

    def _sole_corners(self, shrink: float) -> np.ndarray:
        """(4, 3) corners (m, sole frame) of the sole rectangle shrunk by ``shrink``, in the order of
        :func:`~wbc.geometry.projected_sole_corners` (cached per shrink)."""
        corners = self._corners.get(shrink)
        if corners is None:
            r = self.robot
            a, b = 0.5 * (r.sole_length - 2 * shrink), 0.5 * (r.sole_width - 2 * shrink)
            corners = self._corners[shrink] = np.array([[a, b, 0.0], [-a, b, 0.0], [-a, -b, 0.0], [a, -b, 0.0]])
        return corners

    def _hull(self, shrink: float) -> list:
        """CCW vertices ``(x, y)`` (m, world) of the convex hull of the soles in contact (their rectangles shrunk by
        ``shrink``, cut to their bands (:meth:`_partial_footholds`)), projected on the ground, at the state of
        ``self._data``; [] when no sole is in contact.

        The corners are :func:`wbc.geometry.projected_sole_corners` (``C Rᵀ + p``): the two uncut soles' in one
        matrix product ``C [R_leftᵀ R_rightᵀ]``, which gives each element the same sum as the product per sole."""
        r = self.robot
        views, cuts = self._sole_views, self._cut
        sides = [s for s in ("left", "right") if self.switcher.in_contact(s)]
        if not sides:
            return []
        plain = [views[s] for s in sides if cuts[s] is None]
        pts: list = []
        if plain:
            corners = self._sole_corners(shrink)
            rt = self._rot_t[len(plain)]
            for j, (_, rot, _) in enumerate(plain):
                rt[:, 3 * j:3 * j + 3] = rot.T
            xy = (corners @ rt).tolist()
            for j, (_, _, pos) in enumerate(plain):
                tx, ty, _ = pos.tolist()
                u = 3 * j
                pts += [(row[u] + tx, row[u + 1] + ty) for row in xy]
        for s in sides:
            cut = cuts[s]
            if cut is None:
                continue
            M = views[s][0]
            a, b = 0.5 * r.sole_length - shrink, 0.5 * r.sole_width - shrink
            x0, x1 = max(-a, cut[0]), min(a, cut[1])
            y0, y1 = max(-b, cut[2]), min(b, cut[3])
            if x1 - x0 < 0.002:  # cut within the margin: a 2 mm strip about its middle (the hull keeps an area)
                x0, x1 = 0.5 * (x0 + x1) - 0.001, 0.5 * (x0 + x1) + 0.001
            if y1 - y0 < 0.002:
                y0, y1 = 0.5 * (y0 + y1) - 0.001, 0.5 * (y0 + y1) + 0.001
            c = np.array([[x1, y1, 0.0], [x0, y1, 0.0], [x0, y0, 0.0], [x1, y0, 0.0]])
            pts += [(x, y) for x, y in (c @ M.rotation.T + M.translation)[:, :2].tolist()]
        vertices = hull_vertices(pts)  # the soles' corners are finite: no validation
        if len(vertices) < 3:
            convex_hull(np.array(pts))  # raises InvalidInputError (collinear)
        return vertices

    def _support(self, shrink: float, px: float, py: float) -> tuple[float, float, float]:
        """(margin, x, y) of the point (px, py) (m, world xy) in :meth:`_hull` ``(shrink)``: its
        :func:`~wbc.geometry.polygon_margin` (m, NaN when no sole is in contact) and the closest point of the hull
        (:func:`closest_point_xy`; the point itself when no sole is in contact). Uncut soles: :func:`support_kernel` on
        the corners of :meth:`_hull`'s matrix product, the same numbers.

        Raises:
            InvalidInputError: the soles' corners are collinear (as :meth:`_hull`).
        """
        views, cuts = self._sole_views, self._cut
        sides = [s for s in ("left", "right") if self.switcher.in_contact(s)]
        if not sides:
            return math.nan, px, py
        if cuts["left"] is not None or cuts["right"] is not None:
            hull = self._hull(shrink)
            return (polygon_margin((px, py), hull),) + closest_point_xy(px, py, hull)
        corners = self._sole_corners(shrink)
        ns = len(sides)
        rt = self._rot_t[ns]
        _, rot, pos0 = views[sides[0]]
        rt[:, :3] = rot.T
        tx1 = ty1 = 0.0
        if ns == 2:
            _, rot, pos1 = views[sides[1]]
            rt[:, 3:] = rot.T
            tx1, ty1 = float(pos1[0]), float(pos1[1])
        m, d, qx, qy = support_kernel(corners @ rt, float(pos0[0]), float(pos0[1]), tx1, ty1, ns, px, py)
        if m < 3:
            self._hull(shrink)  # raises InvalidInputError (collinear)
        return d, qx, qy

    def _stabilize(self, k: int, p_meas: np.ndarray) -> tuple[float, float]:
        """``self.stab.acceleration`` at plan sample ``k`` (no cut sole; measured CoP ``p_meas`` (2,) m, NaN: none), the
        support area that of
        :meth:`_support` ``(cop_margin)``, in one :func:`stabilizer_kernel` call: (c̈_x, c̈_y) m/s², the same numbers
        (the soles' corners from :meth:`_support`'s matrix product).

        Raises:
            InvalidInputError: the soles' corners are collinear (as :meth:`_hull`).
        """
        sw, views, stab = self.switcher, self._sole_views, self.stab
        left, right = sw.in_contact("left"), sw.in_contact("right")
        ns = int(left) + int(right)
        _, rot, pos0 = views["left" if left else "right"]
        pos1 = pos0
        xy = self._xy0
        if ns:
            rt = self._rot_t[ns]
            rt[:, :3] = rot.T
            if ns == 2:
                _, rot, pos1 = views["right"]
                rt[:, 3:] = rot.T
            xy = self._sole_corners(self.cop_margin) @ rt
        m, ax, ay, stab.saturated = stabilizer_kernel(
            xy, ns, pos0, pos1, self._com_view, self._vcom_view, self.ref_dcm, self.ref_zmp, k, stab.omega, stab.k_p,
            stab.k_i, stab.k_z, p_meas, stab.i_max, stab.dt, stab.cmp_offset, stab.integral, stab.last_cop,
            stab.last_cmp)
        if m < 3:
            self._hull(self.cop_margin)  # raises InvalidInputError (collinear)
        return ax, ay

    # -- per tick ------------------------------------------------------------------------------------------
    def update(self, t, controller, sim, q, v):
        if self._recovery is not None:
            return self._recovery_update(t, controller, sim, q, v)
        plan, dt, sw = self.plan, self.dt, self.switcher
        n_samples = plan.n_samples
        tf = float(t)
        # plan.index(t) (which raises GaitError for a time that is not finite)
        k = int(min(max(round(tf / plan.dt), 0), n_samples - 1)) if math.isfinite(tf) else plan.index(t)
        k = min(k + self._shift, n_samples - 1)
        tp = k * dt  # plan clock
        # Start the ramp-out of the next swing so that the foot is released at the planned lift-off.
        if self._next < len(self.swings):
            side, k_lift, k_td, fs = self.swings[self._next]
            other = "right" if side == "left" else "left"
            # Never release a foot while the other one is not yet down (late touch-down: the step waits).
            if tp >= k_lift * dt - self.ramp_time - 1e-9 and sw.phase(side) in ("stance", "loading") \
                    and sw.phase(other) in ("stance", "loading") and not self.hold_next_swing:
                sw.unload(side, t)
                if self.terrain_walk is not None or self.blind:
                    # touch-down is detected above the foothold's ground (blind: the planned flat ground)
                    if self.terrain_walk is not None:
                        self._land_z[side] = float(self.terrain_walk.footholds[fs_index(self.plan, k_lift)][2, 3])
                    sw.ground_height[side] = self._land_z[side]
                    pin.framesForwardKinematics(self._model, self._gdata, q)
                    self._dz_lift[side] = float(self._gdata.oMf[self._fid[side]].translation[2]) \
                        - float(self.poses[side][k][2, 3])
                    self._dz_stance[side] = self._dz_lift[side]
                self._t_unload[side] = t
                self._active[side] = self.swings[self._next]
                self._next += 1
        if self.terrain_walk is not None or self.blind:
            self._relative_ground(k, q)
        for side, (_, k_lift, k_td, fs) in self._active.items():
            sw.set_landing_due(side, tp >= k_td * dt - 1e-9)
        sw.update(t, q, v, self.measured_normal_force)
        for side, (_, k_lift, k_td, fs) in list(self._active.items()):
            ph = sw.phase(side)
            if ph == "swing":
                # Armed from mid-swing in sim time: release at t_unload + ramp_time, landing at the planned
                # touch-down less the timing cuts made since (a cut at lift-off must not arm a foot still on the
                # floor: it then "touched down" at once and never stepped).
                t_rel = self._t_unload[side] + self.ramp_time
                if t >= t_rel + 0.5 * (k_td * dt - self._shift * dt - t_rel) - 1e-9:
                    sw.arm(side)
                kk = min(k, k_td)
                P = self.poses[side][kk]
                vel = self.vels[side][kk].copy()
                acc = self.acc[side][kk].copy()
                if self.blind and BLIND_XY_END < 1.0:
                    pose = pin.SE3(P)
                    pose.translation = pose.translation + [0.0, 0.0, self._swing_offset(side, kk, k_lift, k_td)]
                    blind_swing_into((self.poses[side], self.vels[side], self.acc[side]), kk, k_lift, k_td, self.step_height,
                                     self.dt, pose, vel, acc)
                    rot_t, pos = pose.rotation.T.copy(), np.array(pose.translation)
                else:  # (the plan's rotations are rotations: only the numbers added here need checking)
                    rot_t, pos = P[:3, :3].T.copy(), P[:3, 3].copy()
                    if self.terrain_walk is not None or self.blind:
                        pos[2] += self._swing_offset(side, kk, k_lift, k_td)
                late = tp - k_td * dt
                if late > 0:  # late touch-down: keep descending slowly until the state says contact
                    drop = self.max_descent
                    pos[2] -= min(self.descent_speed * late, drop)
                    vel[:] = 0.0
                    vel[2] = -self.descent_speed if self.descent_speed * late < drop else 0.0
                    acc[:] = 0.0
                if _squares_finite(pos, vel, acc):
                    controller.set_foot_reference_rows(side, rot_t, pos, vel, acc)
                else:  # the validated setter raises its typed error
                    controller.set_foot_reference(side, pin.SE3(rot_t.T, pos), vel, acc)
            elif ph in ("loading", "stance") and side in self._active and sw.touchdown_time[side] is not None \
                    and sw.touchdown_time[side] > self._t_unload[side]:
                del self._active[side]
        if self._torso_turn is not None:
            self._turn_torso(controller, k)
        # State quantities (CoM velocity, soles) for the DCM and the log.
        # (centerOfMass with v runs the forward kinematics: only the soles' placements are then updated)
        model, data, fid = self._model, self._data, self._fid
        pin.centerOfMass(model, data, q, v)
        pin.updateFramePlacement(model, data, fid["left"])
        pin.updateFramePlacement(model, data, fid["right"])
        c, cd = self._com_view, self._vcom_view  # data.com[0], data.vcom[0]
        w = plan.omega
        cx, cy, _ = c.tolist()
        cdx, cdy, _ = cd.tolist()
        xix, xiy = cx + cdx / w, cy + cdy / w
        xi = np.array([xix, xiy])
        if self.step_adjust:
            self._adjust_step(t, k, c, cd, xi)
        i = min(self._k, len(self.log["phase"]) - 1)
        dz, dzd = self._support_offset(k) if self.blind or self.terrain_walk is not None else (0.0, 0.0)
        if self.blind:
            self._partial_footholds(controller, q, v, t)
        if self.stabilizer_on:
            stab = self.stab
            p_meas = self.measured_zmp
            if self._cut["left"] is None and self._cut["right"] is None and (p_meas is None or (
                    type(p_meas) is np.ndarray and p_meas.shape == (2,) and p_meas.dtype == np.float64
                    and p_meas[0] == p_meas[0])):
                ax, ay = self._stabilize(k, self._no_cop if p_meas is None else p_meas)
            else:
                xrx, xry = self.ref_dcm[k].tolist()
                prx, pry = self.ref_zmp[k].tolist()
                margin = self.cop_margin

                def project(px: float, py: float) -> tuple[float, float]:
                    return self._support(margin, px, py)[1:]

                ax, ay = stab.acceleration(cx, cy, cdx, cdy, xrx, xry, prx, pry, project, self.measured_zmp)
            z, zd, zdd = float(plan.com[k, 2] + dz), float(plan.com_vel[k, 2] + dzd), float(plan.com_acc[k, 2])
            target = np.array([cx, cy, z])
            vel = np.array([cdx, cdy, zd])  # (z: 0 on flat ground)
            acc = np.array([ax, ay, zdd])
            if math.isfinite(cx + cy + z + cdx + cdy + zd + ax + ay + zdd):
                controller.set_com_reference_trusted(target, vel, acc)
            else:  # the validated setter raises its typed error
                controller.set_com_reference(target, vel, acc)
            self.log["cop_cmd"][i] = self.stab.last_cop
        else:
            controller.set_com_reference(plan.com[k] + [0.0, 0.0, dz], plan.com_vel[k] + [0.0, 0.0, dzd],
                                         plan.com_acc[k])
        lg = self.log
        lg["dcm"][i] = xi
        lg["dcm_ref"][i] = self.ref_dcm[k]
        views = self._sole_views
        for j, s in enumerate(("left", "right")):
            lg["phase"][i, j] = _PHASE_CODE[sw.phase(s)]
            _, R, pos = views[s]
            lg["sole_xy"][i, j] = pos[:2]
            lg["sole_yaw"][i, j] = math.atan2(R[1, 0], R[0, 0])
        self._k += 1
        if self.step_adjust and self._next >= len(self.swings) and not self._active and not self.from_state \
                and not self.recovery_failures \
                and sw.phase("left") == "stance" and sw.phase("right") == "stance" \
                and self._support(self.recovery_margin, xix, xiy)[0] < 0.0:
            self._start_recovery(t, controller, sim, q, v, xi)
        return self._apply_push(t, sim)

    def _turn_torso(self, controller, k: int) -> None:
        """Torso orientation reference of sample ``k`` of a turning plan (class docstring, "Torso heading"):
        ``Rz(h_k − h_0) R_0``, ``h_k`` the mean heading of the planned soles at ``k``."""
        r0, h0, rot_t, pos = self._torso_turn
        pl, pr = self.poses["left"][k], self.poses["right"][k]
        h = math.atan2(pl[1, 0] / math.hypot(pl[0, 0], pl[1, 0]) + pr[1, 0] / math.hypot(pr[0, 0], pr[1, 0]),
                       pl[0, 0] / math.hypot(pl[0, 0], pl[1, 0]) + pr[0, 0] / math.hypot(pr[0, 0], pr[1, 0]))
        c, s = math.cos(h - h0), math.sin(h - h0)
        # R*ᵀ = R_0ᵀ Rz(Δh)ᵀ: row i of R_0ᵀ is column i of R_0
        for i in range(3):
            a, b = r0[0, i], r0[1, i]
            rot_t[i, 0], rot_t[i, 1], rot_t[i, 2] = a * c - b * s, a * s + b * c, r0[2, i]
        controller.torso.task.set_target_rows(rot_t, pos)

    def _relative_ground(self, k: int, q: np.ndarray) -> None:
        """Touch-down height of a swinging foot relative to the stance sole: its landing height (blind: the
        planned flat ground) plus the stance sole's measured height less its planned one. The estimated base height drifts on terrain (odometry of
        the contact heights, centimetres after ten stairs), the relative height of the two soles (joint encoders)
        does not: an absolute rule loaded a G1 foot 2.4 cm above its tread and the robot fell."""
        sw = self.switcher
        swinging = [s for s in ("left", "right") if sw.phase(s) == "swing"]
        if len(swinging) != 1:
            return
        side = swinging[0]
        other = "right" if side == "left" else "left"
        pin.framesForwardKinematics(self._model, self._gdata, q)
        z_other = float(self._gdata.oMf[self._fid[other]].translation[2])
        self._dz_stance[side] = z_other - float(self.poses[other][k][2, 3])
        sw.ground_height[side] = self._land_z[side] + self._dz_stance[side]

    def _partial_footholds(self, controller, q: np.ndarray, v: np.ndarray, t: float = 0.0) -> None:
        """Blind walk: confine a rolling stance sole's contact to the part of it that is supported (partial
        footholds, Wiedebach, Grabowski, Pratt, "Walking on partial footholds including line contacts with the
        humanoid robot Atlas", Humanoids 2016, Sec. III-B: a foot rotating about an edge has its support polygon cut
        at the line of rotation). On rough ground a sole can rest on one terrain node or edge under it; the QP's
        contact (the whole rectangle) then lets it ask a CoP beyond that edge, which the ground cannot give, and
        the ankle torque rolls the sole over the edge.

        Per side in full contact (``switcher.phase`` "stance") whose measured normal force
        (``measured_normal_force``, N) is at least :data:`BLIND_CUT_LOAD` of the weight: ω (3,) = the sole's
        angular velocity (rad/s, sole axes) from the state (q, v); p = (−τ_y / f_z, τ_x / f_z) the sole's measured
        CoP (m, sole frame) from its F/T ground reaction (``measured_wrench``, sole axes). |ω_y| >
        :data:`BLIND_ROLL_RATE` (pitching): the contact's x range becomes [p_x − h, p_x + h]; |ω_x| > rate (rolling):
        its y range [p_y − h, p_y + h]; h = :data:`BLIND_CUT_BAND` — a line contact through the pivot (the measured
        CoP of a sole rotating about a line of support lies on that line). Only about a pivot at least
        :data:`BLIND_PIVOT_INSET` inside the sole's edges (a sole coming down flat about its heel or side edge is
        settling onto the ground, not rolling over it). A band lasts while the rotation does and
        :data:`BLIND_CUT_HOLD` s after, at most until the sole leaves full contact. It bounds the QP's corner forces
        (:meth:`wbc.constraints.sole_contact.SoleContact.set_support`, clipped to the sole, at least
        :data:`BLIND_CUT_MIN` wide) and the stabilizer's support area (:meth:`_hull`).
        Nothing happens without measured wrenches (ground-truth state)."""
        contacts = getattr(controller, "contacts", None)
        f, W = self.measured_normal_force, self.measured_wrench
        A, B = 0.5 * self.robot.sole_length, 0.5 * self.robot.sole_width
        kinematics = False  # forward kinematics with velocities, once per call, only when a sole needs it
        for j, s in enumerate(("left", "right")):
            con = None if contacts is None else contacts.get(s)
            if con is None:
                continue
            cut = list(self._cut[s]) if self._cut[s] is not None else [-np.inf, np.inf, -np.inf, np.inf]
            until = self._cut_until[s]
            new = list(cut)
            if self.switcher.phase(s) != "stance":
                new = [-np.inf, np.inf, -np.inf, np.inf]
            else:
                for ax in (0, 1):  # expired cuts
                    if until[ax] < t:
                        new[2 * ax], new[2 * ax + 1] = -np.inf, np.inf
                fz = 0.0 if W is None else float(W[j][2])
                if f is not None and float(f[j]) >= BLIND_CUT_LOAD * self._weight and fz > 0.0:
                    if not kinematics:
                        pin.forwardKinematics(self._model, self._gdata, q, v)
                        kinematics = True
                    w = pin.getFrameVelocity(self._model, self._gdata, self._fid[s], pin.LOCAL).angular
                    roll_band(new, until, t, w, (-float(W[j][4]) / fz, float(W[j][3]) / fz), (A, B))
            if new == cut:
                continue
            if all(math.isinf(x) for x in new):
                self._cut[s] = None
                con.reset_support()
                continue
            x1, y1 = con.half_size
            x0, y0 = -x1, -y1
            lo_x, hi_x = clip_band_range(max(x0, new[0]), min(x1, new[1]), x0, x1)
            lo_y, hi_y = clip_band_range(max(y0, new[2]), min(y1, new[3]), y0, y1)
            self._cut[s] = tuple(new)
            con.set_support(lo_x, hi_x, lo_y, hi_y)
            self.support_cuts += 1

    def _support_offset(self, k: int) -> tuple[float, float]:
        """Blind walk and planned terrain: height (m) and rate (m/s) added to the planned CoM height at plan sample
        ``k``: the measured − planned height of the soles in contact, weighted by their measured normal forces (``measured_normal_force``;
        equal weights without it), low-passed with the time constant :data:`BLIND_SUPPORT_TAU`. Uses the sole
        placements of the state given to :meth:`update` (``self._data``, updated before the call).

        The CoM then keeps its planned height above the soles, as the swing sole aims at the stance sole's measured
        height (:meth:`_relative_ground`): on uneven ground the estimated base height is contact odometry (each
        sole anchored where it first touches; a sole that then rolls onto the terrain under it moves its anchor point
        with it), so the soles' estimated heights drift, and a CoM held at the planned absolute height bends the
        legs by that drift. On planned terrain the same holds after a flight of stairs: the estimated base height
        drifts by centimetres, the CoM sits that much lower above its stance sole in the plant, and the pelvis rolls
        further with each step down (benchmarks/README.md, "Walking on terrain")."""
        f = self.measured_normal_force
        num = den = 0.0
        for j, s in enumerate(("left", "right")):
            if not self.switcher.in_contact(s):
                continue
            w = 1.0 if f is None else max(float(f[j]), 0.0)
            num += w * (float(self._data.oMf[self._fid[s]].translation[2]) - float(self.poses[s][k][2, 3]))
            den += w
        if den > 0:
            a = self.dt / (self.dt + BLIND_SUPPORT_TAU)
            err = num / den - self._dz_support
            self._dz_support += a * err
            self._dz_support_rate = (1.0 - a) * err / BLIND_SUPPORT_TAU  # d/dt of the low-passed value
        return self._dz_support, self._dz_support_rate

    def _swing_offset(self, side: str, k: int, k_lift: int, k_td: int) -> float:
        """Height (m) added to the planned swing sole at plan sample ``k``: the measured − planned height of the
        swing sole at its release blended (minimum jerk over the swing) into that of the stance sole, so that the
        foot lands on its tread where the touch-down test expects it (:meth:`_relative_ground`). Otherwise a
        foot planned onto the tread's height in the estimate's frame, whose height drifts with the contact
        odometry, stops above or presses into the tread and touch-down comes late or early."""
        b = min_jerk(min(max((k - k_lift) / max(k_td - k_lift, 1), 0.0), 1.0))[0]
        return self._dz_lift[side] + b * (self._dz_stance[side] - self._dz_lift[side])

    def _start_recovery(self, t, controller, sim, q, v, xi):
        """All steps taken and the measured DCM outside the soles' hull shrunk by ``recovery_margin``: a capture step
        (a 2-step walk planned from the measured state, first step from the measured DCM), as
        :class:`wbc.sim.capture_step.CaptureStepScenario` does for a standing robot.

        The stepping foot is the one on the DCM's side of the feet, unless the DCM lies laterally over that sole or
        beyond it (less than half a sole width inwards of its middle): that sole then carries the CoP the DCM needs
        — lifting it leaves the CoP on the other sole, from which the DCM diverges as ``e^{ωt}`` (Englsberger 2015,
        eq. 6) out of any reach — and the other foot steps instead, towards it (a closing step: the feet are wide
        apart after a lateral recovery step; the CoP stays on the sole under the DCM). "Over that sole" also asks the DCM to lie within
        the sole's length along its heading: a DCM far ahead of the sole (a forward push at the end of the walk) is
        captured by that foot stepping forward, not by lifting the other one, on which the DCM then nearly stands."""
        mid = 0.5 * (self._data.oMf[self._fid["left"]].translation[:2] + self._data.oMf[self._fid["right"]].translation[:2])
        lat = self._data.oMf[self._fid["left"]].rotation[:2, 1]  # towards the left sole
        side = "left" if (xi - mid) @ lat >= 0 else "right"
        sign = 1.0 if side == "left" else -1.0
        rel = xi - self._data.oMf[self._fid[side]].translation[:2]
        fwd = self._data.oMf[self._fid[side]].rotation[:2, 0]
        if sign * float(rel @ lat) > -0.5 * self.robot.sole_width \
                and abs(float(rel @ fwd)) <= 0.5 * self.robot.sole_length:
            side = "right" if side == "left" else "left"
            self.recovery_swapped = True
        rec = WalkScenario(2, 0.0, self.step_duration, t_init=0.06, settle=self.settle, from_state=True,
                           first_side=side, stabilizer=self.stabilizer_on, ramp_time=self.ramp_time,
                           zmp_feedback=self.zmp_feedback,
                           cop_margin=self.cop_margin, adjust_timing=False, cmp_offset=self.cmp_offset,
                           stabilizer_gains=self.stabilizer_gains, swing_height_weight=self.swing_height_weight)
        try:
            rec.setup(controller, sim, q, v)
        except GaitError:  # e.g. a sole already tilted off the floor: no step can be planned from here
            self.recovery_failures += 1  # (not tried again: see the trigger in update)
            return
        self._recovery, self._t_recovery = rec, float(t)

    def _recovery_update(self, t, controller, sim, q, v):
        rec = self._recovery
        rec.measured_zmp = self.measured_zmp
        rec.measured_normal_force = self.measured_normal_force
        rec.update(t - self._t_recovery, controller, sim, q, v)
        pin.framesForwardKinematics(self._model, self._data, q)
        i = min(self._k, len(self.log["phase"]) - 1)
        lg = self.log
        for j, s in enumerate(("left", "right")):
            lg["phase"][i, j] = ("stance", "unloading", "swing", "loading").index(rec.switcher.phase(s))
            M = self._data.oMf[self._fid[s]]
            lg["sole_xy"][i, j] = M.translation[:2]
            lg["sole_yaw"][i, j] = math.atan2(M.rotation[1, 0], M.rotation[0, 0])
        self._k += 1
        return self._apply_push(t, sim)

    def _apply_push(self, t, sim):
        active = self.push > 0 and self.push_time <= t < self.push_time + self.push_duration - 1e-9
        f, self._pushing = timed_push(sim, self._push_body, self.push * self.push_vec if active else None, active,
                                      self._pushing)
        return f

    def _adjust_step(self, t, k, c, cd, xi):
        """Step adjustment (class docstring): in the single support of a released swing foot, the landing from
        the measured DCM vs the DCM plan held at the swing's start (eq. 1 of :mod:`wbc.gait.step_adjustment`);
        when it moved by more than 1 cm, replan the DCM and the swing from it (measured CoM state)."""
        idx = self._swing_at[k]  # the first swing with k_lift <= k < k_td
        if idx < 0:
            self._base = None
            return
        side, k_lift, k_td, fs = self.swings[idx]
        if self.switcher.phase(side) != "swing":
            return
        if self._base is None or self._base[0] != idx:
            self._base = (idx, fs, self.ref_dcm.copy())
        time_left = (k_td - k) * self.dt
        # blind: the vertical descent (the last 1 - BLIND_XY_END of the swing) may end on a bump at any tick, so its
        # foothold no longer moves; before it, the foot must reach the foothold by the descent's start
        descent = (1.0 - BLIND_XY_END) * (k_td - k_lift) * self.dt if self.blind else 0.0
        frozen = time_left < max(self.adjust_freeze, descent)
        if frozen and not (self.adjust_timing and self.max_stretch > 0 and self._stretched != idx
                           and time_left >= 0.02):
            return
        _, fs0, dcm0 = self._base
        if fs.x == fs0.x and fs.y == fs0.y:  # (StepAdjuster.correction's dead band: no correction, nothing to do)
            ex, ey = float(xi[0]) - float(dcm0[k, 0]), float(xi[1]) - float(dcm0[k, 1])
            if math.sqrt(ex * ex + ey * ey) <= self.adjuster.dead_band:
                return
        other = "right" if side == "left" else "left"
        M = self._data.oMf[self._fid[other]]
        stance = (M.translation[0], M.translation[1], math.atan2(M.rotation[1, 0], M.rotation[0, 0]))
        corr = self.adjuster.correction(xi, dcm0[k], time_left)
        if not corr.any() and abs(fs.x - fs0.x) + abs(fs.y - fs0.y) == 0.0:
            return
        target = self.adjuster.landing(fs0, stance, corr) if corr.any() else fs0
        skip = 0
        foot = self._data.oMf[self._fid[side]].translation[:2]
        stretch = self._stretch(idx, fs, fs0, stance, corr, target, foot, xi, dcm0[k], time_left)
        if stretch:
            skip = -stretch
            corr = self.adjuster.correction(xi, dcm0[k], time_left, time_left + stretch * self.dt,
                                            np.array(stance[:2]))
            target = self.adjuster.landing(fs0, stance, corr)
        elif frozen:
            return
        if not skip and self.adjust_timing and time_left > self.min_time_left + 0.02 \
                and self._skipped != idx and self._stretched != idx \
                and self.adjuster.correction_clip(fs0, stance, corr, target) > 0.05 and not self._capturable(xi, other):
            # The swing foot must still reach its landing: at most ``max_swing_speed`` on average over the
            # shortened swing (a swing compressed too much touches the floor on its way, short of its target).
            dist = float(np.linalg.norm(foot - [target.x, target.y]))
            cut = min(time_left - self.min_time_left, self.max_cut, time_left - descent - dist / self.max_swing_speed)
            skip = int(round(cut / self.dt)) if cut >= 0.02 else 0
            if skip:
                u0 = np.array(stance[:2])
                corr = self.adjuster.correction(xi, dcm0[k], time_left, time_left - skip * self.dt, u0)
                target = self.adjuster.landing(fs0, stance, corr)
        d = np.array([target.x - fs.x, target.y - fs.y])
        if np.linalg.norm(d) < 0.01 and not skip:
            return
        remaining = [(i, sw) for i, sw in enumerate(self.swings) if sw[2] > k]
        new = [Footstep(sw[3].side, sw[3].x + d[0], sw[3].y + d[1], sw[3].yaw) for _, sw in remaining]
        try:
            rp = self._rp.replan(k - self._rp_k0, np.asarray(c), np.asarray(cd), new, check_start=False, skip=skip)
        except GaitError:
            self.replan_failures += 1
            return
        k1 = k + skip  # the plan sample of the current time after the timing change
        self._rp, self._rp_k0 = rp, k1
        for (i, sw), f in zip(remaining, new):
            self.swings[i] = (sw[0], sw[1], sw[2], f)
        n = rp.n_samples
        for s, P, V in (("left", rp.left_sole, rp.left_sole_vel), ("right", rp.right_sole, rp.right_sole_vel)):
            self.poses[s][k1:k1 + n] = P
            self.vels[s][k1:k1 + n] = V
            self.acc[s][k1:k1 + n] = np.gradient(V, self.dt, axis=0)
        self.ref_dcm[k1:k1 + n] = rp.dcm
        self.ref_zmp[k1:k1 + n] = rp.zmp
        if skip:
            self._shift += skip
            if skip > 0:
                self._skipped = idx
            else:
                self._stretched = idx
            self._base = (idx, target, self.ref_dcm.copy())  # later corrections: against the new plan
            self.timing_changes.append((float(t), side, skip * self.dt))
        self.adjustments.append((float(t), side, float(target.x - fs0.x), float(target.y - fs0.y)))

    def _stretch(self, idx, fs, fs0, stance, corr, target, foot, xi, xi_ref, time_left) -> int:
        """Samples by which to lengthen the swing ``idx`` in progress (0: none): in the last ``stretch_window`` s of
        a swing not yet stretched or cut, with timing adaptation on, :meth:`StepAdjuster.stretch_samples
        <wbc.gait.step_adjustment.StepAdjuster.stretch_samples>` (earlier in the swing, a cut is better: the foot
        can still travel and landing sooner lets the DCM diverge less)."""
        if not self.adjust_timing or self.max_stretch <= 0 or self._stretched == idx or self._skipped == idx \
                or time_left > self.stretch_window:
            return 0
        limits = StretchLimits(self.max_stretch, self.stretch_speed, self.stretch_min, self.dt)
        return self.adjuster.stretch_samples(limits, fs0, fs, stance, corr, target, foot, (xi, xi_ref), time_left)

    def _capturable(self, xi: np.ndarray, stance: str) -> bool:
        """True when the measured DCM lies inside the ``stance`` sole shrunk by the CoP margin: with the CoP at the
        DCM the DCM stays put (``ξ̇ = ω (ξ − p)``, Englsberger 2015 eq. 6) — the state is 0-step capturable (Pratt et
        al. 2006; Koolen et al., IJRR 31(9), 2012) and landing sooner gains nothing, while the swing, hurried,
        may land short of its target (after a wide lateral step put the stance sole under the DCM)."""
        r = self.robot
        sole = projected_sole_corners(self._data.oMf[self._fid[stance]], r.sole_length - 2 * self.cop_margin,
                                      r.sole_width - 2 * self.cop_margin)
        return polygon_margin(np.asarray(xi, float), convex_hull(sole)) >= 0.0

    # -- summary -------------------------------------------------------------------------------------------
    def criteria(self) -> list[Criterion]:
        """:func:`walk_criteria` with the default tolerances (on terrain, and
        :data:`wbc.scenarios.terrain_walk.TERRAIN_CRITERIA`)."""
        if self.terrain is not None:
            from wbc.scenarios.terrain_walk import TERRAIN_CRITERIA

            return walk_criteria() + TERRAIN_CRITERIA
        return walk_criteria()

    def extra_summary(self, run) -> dict:
        n = len(run.t)
        lg = {k: (v[:n] if isinstance(v, np.ndarray) else v[:n]) for k, v in self.log.items()}
        if "q_est" in run.extra:  # the controller read an estimate: the metrics use the plant's (logged) state
            lg["sole_xy"], lg["sole_yaw"] = _sole_tracks(self._model, run.q, self._fid)
        plan, dt = self.plan, self.dt
        # Measured CoP and its margin in the loaded soles' hull (plant's contact forces).
        cop = np.full((n, 2), np.nan)
        margin = np.full(n, np.nan)
        settle = min(n - 1, 5)
        r = self.robot
        for i in range(settle, n):
            wr = run.sim_wrench[i]
            h = 0.0
            if self.terrain_walk is not None:  # on the plane of the loaded soles (normal-force-weighted height)
                fz = np.maximum(wr[:, 2], 0.0)
                h = float(fz @ run.sole_pos[i, :, 2] / fz.sum()) if fz.sum() > 0 else 0.0
            p = measured_cop(wr, run.sole_pos[i], height=h)
            if p is None:
                continue
            cop[i] = p
            pts = []
            for j in range(2):
                if wr[j, 2] > 10.0:
                    yaw = lg["sole_yaw"][i, j]
                    pose = pin.SE3(pin.rpy.rpyToMatrix(0, 0, yaw), np.r_[run.sole_pos[i, j, :2], 0.0])
                    pts.append(projected_sole_corners(pose, r.sole_length, r.sole_width))
            if pts:
                margin[i] = polygon_margin(p, convex_hull(np.vstack(pts)))
        # Touch-downs vs footsteps; stance slip per loaded-stance interval.
        ev = self.switcher.events
        landing, td_delay, slips = [], [], []
        swings = list(self.swings)
        tds = [(t, s) for t, s, e in ev if e == "touchdown"]
        unloads = {sd: [t for t, s, e in ev if e == "unload" and s == sd] for sd in ("left", "right")}
        count = {"left": 0, "right": 0}
        for (side, k_lift, k_td, fs) in swings:
            # the swings of a side are unloaded in order: the i-th unload of a side starts its i-th swing
            if count[side] >= len(unloads[side]):
                continue
            t_unload = unloads[side][count[side]]
            count[side] += 1
            match = [t for t, s in tds if s == side and t > t_unload]
            if not match:
                continue
            ttd = match[0]
            i = min(int(round(ttd / dt)), n - 1)
            j = 0 if side == "left" else 1
            landing.append(float(np.linalg.norm(lg["sole_xy"][i, j] - [fs.x, fs.y])))
            earlier = sum(m for tt, sd, m in self.timing_changes if tt <= ttd)  # planned landing moved earlier
            td_delay.append(ttd - (k_td * dt - earlier))
        for j, s in enumerate(("left", "right")):
            stance = lg["phase"][:, j] == 0  # fully loaded stance
            k = 0
            while k < n:
                if stance[k]:
                    k1 = k
                    while k1 < n and stance[k1]:
                        k1 += 1
                    xy = lg["sole_xy"][k:k1, j]
                    slips.append(float(np.linalg.norm(xy - xy[0], axis=1).max()))
                    k = k1
                else:
                    k += 1
        mid0 = run.sole_pos[0, :, :2].mean(axis=0)
        mid1 = run.sole_pos[-1, :, :2].mean(axis=0)
        yaw_end = math.atan2(np.sin(lg["sole_yaw"][-1]).sum(), np.cos(lg["sole_yaw"][-1]).sum())
        yaw0 = math.atan2(np.sin(lg["sole_yaw"][0]).sum(), np.cos(lg["sole_yaw"][0]).sum())
        last = {}
        for fs in plan.footsteps:
            last[fs.side] = fs.yaw
        yaw_cmd = yaw0 + (self.n_steps - 1) * self.turn if self.n_steps > 1 else yaw0
        dxi = np.linalg.norm(lg["dcm"] - lg["dcm_ref"], axis=1)
        complete = bool(run.t[-1] >= self.duration - 2 * dt) and not run.fell
        out = {
            "steps": self.n_steps, "step_length_m": self.step_length, "step_duration_s": self.step_duration,
            "commanded_speed_mps": self.step_length / self.step_duration,
            "commanded_distance_m": float(plan.planned_distance),
            "walked_distance_m": float(np.linalg.norm(mid1 - mid0)),
            "commanded_heading_rad": float(yaw_cmd - yaw0),
            "walked_heading_rad": float(math.remainder(yaw_end - yaw0, 2 * math.pi)),
            "touchdowns": len(landing),
            "landing_error_m": landing,
            "max_landing_error_m": max(landing) if landing else float("nan"),
            "touchdown_delay_s": td_delay,
            "stance_slip_m": slips,
            "max_stance_slip_m": max(slips) if slips else 0.0,
            "min_measured_cop_margin_m": float(np.nanmin(margin)) if np.isfinite(margin).any() else float("nan"),
            "max_dcm_error_m": float(np.nanmax(dxi)) if np.isfinite(dxi).any() else float("nan"),
            "stabilizer": self.stabilizer_on,
            "touchdown_detection": "state: sole height <= 3 mm and vertical sole velocity <= 0.05 m/s"
                                   + ("" if self.measured_normal_force is None or self.switcher.contact_force is None
                                      else f" and a measured normal force >= {self.switcher.contact_force:.1f} N")
                                   + ("" if self.measured_normal_force is None else
                                      f"; or F/T: normal force >= {100 * self.touchdown_load:g} % of the weight with "
                                      f"the sole below {self.switcher.touchdown_force_height * 1e3:g} mm"),
            "push_n": self.push, "push_time_s": self.push_time,
            "step_adjustments": len(self.adjustments),
            "support_cuts": self.support_cuts,
            "step_timing_changes_s": [m for _, _, m in self.timing_changes],
            "max_step_adjustment_m": max((math.hypot(a[2], a[3]) for a in self.adjustments), default=0.0),
            "adjusted_distance_m": float(np.linalg.norm(
                0.5 * (self.poses["left"][-1, :2, 3] + self.poses["right"][-1, :2, 3])
                - 0.5 * (self.poses["left"][0, :2, 3] + self.poses["right"][0, :2, 3]))),
            "replan_failures": self.replan_failures,
            "recovery_step_time_s": self._t_recovery,
            "recovery_plan_failures": self.recovery_failures,
            "recovery_step_by_far_foot": self.recovery_swapped,
            "completed": complete,
        }
        out["target_distance_m"] = out["adjusted_distance_m"] if self.adjustments else out["commanded_distance_m"]
        if self.terrain_walk is not None:  # from the plant's state (logged q), wbc.scenarios.terrain_walk
            from wbc.scenarios.terrain_walk import terrain_summary

            soles = {s: np.empty((n, 4, 4)) for s in ("left", "right")}
            data = self._model.createData()
            for i in range(n):
                pin.framesForwardKinematics(self._model, data, run.q[i])
                for s in soles:
                    soles[s][i] = data.oMf[self._fid[s]].homogeneous
            ts = terrain_summary(self.terrain_walk, soles["left"], soles["right"], r.sole_length, r.sole_width)
            if ts["min_swing_clearance_m"] is None:
                ts["min_swing_clearance_m"] = float("inf")
            out.update(ts)
        run.extra.update({"support_phase": lg["phase"], "measured_cop": cop, "measured_cop_margin": margin,
                          "dcm": lg["dcm"], "dcm_ref": lg["dcm_ref"], "cop_cmd": lg["cop_cmd"]})
        return out


def fs_index(plan, k_lift: int) -> int:
    """Index in ``plan.footsteps`` of the step whose swing lifts off at sample ``k_lift``."""
    return next(ph.step for ph in plan.phases if ph.step >= 0 and ph.first == k_lift)


def walk_criteria(*, distance_tol: float = 0.05, slip_max: float = 0.005,
                  heading_tol: float = math.radians(5.0)) -> list[Criterion]:
    """Criteria of a physics walk: no fall, walked distance within ``distance_tol`` (relative, at least 1 cm) of
    the target distance (commanded, or the adjusted plan's distance when steps were adjusted), final heading within ``heading_tol`` (rad) of commanded, stance slip ≤ ``slip_max`` (m) per step,
    0 solver failures, walk completed."""
    return [
        NO_FALL,
        Criterion(f"walked distance within {distance_tol:.0%} (≥ 1 cm) of the target", "walked_distance_m", "<=",
                  distance_tol, minus="target_distance_m", scale_by="target_distance_m", floor=0.01),
        Criterion(f"final heading within {math.degrees(heading_tol):.0f} deg of commanded", "walked_heading_rad",
                  "<=", heading_tol, minus="commanded_heading_rad", period=2 * math.pi),
        Criterion(f"stance slip ≤ {slip_max * 1e3:.0f} mm", "max_stance_slip_m", "<=", slip_max),
        Criterion("no solver failure", "solver_failures", "==", 0),
        Criterion("walk completed", "completed", "==", True),
    ]


def walk_acceptance(summary: dict, **tolerances) -> list[str]:
    """Failed criteria of a walk summary (:func:`walk_criteria`, keyword arguments passed on)."""
    return evaluate(summary, walk_criteria(**tolerances))[1]
