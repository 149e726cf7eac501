"""The kinematic controller's clock guard: the tick's CPU time counted as work cuts the stages of a tick (the
strict cascade, the contact correction), and with the class's weight a tick under budget is bitwise the unguarded
one."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import hand_over_posture, standing_controller

DT = 0.002


def test_kinematic_clock_guard_cuts_the_stages_of_a_tick_by_its_cpu_time(robots):
    """Strict levels (a hand target at level 0, the posture at level 1) with a budget of 1 s (4000 counted solves:
    never reached). Without the clock guard the tick solves every level (path 'levels'). With it, and the CPU
    time weighted so that any time at all exceeds the budget (``CLOCK_WEIGHT`` = 1e12), the cascade is not started
    (its least work does not fit beside the time already spent, ``_plan_levels``; before that rule
    it stopped after its first level) nor any contact correction, and the weighted form of the levels answers (one
    QP; its command checked against quadprog in tests/controllers/test_kinematic_weighted_levels.py): ok,
    'levels+budget+weighted', over_budget. Oracles: the soles move ≤ 0.05 mm over the tick by forward kinematics; the
    command is not the cascade's. With the class's weight the 1 s budget is not reached: bitwise the unguarded tick."""
    import pinocchio as pin

    from wbc.exceptions import InvalidInputError

    robot, config, ctrl, (hand, _) = hand_over_posture(robots, budget=1.0)
    assert ctrl.clock_guard is False  # the default: nothing decided by a clock
    full = ctrl.solve(config, DT)
    assert full.ok and full.path == "levels" and not full.over_budget
    _, _, guarded, _ = hand_over_posture(robots, budget=1.0, clock_guard=True)
    same = guarded.solve(config, DT)
    assert same.ok and same.path == "levels" and not same.over_budget
    assert same.v.tobytes() == full.v.tobytes()
    _, _, cutting, _ = hand_over_posture(robots, budget=1.0, clock_guard=True, CLOCK_WEIGHT=1e12)
    cut = cutting.solve(config, DT)
    assert cut.ok and cut.over_budget and cut.path == "levels+budget+weighted", (cut.path, cut.message)
    assert "the cascade of 2 priority levels (with its contact correction, at least 6 counted solves: their " \
           "weighted form's command) skipped" in cut.message
    assert np.linalg.norm(cut.v - full.v) > 1e-6  # not the cascade's command
    model, data = robot.model, robot.model.createData()
    pin.framesForwardKinematics(model, data, pin.integrate(model, config.q, cut.v * DT))
    for frame in (robot.left_sole, robot.right_sole):
        fid = model.getFrameId(frame)
        assert np.linalg.norm(data.oMf[fid].translation - config.frame_placement(fid).translation) <= 5e-5
    for bad in ("yes", 1, None):
        with pytest.raises(InvalidInputError, match="clock_guard"):
            ctrl.clock_guard = bad


def _failing_g1_tick(robots, clock_guard):
    """G1 with both knees 30 mrad past their lower limits (the return-rate ladder runs), a hand target at level 0,
    the posture at level 1 and a hard CoM task 0.3 m up at gain 1e6 (infeasible with the soles held: every tick
    fails), after one warm tick. Returns (model, config, controller)."""
    from wbc.configuration import Configuration
    from wbc.constraints.limits import bounded_joints
    from wbc.tasks import ComTask, FrameTask, PostureTask

    robot = robots("g1")
    model = robot.model
    config = Configuration(robot)
    q = config.q.copy()
    iq, _ = bounded_joints(model)
    knees = [i for i in iq if any("knee" in model.names[j] for j in range(1, model.njoints)
                                  if model.joints[j].idx_q == i)]
    assert len(knees) == 2
    q[knees] = model.lowerPositionLimit[knees] - 0.03
    config.update(q)
    ctrl, _ = standing_controller(robot, config)
    ctrl.clock_guard = clock_guard
    hand = FrameTask(robot, "left_wrist_roll_joint", gain=10.0, orientation_weight=0.0, name="hand")
    target = config.frame_placement(hand.frame_id).copy()
    target.translation += [0.5, 0.5, 0.5]
    hand.set_target(target)
    ctrl.add_task(hand, level=0)
    ctrl.add_task(PostureTask(robot, weight=1.0, name="posture1"), level=1)
    com = ComTask(weight=1.0, name="com_hard")
    com.gain = 1e6
    com.set_target(config.com + [0.0, 0.0, 0.3])
    ctrl.add_task(com, hard=True)
    warm = ctrl.solve(config, DT)  # (first calls: lazy imports and allocations, not the tick's work)
    assert not warm.ok
    config.update(config.integrate(warm.v, DT))
    return model, config, ctrl


@pytest.mark.parametrize("clock_guard", [True, False])
def test_kinematic_clock_guard_bounds_a_failed_tick_on_a_slow_machine(robots, monkeypatch, clock_guard):
    """A failed strict G1 tick (:func:`_failing_g1_tick`) on a machine where each counted QP solve costs three times
    its nominal CPU time (``SOLVE_COST``), simulated on a virtual CPU clock: the clock the tick reads
    (``time.thread_time`` in :mod:`wbc.solvers.base`) advances by 3 × ``SOLVE_COST`` per counted solve and by
    nothing else, so the figure is a count, the same on any machine and load. With the clock guard the tick's
    stages (the return-rate relaxations, the diagnosis, each solve of the safe command) start only when the time
    timed for them in this tick fits before ``STAGE_DEADLINE`` budgets: the tick ends within twice its budget on
    that clock. Without the guard nothing reads the clock and the same tick takes more than twice its budget — the
    control that shows the bound is the guard's doing. Oracles: the virtual clock (a loose bound, twice the budget),
    and each tick is failed with a finite safe command within the joint velocity limits."""
    import wbc.solvers.base as solver_base
    from wbc.controllers.kinematic import KinematicController
    from wbc.solvers.base import TickWork

    model, config, ctrl = _failing_g1_tick(robots, clock_guard)
    clock = [0.0]  # virtual CPU time (s)
    monkeypatch.setattr(solver_base, "thread_time", lambda: clock[0])
    counted = TickWork.solves

    def slow(work, value):  # each counted solve advances the virtual clock by 3 × SOLVE_COST
        extra = round(value - counted.fget(work))
        counted.fset(work, value)
        clock[0] += 3.0 * KinematicController.SOLVE_COST * max(extra, 0)

    monkeypatch.setattr(TickWork, "solves", property(counted.fget, slow))
    spent = []
    for _ in range(3):
        start = clock[0]
        res = ctrl.solve(config, DT)
        spent.append((clock[0] - start) / DT)
        assert not res.ok and res.fallback in ("constraints_only", "contacts_held", "hold"), res.message
        assert np.isfinite(res.v).all() and np.all(np.abs(res.v[6:]) <= model.velocityLimit[6:] + 1e-9)
        config.update(config.integrate(res.v, DT))
    if clock_guard:
        assert max(spent) <= 2.0, (spent, res.path, res.message)
    else:
        assert min(spent) > 2.0, (spent, res.path, res.message)
