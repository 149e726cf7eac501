"""The floating-base estimator and its building blocks (wbc.estimation.base) against closed-form cases: the base
Kalman filter on a constant-velocity base, encoder differencing, the heading handed from sole to sole, the compiled
update against plain numpy/Pinocchio steps. Thresholds are written here."""

import functools
import math

import numpy as np
import pinocchio as pin
import pytest

from wbc.estimation import (BaseKalmanFilter, ComplementaryAttitudeFilter, ContactDetector, FloatingBaseEstimator,
                            FootForceSensor, JointStateFilter)
from wbc.exceptions import InvalidInputError
from wbc.robot import load_robot

DT = 0.002
G = 9.81


def test_constant_velocity_base_converges():
    # Base moving at 0.4 m/s along x, 0.1 m/s along y: IMU input zero acceleration (noisy), leg odometry measures
    # position and velocity (noisy); the filter starts at rest.
    rng = np.random.default_rng(2)
    vel = np.array([0.4, 0.1, 0.0])
    kf = BaseKalmanFilter(DT, sigma_acc=0.5, sigma_pos=0.002, sigma_vel=0.02)
    kf.reset(np.zeros(3), np.zeros(3))
    n = int(3.0 / DT)
    for k in range(1, n + 1):
        kf.predict(rng.normal(0, 0.1, 3))
        kf.correct(vel * k * DT + rng.normal(0, 0.001, 3), vel + rng.normal(0, 0.01, 3))
    assert np.abs(kf.velocity - vel).max() < 0.01
    assert np.abs(kf.p - vel * n * DT).max() < 0.002
    # Prediction alone (flight): a constant velocity is kept exactly with a zero acceleration input.
    kf.reset(np.zeros(3), vel)
    for _ in range(100):
        kf.predict(np.zeros(3))
    assert np.allclose(kf.velocity, vel) and np.allclose(kf.p, vel * 100 * DT)


def test_encoder_differencing_gives_the_joint_rate():
    res = 2 * math.pi / 2**19
    w = np.array([1.0, -0.5, 0.0])
    f = JointStateFilter(3, DT, cutoff_hz=80.0)
    f.reset()
    for k in range(500):
        f.update(np.round(w * k * DT / res) * res)
    # quantisation error of a difference ≤ 2 res / dt (≈ 0.012 rad/s), attenuated by the filter
    assert np.abs(f.velocity - w).max() < 2 * res / DT


def test_joint_velocity_has_no_lag_at_constant_acceleration():
    """The estimator's joint velocities with the g-h-k filter (``velocity_memory=0.5``) track a joint accelerating at 500 rad/s² (a knee at a
    jump's lift-off): closed form q̇ = a t from 19-bit quantised angles q = ½ a t². A backward difference with an
    80 Hz low-pass lags it by (Δt/2 + 1/(2π 80 Hz)) a ≈ 1.5 rad/s."""
    robot = load_robot("g1")
    est = FloatingBaseEstimator(robot, DT, velocity_memory=0.5)
    n = robot.model.nv - 6
    res = 2 * math.pi / 2**19
    acc = 500.0 * np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    est.joints.reset(np.zeros(n), np.zeros(n))
    for k in range(1, 41):  # 0.08 s
        t = k * DT
        v = est.joints.update(np.round(0.5 * acc * t * t / res) * res)
    # after 20 samples the start transient is gone; quantisation error of the rate ≲ 2 res / DT ≈ 0.012 rad/s
    assert np.abs(v - acc * 40 * DT).max() < 0.05


def test_joint_velocity_memory_out_of_range():
    with pytest.raises(InvalidInputError, match="memory"):
        JointStateFilter(3, DT, memory=1.0)


