"""Joint position and velocity limits (wbc.constraints.limits): recovery from outside the range, the priority of the boxes, the compiled box intersection against the generic clip."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import CATALOG, random_configuration, standing_controller
from wbc.configuration import Configuration
from wbc.constraints import JointAccelerationLimit, JointPositionLimit, JointVelocityLimit
from wbc.constraints.limits import bounded_joints
from wbc.controllers.kinematic import KinematicController
from wbc.exceptions import InvalidInputError

DT = 0.002


KNEE = {"talos": "leg_left_4_joint", "g1": "left_knee_joint", "humanoid15": "left_knee"}


ELBOW = {"talos": "arm_right_4_joint", "g1": "right_elbow_joint", "humanoid15": "right_elbow"}


@pytest.mark.parametrize("name", CATALOG)
@pytest.mark.parametrize("variant", ["limits", "slow+acc"])
def test_joint_limit_recovery(robots, name, variant):
    """A knee and an elbow start 0.05 rad outside a limit: both are back inside within 0.5 s and stay inside, every
    tick solves, no NaN. Variant "slow+acc": velocity limits scaled by 0.5 and acceleration limits 20 rad/s² —
    the position recovery yields to the first and wins over the second, so the box never empties."""
    robot = robots(name)
    model = robot.model
    idx_q, _ = bounded_joints(model)
    q = robot.q_ref.copy()
    picked = []
    for pattern in (KNEE[name], ELBOW[name]):  # each pushed 0.05 rad past its limit nearest to q_ref
        iq = model.joints[robot.joint_id(pattern)].idx_q
        assert iq in idx_q
        lo, hi = model.lowerPositionLimit[iq], model.upperPositionLimit[iq]
        side = "upper" if hi - q[iq] < q[iq] - lo else "lower"
        q[iq] = hi + 0.05 if side == "upper" else lo - 0.05
        picked.append((pattern, iq, side))
    config = Configuration(robot, q)
    extra = [JointAccelerationLimit(robot, a_max=20.0)] if variant == "slow+acc" else []
    ctrl, _ = standing_controller(robot, config, *extra, vel_scale=0.5 if variant == "slow+acc" else 1.0)
    inside_at = {}
    relaxed = 0
    for k in range(int(0.6 / DT)):
        res = ctrl.solve(config, DT)
        assert res.ok, res.message
        relaxed += bool(res.relaxed)
        assert np.isfinite(res.v).all()
        config.update(config.integrate(res.v, DT))
        for jname, iq, _ in picked:
            ok = model.lowerPositionLimit[iq] <= config.q[iq] <= model.upperPositionLimit[iq]
            if ok:
                inside_at.setdefault(jname, (k + 1) * DT)
            else:
                assert jname not in inside_at, f"{jname} left its range again at t = {(k + 1) * DT:.3f} s"
    print(f"\n{name} {variant}: back inside after " + ", ".join(f"{j} {t * 1e3:.0f} ms" for j, t in inside_at.items())
          + f"; acceleration limits relaxed on {relaxed} ticks")
    assert set(inside_at) == {j for j, _, _ in picked}
    assert max(inside_at.values()) <= 0.5


def test_box_priority_yields_instead_of_emptying(robots):
    """Position recovery (priority 1) clipped into the scaled velocity box (0); acceleration limits (2) clipped
    into both: lb ≤ ub everywhere, the bounds are the documented ones."""
    robot = robots("humanoid15")
    model = robot.model
    idx_q, idx_v = bounded_joints(model)
    q = robot.q_ref.copy()
    q[idx_q[0]] = model.upperPositionLimit[idx_q[0]] + 0.05
    config = Configuration(robot, q)
    acc = JointAccelerationLimit(robot, a_max=10.0)
    acc.set_previous(np.zeros(robot.nv))
    vel = JointVelocityLimit(robot, scale=0.5)
    ctrl = KinematicController(robot, [], [acc, JointPositionLimit(robot), vel])
    *_, lb, ub = ctrl.assemble(config, DT)
    assert np.all(lb <= ub)
    j = idx_v[0]
    # recovery wants v ≤ −v_max (capped at the full limit); the velocity box allows −0.5 v_max; the acceleration
    # box [−0.02, 0.02] is clipped onto that bound: v = −0.5 v_max exactly
    assert lb[j] == ub[j] == pytest.approx(-0.5 * model.velocityLimit[j])
    others = np.setdiff1d(np.arange(6, robot.nv), [j])
    np.testing.assert_allclose(ub[others], np.minimum(10.0 * DT, 0.5 * model.velocityLimit[others]))


@pytest.mark.parametrize("name", CATALOG)
def test_compiled_box_intersections_match_the_generic_clip(robots, name):
    """The compiled intersect_into of the acceleration and braking limits give the numbers of the generic
    BoxConstraint.intersect_into (compute, then the clip into the running box), bit for bit, on random running boxes
    (some emptying the box, some infinite) and random configurations and previous commands; their compute buffers
    hold the box's own bounds."""
    from wbc.constraints.base import BoxConstraint
    from wbc.constraints.braking import JointBrakingLimit

    robot = robots(name)
    rng = np.random.default_rng(11)
    nv = robot.nv
    boxes = [JointAccelerationLimit(robot, a_max=rng.uniform(5.0, 80.0, nv - 6)), JointBrakingLimit(robot, a_max=40.0)]
    for trial in range(20):
        config = Configuration(robot, random_configuration(robot, rng, spread=0.6 if trial % 2 else 0.05))
        boxes[0].set_previous(rng.uniform(-3.0, 3.0, nv))
        lb0 = rng.uniform(-4.0, 1.0, nv)
        ub0 = lb0 + rng.uniform(0.0, 5.0, nv)
        lb0[rng.random(nv) < 0.2], ub0[rng.random(nv) < 0.2] = -np.inf, np.inf
        for box in boxes:
            lb, ub = lb0.copy(), ub0.copy()
            box.intersect_into(config, 0.002, lb, ub)
            own_lb, own_ub = box._lb.copy(), box._ub.copy()
            ref_lb, ref_ub = lb0.copy(), ub0.copy()
            BoxConstraint.intersect_into(box, config, 0.002, ref_lb, ref_ub)
            assert np.array_equal(lb, ref_lb) and np.array_equal(ub, ref_ub)
            lo, hi = box.compute(config, 0.002)
            assert np.array_equal(own_lb, lo) and np.array_equal(own_ub, hi)


