"""The stance leg's reach (wbc.gait.stance_reach). References: the LIPM c̈ = ω² (c − a) integrated numerically with
scipy's solve_ivp and its event r(t) = R (not the quartic the module solves); the leg's length summed from
Pinocchio's joint placements of Talos's knee and ankle (not the forward kinematics the module reads); typed errors."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from wbc.exceptions import InvalidInputError
from wbc.gait.stance_reach import STANCE_REACH_RATIO, stance_legs, stance_reach_time

OMEGA = math.sqrt(9.81 / 0.877)


def _integrated(com, vel, hip, ankle, reach, t_end=3.0):
    """Time at which |hip(t) − ankle| reaches ``reach``, the CoM on the LIPM about the ankle (RK45, tight
    tolerances), the hip's offset from the CoM and its height kept; inf when not before ``t_end``."""
    a, off, h = np.asarray(ankle[:2]), np.asarray(hip[:2]) - np.asarray(com[:2]), hip[2] - ankle[2]

    def f(_, y):
        return [y[2], y[3], OMEGA ** 2 * (y[0] - a[0]), OMEGA ** 2 * (y[1] - a[1])]

    def event(_, y):
        d = y[:2] + off - a
        return d @ d + h * h - reach * reach

    event.terminal, event.direction = True, 1.0
    sol = solve_ivp(f, (0.0, t_end), [*com[:2], *vel[:2]], events=event, rtol=1e-11, atol=1e-12)
    return float(sol.t_events[0][0]) if sol.t_events[0].size else math.inf


def test_the_reach_time_is_the_integrated_pendulums():
    rng = np.random.default_rng(67)
    found = 0
    for _ in range(60):
        ankle = np.array([*rng.uniform(-0.3, 0.3, 2), 0.1])
        com = np.array([*(ankle[:2] + rng.uniform(-0.15, 0.15, 2)), 0.88])
        vel = np.array([*rng.uniform(-0.8, 0.8, 2), 0.0])
        hip = np.array([*(com[:2] + rng.uniform(-0.05, 0.05, 2)), ankle[2] + rng.uniform(0.55, 0.62)])
        reach = 0.97 * 0.705
        t = stance_reach_time(com, vel, OMEGA, hip, ankle, reach)
        ref = _integrated(com, vel, hip, ankle, reach)
        if math.isinf(ref):
            assert t > 3.0 - 1e-6
        else:
            found += 1
            assert t == pytest.approx(ref, abs=1e-6)
    assert found > 20  # (most draws reach it)


def test_already_stretched_and_never():
    ankle, hip = np.array([0.0, 0.0, 0.1]), np.array([0.3, 0.0, 0.75])
    com = np.array([0.3, 0.0, 0.88])
    assert stance_reach_time(com, np.zeros(3), OMEGA, hip, ankle, 0.5) == 0.0  # r = 0.716 already
    # on the pendulum's stable manifold (ċ = −ω (c − a)) the CoM comes to rest over the ankle: the leg shortens
    com, hip = np.array([0.1, 0.0, 0.88]), np.array([0.1, 0.0, 0.7])
    vel = -OMEGA * np.array([0.1, 0.0, 0.0])
    assert stance_reach_time(com, vel, OMEGA, hip, ankle, 0.97 * 0.705) == math.inf
    assert _integrated(com, vel, hip, ankle, 0.97 * 0.705) == math.inf


@pytest.mark.parametrize("bad", [(0.0, 0.6), (math.nan, 0.6), (OMEGA, 0.0), (OMEGA, math.inf)])
def test_typed_errors(bad):
    with pytest.raises(InvalidInputError, match="omega and reach"):
        stance_reach_time(np.zeros(3), np.zeros(3), bad[0], np.ones(3), np.zeros(3), bad[1])


def test_talos_legs_are_thigh_plus_shank(robots):
    robot = robots("talos")
    model = robot.model
    legs = stance_legs(robot)
    for side in ("left", "right"):
        knee, ankle = (model.getJointId(f"leg_{side}_{i}_joint") for i in (4, 5))
        # the hip joints 1–3 share one origin: thigh = |hip pitch → knee|, shank = |knee → ankle pitch|
        assert all(np.linalg.norm(model.jointPlacements[model.getJointId(f"leg_{side}_{i}_joint")].translation)
                   < 1e-9 for i in (2, 3))
        thigh = np.linalg.norm(model.jointPlacements[knee].translation)
        shank = np.linalg.norm(model.jointPlacements[ankle].translation)
        leg = legs[side]
        assert model.names[leg.hip] == f"leg_{side}_1_joint"
        assert leg.length == pytest.approx(thigh + shank, abs=1e-9)
        assert leg.length == pytest.approx(0.705, abs=1e-3)
    assert 0.0 < STANCE_REACH_RATIO <= 1.0


@pytest.mark.parametrize("field", ["com", "com_velocity", "hip", "ankle"])
def test_non_finite_or_short_positions_are_typed_errors(field):
    args = {"com": np.array([0.1, 0.0, 0.88]), "com_velocity": np.zeros(3), "hip": np.array([0.1, 0.0, 0.7]),
            "ankle": np.array([0.0, 0.0, 0.1])}
    bad = args[field].copy()
    bad[0] = np.nan
    with pytest.raises(InvalidInputError, match="finite"):
        stance_reach_time(args["com"] if field != "com" else bad, args["com_velocity"] if field != "com_velocity"
                          else bad, OMEGA, args["hip"] if field != "hip" else bad,
                          args["ankle"] if field != "ankle" else bad, 0.6)
    with pytest.raises(InvalidInputError, match="finite"):
        stance_reach_time(np.zeros(1), np.zeros(3), OMEGA, args["hip"], args["ankle"], 0.6)
