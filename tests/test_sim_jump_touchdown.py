"""G1 jump with ``wbc sim jump``'s defaults (estimated state, realistic plant): the controller switches a falling
sole to contact only once it is on the ground.

Independent reference: the height of each sole's lowest corner above its t = 0 height, from Pinocchio's forward
kinematics of the logged MuJoCo configuration, and MuJoCo's ground reaction (``sim_wrench``), at the tick where the
controller's contact of that sole turns on (``contact_active``). No number is taken from the scenario's summary. No
wall-clock assertion.
"""

import numpy as np
import pinocchio as pin
import pytest

pytest.importorskip("mujoco", reason="the mujoco extra is not installed")

from wbc.cli import main  # noqa: E402
from wbc.robot import load_robot  # noqa: E402

MAX_TOUCHDOWN_HEIGHT_M = 0.005  # a sole set down by the controller is at most this far above the ground
MAX_AIR_CONTACT_S = 0.004  # ... and the plant pushes on it at most this long after (two ticks at 500 Hz)


def test_g1_jump_touchdown_is_on_the_ground(tmp_path):
    log = tmp_path / "jump.npz"
    main(["sim", "jump", "--robot", "g1", "--count", "1", "--quiet", "--log", str(log)])
    z = np.load(log)
    robot = load_robot("g1")
    m, d = robot.model, robot.model.createData()
    q, t, on = z["q"], z["t"], z["contact_active"]
    fz = z["sim_wrench"][:, :, 2]
    a, b = 0.5 * robot.sole_length, 0.5 * robot.sole_width
    corners = np.array([[a, b, 0.0], [-a, b, 0.0], [-a, -b, 0.0], [a, -b, 0.0]]).T
    soles = [robot.frame_id(robot.left_sole), robot.frame_id(robot.right_sole)]

    def low(k, i):
        pin.framesForwardKinematics(m, d, q[k])
        M = d.oMf[soles[i]]
        return float((M.rotation @ corners + M.translation[:, None])[2].min())

    checked = 0
    for i in range(2):
        for k in np.flatnonzero(~on[:-1, i] & on[1:, i]) + 1:  # the controller's touch-downs of sole i
            height = low(k, i) - low(0, i)
            assert height <= MAX_TOUCHDOWN_HEIGHT_M, (i, t[k], height)
            loaded = np.flatnonzero(fz[k:, i] > 1.0)
            assert len(loaded) and t[k + loaded[0]] - t[k] <= MAX_AIR_CONTACT_S, (i, t[k])
            checked += 1
    assert checked == 2  # one landing per sole
