"""Shared fixtures: catalog robots are loaded once per test session."""

from __future__ import annotations

import os
import sys
import warnings
from pathlib import Path

import pytest

# MuJoCo's offscreen renderer (video tests) picks its GL backend when mujoco is first imported: without a display,
# README's test command gets the same headless EGL backend that .ci/run exports (a full run on Python 3.12 with the
# default backend aborted in the renderer); a backend the user set is kept.
if not os.environ.get("DISPLAY"):
    os.environ.setdefault("MUJOCO_GL", "egl")

# One arithmetic for the suite on every x86-64 host. wbc's numba kernels are compiled with reassociation
# (wbc.compiled.FASTMATH) for the CPU numba detects, OpenBLAS (numpy's, scipy's) picks its kernels by the CPU, and
# numpy's own loops (sin, cos, exp, ...) dispatch to the widest vector unit there is: the last bits of a result depend
# on the host (an AVX-512 znver4 and an AVX2 znver3 EPYC differ), and the fuzz-replay ticks and closed-loop physics
# runs the tests replay follow those bits (a tick that cycles DAQP's workspace on one host is solved at once on the
# other; a pushed walk's worst joint speed 1.0004x its limit on one, 1.04x on the other). The suite pins all three,
# so that what a test replays is what it was found on, whatever the host: numba's kernels compiled for AMD's znver3
# (AVX2 + FMA, its own feature set, none detected), OpenBLAS's Haswell kernels (what it picks on a znver3) and
# numpy's AVX2 loops (its AVX-512 ones switched off where the CPU has them). Set before numpy and numba are imported;
# pytest-xdist's workers and every child process inherit them. A host without AVX2 and FMA cannot run those kernels:
# the session stops with that reason. wbc itself (`wbc walk`, the benchmarks) compiles for the CPU it runs on.
TEST_CPU = {"NUMBA_CPU_NAME": "znver3", "NUMBA_CPU_FEATURES": "", "OPENBLAS_CORETYPE": "Haswell"}
if sys.platform.startswith("linux") and os.uname().machine == "x86_64":
    _flags = set(next((line.split(":", 1)[1].split() for line in Path("/proc/cpuinfo").read_text().splitlines()
                       if line.startswith("flags")), []))
    if not {"avx2", "fma"} <= _flags:
        raise pytest.UsageError("the test suite runs numba's kernels compiled for znver3 (AVX2 + FMA, one arithmetic "
                                "on every host: tests/conftest.py); this CPU lacks " +
                                ", ".join(sorted({"avx2", "fma"} - _flags)))
    os.environ.update(TEST_CPU)
    if "avx512f" in _flags:  # numpy's dispatch targets that need AVX-512 (SPR only where the CPU has AVX512-FP16)
        os.environ["NPY_DISABLE_CPU_FEATURES"] = " ".join(
            ["AVX512F", "AVX512CD", "AVX512_SKX", "AVX512_CLX", "AVX512_CNL", "AVX512_ICL"]
            + ["AVX512_SPR"] * ("avx512fp16" in _flags))

# every wbc.compiled.specialise function checks its array arguments' types on each call in the tests (set before wbc
# is imported; child processes inherit it)
os.environ["WBC_CHECK_KERNEL_TYPES"] = "1"

import numpy as np
import pinocchio as pin

import wbc
from wbc.constraints.base import IDContext
from wbc.state import DynamicsState


def pytest_configure(config):
    """In the process that starts pytest-xdist's workers (two or more), first compile every kernel for the suite's
    CPU (``TEST_CPU``) with ``wbc compile``: each worker then loads them from numba's cache rather than compiling the
    same kernels at the same time as the other (the work of a first ``wbc compile``: 36.9 s for the host's kernels on
    2 quiet cores here; 5.7 s when they are cached)."""
    import subprocess

    workers = getattr(config.option, "numprocesses", None)
    if os.environ.get("PYTEST_XDIST_WORKER") or not workers or workers in ("0", 0) or config.option.collectonly:
        return
    cores = os.cpu_count() or 1
    jobs = cores if workers in ("auto", "logical") else max(1, min(int(workers), cores))
    subprocess.run([sys.executable, "-m", "wbc", "compile", "--quiet", "--jobs", str(jobs)], check=True)


_DDS_DOMAINS = {"next": None}


