"""The joint bounds of the inverse-dynamics QP count on the braking each drive can give (issue 61, record 75).

Trial 440 of push campaign 9414 (``wbc campaign run --kind push --seed 9414``, Talos, realistic plant, estimated
state): 336 N for 0.1 s at 4.562 s towards 319° (back-right) at the end of the walk. During the capture step that
follows, the QP swings the right arm out and back (the hip strategy of the CoM task): the shoulder roll
``arm_right_2_joint`` runs at 1.84 rad/s towards its upper position limit (0 rad, the arm against the body) with its
22.3 N·m drive saturated. The viability bound of eq. 9 let it come that close because it assumed the common braking
acceleration of 50 rad/s² — the drive gives 16.5 at most on the arm's inertia. Near the limit the full QP had no
point within the torque limits (its diagnosis: ``joint_limits`` against ``torque_limits``), the relaxed QP — without
either — took 37 ticks, the shoulder passed its limit and the wrist ``arm_right_6_joint`` its speed limit (1.37×) on
main e2079c2. With the braking accelerations of the drives (``braking_share`` 1: the torque limit over the joint's
own inertia, 16.5 rad/s² for that shoulder; :func:`wbc.constraints.joint_acceleration_bounds.drive_braking`) the
shoulder approaches its limit slower, every full QP solves and the walk passes.
"""

from __future__ import annotations

import json

import numpy as np

from wbc.robot import load_robot

PUSH_9414_440 = ["sim", "walk", "--steps", "8", "--step-length", "0.25", "--step-duration", "0.6", "--push",
                 "335.9216590478776", "--push-time", "4.561585236452412", "--push-dir", "319.0077549727954",
                 "--push-duration", "0.1", "--plant", "realistic", "--state", "estimated", "--seed", "440"]


def test_a_shoulder_driven_to_its_limit_is_braked_within_its_drive(cli, tmp_path):
    """Within 0.05 rad of its upper limit the plant's shoulder roll turns at under 1.5 rad/s (measured 1.36; main
    2.05, 40 ticks past the limit, up to 5.9 mrad; here 17 ticks, 2.3 mrad: MuJoCo's soft joint limit), every tick's
    full QP solves (no relaxed tick), no joint passes its URDF speed limit and the run passes."""
    log, out = tmp_path / "w.npz", tmp_path / "w.json"
    code, err, _ = cli(PUSH_9414_440 + ["--quiet", "--log", str(log), "--json", str(out)])
    s = json.loads(out.read_text())
    model = load_robot("talos").model
    joint = model.joints[model.getJointId("arm_right_2_joint")]
    d = np.load(log)
    q, v = d["q"][:, joint.idx_q], d["v"][:, joint.idx_v]
    near = q > model.upperPositionLimit[joint.idx_q] - 0.05
    assert near.any() and np.abs(v[near]).max() < 1.5, np.abs(v[near]).max()
    assert s["relaxed_qp_ticks"] == 0 and s["joint_speed_exceedances"] == 0, (s["relaxed_qp_ticks"],
                                                                              s["failed_criteria"])
    assert code == 0 and s["passed"], (err, s["failed_criteria"])
