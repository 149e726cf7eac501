"""`wbc ros2 node --sim` prints every fall, not only the first: a soak's driver answers each "sim: FELL" line with
/reset_robot, and a second fall that went unprinted left the robot lying on the floor for the rest of the run."""

from types import SimpleNamespace

import pytest

pytest.importorskip("cyclonedds", reason="the optional extra wbc[ros2] is not installed (cyclonedds missing)")

from wbc.ros2.node import ControllerNode  # noqa: E402


def test_each_fall_after_a_reset_is_printed(capsys):
    walk = SimpleNamespace(walking=True, fell=False, t=0.0, monitor=SimpleNamespace(fall_reason="tilt"),
                           touchdown_replans=0, last_replan="")
    node = SimpleNamespace(walk=walk, _was_walking=True, _fall_reported=False, _replans_seen=0,
                           sim_state=lambda: "state")
    report = ControllerNode._report_sim
    script = [(1.0, False), (2.0, True), (2.002, True), (3.0, False), (4.0, False), (5.0, True), (5.002, True)]
    for t, fell in script:  # up, fall (printed once), /reset_robot (up again), a second fall
        walk.t, walk.fell = t, fell
        report(node)
    out = capsys.readouterr().out
    falls = [ln for ln in out.splitlines() if ln.startswith("sim: FELL")]
    assert falls == ["sim: FELL at t = 2.000 s (tilt); /reset_robot to restart",
                     "sim: FELL at t = 5.000 s (tilt); /reset_robot to restart"], out
