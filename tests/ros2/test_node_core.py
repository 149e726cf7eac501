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
    """The first stamp is the wall clock at the end of the first tick: the epoch is taken in spin() after it, so
    neither the set-up before the loop nor a one-off cost in the first tick puts the stamps behind the wall
    clock."""
    node = _Silent(robot, time_mode="real")
    time.sleep(0.3)  # whatever the start-up costs after the node is built
    tick = node.walk.tick

    def slow_first_tick():  # a one-off cost in the first tick (a kernel loaded on first use)
        if node.ticks == 0:
            time.sleep(0.3)
        tick()

    node.walk.tick = slow_first_tick
    before = time.time()
    node.spin(0.02)
    wall, stamp = node.stamps[0]
    print(f"first stamp - wall clock at its publication: {1e3 * (stamp - wall):.3f} ms")
    assert node.epoch + node.walk.dt >= before + 0.3  # after the first tick, not at construction or spin()'s start
    assert stamp <= wall  # taken before the publication
    assert stamp - node.epoch == pytest.approx(node.walk.dt, abs=1e-6)  # first tick (epoch ~1.8e9 s: 2e-7 s resolution)


def test_real_time_stamps_jump_with_the_wall_clock_over_a_stall(robot):
    """A tick stalled 0.3 s (more than the pacer's 0.1 s catch-up): the next stamps follow the wall clock, the jump
    is counted in stamp_shift, and node time is not rushed."""
    node = _Silent(robot, time_mode="real")
    tick, stalled = node.walk.tick, []

    def stalling_tick():
        if node.ticks == 10:
            stalled.append(time.time())
            time.sleep(0.3)
        tick()

    node.walk.tick = stalling_tick
    node.spin(0.06)
    after = [stamp for wall, stamp in node.stamps if wall > stalled[0]]
    # after[0]: the stalled tick's own state, stamped on the schedule it started on; after[1]: the next tick's
    print(f"stamp jump {node.stamp_shift:.3f} s; next tick's stamp - stall start {after[1] - stalled[0]:.3f} s")
    assert node.pacer.late_ticks >= 1 and node.stamp_shift >= 0.3 - 0.1
    assert after[1] >= stalled[0] + 0.3 - 0.1  # without the jump: stall start + 4 ms
    # a tick is published after the previous tick's due time: its stamp (its own due time) is at most dt ahead
    assert all(stamp <= wall + node.walk.dt + 1e-6 for wall, stamp in node.stamps)


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


def test_deadline_misses_count_the_ticks_that_overran_the_period(robot, capsys):
    """Every 7th tick made 3 ms slower than the 2 ms period (a sleep, so at least 3 ms whatever the load): those
    ticks are deadline misses, counted against the tick times measured independently around the slow ticks, and
    the periodic report prints the count and the maximum."""
    node = _Silent(robot, time_mode="sim")
    tick, slow = node.walk.tick, []

    def sometimes_slow_tick():
        tick()
        if node.ticks % 7 == 3:
            slow.append(node.ticks)
            time.sleep(0.003)

    node.walk.tick = sometimes_slow_tick
    node.spin(0.2, report_every=0.2, trim_every=None)  # 100 ticks
    assert node.ticks == 100 and len(slow) == 14
    fast = [t for i, t in enumerate(node.tick_time) if i not in slow]
    expected = len(slow) + sum(t > node.walk.dt for t in fast)  # a fast tick can overrun too on a loaded machine
    out = capsys.readouterr().out
    print(out, f"misses {node.deadline_misses}, slow {len(slow)}, fast over 2 ms {expected - len(slow)}")
    assert node.deadline_misses == expected and node.deadline_misses >= 14, (node.deadline_misses, len(slow))
    assert node.tick_max >= 0.003
    assert f"deadline misses {node.deadline_misses} (> 2 ms)" in out, out
    assert "max " in out and f"max {1e6 * node.tick_max:.0f} µs" in out, out


def test_a_goal_whose_cancel_was_accepted_ends_canceled_when_a_new_goal_arrives(robot):
    """NavigateToPose: goal 1 canceled (accepted: 0), goal 2 sent during goal 1's closing step: goal 1 ends
    CANCELED (its cancel was honoured; ABORTED is for a goal pre-empted while executing), goal 2 is walked to."""
    from wbc.ros2.node_core import ABORTED, CANCELED, SUCCEEDED

    core = _Silent(robot, time_mode="sim")
    first = core.start_goal(b"\x01" * 16, "navigate_to_pose", (1.0, 0.0, 0.0))
    core.spin(duration=2.0)
    assert core.cancel(b"\x01" * 16) == 0
    core.spin(duration=2.3)  # node time: 0.3 s into the closing step
    assert not core.walk.idle
    second = core.start_goal(b"\x02" * 16, "navigate_to_pose", (0.6, 0.0, 0.0))
    assert first.status == CANCELED and first.result_code == 0, first.result_msg
    third_t = core.walk.t
    core.spin(duration=third_t + 30.0)
    assert second.status == SUCCEEDED, second.result_msg
    # pre-empting an executing goal still aborts it
    core.start_goal(b"\x03" * 16, "navigate_to_pose", (1.0, 0.0, 0.0))
    core.spin(duration=core.walk.t + 1.0)
    fourth = core.start_goal(b"\x04" * 16, "navigate_to_pose", (0.6, 0.0, 0.0))
    assert core.finished_goal(b"\x03" * 16).status == ABORTED
    core.cancel(fourth.uuid)