def test_floating_base_estimator_update_keeps_the_c_heap_flat():
    """5000 updates of FloatingBaseEstimator (one per 2 ms tick: 10 s) must not grow the C heap (glibc's mallinfo2:
    bytes in use plus mmapped): a 500 Hz node runs it for hours. The base quaternion was built with
    pin.Quaternion(R), which leaked 80 B per call (400 kB here, 2.4 MB per minute of a node). Checked against the
    rotation the filter holds (the quaternion read back to a matrix by Pinocchio). The least growth of three such
    windows is asserted: in a CI worker, another test's thread may allocate during one (32.8 kB once, in one window)."""
    import ctypes
    import ctypes.util
    import gc

    from wbc.estimation import FloatingBaseEstimator

    libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
    if not hasattr(libc, "mallinfo2"):
        pytest.skip("needs glibc >= 2.33 (mallinfo2) to read the C heap")

    class MallInfo2(ctypes.Structure):
        _fields_ = [(n, ctypes.c_size_t) for n in ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks",
                                                   "fsmblks", "uordblks", "fordblks", "keepcost")]

    libc.mallinfo2.restype = MallInfo2

    def c_heap_in_use():
        gc.collect()
        m = libc.mallinfo2()
        return m.uordblks + m.hblkhd

    robot = load_robot("humanoid15")
    est = FloatingBaseEstimator(robot, DT)
    est.reset(robot.q_ref)
    joint_q = robot.q_ref[7:].copy()
    gyro = np.array([0.01, -0.02, 0.03])
    accel = np.array([0.0, 0.0, G])
    ft = np.zeros((2, 6))
    ft[:, 2] = -0.5 * robot.mass * G  # (sensor reading of the ground reaction: minus the force on the foot)
    for _ in range(100):
        est.update(joint_q, gyro, accel, ft)
    grown = []  # three windows: a leak grows the heap in each, another thread of the test process only in some
    for _ in range(3):
        before = c_heap_in_use()
        for _ in range(5000):
            q, _ = est.update(joint_q, gyro, accel, ft)
        grown.append(c_heap_in_use() - before)
    print(f"C heap in use grew by {grown} B over three windows of 5000 updates")
    assert min(grown) < 20_000  # 4 B per update (the leak was 80: 400 kB a window)
    R = pin.Quaternion(q[6], q[3], q[4], q[5]).toRotationMatrix()
    assert np.allclose(R, est.attitude.rotation, atol=1e-12)
    assert abs(np.linalg.norm(q[3:7]) - 1.0) < 1e-12


def _talos_standing_level():
    """Talos in its reference posture with the base turned so that both soles are level: (robot, q0 (nq,), R0 (3, 3)
    the base orientation, joint angles (nv − 6,))."""
    robot = load_robot("talos")
    model = robot.model
    q0 = robot.q_ref.copy()
    data = model.createData()
    pin.framesForwardKinematics(model, data, q0)
    n = data.oMf[model.getFrameId(robot.left_sole)].rotation[:, 2]
    quat = pin.Quaternion.FromTwoVectors(n, np.array([0.0, 0.0, 1.0]))
    q0[3:7] = quat.coeffs()
    joints = np.array([q0[model.joints[j].idx_q] for j in range(2, model.njoints)])
    return robot, q0, quat.toRotationMatrix(), joints


def _ft_reading(robot, sole: str, load: float) -> np.ndarray:
    """(6,) F/T reading of ``sole``'s ankle sensor with the sole level (sensor axes = world axes) carrying ``load``
    newtons, the foot below the sensor static (its weight compensated as FootForceSensor assumes)."""
    s = FootForceSensor(robot, sole)
    mg = s.mass * np.array([0.0, 0.0, -G])
    Fs = -np.array([0.0, 0.0, load]) - mg
    return np.r_[Fs, np.cross(s.sole_in_sensor, Fs) - np.cross(s.com_in_sensor - s.sole_in_sensor, mg)]


def _shift_weight_foot_to_foot(robot, est, joints, gyro, accel, seconds: float = 20.0) -> np.ndarray:
    """Run ``est`` on a robot standing still on level soles whose weight moves both → left → both → right, 0.5 s
    each (each foot unloaded and re-anchored every 2 s), with constant encoder, gyro and accelerometer readings, for
    ``seconds`` → the last estimated configuration q (nq,)."""
    reading = functools.partial(_ft_reading, robot)
    W = robot.mass * G
    both = np.array([reading(robot.left_sole, W / 2), reading(robot.right_sole, W / 2)])
    left = np.array([reading(robot.left_sole, W), reading(robot.right_sole, 0.0)])
    right = np.array([reading(robot.left_sole, 0.0), reading(robot.right_sole, W)])
    for cycle in range(int(round(seconds / 0.5))):
        ft = (both, left, both, right)[cycle % 4]
        for _ in range(int(0.5 / DT)):
            q, _ = est.update(joints, gyro, accel, ft)
    return q


