"""The post-impact joint speed bounds (wbc.constraints.impact): the rows are Pinocchio's impulse dynamics
(``pin.impulseDynamics``, an inelastic impact on the stacked sole Jacobians, restitution 0) at any velocity, the
post-impact velocity is contact-consistent and the M-orthogonal projection of the pre-impact one, l ≤ C x ≤ u holds
exactly when every bounded joint's post-impact rate (at v + v̇ h dt) is within s q̇_max, the rows are free with no
touch-down expected, and bad input raises typed errors; the excess rows (ImpactSpeedExcess) are the freed rows, and
their least-squares answer brings each freed rate to its bound after the horizon (impulseDynamics again)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wbc.constraints.base import IDContext
from wbc.constraints.impact import ImpactSpeedBounds, ImpactSpeedExcess
from wbc.dynamics import DynamicsState
from wbc.exceptions import InvalidInputError, UnknownFrameError
from wbc.formulations.reference import AccelerationReference

DT = 0.002
#: the rows' post-impact velocity against Pinocchio's impulse dynamics, relative to the largest rate (two
#: factorizations of the same matrices: round-off)
REL_TOL = 1e-9


def _state(robot, seed):
    rng = np.random.default_rng(seed)
    q = robot.q_ref.copy()
    q[7:] += rng.uniform(-0.2, 0.2, robot.model.nq - 7)
    v = rng.normal(0.0, 1.0, robot.model.nv)
    return DynamicsState(robot, q, v), q, v


def _soles(robot):
    return {"left": robot.left_sole, "right": robot.right_sole}


def _write(con, state, dv, nf=0):
    nv = state.v.size
    C, l, u = np.full((con.dim, nv + nf), np.nan), np.full(con.dim, np.nan), np.full(con.dim, np.nan)
    con.write(IDContext(state, DT, nv, np.zeros((nv, 0)), {}), C, l, u)
    return C, l, u


@pytest.mark.parametrize("support", [(), ("right",)])
def test_rows_are_pinocchios_impulse_dynamics(robots, support):
    robot = robots("talos")
    state, q, v = _state(robot, 78)
    con = ImpactSpeedBounds(robot, _soles(robot))
    con.expect("left", support)
    P = con.post_impact_rows(state)
    model, data = robot.model, robot.model.createData()
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    J = np.vstack([pin.getFrameJacobian(model, data, robot.frame_id(getattr(robot, f"{s}_sole")), pin.LOCAL)
                   for s in ("left", *support)])
    v_after = pin.impulseDynamics(model, data, q, v, J, 0.0, 0.0)
    expected = v_after[con.joints]
    assert np.abs(P @ v - expected).max() <= REL_TOL * np.abs(expected).max()
    # the jump is an impulse through the contacts: M (v⁺ − v) = J_cᵀ λ with J_c v⁺ = 0 (Pinocchio's answer, read
    # through the rows: the bounded joints' rates only)
    assert np.abs(J @ v_after).max() <= 1e-9 * np.abs(v).max()


def test_bounds_hold_exactly_when_post_impact_rates_are_within_the_limit(robots):
    robot = robots("talos")
    state, q, v = _state(robot, 79)
    con = ImpactSpeedBounds(robot, _soles(robot), margin=0.1, horizon=4.0)
    con.expect("right", ("left",))
    nv = robot.model.nv
    C, l, u = _write(con, state, None, nf=24)
    assert np.all(C[:, nv:] == 0.0)
    P = con.post_impact_rows(state)
    vmax = 0.9 * robot.model.velocityLimit[con.joints]
    rng = np.random.default_rng(80)
    for _ in range(50):
        dv = rng.normal(0.0, 200.0, nv)
        post = P @ (v + dv * 4.0 * DT)
        inside = np.all(np.abs(post) <= vmax)
        y = C[:, :nv] @ dv
        assert inside == bool(np.all((l <= y) & (y <= u)))


def test_a_row_already_past_its_bound_is_freed(robots):
    """A post-impact rate past s q̇_max at v̇ = 0 (the body's momentum) frees its row (±∞); every other row keeps the
    bound it would have at a slower state (the rows scale with v, the bounds do not)."""
    robot = robots("talos")
    state, q, v = _state(robot, 83)
    con = ImpactSpeedBounds(robot, _soles(robot), margin=0.1, corners=True)
    con.expect("left", ("right",))
    vmax = np.tile(0.9 * robot.model.velocityLimit[con.joints], 5)
    post = con.post_impact_rows(state) @ v
    scale = 1.5 * vmax.max() / np.abs(post).max() * 10.0  # some rows well past their bound
    fast = DynamicsState(robot, q, v * scale)
    _, l, u = _write(con, fast, None)
    past = np.abs(post * scale) > vmax
    assert 0 < past.sum() < past.size
    assert np.all(l[past] == -np.inf) and np.all(u[past] == np.inf)
    assert np.allclose(u[~past], (vmax - post * scale)[~past] / DT) and np.allclose(l[~past], (-vmax - post * scale)[~past] / DT)


def test_rows_free_without_a_touch_down_expected(robots):
    robot = robots("talos")
    state, _, _ = _state(robot, 81)
    con = ImpactSpeedBounds(robot, _soles(robot))
    C, l, u = _write(con, state, None)
    assert np.all(C == 0.0) and np.all(l == -np.inf) and np.all(u == np.inf)
    # the bounded joints: the 12 leg joints of Talos (the chains from the floating base to the soles)
    names = [robot.model.names[j] for j in range(1, robot.model.njoints) if robot.model.joints[j].idx_v in con.joints]
    assert len(names) == 12 and all(n.startswith("leg_") for n in names)


def test_typed_errors(robots):
    robot = robots("talos")
    with pytest.raises(InvalidInputError):
        ImpactSpeedBounds(robot, {})
    with pytest.raises(UnknownFrameError):
        ImpactSpeedBounds(robot, {"left": "no_such_frame"})
    with pytest.raises(InvalidInputError):
        ImpactSpeedBounds(robot, _soles(robot), margin=1.0)
    with pytest.raises(InvalidInputError):
        ImpactSpeedBounds(robot, _soles(robot), horizon=0.5)
    con = ImpactSpeedBounds(robot, _soles(robot))
    with pytest.raises(InvalidInputError):
        con.expect("middle")
    with pytest.raises(InvalidInputError):
        con.expect("left", ("left",))


@pytest.mark.parametrize("support", [(), ("left",)])
def test_corner_rows_are_point_impacts_at_the_sole_corners(robots, support):
    """With ``corners``, rows 12 k … 12 k + 11 (k = 1 … 4) are Pinocchio's impulse dynamics of a point impact at
    corner k − 1 of the landing sole (a frame added at the corner, its linear Jacobian), the other sole down or
    not."""
    robot = robots("talos")
    state, q, v = _state(robot, 82)
    con = ImpactSpeedBounds(robot, _soles(robot), corners=True)
    assert con.dim == 5 * 12
    con.expect("right", support)
    P = con.post_impact_rows(state)
    model = pin.Model(robot.model)
    sole = model.frames[robot.frame_id(robot.right_sole)]
    ids = [model.addFrame(pin.Frame(f"corner{k}", sole.parentJoint, sole.parentFrame,
                                    sole.placement * pin.SE3(np.eye(3), c), pin.FrameType.OP_FRAME))
           for k, c in enumerate(con.corners)]
    data = model.createData()
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    left = [pin.getFrameJacobian(model, data, robot.frame_id(robot.left_sole), pin.LOCAL)] if support else []
    for k, fid in enumerate(ids):
        Jp = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)[:3]
        v_after = pin.impulseDynamics(model, data, q, v, np.vstack([Jp, *left]), 0.0, 0.0)
        rows = P[12 * (k + 1):12 * (k + 2)]
        assert np.abs(rows @ v - v_after[con.joints]).max() <= REL_TOL * np.abs(v_after[con.joints]).max()


def _post_impact(robot, q, v, sides):
    """The bounded joints' rates after an inelastic impact on the soles ``sides`` (Pinocchio's impulseDynamics)."""
    model, data = robot.model, robot.model.createData()
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    J = np.vstack([pin.getFrameJacobian(model, data, robot.frame_id(getattr(robot, f"{s}_sole")), pin.LOCAL)
                   for s in sides])
    return pin.impulseDynamics(model, data, q, v, J, 0.0, 0.0)


def test_excess_rows_are_the_freed_rows_pulled_back_to_their_bound(robots):
    """ImpactSpeedExcess has the rows the bounds free (post-impact rates past s q̇_max at v̇ = 0) and no other; with
    Kp = 0 and Kd = 1/(h dt), the v̇ that meets its rows puts each of those rates at its bound after the horizon."""
    robot = robots("talos")
    _, q, v = _state(robot, 83)
    h = 4.0
    con = ImpactSpeedBounds(robot, _soles(robot), margin=0.1, horizon=h)
    con.expect("left", ("right",))
    joints, vmax = con.joints, 0.9 * robot.model.velocityLimit[con.joints]
    scale = 1.0 / np.median(np.abs(_post_impact(robot, q, v, ("left", "right"))[joints]) / vmax)  # half past
    fast = DynamicsState(robot, q, v * scale)
    post = _post_impact(robot, q, v * scale, ("left", "right"))[joints]
    past = np.abs(post) > vmax
    assert 0 < past.sum() < past.size
    _, l, u = _write(con, fast, None)
    assert np.array_equal(np.isinf(u), past)  # (the rows the bounds free)
    task = ImpactSpeedExcess(con, weight=2.0)
    J, r = AccelerationReference(task, kp=0.0, kd=1.0 / (h * DT)).compute(fast)
    assert np.array_equal(task.past, past)
    assert np.all(J[~past] == 0.0) and np.all(r[~past] == 0.0)
    dv = np.linalg.lstsq(J[past], r[past], rcond=None)[0]
    after = _post_impact(robot, q, v * scale + dv * h * DT, ("left", "right"))[joints]
    assert np.abs(after[past] - np.sign(post[past]) * vmax[past]).max() <= REL_TOL * np.abs(post).max()
    con.expect(None)
    J, r = AccelerationReference(task, kp=0.0, kd=1.0 / (h * DT)).compute(fast)
    assert np.all(J == 0.0) and np.all(r == 0.0) and not task.past.any()


def test_excess_typed_errors(robots):
    robot = robots("talos")
    with pytest.raises(InvalidInputError):
        ImpactSpeedExcess(object())
    con = ImpactSpeedBounds(robot, _soles(robot))
    with pytest.raises(InvalidInputError):
        ImpactSpeedExcess(con, weight=-1.0)
    task = ImpactSpeedExcess(con, weight=1.0)
    with pytest.raises(InvalidInputError):
        task.weight = np.full(con.dim + 1, 1.0)
