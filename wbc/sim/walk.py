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
  capture step (a 2-step walk planned from the measured state, with the walk's ``adjust_timing``). Step timing
  adjustment (``adjust_timing``, default on): the landing and the touch-down time of the swing from one QP on the DCM
  (:class:`wbc.gait.step_timing.StepTimingQP`, Khadiv et al. 2020), the swing cut short when the QP lands it 0.02 s
  or more earlier, no earlier than its foot can still travel at ``max_swing_speed``; late in a swing, a landing the
  foot can no longer reach in time lengthens the swing instead (``WalkScenario._stretch``), whose stretched rest
  rises off the floor again (``WalkScenario._add_relift``); a stretched sole set down before it rose lands where it
  was, and the plan before the stretch is restored (``WalkScenario._swing_landed``). The stabilizer may put the CMP
  outside the support area by ``cmp_offset`` (hip strategy, :class:`DcmStabilizer`).

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
from wbc.exceptions import GaitError, InvalidInputError
from wbc.geometry import FLOAT64, check_flag, check_scalar, mean_heading
from wbc.gait import Footstep, plan_walk
from wbc.gait.blind import BLIND_XY_END, blind_swing_into
from wbc.gait.stance_reach import STANCE_REACH_RATIO, stance_legs
from wbc.gait.commands import feet_can_yaw
from wbc.gait.stabilizer import DcmStabilizer, stabilizer_kernel, support_kernel
from wbc.gait.step_adjustment import StepAdjuster
from wbc.gait.step_timing import StepTimingQP
from wbc.sim.physics_scenarios import contacts_rank_deficient
from wbc.sim.walk_steps import TRAILING_RELEASE, WalkSteps
from wbc.sim.walk_summary import WalkSummary
from wbc.sim.walk_contacts import WalkContactEvents, contact_events_option
from wbc.sim.walk_support import WalkSupport

__all__ = ["WalkScenario", "TOUCHDOWN_CONFIRM_LOAD"]

_CODE_SWING = {1: "right", 2: "left"}  # plan support code → swinging side
_PHASE_CODE = {"stance": 0, "unloading": 1, "swing": 2, "loading": 3}  # contact phase → its code in the log


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
    law = (1.0, 1.0, 1.0, 0.0, 1.0, 1.0, 1.0, z2.copy(), z2.copy(), z2.copy())  # DcmStabilizer.law()
    for p_meas in (z2.copy(), np.full(4, np.nan)[::2]):  # (_stabilize's specialisation: p_meas of any strides)
        stabilizer_kernel(np.zeros((4, 6)), 2, z3, z3, z3, z3, zr[0], zr[0], p_meas, law)


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


class WalkScenario(WalkSupport, WalkSteps, WalkSummary, WalkContactEvents):
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
        adjust_timing: step timing adjustment (Khadiv et al. 2020; default on): per tick of a single support, the
            landing and touch-down time from one QP on the measured DCM (:class:`wbc.gait.step_timing.StepTimingQP`,
            ``_step_timing``), which changes the time when the reach stops the landing (a push towards the stance
            leg, which the swing foot cannot cross, or beyond the outer reach): landing sooner, the DCM has
            diverged less and the next step comes sooner. A QP time 0.02 s or more before the planned touch-down
            cuts the swing short to it (:meth:`wbc.gait.WalkPlan.replan` ``skip``) onto the QP's landing. ``T`` is
            at least ``min_time_left`` s from now and (distance from the foot to the landing) / ``max_swing_speed``
            (m/s, default 2.5; touch-down is armed at mid-swing in sim time, so a hurried swing does not touch
            down on its way). Not while the measured DCM is inside the stance sole (0-step capturable,
            ``_capturable``); again each time the QP's time moves 0.02 s or more earlier (a cut is not undone). Defaults ``max_swing_speed`` 2.5 m/s, ``lateral_reach`` 0.7,
            ``cmp_offset`` 0.04 m, tuned on the pushed walks of ``benchmarks/walk_push_trials.py``
            (``benchmarks/README.md``): a push towards the stance leg needs two quick steps (the inner foot, which
            cannot cross, then the outer one) and the DCM diverges from the stance CoP meanwhile. The swing in
            progress is **lengthened** instead (by at most ``max_stretch`` s) when, in its last ``stretch_window``
            s, the adjusted landing is farther from the foot than ``stretch_speed`` (m/s) times the time left
            (``_stretch``: a push late in a swing towards the swing side; the foot lands later and further out,
            ``adjust_freeze`` notwithstanding; the stretched rest of the swing rises again, ``_add_relift``).
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
        min_time_left, max_swing_speed, max_stretch, stretch_speed, stretch_min, stretch_window: step timing
            adjustment bounds (s, m/s, s, m/s, m, s) described under ``adjust_timing``.
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
        contact_events: contacts following the measured contact events (:mod:`wbc.sim.walk_contacts`; default off).
        hurry_double_support: with ``step_adjust`` and ``adjust_timing``: a double support ends once the measured
            DCM is outside both soles' hull (shrunk by ``cop_margin``), at its touch-down or any later tick, the next
            swing's ramp-out starting then (:meth:`WalkScenario._hurry_double_support`; default True).
        impact_window: s before a swing's planned touch-down (and after it, while the sole is in swing) in which
            the ID controller bounds the leg joints' speeds after the impact of that sole, flat or on a corner
            (:class:`wbc.constraints.impact.ImpactSpeedBounds`, added to its QP at :meth:`setup`); 0: off.
        reach_ratio: ρ in (0, 1], or None (off): :attr:`~wbc.sim.walk_steps.WalkSteps.reach_ratio`.
        trailing_release: ρ in (0, 1], or None (off): :attr:`~wbc.sim.walk_steps.WalkSteps.trailing_release` (the
            summary's ``trailing_releases``).

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
                 adjust_timing: bool = True, min_time_left: float = 0.15,
                 lateral_reach: float = 0.7, forward_reach: float = 0.65, max_swing_speed: float = 2.5,
                 cmp_offset: float = 0.04, max_stretch: float = 0.15, stretch_speed: float = 1.0,
                 stretch_min: float = 0.03, stretch_window: float = 0.2, zmp_feedback: float = 0.0,
                 stabilizer_gains: dict | None = None, terrain=None, base_weight: float = 3.0,
                 blind: bool = False, touchdown_load: float = 0.05, await_load: bool = False, contact_events=False,
                 swing_froude: float | None = None, swing_height_weight: float | None = None,
                 hurry_double_support: bool = True, impact_window: float = 0.04,
                 reach_ratio: float | None = STANCE_REACH_RATIO, trailing_release: float | None = TRAILING_RELEASE):
        from wbc.terrain import parse_terrain
        self.reach_ratio, self.trailing_release = reach_ratio, trailing_release  # (validated: WalkSteps' setters)
        self.hurry_double_support = check_flag(hurry_double_support, "hurry_double_support")
        self.impact_window = check_scalar(impact_window, "impact_window", "s")
        self.contact_thresholds = contact_events_option(contact_events)
        self.terrain = None if terrain is None else parse_terrain(terrain)
        self.base_weight = check_scalar(base_weight, "base_weight", "task weight")
        self.swing_froude = check_scalar(SWING_FROUDE if swing_froude is None else swing_froude, "swing_froude",
                                         "Froude number", strict=True)
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
        check_scalar(step_duration, "step_duration", "s", minimum=0.2, strict=True)
        check_scalar(max_swing_speed, "max_swing_speed", "m/s", strict=True)
        check_scalar(push, "push force", "N")
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
        self._impact_setup(controller, robot)
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
        reach = dict(max_forward=self.forward_reach * zc, max_backward=0.35 * zc, min_width=robot.sole_width + 0.05,
                     max_width=w0 + self.lateral_reach * zc)
        self.adjuster = StepAdjuster(plan.omega, **reach, dead_band=self.adjust_dead_band,
                                     sole_length=robot.sole_length, sole_width=robot.sole_width)
        self.timing_qp = StepTimingQP(plan.omega, **reach)
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
        self._skipped, self._stretched, self._relift = -1, -1, None  # swings cut / lengthened; _add_relift
        self._base = None  # (swing index, footstep, DCM reference) at the start of the current swing or its last cut
        self._nominal = None  # (swing index, footstep, DCM reference) at the start of the current swing
        self._cut_samples = 0  # samples by which the current swing was cut short so far
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
        self._landed = None  # the side whose swing touched down this tick (_swing_landed, _hurry_double_support)
        self._next = 0  # next swing to start
        self._t_unload = {"left": -1.0, "right": -1.0}
        #: (t, side) of each swing's start: its ramp-out, or the swing of a sole the contact events released
        self.swing_starts: list[tuple[float, str]] = []
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
        self._setup_contact_events(robot, sim.timestep)
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
        self._log_rows = tuple(self.log[key] for key in ("phase", "dcm", "dcm_ref", "cop_cmd", "sole_xy", "sole_yaw"))
        self._k = 0
        self._pushing = False
        self._legs = stance_legs(robot) if self.reach_ratio is not None else None  # (WalkSteps._step_timing)
        self.reach_cuts = 0  # swings whose touch-down time the stance leg's reach brought forward

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
        self._release_next_swing(t, tp, k, q, controller, v)  # (its ramp-out, the foot released at its lift-off)
        if self.terrain_walk is not None or self.blind:
            self._relative_ground(k, q)
        for side, (_, k_lift, k_td, fs) in self._active.items():
            sw.set_landing_due(side, tp >= k_td * dt - 1e-9)
        # CoM, its velocity and the soles for the DCM, the log and the switcher's armed soles: one forward pass (inside
        # centerOfMass with v), then the soles' placements alone
        model, data, fid = self._model, self._data, self._fid
        pin.centerOfMass(model, data, q, v)
        pin.updateFramePlacement(model, data, fid["left"])
        pin.updateFramePlacement(model, data, fid["right"])
        sw.update(t, q, v, self.measured_normal_force, data)
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
                self._add_relift(side, k_td, kk, pos, vel, acc)  # (a stretched swing: its rest re-lifted)
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
                self._swing_landed(side, tf, k)  # (a stretch undone when the sole never rose again)
        self._impact_expect(tp)
        if self._torso_turn is not None:
            self._turn_torso(controller, k)
        self._follow_contacts(tf, controller, tp)  # (opt-in: the contacts follow the measured contact events)
        c, cd = self._com_view, self._vcom_view  # data.com[0], data.vcom[0]
        w = plan.omega
        cx, cy, _ = c.tolist()
        cdx, cdy, _ = cd.tolist()
        xix, xiy = cx + cdx / w, cy + cdy / w
        xi = np.array([xix, xiy])
        if self.step_adjust and self.adjust_timing and self.hurry_double_support \
                and (self._landed is not None or (not self._active and self._next > 0)):
            self._hurry_double_support(t, k, c, cd, xi)
        self._landed = None
        if self.step_adjust:
            self._adjust_step(t, k, c, cd, xi)
        lg_phase, lg_dcm, lg_dcm_ref, lg_cop, lg_xy, lg_yaw = self._log_rows
        i = min(self._k, len(lg_phase) - 1)
        dz, dzd = self._support_offset(k) if self.blind or self.terrain_walk is not None else (0.0, 0.0)
        if self.blind:
            self._partial_footholds(controller, q, v, t)
        if self.stabilizer_on:
            stab = self.stab
            p_meas = self.measured_zmp
            if self._cut["left"] is None and self._cut["right"] is None and (p_meas is None or (
                    type(p_meas) is np.ndarray and p_meas.shape == (2,) and p_meas.dtype == FLOAT64
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
            lg_cop[i] = self.stab.last_cop
        else:
            controller.set_com_reference(plan.com[k] + [0.0, 0.0, dz], plan.com_vel[k] + [0.0, 0.0, dzd],
                                         plan.com_acc[k])
        lg_dcm[i] = xi
        lg_dcm_ref[i] = self.ref_dcm[k]
        lg_phase[i] = (_PHASE_CODE[sw.phase("left")], _PHASE_CODE[sw.phase("right")])
        (_, R0, p0), (_, R1, p1) = self._sole_views["left"], self._sole_views["right"]
        lg_xy[i] = (p0[:2], p1[:2])
        lg_yaw[i, 0] = math.atan2(R0[1, 0], R0[0, 0])
        lg_yaw[i, 1] = math.atan2(R1[1, 0], R1[0, 0])
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
