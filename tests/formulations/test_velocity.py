"""One assembly of the velocity QP (wbc.formulations.velocity): the compiled solver and the general solver receive
the same assembled QP, and their answers agree.

Property (hypothesis) over random task sets (CoM, position / frame / orientation tasks on the hands and torso, a
posture task; random weights and gains), random constraint sets (contacts on 0, 1 or 2 soles, joint position and
velocity limits), a random configuration near the reference one and dt in [1 ms, 20 ms], on talos, g1 and
humanoid15:

1. the QP the compiled solver (``wbc.formulations.velocity_kernel.kinematic_tick_packed``) receives lies in the very
   buffers that ``KinematicController.assemble`` returns (the same memory), and it is bitwise the QP that the general
   path hands its backend (a DAQP controller built from the same draws: its ``backend.solve`` arguments);
2. where the compiled solver ends at a KKT point and DAQP solves that QP, their answers agree to
   ``AGREEMENT`` = 1e-9 in the metric of the cost, ‖v₁ − v₂‖_H = √((v₁ − v₂)ᵀ H (v₁ − v₂)) ≤ 1e-9 · max(1, ‖v‖_H)
   (H ≥ ε I, so ‖v₁ − v₂‖∞ ≤ 1e-9 / √ε · max(1, ‖v‖_H): the max-norm is not a fair measure here, a soft level
   with no contact leaves directions weighted by the damping ε = 1e-6 alone, where two exact solvers differ by
   ≈ 1e-9 in v); the compiled answer also against an independent oracle, quadprog on the same arrays, to ``ORACLE``.
   The compiled side is allowed the H-metric offset its own equality residual accounts for (``_equality_offset``);
   DAQP is allowed its H-metric distance from the exact optimum of its own active set (``_active_set_offset``: the
   equality-constrained QP of its equalities and the rows and bounds it holds active, solved by a refined KKT
   system): DAQP ends some draws with a residual ≈ 1e-9 on the equalities, which alone moves it ≈ 3e-7 along
   ε-weighted directions, and some (humanoid15, H's smallest eigenvalue 1e-6, condition 5e5) 1.7e-9 off that
   optimum where the compiled answer is 1.5e-16 from it. The compiled answer's own distance from the exact optimum
   of its active set is asserted ≤ ``AGREEMENT`` on its own.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pinocchio as pin
import pytest
import qpsolvers
from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st

import wbc
import wbc.controllers.compiled_tick as compiled_tick
import wbc.controllers.general_route as general_route
import wbc.tick as tick
from wbc.configuration import Configuration
from wbc.exceptions import SolverError
from wbc.constraints import ContactConstraint, JointPositionLimit, JointVelocityLimit
from wbc.controllers.kinematic import KinematicController
from wbc.solvers import DaqpBackend
from wbc.tasks import ComTask, FrameTask, OrientationTask, PositionTask, PostureTask

#: largest difference between two solvers' answers on the same QP, in the cost's metric relative to max(1, ‖v‖_H)
AGREEMENT = 1e-9
#: the same against quadprog, the independent oracle: its range-space method factors H itself, and with directions
#: weighted by the damping ε = 1e-6 alone its answer is off by ≈ 1e-6 in that metric (a KKT solve in numpy agrees
#: with the compiled solver and DAQP to 1e-18 there)
ORACLE = 1e-5

_ROBOTS: dict[str, wbc.Robot] = {}


def _robot(name: str) -> wbc.Robot:
    if name not in _ROBOTS:  # each robot loaded once per module
        _ROBOTS[name] = wbc.load_robot(name)
    return _ROBOTS[name]


def _build(robot, draw: dict, solver: str):
    """A controller and its configuration from the drawn parameters (the same objects' numbers for every solver)."""
    rng = np.random.default_rng(draw["seed"])
    model = robot.model
    q = robot.q_ref.copy()
    lo, hi = model.lowerPositionLimit[7:], model.upperPositionLimit[7:]
    q[7:] = np.clip(q[7:] + rng.uniform(-draw["spread"], draw["spread"], model.nq - 7), lo, hi)
    config = Configuration(robot, q)
    tasks = []
    if draw["com"]:
        com = ComTask(weight=draw["com_weight"], gain=draw["gain"])
        com.set_target(config.com + rng.uniform(-0.02, 0.02, 3))
        tasks.append(com)
    frames = [f for f in (robot.left_hand, robot.right_hand, robot.torso) if f is not None]
    for kind, frame in zip(draw["frame_tasks"], frames):
        cls = (PositionTask, FrameTask, OrientationTask)[kind]
        task = cls(robot, frame, gain=draw["gain"], name=f"{cls.__name__}_{frame}")
        pose = config.frame_placement(task.frame_id)
        task.set_target(pin.SE3(pose.rotation @ pin.exp3(rng.uniform(-0.05, 0.05, 3)),
                                pose.translation + rng.uniform(-0.03, 0.03, 3)))
        task.weight = rng.uniform(0.1, 10.0, task.dim)
        tasks.append(task)
    if draw["posture"]:
        tasks.append(PostureTask(robot, weight=draw["posture_weight"], gain=draw["posture_gain"]))
    constraints = []
    for frame in (robot.left_sole, robot.right_sole)[:draw["contacts"]]:
        contact = ContactConstraint(robot, frame, gain=draw["contact_gain"])
        pose = config.frame_placement(contact.frame_id)
        contact.set_placement(pin.SE3(pose.rotation, pose.translation + rng.uniform(-1, 1, 3) * draw["offset"]))
        constraints.append(contact)
    if draw["position_limit"]:
        constraints.append(JointPositionLimit(robot))
    if draw["velocity_limit"]:
        constraints.append(JointVelocityLimit(robot, scale=draw["velocity_scale"]))
    if not tasks:  # at least the posture: the cost is then not the damping alone
        tasks.append(PostureTask(robot, weight=draw["posture_weight"], gain=draw["posture_gain"]))
    return KinematicController(robot, tasks, constraints, solver=solver), config


_draws = st.fixed_dictionaries({
    "robot": st.sampled_from(["talos", "g1", "humanoid15"]),
    "seed": st.integers(0, 2**31 - 1),
    "spread": st.floats(0.0, 0.15),
    "com": st.booleans(),
    "com_weight": st.floats(0.1, 100.0),
    "gain": st.floats(0.5, 200.0),
    "frame_tasks": st.lists(st.integers(0, 2), min_size=0, max_size=3),
    "posture": st.booleans(),
    "posture_weight": st.floats(1e-3, 1.0),
    "posture_gain": st.floats(0.5, 50.0),
    "contacts": st.integers(0, 2),
    "contact_gain": st.floats(1.0, 500.0),
    "offset": st.floats(0.0, 1e-4),
    "position_limit": st.booleans(),
    "velocity_limit": st.booleans(),
    "velocity_scale": st.floats(0.2, 1.0),
    "dt": st.floats(1e-3, 2e-2),
})


def _bits(arrays) -> list[bytes]:
    return [np.ascontiguousarray(a).tobytes() for a in arrays]


def _distance(H, a, b) -> float:
    """‖a − b‖_H = √((a − b)ᵀ H (a − b)) (H the QP's cost Hessian, positive definite)."""
    d = a - b
    return float(np.sqrt(d @ H @ d))


def _equality_offset(H, A, b, v) -> float:
    """How far in the H-metric an answer's equality residual r = A v − b alone moves it: √(rᵀ (A H⁻¹ Aᵀ)⁺ r), the
    H-norm of the smallest correction that removes r. DAQP ends some ill-conditioned draws (H = ε I on most
    variables) with r ≈ 1e-9, which moves its answer ≈ 3e-7 along the ε-weighted directions; the comparison allows
    each solver its own offset, so a solver that is exact on its own rows gets no slack from the other's."""
    if A.shape[0] == 0:
        return 0.0
    r = A @ v - b
    S = A @ np.linalg.solve(H, A.T)
    return float(np.sqrt(max(0.0, r @ np.linalg.pinv(S) @ r)))


def _active_set_offset(H, g, A, b, C, l, u, lb, ub, v, tol: float = 1e-9) -> float:
    """‖v − v*‖_H, v* the exact minimiser of ½ xᵀHx + gᵀx subject to A x = b and, held as equalities, the rows of C
    and the bounds that v holds within ``tol`` of a side (v's active set): the KKT system solved by least squares
    (the active rows may be dependent) with three steps of iterative refinement. How far a solver's answer is from
    the optimum of its own active set: its accuracy, apart from which set it chose."""
    n = H.shape[0]
    rows, rhs = [A], [b]
    Cv = C @ v
    for side in (u, l):
        hit = np.isfinite(side) & (np.abs(Cv - side) <= tol)
        rows.append(C[hit])
        rhs.append(side[hit])
    for side in (ub, lb):
        hit = np.isfinite(side) & (np.abs(v - side) <= tol)
        rows.append(np.eye(n)[hit])
        rhs.append(side[hit])
    E, e = np.vstack(rows), np.concatenate(rhs)
    m = E.shape[0]
    K = np.block([[H, E.T], [E, np.zeros((m, m))]])
    k_rhs = np.concatenate([-g, e])
    sol = np.linalg.lstsq(K, k_rhs, rcond=None)[0]
    for _ in range(3):
        sol += np.linalg.lstsq(K, k_rhs - K @ sol, rcond=None)[0]
    return _distance(H, v, sol[:n])


def _quadprog(H, g, A, b, C, l, u, lb, ub):
    """quadprog on the QP, its inequalities and bounds as rows G v ≤ h, the infinite sides left out (large finite
    stand-ins for them spoil its answer by ≈ 1e-6)."""
    eye = np.eye(H.shape[0])
    G = np.vstack([C, -C, eye, -eye])
    h = np.concatenate([u, -l, ub, -lb])
    keep = np.isfinite(h)
    return qpsolvers.solve_qp(H, g, G=G[keep] if keep.any() else None, h=h[keep] if keep.any() else None,
                              A=A if A.shape[0] else None, b=b if A.shape[0] else None, solver="quadprog")


# a draw on which the range-space solve without refinement ended 1.4e-9 off in the H-metric (residual 3.9e-11 on the
# second contact's rows: the Schur complement squares their conditioning)
_ILL_CONDITIONED_CONTACTS = {
    "robot": "humanoid15", "seed": 1, "spread": 0.125, "com": False, "com_weight": 1.0, "gain": 1.0,
    "frame_tasks": [0, 0, 1], "posture": False, "posture_weight": 1.0, "posture_gain": 1.0, "contacts": 2,
    "contact_gain": 1.0, "offset": 0.0, "position_limit": False, "velocity_limit": False, "velocity_scale": 1.0,
    "dt": 0.015625}

# a draw where DAQP ends with an equality residual of 8.7e-10 and 3.05e-7 from the compiled answer in the H-metric,
# all of it explained by that residual (its H-metric projection onto the equalities lands 3.8e-12 from the compiled
# answer; quadprog agrees with the compiled answer to 8.6e-15)
_DAQP_EQUALITY_RESIDUAL = {**_ILL_CONDITIONED_CONTACTS, "spread": 0.015625, "frame_tasks": []}

# a draw where DAQP ends 1.749e-9 (H-metric) from the exact optimum of its active set (8 velocity bounds, the same set
# as the compiled solver's) with an equality residual of 8e-11 that accounts for 2.7e-11 of it; the compiled answer
# is 1.5e-16 from that optimum, quadprog 9.9e-15
_DAQP_OFF_ITS_ACTIVE_SET = {
    "robot": "humanoid15", "seed": 81, "spread": 0.015625, "com": True, "com_weight": 0.5, "gain": 36.0,
    "frame_tasks": [], "posture": False, "posture_weight": 1.0, "posture_gain": 1.0, "contacts": 2,
    "contact_gain": 1.0, "offset": 0.0, "position_limit": False, "velocity_limit": True, "velocity_scale": 0.25,
    "dt": 0.015625}


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(draw=_draws)
@example(draw=_ILL_CONDITIONED_CONTACTS)
@example(draw=_DAQP_EQUALITY_RESIDUAL)
@example(draw=_DAQP_OFF_ITS_ACTIVE_SET)
def test_compiled_and_general_solvers_receive_one_assembled_qp(draw):
    robot = _robot(draw["robot"])
    dt = draw["dt"]
    fast, config = _build(robot, draw, "fast")
    general, config_g = _build(robot, draw, "daqp")
    received = []  # (the compiled solver's QP as its buffers held it when solved, its exit code, its v)
    tick_packed = compiled_tick.kinematic_tick_packed

    def spy(bufs, *args):  # the kernel forms H, g, then solves reading (never writing) the QP: read after it
        it, guard = tick_packed(bufs, *args)
        received.append((bufs.fb, bufs.fb.copy(), it, args[3].copy()))
        return it, guard

    kernel = compiled_tick.FusedPlan.tick_kernel  # (specialised once per process, with the first plan)
    compiled_tick.FusedPlan.tick_kernel = spy
    try:
        fast.solve(config, dt)
    finally:
        compiled_tick.FusedPlan.tick_kernel = kernel
    handed = []  # what the general path hands its backend

    def backend_spy(*qp, _solve=general.backend.solve, **kw):
        handed.append([np.array(a, copy=True) for a in qp])
        return _solve(*qp, **kw)

    general.backend.solve = backend_spy
    general.solve(config_g, dt)
    assert handed, "the general path solved no QP"
    event(f"compiled solver {'not called' if not received else 'solved' if received[0][2] >= 1 else 'gave up'}")
    if not received:  # not a tick the compiled solver covers: dependent equality rows (two flat 5-DoF legs)
        from wbc.solvers.hierarchy import independent_rows

        assert independent_rows(fast.assemble(config, dt)[2]).size < fast.assemble(config, dt)[2].shape[0]
        return
    fb, snapshot, it, v_compiled = received[0]
    # 1. the compiled solver read the assemble() buffers themselves, holding the general path's QP bit for bit
    qp = fast.assemble(config, dt)
    for a in qp:
        assert a.size == 0 or np.shares_memory(a, fb)
    offsets = [(a.ctypes.data - fb.ctypes.data) // fb.itemsize for a in qp]
    seen = [snapshot[o:o + a.size].reshape(a.shape) for o, a in zip(offsets, qp)]
    assert _bits(seen) == _bits(qp)  # assembly deterministic: the same config gives the same bits
    assert _bits(seen) == _bits(handed[0])
    # 2. both solvers on that QP agree where both succeed; quadprog on the same arrays is the oracle
    try:
        v_daqp = DaqpBackend().solve(*seen)
    except SolverError:
        v_daqp = None
    ref = _quadprog(*seen)
    H = seen[0]
    if it >= 1:
        assert ref is not None
        assert _distance(H, v_compiled, ref) <= ORACLE * max(1.0, _distance(H, ref, 0.0))
        scale = max(1.0, _distance(H, v_compiled, 0.0))
        assert _active_set_offset(*seen, v_compiled) <= AGREEMENT * scale
        if v_daqp is not None:
            H, A, b = seen[0], seen[2], seen[3]
            slack = _equality_offset(H, A, b, v_compiled) + _active_set_offset(*seen, v_daqp)
            assert _distance(H, v_compiled, v_daqp) <= AGREEMENT * max(1.0, _distance(H, v_daqp, 0.0)) + slack


@pytest.mark.parametrize("name", ["talos", "g1", "humanoid15"])
def test_compiled_tick_solves_the_assembled_qp_on_a_standing_set(name):
    """A deterministic instance of the property: a sole in contact where it is, CoM, torso, posture, limits: the compiled
    tick is taken (route ``compiled``) and its command is the optimum of the assembled QP (quadprog, AGREEMENT)."""
    robot = _robot(name)
    draw = {"seed": 3, "spread": 0.05, "com": True, "com_weight": 10.0, "gain": 2.0, "frame_tasks": [2],
            "posture": True, "posture_weight": 1e-2, "posture_gain": 1.0, "contacts": 1, "contact_gain": 100.0,
            "offset": 0.0, "position_limit": True, "velocity_limit": True, "velocity_scale": 1.0}
    ctrl, config = _build(robot, draw, "fast")
    result = ctrl.solve(config, 0.002)
    assert result.ok and str(result.path) == "compiled", (result.path, result.message)
    qp = ctrl.assemble(config, 0.002)
    ref = _quadprog(*qp)
    assert _distance(qp[0], result.v, ref) <= AGREEMENT * max(1.0, _distance(qp[0], ref, 0.0))


def test_compiled_tick_result_is_the_dataclass_result():
    """The compiled tick's TickResult has every field of the dataclass, equal to the one its constructor gives for the
    same v, timings, sole_drift and path (the others at their defaults), and lists of its own on each tick."""
    robot = _robot("talos")
    draw = {"seed": 3, "spread": 0.05, "com": True, "com_weight": 10.0, "gain": 2.0, "frame_tasks": [2],
            "posture": True, "posture_weight": 1e-2, "posture_gain": 1.0, "contacts": 2, "contact_gain": 100.0,
            "offset": 0.0, "position_limit": True, "velocity_limit": True, "velocity_scale": 1.0}
    ctrl, config = _build(robot, draw, "fast")
    first, second = ctrl.solve(config, 0.002), ctrl.solve(config, 0.002)
    for result in (first, second):
        assert str(result.path) == "compiled", (result.path, result.message)
        built = tick.TickResult(result.v, timings=result.timings, sole_drift=result.sole_drift, path=result.path)
        assert list(vars(result)) == [f.name for f in dataclasses.fields(tick.TickResult)]
        # field by field (Python 3.13's dataclass __eq__ compares fields with ==, which an array field cannot answer)
        assert all(np.array_equal(a, b) if isinstance(a, np.ndarray) else a == b
                   for a, b in zip(vars(result).values(), vars(built).values())), (vars(result), vars(built))
        assert result.ok and result.conflicts == [] and result.relaxed == [] and result.fallback == ""
    assert first.conflicts is not second.conflicts and first.relaxed is not second.relaxed


@pytest.mark.parametrize("name", ["talos", "g1", "humanoid15"])
def test_strict_levels_take_the_gathered_rows(name):
    """The strict levels (route ``levels``) receive the rows that ``assemble`` gathered, with the weights applied by
    the formula of the soft level's cost (``wbc.formulations.velocity_kernel.weighted_rows``): √w J and √w v*, v* = ė* −
    K e, against the tasks' own ``compute`` and ``velocity_target`` in numpy (to 1e-12 relative: the compiled product
    may be fused)."""
    robot = _robot(name)
    draw = {"seed": 5, "spread": 0.05, "com": False, "com_weight": 1.0, "gain": 2.0, "frame_tasks": [],
            "posture": True, "posture_weight": 1e-2, "posture_gain": 1.0, "contacts": 2, "contact_gain": 100.0,
            "offset": 0.0, "position_limit": True, "velocity_limit": True, "velocity_scale": 1.0}
    ctrl, config = _build(robot, draw, "fast")
    hand = PositionTask(robot, robot.right_hand or robot.torso, gain=3.0, name="hand")
    hand.set_target(config.frame_placement(hand.frame_id).translation + np.array([0.05, -0.02, 0.03]))
    hand.weight = np.array([1.0, 4.0, 0.5])
    com = ComTask(weight=np.array([2.0, 2.0, 0.1]), gain=5.0)
    com.set_target(config.com + np.array([0.01, 0.0, -0.01]))
    ctrl.add_task(hand, level=0)
    ctrl.add_task(com, level=1)
    seen = []
    cascade = general_route.solve_lexicographic

    def spy(levels, *args, **kw):
        seen.append([(J.copy(), t.copy()) for J, t in levels])
        out = cascade(levels, *args, **kw)
        spy.last_cut = cascade.last_cut
        return out

    general_route.solve_lexicographic = spy
    ctrl.budget = math.inf  # (at 2 ms the new layout's tick starts on the levels' weighted form: no cascade)
    try:
        result = ctrl.solve(config, 0.002)
    finally:
        general_route.solve_lexicographic = cascade
    assert result.ok and result.path.route == "levels", (result.path, result.message)
    for (J, t), task in zip(seen[0], (hand, com)):
        error, jac = task.compute(config)
        sw = np.sqrt(task.weight)
        ref_J, ref_t = jac * sw[:, None], task.velocity_target(error) * sw
        assert np.abs(J - ref_J).max() <= 1e-12 * max(1.0, np.abs(ref_J).max())
        assert np.abs(t - ref_t).max() <= 1e-12 * max(1.0, np.abs(ref_t).max())
