"""The bound on a frame origin's linear acceleration (wbc.constraints.frame_acceleration): its rows give Pinocchio's
classical acceleration of the frame (``forwardKinematics(q, v, v̇)`` then ``getFrameClassicalAcceleration``, a pass
that the rows' own Jacobian and drift do not share) and the central finite difference of the origin's world velocity
along a path with velocity v and acceleration v̇, at any x = [v̇; f]; l ≤ C x ≤ u holds exactly when |p̈| ≤ a_max;
added to a Talos InverseDynamicsController reaching with the right hand, it binds, its ticks stay on the compiled
route (``path`` is ``kernel``), and the compiled answer is quadprog's optimum of the QP that ``build`` assembles."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from conftest import assert_id_command_is_the_qp_optimum, id_ticks_from_standing, written_id_rows
from wbc.constraints import FrameAccelerationBound
from wbc.dynamics import AccelerationReference, DynamicsState, InverseDynamicsController, InverseDynamicsQP, SoleContact
from wbc.exceptions import InvalidInputError, UnknownFrameError
from wbc.tasks import PositionTask, PostureTask

DT = 0.002
LIMIT = np.array([3.0, 2.5, 3.0])  # m/s², world x, y, z
#: the rows against Pinocchio's p̈, relative to the largest p̈ (round-off of two kinematic passes)
ROW_TOL = 1e-9
#: the rows against the central finite difference (step FD_STEP s: truncation O(h²) and round-off O(ε/h))
FD_STEP = 1e-5
FD_TOL = 1e-7
#: the compiled answer against quadprog's on the same QP (rad/s², N), relative: both are exact active-set solvers
X_TOL = 1e-6


def _classical_acceleration(robot, frame_id, q, v, dv) -> np.ndarray:
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q, v, dv)
    pin.updateFramePlacements(robot.model, data)
    return pin.getFrameClassicalAcceleration(robot.model, data, frame_id, pin.LOCAL_WORLD_ALIGNED).linear.copy()


def _origin_velocity(robot, frame_id, q, v) -> np.ndarray:
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q, v)
    pin.updateFramePlacements(robot.model, data)
    return pin.getFrameVelocity(robot.model, data, frame_id, pin.LOCAL_WORLD_ALIGNED).linear.copy()


def _finite_difference(robot, frame_id, q, v, dv) -> np.ndarray:
    """d/dt ṗ at t = 0 along q(t) = q ⊕ (t v + ½ t² v̇), whose velocity is v + t v̇ up to an even O(t²) term (the
    Lie bracket of the two): central difference of the origin's world velocity, O(h²)."""
    h = FD_STEP
    ends = [_origin_velocity(robot, frame_id, pin.integrate(robot.model, q, s * h * v + 0.5 * h * h * dv),
                             v + s * h * dv) for s in (1.0, -1.0)]
    return (ends[0] - ends[1]) / (2 * h)


@pytest.mark.parametrize("frame", ["right_hand", "left_sole"])
def test_rows_are_the_frames_classical_acceleration_against_the_limit(robots, frame):
    robot = robots("talos")
    frame_name = getattr(robot, frame)
    rng = np.random.default_rng(72)
    nf = 24
    con = FrameAccelerationBound(robot, frame_name, LIMIT)
    fid = con.frame_id
    checked = {True: 0, False: 0}
    for q, v, C, l, u in written_id_rows(robot, con, rng, DT, nf=nf):
        for scale in (0.01, 0.3, 30.0):  # |p̈| inside the limit, near it, far outside
            dv = scale * rng.standard_normal(robot.nv)
            x = np.concatenate([dv, rng.standard_normal(nf)])
            acc = _classical_acceleration(robot, fid, q, v, dv)
            Cx = C @ x
            size = max(1.0, abs(acc).max())
            np.testing.assert_allclose(Cx - l, acc + LIMIT, rtol=0, atol=ROW_TOL * size)
            np.testing.assert_allclose(u - Cx, LIMIT - acc, rtol=0, atol=ROW_TOL * size)
            np.testing.assert_allclose(Cx - l - LIMIT, _finite_difference(robot, fid, q, v, dv), rtol=0,
                                       atol=FD_TOL * size)
            inside = bool((np.abs(acc) <= LIMIT).all())
            assert bool(((l <= Cx) & (Cx <= u)).all()) == inside
            checked[inside] += 1
    assert checked[True] and checked[False]  # both sides of the bound were met


