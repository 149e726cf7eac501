"""The capture step after the last planned step adapts its step timing as the walk does (issue 61, record 81).

Trial 994 of push campaign 9418 (``wbc campaign run --kind push --seed 9418``, Talos, realistic plant, estimated
state): 340 N for 0.1 s at 4.774 s towards 119.5° (left and back) in the last steps of the walk. The walk ends with
the DCM outside both soles and ``WalkScenario._start_recovery`` plans the capture step (a 2-step walk from the
measured state, the left foot first). With that walk's step time held at the walk's 0.6 s (main 5ec31bf) the left
swing took 0.442 s, the DCM diverged out of the landed sole's reach and the base dropped (fell, 52 joint-speed
exceedances up to 1.31×). With the step timing QP on in the capture walk (``adjust_timing`` of the walk) the swing is
cut to 0.254 s and the walk passes.
"""

from __future__ import annotations

import json

import numpy as np

PUSH_9418_994 = ["sim", "walk", "--steps", "8", "--step-length", "0.25", "--step-duration", "0.6", "--push",
                 "340.00565337759195", "--push-time", "4.7742151722604405", "--push-dir", "119.504844089868",
                 "--push-duration", "0.1", "--plant", "realistic", "--state", "estimated", "--seed", "994"]


def test_capture_step_cut_short_by_the_step_timing_qp_catches_a_late_push(cli, tmp_path):
    """The run passes every criterion of the walk (no fall, completed, no joint past its speed limit: measured
    0.997× at most); the capture step's swing — the first lift-off after the capture step
    started (``recovery_step_time_s``) to that sole's next contact, from the controller's contact log — lasts under
    0.3 s (measured 0.254 s; 0.442 s with the time held)."""
    log, out = tmp_path / "w.npz", tmp_path / "w.json"
    code, err, _ = cli(PUSH_9418_994 + ["--quiet", "--log", str(log), "--json", str(out)])
    s = json.loads(out.read_text())
    assert code == 0 and s["failed_criteria"] == [], (err, s["failed_criteria"])
    assert not s["fell"] and s["completed"] and s["joint_speed_exceedances"] == 0
    t0 = s["recovery_step_time_s"]
    assert t0 is not None and 4.77 < t0 < 6.0, t0
    d = np.load(log)
    t, active = d["t"], d["contact_active"].astype(bool)
    lift = next((i, j) for i in range(int(np.searchsorted(t, t0)), len(t)) for j in range(2)
                if active[i - 1, j] and not active[i, j])
    i, j = lift
    land = next(k for k in range(i, len(t)) if active[k, j])
    assert t[land] - t[i] < 0.3, (t[i], t[land])