@pytest.mark.parametrize("ground_height", [0.0, None], ids=["flat", "uneven"])
def test_heading_passes_from_sole_to_sole_without_the_gyro_drift(ground_height):
    """Talos standing still, soles level, the weight shifted from foot to foot every 0.5 s (each foot is unloaded
    and re-anchored 10 times), gyro biased about the vertical by b_z, no bias integration: with the hand-over the
    heading of each re-anchored sole comes from the other sole through the kinematics, so the yaw error stays at
    the equilibrium of eq. 32a, b_z / (k_P k_heading) (the yaw-only heading gains off); without it each new anchor
    takes R̂'s yaw, whose error then grows with the integral of b_z (b_z t = 2.3° after 20 s). The same on flat
    ground of known height (the soles' axes held horizontal) and on uneven ground (``ground_height=None``: the
    heading is handed over, the tilt stays R̂'s)."""
    from wbc.estimation import FloatingBaseEstimator

    robot, q0, R0, joints = _talos_standing_level()
    accel = R0.T @ np.array([0.0, 0.0, G])
    b_z, k_p = 0.002, 0.2
    gyro = R0.T @ np.array([0.0, 0.0, b_z])
    yaw = {}
    for handover in (True, False):
        est = FloatingBaseEstimator(robot, DT, k_p=k_p, k_i=0.0, heading_weight=1.0, heading_handover=handover,
                                    k_heading=0.0, k_heading_bias=0.0, ground_height=ground_height)
        est.reset(q0)
        q = _shift_weight_foot_to_foot(robot, est, joints, gyro, accel)
        R = pin.Quaternion(q[6], q[3], q[4], q[5]).toRotationMatrix()
        yaw[handover] = abs(float(pin.log3(R @ R0.T)[2]))
    assert yaw[True] <= 1.1 * b_z / k_p, math.degrees(yaw[True])
    assert yaw[False] >= 2.0 * b_z / k_p, math.degrees(yaw[False])  # the drift the hand-over removes
    with pytest.raises(InvalidInputError, match="heading_handover"):
        FloatingBaseEstimator(robot, DT, heading_handover="yes")


def test_uneven_ground_hands_over_the_heading_not_the_tilt():
    """Talos standing still with soles level, weight shifted from foot to foot every 0.5 s, on uneven ground
    (``ground_height=None``), the estimate started with a 2° pitch error (``reset`` with a pitched base). The
    accelerometer pulls the pitch back (k_P = 0.2 rad/s); a hand-over that passed each anchored sole's whole
    orientation to the next would pass the pitch error of the first anchors (their forward axes tilted with it) on
    from sole to sole, and those axes hold R̂ back. With the heading only handed over, the tilt error decays as
    without the hand-over: after 20 s both are below 0.1° (the accelerometer alone: 2° e^(−0.2·20) = 0.04°;
    a whole-orientation hand-over keeps 1.0°)."""
    robot, q0, R0, joints = _talos_standing_level()
    accel = R0.T @ np.array([0.0, 0.0, G])
    q_wrong = q0.copy()
    q_wrong[3:7] = pin.Quaternion(pin.rpy.rpyToMatrix(0.0, math.radians(2.0), 0.0) @ R0).coeffs()
    tilt = {}
    for handover in (True, False):
        est = FloatingBaseEstimator(robot, DT, k_p=0.2, k_i=0.0, heading_handover=handover, ground_height=None)
        est.reset(q_wrong)
        q = _shift_weight_foot_to_foot(robot, est, joints, np.zeros(3), accel)
        R = pin.Quaternion(q[6], q[3], q[4], q[5]).toRotationMatrix()
        tilt[handover] = math.degrees(float(np.linalg.norm(pin.log3(R @ R0.T)[:2])))
    assert tilt[True] < 0.1 and tilt[False] < 0.1, tilt


