"""Sensors of the simulated robot: joint encoders, a pelvis IMU and 6-axis force/torque sensors at both ankles.

The MuJoCo model gets real MuJoCo sensors (:func:`add_sensors`, called by
:func:`wbc.sim.mujoco_model.build_mujoco_model` on its ``MjSpec``):

================  =====================================  ===================================================
name              MuJoCo sensor                          what it measures (MuJoCo's definition)
================  =====================================  ===================================================
``enc_<joint>``   ``jointpos`` per actuated 1-DoF joint  joint angle (rad)
``imu_gyro``      ``gyro`` at site ``imu``               angular velocity of the IMU frame, IMU axes (rad/s)
``imu_accel``     ``accelerometer`` at site ``imu``      specific force a − g of the IMU site, IMU axes (m/s²)
``ft_<side>_f``   ``force`` at site ``ft_<side>``        force between the ankle body and its parent (N)
``ft_<side>_t``   ``torque`` at site ``ft_<side>``       moment of that interaction about the site (N·m)
================  =====================================  ===================================================

The IMU site is the origin of the floating base (the root link, e.g. Talos's pelvis ``base_link``), with its
axes. Each F/T site is the origin of the body carrying the sole frame (the link moved by the ankle roll joint),
with the sole frame's axes: the sensor carries the foot below it, whose weight and inertia it measures too
(:mod:`wbc.estimation.contact` removes them).

:class:`PlantSensors` reads ``data.sensordata`` after ``mj_step1`` (positions and velocities of the current
state; the accelerometer and the F/T sensors hold the acceleration-stage values of the previous step, i.e. the
motion and forces of the last control period, as a real sensor sampled at the tick would) and corrupts it with
noise drawn from its own ``numpy.random.default_rng(seed)`` (MuJoCo's ``noise`` attribute is set to the white-noise
standard deviation for the record but MuJoCo itself adds no noise):

* encoders: the angle quantised to ``counts_per_rev`` counts per revolution (``round(q / Δ) Δ``, Δ = 2π / counts).
  Joint velocities are not measured: the estimator differentiates the encoder positions
  (:class:`wbc.estimation.JointStateFilter`). Not MuJoCo's ``qvel``.
* IMU: white noise of density ``n`` (per-sample standard deviation ``n √rate``) plus a bias ``b`` that starts at a
  draw of standard deviation ``*_bias_std`` and follows a random walk ``b_{k+1} = b_k + σ_w √Δt w_k`` (w standard
  normal) — the usual continuous-time IMU model (e.g. Furgale, Rehder, Siegwart 2013, "Unified temporal and
  spatial calibration for multi-sensor systems", IROS, eq. 8–9; Kalibr's IMU noise model).
* F/T: white noise of standard deviation ``force_noise``/``torque_noise`` per sample plus a constant offset drawn
  once (standard deviation ``force_bias_std``/``torque_bias_std``).

Each sensor updates at its ``rate_hz`` and holds its last value in between (sample and hold); the rate must divide
the control rate (an integer number of ticks per sample).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import mujoco
import numba as nb
import numpy as np
import pinocchio as pin

from wbc.compiled import CHECK_TYPES, once_per_process, specialise
from wbc.constants import GRAVITY, SIDES
from wbc.exceptions import InvalidInputError

__all__ = ["EncoderSpec", "ImuSpec", "ForceTorqueSpec", "SensorSpecs", "add_sensors", "PlantSensors",
           "SensorReadings", "IMU_SITE", "ft_site"]

IMU_SITE = "imu"  #: name of the IMU site on the floating base


def ft_site(side: str) -> str:
    """Name of the F/T site of ``side`` ("left"/"right")."""
    return f"ft_{side}"


def _check(value, what: str, *, positive: bool = False) -> float:
    ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool) \
        and np.isfinite(value) and (value > 0 if positive else value >= 0)
    if not ok:
        raise InvalidInputError(f"{what} must be a finite number {'> 0' if positive else '≥ 0'}, got {value!r}")
    return float(value)


class _Spec:
    """Validates every numeric field at construction and on assignment (typed error naming the field)."""

    _positive: tuple[str, ...] = ("rate_hz",)

    def __setattr__(self, name, value):
        if name in self.__dataclass_fields__:
            if name == "counts_per_rev":
                if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 2:
                    raise InvalidInputError(f"counts_per_rev must be an integer ≥ 2, got {value!r}")
                value = int(value)
            else:
                value = _check(value, f"{type(self).__name__}.{name}", positive=name in self._positive)
        object.__setattr__(self, name, value)


@dataclass
class EncoderSpec(_Spec):
    """Joint encoders.

    Attributes:
        counts_per_rev: counts per revolution of the joint (default 2¹⁹ = 524288: a 19-bit absolute joint encoder,
            resolution 1.2e-5 rad — an assumed value of the class of encoders on torque-controlled humanoids).
        rate_hz: sampling rate (Hz, default 500: every control tick).
    """

    counts_per_rev: int = 2**19
    rate_hz: float = 500.0


@dataclass
class ImuSpec(_Spec):
    """Pelvis IMU (gyroscope and accelerometer). Defaults: datasheet values of a MicroStrain 3DM-GX5-25
    (gyro noise density 0.005 °/s/√Hz, bias instability 8 °/h; accelerometer noise density 100 µg/√Hz, bias
    instability 0.04 mg); the bias random-walk densities are set so that the bias moves by about its bias
    instability in 100 s (σ_w = instability / √100 s), and the initial biases are assumed residuals after the
    at-rest calibration a robot does before it starts.

    Attributes:
        gyro_noise_density: rad/s/√Hz. gyro_bias_walk: rad/s/√s. gyro_bias_std: initial bias std (rad/s).
        accel_noise_density: m/s²/√Hz. accel_bias_walk: m/s²/√s. accel_bias_std: initial bias std (m/s²).
        rate_hz: sampling rate (Hz, default 500).
    """

    gyro_noise_density: float = math.radians(0.005)
    gyro_bias_walk: float = math.radians(8.0 / 3600.0) / 10.0
    gyro_bias_std: float = math.radians(0.05)
    accel_noise_density: float = 100e-6 * GRAVITY
    accel_bias_walk: float = 0.04e-3 * GRAVITY / 10.0
    accel_bias_std: float = 2e-3 * GRAVITY
    rate_hz: float = 500.0


@dataclass
class ForceTorqueSpec(_Spec):
    """Ankle 6-axis force/torque sensors (assumed values of a strain-gauge sensor of a ~2 kN range: noise 0.5 N and
    0.05 N·m per sample, offsets left after taring of 2 N and 0.1 N·m standard deviation).

    Attributes:
        force_noise: N (std per sample). torque_noise: N·m. force_bias_std: N. torque_bias_std: N·m.
        rate_hz: sampling rate (Hz, default 500).
    """

    force_noise: float = 0.5
    torque_noise: float = 0.05
    force_bias_std: float = 2.0
    torque_bias_std: float = 0.1
    rate_hz: float = 500.0


@dataclass
class SensorSpecs:
    """All the sensor models (module docstring); ``SensorSpecs.ideal()`` has no noise, bias or quantisation beyond
    2³¹ counts per revolution."""

    encoder: EncoderSpec = field(default_factory=EncoderSpec)
    imu: ImuSpec = field(default_factory=ImuSpec)
    ft: ForceTorqueSpec = field(default_factory=ForceTorqueSpec)

    def __post_init__(self):
        for name, kind in (("encoder", EncoderSpec), ("imu", ImuSpec), ("ft", ForceTorqueSpec)):
            if not isinstance(getattr(self, name), kind):
                raise InvalidInputError(f"SensorSpecs.{name} must be a {kind.__name__}, got {getattr(self, name)!r}")

    @classmethod
    def ideal(cls) -> "SensorSpecs":
        """Noise-free, bias-free sensors (for tests of the estimator's own error)."""
        return cls(EncoderSpec(counts_per_rev=2**31),
                   ImuSpec(0.0, 0.0, 0.0, 0.0, 0.0, 0.0), ForceTorqueSpec(0.0, 0.0, 0.0, 0.0))


def add_sensors(spec: mujoco.MjSpec, robot, specs: SensorSpecs | None = None) -> None:
    """Add the sites and sensors of the module docstring to ``spec`` (before compilation).

    Args:
        spec: the robot's ``MjSpec`` (as built by :func:`wbc.sim.mujoco_model.build_mujoco_model`: root link with a
            free joint, joints named as in the Pinocchio model).
        robot: the :class:`~wbc.robot.Robot` (its sole frames and joint names).
        specs: noise levels recorded in MuJoCo's ``noise`` attribute (default :class:`SensorSpecs`).
    """
    specs = SensorSpecs() if specs is None else specs
    pmodel = robot.model
    root = list(spec.worldbody.bodies)[0]
    root.add_site(name=IMU_SITE, pos=[0.0, 0.0, 0.0], quat=[1.0, 0.0, 0.0, 0.0], group=4)
    imu = specs.imu
    for name, kind, noise in (("imu_gyro", mujoco.mjtSensor.mjSENS_GYRO, imu.gyro_noise_density * math.sqrt(imu.rate_hz)),
                              ("imu_accel", mujoco.mjtSensor.mjSENS_ACCELEROMETER,
                               imu.accel_noise_density * math.sqrt(imu.rate_hz))):
        spec.add_sensor(name=name, type=kind, objtype=mujoco.mjtObj.mjOBJ_SITE, objname=IMU_SITE, noise=noise)
    for side in SIDES:
        body, rot = _ft_body(robot, side)
        quat = pin.Quaternion(rot)
        spec.body(body).add_site(name=ft_site(side), pos=[0.0, 0.0, 0.0], quat=[quat.w, quat.x, quat.y, quat.z],
                                 group=4)
        spec.add_sensor(name=f"ft_{side}_f", type=mujoco.mjtSensor.mjSENS_FORCE, objtype=mujoco.mjtObj.mjOBJ_SITE,
                        objname=ft_site(side), noise=specs.ft.force_noise)
        spec.add_sensor(name=f"ft_{side}_t", type=mujoco.mjtSensor.mjSENS_TORQUE, objtype=mujoco.mjtObj.mjOBJ_SITE,
                        objname=ft_site(side), noise=specs.ft.torque_noise)
    for name in pmodel.names[2:]:
        spec.add_sensor(name=f"enc_{name}", type=mujoco.mjtSensor.mjSENS_JOINTPOS, objtype=mujoco.mjtObj.mjOBJ_JOINT,
                        objname=name)


def _ft_body(robot, side: str) -> tuple[str, np.ndarray]:
    """(name of the link moved by the joint that carries the sole frame, rotation of the sole frame in it)."""
    pmodel = robot.model
    sole = pmodel.frames[robot.frame_id(getattr(robot, f"{side}_sole"))]
    joint = sole.parentJoint
    # In a URDF the joint frame is the child link's frame: the sole placement in the joint frame is the placement
    # of the sole in that link.
    return _child_link(pmodel, joint), sole.placement.rotation


def _child_link(pmodel: pin.Model, joint: int) -> str:
    jframe = next(i for i, f in enumerate(pmodel.frames) if f.type == pin.FrameType.JOINT and f.parentJoint == joint)
    return next(f.name for f in pmodel.frames if f.type == pin.FrameType.BODY and f.parentFrame == jframe)


_DRAWS_BUFFER = 4096  #: standard normal draws taken from the generator at once (≈ 170 ticks of all sensors)


class _SensorLayout(NamedTuple):
    """What :func:`_read_kernel` reads and writes besides the tick's inputs (:class:`PlantSensors`'s arrays, built at
    each :meth:`PlantSensors.reset`)."""

    enc: np.ndarray       #: (nj,) int64 index of each encoder in ``sensordata``
    res: float            #: encoder resolution (rad per count)
    walk_idx: np.ndarray  #: int64 indices in the 18-vector of the IMU bias walks' draws
    imu_idx: np.ndarray   #: int64 indices in the 18-vector of the IMU white noise draws
    ft_idx: np.ndarray    #: int64 indices in the 18-vector of the F/T white noise draws
    imu_ft: np.ndarray    #: (18,) int64 index in ``sensordata`` of each entry of a sample (gyro, accel, 2 × F/T)
    sample: np.ndarray    #: (18,) out: the IMU and F/T readings
    bias: np.ndarray      #: (18,) the sensors' biases (updated by the bias walks)


@nb.njit(cache=True)
def _read_kernel(sd, joint_q, imu_on, ft_on, z, scale, lay):
    """:meth:`PlantSensors.read`'s arithmetic after the tick's standard normal draws ``z`` (``len(scale)`` of them),
    element by element in its order, on ``sd`` (MuJoCo's ``sensordata``) and ``lay`` (:class:`_SensorLayout`): the
    encoders quantised (``joint_q`` None: not sampled this tick), the draws scaled by ``scale``, the bias walks added
    to ``lay.bias``, the IMU and/or F/T readings ``sd[imu_ft] + bias`` plus their white noise written to
    ``lay.sample``."""
    enc, res, walk_idx, imu_idx, ft_idx, imu_ft, sample, bias = lay
    if joint_q is not None:
        for i in range(enc.size):
            joint_q[i] = np.rint(sd[enc[i]] / res) * res
    nz = scale.size
    for i in range(nz):
        z[i] *= scale[i]
    lo = 0 if imu_on else 6
    hi = 18 if ft_on else 6
    n = 0
    if imu_on:
        for i in range(walk_idx.size):
            bias[walk_idx[i]] += z[i]
        n = walk_idx.size
    for i in range(lo, hi):
        sample[i] = sd[imu_ft[i]] + bias[i]
    if imu_on:
        for i in range(imu_idx.size):
            sample[imu_idx[i]] += z[n + i]
        n += imu_idx.size
    if ft_on:
        for i in range(nz - n):
            sample[ft_idx[i]] += z[n + i]


@once_per_process
def _warm_up() -> None:
    """Load :func:`_read_kernel` (on-disk cache) once per process, with and without the encoder sample."""
    i1, f18 = np.zeros(1, dtype=np.int64), np.zeros(18)
    lay = _SensorLayout(i1, 1.0, i1[:0], i1[:0], i1[:0], np.zeros(18, dtype=np.int64), np.zeros(18), np.zeros(18))
    for joint_q in (np.zeros(1), None):
        _read_kernel(f18, joint_q, True, True, np.zeros(24), np.zeros(0), lay)


@dataclass
class SensorReadings:
    """One tick of sensor outputs (arrays preallocated, overwritten by :meth:`PlantSensors.read`).

    Attributes:
        t: time of the reading (s).
        joint_q: (nv − 6,) encoder angles (rad), Pinocchio's ``v[6:]`` order (1-DoF joints).
        gyro: (3,) angular velocity (rad/s, IMU axes = base axes).
        accel: (3,) specific force a − g (m/s², IMU axes; +9.81 along the up axis at rest).
        ft: (2, 6) (left, right) force (N) and moment (N·m, about the sensor origin) that the leg exerts on the
            foot below the sensor (MuJoCo's ``force``/``torque`` sensors: the interaction between the sensor's body
            and its parent), sensor (= sole) axes; :class:`wbc.estimation.FootForceSensor` turns it into the
            ground reaction.
    """

    t: float
    joint_q: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    ft: np.ndarray


class PlantSensors:
    """Noisy readings of the MuJoCo sensors added by :func:`add_sensors` (module docstring).

    Args:
        sim: a :class:`~wbc.sim.mujoco_runtime.MujocoModel` built with sensors.
        specs: sensor models (default :class:`SensorSpecs`).
        seed: seed of the noise generator (the same seed gives the same noise).

    Attributes:
        rng: the noise generator (:meth:`read` takes its standard normal draws from it in blocks of
            ``_DRAWS_BUFFER``, used in order: the same noise as one draw per reading).

    Raises:
        InvalidInputError: ``sim`` has no such sensors, a rate that does not divide the control rate.
    """

    def __init__(self, sim, specs: SensorSpecs | None = None, *, seed: int = 0):
        self.specs = SensorSpecs() if specs is None else specs
        if not isinstance(self.specs, SensorSpecs):
            raise InvalidInputError(f"specs must be a SensorSpecs, got {specs!r}")
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
            raise InvalidInputError(f"seed must be an integer, got {seed!r}")
        self.sim, self.seed = sim, int(seed)
        m = sim.model
        self.dt = float(m.opt.timestep)

        def adr(name: str, dim: int) -> np.ndarray:
            sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SENSOR, name)
            if sid < 0:
                raise InvalidInputError(f"the MuJoCo model has no sensor {name!r}: build it with sensors "
                                        "(build_mujoco_model(..., sensors=True))")
            return m.sensor_adr[sid] + np.arange(dim)

        names = sim.robot.model.names[2:]
        self._enc = np.array([adr(f"enc_{n}", 1)[0] for n in names], dtype=int)
        self._gyro, self._acc = adr("imu_gyro", 3), adr("imu_accel", 3)
        self._ft = np.array([np.r_[adr(f"ft_{s}_f", 3), adr(f"ft_{s}_t", 3)] for s in SIDES], dtype=int)
        self._every = {}
        for name, s in (("encoder", self.specs.encoder), ("imu", self.specs.imu), ("ft", self.specs.ft)):
            ratio = 1.0 / (s.rate_hz * self.dt)
            if ratio < 1.0 - 1e-9 or abs(ratio - round(ratio)) > 1e-6:
                raise InvalidInputError(f"{name} rate {s.rate_hz} Hz must divide the control rate {1 / self.dt:g} Hz "
                                        "(an integer number of ticks per sample)")
            self._every[name] = int(round(ratio))
        nj = len(names)
        # gyro (3), accel (3), ft (2 × 6) of a sample in one vector: one gather and one add per tick
        self._imu_ft = np.r_[self._gyro, self._acc, self._ft.ravel()].astype(np.int64)
        self._sample = np.zeros(18)
        self._bias = np.zeros(18)
        self.readings = SensorReadings(0.0, np.zeros(nj), self._sample[0:3], self._sample[3:6],
                                       self._sample[6:18].reshape(2, 6))
        self.reset()
        _warm_up()
        # read's compiled calls, with and without the encoder sample: their arguments are this object's arrays and
        # MuJoCo's sensordata, of fixed types (wbc.compiled.specialise; with kernel type checks on, the dispatcher)
        args = (self.sim.data.sensordata, None, True, True, self._draws[:0], self._draw_sd[True, True], self._layout)
        self._read = {False: _read_kernel, True: _read_kernel} if CHECK_TYPES else {
            False: specialise(_read_kernel, *args), True: specialise(_read_kernel, args[0], self.readings.joint_q,
                                                                     *args[2:])}

    def reset(self) -> None:
        """Restart the noise generator from ``seed`` and draw new initial biases. The noise levels of
        :attr:`specs` are read here (and at construction)."""
        self.rng = np.random.default_rng(self.seed)
        imu, ft = self.specs.imu, self.specs.ft
        b = self._bias
        b[:] = 0.0
        self.gyro_bias, self.accel_bias, self.ft_bias = b[0:3], b[3:6], b[6:18].reshape(2, 6)
        if imu.gyro_bias_std:
            self.gyro_bias[:] = self.rng.normal(0.0, imu.gyro_bias_std, 3)
        if imu.accel_bias_std:
            self.accel_bias[:] = self.rng.normal(0.0, imu.accel_bias_std, 3)
        if ft.force_bias_std:
            self.ft_bias[:, :3] = self.rng.normal(0.0, ft.force_bias_std, (2, 3))
        if ft.torque_bias_std:
            self.ft_bias[:, 3:] = self.rng.normal(0.0, ft.torque_bias_std, (2, 3))
        self._k = 0
        enc = self.specs.encoder
        self._res = 2.0 * math.pi / enc.counts_per_rev
        # Per sample of each group, the draws in their order (bias walks, then white noise; the F/T's (2, 3)
        # blocks row by row): index in the 18-vector and standard deviation. A draw N(0, σ) is σ z of a
        # standard normal z, so one ``standard_normal`` of all a tick's draws consumes the generator as the
        # separate ``normal`` calls would.
        h = self._every["imu"] * self.dt
        walk = [(range(0, 3), imu.gyro_bias_walk * math.sqrt(h)), (range(3, 6), imu.accel_bias_walk * math.sqrt(h))]
        white = [(range(0, 3), imu.gyro_noise_density * math.sqrt(imu.rate_hz)),
                 (range(3, 6), imu.accel_noise_density * math.sqrt(imu.rate_hz))]
        ft_white = [((6, 7, 8, 12, 13, 14), ft.force_noise), ((9, 10, 11, 15, 16, 17), ft.torque_noise)]

        def draws(blocks):
            idx = [i for rows, sd in blocks if sd for i in rows]
            return np.array(idx, dtype=int), np.array([sd for rows, sd in blocks if sd for _ in rows])

        self._walk_idx, walk_sd = draws(walk)
        self._imu_idx, imu_sd = draws(white)
        self._ft_idx, ft_sd = draws(ft_white)
        self._draw_sd = {(True, True): np.r_[walk_sd, imu_sd, ft_sd], (True, False): np.r_[walk_sd, imu_sd],
                         (False, True): ft_sd, (False, False): np.zeros(0)}
        # standard normal draws of the generator not used yet: _draws[_drawn:] (drawn in bulk by read)
        self._draws, self._drawn = np.zeros(_DRAWS_BUFFER), _DRAWS_BUFFER
        self._layout = _SensorLayout(self._enc, self._res, self._walk_idx, self._imu_idx, self._ft_idx, self._imu_ft,
                                    self._sample, self._bias)

    def read(self, t: float, data: mujoco.MjData | None = None) -> SensorReadings:
        """Sample the sensors at tick time ``t`` (s) from ``data.sensordata`` (call after ``mj_step1``/``mj_forward``)
        and return the (preallocated, overwritten) :class:`SensorReadings`."""
        d = self.sim.data if data is None else data
        sd = d.sensordata
        r, k, every = self.readings, self._k, self._every
        r.t = float(t)
        enc_on = k % every["encoder"] == 0
        imu_on, ft_on = k % every["imu"] == 0, k % every["ft"] == 0
        self._k = k + 1
        if not (imu_on or ft_on):
            if enc_on:
                self._read[True](sd, r.joint_q, False, False, self._draws, self._draw_sd[False, False], self._layout)
            return r
        scale = self._draw_sd[imu_on, ft_on]
        nz, pos, buf = len(scale), self._drawn, self._draws
        if pos + nz > len(buf):  # the next draws of the generator, many ticks' at once (the same stream)
            rest = len(buf) - pos
            buf[:rest] = buf[pos:]
            self.rng.standard_normal(out=buf[rest:])
            pos = 0
        z = buf[pos:pos + nz]
        self._drawn = pos + nz
        self._read[enc_on](sd, r.joint_q if enc_on else None, imu_on, ft_on, z, scale, self._layout)
        return r
