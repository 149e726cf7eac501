"""``wbc sim``'s refusals before any run, as the exact line a user sees and exit 2: a push beyond what a trial can
mean (with the bound), stairs the robot cannot walk, a ± bound given negative, a NaN velocity command,
contact events without the F/T sensors."""

from __future__ import annotations

import math

import pytest

import wbc
from wbc.sim.scenarios import capture_point_bound

REFUSED = [
    (["sim", "push", "--force", "1e9"],
     "wbc sim: error: --force 1e+09 N for 0.1 s is beyond what a trial can mean (valid: <= 5278 N, 10 × talos's "
     "capture-point bound of 528 N for this duration and direction, beyond which it falls whatever the controller "
     "does)"),
    (["sim", "walk", "--terrain", "stairs:0.5:0.1:3"],
     "wbc sim: error: --terrain stairs:0.5:0.1:3:up: a 0.1 m tread is shorter than talos's 0.21 m sole (valid: "
     "TREAD >= 0.21 m: the whole sole stands on each tread)"),
    (["sim", "push", "--mass-error", "-10"],
     "wbc sim: error: argument --mass-error: -10 is out of range (valid: 0 <= value < 100: a ± bound in %, each "
     "link's mass scaled by 1 + e with e uniform in [-value, +value] %; give its magnitude, e.g. --mass-error 10 "
     "for ±10 %) (see wbc sim --help)"),
    (["sim", "walk", "--wz", "nan"],
     "wbc sim: error: --wz nan is not a finite number (valid: |wz| < 112.5 deg/s: 90 deg per 0.8 s step)"),
    (["sim", "walk", "--contact-events", "--state", "ground-truth"],
     "wbc sim: error: --contact-events needs the ankle F/T of --state estimated and a stepping scenario (walk, "
     "push-step), got walk --state ground-truth"),
    (["sim", "push-step", "--contact-events", "--state", "ground-truth"],
     "wbc sim: error: --contact-events needs the ankle F/T of --state estimated and a stepping scenario (walk, "
     "push-step), got push-step --state ground-truth"),
]


@pytest.mark.parametrize("argv, line", REFUSED, ids=[" ".join(a) for a, _ in REFUSED])
def test_refused_before_any_run(argv, line, cli, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli(argv) == (2, line, "")
    assert list(tmp_path.iterdir()) == []  # no MUJOCO_LOG.TXT, nothing else


def test_push_bound_is_ten_capture_point_bounds():
    """Closed form, independent of the CLI: the finite-push capture-point bound of Talos for 0.1 s sideways is
    F = m ω² d / (1 − e^(−ω Δt)) with ω = sqrt(g / z_c), d the CoM-to-edge distance; 10 × it is 5278 N."""
    robot = wbc.load_robot("talos")
    cp = capture_point_bound(robot, 0.1, (0.0, 1.0, 0.0))
    omega = math.sqrt(9.81 / cp["com_height_m"])
    assert cp["omega"] == pytest.approx(omega, rel=1e-3)
    closed = robot.mass * omega**2 * cp["edge_distance_m"] / (1.0 - math.exp(-omega * 0.1))
    assert cp["f_max_finite_n"] == pytest.approx(closed, rel=1e-3)
    assert math.floor(10 * closed) in (5278, 5279)
