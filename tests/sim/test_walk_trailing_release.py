"""The trailing sole let go when its leg cannot follow (wbc.sim.walk_steps.WalkSteps._release_trailing), on a pushed
walk of the realistic plant on estimated state: trial 527 of push campaign 9420 (491 N towards 303° at 1.52 s, the
left foot in stance, 8 steps of 0.25 m × 0.6 s)."""

from __future__ import annotations

import json

import numpy as np

TRIAL_9420_527 = ["sim", "walk", "--steps", "8", "--step-length", "0.25", "--step-duration", "0.6", "--push",
                  "491.15573555476954", "--push-time", "1.5214341009329133", "--push-dir", "303.38678099839876",
                  "--push-duration", "0.1", "--plant", "realistic", "--state", "estimated", "--seed", "527"]


def test_a_capture_step_releases_the_stretched_trailing_sole_and_the_landed_knee_stays_in_its_limit(cli, tmp_path):
    """The push sends the right foot 0.55 m forward-right (it lands at 1.88 s). The left leg, behind, stretches at the
    speed of its knee.

    With the rule off, the left sole stays a contact. In 1.896–1.912 s the QP then plans less than 40 % of the normal
    force that MuJoCo's soles carry (its best answer with the left knee at its speed bound lets the body fall). The
    landed right knee, driven by torques for a falling body, folds past its limit: 1.0338× in the suite's arithmetic
    (``TEST_CPU``), 7 ticks.

    With the default (ρ = 0.8), the left sole is released at 1.884 s, its knee at 0.82 of its limit. No joint of the
    plant passes its limit (0.952×) and the robot does not fall. Measured from the plant's log (MuJoCo's joint
    velocities and contact forces), not from the plan. Thresholds: the URDF limit (1×), and the 40 % of the force
    comparison, written here."""
    off_log, off_json = tmp_path / "off.npz", tmp_path / "off.json"
    code, err, _ = cli(TRIAL_9420_527 + ["--trailing-release", "off", "--quiet", "--log", str(off_log),
                                         "--json", str(off_json)])
    off = json.loads(off_json.read_text())
    assert off["trailing_releases"] == []
    assert off["max_joint_speed_ratio"] > 1.0 and off["joint_speed_exceedances"] > 0, off["failed_criteria"]
    d = np.load(off_log)
    t = d["t"]
    w = (t >= 1.896) & (t <= 1.912)
    planned = d["qp_forces"][w][:, 2::3].sum(axis=1)  # every corner's normal force, both soles (N)
    plant = d["sim_wrench"][w][:, :, 2].sum(axis=1)
    assert np.all(planned < 0.4 * plant), np.c_[t[w], planned, plant]

    on_json = tmp_path / "on.json"
    code, err, _ = cli(TRIAL_9420_527 + ["--quiet", "--json", str(on_json)])
    on = json.loads(on_json.read_text())
    rel = on["trailing_releases"]
    assert [r["sole"] for r in rel] == ["left"] and 1.88 <= rel[0]["t"] <= 1.89, rel
    assert 0.8 <= rel[0]["speed_ratio"] < 0.9, rel
    assert not on["fell"], on["fall_reason"]
    assert on["joint_speed_exceedances"] == 0 and on["max_joint_speed_ratio"] < 1.0, on["failed_criteria"]


def test_the_unpushed_walk_releases_no_sole(cli, tmp_path):
    """In the unpushed 4-step walk no leg joint comes near 0.8 of its limit (the 8-step walk's largest is 0.30 in a
    double support): the rule never acts, and the walk is main's."""
    out = tmp_path / "w.json"
    cli(["sim", "walk", "--steps", "4", "--plant", "realistic", "--state", "estimated", "--quiet", "--json", str(out)])
    s = json.loads(out.read_text())
    assert s["trailing_releases"] == [] and s["passed"], s["failed_criteria"]
