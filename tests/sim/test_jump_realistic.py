"""Two consecutive G1 jumps with ``wbc sim jump``'s defaults (estimated state from the simulated sensors, realistic
plant drives), judged from the logged plant state as an operator would.

Independent references: foot heights are the lowest corner of each sole rectangle placed by Pinocchio's forward
kinematics of the logged MuJoCo configuration; tilts are the angle between the pelvis / torso axes that pointed up
at t = 0 and world +z now (same logged q); the ground reaction is MuJoCo's (``sim_wrench``); the controller's
touch-downs are its logged ``contact_active``. No number is taken
from the scenario's own summary. No wall-clock assertion.
"""

import math

import numpy as np
import pinocchio as pin
import pytest

pytest.importorskip("mujoco", reason="the mujoco extra is not installed")

from wbc.cli import main  # noqa: E402
from wbc.robot import load_robot  # noqa: E402

MIN_FLIGHT_S = 0.1  # both feet at least CLEARANCE_M above the ground for this long, in every jump
CLEARANCE_M = 0.05
MAX_TILT_DEG = 30.0
MAX_BASE_DROP_M = 0.2
MAX_TOUCHDOWN_HEIGHT_M = 0.005  # a sole set down by the controller is at most this far above the ground
MAX_AIR_CONTACT_S = 0.004  # ... and the plant pushes on it at most this long after (two ticks at 500 Hz)


@pytest.fixture(scope="module")
def two_jumps(tmp_path_factory):
    """The log of one ``wbc sim jump --robot g1 --count 2`` run and, from Pinocchio's forward kinematics of its
    logged MuJoCo configurations: the lowest sole-rectangle corner of each sole per tick (N, 2) (m, world z) and the
    larger of the pelvis / torso tilts per tick (N,) (deg)."""
    log = tmp_path_factory.mktemp("jump") / "jump.npz"
    main(["sim", "jump", "--robot", "g1", "--count", "2", "--quiet", "--log", str(log)])
    z = dict(np.load(log))
    robot = load_robot("g1")
    m, d = robot.model, robot.model.createData()
    q, t = z["q"], z["t"]
    soles = [robot.frame_id(robot.left_sole), robot.frame_id(robot.right_sole)]
    torso = robot.frame_id(robot.torso)
    a, b = 0.5 * robot.sole_length, 0.5 * robot.sole_width
    corners = np.array([[a, b, 0.0], [-a, b, 0.0], [-a, -b, 0.0], [a, -b, 0.0]]).T
    low = np.empty((len(t), 2))
    tilt = np.empty(len(t))
    up0 = None
    for k in range(len(t)):
        pin.framesForwardKinematics(m, d, q[k])
        for i, f in enumerate(soles):
            M = d.oMf[f]
            low[k, i] = (M.rotation @ corners + M.translation[:, None])[2].min()
        rb = pin.Quaternion(q[k, 3:7]).toRotationMatrix()
        rt = d.oMf[torso].rotation
        if up0 is None:
            up0 = (rb.T @ [0.0, 0.0, 1.0], rt.T @ [0.0, 0.0, 1.0])
        tilt[k] = math.degrees(math.acos(min(1.0, (rb @ up0[0])[2], (rt @ up0[1])[2])))
    return z, robot, low, tilt


def test_g1_two_jumps_estimated_state_realistic_plant(two_jumps):
    z, robot, low, tilt = two_jumps
    q, t = z["q"], z["t"]
    dt = float(t[1] - t[0])
    # no fall: base never 0.2 m below its start, pelvis and torso within 30°, the run went to its end
    assert q[:, 2].min() >= q[0, 2] - MAX_BASE_DROP_M
    assert tilt.max() <= MAX_TILT_DEG, tilt.max()
    # two flights: intervals with no ground force; in each, both feet ≥ 5 cm up for ≥ 0.1 s
    fz = z["sim_wrench"][:, :, 2].sum(axis=1)
    up = (low - low[0]).min(axis=1) >= CLEARANCE_M
    assert (fz[up] < 1e-6).all()  # both feet up means no ground force
    edges = np.flatnonzero(np.diff(up.astype(int)))
    starts, ends = edges[::2] + 1, edges[1::2] + 1
    flights = [(e - s) * dt for s, e in zip(starts, ends)]
    long_flights = [f for f in flights if f >= MIN_FLIGHT_S]
    assert len(long_flights) == 2, flights
    # landed: the last 0.5 s on both feet carrying the robot's weight
    last = t > t[-1] - 0.5
    weight = robot.mass * 9.81
    assert abs(fz[last].mean() - weight) < 0.1 * weight


def test_g1_jump_touchdown_is_on_the_ground(two_jumps):
    """The controller switches a falling sole to contact only once it is on the ground: at each of its touch-downs
    (``contact_active`` turning on) the sole's lowest corner is at most MAX_TOUCHDOWN_HEIGHT_M above its t = 0
    height and MuJoCo's ground force on it appears within MAX_AIR_CONTACT_S."""
    z, _, low, _ = two_jumps
    t, on = z["t"], z["contact_active"]
    fz = z["sim_wrench"][:, :, 2]
    checked = 0
    for i in range(2):
        for k in np.flatnonzero(~on[:-1, i] & on[1:, i]) + 1:  # the controller's touch-downs of sole i
            height = low[k, i] - low[0, i]
            assert height <= MAX_TOUCHDOWN_HEIGHT_M, (i, t[k], height)
            loaded = np.flatnonzero(fz[k:, i] > 1.0)
            assert len(loaded) and t[k + loaded[0]] - t[k] <= MAX_AIR_CONTACT_S, (i, t[k])
            checked += 1
    assert checked == 4  # one landing per sole and jump


@pytest.mark.parametrize("value", [-0.01, 0.2, float("nan")])
def test_landing_crouch_out_of_range_is_a_typed_error(value):
    from wbc.exceptions import InvalidInputError
    from wbc.sim.jump import JumpScenario

    with pytest.raises(InvalidInputError, match="landing_crouch"):
        JumpScenario(crouch=0.1, landing_crouch=value)
