"""Contact events (wbc.estimation.contact_events) against synthetic signals with known crossing times and against
MuJoCo's own contacts on a scripted foot (a box sole lifted off the floor, a box sole tilted onto its edge)."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from conftest import box_sole_mjcf
from wbc.estimation.contact_events import ContactEventThresholds, SoleContactEvents
from wbc.exceptions import InvalidInputError

DT = 0.002
L, W = 0.21, 0.13  # sole rectangle (m)
WEIGHT = 900.0  # N
FLAT = np.eye(3)


def _wrench(fz, cop=(0.0, 0.0)):
    """Ground reaction at the sole origin of a vertical force fz (N) applied at ``cop`` (m, sole frame)."""
    return np.array([0.0, 0.0, fz, cop[1] * fz, -cop[0] * fz, 0.0])


def _tilt_y(theta):
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def test_unloading_and_lifting_is_a_loss_confirmed_after_five_ticks():
    det = SoleContactEvents("left", L, W, WEIGHT, DT)
    assert det.latency == pytest.approx(5 * DT)  # 0.01 s at 2 ms
    events = []
    for k in range(100):
        t = k * DT
        up = k >= 40  # from tick 40: no load, 1 cm up
        ev = det.update(t, _wrench(0.0 if up else 450.0), FLAT, [0.0, 0.0, 0.01 if up else 0.0], 0.0, True)
        events += ev
    assert [(e.kind, e.cause) for e in events] == [("loss", "unloaded")]
    assert events[0].t == pytest.approx(44 * DT)  # the 5th tick of the new state
    assert not det.in_contact


def test_a_load_between_the_thresholds_does_not_chatter():
    det = SoleContactEvents("left", L, W, WEIGHT, DT)
    rng = np.random.default_rng(0)
    # 30 N ± 2 N (std) on a sole 1 cm up: between load_off (18 N) and load_on (45 N): loaded stays loaded
    for k in range(500):
        det.update(k * DT, _wrench(30.0 + 2.0 * rng.standard_normal()), FLAT, [0, 0, 0.01], 0.0, True)
    assert det.events == [] and det.in_contact


def test_unloaded_sole_on_the_ground_is_kept_and_loss_needs_air_or_tilt():
    det = SoleContactEvents("right", L, W, WEIGHT, DT)
    for k in range(50):  # 0 N but flat at 1 mm: a double-support sole the controller does not load
        det.update(k * DT, _wrench(0.0), FLAT, [0, 0, 0.001], 0.0, True)
    assert det.in_contact and det.events == []


def test_cop_at_the_edge_with_tilt_is_an_edge_loss_and_without_tilt_is_not():
    th = ContactEventThresholds()
    det = SoleContactEvents("left", L, W, WEIGHT, DT, th)
    for k in range(50):  # CoP 2 mm from the toe, flat: a loaded sole at its limit, still a contact
        det.update(k * DT, _wrench(800.0, (0.5 * L - 0.002, 0.0)), FLAT, [0, 0, 0], 0.0, True)
    assert det.in_contact
    R = _tilt_y(math.radians(6.0))  # heel up (toe down) by 6°: the sole pivots on its toe edge
    for k in range(50, 60):
        det.update(k * DT, _wrench(800.0, (0.5 * L - 0.002, 0.0)), R, [0, 0, 0.5 * L * math.sin(math.radians(6))],
                   0.0, True)
    assert [(e.kind, e.cause, e.t) for e in det.events] == [("loss", "edge", pytest.approx(54 * DT))]
    assert det.events[0].tilt == pytest.approx(math.radians(6.0))
    assert det.events[0].clearance == pytest.approx(0.0, abs=1e-12)  # the toe edge on the ground


def test_touchdown_early_late_and_liftoff_against_the_plan():
    det = SoleContactEvents("left", L, W, WEIGHT, DT, in_contact=False)
    kinds = []
    for k in range(200):
        t = k * DT
        planned = k >= 50  # the plan lands at tick 50; the sole lands at tick 80 (late)
        fz = 500.0 if k >= 80 else 0.0
        kinds += [(e.kind, round(e.t / DT)) for e in det.update(t, _wrench(fz), FLAT, [0, 0, 0 if k >= 80 else 0.02],
                                                                 0.0, planned)]
    # late: 0.03 s = 15 ticks after the planned landing; touch-down: 5th tick of the load
    assert kinds == [("late", 65), ("touchdown", 84)]
    assert det.events[0].cause == "unloaded"
    det2 = SoleContactEvents("left", L, W, WEIGHT, DT, in_contact=False)
    ev = []
    for k in range(20):  # loaded while the plan has it in the air: early
        ev += det2.update(k * DT, _wrench(500.0), FLAT, [0, 0, 0], 0.0, False)
    assert [e.kind for e in ev] == ["touchdown", "early"]
    ev = []
    for k in range(20, 40):  # unloaded and up with the plan in the air: a lift-off, not a loss
        ev += det2.update(k * DT, _wrench(0.0), FLAT, [0, 0, 0.02], 0.0, False)
    assert [(e.kind, e.cause) for e in ev] == [("liftoff", "planned")]


def test_a_detector_continued_from_another_keeps_its_loss_and_starts_the_plan_timing_anew():
    """A new plan's detector (the walk's capture walk, on its own clock) continued from the old one: a sole the old
    events saw leave the ground stays out of contact (a fresh detector takes it as standing), a change pending there
    starts again, and the new plan's late landing counts from its own first tick."""
    old = SoleContactEvents("left", L, W, WEIGHT, DT)
    for k in range(10):  # unloaded, 1 cm up: a loss at the 5th tick
        old.update(k * DT, _wrench(0.0), FLAT, [0, 0, 0.01], 0.0, True)
    assert not old.in_contact and [e.kind for e in old.events] == ["loss"]
    fresh, new = SoleContactEvents("left", L, W, WEIGHT, DT), SoleContactEvents("left", L, W, WEIGHT, DT)
    new.continue_from(old)
    assert new.in_contact is False and new.cause == "unloaded" and new.loaded is False
    kinds, kinds_fresh = [], []
    for k in range(40):  # on the new clock: planned down, still 1 cm up and unloaded
        kinds += [(e.kind, round(e.t / DT)) for e in new.update(k * DT, _wrench(0.0), FLAT, [0, 0, 0.01], 0.0, True)]
        kinds_fresh += [e.kind for e in fresh.update(k * DT, _wrench(0.0), FLAT, [0, 0, 0.01], 0.0, True)]
    assert kinds == [("late", 15)]  # 0.03 s after the new plan's first tick
    assert kinds_fresh == ["loss"]  # the fresh one starts in contact and loses it again, 10 ms late
    for k in range(40, 50):  # set down flat and loaded: a touch-down at the 5th tick
        kinds += [(e.kind, round(e.t / DT)) for e in new.update(k * DT, _wrench(500.0), FLAT, [0, 0, 0], 0.0, True)]
    assert kinds[-1] == ("touchdown", 44) and new.in_contact
    for bad in (SoleContactEvents("right", L, W, WEIGHT, DT), None):  # another sole's, or not a detector
        with pytest.raises(InvalidInputError, match="left sole's SoleContactEvents"):
            new.continue_from(bad)