def test_heading_hand_over_follows_a_sole_settling_under_load():
    """Talos standing still, base level and fixed, soles level. The left sole lifts off, lands carrying 70 % of the
    weight from its first sample and then turns by 0.5° about the vertical over 0.1 s (its hip yaw joint turns, the
    base does not: the gyro reads 0); then the right sole lifts off. The left sole's heading comes from the right
    sole through the kinematics for as long as both are in contact, so it includes the turn and the base yaw stays
    right (< 0.05°); a hand-over that ends when the new sole carries the larger share (``handover_end_share=0.5``)
    locks the first sample's heading, and the filter then turns the base yaw by the 0.5° the sole settled (> 0.3°
    after 3 s on the left sole alone)."""
    from wbc.estimation import FloatingBaseEstimator

    robot, q0, R0, joints0 = _talos_standing_level()
    hip_yaw = robot.model.joints[robot.model.getJointId("leg_left_1_joint")].idx_v - 6
    reading = functools.partial(_ft_reading, robot)

    W = robot.mass * G
    ft = {(a, b): np.array([reading(robot.left_sole, a * W), reading(robot.right_sole, b * W)])
          for a, b in ((0.5, 0.5), (0.0, 1.0), (0.7, 0.3), (1.0, 0.0))}
    accel = R0.T @ np.array([0.0, 0.0, G])
    turn = math.radians(0.5)
    yaw = {}
    for share in (0.0, 0.5):
        # turn_rate off: the sole's 5°/s settling turn would otherwise re-anchor it from R̂ (the gyro reads 0 here)
        est = FloatingBaseEstimator(robot, DT, handover_end_share=share, turn_rate=1e3)
        est.reset(q0)
        joints = joints0.copy()
        plan = [((0.5, 0.5), 0.5), ((0.0, 1.0), 0.5), ((0.7, 0.3), 0.2), ((1.0, 0.0), 3.0)]
        for loads, duration in plan:
            for k in range(int(round(duration / DT))):
                if loads == (0.7, 0.3):  # the landed left sole settles: its hip yaw turns 0.5° over 0.1 s
                    joints[hip_yaw] = joints0[hip_yaw] + turn * min(1.0, (k + 1) * DT / 0.1)
                q, _ = est.update(joints, np.zeros(3), accel, ft[loads])
        R = pin.Quaternion(q[6], q[3], q[4], q[5]).toRotationMatrix()
        yaw[share] = abs(math.degrees(float(pin.log3(R @ R0.T)[2])))
    assert yaw[0.0] < 0.05, yaw
    assert yaw[0.5] > 0.3, yaw  # the settling turn locked in by the early end
    with pytest.raises(InvalidInputError, match="handover_end_share"):
        FloatingBaseEstimator(robot, DT, handover_end_share=1.0)


def test_soles_pivoting_on_the_ground_are_reanchored_from_the_gyro():
    """Talos standing on both level soles, the whole robot pivots about the vertical by 3° in 0.3 s (as its soles do
    on a jump's landing: the impact turns the feet on the ground, no still sole is left to hand the heading over
    from), then stands still for 3 s. The gyro reads the turn; the encoders and the F/T readings do not change. A
    sole whose world yaw rate (gyro + leg kinematics) exceeds ``turn_rate`` is re-anchored from R̂ on every sample,
    so the estimated yaw ends at the true 3° (error < 0.1°); soles anchored once pull the estimate back towards
    their stale heading (error > 1° after 3 s)."""
    from wbc.estimation import FloatingBaseEstimator

    robot, q0, R0, joints = _talos_standing_level()
    W = robot.mass * G
    both = np.array([_ft_reading(robot, robot.left_sole, W / 2), _ft_reading(robot, robot.right_sole, W / 2)])
    accel = R0.T @ np.array([0.0, 0.0, G])
    turn, t_turn = math.radians(3.0), 0.3
    gyro_turn = R0.T @ np.array([0.0, 0.0, turn / t_turn])  # about the world vertical, in IMU axes
    R_true = pin.exp3(np.array([0.0, 0.0, turn])) @ R0
    err = {}
    for rate in (0.05, 1e3):  # 1e3 rad/s: never turning (the rule off)
        est = FloatingBaseEstimator(robot, DT, turn_rate=rate)
        est.reset(q0)
        for k in range(int(round(3.8 / DT))):
            moving = 0.5 <= k * DT < 0.5 + t_turn
            q, _ = est.update(joints, gyro_turn if moving else np.zeros(3), accel, both)
        R = pin.Quaternion(q[6], q[3], q[4], q[5]).toRotationMatrix()
        err[rate] = abs(math.degrees(float(pin.log3(R @ R_true.T)[2])))
    assert err[0.05] < 0.1, err
    assert err[1e3] > 1.0, err  # the stale anchors win without the rule
    with pytest.raises(InvalidInputError, match="turn_rate"):
        FloatingBaseEstimator(robot, DT, turn_rate=0.0)


