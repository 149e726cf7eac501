"""wbc.cli.ros2.real_time: where a run's time is real (the controller's clock guard is on there, and only there)."""

from __future__ import annotations

from argparse import Namespace

import pytest

from wbc.cli.ros2 import real_time


@pytest.mark.parametrize("options, real", [
    ({}, False),  # a logged/offline run: reproducible
    ({"live": False, "ros2": False, "ros2_unpaced": False}, False),
    ({"live": True}, True),  # paced by the viewer
    ({"live": False, "ros2": True, "ros2_unpaced": False}, True),  # paced by the publisher
    ({"live": False, "ros2": True, "ros2_unpaced": True}, False),  # as fast as it goes: not real time
    ({"live": True, "ros2": True, "ros2_unpaced": True}, True),
])
def test_real_time_is_live_or_a_paced_ros2_run(options, real):
    assert real_time(Namespace(**options)) is real
