"""Romeo's standing push-step as a user runs it (``wbc sim push-step``: contact events on by default on estimated
state, standing air height :data:`wbc.sim.capture_step.STANDING_AIR_HEIGHT`): the right sole the push lifts off
the floor is released from the contact set, held flat and set down again (issue 61's contact-loss case; without
the events the controller kept it a contact with 0 N in the air and then loaded it 1–3 mm up: RHipYaw 1.29× its
0.32 rad/s limit, tests/fixtures/contact_loss_romeo_push_step.npz and tests/estimation/test_contact_events.py).

References are the plant's, independent of the controller's estimate: MuJoCo's ground reaction on the sole and
the lowest sole corner by Pinocchio's forward kinematics of the logged MuJoCo configuration.
"""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin


def test_romeo_push_step_releases_the_lifted_sole_and_sets_it_down(cli, tmp_path):
    import wbc

    log, out = tmp_path / "romeo.npz", tmp_path / "romeo.json"
    code, err, _ = cli(["sim", "push-step", "--robot", "examples/robots/romeo.toml", "--quiet",
                        "--log", str(log), "--json", str(out)])
    s = json.loads(out.read_text())
    assert code == 0 and s["passed"], (err, s["failed_criteria"])
    assert s["joint_speed_exceedances"] == 0 and s["max_joint_speed_ratio"] < 1.0 and not s["stepped"]
    acts = [(r["sole"], r["action"]) for r in s["contact_releases"]]
    assert acts == [("right", "release"), ("right", "touchdown")]
    t_rel, t_td = (r["t"] for r in s["contact_releases"])
    d = np.load(log)
    t, dt = d["t"], float(d["dt"])
    k_rel, k_td = int(round(t_rel / dt)), int(round(t_td / dt))
    robot = wbc.load_robot("examples/robots/romeo.toml")
    weight = robot.mass * robot.gravity
    fz = d["sim_wrench"][:, 1, 2]
    model, data = robot.model, robot.model.createData()
    fid = robot.frame_id(robot.right_sole)
    hl, hw = 0.5 * robot.sole_length, 0.5 * robot.sole_width
    corners = np.array([[sx * hl, sy * hw, 0.0] for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1))])

    def lowest(k):
        pin.framesForwardKinematics(model, data, d["q"][k])
        return float((corners @ data.oMf[fid].rotation[2]).min() + data.oMf[fid].translation[2])

    # released after the push (0.5-0.6 s) while the plant's sole was in the air: 0 N for the 10 ms before, its
    # lowest corner over 1 mm at the release
    assert 0.6 < t_rel < 0.8
    assert (fz[k_rel - 5:k_rel + 1] < 0.02 * weight).all() and lowest(k_rel) > 0.001
    # no contact of the controller on it (so no force planned) from the release to the touch-down ...
    assert not d["contact_active"][k_rel + 1:k_td, 1].any() and d["contact_active"][k_td + 1:, 1].all()
    # ... which the plant confirms: the sole down and loaded (MuJoCo) within 10 ms of it, 0.05-0.2 s later
    assert 0.05 < t_td - t_rel < 0.2
    assert fz[k_td - 5:k_td + 1].max() > 0.02 * weight and lowest(k_td) < 0.001
    # both soles carry the robot at the end, where they started (no step)
    assert (d["sim_wrench"][-1, :, 2] > 0.2 * weight).all()
    assert np.abs(d["sole_pos"][-1, :, :2] - d["sole_pos"][0, :, :2]).max() < 0.01