class _PlainEstimator:
    """FloatingBaseEstimator.update written with numpy and Pinocchio one step at a time (the module docstring's
    steps 1-4, the building blocks' Python methods: ComplementaryAttitudeFilter.update with pin.exp3,
    BaseKalmanFilter.predict/correct, FootForceSensor.ground_wrench, ContactDetector), the reference of the
    compiled update."""

    def __init__(self, robot, dt, q0, ground_height, handover, turn_rate, **gains):
        self.model, self.data, self.dt = robot.model, robot.model.createData(), dt
        est = FloatingBaseEstimator(robot, dt, ground_height=ground_height, heading_handover=handover,
                                    turn_rate=turn_rate, **gains)  # its numbers (gains, thresholds, corners)
        self.att = ComplementaryAttitudeFilter(dt, k_p=est.attitude.k_p, k_i=est.attitude.k_i,
                                               accel_gate=est.attitude.accel_gate, k_heading=est.attitude.k_heading,
                                               k_heading_bias=est.attitude.k_heading_bias)
        self.kf = BaseKalmanFilter(dt)
        self.det = [ContactDetector(est.detectors[s].on, est.detectors[s].off) for s in ("left", "right")]
        self.ft = [FootForceSensor(robot, robot.left_sole), FootForceSensor(robot, robot.right_sole)]
        self.alpha, self.beta, self.alpha_turn = est.joints.alpha, est._beta, est._alpha_turn
        self.gh, self.handover, self.turn_rate, self.hw = ground_height, handover, turn_rate, est.heading_weight
        R = pin.Quaternion(q0[6], q0[3], q0[4], q0[5]).toRotationMatrix()
        self.att.reset(R)
        self.kf.reset(q0[0:3], np.zeros(3))
        self.prev, self.vj = q0[7:].copy(), np.zeros(self.model.nv - 6)
        self.qk = pin.neutral(self.model)
        self.contact, self.turning, self.frm = [False, False], [False, False], [None, None]
        self.yaw, self.acc, self.zv_prev, self.have_zv = np.zeros(2), np.zeros(3), np.zeros(3), False
        self.anchor, self.axis = np.zeros((2, 3)), np.tile([1.0, 0.0, 0.0], (2, 1))
        self.arot = np.array([np.eye(3), np.eye(3)])

    def update(self, joint_q, gyro, accel, ft):
        model, data, dt, att, kf = self.model, self.data, self.dt, self.att, self.kf
        self.vj = self.vj + self.alpha * ((joint_q - self.prev) / dt - self.vj)
        self.prev = joint_q.copy()
        self.qk[7:] = joint_q
        pin.forwardKinematics(model, data, self.qk, np.r_[np.zeros(3), gyro - att.bias, self.vj])
        Rp = att.rotation.copy()
        rot, pos, u, fz = [], [], [], [0.0, 0.0]
        wrench = np.zeros((2, 6))
        zv, fz_total = np.zeros(3), 0.0
        for j in range(2):
            X = pin.updateFramePlacement(model, data, self.ft[j].frame_id).copy()
            rot.append(X.rotation)
            pos.append(X.translation)
            Rw = Rp @ X.rotation
            wrench[j] = self.ft[j].ground_wrench(ft[j], Rw)
            fz[j] = float(Rw[2] @ wrench[j, 0:3])
            vel = pin.getFrameVelocity(model, data, self.ft[j].frame_id, pin.LOCAL_WORLD_ALIGNED)
            u.append(vel.linear.copy())
            self.yaw[j] += self.alpha_turn * (float(Rp[2] @ vel.angular) - self.yaw[j])
            self.turning[j] = abs(self.yaw[j]) > self.turn_rate
            if self.contact[j] and fz[j] > 0:
                zv -= fz[j] * u[j]
                fz_total += fz[j]
        if fz_total > 0:
            zw = Rp @ (zv / fz_total)
            if self.have_zv:
                self.acc = self.acc + self.beta * ((zw - self.zv_prev) / dt - self.acc)
            self.zv_prev, self.have_zv = zw, True
        else:
            self.have_zv = False
            self.acc = self.acc * (1.0 - self.beta)
        dirs = [(self.axis[j].copy(), rot[j][:, 0], self.hw * fz[j] / fz_total) for j in range(2)
                if self.hw > 0 and fz_total > 0 and self.contact[j] and fz[j] > 0]
        att.update(gyro, accel - Rp.T @ self.acc, dirs, heading=dirs)
        R = att.rotation
        kf.predict(R @ accel + np.array([0.0, 0.0, -9.81]))
        zp, zvw, total, newly, r = np.zeros(3), np.zeros(3), 0.0, [], [R @ pos[0], R @ pos[1]]
        for j in range(2):
            was, now = self.contact[j], self.det[j].update(fz[j])
            self.contact[j] = now
            if now and not was:
                newly.append(j)
            if now and was:
                w = max(fz[j], 0.0)
                zp += w * (self.anchor[j] - r[j])
                zvw -= w * (R @ u[j])
                total += w
        if total > 0:
            kf.correct(zp / total, zvw / total)
        for j in newly:
            self.anchor[j] = kf.p + r[j]
            self.frm[j] = None
            axis = R @ rot[j][:, 0]
            if self.gh is not None:
                self.anchor[j, 2], axis[2] = self.gh, 0.0
            else:
                self.arot[j] = R @ rot[j]
            if self.handover and self.contact[1 - j] and self.frm[1 - j] is None:
                self.frm[j] = 1 - j
            self.axis[j] = axis / np.linalg.norm(axis)
        for j in range(2):
            if self.contact[j] and self.turning[j] and self.frm[j] is None:
                axis = R @ rot[j][:, 0]
                if self.gh is not None:
                    axis[2] = 0.0
                else:
                    self.arot[j] = R @ rot[j]
                self.axis[j] = axis / np.linalg.norm(axis)
        for j in range(2):
            o = self.frm[j]
            if o is None:
                continue
            if not (self.contact[j] and self.contact[o]):
                self.frm[j] = None
                continue
            rel = rot[o].T @ rot[j][:, 0]
            if self.gh is not None:
                ca, sa = self.axis[o, 0], self.axis[o, 1]
                axis = np.array([ca * rel[0] - sa * rel[1], sa * rel[0] + ca * rel[1], 0.0])
            else:
                chain = self.arot[o] @ rel
                Rs = R @ rot[j]
                turn = math.atan2(chain[1], chain[0]) - math.atan2(Rs[1, 0], Rs[0, 0])
                Rs = pin.rpy.rpyToMatrix(0.0, 0.0, turn) @ Rs
                self.arot[j] = Rs
                axis = Rs[:, 0].copy()
            self.axis[j] = axis / np.linalg.norm(axis)
            if max(fz[o], 0.0) <= 0.0:
                self.frm[j] = None
        q = np.r_[kf.p, pin.Quaternion(R).coeffs(), joint_q]
        v = np.r_[R.T @ kf.velocity, att.omega, self.vj]
        soles = [(R @ rot[j], r[j] + kf.p) for j in range(2)]
        return q, v, wrench, fz, list(self.contact), soles