def dds_domain_id() -> int:
    """A ROS_DOMAIN_ID for one DDS test that no test running at the same time uses. Each pytest-xdist worker draws
    from its own range of 1–230 (cyclonedds' port formula allows up to 232), one test at a time per worker, cycling
    from a random start; a run without xdist uses the whole range. (Two workers drawing at random from 1–200 met on
    one domain once: a tutorial's subscriber then received a ROS 2 node test's /joint_states.)"""
    import random

    count = max(1, int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1")))
    worker = int(os.environ.get("PYTEST_XDIST_WORKER", "gw0")[2:] or 0)
    size = 230 // count
    if _DDS_DOMAINS["next"] is None:
        _DDS_DOMAINS["next"] = random.randrange(size)
    k = _DDS_DOMAINS["next"]
    _DDS_DOMAINS["next"] = (k + 1) % size
    return 1 + worker * size + k

CATALOG = ["talos", "g1", "humanoid15"]


@pytest.fixture(scope="session")
def robots():
    cache: dict[str, wbc.Robot] = {}

    def get(name: str) -> wbc.Robot:
        if name not in cache:
            cache[name] = wbc.load_robot(name)
        return cache[name]

    return get


def random_configuration(robot: wbc.Robot, rng: np.random.Generator, spread: float = 0.3) -> np.ndarray:
    """q_ref perturbed: joints by up to ±spread rad inside the limits, base by a random pose."""
    model = robot.model
    q = robot.q_ref.copy()
    lo, hi = model.lowerPositionLimit[7:], model.upperPositionLimit[7:]
    q[7:] = np.clip(q[7:] + rng.uniform(-spread, spread, model.nq - 7), lo, hi)
    base = pin.SE3(pin.rpy.rpyToMatrix(*rng.uniform(-0.3, 0.3, 3)), rng.uniform(-0.5, 0.5, 3))
    q[:7] = pin.SE3ToXYZQUAT(base)
    return q


def standing_controller(robot, config, *extra_constraints, tasks=(), vel_scale=1.0, posture_weight=1e-2):
    """The walk's standing set: both soles as contacts where they are, CoM (weight 10) and torso orientation held,
    posture on every DoF, joint position + velocity limits; plus ``extra_constraints`` and ``tasks``.
    Returns (controller, CoM task)."""
    from wbc.constraints import ContactConstraint, JointPositionLimit, JointVelocityLimit
    from wbc.controllers.kinematic import KinematicController
    from wbc.tasks import ComTask, OrientationTask, PostureTask

    contacts = [ContactConstraint(robot, f) for f in (robot.left_sole, robot.right_sole)]
    for c in contacts:
        c.set_placement_from_configuration(config)
    com = ComTask(weight=10.0)
    com.set_target(config.com)
    torso = OrientationTask(robot, robot.torso, name="torso")
    torso.set_target_from_configuration(config)
    ctrl = KinematicController(robot, [com, torso, *tasks, PostureTask(robot, weight=posture_weight)],
                               [*contacts, JointPositionLimit(robot), JointVelocityLimit(robot, scale=vel_scale),
                                *extra_constraints])
    return ctrl, com


def hand_over_posture(robots, **options):
    """(robot, config, controller, [hand, posture]): a standing Talos (:func:`standing_controller`) with a left-hand
    position task on strict level 0 (5 cm off in x, y, z) and a posture task on level 1; ``options`` are set on the
    controller (attribute = value) before the levels are added."""
    from wbc.configuration import Configuration
    from wbc.tasks import FrameTask, PostureTask

    robot = robots("talos")
    config = Configuration(robot)
    ctrl, _ = standing_controller(robot, config)
    for name, value in options.items():
        setattr(ctrl, name, value)
    hand = FrameTask(robot, "gripper_left_joint", gain=10.0, orientation_weight=0.0, name="hand")
    target = config.frame_placement(hand.frame_id).copy()
    target.translation += [0.05, 0.05, 0.05]
    hand.set_target(target)
    ctrl.add_task(hand, level=0)
    posture = PostureTask(robot, weight=1.0, name="posture1")
    ctrl.add_task(posture, level=1)
    return robot, config, ctrl, [hand, posture]


def count_cascades(monkeypatch) -> list:
    """Spy on the kinematic controller's strict cascade (``wbc.controllers.general_route.solve_lexicographic``): each
    call appends 1 to the returned list. The spy shares the cascade's attributes (its ``last_cut``, … reports)."""
    from wbc.controllers import general_route

    cascade = general_route.solve_lexicographic
    calls: list = []

    def counted(*args, **kwargs):
        calls.append(1)
        return cascade(*args, **kwargs)

    counted.__dict__ = cascade.__dict__  # (the same dict: the reports the cascade writes are read through the spy)
    monkeypatch.setattr(general_route, "solve_lexicographic", counted)
    return calls


def centroidal_oracle(model, q: np.ndarray, v: np.ndarray, dt: float):
    """Independent oracle of the executed-ZMP tests, straight from Pinocchio: total mass (kg), CoM (N, 3) of each
    q, its central second differences c̈ (N, 3) (end rows copied), and L̇ (N, 3), the backward difference of the
    centroidal angular momentum of each (q, v) (first row copied)."""
    data = model.createData()
    mass = sum(inertia.mass for inertia in model.inertias)
    com = np.array([pin.centerOfMass(model, data, qk) for qk in q])
    L = np.array([pin.computeCentroidalMomentum(model, data, qk, vk).angular for qk, vk in zip(q, v)])
    acc = np.zeros_like(com)
    acc[1:-1] = np.diff(com, 2, axis=0) / dt**2
    acc[0], acc[-1] = acc[1], acc[-2]
    ldot = np.zeros_like(L)
    ldot[1:] = np.diff(L, axis=0) / dt
    ldot[0] = ldot[1]
    return mass, com, acc, ldot


EPS = 1e-6


def make_tasks(robot, rng):
    """One task of every position-level type on ``robot``, with random targets (tests of tasks and of the
    in-place assembly)."""
    from wbc.tasks import ComTask, FrameTask, OrientationTask, PositionTask, PostureTask, RelativeFrameTask

    target = pin.SE3(pin.rpy.rpyToMatrix(*rng.uniform(-0.5, 0.5, 3)), rng.uniform(-0.3, 0.3, 3))
    frame = FrameTask(robot, robot.left_sole, position_weight=[1, 2, 3], orientation_weight=[0.5, 1, 1])
    frame.set_target(target)
    partial = FrameTask(robot, robot.torso, position_weight=[1, 0, 1], orientation_weight=[0, 1, 0])
    partial.set_target(target)
    pos = PositionTask(robot, robot.right_sole)
    pos.set_target(target)
    ori = OrientationTask(robot, robot.torso)
    ori.set_target(target)
    com = ComTask()
    com.set_target(rng.uniform(-0.2, 0.2, 3))
    posture = PostureTask(robot)
    posture.set_target(random_configuration(robot, rng))
    subset = PostureTask(robot, joints=robot.joint_names[:3])
    hand = robot.right_hand or robot.right_sole
    rel = RelativeFrameTask(robot, hand, robot.torso, position_weight=[1, 2, 3], orientation_weight=[1, 0.5, 2])
    rel.set_target(target)
    rel_partial = RelativeFrameTask(robot, robot.left_sole, robot.right_sole, position_weight=[0, 1, 1],
                                    orientation_weight=[1, 0, 0])
    rel_partial.set_target(target)
    return [frame, partial, pos, ori, com, posture, subset, rel, rel_partial]


def fd_jacobian(task, robot, q):
    """Central finite-difference Jacobian of ``task``'s error along q ⊕ dq (step ``EPS``), (dim, nv)."""
    from wbc.configuration import Configuration

    J = np.empty((task.dim, robot.nv))
    for i in range(robot.nv):
        dq = np.zeros(robot.nv)
        dq[i] = EPS
        ep = task.compute_error(Configuration(robot, pin.integrate(robot.model, q, dq)))
        em = task.compute_error(Configuration(robot, pin.integrate(robot.model, q, -dq)))
        J[:, i] = (ep - em) / (2 * EPS)
    return J


def id_ticks_from_standing(robot, ctrl, ticks: int, dt: float, measure):
    """``ticks`` ticks of an inverse-dynamics controller from standing (q_ref, v = 0), the state integrated from the
    commanded v̇ (semi-implicit Euler); each command must be ok and unrelaxed. Returns [(command, measure(q, v, v̇))]
    per tick (``measure`` an independent reference of the constrained quantity, e.g. Pinocchio's)."""
    q, v = robot.q_ref.copy(), np.zeros(robot.nv)
    out = []
    for _ in range(ticks):
        cmd = ctrl.solve(q, v)
        assert cmd.ok and not cmd.relaxed, cmd.path_reason
        out.append((cmd, measure(q, v, cmd.dv)))
        v = v + dt * cmd.dv
        q = pin.integrate(robot.model, q, dt * v)
    return out


def written_id_rows(robot, con, rng, dt: float, states: int = 4, nf: int = 24):
    """Yield (q, v, C, l, u) of an inequality ID constraint written at ``states`` random (q, v) of the robot (NaN
    buffers, nf force columns, which must stay zero: forces enter through the dynamics rows only)."""
    for _ in range(states):
        q, v = random_configuration(robot, rng), rng.normal(scale=0.5, size=robot.nv)
        C, l, u = np.full((con.dim, robot.nv + nf), np.nan), np.full(con.dim, np.nan), np.full(con.dim, np.nan)
        con.write(IDContext(DynamicsState(robot, q, v), dt, robot.nv, np.zeros((robot.nv, nf)), {}), C, l, u)
        assert (C[:, robot.nv:] == 0).all()
        yield q, v, C, l, u


def assert_id_command_is_the_qp_optimum(ctrl, cmd, dt: float, x_tol: float) -> np.ndarray:
    """The command's x = [v̇; f] equals quadprog's optimum of the QP ``ctrl.qp.build`` assembles at the controller's
    state (within x_tol · max(1, |x*|)); returns that QP's C (inequality rows) for checks of added rows."""
    H, g, A, b, C, l, u, lb, ub = ctrl.qp.build(ctrl.state, dt)
    xq = dense_quadprog(H, g, A, b, C, l, u, lb, ub)
    x = np.concatenate([cmd.dv, cmd.forces])
    np.testing.assert_allclose(x, xq, rtol=0, atol=x_tol * max(1.0, np.abs(xq).max()))
    return C


def dense_quadprog(H, g, A, b, C, l, u, lb, ub) -> np.ndarray:
    """quadprog's optimum (dense Goldfarb–Idnani) of min ½ xᵀHx + gᵀx s.t. A x = b, l ≤ C x ≤ u, lb ≤ x ≤ ub, the QP as
    given (a pinned variable lb = ub: two inequalities): the independent oracle of the QP tests' optimum claims."""
    import quadprog

    fl, fu, bl, bu = np.isfinite(l), np.isfinite(u), np.isfinite(lb), np.isfinite(ub)
    eye = np.eye(H.shape[0])
    Cq = np.hstack([A.T, C[fl].T, -C[fu].T, eye[:, bl], -eye[:, bu]])
    bq = np.concatenate([b, l[fl], -u[fu], lb[bl], -ub[bu]])
    return quadprog.solve_qp(H, -g, Cq, bq, A.shape[0])[0]


def dense_active_set(qp, arrays, max_iter, settings=None) -> int:
    """:func:`wbc.solvers.active_set.solve_qp_into` (same qp, arrays) with the kinematic tick's settings at
    ``max_iter`` (:func:`~wbc.solvers.active_set.kinematic_settings`), or ``settings``, in fresh workspaces of
    :func:`~wbc.solvers.active_set.qp_ws_sizes`: its return."""
    from wbc.solvers.active_set import kinematic_settings, qp_ws_sizes, solve_qp_into

    fsize, isize = qp_ws_sizes(qp[0].shape[0], qp[2].shape[0], qp[4].shape[0])
    return solve_qp_into(qp, arrays, settings or kinematic_settings(max_iter), np.empty(fsize),
                         np.empty(isize, np.int64))


def highs_feasible(A, b, C, l, u, lb, ub) -> bool:
    """Whether {x : A x = b, l ≤ C x ≤ u, lb ≤ x ≤ ub} is non-empty, by HiGHS's LP (scipy): the independent oracle of
    the QP tests' feasibility claims."""
    import scipy.optimize as so

    fu, fl = np.isfinite(u), np.isfinite(l)
    bounds = [(lo if np.isfinite(lo) else None, hi if np.isfinite(hi) else None) for lo, hi in zip(lb, ub)]
    r = so.linprog(np.zeros(A.shape[1]), A_ub=np.vstack([C[fu], -C[fl]]), b_ub=np.concatenate([u[fu], -l[fl]]),
                   A_eq=A, b_eq=b, bounds=bounds, method="highs")
    return r.status == 0


def kkt_gap(H, g, A, b, C, l, u, lb, ub, x, active_tol: float = 1e-8) -> float:
    """Largest violation of the KKT conditions of min ½ xᵀHx + gᵀx s.t. A x = b, l ≤ C x ≤ u, lb ≤ x ≤ ub at x,
    relative to max(1, ‖g‖∞, ‖b‖∞): primal feasibility, and stationarity H x + g = Aᵀλ + Σ μ_i c_i with the
    multipliers of the active inequalities (within ``active_tol``) of the right sign, fitted by scipy's bounded
    least squares (no QP solver): the independent oracle of the QP tests' optimality claims."""
    import scipy.optimize as so

    n = H.shape[0]
    scale = max(1.0, float(np.abs(g).max()), float(np.abs(b).max(initial=0.0)))
    Cx, eye = C @ x, np.eye(n)
    # each active side as a column of the gradient's expansion, oriented so that its multiplier is ≥ 0
    cols = [A.T, C[Cx <= l + active_tol].T, -C[Cx >= u - active_tol].T, eye[:, x <= lb + active_tol],
            -eye[:, x >= ub - active_tol]]
    M = np.hstack(cols)
    low = np.concatenate([np.full(A.shape[0], -np.inf), np.zeros(M.shape[1] - A.shape[0])])
    grad = H @ x + g
    r = grad - M @ so.lsq_linear(M, grad, bounds=(low, np.inf), method="bvls").x if M.shape[1] else grad
    primal = [np.abs(A @ x - b).max(initial=0.0), np.maximum(l - Cx, 0.0).max(initial=0.0),
              np.maximum(Cx - u, 0.0).max(initial=0.0), np.maximum(lb - x, 0.0).max(), np.maximum(x - ub, 0.0).max()]
    return float(max(np.abs(r).max(), *primal)) / scale


#: (seed, episode, tick) of a kinematic fuzz tick (``fuzz_episode``; humanoid15, a far hand target, strict levels,
#: dt 2 ms) that, replayed with ``FIRST_RESOLVE_WORK = inf`` on the controller, fails past its count: a sole drifts
#: 0.1 mm even inside a trust region, the contact correction and the trust region are cut, the tick holds the
#: contacts (``fallback:contacts_held``), the ticks before it ok (in the suite's arithmetic, ``TEST_CPU``).
HELD_PAST_COUNT_TICK = (100016, 30, 5)


def fuzz_episode(robots, seed: int, episode: int, dts=(0.002,), past_limits: float = 0.0):
    """(name, kind, strict, dt, config, controller) of ``benchmarks/fuzz.py``'s episode ``episode`` of chunk ``seed``
    (its random streams replayed) run with ``--dts`` and ``--past-limits`` (default: the fuzz's defaults, dt = 2 ms
    and no episode past the limits); the fuzz's budget: the tick's dt, counted in solves."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import fuzz

    robots_ = {n: robots(n) for n in ("talos", "g1", "humanoid15")}
    rng = np.random.default_rng(seed)
    extra = np.random.default_rng(seed + 7_000_000)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for _ in range(episode + 1):
            name = str(rng.choice(list(robots_)))
            kind = str(rng.choice(["reachable", "absurd", "far"]))
            strict = bool(rng.random() < 0.5)
            dt = float(extra.choice(dts))
            past = bool(extra.random() < past_limits)
            config, ctrl = fuzz.build_episode(robots_[name], name, rng, kind, strict, past_limits=past)
    ctrl.budget = None
    return name, kind, strict, dt, config, ctrl


@pytest.fixture
def cli(capsys):
    """Run ``wbc ARGV`` in-process: returns (exit code, stderr stripped, stdout); argparse's own exits included."""
    from wbc.cli import main

    def run(argv):
        try:
            code = main(argv)
        except SystemExit as exc:
            code = exc.code
        out, err = capsys.readouterr()
        return code, err.strip(), out

    return run


def box_sole_mjcf(length: float, width: float, dt: float) -> str:
    """MJCF of a 30 kg box sole (``length`` × ``width`` m, 6 cm thick) on a floor, free to slide in z and x and to
    pitch (damped), its pitch driven by a position actuator (kp 800 N·m/rad), a site ``sole`` at its bottom face's
    centre; MuJoCo timestep ``dt`` (s). The scripted foot of the contact-event and partial-foothold tests."""
    return f"""
<mujoco>
  <option timestep="{dt}"/>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="foot" pos="0 0 0.03">
      <joint name="z" type="slide" axis="0 0 1" damping="50"/>
      <joint name="x" type="slide" axis="1 0 0" damping="50"/>
      <joint name="pitch" type="hinge" axis="0 1 0" damping="40"/>
      <geom name="sole" type="box" size="{length / 2} {width / 2} 0.03" mass="30"/>
      <site name="sole" pos="0 0 -0.03"/>
    </body>
  </worldbody>
  <actuator><position name="pitch" joint="pitch" kp="800"/></actuator>
</mujoco>
"""
