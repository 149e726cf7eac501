"""Walk plans and helpers shared by the gait tests (tests/gait/test_<module>.py): Talos-sized plans (straight,
turning, one step, replanned) and the ``any_plan`` fixture over them, sole poses, rotation finite differences."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from wbc.gait import DOUBLE_SUPPORT, WalkPlan, plan_walk

DT = 0.002
Z_COM = 0.87
HALF_WIDTH = 0.085  # Talos: soles at y = ±0.085 in the reference posture


def pose(x: float, y: float, yaw: float = 0.0) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0, x], [s, c, 0.0, y], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


def lifted(m: np.ndarray, z: float) -> np.ndarray:
    m = m.copy()
    m[2, 3] = z
    return m


def talos_size_walk(**kw) -> WalkPlan:
    args = dict(n_steps=8, step_length=0.15)
    args.update(kw)
    return plan_walk(pose(0.0, HALF_WIDTH), pose(0.0, -HALF_WIDTH), np.array([0.0, 0.0, Z_COM]), **args)


def straight_plan() -> WalkPlan:
    return talos_size_walk()


def turning_plan() -> WalkPlan:
    return talos_size_walk(n_steps=8, step_length=0.1, turn=0.15, first_side="left")


def one_step_plan() -> WalkPlan:
    return talos_size_walk(n_steps=1)


def replanned_plan() -> WalkPlan:
    plan = talos_size_walk(n_steps=6)
    k = plan.index(2.5)  # mid single support (SS of step 2: 2.1 s .. 2.9 s)
    assert plan.support[k] != DOUBLE_SUPPORT
    return plan.replan(k, plan.com[k], plan.com_vel[k] + np.array([0.04, -0.05, 0.0]))


PLANS = {"straight_8x0.15": straight_plan, "turning": turning_plan, "one_step": one_step_plan, "replan": replanned_plan}


@pytest.fixture(scope="module", params=list(PLANS))
def any_plan(request) -> WalkPlan:
    return PLANS[request.param]()


# ------------------------------------------------------------------------------------------- CoM / ZMP


def rot_fd(R: np.ndarray, dt: float) -> np.ndarray:
    """World angular velocity from central differences of (N, 3, 3) rotations, samples 1..N-2."""
    out = np.empty((R.shape[0] - 2, 3))
    for i in range(1, R.shape[0] - 1):
        out[i - 1] = R[i] @ pin.log3(R[i - 1].T @ R[i + 1]) / (2 * dt)
    return out