@pytest.mark.parametrize("kwargs", [dict(load_on=0.01, load_off=0.02), dict(air_height=-1.0),
                                    dict(touch_height=0.01, air_height=0.005), dict(confirm_time=math.nan),
                                    dict(flat_tilt=0.2, edge_tilt=0.1)])
def test_bad_thresholds_raise(kwargs):
    with pytest.raises(InvalidInputError):
        ContactEventThresholds(**kwargs)


def test_bad_sole_raises():
    with pytest.raises(InvalidInputError, match="sole"):
        SoleContactEvents("middle", L, W, WEIGHT, DT)
    with pytest.raises(InvalidInputError, match="length"):
        SoleContactEvents("left", 0.0, W, WEIGHT, DT)


# -- MuJoCo: a box sole on a floor, the detector fed with MuJoCo's contact forces -------------------------------

_FOOT = box_sole_mjcf(L, W, DT)


def _ground_wrench(model, data, site):
    """Ground reaction (6,) on the foot at the sole site, sole axes, summed from MuJoCo's contacts; the world
    positions of the contacts; their count."""
    R = data.site_xmat[site].reshape(3, 3)
    p = data.site_xpos[site]
    f, tau, pts = np.zeros(3), np.zeros(3), []
    c6 = np.zeros(6)
    for i in range(data.ncon):
        con = data.contact[i]
        mujoco.mj_contactForce(model, data, i, c6)
        frame = con.frame.reshape(3, 3)  # rows: the contact frame's axes (normal first) in world
        fw = frame.T @ c6[:3]  # force on geom2 from geom1, world
        if model.geom_bodyid[con.geom1] == model.body("foot").id:
            fw = -fw
        f += fw
        tau += np.cross(con.pos - p, fw)
        pts.append(con.pos.copy())
    return np.concatenate([R.T @ f, R.T @ tau]), pts


