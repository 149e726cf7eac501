"""The compiled estimator (wbc.estimation.kernels, run through FloatingBaseEstimator.update) against a plain
numpy/Pinocchio reference of the same equations written here, fed the same sensor readings on every tick (Talos,
soles loaded and unloaded in turn, turning soles, flat and uneven ground, both joint-velocity filters), and the
small kernels against Pinocchio (exp3, the quaternion of SE3ToXYZQUAT). Tolerances are written here."""

import math

import numpy as np
import pinocchio as pin
import pytest

from wbc.estimation import (BaseKalmanFilter, ComplementaryAttitudeFilter, FloatingBaseEstimator, FootForceSensor,
                            JointStateFilter)
from wbc.estimation.kernels import exp3, rotation_quaternion
from wbc.exceptions import InvalidInputError
from wbc.robot import load_robot

DT = 0.002
G = 9.81
SIDES = ("left", "right")
TOL = 1e-12  # relative, absolute for values below 1


def _close(a, b) -> bool:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return bool(np.all(np.abs(a - b) <= TOL * np.maximum(1.0, np.abs(b))))


class Reference:
    """FloatingBaseEstimator.update in plain numpy (wbc/estimation/base.py module docstring), default options but
    ``ground_height`` and ``velocity_memory``."""

    def __init__(self, robot, ground_height, memory):
        self.model, self.data = robot.model, robot.model.createData()
        self.gh, self.memory = ground_height, memory
        w = robot.mass * robot.gravity
        self.on, self.off = 0.2 * w, 0.08 * w
        self.ft = [FootForceSensor(robot, getattr(robot, f"{s}_sole")) for s in SIDES]
        self.alpha = DT / (DT + 1.0 / (2.0 * math.pi * 80.0))
        self.beta = DT / (DT + 1.0 / (2.0 * math.pi * 10.0))
        self.alpha_turn = DT / (DT + 1.0 / (2.0 * math.pi * 10.0))
        th = 0.0 if memory is None else memory
        self.g, self.h, self.k = 1.0 - th**3, 1.5 * (1.0 - th) ** 2 * (1.0 + th), 0.5 * (1.0 - th) ** 3
        self.Q = 0.5**2 * np.array([[DT**4 / 4, DT**3 / 2], [DT**3 / 2, DT**2]])
        self.Rn = np.diag([0.002**2, 0.02**2])

    def reset(self, q0, joints):
        quat = q0[3:7] / np.linalg.norm(q0[3:7])
        self.R = pin.Quaternion(quat[3], quat[0], quat[1], quat[2]).toRotationMatrix()
        self.bias = np.zeros(3)
        self.p, self.pd, self.P = q0[0:3].copy(), np.zeros(3), np.diag([1e-6, 1e-4])
        self.x, self.vj, self.aj = joints.copy(), np.zeros(len(joints)), np.zeros(len(joints))
        self.acc_kin, self.zv_prev, self.have_zv = np.zeros(3), np.zeros(3), False
        self.contact, self.turning, self.yaw = [False, False], [False, False], np.zeros(2)
        self.handover = [None, None]
        self.anchor, self.axis = np.zeros((2, 3)), np.array([[1.0, 0, 0], [1.0, 0, 0]])
        self.anchor_rot = np.array([np.eye(3), np.eye(3)])

    def attitude(self, gyro, accel, dirs):
        n = np.linalg.norm(accel)
        used = n > 0 and abs(n - G) <= 2.0
        wm = np.cross(accel / n, self.R[2]) if used else np.zeros(3)
        wh = np.zeros(3)
        for v0, v, k in dirs:
            c = k * np.cross(v, self.R.T @ v0)
            wm, wh = wm + c, wh + c
        wh = (wh @ self.R[2]) * self.R[2]
        omega = gyro - self.bias
        self.R = self.R @ pin.exp3((wm * 0.2 + omega + 0.5 * wh) * DT)
        if used and wm @ wm <= 0.02**2:
            self.bias = self.bias - 0.01 * DT * wm
        if wh @ wh <= 0.02**2:
            self.bias = self.bias - 0.1 * DT * wh
        self.bias = np.clip(self.bias, -0.05, 0.05)
        return omega

    def update(self, joint_q, gyro, accel, ft):
        model, data = self.model, self.data
        if self.memory is None:
            self.vj = self.vj + self.alpha * ((joint_q - self.x) / DT - self.vj)
            self.x = joint_q.copy()
        else:
            self.x = self.x + self.vj * DT + 0.5 * DT * DT * self.aj
            self.vj = self.vj + self.aj * DT
            r = joint_q - self.x
            self.x, self.vj, self.aj = self.x + self.g * r, self.vj + self.h / DT * r, self.aj + 2 * self.k / DT**2 * r
        qk = pin.neutral(model)
        qk[7:] = joint_q  # Talos: 1-DoF joints in v order
        vk = np.r_[0.0, 0.0, 0.0, gyro - self.bias, self.vj]
        pin.forwardKinematics(model, data, qk, vk)
        R0 = self.R
        rot, pos, lin, fzs, wrench = [], [], [], np.zeros(2), np.zeros((2, 6))
        zv, total = np.zeros(3), 0.0
        for j, sensor in enumerate(self.ft):
            X = pin.updateFramePlacement(model, data, sensor.frame_id)
            rot.append(X.rotation.copy())
            pos.append(X.translation.copy())
            Rw = R0 @ rot[j]
            mg = sensor.mass * Rw.T @ np.array([0.0, 0.0, -G])
            p, c = sensor.sole_in_sensor, sensor.com_in_sensor
            wrench[j] = np.r_[-ft[j, 0:3] - mg, -ft[j, 3:6] + np.cross(p, ft[j, 0:3]) - np.cross(c - p, mg)]
            fzs[j] = Rw[2] @ wrench[j, 0:3]
            vel = pin.getFrameVelocity(model, data, sensor.frame_id, pin.LOCAL_WORLD_ALIGNED)
            lin.append(vel.linear.copy())
            self.yaw[j] += self.alpha_turn * (R0[2] @ vel.angular - self.yaw[j])
            self.turning[j] = abs(self.yaw[j]) > 0.05
            if self.contact[j] and fzs[j] > 0:
                zv, total = zv - fzs[j] * lin[j], total + fzs[j]
        if total > 0:
            zw = R0 @ (zv / total)
            if self.have_zv:
                self.acc_kin = self.acc_kin + self.beta * ((zw - self.zv_prev) / DT - self.acc_kin)
            self.zv_prev, self.have_zv = zw, True
        else:
            self.have_zv, self.acc_kin = False, self.acc_kin * (1.0 - self.beta)
        dirs = [(self.axis[j].copy(), rot[j][:, 0], fzs[j] / total) for j in range(2)
                if total > 0 and self.contact[j] and fzs[j] > 0]
        omega = self.attitude(gyro, accel - R0.T @ self.acc_kin, dirs)
        R = self.R
        a = R @ accel + np.array([0.0, 0.0, -G])
        self.p, self.pd = self.p + self.pd * DT + 0.5 * DT * DT * a, self.pd + a * DT
        A = np.array([[1.0, DT], [0.0, 1.0]])
        self.P = A @ self.P @ A.T + self.Q
        zp, zvw, wsum, newly = np.zeros(3), np.zeros(3), 0.0, []
        r_world = [R @ pos[j] for j in range(2)]
        for j in range(2):
            was = self.contact[j]
            now = fzs[j] >= self.off if was else fzs[j] > self.on
            self.contact[j] = now
            if now and not was:
                newly.append(j)
            if now and was:
                w = max(fzs[j], 0.0)
                zp, zvw, wsum = zp + w * (self.anchor[j] - r_world[j]), zvw - w * (R @ lin[j]), wsum + w
        if wsum > 0:
            K = self.P @ np.linalg.inv(self.P + self.Rn)
            ep, ev = zp / wsum - self.p, zvw / wsum - self.pd
            self.p, self.pd = self.p + K[0, 0] * ep + K[0, 1] * ev, self.pd + K[1, 0] * ep + K[1, 1] * ev
            self.P = (np.eye(2) - K) @ self.P
        for j in newly:
            self.anchor[j] = self.p + r_world[j]
            self.handover[j] = None
            axis = R @ rot[j][:, 0]
            if self.gh is not None:
                self.anchor[j, 2], axis[2] = self.gh, 0.0
            else:
                self.anchor_rot[j] = R @ rot[j]
            if self.contact[1 - j] and self.handover[1 - j] is None:
                self.handover[j] = 1 - j
            self.axis[j] = axis / np.linalg.norm(axis)
        for j in range(2):
            if self.contact[j] and self.turning[j] and self.handover[j] is None:
                axis = R @ rot[j][:, 0]
                if self.gh is not None:
                    axis[2] = 0.0
                else:
                    self.anchor_rot[j] = R @ rot[j]
                self.axis[j] = axis / np.linalg.norm(axis)
        for j in range(2):
            o = self.handover[j]
            if o is None:
                continue
            if not (self.contact[j] and self.contact[o]):
                self.handover[j] = None
                continue
            if self.gh is not None:
                rel = rot[o].T @ rot[j][:, 0]
                ca, sa = self.axis[o, 0], self.axis[o, 1]
                axis = np.array([ca * rel[0] - sa * rel[1], sa * rel[0] + ca * rel[1], 0.0])
            else:
                chain = self.anchor_rot[o] @ (rot[o].T @ rot[j][:, 0])
                Rs = R @ rot[j]
                turn = math.atan2(chain[1], chain[0]) - math.atan2(Rs[1, 0], Rs[0, 0])
                Rs = pin.rpy.rpyToMatrix(0.0, 0.0, turn) @ Rs
                self.anchor_rot[j] = Rs
                axis = Rs[:, 0].copy()
            self.axis[j] = axis / np.linalg.norm(axis)
            if max(fzs[o], 0.0) <= 0.0:
                self.handover[j] = None
        soles = [(R @ rot[j], r_world[j] + self.p) for j in range(2)]
        q = np.r_[self.p, pin.SE3ToXYZQUAT(pin.SE3(R, np.zeros(3)))[3:], joint_q]
        v = np.r_[R.T @ self.pd, omega, self.vj]
        return q, v, wrench, fzs, soles


