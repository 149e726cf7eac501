"""Talos is a left/right mirror image where it matters for a push response (record 40): link masses, joint
placements, position/velocity/effort limits, the MuJoCo plant's drives, foot boxes and contact pairs, and the walk
plan (the right-first plan is the mirror image of the left-first one). Two upstream asymmetries of
example-robot-data 6.0.0 are pinned with their measured size, so a change of the robot files is noticed: the right
arm's inertials are the left arm's copied (not mirrored about the sagittal plane), and the pelvis CoM sits 8.4 mm to
the left; together they put the half_sitting CoM 1.42 mm left of the feet mid-point.

Mirror about the sagittal plane: M = diag(1, -1, 1); a left joint placement (p, R) mirrors to (M p, M R M), a link
CoM c to M c and inertia I to M I M; a revolute axis a (a pseudo-vector) to -M a, so the mirrored joint angle is
s q with s = (-M a_left) . a_right = ±1 and mirrored limits [lo, hi] -> [lo, hi] (s = 1) or [-hi, -lo] (s = -1).
"""

from __future__ import annotations

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from wbc.gait import plan_walk

M = np.diag([1.0, -1.0, 1.0])
AXES = {"JointModelRX": (1.0, 0.0, 0.0), "JointModelRY": (0.0, 1.0, 0.0), "JointModelRZ": (0.0, 0.0, 1.0)}
GRIPPERS = {"gripper_left_joint"}  # its joint frame is rotated differently on the right: not a mirror pair


def _other(name: str) -> str:
    return name.replace("left", "@").replace("right", "left").replace("@", "right")


@pytest.fixture(scope="module")
def talos(robots):
    return robots("talos")


def _pairs(model):
    """(left joint id, right joint id, angle sign s) of every left joint."""
    out = []
    for j in range(1, model.njoints):
        name = model.names[j]
        if "left" in name:
            jr = model.getJointId(_other(name))
            a, b = (np.array(AXES[model.joints[k].shortname()]) for k in (j, jr))
            out.append((j, jr, float(-M @ a @ b)))
    return out


def test_joint_placements_masses_and_limits_are_mirror_images(talos):
    model = talos.model
    pairs = _pairs(model)
    assert len(pairs) == 14  # per side: 6 leg joints, 7 arm joints, the gripper
    for j, jr, s in pairs:
        name = model.names[j]
        assert abs(s) == 1.0, name
        pl, pr = model.jointPlacements[j], model.jointPlacements[jr]
        np.testing.assert_allclose(M @ pl.translation, pr.translation, atol=1e-12, err_msg=name)
        assert model.inertias[j].mass == model.inertias[jr].mass, name
        iv, ivr = model.joints[j].idx_v, model.joints[jr].idx_v
        assert model.velocityLimit[iv] == model.velocityLimit[ivr], name
        assert model.effortLimit[iv] == model.effortLimit[ivr], name
        if name in GRIPPERS:
            continue
        np.testing.assert_allclose(M @ pl.rotation @ M, pr.rotation, atol=1e-12, err_msg=name)
        iq, iqr = model.joints[j].idx_q, model.joints[jr].idx_q
        lo, hi = model.lowerPositionLimit[iq], model.upperPositionLimit[iq]
        mirrored = (lo, hi) if s > 0 else (-hi, -lo)
        np.testing.assert_allclose(mirrored, (model.lowerPositionLimit[iqr], model.upperPositionLimit[iqr]),
                                   atol=1e-12, err_msg=name)