def _run(script, seconds=1.2):
    """Simulate the box foot with ``script(t, model, data)`` each tick; feed the detector. Returns (events, per
    tick list of (t, MuJoCo contact count, contact points in the sole frame, sole tilt (rad)))."""
    model = mujoco.MjModel.from_xml_string(_FOOT)
    data = mujoco.MjData(model)
    site = model.site("sole").id
    weight = float(model.body_subtreemass[model.body("foot").id] * 9.81)
    det = SoleContactEvents("left", L, W, weight, DT)
    trace = []
    for k in range(int(round(seconds / DT))):
        t = k * DT
        script(t, model, data)
        mujoco.mj_step1(model, data)  # contacts and forces of the state at t (as the plant's F/T is sampled)
        mujoco.mj_rnePostConstraint(model, data)
        wrench, pts = _ground_wrench(model, data, site)
        R, p = data.site_xmat[site].reshape(3, 3), data.site_xpos[site]
        det.update(t, wrench, R, p, 0.0, True)
        trace.append((t, data.ncon, [R.T @ (x - p) for x in pts], math.acos(min(1.0, float(R[2, 2])))))
        mujoco.mj_step2(model, data)
    return det, trace


def test_mujoco_foot_lifted_off_the_floor_is_a_loss_after_mujoco_drops_the_contact():
    def lift(t, model, data):
        data.xfrc_applied[model.body("foot").id, 2] = 700.0 if t >= 0.5 else 0.0  # > 30 kg · g: it rises

    det, trace = _run(lift)
    t_off = next(t for t, n, _, _ in trace if t >= 0.5 and n == 0)  # MuJoCo: no contact from here
    assert all(n == 0 for t, n, _, _ in trace if t >= t_off)
    losses = [e for e in det.events if e.kind == "loss"]
    assert len(det.events) == 1 and len(losses) == 1 and losses[0].cause == "unloaded"
    # after MuJoCo's contact ended; within the latency (10 ms) plus the time the sole takes to rise 3 mm
    # (a = 700/30 − 9.81 = 13.5 m/s², 21 ms from rest, less its damping) — 50 ms bounds both
    assert t_off <= losses[0].t <= t_off + 0.05


def test_mujoco_foot_tilted_onto_its_edge_is_an_edge_loss_and_flat_again_a_touchdown():
    def tilt(t, model, data):  # 8° over 0.2 s from 0.5 s, back to 0 over 0.2 s from 0.9 s
        a = min(1.0, max(0.0, (t - 0.5) / 0.2)) if t < 0.9 else max(0.0, 1.0 - (t - 0.9) / 0.2)
        data.ctrl[0] = math.radians(8.0) * a

    det, trace = _run(tilt, 1.4)
    ha = 0.5 * L

    def one_edge(pts):  # MuJoCo's box-plane contacts (at the corners) all on one short edge, x = +L/2 or −L/2
        return bool(pts) and (all(abs(x[0] - ha) < 2e-3 for x in pts) or all(abs(x[0] + ha) < 2e-3 for x in pts))

    # the sole's tilt in MuJoCo passes 3° (the default edge tilt) at t_tilt; from then until the tilt is undone,
    # MuJoCo's contacts are all on one edge
    t_tilt = next(t for t, _, _, tilt in trace if t >= 0.5 and tilt > math.radians(3.0))
    assert all(one_edge(pts) for t, n, pts, _ in trace if t_tilt <= t < 0.9)
    t_flat = next(t for t, n, pts, _ in trace if t >= 0.9 and n > 0 and not one_edge(pts))
    kinds = [(e.kind, e.cause) for e in det.events]
    assert kinds == [("loss", "edge"), ("touchdown", "load")]
    loss, down = det.events
    assert t_tilt <= loss.t <= t_tilt + 0.02  # the latency (10 ms) and a tick
    assert loss.tilt > math.radians(3.0) and abs(abs(loss.cop[0]) - ha) < 0.01
    # a loaded sole is down once within 2° of flat (the default flat tilt): at the commanded 40°/s that is up to
    # 50 ms before MuJoCo's contacts reach the other edge
    assert t_flat - 0.06 <= down.t <= t_flat + 0.02


# -- the logged contact-loss case of a walking push (Talos, wbc sim walk, seed 9813, 300 N at 4.2 s, 344°) -------

FIXTURES = __import__("pathlib").Path(__file__).resolve().parents[1] / "fixtures"