@pytest.mark.parametrize("ground_height", [0.0, None], ids=["flat", "uneven"])
def test_compiled_update_matches_the_plain_numpy_pinocchio_steps(ground_height):
    """FloatingBaseEstimator.update (one compiled kernel after Pinocchio's leg kinematics) against
    :class:`_PlainEstimator` on 1.6 s of Talos shifting its weight from foot to foot (contacts made and broken,
    the heading handed over) with swaying joints, noisy gyro and accelerometer readings and a yaw rate that makes
    the soles count as turning: q, v, the wrenches, normal forces, contacts and sole placements agree to 1e-12
    (relative to values above 1) on every sample."""
    robot, q0, R0, joints0 = _talos_standing_level()
    rng = np.random.default_rng(3)
    gains = dict(k_i=0.02, k_heading=0.5, k_heading_bias=0.1)
    est = FloatingBaseEstimator(robot, DT, ground_height=ground_height, turn_rate=0.02, **gains)
    est.reset(q0)
    ref = _PlainEstimator(robot, DT, q0, ground_height, True, 0.02, **gains)
    W = robot.mass * G
    worst, n_contact_changes, last = 0.0, 0, None
    for k in range(800):
        phase = (k // 100) % 4
        share = (0.5, 0.9, 0.5, 0.1)[phase]
        ft = np.array([_ft_reading(robot, robot.left_sole, share * W), _ft_reading(robot, robot.right_sole,
                                                                                  (1 - share) * W)])
        ft[:, 2] *= (phase in (1, 3)) * np.array([share > 0.5, share < 0.5]) + (phase in (0, 2))  # unload a foot
        ft += rng.normal(0.0, 0.5, ft.shape)
        joints = joints0 + 0.02 * np.sin(0.01 * k + np.arange(len(joints0)))
        gyro = R0.T @ np.array([0.0, 0.0, 0.05]) + rng.normal(0.0, 1e-3, 3)
        accel = R0.T @ np.array([0.0, 0.0, G]) + rng.normal(0.0, 0.05, 3)
        q, v = est.update(joints, gyro, accel, ft)
        rq, rv, rw, rfz, rc, rs = ref.update(joints, gyro, accel, ft)
        if rq[6] * q[6] < 0:
            rq[3:7] *= -1.0
        assert [est.contact["left"], est.contact["right"]] == rc
        n_contact_changes += last is not None and rc != last
        last = rc
        for a, b in ((q, rq), (v, rv), (est.wrench, rw), (np.array([est.normal_force["left"],
                                                                     est.normal_force["right"]]), np.array(rfz))):
            worst = max(worst, float(np.max(np.abs(a - b) / np.maximum(1.0, np.abs(b)))))
        for j, side in enumerate(("left", "right")):
            worst = max(worst, float(np.max(np.abs(est.sole[side].rotation - rs[j][0]))),
                        float(np.max(np.abs(est.sole[side].translation - rs[j][1]))))
    assert n_contact_changes >= 4, n_contact_changes
    assert worst < 1e-12, worst


def test_detector_thresholds_and_kalman_noise_changed_after_construction_take_effect():
    """The compiled update reads the contact detectors' thresholds and the Kalman filter's Q and R every sample: a
    left detector whose ``on`` is raised above the load after construction never closes its contact (the right one,
    unchanged, does), and a filter given another R after construction follows the plain steps' filter given it at
    once (1e-12)."""
    robot, q0, _R0, joints = _talos_standing_level()
    W = robot.mass * G
    ft = np.array([_ft_reading(robot, robot.left_sole, W / 2), _ft_reading(robot, robot.right_sole, W / 2)])
    gyro, accel = np.zeros(3), np.array([0.0, 0.0, G])
    est = FloatingBaseEstimator(robot, DT)
    est.reset(q0)
    est.detectors["left"].on = 2.0 * W  # more than the foot ever carries
    for _ in range(50):
        est.update(joints, gyro, accel, ft)
    assert est.contact == {"left": False, "right": True}
    # R changed after construction: the same answer as an estimator built with it
    other = FloatingBaseEstimator(robot, DT)
    a, b = FloatingBaseEstimator(robot, DT), FloatingBaseEstimator(robot, DT)
    R_new = np.diag([1e-2, 4e-2])
    a.kf.R = R_new.copy()
    b.kf.R[:] = R_new
    for e in (a, b, other):
        e.reset(q0)
    rng = np.random.default_rng(3)
    for _ in range(200):
        acc = accel + rng.normal(0.0, 0.3, 3)
        qa, va = (x.copy() for x in a.update(joints, gyro, acc, ft))
        qb, vb = (x.copy() for x in b.update(joints, gyro, acc, ft))
        qo, _ = other.update(joints, gyro, acc, ft)
        assert np.allclose(qa, qb, rtol=0, atol=1e-12) and np.allclose(va, vb, rtol=0, atol=1e-12)
    assert np.max(np.abs(qa[:3] - qo[:3])) > 1e-9  # the new R changed the estimate