def _ft_reading(sensor, load, moment):
    """(6,) F/T reading of a level sole (sensor axes = world axes) carrying ``load`` N with the ground moment
    ``moment`` (2,) about its sole origin; the foot's weight as FootForceSensor compensates it."""
    mg = sensor.mass * np.array([0.0, 0.0, -G])
    Fs = -np.array([0.0, 0.0, load]) - mg
    return np.r_[Fs, np.cross(sensor.sole_in_sensor, Fs) - np.cross(sensor.com_in_sensor - sensor.sole_in_sensor, mg)
                 - np.r_[moment, 0.0]]


@pytest.mark.parametrize("ground_height, memory", [(0.0, None), (None, 0.5)], ids=["flat-lowpass", "uneven-ghk"])
def test_compiled_estimator_matches_the_numpy_reference_tick_by_tick(ground_height, memory):
    """3 s of synthetic readings: joints moving, gyro turning about every axis (the soles' yaw rate crosses
    ``turn_rate``), accelerometer noisy, the weight passed left → both → right → flight → both with noisy
    moments (contact changes, hand-overs, re-anchoring). Every tick: q, v, wrenches, normal forces, contact and
    turning flags and sole placements equal the reference to 1e-12."""
    robot = load_robot("talos")
    model = robot.model
    rng = np.random.default_rng(7)
    est = FloatingBaseEstimator(robot, DT, ground_height=ground_height, velocity_memory=memory)
    ref = Reference(robot, ground_height, memory)
    q0 = robot.q_ref.copy()
    joints0 = q0[7:].copy()
    est.reset(q0)
    ref.reset(q0, joints0)
    sensors = [FootForceSensor(robot, getattr(robot, f"{s}_sole")) for s in SIDES]
    W = robot.mass * G
    shares = [(1.0, 0.0), (0.5, 0.5), (0.0, 1.0), (0.0, 0.0), (0.5, 0.5), (0.9, 0.1)]
    seen = {"contact change": 0, "turning": 0, "handover": 0}
    for k in range(1500):
        t = k * DT
        joint_q = joints0 + 0.02 * np.sin(2 * math.pi * 0.7 * t + np.arange(model.nv - 6))
        gyro = np.array([0.05 * math.sin(3 * t), 0.04 * math.cos(2 * t), 0.3 * math.sin(4 * t)])
        gyro += rng.normal(0, 1e-3, 3)
        accel = np.array([0.0, 0.0, G]) + rng.normal(0, 0.05, 3)
        share = shares[(k // 100) % len(shares)]
        ft = np.array([_ft_reading(s, f * W, rng.normal(0, 5.0, 2)) for s, f in zip(sensors, share)])
        before = dict(est.contact)
        q, v = est.update(joint_q, gyro, accel, ft)
        rq, rv, rw, rf, rsoles = ref.update(joint_q, gyro, accel, ft)
        seen["contact change"] += before != est.contact
        seen["turning"] += any(est.turning.values())
        seen["handover"] += any(h is not None for h in ref.handover)
        assert _close(q, rq), (k, np.abs(q - rq).max())
        assert _close(v, rv), (k, np.abs(v - rv).max())
        assert _close(est.wrench, rw), k
        assert _close([est.normal_force[s] for s in SIDES], rf), k
        assert [est.contact[s] for s in SIDES] == ref.contact, k
        assert [est.turning[s] for s in SIDES] == ref.turning, k
        for s, (Rs, ps) in zip(SIDES, rsoles):
            assert _close(est.sole[s].rotation, Rs) and _close(est.sole[s].translation, ps), k
        assert _close(np.array([est.anchor_axis[s] for s in SIDES]), ref.axis), k
    assert all(n > 0 for n in seen.values()), seen  # every branch ran


def test_exp3_and_quaternion_match_pinocchio():
    rng = np.random.default_rng(3)
    out, quat = np.empty((3, 3)), np.empty(4)
    for scale in (1e-9, 1e-6, 1e-3, 1.0, 3.0):  # below and above Pinocchio's Taylor threshold
        for _ in range(50):
            w = scale * rng.normal(size=3)
            exp3(w, out)
            assert np.abs(out - pin.exp3(w)).max() <= 1e-15
            rotation_quaternion(out, quat)
            assert np.abs(quat - pin.SE3ToXYZQUAT(pin.SE3(out, np.zeros(3)))[3:]).max() <= 1e-15


@pytest.mark.parametrize("make", [lambda: ComplementaryAttitudeFilter(0.002), lambda: BaseKalmanFilter(0.002),
                                  lambda: JointStateFilter(5, 0.002)], ids=["attitude", "kalman", "joints"])
def test_use_storage_moves_the_state_and_refuses_arrays_that_cannot_hold_it(make):
    """A filter moved into a caller's arrays keeps its values there and keeps working on them; arrays of another
    shape or dtype, or read-only ones, raise InvalidInputError and leave the filter as it was."""
    f = make()
    f.storage[0][...] += np.arange(f.storage[0].size).reshape(f.storage[0].shape) * 1e-3  # distinct values
    state, params = (a.copy() for a in f.storage)
    new_state, new_params = np.zeros_like(state), np.zeros_like(params)
    f.use_storage(new_state, new_params)
    assert np.array_equal(new_state, state) and np.array_equal(new_params, params)
    assert f.storage[0] is new_state and f.storage[1] is new_params
    readonly = np.zeros_like(state)
    readonly.flags.writeable = False
    for bad in (np.zeros(state.size + 1), state.astype(np.float32), readonly, list(state.ravel())):
        with pytest.raises(InvalidInputError, match="state must be a writable float64 array"):
            f.use_storage(bad, np.zeros_like(params))
    assert f.storage[0] is new_state
    with pytest.raises(InvalidInputError, match="params must be"):
        f.use_storage(np.zeros_like(state), np.zeros(params.size + 2))