def test_walking_push_9813_right_sole_landing_on_its_toe_is_flagged_while_the_controller_keeps_it_as_a_contact():
    """tests/fixtures/contact_loss_talos_9813.npz: 4.2–4.5 s of the run's log (benchmarks/contact_loss_fixture.py):
    MuJoCo's ground reaction on each foot and the plant's sole placements, the controller's contact state and its
    QP normal force per sole. The right sole lands after a 0.26 m step adjustment on its toe edge."""
    d = np.load(FIXTURES / "contact_loss_talos_9813.npz")
    t, dt = d["t"], float(d["dt"])
    flagged = []
    for j, side in enumerate(("left", "right")):
        det = SoleContactEvents(side, float(d["sole_length"]), float(d["sole_width"]), float(d["weight"]), dt,
                                in_contact=bool(d["contact_active"][0, j]))
        for k in range(len(t)):
            det.update(float(t[k]), d["wrench"][k, j], d["rotation"][k, j], d["position"][k, j], 0.0,
                       bool(d["contact_active"][k, j]))
        flagged += [e for e in det.events if e.kind in ("loss", "late")]
    # the sole never sits flat: no touch-down; 30 ms after the controller made it a contact, a late contact on
    # its edge
    assert [(e.sole, e.kind, e.cause) for e in flagged] == [("right", "late", "edge")]
    e = flagged[0]
    k = int(round((e.t - t[0]) / dt))
    k_on = int(np.argmax(d["contact_active"][:, 1]))  # the controller's touch-down of the right sole
    assert t[k_on] == pytest.approx(4.32, abs=0.011) and e.t == pytest.approx(t[k_on] + 0.03, abs=1e-9)
    # what MuJoCo says at that tick, independently of the detector: the sole carries load with its origin more
    # than 3 mm over the floor (so it rests on an edge), its CoP (MuJoCo's contact wrench) at the toe
    f = d["wrench"][k, 1]
    assert f[2] > 100.0 and d["position"][k, 1, 2] > 0.003
    assert -f[4] / f[2] > 0.5 * float(d["sole_length"]) - 0.01
    # while the controller held it as a full contact and asked it for a few hundred newtons
    assert d["contact_active"][k, 1] and d["qp_normal_force"][k, 1] > 300.0


def test_romeo_push_step_right_sole_unloaded_in_the_air_is_a_loss_with_a_2_mm_air_height():
    """tests/fixtures/contact_loss_romeo_push_step.npz: 0.45–1.0 s of ``wbc sim push-step --robot
    examples/robots/romeo.toml`` (defaults; benchmarks/contact_loss_fixture.py). The pushed robot unloads its right
    sole (MuJoCo: 0 N) and lifts it to 2.7 mm (lowest corner) while the controller keeps it a contact."""
    d = np.load(FIXTURES / "contact_loss_romeo_push_step.npz")
    t, dt, weight = d["t"], float(d["dt"]), float(d["weight"])
    length, width = float(d["sole_length"]), float(d["sole_width"])
    corners = np.array([[sx * length / 2, sy * width / 2, 0.0] for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1))])
    # the reference, from MuJoCo's force and the plant's sole pose alone: the first tick from which the right sole
    # carries under 2 % of the weight with its lowest corner over 2 mm
    low = np.array([(corners @ d["rotation"][k, 1][2]).min() + d["position"][k, 1, 2] for k in range(len(t))])
    off = (d["wrench"][:, 1, 2] < 0.02 * weight) & (low > 0.002)
    k_ref = int(np.argmax(off))
    assert off[k_ref:k_ref + 5].all() and d["contact_active"][k_ref, 1]
    events = {}
    for air in (0.002, 0.003):
        th = ContactEventThresholds(air_height=air, touch_height=0.001)
        det = SoleContactEvents("right", length, width, weight, dt, th)
        for k in range(len(t)):
            det.update(float(t[k]), d["wrench"][k, 1], d["rotation"][k, 1], d["position"][k, 1], 0.0,
                       bool(d["contact_active"][k, 1]))
        events[air] = [(e.kind, e.cause, e.t) for e in det.events]
    # 2 mm: lost on the 5th tick of the reference condition; 3 mm (the default): the sole stays under it, kept
    assert events[0.002][0] == ("loss", "unloaded", pytest.approx(t[k_ref] + 4 * dt))
    assert events[0.003] == []
    # the controller's QP had already taken the load off it (its planned normal force there: 0 N)
    assert abs(d["qp_normal_force"][k_ref, 1]) < 1.0
