"""Plant sensors (``wbc.sim.sensors``) against MuJoCo's ground truth: ankle F/T (statically compensated by
``wbc.estimation.FootForceSensor``) equals the foot–floor contact wrench from ``mj_contactForce``; encoders are
quantised to their step; the IMU at rest reads the gravity direction; the noise is reproducible from its seed;
splitting ``mj_step`` into ``mj_step1``/``mj_step2`` (as the estimated-state loop does) leaves the physics bitwise
unchanged. Thresholds are written here."""

import math

import mujoco
import numpy as np
import pytest

from wbc.estimation import FootForceSensor
from wbc.exceptions import InvalidInputError
from wbc.robot import load_robot
from wbc.sim.mujoco_model import build_mujoco_model
from wbc.sim.scenarios import make_controller
from wbc.sim.sensors import EncoderSpec, ForceTorqueSpec, ImuSpec, PlantSensors, SensorSpecs


@pytest.fixture(scope="module")
def standing():
    """Talos standing 0.6 s under the joint-PD baseline, then ``mj_forward`` (sensors and contacts of one state)."""
    robot = load_robot("talos")
    sim = build_mujoco_model(robot)
    ctrl = make_controller(robot, "pd", dt=sim.timestep)
    q, v = sim.get_state()
    ctrl.reset(q, v)
    for _ in range(300):
        q, v = sim.get_state()
        sim.set_torques(ctrl.solve(q, v))
        mujoco.mj_step(sim.model, sim.data)
    mujoco.mj_forward(sim.model, sim.data)
    return robot, sim


def test_ankle_ft_equals_the_foot_contact_wrench(standing):
    robot, sim = standing
    r = PlantSensors(sim, SensorSpecs.ideal()).read(0.0)
    truth = sim.foot_contact_wrenches()
    for j, side in enumerate(("left", "right")):
        X = sim.sole_pose(side)
        w = FootForceSensor(robot, getattr(robot, f"{side}_sole")).ground_wrench(r.ft[j], X.rotation)
        f_true, t_true = X.rotation.T @ truth[side][:3], X.rotation.T @ truth[side][3:]
        assert f_true[2] > 0.3 * robot.mass * 9.81  # both feet loaded
        # static compensation: the residual is the foot's own acceleration (robot at rest: < 0.5 N, 0.05 N·m)
        assert np.abs(w[:3] - f_true).max() < 0.5
        assert np.abs(w[3:] - t_true).max() < 0.05


def test_encoders_are_quantised_and_imu_reads_gravity(standing):
    robot, sim = standing
    counts = 4096
    specs = SensorSpecs(encoder=EncoderSpec(counts_per_rev=counts), imu=ImuSpec(0, 0, 0, 0, 0, 0))
    r = PlantSensors(sim, specs).read(0.0)
    q, v = sim.get_state()
    step = 2 * math.pi / counts
    joints = q[7:]  # all 1-DoF revolute joints on Talos (nq = nv + 1)
    assert np.allclose(r.joint_q / step, np.round(r.joint_q / step), atol=1e-9)  # multiples of the step
    assert np.abs(r.joint_q - joints).max() <= 0.5 * step + 1e-12
    assert np.abs(r.joint_q - joints).max() > 0.05 * step  # not the exact angle
    R = sim.state_map.base_rotation(q)
    assert np.allclose(r.accel, R.T @ [0, 0, 9.81], atol=0.05)  # at rest: specific force = +g up, base axes
    assert np.abs(r.gyro).max() < 1e-2


def test_noise_is_seeded_and_biased(standing):
    robot, sim = standing
    a = PlantSensors(sim, seed=7)
    b = PlantSensors(sim, seed=7)
    c = PlantSensors(sim, seed=8)
    ra = [a.read(0.002 * k).gyro.copy() for k in range(200)]
    rb = [b.read(0.002 * k).gyro.copy() for k in range(200)]
    rc = [c.read(0.002 * k).gyro.copy() for k in range(200)]
    assert np.array_equal(ra, rb) and not np.array_equal(ra, rc)
    # white noise std per sample = density √rate; the mean is the bias (true rate ≈ 0 at rest)
    spec = ImuSpec()
    std = np.std(np.array(ra) - np.mean(ra, axis=0), axis=0)
    assert np.allclose(std, spec.gyro_noise_density * math.sqrt(spec.rate_hz), rtol=0.25)


def test_sensor_rates_and_specs_are_checked(standing):
    robot, sim = standing
    with pytest.raises(InvalidInputError, match="rate"):
        PlantSensors(sim, SensorSpecs(imu=ImuSpec(rate_hz=300.0)))
    s = ImuSpec()
    with pytest.raises(InvalidInputError, match="gyro_noise_density"):
        s.gyro_noise_density = -1.0
    with pytest.raises(InvalidInputError, match="counts_per_rev"):
        EncoderSpec(counts_per_rev=1.5)
    # a 250 Hz IMU holds every value for two ticks
    p = PlantSensors(sim, SensorSpecs(imu=ImuSpec(rate_hz=250.0)))
    g = [p.read(0.002 * k).gyro.copy() for k in range(4)]
    assert np.array_equal(g[0], g[1]) and np.array_equal(g[2], g[3]) and not np.array_equal(g[1], g[2])


