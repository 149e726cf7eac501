"""The one constraint protocol of both QP levels (wbc.constraints.base): every constraint class of both levels is a
Constraint with a kind, a level and a ``write``; a kinematic constraint's ``write`` gives the rows of its ``compute``;
the inverse-dynamics QP takes an equality constraint of the user's own, solved exactly and named by the diagnosis;
each controller refuses the other level's constraints with a typed error.

Independent references: each constraint's own ``compute`` (kinematic rows, which the constraint's own test file
checks by finite differences), Pinocchio's RNEA for the equations of motion, the closed-form value of the constrained
joint acceleration.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import numpy as np
import pinocchio as pin
import pytest

import wbc
import wbc.constraints
from wbc.configuration import Configuration
from wbc.constraints import (ComPolygonConstraint, ContactConstraint, JointPositionLimit, JointVelocityLimit)
from wbc.constraints.base import (CONSTRAINT_KINDS, Constraint, IDConstraint, KinematicContext)
from wbc.dynamics import AccelerationReference, DynamicsState, InverseDynamicsQP, SoleContact
from wbc.exceptions import InvalidInputError
from wbc.tasks import PostureTask

DT = 0.002
BASES = {"Constraint", "EqualityConstraint", "InequalityConstraint", "BoxConstraint", "IDConstraint", "AxisBound"}


def _constraint_classes():
    out = []
    for info in pkgutil.iter_modules(wbc.constraints.__path__):
        module = importlib.import_module(f"wbc.constraints.{info.name}")
        for name, cls in inspect.getmembers(module, inspect.isclass):
            if cls.__module__ == module.__name__ and name not in BASES and issubclass(cls, Constraint):
                out.append(cls)
    return out


def test_every_constraint_class_of_both_levels_follows_the_one_protocol():
    classes = _constraint_classes()
    names = {c.__name__ for c in classes}
    # both levels are found (the walk over the package is not empty)
    assert {"ContactConstraint", "JointPositionLimit", "ComPolygonConstraint", "FloatingBaseDynamics",
            "ContactAcceleration", "TorqueLimits", "FrictionPyramid", "Unilaterality", "JointAccelerationLimits",
            "AccelerationBarrier", "HardTask", "JointSpeedBounds"} <= names
    for cls in classes:
        assert cls.kind in CONSTRAINT_KINDS, cls
        assert cls.level in ("velocity", "acceleration"), cls
        assert (cls.level == "acceleration") == issubclass(cls, IDConstraint), cls
        assert not inspect.isabstract(cls), f"{cls.__name__} does not implement write"


def test_kinematic_write_gives_the_rows_of_compute(robots):
    robot = robots("talos")
    rng = np.random.default_rng(3)
    q = pin.integrate(robot.model, robot.q_ref, rng.normal(scale=0.05, size=robot.nv))
    config = Configuration(robot, q)
    ctx = KinematicContext(config, DT)
    foot = ContactConstraint(robot, robot.left_sole)
    foot.set_placement_from_configuration(Configuration(robot))  # an error to correct
    polygon = ComPolygonConstraint(robot, margin=0.01)
    polygon.set_support([Configuration(robot).data.oMf[robot.frame_id(s)] for s in (robot.left_sole,
                                                                                     robot.right_sole)])
    for con in (foot, polygon):
        rows = con.compute(config, DT)
        out = [np.full_like(r, np.nan) for r in rows]
        con.write(ctx, *out, *([None] * (3 - len(out))))
        for got, want in zip(out, rows):
            np.testing.assert_array_equal(got, want)
    for box in (JointPositionLimit(robot), JointVelocityLimit(robot)):
        lo, hi = np.full(box.dim, np.nan), np.full(box.dim, np.nan)
        box.write(ctx, None, lo, hi)
        want_lo, want_hi = box.compute(config, DT)
        np.testing.assert_array_equal(lo, want_lo)
        np.testing.assert_array_equal(hi, want_hi)


def test_a_contact_subclass_with_its_own_rows_is_written_from_them(robots):
    robot = robots("talos")
    config = Configuration(robot)

    class Shifted(ContactConstraint):
        def compute(self, config, dt):
            A, b = super().compute(config, dt)
            return A, b + 1.0

    con = Shifted(robot, robot.left_sole)
    con.set_placement_from_configuration(config)
    A, b = np.zeros((6, robot.nv)), np.zeros(6)
    con.write(KinematicContext(config, DT), A, b, None)
    np.testing.assert_array_equal(b, np.ones(6))  # the placement is held: compute's b is 0 + 1


class JointAccelerationEquality(IDConstraint):
    """A user's own equality on x = [v̇; f]: v̇_j = a (rad/s²) for one joint."""

    kind = "equality"
    dim = 1

    def __init__(self, name, index, value):
        self.name, self.index, self.value = name, index, value

    def write(self, ctx, A, b, _):
        A[:] = 0.0
        A[0, self.index] = 1.0
        b[0] = self.value


