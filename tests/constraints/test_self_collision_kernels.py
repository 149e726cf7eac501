"""The compiled kernels of the self-collision constraint: the distance-rate rows against finite differences of the
witness points carried by their bodies."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from conftest import random_configuration
from wbc.constraints.self_collision_kernels import damper_rows


def _support(model) -> np.ndarray:
    """Row j: the number of columns of joint j's support, then those columns (the kernel's input contract)."""
    out = np.zeros((model.njoints, 1 + model.nv), dtype=np.int32)
    for j in range(1, model.njoints):
        cols = [c for i in model.supports[j] if i > 0
                for c in range(model.joints[i].idx_v, model.joints[i].idx_v + model.joints[i].nv)]
        out[j, 0] = len(cols)
        out[j, 1:1 + len(cols)] = sorted(cols)
    return out


@pytest.mark.parametrize("name", ["talos", "g1"])
def test_damper_rows_are_the_rate_of_the_witness_gap(robots, name):
    """Row · v = d/dt nᵀ(p2 − p1) with p1, p2 material points of two bodies (right hand, torso): central differences
    of the points moved with their joints along q ⊕ εv."""
    robot = robots(name)
    model, data = robot.model, robot.model.createData()
    rng = np.random.default_rng(4)
    q = random_configuration(robot, rng)
    j1 = model.frames[robot.frame_id(robot.right_hand or robot.right_sole)].parentJoint
    j2 = model.frames[robot.frame_id(robot.torso)].parentJoint
    pin.computeJointJacobians(model, data, q)
    p1, p2 = rng.uniform(-0.5, 0.5, (1, 3)), rng.uniform(-0.5, 0.5, (1, 3))
    n = rng.standard_normal((1, 3))
    n /= np.linalg.norm(n)
    C = np.zeros((1, model.nv))
    damper_rows(n, p1, p2, np.array([j1]), np.array([j2]), data.J, _support(model), C, np.array([0]))
    local = [data.oMi[j].actInv(p[0]) for j, p in ((j1, p1), (j2, p2))]  # the points in their joints' frames

    def gap(qq):
        d = model.createData()
        pin.forwardKinematics(model, d, qq)
        return float(n[0] @ (d.oMi[j2].act(local[1]) - d.oMi[j1].act(local[0])))

    eps = 1e-6
    for _ in range(3):
        v = rng.standard_normal(model.nv)
        fd = (gap(pin.integrate(model, q, eps * v)) - gap(pin.integrate(model, q, -eps * v))) / (2 * eps)
        assert C[0] @ v == pytest.approx(fd, abs=1e-7)
    rows = C.copy()
    damper_rows(n, p1, p2, np.array([j1]), np.array([j2]), data.J, _support(model), C, np.array([0]))
    np.testing.assert_allclose(C, 2 * rows, atol=1e-14)  # the kernel adds into its slot

