"""The compiled tick (:mod:`wbc.controllers.compiled_tick`): the command of every tick it answers (path 'compiled')
is the optimum of the QP that :meth:`~wbc.formulations.velocity.VelocityQP.assemble` writes, checked against
quadprog (dense Goldfarb–Idnani) and the KKT conditions (scipy's bounded least squares) on that same QP, and
against the general route (DAQP) of a twin controller; ``prepare_layouts`` leaves the ticks' answers unchanged and
refuses bad arguments with typed errors."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import dense_quadprog, kkt_gap, standing_controller
from wbc.configuration import Configuration
from wbc.constraints import ContactConstraint
from wbc.exceptions import InvalidInputError
from wbc.solvers import DaqpBackend

DT = 0.01


def _swaying(robots, **options):
    """(robot, config, controller, CoM task): a standing Talos whose CoM target is moved 3 cm forward and 2 cm to the
    side (the posture and limits then shape the answer); ``options`` set on the controller."""
    robot = robots("talos")
    config = Configuration(robot)
    ctrl, com = standing_controller(robot, config)
    for name, value in options.items():
        setattr(ctrl, name, value)
    com.set_target(config.com + np.array([0.03, -0.02, 0.0]))
    return robot, config, ctrl, com


def test_compiled_ticks_are_the_optimum_of_the_assembled_qp(robots):
    """20 ticks of a CoM sway: each tick answered by the compiled tick is the optimum of its assembled QP — quadprog's
    answer on the same QP within 1e-6 (rad/s, m/s; as measured, about 1e-12) and KKT conditions met to 1e-7."""
    robot, config, ctrl, _ = _swaying(robots, contact_correction=0.0, sole_drift_tolerance=None)
    compiled = 0
    for _ in range(20):
        q = config.q.copy()
        res = ctrl.solve(config, DT)
        assert res.ok, res.message
        if res.path == "compiled":
            compiled += 1
            qp = tuple(np.array(a, copy=True) for a in ctrl.assemble(Configuration(robot, q), DT))
            ref = dense_quadprog(*qp)
            assert np.abs(res.v - ref).max() < 1e-6, np.abs(res.v - ref).max()
            assert kkt_gap(*qp, res.v) < 1e-7, kkt_gap(*qp, res.v)
        config.update(config.integrate(res.v, DT))
    assert compiled >= 18, f"only {compiled} of 20 ticks took the compiled tick"


def test_compiled_tick_agrees_with_the_general_route(robots):
    """The same 10 ticks on the default backend (compiled tick) and on DAQP (the general route, path 'general:daqp'),
    each twin integrating its own command, the second-order contact hold off on both (it sends a tick whose soles
    drift to the general route): the commands agree within 1e-6."""
    options = dict(contact_correction=0.0, sole_drift_tolerance=None)
    robot, config, ctrl, _ = _swaying(robots, **options)
    _, config2, twin, _ = _swaying(robots, **options)
    twin.backend = DaqpBackend()
    for _ in range(10):
        res, res2 = ctrl.solve(config, DT), twin.solve(config2, DT)
        assert res.ok and res2.ok
        assert res.path == "compiled" and res2.path == "general:daqp", (res.path, res2.path)
        assert np.abs(res.v - res2.v).max() < 1e-6, np.abs(res.v - res2.v).max()
        config.update(config.integrate(res.v, DT))
        config2.update(config2.integrate(res2.v, DT))


def test_prepared_layouts_leave_the_answers_unchanged(robots):
    """A controller that prepared the single-support arrangement ahead answers ticks that switch to it and back exactly
    (bitwise) as one that did not."""
    answers = []
    for prepare in (False, True):
        robot, config, ctrl, _ = _swaying(robots)
        left = next(c for c in ctrl.constraints if isinstance(c, ContactConstraint) and c.frame == robot.left_sole)
        single = [c for c in ctrl.constraints if c is not left]
        if prepare:
            ctrl.prepare_layouts([(list(ctrl.tasks), single), (list(ctrl.tasks), list(ctrl.constraints))], config, DT)
        index = ctrl.constraints.index(left)
        vs = []
        for k in range(6):
            if k == 2:
                ctrl.remove_constraint(left)
            if k == 4:
                ctrl.add_constraint(left, index)
            res = ctrl.solve(config, DT)
            vs.append(res.v.copy())
            config.update(config.integrate(res.v, DT))
        answers.append(np.array(vs))
    np.testing.assert_array_equal(answers[0], answers[1])


def test_prepare_layouts_refuses_bad_arguments(robots):
    robot, config, ctrl, _ = _swaying(robots)
    arrangement = [(list(ctrl.tasks), list(ctrl.constraints))]
    for dt in (0.0, -0.01, float("nan"), float("inf")):
        with pytest.raises(InvalidInputError, match="dt"):
            ctrl.prepare_layouts(arrangement, config, dt)
    with pytest.raises(InvalidInputError, match="Task"):
        ctrl.prepare_layouts([(["com"], list(ctrl.constraints))], config, DT)
    with pytest.raises(InvalidInputError, match="Constraint"):
        ctrl.prepare_layouts([(list(ctrl.tasks), [object()])], config, DT)
    _, _, fresh, _ = _swaying(robots)
    np.testing.assert_array_equal(ctrl.solve(config, DT).v, fresh.solve(config, DT).v)  # its own layout kept


def test_prepared_ticks_pay_no_one_time_cost(robots, monkeypatch):
    """The one-time costs of the compiled tick are paid before the ticks: the configuration's lookahead Data is made
    with the configuration (the one its first lookahead returns), the tick kernel and the biped's drift kernel are
    specialised once per process, when the first plan is made; then six ticks of a swaying Talos, at least four of
    them compiled (each drift-checked: two soles), call :func:`wbc.compiled.specialise` zero times, after
    ``prepare_layouts`` or, for a second controller, in its first ticks (a new plan)."""
    import wbc.controllers.compiled_tick as compiled_tick

    robot, config, ctrl, _ = _swaying(robots)
    made = config._spare[0]
    assert config.lookahead(np.zeros(robot.model.nv)) is made
    ctrl.prepare_layouts([(list(ctrl.tasks), list(ctrl.constraints))], config, DT)
    calls = []
    real = compiled_tick.specialise
    monkeypatch.setattr(compiled_tick, "specialise", lambda *a: calls.append(a[0]) or real(*a))
    for prepared in (True, False):
        if not prepared:
            robot, config, ctrl, _ = _swaying(robots)
        paths = []
        for _ in range(6):
            res = ctrl.solve(config, DT)
            assert res.ok, res.message
            paths.append(str(res.path))
            config.step(res.v, DT)
        assert paths.count("compiled") >= 4, paths
        assert calls == []
