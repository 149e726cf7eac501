"""Swing clearance of fast adjusted steps (``WalkScenario(swing_height_weight=...)``).

A push during a walk on the realistic plant with the estimated state: the step adjustment asks for a swing faster than
the leg joints' speed bounds allow. With every position row of the swing-foot task weighted alike, the QP traded the
sole's height for its horizontal travel: the foot rose < 1 cm, scuffed the floor mid-swing at 2.4–2.6 m/s, was set
down 10 cm short while sliding, and the robot fell (pelvis past 30°).

Independent references: the swing intervals from the logged support phases, the sole heights from the logged
MuJoCo sole positions, the fall and joint-speed criteria from the simulator's summary (plant state). No wall-clock
assertion.
"""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from wbc.exceptions import InvalidInputError
from wbc.sim.walk import WalkScenario


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf")])
def test_swing_height_weight_must_be_a_positive_ratio(bad):
    with pytest.raises(InvalidInputError, match="swing_height_weight"):
        WalkScenario(2, 0.2, 0.6, swing_height_weight=bad)


def test_pushed_walk_does_not_set_a_sliding_swing_foot_down(tmp_path):
    # seed 9210 of benchmarks/walk_push_trials.py --state estimated: 300 N x 0.1 s at t = 4.160 s towards 326.6°
    # (forwards-right) during a Talos 8 x 0.25 m walk at 0.6 s/step; fell with the rows weighted alike
    # (the left swing after the adjusted step rose 7.8 mm and scuffed the floor at 2.5 m/s).
    seed, t_push, direction = 9210, 4.160283945276935, 326.6400716767497
    summary, log = tmp_path / "s.json", tmp_path / "log.npz"
    cmd = [sys.executable, "-m", "wbc", "sim", "walk", "--robot", "talos", "--steps", "8", "--step-length", "0.25",
           "--step-duration", "0.6", "--push", "300", "--push-time", repr(t_push), "--push-dir", repr(direction),
           "--push-duration", "0.1", "--plant", "realistic", "--state", "estimated", "--seed", str(seed), "--quiet",
           "--json", str(summary), "--log", str(log)]
    subprocess.run(cmd, check=True, capture_output=True, env=dict(os.environ))
    s = json.loads(summary.read_text())
    s = s.get("summary", s)
    assert not s["fell"], s.get("fall_reason")
    assert s["joint_speed_exceedances"] == 0
    d = np.load(log)
    phase, sole = d["support_phase"], d["sole_pos"]
    # every swing (released -> touch-down) lifts the MuJoCo sole at least 2 cm (plan: 5 cm; before: 7.8 mm)
    peaks = []
    for j in range(2):
        swing = (phase[:, j] == 2).astype(int)
        starts, ends = np.flatnonzero(np.diff(swing) == 1) + 1, np.flatnonzero(np.diff(swing) == -1) + 1
        peaks += [float(sole[a:b, j, 2].max()) for a, b in zip(starts, ends)]
    assert len(peaks) >= 8
    assert min(peaks) >= 0.02, peaks