def _reaching(robot, bound: FrameAccelerationBound | None) -> InverseDynamicsController:
    """Talos on both soles, a stiff position task asking the right hand to move 15 cm forward and 10 cm up (far
    more than the bound's acceleration at the start), a soft posture; the bound added in one line when given."""
    posture = AccelerationReference(PostureTask(robot), kp=100.0, kd=20.0, name="posture")
    hand = AccelerationReference(PositionTask(robot, robot.right_hand), kp=400.0, kd=40.0, name="hand")
    start = DynamicsState(robot).frame_placement(robot.frame_id(robot.right_hand)).translation
    hand.set_target(start + [0.15, 0.0, 0.10])
    soles = [SoleContact(robot, robot.left_sole, name="left"), SoleContact(robot, robot.right_sole, name="right")]
    ctrl = InverseDynamicsController(InverseDynamicsQP(robot, [posture, hand], soles), DT)
    if bound is not None:
        ctrl.qp.add_constraint(bound)
    return ctrl


def _run(robot, ctrl):
    """20 ticks from standing; per tick the command and Pinocchio's p̈ of the right hand under it."""
    fid = robot.frame_id(robot.right_hand)
    return id_ticks_from_standing(robot, ctrl, 20, DT, lambda q, v, dv: _classical_acceleration(robot, fid, q, v, dv))


def test_on_a_talos_controller_it_binds_and_stays_on_the_compiled_path(robots):
    robot = robots("talos")
    free = _run(robot, _reaching(robot, None))
    assert max(abs(acc[0]) for _, acc in free) > 2 * LIMIT[0]  # the task alone asks far more than the bound
    assert max(abs(acc[2]) for _, acc in free) > 2 * LIMIT[2]
    bound = FrameAccelerationBound(robot, robot.right_hand, LIMIT)
    ctrl = _reaching(robot, bound)
    held = _run(robot, ctrl)
    # the first tick is cold (no warm start) and leaves the compiled route with or without the bound
    assert str(held[0][0].path) == str(free[0][0].path)
    for k, (cmd, acc) in enumerate(held):
        assert (np.abs(acc) <= LIMIT * (1 + 1e-6)).all(), (k, acc)
        for axis in (0, 2):  # it binds on x and z, the directions of the reach
            assert abs(abs(acc[axis]) - LIMIT[axis]) <= 1e-6 * LIMIT[axis], (k, axis, acc)
        if k:
            assert str(cmd.path) == "kernel" and cmd.path_reason == "", (k, cmd.path, cmd.path_reason)
    assert ctrl.paths["kernel"] == 19
    # the compiled answer of the last tick is the optimum of the QP build() assembles there, the bound's rows in it
    C = assert_id_command_is_the_qp_optimum(ctrl, held[-1][0], DT, X_TOL)
    np.testing.assert_array_equal(C[bound.rows, :robot.nv],
                                  ctrl.state.frame_jacobian(bound.frame_id)[0:3])


@pytest.mark.parametrize("limit", [0.0, -1.0, math.nan, [1.0, 2.0], "big", [1.0, -2.0, 3.0]])
def test_bad_limit_is_a_typed_error(robots, limit):
    robot = robots("talos")
    with pytest.raises(InvalidInputError, match="frame_acceleration:.*: limit must be"):
        FrameAccelerationBound(robot, robot.right_hand, limit)


def test_unknown_frame_is_a_typed_error(robots):
    with pytest.raises(UnknownFrameError):
        FrameAccelerationBound(robots("talos"), "no_such_hand", 1.0)


def test_a_free_axis_a_new_limit_and_a_name(robots):
    robot = robots("talos")
    bound = FrameAccelerationBound(robot, robot.right_hand, [math.inf, 10.0, 10.0], name="cup")
    assert bound.name == "cup" and bound.limit[0] == math.inf
    assert FrameAccelerationBound(robot, robot.right_hand, 1.0).name == f"frame_acceleration:{robot.right_hand}"
    bound.set_limit(5.0)
    np.testing.assert_array_equal(bound.limit, [5.0, 5.0, 5.0])
    bound.limit[:] = 1.0  # a copy: the bound is unchanged
    np.testing.assert_array_equal(bound.limit, [5.0, 5.0, 5.0])


def test_assigning_the_limit_validates_it(robots):
    robot = robots("talos")
    bound = FrameAccelerationBound(robot, robot.right_hand, 3.0)
    bound.limit = [1.0, 2.0, math.inf]
    np.testing.assert_array_equal(bound.limit, [1.0, 2.0, math.inf])
    with pytest.raises(InvalidInputError, match="limit must be one number or 3"):
        bound.limit = [1.0, 2.0]
    np.testing.assert_array_equal(bound.limit, [1.0, 2.0, math.inf])  # unchanged by the refused value
