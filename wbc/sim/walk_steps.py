"""Step adjustment of a physics walk (:class:`wbc.sim.walk.WalkScenario`, :class:`WalkSteps`): the landing point
following the measured DCM during a swing, the swing cut short or stretched (the stretched rest re-lifted off the
floor), the capture step after the last step and the scheduled push."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.constraints.impact import ImpactSpeedBounds, ImpactSpeedExcess
from wbc.exceptions import GaitError, InvalidInputError
from wbc.formulations.reference import AccelerationReference
from wbc.gait import Footstep
from wbc.gait.blind import BLIND_XY_END
from wbc.gait.stance_reach import STANCE_REACH_RATIO, stance_reach_time
from wbc.gait.step_adjustment import StretchLimits
from wbc.geometry import check_scalar, convex_hull, polygon_margin, projected_sole_corners
from wbc.sim.actuators import leg_joints
from wbc.sim.scenarios import timed_push

_ZERO6 = np.zeros(6)  # (a held foot's velocity and acceleration feed-forward; read, never written)


def _fraction_or_none(value, what: str, unit: str) -> float | None:
    """None, or ``value`` as a float in (0, 1]; else an InvalidInputError naming ``what``."""
    if value is not None and not check_scalar(value, what, unit, strict=True) <= 1:
        raise InvalidInputError(f"{what} must be a number in (0, 1] or None, got {value!r}")
    return None if value is None else float(value)

__all__ = ["WalkSteps", "SWING_RAMP", "TRAILING_RELEASE"]

#: r of :attr:`WalkSteps.swing_ramp`: the velocity of a re-planned swing in progress ramps up and down over 0.3 of its
#: rest (:func:`wbc.profiles.ramped_trapezoid`; peak 1.43 times the average, against the minimum-jerk blend's 1.875).
#: Chosen on a screen of push campaign 9417 (benchmarks/records/79): 0.3 against 0.4 and the minimum-jerk blend.
SWING_RAMP = 0.3

#: ρ of :attr:`WalkSteps.trailing_release` (:meth:`WalkSteps._release_trailing`): the sole of the next swing is let go in a double
#: support once a joint of its leg moves at ρ of its URDF speed limit (estimated). The unpushed Talos walk stays
#: under 0.31; in the speed failures of push campaign 9420 the trailing knee's speed bound held the QP from 0.8 on
#: (benchmarks/records/85): 0.8 against 0.9 on its 102 failures, 100 of its survivors unchanged.
TRAILING_RELEASE = 0.8


class WalkSteps:
    """Step adjustment, capture step and push of :class:`wbc.sim.walk.WalkScenario` (its state: the plan, the
    switcher, the step adjuster)."""

    _pre_stretch = None  # the plan before the last stretch, set in _adjust_step (_swing_landed)
    _swing_ramp: float | None = SWING_RAMP

    @property
    def swing_ramp(self) -> float | None:
        """How the swing in progress follows a moved landing (:meth:`wbc.gait.WalkPlan.replan`): a fraction r,
        0 < r ≤ 0.5, of its rest over which its horizontal velocity ramps up and down (the ramped trapezoid of
        :mod:`wbc.profiles`: top speed 1/(1 − r) times the average), default :data:`SWING_RAMP`; None: the
        minimum-jerk blend (top speed 1.875 times the average). A late move of a landing asks the swing leg's joints
        for more speed than they have with the minimum-jerk blend: the sole then lags its reference, and lands late in
        its descent still travelling along the floor (benchmarks/records/79).

        Raises:
            InvalidInputError: on assignment, a value that is not None or a number in (0, 0.5].
        """
        return self._swing_ramp

    @swing_ramp.setter
    def swing_ramp(self, value) -> None:
        if value is not None and (isinstance(value, bool) or not isinstance(value, (int, float, np.floating))
                                  or not 0.0 < value <= 0.5):
            raise InvalidInputError(f"swing_ramp must be None (minimum-jerk) or a number in (0, 0.5], got {value!r}")
        self._swing_ramp = None if value is None else float(value)

    _reach_ratio: float | None = STANCE_REACH_RATIO
    _trailing_release: float | None = TRAILING_RELEASE

    @property
    def reach_ratio(self) -> float | None:
        """ρ in (0, 1], or None (off): a swing whose time the step timing QP adapts touches down no later than the
        stance leg's hip-to-ankle distance reaches ρ × the leg's stretched length on the LIPM
        (:func:`wbc.gait.stance_reach.stance_reach_time`; default :data:`~wbc.gait.stance_reach.STANCE_REACH_RATIO`);
        :attr:`reach_cuts` counts the swings whose time it set.

        Raises:
            InvalidInputError: on assignment, a value that is not None or a number in (0, 1].
        """
        return self._reach_ratio

    @reach_ratio.setter
    def reach_ratio(self, value) -> None:
        self._reach_ratio = _fraction_or_none(value, "reach_ratio", "of the leg")

    @property
    def trailing_release(self) -> float | None:
        """ρ in (0, 1], or None (off): in a double support after a touch-down, the sole of the next swing is released
        at once when a joint of its leg moves at ρ or more of its URDF speed limit (:meth:`_release_trailing`; default
        :data:`TRAILING_RELEASE`); :attr:`trailing_releases` lists them as (t s, side, speed / limit).

        Raises:
            InvalidInputError: on assignment, a value that is not None or a number in (0, 1].
        """
        return self._trailing_release

    @trailing_release.setter
    def trailing_release(self, value) -> None:
        self._trailing_release = _fraction_or_none(value, "trailing_release", "of the joint speed limit")

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
        captured by that foot stepping forward, not by lifting the other one, on which the DCM then nearly stands.

        Either choice is then checked on the LIPM (:meth:`_capture_excess`): when the other foot's step needs less
        than the chosen one's beyond the step adjuster's reach, the other foot steps. After a wide lateral step the
        DCM can lie just inside the landed sole's inner half or ahead of it, and lifting that sole leaves the CoP on
        the far one, 0.6–0.8 m from the DCM (14 of 32 falls after pushes late in the walk, record 74).

        The capture walk adapts its step timing as the walk does (``adjust_timing``: the step timing QP cuts the
        capture swing short and moves its landing with the time, :meth:`_step_timing`; the double support hurried,
        :meth:`_hurry_double_support`). With its time held at the walk's step duration, the DCM diverged during the
        capture swing out of the landed sole's reach: push campaign 9418 took the capture step in 31 of 1000 trials,
        of which 4 survived and 19 fell; with the timing adapted 9 survive and 11 fall, and on campaign 9419 9 of 30
        against 6 (falls 13 against 17) (benchmarks/records/81)."""
        mid = 0.5 * (self._data.oMf[self._fid["left"]].translation[:2] + self._data.oMf[self._fid["right"]].translation[:2])
        lat = self._data.oMf[self._fid["left"]].rotation[:2, 1]  # towards the left sole
        dcm_side = "left" if (xi - mid) @ lat >= 0 else "right"
        side, sign = dcm_side, 1.0 if dcm_side == "left" else -1.0
        rel = xi - self._data.oMf[self._fid[side]].translation[:2]
        fwd = self._data.oMf[self._fid[side]].rotation[:2, 0]
        if sign * float(rel @ lat) > -0.5 * self.robot.sole_width \
                and abs(float(rel @ fwd)) <= 0.5 * self.robot.sole_length:
            side = "right" if side == "left" else "left"
        other = "right" if side == "left" else "left"
        if self._capture_excess(xi, other) < self._capture_excess(xi, side):
            side = other
        self.recovery_swapped = side != dcm_side
        rec = type(self)(2, 0.0, self.step_duration, t_init=0.06, settle=self.settle, from_state=True,
                           first_side=side, stabilizer=self.stabilizer_on, ramp_time=self.ramp_time,
                           zmp_feedback=self.zmp_feedback,
                           cop_margin=self.cop_margin, adjust_timing=self.adjust_timing, cmp_offset=self.cmp_offset,
                           stabilizer_gains=self.stabilizer_gains, swing_height_weight=self.swing_height_weight,
                           contact_events=self.contact_thresholds or False, trailing_release=self.trailing_release)
        try:
            rec.setup(controller, sim, q, v)
        except GaitError:  # e.g. a sole already tilted off the floor: no step can be planned from here
            self.recovery_failures += 1  # (not tried again: see the trigger in update)
            return
        if self.contact_monitor is not None:  # the events go on from what they measured (not from standing)
            for side, sole in rec.contact_monitor.soles.items():
                sole.continue_from(self.contact_monitor.soles[side])
        self._recovery, self._t_recovery = rec, float(t)

    def _capture_excess(self, xi: np.ndarray, side: str) -> float:
        """How far (m) the landing that captures the measured DCM ``xi`` (2,) m lies outside the step adjuster's
        reach when ``side`` steps: the other sole is the stance, the CoP at the point of that sole (shrunk by the CoP
        margin) nearest the DCM for a swing of ``t_ss`` s, the DCM then at ``p + (ξ − p) e^{ω t_ss}`` (Englsberger
        2015, eq. 6), and the reach the adjuster's box in the stance sole's frame (forward/backward, and laterally
        from ``min_width`` to ``max_width`` on the stepping foot's side: no leg crossing). 0 inside the reach."""
        stance = "right" if side == "left" else "left"
        M = self._data.oMf[self._fid[stance]]
        R, o = M.rotation[:2, :2], M.translation[:2]
        r = R.T @ (np.asarray(xi, float) - o)  # DCM in the stance sole's frame (x forward, y left)
        hl = 0.5 * self.robot.sole_length - self.cop_margin
        hw = 0.5 * self.robot.sole_width - self.cop_margin
        p = np.array([min(max(r[0], -hl), hl), min(max(r[1], -hw), hw)])
        x, y = p + (r - p) * math.exp(self.plan.omega * self.t_ss)
        lat = y if side == "left" else -y
        a = self.adjuster
        return max(0.0, x - a.max_forward) + max(0.0, -x - a.max_backward) + max(0.0, a.min_width - lat) \
            + max(0.0, lat - a.max_width)

    def _recovery_update(self, t, controller, sim, q, v):
        rec = self._recovery
        rec.measured_zmp = self.measured_zmp
        rec.measured_normal_force = self.measured_normal_force
        rec.measured_wrench = self.measured_wrench
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
        if not (active or self._pushing):  # (nothing to apply or clear: timed_push's (None, False))
            return None
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
            self._base = self._nominal = (idx, fs, self.ref_dcm.copy())
            self._cut_samples = 0
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
        elif self.adjust_timing and time_left > self.min_time_left + 0.02 and self._stretched != idx \
                and not self._capturable(xi, other):
            target, skip = self._step_timing(idx, k, xi, stance, foot, target, descent)
        d = np.array([target.x - fs.x, target.y - fs.y])
        if np.linalg.norm(d) < 0.01 and not skip:
            return
        remaining = [(i, sw) for i, sw in enumerate(self.swings) if sw[2] > k]
        new = [Footstep(sw[3].side, sw[3].x + d[0], sw[3].y + d[1], sw[3].yaw) for _, sw in remaining]
        try:
            rp = self._rp.replan(k - self._rp_k0, np.asarray(c), np.asarray(cd), new, check_start=False, skip=skip,
                                 swing_ramp=self.swing_ramp)
        except GaitError:
            self.replan_failures += 1
            return
        k1 = k + skip  # the plan sample of the current time after the timing change
        if skip < 0:  # (the plan as it was, for _swing_landed)
            soles = {s: (self.poses[s].copy(), self.vels[s].copy(), self.acc[s].copy()) for s in ("left", "right")}
            self._pre_stretch = (self._rp, self._rp_k0, list(self.swings), soles, self.ref_dcm.copy(),
                                 self.ref_zmp.copy(), self._shift, self._base, len(self.adjustments))
        self._adopt_plan(rp, k1)
        for (i, sw), f in zip(remaining, new):
            self.swings[i] = (sw[0], sw[1], sw[2], f)
        if skip:
            self._shift += skip
            if skip > 0:
                self._skipped = idx
                self._cut_samples += skip
            else:
                self._stretched = idx
                _, k_lift, k_td, _ = self.swings[idx]  # the rest of the swing rises again (_add_relift)
                self._relift = (side, k1, k_td, self.step_height * (k_td - k1) / (k_td - k_lift))
            self._base = (idx, target, self.ref_dcm.copy())  # later corrections: against the new plan
            self.timing_changes.append((float(t), side, skip * self.dt))
        self.adjustments.append((float(t), side, float(target.x - fs0.x), float(target.y - fs0.y)))

    def _adopt_plan(self, rp, k1: int) -> None:
        """Make the re-planned walk ``rp`` (:meth:`wbc.gait.WalkPlan.replan`, its sample 0 at plan sample ``k1``)
        the plan: the soles' poses, velocities and accelerations and the DCM and ZMP references from ``k1`` on."""
        self._rp, self._rp_k0 = rp, k1
        n = rp.n_samples
        for s, P, V in (("left", rp.left_sole, rp.left_sole_vel), ("right", rp.right_sole, rp.right_sole_vel)):
            self.poses[s][k1:k1 + n] = P
            self.vels[s][k1:k1 + n] = V
            self.acc[s][k1:k1 + n] = np.gradient(V, self.dt, axis=0)
        self.ref_dcm[k1:k1 + n] = rp.dcm
        self.ref_zmp[k1:k1 + n] = rp.zmp

    def _step_timing(self, idx, k, xi, stance, foot, target, descent):
        """(landing, samples to cut) of the swing ``idx`` at plan sample ``k`` from the step timing QP
        (:class:`wbc.gait.step_timing.StepTimingQP`, Khadiv et al. 2020): the landing and the touch-down time
        together, from the measured DCM ``xi`` dead-banded against the swing's nominal DCM plan (as
        :meth:`StepAdjuster.correction <wbc.gait.step_adjustment.StepAdjuster.correction>`), the nominal values
        of the plan at the swing's start (its footstep, single-support time and DCM offset, whatever was cut
        since), the reach around the ``stance`` sole, and ``T`` between the current touch-down time (cuts only
        shorten; no later than the stance leg's reach ends, ``reach_ratio``) and the earliest time at which the
        ``foot`` (x, y) still reaches the landing at
        ``max_swing_speed`` (after ``descent`` s of vertical descent, blind), at least ``min_time_left`` s from
        now. ``target`` (the landing of eq. 1, clipped) and no cut when the QP's time is less than 0.02 s before
        the current one: the QP's landing with the time held is that landing (its DCM offset weighted so much more
        than the landing, :data:`wbc.gait.step_timing.STEP_TIMING_WEIGHTS`)."""
        _, fs0, dcm0 = self._nominal
        k_lift, k_td, cut = self.swings[idx][1], self.swings[idx][2], self._cut_samples
        dt = self.dt
        t, t_nom = (k - k_lift - cut) * dt, (k_td - k_lift) * dt  # since the release; the plan's duration
        t_cur = t_nom - cut * dt
        xi_ref = dcm0[k - cut]
        e = np.asarray(xi, float) - xi_ref
        n = float(np.linalg.norm(e))
        band = self.adjuster.dead_band
        xi_b = xi_ref + (0.0 if n <= band else 1.0 - band / n) * e
        u0 = np.array(stance[:2])
        un = np.array([fs0.x, fs0.y])
        bn = self.timing_qp.nominal_offset(xi_ref, u0, un, t_nom - t)
        land = np.array([target.x, target.y])
        sol = None
        t_max = t_cur
        if self._legs is not None:  # no later than the stance leg's reach ends (wbc.gait.stance_reach)
            leg = self._legs["right" if fs0.side == "left" else "left"]
            t_max = min(t_cur, t + stance_reach_time(self._com_view, self._vcom_view, self.plan.omega,
                                                     self._data.oMi[leg.hip].translation,
                                                     self._data.oMi[leg.ankle].translation,
                                                     self.reach_ratio * leg.length))
        for _ in range(2):  # the earliest landing time depends on the landing: once more from the QP's landing
            t_min = t + max(self.min_time_left, descent + float(np.linalg.norm(foot - land)) / self.max_swing_speed)
            if t_min >= t_cur - 0.02:  # (no cut the foot can travel)
                sol = None
                break
            try:
                sol = self.timing_qp.solve(xi_b, stance=stance, stance_cop=u0, swing_left=fs0.side == "left",
                                           elapsed=t, landing_nom=un, duration_nom=t_nom, offset_nom=bn,
                                           t_min=t_min, t_max=(t_hi := max(t_max, t_min + 0.02)))
            except GaitError:  # (DAQP's exit flag: the time held, the landing of eq. 1)
                self.replan_failures += 1
                return target, 0
            if float(np.linalg.norm(foot - sol.landing)) / self.max_swing_speed + descent <= sol.duration - t + 1e-9:
                break
            land = sol.landing
        skip = 0 if sol is None else int(round((t_cur - sol.duration) / dt))
        if skip * dt < 0.02 - 1e-9:
            return target, 0
        if t_max < t_cur and sol.duration >= t_hi - 1e-6 and self._reach_cut != idx:  # the reach set the time
            self.reach_cuts, self._reach_cut = self.reach_cuts + 1, idx
        moved = Footstep(fs0.side, float(sol.landing[0]), float(sol.landing[1]), fs0.yaw)
        return self.adjuster.landing(moved, stance, np.zeros(2)), skip

    _legs = None  # wbc.gait.stance_reach.stance_legs of the robot when reach_ratio is set (WalkScenario.setup)
    _leg_v = _trailing_hold = None  # _release_trailing's, set at its first call
    #: (t s, side, the leg's largest joint speed / its limit) of each sole :meth:`_release_trailing` let go
    trailing_releases: list | tuple = ()
    _reach_cut = -1  # the last swing whose time the stance leg's reach cut (_step_timing's count of reach_cuts)
    _impact = None  # the controller's ImpactSpeedBounds (_impact_setup), or None
    #: weight of the post-impact rates past their bound (ImpactSpeedExcess, (rad/s²)⁻²); 0: those rows free. At 10
    #: (the default) push campaign 9409 survives 848/1000 against 812 at 0, with 57 falls against 53
    #: (benchmarks/records/68 and 71)
    impact_excess_weight = 10.0

    def _impact_setup(self, controller, robot) -> None:
        """With ``impact_window`` > 0 and an ID controller with joint speed bounds: add
        :class:`~wbc.constraints.impact.ImpactSpeedBounds` (flat sole and its corners) to its QP, with the margins
        and the horizon of its joint speed bounds, and their :class:`~wbc.constraints.impact.ImpactSpeedExcess` as a
        task of weight :attr:`impact_excess_weight` (Kp 0, Kd 1/(h dt)) — or take the ones already there (a capture
        step's walk on the same controller; with ``impact_window`` 0 their rows are set free and stay free)."""
        qp = getattr(controller, "qp", None)
        if qp is None or getattr(qp, "joint_speed_limits", None) is None:
            return
        for con in qp.extra_constraints:
            if isinstance(con, ImpactSpeedBounds):
                con.expect(None)  # (an earlier walk's landing is not this one's)
                self._impact = con if self.impact_window > 0 else None
                return
        if self.impact_window <= 0:
            return
        js = qp.joint_speed_limits
        lim = np.asarray(robot.model.velocityLimit, dtype=float)[6:]
        margin = np.zeros(robot.model.nv - 6)
        margin[js.indices - 6] = 1.0 - js.vmax / lim[js.indices - 6]
        self._impact = ImpactSpeedBounds(robot, {"left": robot.left_sole, "right": robot.right_sole},
                                         np.clip(margin, 0.0, 0.99), js.horizon, corners=True)
        qp.add_constraint(self._impact)
        if self.impact_excess_weight > 0:
            qp.add_task(AccelerationReference(ImpactSpeedExcess(self._impact, self.impact_excess_weight), kp=0.0,
                                              kd=1.0 / (js.horizon * controller.dt), weight=self.impact_excess_weight))

    def _impact_expect(self, tp: float) -> None:
        """Tell the impact bounds (:meth:`_impact_setup`) which sole may touch down at plan time ``tp`` (s): a sole
        in swing within ``impact_window`` s of its planned touch-down or past it, the other sole down (stance or
        loading) or not; else none."""
        c = self._impact
        if c is None:
            return
        landing = None
        for side, (_, _, k_td, _) in self._active.items():
            if self.switcher.phase(side) == "swing" and tp >= k_td * self.dt - self.impact_window:
                landing = side
        if landing is None:
            c.expect(None)
            return
        other = "right" if landing == "left" else "left"
        c.expect(landing, (other,) if self.switcher.phase(other) in ("stance", "loading") else ())

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

    def _swing_landed(self, side: str, t: float, k: int) -> None:
        """The swing of ``side`` touched down (its entry leaves ``_active``) at time ``t`` (s), plan sample ``k``.
        When that swing had been stretched (``_relift``) and its re-lift has not yet reached its peak (``k`` in the
        first half of the stretched rest), the sole never rose off the floor and lands where it was, not at the
        stretched landing: the plan before the stretch (``_pre_stretch``: the remaining footsteps, soles, DCM and
        ZMP references, the plan clock) is restored, and the stretch undone in ``timing_changes`` (its length again,
        with the opposite sign).

        The stretch moves every remaining footstep and the DCM plan by the stretched landing's offset (0.2–0.3 m
        on a push late in a swing); with the sole down where it was, the next steps were planned from a footstep
        it never reached, and the other foot's swing then started with the DCM beyond the landed sole, which it
        cannot cross to capture (record 52)."""
        del self._active[side]
        self._landed = side
        relift, pre = self._relift, self._pre_stretch
        if relift is None or pre is None or relift[0] != side or 2 * k >= relift[1] + relift[2]:
            return
        self._rp, self._rp_k0, swings, soles, dcm, zmp, shift, self._base, n_adj = pre
        self.swings[:] = swings
        for s, (P, V, A) in soles.items():
            self.poses[s][:], self.vels[s][:], self.acc[s][:] = P, V, A
        self.ref_dcm[:], self.ref_zmp[:] = dcm, zmp
        self.timing_changes.append((float(t), side, (shift - self._shift) * self.dt))
        self._shift = shift
        del self.adjustments[n_adj:]
        self._relift = self._pre_stretch = None

    def _release_next_swing(self, t: float, tp: float, k: int, q: np.ndarray, controller, v: np.ndarray) -> None:
        """Start the ramp-out of the next swing (``_next``) at plan time ``tp`` (s; plan sample ``k``, configuration
        ``q``) so that its foot is released at the planned lift-off, never while the other foot is not yet down (a
        late touch-down: the step waits) nor while ``hold_next_swing``; on terrain or blind, the ground height its
        touch-down is detected above and the sole's measured − planned height at its release (``_relative_ground``).
        First, a trailing sole whose leg cannot follow is let go at once (:meth:`_release_trailing`; ``controller``,
        its state's ``v``)."""
        self._release_trailing(t, controller, v)
        if self._next < len(self.swings):
            side, k_lift, k_td, fs = self.swings[self._next]
            other = "right" if side == "left" else "left"
            # Never release a foot while the other one is not yet down (late touch-down: the step waits). A sole the
            # contact events released (a contact loss) swings from where they hold it, with no ramp-out.
            if tp >= k_lift * self.dt - self.ramp_time - 1e-9 and self.switcher.phase(other) in ("stance", "loading") \
                    and not self.hold_next_swing:
                if self.switcher.phase(side) in ("stance", "loading"):
                    self.switcher.unload(side, t)
                elif self._trailing_hold and self._trailing_hold[side] is not None:  # (_release_trailing's)
                    self._trailing_hold[side] = None
                elif not self._lost_sole_swings(side):
                    return
                if self.terrain_walk is not None or self.blind:
                    # touch-down is detected above the foothold's ground (blind: the planned flat ground)
                    if self.terrain_walk is not None:
                        self._land_z[side] = float(self.terrain_walk.footholds[fs_index(self.plan, k_lift)][2, 3])
                    self.switcher.ground_height[side] = self._land_z[side]
                    pin.framesForwardKinematics(self._model, self._gdata, q)
                    self._dz_lift[side] = float(self._gdata.oMf[self._fid[side]].translation[2]) \
                        - float(self.poses[side][k][2, 3])
                    self._dz_stance[side] = self._dz_lift[side]
                self._t_unload[side] = t
                self.swing_starts.append((float(t), side))
                self._active[side] = self.swings[self._next]
                self._next += 1

    def _release_trailing(self, t: float, controller, v: np.ndarray) -> None:
        """The trailing sole let go when its leg cannot follow the body (``trailing_release`` ρ; None: off).

        In a double support after the other sole's touch-down, the sole of the next swing (not yet unloading) is
        released at once (:meth:`~wbc.dynamics.contact_switching.ContactSwitcher.release`: no ramp-out) when a joint
        of its leg moves at ρ or more of its URDF speed limit in ``v`` (nv,) (the controller's state, rad/s). It is
        then held where it was released, flat, at its yaw (a frame task, not a contact), until its planned swing starts
        from there (:meth:`_release_next_swing`).

        Why: after a long or fast step (a capture step) the body moves away from the trailing sole, and that leg
        stretches at the speed its knee or hip allows. Held as a contact (its sole's acceleration 0), the trailing
        leg's joint speed bounds then bound the base's motion in the QP: its best answer lets the body fall (push
        campaign 9420, trial 527: 126–179 N planned in all in 1.900–1.912 s while the plant's soles carry 363–802 N),
        and the landed leg, driven by torques for a falling body, folds past its speed limit (the knee at 1.03×).
        Released, the foot rolls off the floor as a foot does, and the landed leg carries the weight
        (benchmarks/records/85)."""
        if self._leg_v is None:  # the first tick: each leg's velocity indices (nv) and speed limits (rad/s)
            vmax = np.asarray(self.robot.model.velocityLimit, dtype=float)
            self._leg_v = {s: 6 + np.flatnonzero(leg_joints(self.robot, (s,))) for s in ("left", "right")}
            self._leg_vmax = {s: vmax[i] for s, i in self._leg_v.items()}
            self._trailing_hold = {"left": None, "right": None}  # the pose a sole released here is held at
            self.trailing_releases = []
        if self.trailing_release is None or self._next >= len(self.swings):
            return
        sw = self.switcher
        for s in ("left", "right"):  # a released sole held until its swing starts (or it is set down)
            held = self._trailing_hold[s]
            if held is not None:
                if sw.phase(s) != "swing" or s in self._active:
                    self._trailing_hold[s] = None
                else:
                    controller.set_foot_reference(s, held, _ZERO6, _ZERO6)
        side = self.swings[self._next][0]
        other = "right" if side == "left" else "left"
        down, own = sw.touchdown_time[other], sw.touchdown_time[side]
        if self._trailing_hold[side] is not None or side in self._active or sw.phase(side) != "stance" \
                or sw.phase(other) not in ("stance", "loading") or down is None or (own is not None and own > down):
            return
        ratio = float(np.max(np.abs(v[self._leg_v[side]]) / self._leg_vmax[side]))
        if ratio < self.trailing_release:
            return
        sw.release(side, t)
        M = self._data.oMf[self._fid[side]]
        yaw = math.atan2(M.rotation[1, 0], M.rotation[0, 0])
        held = pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, yaw), M.translation.copy())
        self._trailing_hold[side] = held
        controller.set_foot_reference(side, held, _ZERO6, _ZERO6)
        self.trailing_releases.append((float(t), side, ratio))

    def _hurry_double_support(self, t: float, k: int, c, cd, xi: np.ndarray) -> None:
        """At the touch-down of a swing (``_landed``) and at every later tick of the double support, with timing
        adaptation on: when the measured DCM ``xi`` (2,) m lies outside both soles' hull shrunk by the CoP margin,
        no CoP of the double support stops its divergence (``ξ̇ = ω (ξ − p)``, Englsberger 2015 eq. 6): the rest
        of the double support only lets it grow, and the next step is what can capture it (a lateral push towards
        the stance leg: two quick steps, the first landing foot cannot cross). The plan clock then jumps
        (``_shift``) to the next swing's ramp-out, which starts now: the double support ends ``ramp_time`` later.
        A push late in a swing moves the DCM out only during the double support after its touch-down, hence the
        check at every tick of it (record 72). The plan is re-planned from the measured CoM state at the new
        sample (:meth:`wbc.gait.WalkPlan.replan`, footsteps unchanged), and the jump is logged in
        ``timing_changes``."""
        if self._next >= len(self.swings):
            return
        side, k_lift, _, _ = self.swings[self._next]
        r = self.robot
        m = self.cop_margin
        soles = np.vstack([projected_sole_corners(self._data.oMf[self._fid[s]], r.sole_length - 2 * m,
                                                  r.sole_width - 2 * m) for s in ("left", "right")])
        if polygon_margin(np.asarray(xi, float), convex_hull(soles)) >= 0.0:
            return
        n = k_lift - int(round(self.ramp_time / self.dt)) - k
        if n <= 0:
            return
        k1 = k + n
        try:
            rp = self._rp.replan(k1 - self._rp_k0, np.asarray(c), np.asarray(cd), check_start=False)
        except GaitError:
            self.replan_failures += 1
            return
        self._adopt_plan(rp, k1)
        self._shift += n
        self.timing_changes.append((float(t), side, n * self.dt))

    def _capturable(self, xi: np.ndarray, stance: str) -> bool:
        """True when the measured DCM lies inside the ``stance`` sole shrunk by the CoP margin: with the CoP at the
        DCM the DCM stays put (``ξ̇ = ω (ξ − p)``, Englsberger 2015 eq. 6) — the state is 0-step capturable (Pratt et
        al. 2006; Koolen et al., IJRR 31(9), 2012) and landing sooner gains nothing, while the swing, hurried,
        may land short of its target (after a wide lateral step put the stance sole under the DCM)."""
        r = self.robot
        sole = projected_sole_corners(self._data.oMf[self._fid[stance]], r.sole_length - 2 * self.cop_margin,
                                      r.sole_width - 2 * self.cop_margin)
        return polygon_margin(np.asarray(xi, float), convex_hull(sole)) >= 0.0

    def _add_relift(self, side: str, k_td: int, kk: int, pos: np.ndarray, vel: np.ndarray, acc: np.ndarray) -> None:
        """When the swing of ``side`` landing at plan sample ``k_td`` was stretched (``_relift``: side, plan samples
        ``k1`` of the stretch and ``k_td`` of the touch-down, height ``h`` m), add its re-lift at plan sample ``kk``
        to its reference ``pos`` (3,) m, ``vel`` (6,) m/s and ``acc`` (6,) m/s² (world; in place, vertical rows
        only); else nothing.

        A stretch comes in the last ``stretch_window`` s of a swing, when the sole is in its final descent;
        :meth:`wbc.gait.WalkPlan.replan` stretches the rest of that descent in time and blends the landing's move
        in, so the sole would travel the added distance a few tenths of a millimetre over the floor, where its heel
        or toe catches (the estimated sole height is about a millimetre off). Walking push 9813 (record 48): 0.29 m
        at up to 1.9 m/s; the heel caught, the sole tripped onto its toe and was set down there, 0.24 m short, and
        the next step could not catch the DCM. The stretched rest is therefore a swing of its own: the clearance
        bump of :mod:`wbc.gait.swing`, ``h · 64 s³ (1 − s)³`` with ``s = (kk − k1) / (k_td − k1)``, and ``h``
        the walk's step height scaled by the rest's share of the planned single support (the nominal swing's
        peak vertical speed, ``h / T``). A blind walk's too: its stretched rest re-lifted, then descending until a
        load confirms the ground (its late touch-down); records 48 and 55 measure both ways on blind rough
        ground."""
        relift = self._relift
        if relift is None or relift[0] != side or relift[2] != k_td:
            return
        _, k1, _, h = relift
        n = k_td - k1
        s = min(max((kk - k1) / n, 0.0), 1.0)
        T = n * self.dt
        u = s * (1.0 - s)
        pos[2] += h * 64.0 * u * u * u
        vel[2] += h * 192.0 * u * u * (1.0 - 2.0 * s) / T
        acc[2] += h * 384.0 * u * (1.0 - 5.0 * s + 5.0 * s * s) / (T * T)


def fs_index(plan, k_lift: int) -> int:
    """Index in ``plan.footsteps`` of the step whose swing lifts off at sample ``k_lift``."""
    return next(ph.step for ph in plan.phases if ph.step >= 0 and ph.first == k_lift)
