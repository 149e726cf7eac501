"""Gait layer: footsteps, support geometry, LIPM/DCM CoM plan, swing feet, replanning."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from scipy.spatial import ConvexHull

from wbc.exceptions import GaitError, InvalidInputError
from wbc.gait import (
    DOUBLE_SUPPORT,
    LEFT_SUPPORT,
    RIGHT_SUPPORT,
    WalkPlan,
    convex_hull,
    feet_overlap,
    min_jerk,
    plan_footsteps,
    plan_walk,
    polygons_overlap,
    signed_distance,
    sole_polygon,
)

DT = 0.002
Z_COM = 0.87
HALF_WIDTH = 0.085  # Talos: soles at y = ±0.085 in the reference posture


def pose(x: float, y: float, yaw: float = 0.0) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0, x], [s, c, 0.0, y], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


def lifted(m: np.ndarray, z: float) -> np.ndarray:
    m = m.copy()
    m[2, 3] = z
    return m


def talos_size_walk(**kw) -> WalkPlan:
    args = dict(n_steps=8, step_length=0.15)
    args.update(kw)
    return plan_walk(pose(0.0, HALF_WIDTH), pose(0.0, -HALF_WIDTH), np.array([0.0, 0.0, Z_COM]), **args)


def _straight() -> WalkPlan:
    return talos_size_walk()


def _turning() -> WalkPlan:
    return talos_size_walk(n_steps=8, step_length=0.1, turn=0.15, first_side="left")


def _one_step() -> WalkPlan:
    return talos_size_walk(n_steps=1)


def _replanned() -> WalkPlan:
    plan = talos_size_walk(n_steps=6)
    k = plan.index(2.5)  # mid single support (SS of step 2: 2.1 s .. 2.9 s)
    assert plan.support[k] != DOUBLE_SUPPORT
    return plan.replan(k, plan.com[k], plan.com_vel[k] + np.array([0.04, -0.05, 0.0]))


PLANS = {"straight_8x0.15": _straight, "turning": _turning, "one_step": _one_step, "replan": _replanned}


@pytest.fixture(scope="module", params=list(PLANS))
def any_plan(request) -> WalkPlan:
    return PLANS[request.param]()


# ---------------------------------------------------------------------------------------------- support.py


def test_sole_polygon_corners_ccw():
    poly = sole_polygon(1.0, 2.0, math.pi / 2, 0.2, 0.1)
    np.testing.assert_allclose(poly, [[0.95, 2.1], [0.95, 1.9], [1.05, 1.9], [1.05, 2.1]], atol=1e-12)
    x, y = poly[:, 0], poly[:, 1]
    assert np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y) > 0  # CCW: positive signed area


def test_convex_hull_matches_scipy():
    rng = np.random.default_rng(0)
    for _ in range(20):
        pts = rng.normal(size=(30, 2))
        hull = convex_hull(pts)
        ref = pts[ConvexHull(pts).vertices]
        assert {tuple(p) for p in hull.tolist()} == {tuple(p) for p in ref.tolist()}
        x, y = hull[:, 0], hull[:, 1]
        assert np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y) > 0


def test_convex_hull_drops_collinear_and_rejects_degenerate():
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0], [0.5, 0.5]], dtype=float)
    assert len(convex_hull(square)) == 4
    with pytest.raises(InvalidInputError):
        convex_hull(np.array([[0, 0], [1, 1], [2, 2.0]]))
    with pytest.raises(InvalidInputError):
        convex_hull(np.zeros((2, 2)))


def test_signed_distance_values_and_vectorisation():
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    pts = np.array([[0.5, 0.5], [0.9, 0.5], [2.0, 0.5], [2.0, 2.0], [-0.5, 0.5], [1.0, 0.3]])
    expected = [0.5, 0.1, -1.0, -math.sqrt(2), -0.5, 0.0]
    np.testing.assert_allclose(signed_distance(pts, square), expected, atol=1e-12)
    np.testing.assert_allclose(signed_distance(pts, square[::-1]), expected, atol=1e-12)  # CW input
    for p, e in zip(pts, expected):
        d = signed_distance(p, square)
        assert isinstance(d, float) and d == pytest.approx(e, abs=1e-12)
    with pytest.raises(InvalidInputError):
        signed_distance(np.array([np.nan, 0.0]), square)
    with pytest.raises(InvalidInputError):
        signed_distance(np.zeros(3), square)


def test_signed_distance_random_against_brute_force():
    rng = np.random.default_rng(1)
    poly = convex_hull(rng.normal(size=(12, 2)))
    pts = rng.normal(scale=2.0, size=(500, 2))
    d = signed_distance(pts, poly)
    # Brute force: distance to densely sampled boundary; sign from the half-planes.
    edges = [(poly[i], poly[(i + 1) % len(poly)]) for i in range(len(poly))]
    boundary = np.vstack([a + np.linspace(0, 1, 2001)[:, None] * (b - a) for a, b in edges])
    dist = np.min(np.linalg.norm(pts[:, None, :] - boundary[None], axis=2), axis=1)
    inside = np.all([(b - a)[0] * (pts[:, 1] - a[1]) - (b - a)[1] * (pts[:, 0] - a[0]) >= 0 for a, b in edges],
                    axis=0)
    np.testing.assert_allclose(np.abs(d), dist, atol=2e-3)
    assert np.all((d > 0) == inside)


def test_polygons_overlap_and_feet_overlap():
    a = sole_polygon(0, 0, 0, 0.2, 0.1)
    assert polygons_overlap(a, sole_polygon(0, 0.09, 0, 0.2, 0.1))
    assert not polygons_overlap(a, sole_polygon(0, 0.11, 0, 0.2, 0.1))
    assert polygons_overlap(a, sole_polygon(0, 0.11, 0, 0.2, 0.1), clearance=0.011)  # 1 cm gap < clearance
    assert polygons_overlap(a, sole_polygon(0.2, 0.0, math.pi / 4, 0.2, 0.1))  # rotated corner reaches in
    assert not polygons_overlap(a, sole_polygon(0.25, 0.0, math.pi / 4, 0.2, 0.1))
    got = feet_overlap(np.array([[0, 0, 0]] * 4),
                       np.array([[0, 0.09, 0], [0, 0.11, 0], [0.2, 0, math.pi / 4], [0.25, 0, math.pi / 4]]),
                       0.2, 0.1)
    assert got.tolist() == [True, False, True, False]


# -------------------------------------------------------------------------------------------- footsteps


def test_straight_footsteps_geometry():
    steps = plan_footsteps((0, HALF_WIDTH, 0), (0, -HALF_WIDTH, 0), 8, 0.15, 0.17)
    assert [s.side for s in steps] == ["left", "right"] * 4
    for i, s in enumerate(steps[:-1]):
        assert s.x == pytest.approx(0.15 * (i + 1)) and s.yaw == 0.0
        assert s.y == pytest.approx(HALF_WIDTH if s.side == "left" else -HALF_WIDTH)
    assert steps[-1].x == pytest.approx(steps[-2].x)  # closing step alongside
    assert steps[-1].y - steps[-2].y == pytest.approx(-0.17)
    plan = _straight()
    assert plan.planned_distance == pytest.approx(7 * 0.15, abs=1e-12)
    assert plan.footsteps == tuple(steps)


def test_turning_footsteps_geometry():
    L, w, turn = 0.1, 0.17, 0.15
    steps = plan_footsteps((0, HALF_WIDTH, 0), (0, -HALF_WIDTH, 0), 6, L, w, turn, "right")
    feet = {"left": (0, HALF_WIDTH, 0.0), "right": (0, -HALF_WIDTH, 0.0)}
    for i, s in enumerate(steps):
        stance = feet["left" if s.side == "right" else "right"]
        closing = i == len(steps) - 1
        assert s.yaw - stance[2] == pytest.approx(0.0 if closing else turn)
        c, sn = math.cos(s.yaw), math.sin(s.yaw)
        dx, dy = s.x - stance[0], s.y - stance[1]
        local = (c * dx + sn * dy, -sn * dx + c * dy)  # offset in the new heading frame
        sign = 1.0 if s.side == "left" else -1.0
        assert local == pytest.approx((0.0 if closing else L, sign * w), abs=1e-12)
        feet[s.side] = (s.x, s.y, s.yaw)
    assert steps[-1].yaw == pytest.approx(5 * turn)


def test_first_side_right_and_one_step():
    plan = talos_size_walk(n_steps=3, first_side="right")
    assert [s.side for s in plan.footsteps] == ["right", "left", "right"]
    assert plan.support[plan.phases[1].first] == LEFT_SUPPORT
    one = _one_step()
    assert len(one.footsteps) == 1 and one.planned_distance == pytest.approx(0.0, abs=1e-12)
    assert one.footsteps[0].side == "left"
    assert [ph.support for ph in one.phases] == [DOUBLE_SUPPORT, RIGHT_SUPPORT, DOUBLE_SUPPORT]


# ------------------------------------------------------------------------------------------- CoM / ZMP


def test_zmp_equals_reference_and_stays_in_support(any_plan):
    p = any_plan.com[:, :2] - any_plan.com_acc[:, :2] / any_plan.omega**2
    np.testing.assert_allclose(p, any_plan.zmp, rtol=0, atol=1e-9)
    margin = any_plan.zmp_margin()
    assert margin.shape == (any_plan.n_samples,)
    assert margin.min() >= 0.0, f"min ZMP margin {margin.min():.6f} m"


def test_expected_min_margins():
    # Single support keeps the ZMP at the sole centre: margin = half the sole width (0.13 / 2).
    for name in ("straight_8x0.15", "turning", "one_step"):
        assert PLANS[name]().zmp_margin().min() == pytest.approx(0.065, abs=1e-9), name
    assert _replanned().zmp_margin().min() > 0.0


def test_lipm_dynamics_against_finite_differences(any_plan):
    c, v, a, dt = any_plan.com, any_plan.com_vel, any_plan.com_acc, any_plan.dt
    np.testing.assert_allclose(a[:, :2], any_plan.omega**2 * (c[:, :2] - any_plan.zmp), rtol=0, atol=1e-9)
    v_fd = (c[2:] - c[:-2]) / (2 * dt)
    a_fd = (c[2:] - 2 * c[1:-1] + c[:-2]) / dt**2
    # Central differences: O(dt²) error, |c'''| dt²/6 ~ 1e-6 m/s. The second difference is O(dt) at segment
    # boundaries where c''' = ω²(ċ − ṗ) jumps with the ZMP slope: dt·ω²·|Δṗ|/6 ≈ 2e-3 m/s².
    assert np.abs(v_fd - v[1:-1]).max() < 1e-5
    assert np.abs(a_fd - a[1:-1]).max() < 5e-3
    assert np.all(c[:, 2] == any_plan.com_height) and np.all(v[:, 2] == 0) and np.all(a[:, 2] == 0)
    np.testing.assert_allclose(any_plan.dcm, c[:, :2] + v[:, :2] / any_plan.omega, atol=1e-12)


def test_com_continuity(any_plan):
    c, v, a, dt = any_plan.com, any_plan.com_vel, any_plan.com_acc, any_plan.dt
    dc = np.linalg.norm(np.diff(c, axis=0), axis=1)
    dv = np.linalg.norm(np.diff(v, axis=0), axis=1)
    assert dc.max() <= dt * np.linalg.norm(v, axis=1).max() * (1 + 1e-6)
    assert dv.max() <= dt * np.linalg.norm(a, axis=1).max() * (1 + 1e-6)
    # Acceleration continuity too: c̈ = ω²(c − p) with c and the ZMP reference p both continuous, so per
    # sample |Δc̈| <= ω² (max|Δc| + max|Δp|); a ZMP jump would break this bound.
    dp = np.linalg.norm(np.diff(any_plan.zmp, axis=0), axis=1)
    da = np.linalg.norm(np.diff(a, axis=0), axis=1)
    assert da.max() <= any_plan.omega**2 * (dc.max() + dp.max()) * (1 + 1e-6)


def test_starts_at_rest_and_settles():
    plan = _straight()
    np.testing.assert_allclose(plan.com[0], [0.0, 0.0, Z_COM], atol=1e-12)
    assert np.abs(plan.com_vel[0]).max() < 1e-9
    mid = 0.5 * (plan.left_sole[-1, :2, 3] + plan.right_sole[-1, :2, 3])
    np.testing.assert_allclose(plan.dcm[-1], mid, atol=1e-12)  # terminal DCM on the final ZMP
    np.testing.assert_allclose(plan.zmp[-1], mid, atol=1e-12)
    # The CoM converges to the DCM as e^{-ω t} during the 0.9 s hold: measured |ċ| ≈ 4.2 mm/s, 1.2 mm off.
    assert np.linalg.norm(plan.com_vel[-1]) < 0.006
    assert np.linalg.norm(plan.com[-1, :2] - mid) < 0.002


def test_initial_zmp_inside_start_polygon_and_com_velocity_start():
    plan = talos_size_walk(n_steps=4, com_velocity=np.array([0.05, 0.02, 0.1]))
    assert plan.com_vel[0, :2] == pytest.approx([0.05, 0.02], abs=1e-12)
    assert plan.zmp_margin().min() >= 0.0


# ------------------------------------------------------------------------------------------------ replan


def test_replan_without_perturbation_reproduces_plan():
    plan = talos_size_walk(n_steps=6)
    for k in (0, 1, plan.index(1.0), plan.index(1.5), plan.index(2.95), plan.n_samples - 2):
        r = plan.replan(k, plan.com[k], plan.com_vel[k])
        assert r.n_samples == plan.n_samples - k and r.t_offset == pytest.approx(k * DT)
        np.testing.assert_allclose(r.com, plan.com[k:], atol=1e-9)
        np.testing.assert_allclose(r.com_vel, plan.com_vel[k:], atol=1e-9)
        np.testing.assert_allclose(r.zmp, plan.zmp[k:], atol=1e-8)
        assert np.array_equal(r.left_sole, plan.left_sole[k:]) and np.array_equal(r.support, plan.support[k:])
        assert r.footsteps == plan.footsteps[len(plan.footsteps) - len(r.footsteps):]


def test_replan_with_perturbed_velocity_starts_at_state():
    plan = talos_size_walk(n_steps=6)
    k = plan.index(3.0)
    v = plan.com_vel[k] + np.array([0.04, -0.05, 0.0])
    r = plan.replan(k, plan.com[k], v)
    np.testing.assert_allclose(r.com[0, :2], plan.com[k, :2], atol=1e-12)
    np.testing.assert_allclose(r.com_vel[0, :2], v[:2], atol=1e-12)
    assert r.t[0] == 0.0 and r.duration == pytest.approx(plan.duration - k * DT)
    assert r.zmp_margin().min() >= 0.0
    # The reference is unchanged after the current segment.
    seg_end = r.segments.first[1]
    np.testing.assert_allclose(r.zmp[seg_end:], plan.zmp[k + seg_end:], atol=1e-12)
    # Replanning twice composes.
    r2 = r.replan(10, r.com[10], r.com_vel[10])
    assert r2.t_offset == pytest.approx((k + 10) * DT)
    np.testing.assert_allclose(r2.com, r.com[10:], atol=1e-9)


def test_replan_rejects_uncapturable_state_and_bad_input():
    plan = talos_size_walk(n_steps=4)
    k = plan.index(2.0)
    with pytest.raises(GaitError, match="outside the current support polygon"):
        plan.replan(k, plan.com[k], plan.com_vel[k] + np.array([0.0, 1.0, 0.0]))
    for bad_k in (-1, plan.n_samples - 1, 1.5, True):
        with pytest.raises(GaitError):
            plan.replan(bad_k, plan.com[0], plan.com_vel[0])
    with pytest.raises(GaitError):
        plan.replan(k, np.array([0.0, np.nan, Z_COM]), plan.com_vel[k])
    with pytest.raises(GaitError):
        plan.replan(k, plan.com[k], np.zeros(2))


# ------------------------------------------------------------------------------------------------ swing


def _rot_fd(R: np.ndarray, dt: float) -> np.ndarray:
    """World angular velocity from central differences of (N, 3, 3) rotations, samples 1..N-2."""
    out = np.empty((R.shape[0] - 2, 3))
    for i in range(1, R.shape[0] - 1):
        out[i - 1] = R[i] @ pin.log3(R[i - 1].T @ R[i + 1]) / (2 * dt)
    return out


@pytest.mark.parametrize("name", ["straight_8x0.15", "turning"])
def test_swing_trajectories(name):
    plan = PLANS[name]()
    h = 0.05
    for ph in plan.phases:
        if ph.support == DOUBLE_SUPPORT:
            continue
        swing_side = "right" if ph.support == LEFT_SUPPORT else "left"
        sw = getattr(plan, f"{swing_side}_sole")
        sw_v = getattr(plan, f"{swing_side}_sole_vel")
        st = getattr(plan, f"{'left' if swing_side == 'right' else 'right'}_sole")
        st_v = getattr(plan, f"{'left' if swing_side == 'right' else 'right'}_sole_vel")
        lo, td = ph.first, ph.end
        # Zero velocity at lift-off and touch-down; the stance foot does not move at all.
        assert np.all(sw_v[lo] == 0.0) and np.all(sw_v[td] == 0.0)
        assert np.all(st[lo:td + 1] == st[lo]) and np.all(st_v[lo:td + 1] == 0.0)
        # Lands exactly on the footstep; clearance peaks at h mid-swing.
        assert np.array_equal(sw[td], plan.footsteps[ph.step].pose())
        assert sw[lo:td + 1, 2, 3].max() == pytest.approx(h, abs=1e-3)
        assert sw[(lo + td) // 2, 2, 3] == pytest.approx(h, abs=1e-12)
        # Analytic velocities match central differences of the poses.
        seg = slice(lo, td + 1)
        v_fd = (sw[seg][2:, :3, 3] - sw[seg][:-2, :3, 3]) / (2 * plan.dt)
        assert np.abs(v_fd - sw_v[seg][1:-1, :3]).max() < 2e-4
        w_fd = _rot_fd(sw[seg][:, :3, :3], plan.dt)
        assert np.abs(w_fd - sw_v[seg][1:-1, 3:]).max() < 2e-4
        # Swing rotations stay orthonormal.
        R = sw[seg][:, :3, :3]
        assert np.abs(np.einsum("nji,njk->nik", R, R) - np.eye(3)).max() < 1e-12


def test_feet_poses_exact_at_ends_and_constant_between_swings():
    L0, R0 = pose(0.0, HALF_WIDTH), pose(0.0, -HALF_WIDTH)
    plan = plan_walk(L0, R0, np.array([0.0, 0.0, Z_COM]), n_steps=5, step_length=0.12)
    assert np.array_equal(plan.left_sole[0], L0) and np.array_equal(plan.right_sole[0], R0)
    last = {fs.side: fs for fs in plan.footsteps}
    assert np.array_equal(plan.left_sole[-1], last["left"].pose())
    assert np.array_equal(plan.right_sole[-1], last["right"].pose())
    swinging = {"left": np.zeros(plan.n_samples, bool), "right": np.zeros(plan.n_samples, bool)}
    for ph in plan.phases:
        if ph.step >= 0:
            swinging[plan.footsteps[ph.step].side][ph.first + 1:ph.end] = True
    for side in ("left", "right"):
        poses, vel = getattr(plan, f"{side}_sole"), getattr(plan, f"{side}_sole_vel")
        rest = ~swinging[side]
        changes = np.flatnonzero(np.any(poses[1:] != poses[:-1], axis=(1, 2)) & rest[1:] & rest[:-1])
        assert changes.size == 0
        assert np.all(vel[rest] == 0.0)


def test_min_jerk_profile():
    s = np.linspace(0, 1, 11)
    b, db, _ = min_jerk(s)
    assert b[0] == 0.0 and b[-1] == 1.0 and db[0] == 0.0 and db[-1] == 0.0
    assert b[5] == pytest.approx(0.5)


# ------------------------------------------------------------------------------------------ plan basics


def test_plan_structure_and_immutability():
    plan = _straight()
    n = plan.n_samples
    assert plan.t.shape == (n,) and plan.t[1] == DT and plan.duration == pytest.approx(plan.t[-1])
    assert plan.duration == pytest.approx(1.0 + 8 * 0.8 + 7 * 0.3 + 1.2)
    for name, shape in [("com", (n, 3)), ("com_vel", (n, 3)), ("com_acc", (n, 3)), ("zmp", (n, 2)),
                        ("dcm", (n, 2)), ("left_sole", (n, 4, 4)), ("right_sole", (n, 4, 4)),
                        ("left_sole_vel", (n, 6)), ("right_sole_vel", (n, 6)), ("support", (n,))]:
        arr = getattr(plan, name)
        assert arr.shape == shape, name
        with pytest.raises(ValueError):
            arr[0] = 0
    assert plan.support.dtype == np.int8 and plan.support[0] == DOUBLE_SUPPORT and plan.support[-1] == 0
    assert set(np.unique(plan.support).tolist()) == {0, 1, 2}
    assert sum(ph.count for ph in plan.phases) == n - 1
    assert plan.index(0.0) == 0 and plan.index(1.0) == 500 and plan.index(1e9) == n - 1 and plan.index(-3) == 0
    with pytest.raises(GaitError):
        plan.index(float("nan"))
    poly = plan.support_polygon_at(plan.phases[1].first + 3)
    assert poly.shape == (4, 2)
    assert plan.support_polygon_at(0).shape[0] >= 4


def test_talos_robot_feet():
    """Real Talos soles (0.0017 rad roll in the reference posture) and CoM."""
    from wbc import load_robot

    robot = load_robot("talos")
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, robot.q_ref)
    L0 = data.oMf[robot.frame_id(robot.left_sole)]
    R0 = data.oMf[robot.frame_id(robot.right_sole)]
    com = pin.centerOfMass(robot.model, data, robot.q_ref)
    plan = plan_walk(L0, R0, com, n_steps=6, sole_length=robot.sole_length, sole_width=robot.sole_width)
    assert np.array_equal(plan.left_sole[0], L0.homogeneous) and np.array_equal(plan.right_sole[0], R0.homogeneous)
    assert plan.zmp_margin().min() >= 0.0
    assert plan.planned_distance == pytest.approx(5 * 0.15, abs=1e-9)
    # The first swing of each foot also levels the sole: velocities stay consistent with the poses.
    w = _rot_fd(plan.left_sole[:, :3, :3], plan.dt)
    assert np.abs(w - plan.left_sole_vel[1:-1, 3:]).max() < 2e-4
    assert np.allclose(plan.left_sole[-1, :3, :3] @ [0, 0, 1], [0, 0, 1])


# ------------------------------------------------------------------------------------------- bad inputs


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(n_steps=0), "n_steps"),
        (dict(n_steps=2.0), "n_steps"),
        (dict(n_steps=True), "n_steps"),
        (dict(t_ss=-0.8), "t_ss"),
        (dict(t_ds=0.0), "t_ds"),
        (dict(t_init=float("nan")), "t_init"),
        (dict(t_final=0.001), "t_final"),
        (dict(dt=0.0), "dt"),
        (dict(step_height=-0.01), "step_height"),
        (dict(step_width=0.1), "step_width"),
        (dict(step_length=float("inf")), "step_length"),
        (dict(turn=2.0), "turn"),
        (dict(sole_length=0.0), "sole_length"),
        (dict(first_side="middle"), "first_side"),
        (dict(com_velocity=np.zeros(2)), "com_velocity"),
        (dict(com_velocity=np.array([0.0, 2.0, 0.0])), "outside the current support polygon"),
    ],
)
def test_bad_arguments_raise_gait_error(kwargs, match):
    with pytest.raises(GaitError, match=match):
        talos_size_walk(**kwargs)


@pytest.mark.parametrize(
    "left, right, com, match",
    [
        (pose(0, 0.085), pose(0, -0.085), np.array([0.0, np.nan, Z_COM]), "com"),
        (pose(0, 0.085), pose(0, -0.085), np.zeros(2), "com"),
        (pose(0, 0.085), pose(0, -0.085), np.array([0.0, 0.0, -0.1]), "com"),
        (np.eye(3), pose(0, -0.085), np.array([0.0, 0.0, Z_COM]), "left_sole"),
        (pose(0, 0.085), "foot", np.array([0.0, 0.0, Z_COM]), "right_sole"),
        (pose(0, -0.085), pose(0, 0.085), np.array([0.0, 0.0, Z_COM]), "left of"),
        (pose(0, 0.05), pose(0, -0.05), np.array([0.0, 0.0, Z_COM]), "overlap"),
        (lifted(pose(0, 0.085), 0.2), pose(0, -0.085), np.array([0.0, 0.0, Z_COM]), "flat"),
        (pin.SE3(pin.rpy.rpyToMatrix(0.3, 0, 0), np.array([0, 0.085, 0])), pose(0, -0.085),
         np.array([0.0, 0.0, Z_COM]), "flat"),
        (pose(0, 0.085) @ np.diag([1.0, 1.0, 2.0, 1.0]), pose(0, -0.085), np.array([0.0, 0.0, Z_COM]), "rigid"),
    ],
)
def test_bad_feet_or_com_raise_gait_error(left, right, com, match):
    with pytest.raises(GaitError, match=match):
        plan_walk(left, right, com)


def test_gait_error_is_invalid_input():
    assert issubclass(GaitError, InvalidInputError) and issubclass(GaitError, ValueError)
