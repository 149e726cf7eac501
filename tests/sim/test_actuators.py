"""Drive models of the plant (wbc.sim.actuators): URDF damping/friction and armature in MuJoCo, the torque–speed
envelope against its closed form and in the physics."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import wbc
from wbc.exceptions import InvalidInputError
from wbc.sim.actuators import ActuatorModel, actuator_model, apply_actuators, nominal_armature
from wbc.sim.mujoco_model import build_mujoco_model


@pytest.fixture(scope="module")
def talos():
    return wbc.load_robot("talos")


def test_envelope_closed_form():
    act = ActuatorModel(np.zeros(4), np.zeros(4), np.zeros(4), np.full(4, 10.0), np.full(4, 2.0))
    tau = np.array([10.0, 10.0, -10.0, 10.0])
    qd = np.array([1.0, -1.0, 1.5, 3.0])
    # motoring at half the no-load speed: 5 N·m; braking: full 10; motoring at 3/4: 2.5; above ω0: 0
    np.testing.assert_allclose(act.available_torque(tau, qd), [5.0, 10.0, -10.0, 0.0])
    np.testing.assert_allclose(act.available_torque(np.array([-3.0, 3.0, 2.0, -20.0]), qd), [-3.0, 3.0, 2.0, -10.0])


def test_realistic_talos_plant_has_urdf_dynamics_and_srdf_armature(talos):
    real = build_mujoco_model(talos, plant="realistic")
    ideal = build_mujoco_model(talos, plant="ideal")
    dofs = real.state_map.mj_qvel
    m = talos.model
    # URDF <dynamics>: Pinocchio's parse of the URDF is the reference (Talos: damping 0.5–1, friction 1 on 20 joints)
    np.testing.assert_array_equal(real.model.dof_damping[dofs], m.damping[6:])
    np.testing.assert_array_equal(real.model.dof_frictionloss[dofs], m.friction[6:])
    assert (m.friction[6:] == 1.0).sum() == 20
    # SRDF rotor_params: rotor inertia 1e-5 kg·m², gear ratio 100 on every listed joint → 0.1 kg·m²
    names = list(m.names[2:])
    arm = real.model.dof_armature[dofs]
    assert arm[names.index("leg_left_4_joint")] == pytest.approx(0.1)
    assert arm[names.index("arm_right_7_joint")] == pytest.approx(0.1)
    assert np.all(ideal.model.dof_damping == 0) and np.all(ideal.model.dof_frictionloss == 0)
    assert np.all(ideal.model.dof_armature == 0) and ideal.drive is None
    assert real.drive is not None
    np.testing.assert_allclose(real.drive.no_load_speed, 1.2 * m.velocityLimit[6:])
    _, source = nominal_armature(wbc.load_robot("g1"))
    assert "Menagerie" in source


def test_drive_cannot_spin_its_joint_above_the_no_load_speed(talos):
    """Full torque on the Talos wrist (URDF 1.95 rad/s): the ideal plant passes 1.2 × 1.95 rad/s within 0.1 s, the
    realistic one stays below it (MuJoCo qvel)."""
    peak = {}
    for plant in ("ideal", "realistic"):
        sim = build_mujoco_model(talos, plant=plant)
        j = list(talos.model.names[2:]).index("arm_left_7_joint")
        dof = sim.state_map.mj_qvel[j]
        tau = np.zeros(talos.model.nv - 6)
        tau[j] = sim.effort_limit[j]
        fast = 0.0
        for _ in range(50):
            sim.set_torques(tau)
            mujoco.mj_step(sim.model, sim.data)
            fast = max(fast, abs(float(sim.data.qvel[dof])))
        peak[plant] = fast
    w0 = 1.2 * 1.95
    assert peak["ideal"] > w0
    assert peak["realistic"] <= w0 * 1.001


def test_bad_plant_options(talos):
    with pytest.raises(InvalidInputError, match="plant"):
        actuator_model(talos, "perfect")
    with pytest.raises(InvalidInputError, match="extra_friction"):
        actuator_model(talos, extra_friction=-1.0)
    with pytest.raises(InvalidInputError, match="plant"):
        build_mujoco_model(talos, plant="real")
    sim = build_mujoco_model(talos)
    apply_actuators(sim, actuator_model(talos, extra_friction=2.0, armature=0.05))
    assert np.all(sim.model.dof_frictionloss[sim.state_map.mj_qvel] >= 2.0)
    assert np.all(sim.model.dof_armature[sim.state_map.mj_qvel] == 0.05)


def test_cli_rejects_bad_plant_options(capsys):
    from wbc.cli import main

    with pytest.raises(SystemExit) as exc:
        main(["sim", "stand", "--plant", "perfect"])
    assert exc.value.code == 2
    capsys.readouterr()
    with pytest.raises(SystemExit) as exc:  # refused while parsing, before any model is built
        main(["sim", "stand", "--no-load-factor", "0"])
    assert exc.value.code == 2
    assert "--no-load-factor: 0 is out of range" in capsys.readouterr().err


def test_robot_file_armature_reaches_the_realistic_plant(tmp_path):
    """A robot file's [mujoco] armature is the realistic plant's (it was replaced by "none known (0)")."""
    from pathlib import Path

    import wbc.robots

    cat = Path(wbc.robots.__path__[0]).resolve()  # the installed catalog (robots/ of the repository)
    text = (cat / "humanoid15.toml").read_text().replace('"humanoid15.urdf"', f'"{cat / "humanoid15.urdf"}"')
    text = text.replace('"humanoid15.srdf"', f'"{cat / "humanoid15.srdf"}"')
    path = tmp_path / "mine.toml"
    path.write_text('name = "mine"\n' + text + "\n[mujoco]\narmature = 0.03\n")
    robot = wbc.load_robot(str(path))
    act = actuator_model(robot, "realistic")
    np.testing.assert_allclose(act.armature, 0.03)
    assert "robot file" in act.armature_source
    sim = build_mujoco_model(robot, plant="realistic")
    np.testing.assert_allclose(sim.model.dof_armature[sim.state_map.mj_qvel], 0.03)


def test_srdf_rotor_data_gaps_take_the_robot_file_armature():
    """Joints an SRDF's <rotor_params> leave at 0 (Talos's grippers) take the robot file's armature; the others keep
    rotor inertia × gear ratio² (computed here with Pinocchio's loader)."""
    import pinocchio as pin

    robot = wbc.load_robot("talos")
    m = robot.model.copy()
    pin.loadRotorParameters(m, str(robot.srdf_path), False)
    srdf = np.asarray(m.rotorInertia[6:]) * np.asarray(m.rotorGearRatio[6:]) ** 2
    assert np.any(srdf == 0) and np.any(srdf > 0)
    robot.model.armature[6:] = 0.02
    arm, source = nominal_armature(robot)
    np.testing.assert_allclose(arm, np.where(srdf == 0, 0.02, srdf))
    assert "robot file" in source


def test_set_torques_writes_the_envelope_of_the_numpy_reference(talos):
    """MuJoCo's ctrl after set_torques with a drive equals the drive envelope computed here with numpy (clamp to
    ±τ_max, motoring torque capped by τ_max (1 − |q̇|/ω₀)⁺), bit for bit, NaN speeds included; bad torques still
    raise the typed error."""
    from wbc.exceptions import ConfigurationError

    sim = build_mujoco_model(talos)
    act = actuator_model(talos, "realistic")
    apply_actuators(sim, act)
    rng = np.random.default_rng(3)
    n, d = talos.model.nv - 6, sim.data
    for k in range(200):
        tau = rng.normal(size=n) * act.effort_limit * 1.5
        d.qvel[:] = rng.normal(size=d.qvel.size) * 8.0
        if k % 5 == 0:
            d.qvel[rng.integers(0, d.qvel.size)] = np.nan
        sim.set_torques(tau)
        qd = np.array(d.qvel)[sim.state_map.mj_qvel]
        cap = np.where(tau * qd > 0, act.effort_limit * np.clip(1.0 - np.abs(qd) / act.no_load_speed, 0.0, 1.0),
                       act.effort_limit)
        np.testing.assert_array_equal(np.array(d.ctrl)[sim.actuator_ids], np.minimum(np.maximum(tau, -cap), cap))
    for bad in (np.full(n, np.nan), np.zeros(n - 1), [0.0] * (n + 1)):
        with pytest.raises(ConfigurationError):
            sim.set_torques(bad)


def test_leg_joints_of_one_side_are_that_leg_chain(talos):
    """leg_joints(robot, sides): the joints on the chain from the base to each sole of ``sides`` (Talos's names say
    which: leg_left_* / leg_right_*); both sides: their union; a side not "left"/"right" is refused."""
    from wbc.sim.actuators import leg_joints

    names = talos.model.names[2:]
    left, right = leg_joints(talos, ("left",)), leg_joints(talos, ("right",))
    np.testing.assert_array_equal(left, [n.startswith("leg_left_") for n in names])
    np.testing.assert_array_equal(right, [n.startswith("leg_right_") for n in names])
    np.testing.assert_array_equal(leg_joints(talos), left | right)
    for bad in ("left", ("up",), ("left", 1)):
        with pytest.raises(InvalidInputError, match="sides"):
            leg_joints(talos, bad)