def test_leg_inertials_mirror_and_the_upstream_arm_and_pelvis_offsets_stay_small(talos):
    """Legs: CoM within 0.5 mm and inertia within 3e-4 kg m^2 of the mirror image (measured 0.4 mm, 2.3e-4: the
    hip and ankle roll links carry a y of -0.1/-0.2 mm on both sides). Arms: the right arm's link CoMs are the left
    arm's copied, e.g. arm_3 (1.47 kg) at y = +14.3 mm on both sides (mirror image: 28.6 mm apart). Whole robot at
    half_sitting: CoM 1.42 mm left of the feet mid-point, 1.28 mm of it from the pelvis CoM (y = +8.38 mm,
    13.5 kg); bound 2 mm, 1.5 % of the 130 mm sole width."""
    model = talos.model
    for j, jr, _ in _pairs(model):
        name = model.names[j]
        il, ir = model.inertias[j], model.inertias[jr]
        dc = np.linalg.norm(M @ il.lever - ir.lever)
        if name.startswith("leg"):
            assert dc < 5e-4, name
            assert np.abs(M @ il.inertia @ M - ir.inertia).max() < 3e-4, name
    j3, j3r = model.getJointId("arm_left_3_joint"), model.getJointId("arm_right_3_joint")
    np.testing.assert_allclose(model.inertias[j3].lever, model.inertias[j3r].lever, atol=0)  # copied
    assert model.inertias[j3].lever[1] == pytest.approx(0.0143, abs=5e-5)
    data = model.createData()
    q = talos.q_ref
    pin.framesForwardKinematics(model, data, q)
    com = pin.centerOfMass(model, data, q)
    mid = 0.5 * (data.oMf[talos.frame_id(talos.left_sole)].translation
                 + data.oMf[talos.frame_id(talos.right_sole)].translation)
    assert com[1] - mid[1] == pytest.approx(1.42e-3, abs=0.01e-3)
    assert abs(com[1] - mid[1]) < 2e-3
    assert model.inertias[model.getJointId("root_joint")].lever[1] == pytest.approx(8.38e-3, abs=0.01e-3)


def test_mujoco_plant_drives_feet_and_contacts_are_mirror_images(talos):
    from wbc.sim.mujoco_model import build_mujoco_model

    sim = build_mujoco_model(talos, plant="realistic")
    m = sim.model
    for j in range(m.njnt):
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or ""
        if "left" not in name:
            continue
        jr = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, _other(name))
        d, dr = m.jnt_dofadr[j], m.jnt_dofadr[jr]
        for what in ("dof_armature", "dof_damping", "dof_frictionloss"):
            assert getattr(m, what)[d] == getattr(m, what)[dr], (name, what)
    for a in range(m.nu):
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, a) or ""
        if "left" in name:
            ar = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, _other(name))
            np.testing.assert_array_equal(m.actuator_forcerange[a], m.actuator_forcerange[ar], err_msg=name)
            np.testing.assert_array_equal(m.actuator_gear[a], m.actuator_gear[ar], err_msg=name)
    gl = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "left_foot_box")
    gr = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "right_foot_box")
    np.testing.assert_array_equal(m.geom_size[gl], m.geom_size[gr])
    np.testing.assert_array_equal(m.geom_pos[gl] * [1, -1, 1], m.geom_pos[gr])
    np.testing.assert_array_equal(m.geom_quat[gl], m.geom_quat[gr])
    assert m.npair == 2
    for what in ("pair_friction", "pair_solref", "pair_solreffriction", "pair_solimp", "pair_margin"):
        np.testing.assert_array_equal(getattr(m, what)[0], getattr(m, what)[1], err_msg=what)


def test_right_first_walk_plan_is_the_mirror_image_of_the_left_first_one(talos):
    """The campaign's walk (8 steps of 0.25 m, 0.48 s single + 0.12 s double support) from half_sitting's feet;
    CoM on the sagittal plane: mirror images to 1e-12 m. From half_sitting's CoM (1.42 mm left) they differ by
    2.84 mm (twice the offset), the only plan asymmetry."""
    model, data = talos.model, talos.model.createData()
    pin.framesForwardKinematics(model, data, talos.q_ref)
    com = pin.centerOfMass(model, data, talos.q_ref).copy()
    left = data.oMf[talos.frame_id(talos.left_sole)].homogeneous
    right = data.oMf[talos.frame_id(talos.right_sole)].homogeneous
    kw = dict(n_steps=8, step_length=0.25, t_ss=0.48, t_ds=0.12, t_init=0.8, t_final=1.2)
    my = np.array([1.0, -1.0])
    for y0, dev in ((0.0, 1e-12), (com[1], 2 * com[1] + 1e-9)):
        c = np.array([com[0], y0, com[2]])
        a = plan_walk(left, right, c, first_side="left", **kw)
        b = plan_walk(left, right, c, first_side="right", **kw)
        assert len(a.t) == len(b.t)
        assert np.abs(a.com[:, :2] * my - b.com[:, :2]).max() <= dev
        assert np.abs(a.dcm * my - b.dcm).max() <= dev
        np.testing.assert_allclose(a.left_sole[:, :3, 3] * [1, -1, 1], b.right_sole[:, :3, 3], atol=1e-12)
        swapped = np.where(a.support == 1, 2, np.where(a.support == 2, 1, 0))
        np.testing.assert_array_equal(swapped, b.support)
