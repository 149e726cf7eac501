"""The compiled SO(3)/SE(3) logarithms of :mod:`wbc.tasks.frame` (``log3_into``, ``jlog3_into``,
``placement_log6_into``) against Pinocchio's ``log3``, ``Jlog3`` and ``log6(P.actInv(M))``, from tiny to nearly half-turn
angles, and the orientation rows of :meth:`FrameTask.compute_into` (compiled log₃) against the rows written out here
with Pinocchio's functions."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from conftest import random_configuration
from wbc.configuration import Configuration
from wbc.tasks import FrameTask, OrientationTask
from wbc.tasks.frame import jlog3_into, log3_into, placement_log6_into

#: relative agreement with Pinocchio (the same formulas; the last bits may differ with the order of the sums)
RTOL = 1e-12


def _close(a, b) -> bool:
    return np.abs(np.asarray(a) - np.asarray(b)).max() <= RTOL * max(1.0, np.abs(b).max())


def _rotations(rng, n):
    """Rotations of angles from 1e-12 rad to π − 0.05 rad about random axes."""
    for k in range(n):
        axis = rng.standard_normal(3)
        angle = 10.0 ** rng.uniform(-12, 0) if k % 2 else rng.uniform(0.0, np.pi - 0.05)
        yield pin.exp3(axis / np.linalg.norm(axis) * angle)


def test_log3_and_jlog3_are_pinocchios():
    rng = np.random.default_rng(7)
    log, jlog = np.empty(3), np.empty((3, 3))
    for R in _rotations(rng, 400):
        theta = log3_into(R, log)
        assert _close(log, pin.log3(R))
        jlog3_into(theta, log, jlog)
        assert _close(jlog, pin.Jlog3(R))


def test_log3_leaves_the_half_turn_to_pinocchio():
    log = np.full(3, 7.0)
    assert log3_into(pin.exp3(np.array([0.0, 0.0, np.pi - 1e-7])), log) < 0.0
    assert np.all(log == 7.0)  # untouched


def test_placement_log6_is_pinocchios_log6_of_act_inv():
    rng = np.random.default_rng(8)
    out = np.empty(6)
    for k, R in enumerate(_rotations(rng, 400)):
        P = pin.SE3(pin.exp3(rng.standard_normal(3)), rng.uniform(-1, 1, 3))
        M = P * pin.SE3(R, rng.standard_normal(3) * 10.0 ** rng.uniform(-12, 0))
        pose = np.vstack([P.rotation, P.translation])
        assert placement_log6_into(pose, np.asfortranarray(M.rotation), M.translation.copy(), out)
        assert _close(out, pin.log6(P.actInv(M)).vector)
    half = P * pin.SE3(pin.exp3(np.array([np.pi - 1e-7, 0.0, 0.0])), np.zeros(3))
    assert not placement_log6_into(pose, half.rotation, half.translation, out)


@pytest.mark.parametrize("name", ["talos", "g1"])
def test_orientation_rows_are_those_of_pinocchios_log3(robots, name):
    robot = robots(name)
    rng = np.random.default_rng(9)
    config = Configuration(robot)
    tasks = [OrientationTask(robot, robot.torso), FrameTask(robot, robot.left_sole)]
    for _ in range(20):
        config.update(random_configuration(robot, rng))
        for task in tasks:
            task.set_target(pin.SE3(pin.exp3(rng.standard_normal(3)), rng.uniform(-1, 1, 3)))
            e, J = np.empty(task.dim), np.empty((task.dim, robot.nv))
            task.compute_into(config, e, J)
            fid = task.frame_id
            oMf = config.data.oMf[fid]
            rel = task.target.rotation.T @ oMf.rotation
            j_local = pin.getFrameJacobian(robot.model, config.data, fid, pin.LOCAL)
            e_ref = np.concatenate([oMf.translation - task.target.translation, pin.log3(rel)])[task.rows]
            J_ref = np.vstack([oMf.rotation @ j_local[:3], pin.Jlog3(rel) @ j_local[3:]])[task.rows]
            assert _close(e, e_ref) and _close(J, J_ref)
