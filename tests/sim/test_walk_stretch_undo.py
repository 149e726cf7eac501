"""A stretched swing set down before its re-lift rose: the stretch is undone (issue 61, record 52).

Walk-push development trial 6842 of ``benchmarks/walk_push_trials.py --state estimated`` (300 N for 0.1 s at
4.782 s towards 52.2°, forwards-left, late in a left swing). The step adjustment stretches the left swing by 0.15 s
with the sole a couple of millimetres over the floor; the switcher sets it down where it is within a few ticks,
before the re-lift (:meth:`wbc.sim.walk.WalkScenario._add_relift`) can raise it. Before this fix the plan kept the
stretch (the remaining footsteps and the DCM plan moved 0.19 m forward and 0.17 m left, the plan clock 0.15 s
back): the right swing started with the DCM beyond the landed left sole and the robot fell (base drop at 5.90 s,
674 joint-speed exceedances). With the stretch undone (:meth:`WalkScenario._swing_landed`) the walk passes.
"""

from __future__ import annotations

import json

import numpy as np

PUSH_6842 = ["sim", "walk", "--steps", "8", "--step-length", "0.25", "--step-duration", "0.6", "--push", "300.0",
             "--push-time", "4.781792538287939", "--push-dir", "52.15408111037001", "--push-duration", "0.1",
             "--plant", "realistic", "--state", "estimated", "--seed", "6842"]


def test_walk_push_trial_with_a_stretch_set_down_at_once_passes_with_the_stretch_undone(cli, tmp_path):
    """The run passes with no joint past its speed limit; its only timing changes are the stretch and its undoing
    (equal and opposite), every landing lies within 3 cm of its planned footstep (before the fix the right sole
    landed 0.23 m from the footstep the stretch had moved), and MuJoCo loads the left sole (> 100 N) between 4.80 and
    4.88 s: the swing stretched at 4.85 s was set down at once (the case the undo is for)."""
    log, out = tmp_path / "w.npz", tmp_path / "w.json"
    code, err, _ = cli(PUSH_6842 + ["--quiet", "--log", str(log), "--json", str(out)])
    s = json.loads(out.read_text())
    assert code == 0 and s["passed"], (err, s["failed_criteria"])
    assert not s["fell"] and s["joint_speed_exceedances"] == 0
    changes = s["step_timing_changes_s"]
    assert len(changes) == 2 and changes[0] < -0.1 and abs(changes[0] + changes[1]) < 1e-9
    assert s["max_landing_error_m"] < 0.03
    d = np.load(log)
    t, fz = d["t"], d["sim_wrench"][:, 0, 2]  # MuJoCo's normal force on the left sole
    after = (t > 4.80) & (t < 4.88)
    assert fz[after].max() > 100.0