def _standing_qp(robot):
    soles = [SoleContact(robot, robot.left_sole, name="left", mu=0.8),
             SoleContact(robot, robot.right_sole, name="right", mu=0.8)]
    return InverseDynamicsQP(robot, [AccelerationReference(PostureTask(robot), kp=10.0)], soles)


def test_inverse_dynamics_takes_an_equality_constraint_of_the_users_own(robots):
    robot = robots("talos")
    qp = _standing_qp(robot)
    j = robot.model.joints[robot.model.getJointId("arm_left_4_joint")].idx_v
    state = DynamicsState(robot, robot.q_ref, np.zeros(robot.nv))
    free = qp.solve(state, DT)
    assert abs(free.dv[j] - 2.5) > 1.0  # the posture task alone does not ask for it
    con = qp.add_constraint(JointAccelerationEquality("elbow_acceleration", j, 2.5))
    assert con in qp.constraints and con.rows.stop - con.rows.start == 0  # laid out at the next build
    sol = qp.solve(state, DT)
    assert sol.dv[j] == pytest.approx(2.5, abs=1e-8)
    assert str(sol.path) == "kernel"  # the user's rows are gathered into the compiled tick (one assembly driver)
    # equations of motion, independently: M v̇ + h = Sᵀτ + J_cᵀ f from Pinocchio's RNEA
    data = robot.model.createData()
    tau_full = pin.rnea(robot.model, data, robot.q_ref, np.zeros(robot.nv), sol.dv)
    gen = qp.contact_jacobian_transpose @ sol.forces
    np.testing.assert_allclose(tau_full[:6], gen[:6], atol=1e-6)
    np.testing.assert_allclose(tau_full[6:] - gen[6:], sol.tau, atol=1e-6)
    # two equalities that cannot both hold: the diagnosis names them
    qp.add_constraint(JointAccelerationEquality("elbow_other", j, -2.5))
    names = [n for n, _ in qp.diagnose(state, DT)]
    assert "elbow_acceleration" in names or "elbow_other" in names
    qp.remove_constraint(con)
    qp.remove_constraint(qp.extra_equalities[0])
    again = qp.solve(state, DT)
    np.testing.assert_allclose(again.dv, free.dv, atol=1e-9)


def test_each_level_refuses_the_other_levels_constraints(robots):
    robot = robots("talos")
    qp = _standing_qp(robot)
    with pytest.raises(InvalidInputError, match="bounds|JointPositionLimit"):
        qp.add_constraint(JointPositionLimit(robot))
    with pytest.raises(InvalidInputError, match="already in the QP"):
        qp.add_constraint(JointAccelerationEquality("torque_limits", 6, 0.0))
    ctrl = wbc.KinematicController(robot, [PostureTask(robot)], [])
    with pytest.raises(InvalidInputError, match="acceleration level"):
        ctrl.add_constraint(JointAccelerationEquality("elbow_acceleration", 6, 0.0))
