"""The executed-ZMP and DCM constraints of the kinematic QP against independent computations with Pinocchio."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wbc.configuration import Configuration
from wbc.constraints.zmp import DcmPolygonConstraint, ExecutedZmpConstraint
from wbc.exceptions import InvalidInputError


def _zmp_oracle(model, q0, v0, q1, v1, q2, ground_z, dt):
    """Multi-body ZMP at state 1 of the sequence q0 -v0-> q1 -v1-> q2: c̈ by central differences of Pinocchio's
    centerOfMass, L̇ by the difference of computeCentroidalMomentum (angular) over ticks 0 and 1."""
    data = model.createData()
    c = [pin.centerOfMass(model, data, q).copy() for q in (q0, q1, q2)]
    L0 = pin.computeCentroidalMomentum(model, data, q0, v0).angular.copy()
    L1 = pin.computeCentroidalMomentum(model, data, q1, v1).angular.copy()
    acc = (c[2] - 2 * c[1] + c[0]) / dt**2
    ldot = (L1 - L0) / dt
    mass = sum(i.mass for i in model.inertias)
    h = c[1][2] - ground_z
    fz = mass * (acc[2] + 9.81)
    zmp = np.array([c[1][0] - (mass * h * acc[0] + ldot[1]) / fz, c[1][1] - (mass * h * acc[1] - ldot[0]) / fz])
    return zmp, acc, h


@pytest.mark.parametrize("name", ["talos", "g1"])
def test_zmp_rows_are_the_executed_zmp_distance(robots, name):
    """Row i's slack u_i − C_i v equals dt (g + c̈_z) / h × (b_i − n_i·p), p the multi-body ZMP of the motion
    that v produces (oracle above), up to the one-tick-old second-order CoM term the row assumes (measured 0.18 mm on G1 for these 0.1 rad/s motions)."""
    robot = robots(name)
    model, dt = robot.model, 0.002
    config = Configuration(robot)
    zmp = ExecutedZmpConstraint(robot, margin=0.002)
    lf, rf = (config.data.oMf[robot.frame_id(f)].copy() for f in (robot.left_sole, robot.right_sole))
    zmp.set_support([lf, rf])
    rng = np.random.default_rng(0)
    v0 = np.zeros(model.nv)
    v0[6:] = 0.1 * rng.standard_normal(model.nv - 6)
    v1 = v0 + 0.05 * np.r_[np.zeros(6), rng.standard_normal(model.nv - 6)]  # a different command next tick
    C, l, u = zmp.compute(config, dt)
    assert np.all(np.isinf(u))  # no previous tick yet: inactive
    zmp.set_previous(v0)
    q0 = config.q.copy()
    config.step(v0, dt)
    q1 = config.q.copy()
    # the row assumes this tick's second-order CoM term equals the last one: take one more equal step first
    zmp.compute(config, dt)
    zmp.set_previous(v0)
    config.step(v0, dt)
    q0, q1 = q1, config.q.copy()
    C, l, u = (x.copy() for x in zmp.compute(config, dt))
    q2 = pin.integrate(model, q1, v1 * dt)
    p, acc, h = _zmp_oracle(model, q0, v0, q1, v1, q2, zmp.ground_z, dt)
    k = len(zmp.offsets)
    predicted = (u[:k] - C[:k] @ v1) * h / (dt * (9.81 + acc[2]))
    actual = zmp.offsets - zmp.normals @ p
    np.testing.assert_allclose(predicted, actual, atol=3e-4)
    assert actual.min() < 0.0  # this random motion would not be balanced: the rows are not vacuous
    # normal-force row: −c̈_z ≤ (1 − ρ) g
    assert (u[-1] - C[-1] @ v1) == pytest.approx(dt * ((1 - 0.5) * 9.81 + acc[2]), abs=1e-3 * dt * 9.81)


def test_undo_previous_takes_back_exactly_one_command(robots):
    """A tick solved twice (StanceController's retry): after set_previous(v1), undo_previous(), set_previous(v2) the
    next tick's rows are those of a constraint that only ever saw v2 (bitwise); a second undo is a no-op; the same
    with a state() snapshot taken before the tick and restore()."""
    robot = robots("talos")
    dt = 0.002
    rng = np.random.default_rng(5)
    v0, v1, v2 = (np.r_[np.zeros(6), 0.1 * rng.standard_normal(robot.nv - 6)] for _ in range(3))
    rows = []
    for retry in (None, "undo", "restore"):
        config = Configuration(robot)
        zmp = ExecutedZmpConstraint(robot)
        zmp.set_support([config.data.oMf[robot.frame_id(f)] for f in (robot.left_sole, robot.right_sole)])
        zmp.compute(config, dt)
        zmp.set_previous(v0)
        config.step(v0, dt)
        snapshot = zmp.state()
        zmp.compute(config, dt)
        if retry == "undo":
            zmp.set_previous(v1)
            zmp.undo_previous()
            zmp.undo_previous()
        elif retry == "restore":
            zmp.set_previous(v1)
            zmp.restore(snapshot)
        zmp.set_previous(v2)
        config.step(v2, dt)
        rows.append([x.copy() for x in zmp.compute(config, dt)])
    for other in rows[1:]:
        for a, b in zip(rows[0], other):
            np.testing.assert_array_equal(a, b)
    assert np.isfinite(rows[0][2][:-1]).sum() >= 4  # the rows are active (a previous tick is known)


def test_support_half_planes_match_the_geometry_module(robots):
    """set_support's plain-float half-planes (one sole, two soles, turned and shifted) are those of
    wbc.geometry.support_polygon + com_polygon.halfplanes shrunk by the margin; ground height = mean sole z."""
    from wbc.constraints.com_polygon import halfplanes
    from wbc.geometry import support_polygon

    robot = robots("talos")
    zmp = ExecutedZmpConstraint(robot, margin=0.003)
    rng = np.random.default_rng(2)
    for _ in range(20):
        poses = [pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, rng.uniform(-1, 1)), np.r_[rng.uniform(-1, 1, 2), z])
                 for z in rng.uniform(-0.01, 0.01, int(rng.integers(1, 3)))]
        if len(poses) == 2:
            poses[1].translation = poses[0].translation + np.r_[rng.uniform(-0.3, 0.3), 0.25, 0.0]
        zmp.set_support(poses)
        normals, offsets = halfplanes(support_polygon(poses, robot.sole_length, robot.sole_width))
        np.testing.assert_allclose(zmp.normals, normals, rtol=0, atol=1e-15)
        np.testing.assert_allclose(zmp.offsets, offsets - 0.003, rtol=0, atol=1e-15)
        assert zmp.ground_z == pytest.approx(np.mean([p.translation[2] for p in poses]), abs=1e-15)


def test_dcm_rows(robots):
    """n_i·J_com,xy v ≤ ω s_i: at the bound, the capture point c + ċ/ω lands on the shrunk edge."""
    robot = robots("talos")
    config = Configuration(robot)
    dcm = DcmPolygonConstraint(robot, margin=0.01)
    dcm.set_support([config.data.oMf[robot.frame_id(f)] for f in (robot.left_sole, robot.right_sole)])
    C, l, u = dcm.compute(config, 0.002)
    k = len(dcm.offsets)
    omega = np.sqrt(9.81 / (config.com[2] - dcm.ground_z))
    slack = dcm.offsets - dcm.margin - dcm.normals @ config.com[:2]
    np.testing.assert_allclose(u[:k], omega * slack)
    np.testing.assert_allclose(C[:k], dcm.normals @ config.com_jacobian[:2])


def test_bad_inputs(robots):
    robot = robots("humanoid15")
    for kw in ({"margin": -0.001}, {"margin": float("nan")}, {"min_normal_ratio": 1.0}, {"min_normal_ratio": -0.1},
               {"gravity": 0.0}, {"max_soles": 0}):
        with pytest.raises(InvalidInputError):
            ExecutedZmpConstraint(robot, **kw)
    with pytest.raises(InvalidInputError):
        DcmPolygonConstraint(robot, gravity=-9.81)
    zmp = ExecutedZmpConstraint(robot, margin=0.2)
    config = Configuration(robot)
    with pytest.raises(InvalidInputError, match="too small for margin"):
        zmp.set_support([config.data.oMf[robot.frame_id(robot.left_sole)]])


def test_braking_bounds(robots):
    """ub dt + ub²/(2 a) = q_max − q (move one tick, then brake at a), symmetric for the lower limit; 0 at a limit."""
    from wbc.constraints.braking import JointBrakingLimit

    robot = robots("talos")
    config = Configuration(robot)
    brake = JointBrakingLimit(robot, a_max=40.0)
    dt = 0.002
    lb, ub = (x.copy() for x in brake.compute(config, dt))
    q = config.q[brake.idx_q]
    np.testing.assert_allclose(ub * dt + ub**2 / 80.0, brake.q_max - q, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(-lb * dt + lb**2 / 80.0, q - brake.q_min, rtol=1e-9, atol=1e-15)
    at_limit = np.isclose(q, brake.q_max)  # Talos's grippers sit on their upper limit in half_sitting
    assert at_limit.any() and np.all(ub[at_limit] <= 1e-12)
    for bad in (0.0, -1.0, float("inf"), True):
        with pytest.raises(InvalidInputError):
            JointBrakingLimit(robot, a_max=bad)
