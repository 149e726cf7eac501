"""The CoM polygon constraint: a step of the CoM lands on the shrunk support boundary, recovers from outside, typed input errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import CATALOG
from wbc.configuration import Configuration
from wbc.constraints import ComPolygonConstraint, ContactConstraint
from wbc.controllers.kinematic import KinematicController
from wbc.exceptions import InvalidInputError
from wbc.geometry import convex_hull, signed_distance, sole_polygon
from wbc.tasks import ComTask, PostureTask

DT = 0.002


def _support(robot, config, sides):
    frames = {"left": robot.left_sole, "right": robot.right_sole}
    return [config.frame_placement(robot.frame_id(frames[s])) for s in sides]


POLYGON_CASES = [(name, sides) for name in CATALOG for sides in (("left", "right"), ("left",))
                 # humanoid15's 5-DoF legs cannot yaw a flat foot: two flat contacts drift apart in yaw at second
                 # order under large CoM swings until their dependent rows disagree (controller docstring); its
                 # polygon rows are checked in single support
                 if (name, sides) != ("humanoid15", ("left", "right"))]


@pytest.mark.parametrize(("name", "sides"), POLYGON_CASES)
def test_com_polygon_step_lands_on_the_shrunk_boundary(robots, name, sides):
    """A CoM task pulls 0.3 m away (sideways, other side, forward-diagonal); the polygon rows stop it. Reference
    geometry built independently: sole rectangles from the frames' placements and their hull,
    ``signed_distance`` to it. Every tick the first-order step c + J v dt stays ≥ margin inside (1e-9) and lands
    exactly at distance ``margin`` (1e-9 m) when the row is active; the integrated CoM (second-order error of
    the step) never gets closer than margin − 1e-5 m and settles on the shrunk boundary to 1e-6 m."""
    robot = robots(name)
    config = Configuration(robot)
    margin = 0.015
    poly_c = ComPolygonConstraint(robot, margin=margin)
    soles = _support(robot, config, sides)
    poly_c.set_support(soles)
    corners = np.vstack([sole_polygon(M.translation[0], M.translation[1], math.atan2(M.rotation[1, 0], M.rotation[0, 0]),
                                      robot.sole_length, robot.sole_width) for M in soles])
    polygon = convex_hull(corners)
    frames = {"left": robot.left_sole, "right": robot.right_sole}
    contacts = [ContactConstraint(robot, frames[s]) for s in sides]  # single support: the other foot is free
    for c in contacts:
        c.set_placement_from_configuration(config)
    com = ComTask(weight=10.0, gain=3.0)
    ctrl = KinematicController(robot, [com, PostureTask(robot, weight=1e-2)], contacts)
    if len(sides) == 1:  # bring the CoM over the stance sole first
        com.set_target(np.r_[soles[0].translation[:2], config.com[2]])
        for _ in range(500):
            config.update(config.integrate(ctrl.solve(config, DT).v, DT))
    assert poly_c.shrunk_distance(config.com[:2]) > 0
    ctrl.add_constraint(poly_c)
    landed, worst = 0, np.inf
    for direction in ([0.0, 1.0], [0.0, -1.0], [1.0, 0.3]):
        direction = np.array(direction) / np.linalg.norm(direction)
        com.set_target(config.com + np.r_[0.3 * direction, 0.0])
        active_run = 0
        for _ in range(1000):  # until a polygon row has been active for 50 ticks
            res = ctrl.solve(config, DT)
            assert res.ok, res.message
            predicted = config.com[:2] + DT * (config.com_jacobian[:2] @ res.v)
            d_pred = signed_distance(predicted, polygon)
            assert d_pred >= margin - 1e-9
            C, _, u = poly_c.compute(config, DT)
            if np.any(np.abs(C @ res.v - u) < 1e-9):  # a polygon row is active: exactly on the boundary
                assert d_pred == pytest.approx(margin, abs=1e-9)
                landed += 1
                active_run += 1
            else:
                active_run = 0
            config.update(config.integrate(res.v, DT))
            worst = min(worst, signed_distance(config.com[:2], polygon) - margin)
            if active_run == 50:
                break
        assert active_run == 50, "the CoM never reached the shrunk boundary"
        assert signed_distance(config.com[:2], polygon) == pytest.approx(margin, abs=1e-6)
    print(f"\n{name} {sides}: integrated CoM at worst {-worst * 1e6:.2f} µm inside the margin line" if worst < 0
          else f"\n{name} {sides}: integrated CoM never crossed the margin line")
    assert worst >= -1e-5  # second order in the step (≤ 1 cm per tick here)
    assert landed > 100


def test_com_polygon_recovers_from_outside(robots):
    """CoM starts > 2 cm outside the shrunk single-support polygon: the QP stays feasible, the CoM moves back at
    ≤ recovery_speed along each violated edge normal and ends inside."""
    robot = robots("talos")
    config = Configuration(robot)
    poly_c = ComPolygonConstraint(robot, margin=0.01, recovery_speed=0.05)
    poly_c.set_support(_support(robot, config, ("left",)))
    start = poly_c.shrunk_distance(config.com[:2])
    assert start < -0.02
    contacts = [ContactConstraint(robot, f) for f in (robot.left_sole, robot.right_sole)]
    for c in contacts:
        c.set_placement_from_configuration(config)
    com = ComTask(weight=1.0)
    com.set_target(config.com)  # holds the CoM where it is: conflicts with the recovery
    ctrl = KinematicController(robot, [com, PostureTask(robot)], [*contacts, poly_c])
    previous = start
    for _ in range(int(1.5 / DT)):
        res = ctrl.solve(config, DT)
        assert res.ok, res.message
        config.update(config.integrate(res.v, DT))
        now = poly_c.shrunk_distance(config.com[:2])
        if previous < 0:
            assert now - previous <= 0.05 * DT * 1.01 + 1e-9 or now > 0  # bounded rate
            assert now >= previous - 1e-7
        previous = now
    assert previous > -1e-6


def test_com_polygon_inputs(robots):
    robot = robots("g1")  # sole width 0.05 m
    config = Configuration(robot)
    c = ComPolygonConstraint(robot, margin=0.03)
    with pytest.raises(InvalidInputError, match="too small"):
        c.set_support(_support(robot, config, ("left",)))
    c.set_support(_support(robot, config, ("left", "right")))  # the hull of both is wide enough
    with pytest.raises(InvalidInputError):
        c.set_support([])
    with pytest.raises(InvalidInputError):
        ComPolygonConstraint(robot, margin=-0.01)