def test_position_limit_assignment_reaches_the_compiled_bounds(robots):
    """JointPositionLimit.q_min / q_max / v_max, assigned or changed in place after construction, are what the
    compiled intersect_into and compute use: bounds equal a numpy reference written here, lb = min((q_min − q)/dt,
    v_max), ub = max((q_max − q)/dt, −v_max) clipped into the running box; bad assignments raise."""
    robot = robots("talos")
    lim = JointPositionLimit(robot)
    rng = np.random.default_rng(3)
    config = Configuration(robot, random_configuration(robot, rng, spread=0.3))
    q = config.q[lim.idx_q]
    lim.q_min = q - rng.uniform(-0.01, 0.05, lim.dim)  # some joints outside their new range
    lim.q_max = np.maximum(lim.q_min, q + rng.uniform(-0.01, 0.05, lim.dim))
    lim.v_max = rng.uniform(0.5, 3.0, lim.dim)
    lim.v_max[:3] = 7.0  # in place
    dt = 0.002
    lo = np.minimum((lim.q_min - q) / dt, lim.v_max)
    hi = np.maximum((lim.q_max - q) / dt, -lim.v_max)
    got_lo, got_hi = lim.compute(config, dt)
    assert np.array_equal(got_lo, lo) and np.array_equal(got_hi, hi)
    lb, ub = np.full(robot.nv, -np.inf), np.full(robot.nv, np.inf)
    lim.intersect_into(config, dt, lb, ub)
    assert np.array_equal(lb[lim.indices], lo) and np.array_equal(ub[lim.indices], hi)
    with pytest.raises(InvalidInputError, match="q_min"):
        lim.q_min = np.zeros(3)
    with pytest.raises(InvalidInputError, match="q_min must be ≤ q_max"):
        lim.q_max = lim.q_min - 1.0
    with pytest.raises(InvalidInputError, match="v_max"):
        lim.v_max = np.zeros(lim.dim)
    with pytest.raises(InvalidInputError):
        lim.q_min = np.full(lim.dim, np.nan)
