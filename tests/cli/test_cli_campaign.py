"""`wbc campaign run`: a push beyond what a trial can mean is refused before any trial runs, with the bound said
(as `wbc sim push --force` is): 10 × the robot's capture-point bound for the campaign's longest push, in the most
favourable push direction."""

from __future__ import annotations

import math

import pytest

from wbc.cli import main
from wbc.robot import load_robot
from wbc.sim.scenarios import capture_point_bound


def _bound(duration: float) -> float:
    """talos's largest finite-push capture-point bound over directions every 15 deg (N)."""
    robot = load_robot("talos")
    return max(capture_point_bound(robot, duration, (math.cos(math.radians(a)), math.sin(math.radians(a)), 0.0))
               ["f_max_finite_n"] for a in range(0, 360, 15))


@pytest.mark.parametrize("sets, force, duration", [
    (["factors.force=4000", "factors.push_duration=2"], 4000.0, 2.0),
    (["factors.force=[300, 4000]", "factors.push_duration=[0.1, 1.0]"], 4000.0, 1.0),
    (["factors.force=1e9"], 1e9, 0.1),  # (the spec's default push_duration)
])
def test_a_push_beyond_what_a_trial_can_mean_is_refused_with_the_bound(tmp_path, capsys, sets, force, duration):
    argv = ["campaign", "run", "--kind", "push", "--trials", "2", "--no-plots", "--no-progress", "--results",
            str(tmp_path / "c")]
    for s in sets:
        argv += ["--set", s]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    bound = _bound(duration)
    assert 10 * bound < force  # the case is beyond the bound
    assert err == (f"wbc campaign: error: factors.force up to {force:g} N for {duration:g} s is beyond what a trial "
                   f"can mean (valid: <= {math.floor(10 * bound):.0f} N, 10 × talos's largest capture-point bound of "
                   f"{bound:.0f} N over push directions for a {duration:g} s push, beyond which it falls whatever "
                   "the controller does)"), err
    assert not (tmp_path / "c" / "trials").exists() or not any((tmp_path / "c" / "trials").iterdir())
