"""wbc.gait.terrain_walk: footholds on treads, soles on slopes, swings over the edges, CoM height from the VRP —
checked against the stairs' tread intervals, closed-form slope geometry and finite differences of the plan."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wbc.exceptions import GaitError
from wbc.gait import plan_walk
from wbc.gait.terrain_walk import plan_terrain_walk
from wbc.terrain import parse_terrain

L, W = 0.22, 0.13  # sole (m)


def _feet():
    left, right = np.eye(4), np.eye(4)
    left[1, 3], right[1, 3] = 0.085, -0.085
    return left, right, np.array([0.0, 0.0, 0.87])


def _plan(spec, **kw):
    left, right, com = _feet()
    kw = {"n_steps": 6, "step_length": 0.3, "sole_length": L, "sole_width": W, **kw}
    return plan_terrain_walk(spec, left, right, com, **kw)


def test_flat_terrain_gives_the_flat_plan_bit_for_bit():
    left, right, com = _feet()
    a = plan_walk(left, right, com, n_steps=4, step_length=0.2, sole_length=L, sole_width=W)
    b = _plan("flat", n_steps=4, step_length=0.2).plan
    for name in ("com", "com_vel", "com_acc", "zmp", "dcm", "left_sole", "right_sole", "left_sole_vel",
                 "right_sole_vel", "support"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name


@pytest.mark.parametrize("spec", ["stairs:0.1:0.3:3:up", "stairs:0.15:0.3:4:updown", "stairs:0.15:0.3:3:down"])
def test_footholds_lie_on_one_tread_with_the_edge_margin(spec):
    margin = 0.02
    tw = _plan(spec, n_steps=12, edge_margin=margin)
    treads = tw.terrain.treads
    for H in tw.footholds:
        x, z = H[0, 3], H[2, 3]
        lo, hi = x - L / 2 - margin, x + L / 2 + margin
        inside = [tr for tr in treads if tr[0] - 1e-9 <= lo and hi <= tr[1] + 1e-9]
        assert len(inside) == 1, f"sole over x in [{lo:.3f}, {hi:.3f}] is not on one tread"
        assert z == pytest.approx(inside[0][2], abs=1e-12)
        assert np.allclose(H[:3, 2], [0, 0, 1])


def test_swing_soles_clear_every_riser_edge():
    """Where any underside point of a swinging sole is over a tread, it is above that tread by the clearance (the
    planner's check uses a 5 x 3 grid; here 21 x 7 points, riser edges included, away from the footholds)."""
    clearance = 0.03
    tw = _plan("stairs:0.15:0.3:4:updown", n_steps=14, clearance=clearance)
    p, terrain = tw.plan, tw.terrain
    u, w = np.meshgrid(np.linspace(-L / 2, L / 2, 21), np.linspace(-W / 2, W / 2, 7))
    local = np.stack([u.ravel(), w.ravel(), np.zeros(u.size)])
    worst = math.inf
    for ph in p.phases:
        if ph.step < 0:
            continue
        poses = (p.left_sole if tw.plan.footsteps[ph.step].side == "left" else p.right_sole)[ph.first:ph.end]
        start, land = poses[0, :2, 3], tw.footholds[ph.step][:2, 3]
        far = (np.linalg.norm(poses[:, :2, 3] - start, axis=1) > L / 2) & \
              (np.linalg.norm(poses[:, :2, 3] - land, axis=1) > L / 2)
        pts = np.matmul(poses[far, :3, :3], local) + poses[far, :3, 3:4]
        worst = min(worst, float((pts[:, 2] - terrain.height(pts[:, 0], pts[:, 1])).min()))
    assert worst >= clearance - 0.005  # between the planner's grid points the underside is a plane


def test_slope_soles_lie_on_the_incline():
    deg = 10.0
    tw = _plan(f"slope:{deg}", n_steps=10, step_length=0.2)
    th = math.radians(deg)
    on_ramp = [H for H in tw.footholds if 0.3 + L / 2 + 0.02 <= H[0, 3] <= 2.3 - L / 2 - 0.02]
    assert len(on_ramp) >= 5
    for H in on_ramp:
        assert H[2, 3] == pytest.approx((H[0, 3] - 0.3) * math.tan(th), abs=1e-12)
        assert np.allclose(H[:3, 2], [-math.sin(th), 0.0, math.cos(th)], atol=1e-12)  # sole z axis = normal
        assert np.allclose(H[:3, :3].T @ H[:3, :3], np.eye(3), atol=1e-12)
        assert H[1, 0] == pytest.approx(0.0, abs=1e-12)  # heading +x kept


def test_com_height_follows_the_terrain_and_its_derivatives_are_consistent():
    tw = _plan("stairs:0.1:0.3:3:up", n_steps=6)
    p = tw.plan
    z0 = 0.87
    assert p.com[0, 2] == pytest.approx(z0, abs=1e-9)
    assert p.com[-1, 2] == pytest.approx(z0 + 0.3, abs=2e-3)  # at rest over the top tread (DCM recursion's end)
    dt = p.dt
    vz_fd = np.gradient(p.com[:, 2], dt)
    az_fd = np.gradient(p.com_vel[:, 2], dt)
    assert np.abs(vz_fd - p.com_vel[:, 2])[1:-1].max() < 2e-3
    assert np.abs(az_fd - p.com_acc[:, 2])[1:-1].max() < 5e-2
    for side in ("left", "right"):
        z = getattr(p, f"{side}_sole")[:, 2, 3]
        vz = getattr(p, f"{side}_sole_vel")[:, 2]
        assert np.abs(np.gradient(z, dt) - vz)[1:-1].max() < 5e-3  # sole z velocity = derivative of its z
    assert (np.diff(p.com[:, 2]) >= -1e-6).all()  # climbing: the CoM never goes down


def test_no_foothold_or_no_clearance_is_a_gait_error():
    with pytest.raises(GaitError, match=r"step 1 .*no foothold"):
        _plan("stairs:0.1:0.2:3", step_length=0.2)  # a 20 cm tread is shorter than the sole + 2 x 2 cm
    with pytest.raises(GaitError, match="clears the terrain by only"):
        _plan("stairs:0.1:0.3:3", clearance=0.05, max_apex=0.06)
    with pytest.raises(GaitError, match="edge_margin"):
        _plan("stairs:0.1:0.3:3", edge_margin=-0.01)
    with pytest.raises(GaitError, match="straight"):
        _plan("stairs:0.1:0.3:3", turn=0.1)


@pytest.mark.parametrize("spec", ["stairs:0.1:0.3:3", "stairs:0.15:0.3:4:updown"])
def test_planned_soles_never_dip_into_a_riser(spec):
    """Every planned pose of both soles, the sole rectangle sampled densely (21 × 7 points): no point below the
    terrain surface under it by more than 0.1 mm — in particular the toe of a foot stepping up from a tread whose
    next riser is just ahead (the lift-off neighbourhood used to be skipped by the clearance check)."""
    tw = _plan(spec, n_steps=8 if "updown" not in spec else 12)
    terrain = tw.terrain
    u, w = np.meshgrid(np.linspace(-L / 2, L / 2, 21), np.linspace(-W / 2, W / 2, 7))
    local = np.stack([u.ravel(), w.ravel(), np.zeros(u.size)])
    worst = math.inf
    for poses in (tw.plan.left_sole, tw.plan.right_sole):
        pts = np.matmul(poses[:, :3, :3], local) + poses[:, :3, 3:4]
        worst = min(worst, float((pts[:, 2] - terrain.height(pts[:, 0], pts[:, 1])).min()))
    assert worst >= -1e-4, worst


def test_steps_up_clear_the_nosing_without_a_tall_swing():
    """One foot per tread on 10 cm stairs (each swing rises two treads, 0.2 m, over 0.6 m), G1's 0.17 m sole:
    every swing going up clears the terrain by 5 cm away from its footholds (21 x 7 underside points), its sole rises
    at most 0.1 m above its landing tread (a knee-high bump tips a small robot; the set-down is vertical onto the
    tread), and it lands with no horizontal speed (the sole's planned velocity at touch-down)."""
    left, right, com = _feet()
    length, width = 0.17, 0.05
    tw = plan_terrain_walk("stairs:0.1:0.3:6:up", left, right, com, n_steps=8, step_length=0.3, sole_length=length,
                           sole_width=width, step_height=0.04, clearance=0.05)
    p, terrain = tw.plan, tw.terrain
    u, w = np.meshgrid(np.linspace(-length / 2, length / 2, 21), np.linspace(-width / 2, width / 2, 7))
    local = np.stack([u.ravel(), w.ravel(), np.zeros(u.size)])
    ups = 0
    for ph in p.phases:
        if ph.step < 0:
            continue
        side = tw.plan.footsteps[ph.step].side
        poses = (p.left_sole if side == "left" else p.right_sole)[ph.first:ph.end + 1]
        vel = (p.left_sole_vel if side == "left" else p.right_sole_vel)[ph.first:ph.end + 1]
        z0, z1 = poses[0, 2, 3], tw.footholds[ph.step][2, 3]
        if z1 < z0 + 0.05:
            continue
        ups += 1
        start, land = poses[0, :2, 3], tw.footholds[ph.step][:2, 3]
        far = (np.linalg.norm(poses[:, :2, 3] - start, axis=1) > length / 2) & \
              (np.linalg.norm(poses[:, :2, 3] - land, axis=1) > length / 2)
        pts = np.matmul(poses[far, :3, :3], local) + poses[far, :3, 3:4]
        assert (pts[:, 2] - terrain.height(pts[:, 0], pts[:, 1])).min() >= 0.05 - 0.005
        assert poses[:, 2, 3].max() - z1 <= 0.1
        assert np.linalg.norm(vel[-1, :2]) <= 1e-6
    assert ups >= 4


def _peak_speeds(plan):
    """Peak speed (m/s) of each swing, from finite differences of the planned sole positions (not the plan's
    velocities)."""
    out = []
    for ph in plan.phases:
        if ph.step < 0:
            continue
        P = (plan.left_sole if plan.footsteps[ph.step].side == "left" else plan.right_sole)[ph.first:ph.end + 1, :3, 3]
        out.append(float(np.linalg.norm(np.diff(P, axis=0), axis=1).max() / plan.dt))
    return np.array(out)


def test_step_timing_keeps_the_swing_sole_under_its_speed_bound():
    """Steps whose swing would be faster than max_sole_speed (stairs: 2 treads forward and a rise) last longer,
    single and double support by the same factor, so that their peak sole speed is the bound; the others keep
    t_ss. Speeds from finite differences of the planned soles."""
    spec, v_max, t_ss, t_ds = "stairs:0.15:0.3:4:updown", 1.6, 0.64, 0.16
    free = _plan(spec, n_steps=12, t_ss=t_ss, t_ds=t_ds).plan
    timed = _plan(spec, n_steps=12, t_ss=t_ss, t_ds=t_ds, max_sole_speed=v_max).plan
    v0, v1 = _peak_speeds(free), _peak_speeds(timed)
    assert v0.max() > 1.5 * v_max  # the bound binds
    assert v1.max() <= v_max * 1.01
    ss = [ph.duration for ph in timed.phases if ph.step >= 0]
    for i, (a, b, T) in enumerate(zip(v0, v1, ss)):
        if a <= v_max:  # not lengthened
            assert T == pytest.approx(t_ss) and b == pytest.approx(a, rel=1e-9), i
        else:  # speed ~ 1/T: the lengthened swing peaks at the bound, within a sample's rounding
            assert T == pytest.approx(t_ss * a / v_max, abs=timed.dt), i
            assert b == pytest.approx(v_max, rel=0.01), i
    # the double support after a lengthened step is lengthened by the same factor
    phases = list(timed.phases)
    for j, ph in enumerate(phases[:-2]):
        if ph.step >= 0 and phases[j + 1] is not phases[-1]:
            assert phases[j + 1].duration == pytest.approx(t_ds * ph.duration / t_ss, abs=2 * timed.dt)
    # steps with a height change are the lengthened ones; the feet still land on their footholds
    assert timed.duration > free.duration + 1.0
    assert np.allclose(timed.left_sole[-1], free.left_sole[-1]) and np.allclose(timed.right_sole[-1],
                                                                                  free.right_sole[-1])


def test_step_timing_bad_bound_and_per_step_durations_are_gait_errors():
    for bad in (0.0, -1.0, math.nan, "fast"):
        with pytest.raises(GaitError, match="max_sole_speed"):
            _plan("stairs:0.1:0.3:3:up", max_sole_speed=bad)
    left, right, com = _feet()
    with pytest.raises(GaitError, match="t_ss must be one duration"):
        plan_walk(left, right, com, n_steps=3, t_ss=[0.8, 0.8])
    with pytest.raises(GaitError, match=r"t_ds\[1\]"):
        plan_walk(left, right, com, n_steps=3, t_ds=[0.3, -0.1, 0.3])
    p = plan_walk(left, right, com, n_steps=3, t_ss=[0.6, 0.8, 1.0], t_ds=[0.2, 0.4, 0.3], sole_length=L,
                  sole_width=W)
    assert [round(ph.duration, 9) for ph in p.phases[1:-1]] == [0.6, 0.2, 0.8, 0.4, 1.0]


@pytest.mark.parametrize("spec", ["stairs:0.15:0.3:3:updown", "stairs:0.23:0.3:6:down", "stairs:0.1:0.3:3:up"])
def test_steps_to_cross_is_the_fewest_steps_whose_planned_feet_pass_the_end(spec):
    """The count chosen: its full plan (footholds as planned, both heels measured) ends past the terrain's end,
    one step fewer does not."""
    from wbc.gait.terrain_walk import steps_to_cross

    left, right, _ = _feet()
    n = steps_to_cross(spec, left, right, step_length=0.3, sole_length=L, sole_width=W)
    end = parse_terrain(spec).end_x

    def heel(count):
        holds = _plan(spec, n_steps=count).footholds
        return min(holds[-1][0, 3], holds[-2][0, 3]) - L / 2

    assert heel(n) >= end > heel(n - 1)


def test_steps_to_cross_flat_plan_closed_form_and_no_end():
    """Planned blind (the flat plan's footsteps): from feet side by side at x = 0, n steps of 0.3 m end side by side
    at 0.3 (n - 1): the fewest with the heel past the end is ceil((end + L / 2) / 0.3) + 1. No end: None."""
    from wbc.gait.terrain_walk import steps_to_cross

    left, right, _ = _feet()
    for spec in ("stairs:0.22:0.3:6:updown", "stairs:0.1:0.3:3:down", "slope:10"):
        end = parse_terrain(spec).end_x
        got = steps_to_cross(spec, left, right, step_length=0.3, sole_length=L, on_terrain=False)
        assert got == math.ceil((end + L / 2) / 0.3 - 1e-12) + 1, spec
    assert steps_to_cross("rough:0.02:1", left, right, step_length=0.3) is None
    assert steps_to_cross("stairs:0.1:0.3:3", left, right, step_length=0.0) is None


@pytest.mark.parametrize("spec", ["stairs:0.22:0.3:6:updown", "stairs:0.1:0.3:6:up", "stairs:0.23:0.3:6:down"])
def test_steps_up_stand_at_the_back_of_their_tread_and_steps_down_in_its_middle(spec):
    """Against the stairs' tread intervals: a foothold higher than its stance foot has its heel ``edge_margin``
    (within the 5 mm search grid) in front of the nosing behind it, so its toe is ``tread − sole − edge_margin``
    from the next riser (the stance shin leans over that riser's nosing while the CoM rises, module docstring); a
    foothold lower than its stance foot on a tread is centred on it (within half a grid step)."""
    margin, grid = 0.02, 0.005
    tw = _plan(spec, n_steps=16, edge_margin=margin)
    treads = [tr for tr in tw.terrain.treads if math.isfinite(tr[0]) and tr[1] - tr[0] < 0.5]  # not floor/landing
    z_stance = {"left": 0.0, "right": 0.0}
    ups = downs = 0
    for fs, H in zip(tw.plan.footsteps, tw.footholds):
        x, z = H[0, 3], H[2, 3]
        stance = "right" if fs.side == "left" else "left"
        on = [tr for tr in treads if tr[0] <= x <= tr[1]]
        if on and z > z_stance[stance] + 1e-3:
            ups += 1
            assert -1e-9 <= (x - L / 2) - (on[0][0] + margin) < grid + 1e-9, (spec, x, on[0])
            assert on[0][1] - (x + L / 2) >= (on[0][1] - on[0][0]) - L - margin - grid - 1e-9
        elif on and z < z_stance[stance] - 1e-3:
            downs += 1
            assert abs(x - 0.5 * (on[0][0] + on[0][1])) <= grid / 2 + 1e-9, (spec, x, on[0])
        z_stance[fs.side] = z
    assert ups >= (4 if "up" in spec else 0) and downs >= (4 if "down" in spec else 0)