def test_split_step_is_mj_step(standing):
    robot, sim = standing
    d0, d1 = mujoco.MjData(sim.model), mujoco.MjData(sim.model)
    tau = 0.3 * np.sin(np.arange(robot.model.nv - 6))
    for d in (d0, d1):
        sim.set_state(robot.q_ref, data=d)
        sim.set_torques(tau, data=d)
    for _ in range(50):
        mujoco.mj_step(sim.model, d0)
        mujoco.mj_step1(sim.model, d1)
        mujoco.mj_step2(sim.model, d1)
    assert d0.ncon > 0  # the feet touch the floor: contacts are part of the step
    assert np.array_equal(d0.qpos, d1.qpos) and np.array_equal(d0.qvel, d1.qvel)
    assert np.array_equal(d0.sensordata, d1.sensordata)


def test_measured_zmp_equals_the_cop_of_the_contact_forces(standing):
    from wbc.sim.estimated_state import EstimatedState
    from wbc.sim.walk_summary import measured_cop

    robot, sim = standing
    state = EstimatedState(sim, SensorSpecs.ideal())
    q, v = sim.get_state()
    state.reset(q, v)
    state.measure(sim, 0.0)
    zmp = state.measured_zmp()
    truth = sim.foot_contact_wrenches()
    wrench = np.array([truth["left"], truth["right"]])
    pos = np.array([sim.sole_pose(s).translation for s in ("left", "right")])
    cop = measured_cop(wrench, pos)  # from mj_contactForce, world
    assert np.linalg.norm(zmp - cop) < 1e-3


def test_read_equals_the_plain_numpy_sensor_model(standing):
    """PlantSensors.read (one compiled pass after the noise draws) against the sensor model written here with numpy:
    the same generator drawn in the same order (per IMU sample the gyro then accelerometer bias walks, then their
    white noise; per F/T sample the forces then the moments, left then right), bias walks accumulated, encoders
    rounded to their step; F/T at half the control rate. Equal to 1e-12 over 50 ticks of a perturbed state."""
    robot, sim = standing
    specs = SensorSpecs(ft=ForceTorqueSpec(rate_hz=250.0))
    sensors = PlantSensors(sim, specs, seed=7)
    enc, imu, ft = specs.encoder, specs.imu, specs.ft
    m, d = sim.model, sim.data
    adr = {name: m.sensor_adr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SENSOR, name)] for name in
           ["imu_gyro", "imu_accel"] + [f"ft_{s}_{k}" for s in ("left", "right") for k in "ft"]}
    enc_adr = [m.sensor_adr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SENSOR, f"enc_{n}")]
               for n in robot.model.names[2:]]
    rng = np.random.default_rng(7)
    bias = np.zeros(18)
    bias[0:3] = rng.normal(0.0, imu.gyro_bias_std, 3)
    bias[3:6] = rng.normal(0.0, imu.accel_bias_std, 3)
    bias[6:18].reshape(2, 6)[:, :3] = rng.normal(0.0, ft.force_bias_std, (2, 3))
    bias[6:18].reshape(2, 6)[:, 3:] = rng.normal(0.0, ft.torque_bias_std, (2, 3))
    res, h = 2 * math.pi / enc.counts_per_rev, sim.timestep
    ft_every = int(round(1.0 / (ft.rate_hz * h)))
    sample = np.zeros(18)
    rs = np.random.default_rng(11)
    worst = 0.0
    qvel0 = d.qvel.copy()
    for k in range(50):
        d.qvel[:] += rs.normal(0.0, 0.01, m.nv)
        mujoco.mj_forward(m, d)
        sd = d.sensordata
        joint_q = np.array([round(sd[a] / res) * res for a in enc_adr])
        bias[0:3] += rng.normal(0.0, imu.gyro_bias_walk * math.sqrt(h), 3)
        bias[3:6] += rng.normal(0.0, imu.accel_bias_walk * math.sqrt(h), 3)
        white_imu = np.r_[rng.normal(0.0, imu.gyro_noise_density * math.sqrt(imu.rate_hz), 3),
                          rng.normal(0.0, imu.accel_noise_density * math.sqrt(imu.rate_hz), 3)]
        sample[0:3] = sd[adr["imu_gyro"]:adr["imu_gyro"] + 3] + bias[0:3] + white_imu[0:3]
        sample[3:6] = sd[adr["imu_accel"]:adr["imu_accel"] + 3] + bias[3:6] + white_imu[3:6]
        if k % ft_every == 0:
            f_noise = rng.normal(0.0, ft.force_noise, (2, 3))
            t_noise = rng.normal(0.0, ft.torque_noise, (2, 3))
            for j, s in enumerate(("left", "right")):
                o = 6 + 6 * j
                sample[o:o + 3] = sd[adr[f"ft_{s}_f"]:adr[f"ft_{s}_f"] + 3] + bias[o:o + 3] + f_noise[j]
                sample[o + 3:o + 6] = sd[adr[f"ft_{s}_t"]:adr[f"ft_{s}_t"] + 3] + bias[o + 3:o + 6] + t_noise[j]
        r = sensors.read(k * h)
        got = np.r_[r.joint_q, r.gyro, r.accel, r.ft.ravel()]
        want = np.r_[joint_q, sample]
        worst = max(worst, float(np.max(np.abs(got - want) / np.maximum(1.0, np.abs(want)))))
    d.qvel[:] = qvel0  # (the fixture's state back)
    mujoco.mj_forward(m, d)
    assert worst < 1e-12, worst
