"""wbc.ros2.node_core without a transport: the parameter rules, the real-time epoch, --max-rtf, history depth."""

import math
import time

import pytest

from wbc.exceptions import InvalidInputError
from wbc.robot import load_robot
from wbc.ros2.node_core import NodeCore, history_depth


class _Silent(NodeCore):
    """A transport that publishes nothing: records the stamps the state would carry."""

    def __init__(self, *a, **k):
        super().__init__(*a, **k)
        self.stamps, self.rates = [], []

    def _poll(self):
        pass

    def _publish_state(self):
        self.stamps.append((time.time(), self.stamp_seconds()))

    def _rate_changed(self, rate):
        self.rates.append(rate)


@pytest.fixture(scope="module")
def robot():
    return load_robot("humanoid15")


def test_real_time_epoch_is_taken_when_the_loop_starts(robot):
    """The first stamp is the wall clock of the first tick: the epoch is taken in spin(), after every import and
    the walk's set-up, so nothing that happens before the loop delays the stamps."""
    node = _Silent(robot, time_mode="real")
    time.sleep(0.3)  # whatever the start-up costs after the node is built
    before = time.time()
    node.spin(0.02)
    wall, stamp = node.stamps[0]
    print(f"first stamp - wall clock at its tick: {1e3 * (stamp - wall):.3f} ms")
    assert node.epoch >= before  # not the construction time, 0.3 s earlier
    assert stamp - node.epoch == pytest.approx(node.walk.dt, abs=1e-6)  # first tick (epoch ~1.8e9 s: 2e-7 s resolution)


def test_parameter_rules(robot):
    node = _Silent(robot, time_mode="sim")
    assert node.check("update_rate", 3, 100.0) == ""
    assert node.check("update_rate", 2, 100) == ""  # an integer for a double
    assert node.check("update_rate", 3, 1000.0) == "update_rate = 1000.0 is out of range: valid is [1, 500]"
    assert node.check("update_rate", 3, math.nan).startswith("update_rate = nan is out of range")
    assert node.check("use_sim_time", 1, False) == "parameter 'use_sim_time' is read-only"
    assert node.check("max_velocity", 1, True) == "parameter 'max_velocity' is a double; got a bool"
    assert node.check("nope", 3, 1.0).startswith("parameter 'nope' does not exist; valid: ['cmd_vel_timeout'")
    node.apply("update_rate", 200.0)
    assert node.params["update_rate"] == 200.0 and node.rates == [200.0]
    node.apply("step_duration", 1.2)
    assert node.walk.step_duration == pytest.approx(1.2, abs=1e-12) and node.rates == [200.0]


def test_history_depth_is_one_second_of_samples():
    assert [history_depth(r) for r in (1, 10, 50, 100.5, 500)] == [10, 10, 50, 101, 500]


def test_max_rtf_caps_sim_time(robot):
    node = _Silent(robot, time_mode="sim", max_rtf=4.0)
    node.spin(0.4)
    (w0, _), (w1, _) = node.stamps[0], node.stamps[-1]
    assert node.pacer is not None and node.pacer.speed == 4.0
    # 0.4 s of node time at most 4x real time: the last tick waited for its due time (0.1 s after the first)
    assert w1 - w0 >= (0.4 - 2 * node.walk.dt) / 4.0 - 1e-3


@pytest.mark.parametrize("kw, words", [
    (dict(time_mode="real", max_rtf=2.0), "max_rtf applies to time mode 'sim' only"),
    (dict(time_mode="sim", max_rtf=0.0), "max_rtf 0.0 is invalid: valid is a finite number > 0"),
    (dict(time_mode="sim", max_rtf=math.inf), "max_rtf inf is invalid"),
    (dict(time_mode="wall"), "time mode 'wall' is invalid: valid are 'real', 'sim'"),
    (dict(name="1node"), "node name '1node' is invalid"),
    (dict(update_rate=0.5), "update_rate = 0.5 is out of range: valid is [1, 500]"),
])
def test_bad_arguments_are_refused(robot, kw, words):
    with pytest.raises(InvalidInputError, match=words.replace("[", r"\[").replace("]", r"\]")):
        _Silent(robot, **kw)
