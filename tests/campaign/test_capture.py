"""The campaign's denominator (wbc.campaign.capture): each trial's push classified at the nominal walk's state at its
onset — compared with wbc.analysis.capturability called on the state set by hand here (soles from Pinocchio, the
time to touch-down counted by hand) — and the survival counts (an operator's verdict: a joint past its speed limit
fails the trial) with Wilson intervals from the closed form written here."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pyarrow as pa
import pytest

from wbc.analysis.capturability import capturability
from wbc.campaign.capture import NominalWalk, capture_model, capture_summary, format_capture_report, \
    push_capturability

DT = 0.002


@pytest.fixture(scope="module")
def talos_walk(robots):
    robot = robots("talos")
    t = np.arange(0.0, 3.0, DT)
    contact = np.ones((t.size, 2), dtype=bool)
    contact[(t >= 1.0) & (t < 1.48), 0] = False  # left swing 1.0–1.48 s
    contact[(t >= 1.6) & (t < 2.08), 1] = False  # right swing 1.6–2.08 s
    data = robot.model.createData()
    com = pin.centerOfMass(robot.model, data, robot.q_ref)
    nominal = NominalWalk(t=t, com=np.tile(com, (t.size, 1)), com_velocity=np.tile([0.3, 0.05, 0.0], (t.size, 1)),
                          contact=contact, q=np.tile(robot.q_ref, (t.size, 1)), robot=robot.name)
    return robot, nominal


def _table(rows):
    keys = rows[0].keys()
    return pa.table({k: [r[k] for r in rows] for k in keys})


ROWS = [  # push at 1.2 s: left swinging, lands at 1.48 s; at 0.5 s: double support
    {"trial": 0, "outcome": "survived", "force": 400.0, "direction_deg": 100.0, "push_time_s": 1.2,
     "push_duration": 0.1, "joint_speed_exceedances": 0, "phase": 0.2},
    {"trial": 1, "outcome": "survived", "force": 300.0, "direction_deg": -30.0, "push_time_s": 0.5,
     "push_duration": 0.1, "joint_speed_exceedances": 4, "phase": 0.0},
    {"trial": 2, "outcome": "fell", "force": 2500.0, "direction_deg": 200.0, "push_time_s": 1.7,
     "push_duration": 0.1, "joint_speed_exceedances": 0, "phase": 0.3},
    {"trial": 3, "outcome": "error", "force": 350.0, "direction_deg": 0.0, "push_time_s": None,
     "push_duration": 0.1, "joint_speed_exceedances": None, "phase": 0.1},
]


def test_the_swing_time_is_read_from_the_walk(talos_walk):
    robot, nominal = talos_walk
    m = capture_model(robot, nominal, 0.6)
    assert m.swing_time == pytest.approx(0.48, abs=DT + 1e-9) and m.step_time == 0.6


def test_each_push_is_classified_at_its_onset_state(talos_walk):
    robot, nominal = talos_walk
    model = capture_model(robot, nominal, 0.6)
    cap = push_capturability(_table(ROWS), nominal, model, robot)
    assert cap["trial"].tolist() == [0, 1, 2]  # the error row left out
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, robot.q_ref)
    soles = [(data.oMf[robot.frame_id(f)].translation[0], data.oMf[robot.frame_id(f)].translation[1], 0.0)
             for f in (robot.left_sole, robot.right_sole)]
    com = nominal.com[0]
    expected = [  # (stance soles, time to the touch-down) set by hand from the contact pattern
        ([soles[1]], 1.48 - 1.2), (soles, model.swing_time), ([soles[0]], 2.08 - 1.7)]
    for row, (stance, t_first), steps, t1 in zip(ROWS, expected, cap["steps"], cap["t_first_s"]):
        a = math.radians(row["direction_deg"])
        ref = capturability(model, com, [0.3, 0.05], (row["force"] * math.cos(a), row["force"] * math.sin(a)), 0.1,
                            stance, t_first)
        assert t1 == pytest.approx(t_first, abs=DT + 1e-9)
        assert steps == (-1 if ref.steps is None else ref.steps)
    assert cap["steps"][2] == -1  # 2500 N for 0.1 s: beyond any 3 steps of Talos
    assert cap["steps"][0] >= 0


def _wilson(k, n, z=1.959963984540054):
    p = k / n
    c = (p + z * z / (2 * n)) / (1 + z * z / n)
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return c - h, c + h


def test_survival_counts_a_speed_exceedance_as_a_failure(talos_walk):
    robot, nominal = talos_walk
    table = _table(ROWS)
    cap = push_capturability(table, nominal, capture_model(robot, nominal, 0.6), robot)
    s = capture_summary(table, cap)
    assert (s["overall"]["n"], s["overall"]["survived"]) == (3, 1)  # trial 1 survived with 4 exceedances: failed
    assert s["overall"]["wilson95"] == pytest.approx(_wilson(1, 3), abs=1e-12)
    assert (s["capturable"]["n"], s["capturable"]["survived"]) == (2, 1)
    assert s["share_capturable"][:2] == (2, 3)
    assert s["per_octant"]["left"]["survived"] == 1 and s["per_octant"]["forward-right"]["n"] == 1
    assert s["per_octant"]["back"]["n"] == 0  # trial 2 is not capturable: not among the octants' pushes
    text = format_capture_report(s)
    assert "capturable pushes" in text and "forward-right" in text


def test_the_zero_step_boundary_is_the_closed_form_push(talos_walk):
    """At rest over the sole's centre, the largest push along the sole's x the CoP alone captures moves the capture
    point to the sole's front edge: F = (L/2) m ω² / (1 − e^{−ωT}) (closed form); along y, (W/2) likewise."""
    from wbc.campaign.capture import boundary_forces

    robot, nominal = talos_walk
    m = capture_model(robot, nominal, 0.6)
    state = (np.zeros(3), np.zeros(3), [(0.0, 0.0, 0.0)], 0.3, 0.1)
    b = boundary_forces(m, [state], [0.0, 90.0, 180.0], 0)[:, 0]
    k = m.mass * m.omega**2 / (1.0 - math.exp(-m.omega * 0.1))
    assert b == pytest.approx([0.5 * m.sole_length * k, 0.5 * m.sole_width * k, 0.5 * m.sole_length * k], abs=1.0)


def test_a_nominal_walk_of_another_step_time_is_refused(talos_walk):
    from wbc.exceptions import InvalidInputError

    robot, nominal = talos_walk  # lift-offs 0.6 s apart
    with pytest.raises(InvalidInputError, match="steps last 0.600 s, the campaign's 0.800 s"):
        capture_model(robot, nominal, 0.8)


def test_a_right_first_walk_is_classified_as_the_mirror_image_of_the_nominal(talos_walk):
    """A trial that swings the right foot first, pushed towards θ at t, meets the state of the (left-first) nominal
    walk mirrored about y = 0 (soles, CoM and its velocity set by hand here): steps and capture point distance as
    capturability gives on that state; and the same as the left-first trial pushed towards −θ at t."""
    robot, nominal = talos_walk
    model = capture_model(robot, nominal, 0.6)
    rows = [dict(ROWS[0], trial=10, first_side="right", direction_deg=-100.0),
            dict(ROWS[0], trial=11, first_side="left", direction_deg=100.0),
            dict(ROWS[0], trial=12, first_side="right", direction_deg=100.0)]
    cap = push_capturability(_table(rows), nominal, model, robot)
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, robot.q_ref)
    right = data.oMf[robot.frame_id(robot.right_sole)].translation  # the nominal's stance at 1.2 s
    com = nominal.com[0] * (1.0, -1.0, 1.0)
    for k, deg in ((0, -100.0), (2, 100.0)):
        a = math.radians(deg)
        ref = capturability(model, com, [0.3, -0.05], (400.0 * math.cos(a), 400.0 * math.sin(a)), 0.1,
                            [(right[0], -right[1], 0.0)], 1.48 - 1.2)
        assert cap["steps"][k] == (-1 if ref.steps is None else ref.steps)
        assert cap["distance_m"][k] == pytest.approx(ref.distance, abs=1e-12)
    assert cap["steps"][0] == cap["steps"][1] and cap["distance_m"][0] == pytest.approx(cap["distance_m"][1],
                                                                                        abs=1e-12)


def test_pushes_are_counted_relative_to_the_stance_foot(talos_walk):
    """At 1.2 s the nominal stands on its right sole (at −y): a push towards 100° points away from it, one towards
    −100° towards it; mirrored (right first) the stance is the left sole and the verdicts swap with the side; a
    push 20° off the walking axis and any push in double support are sagittal."""
    from wbc.campaign.capture import STANCE_RELATIONS

    robot, nominal = talos_walk
    model = capture_model(robot, nominal, 0.6)
    rows = [dict(ROWS[0], trial=20, direction_deg=100.0), dict(ROWS[0], trial=21, direction_deg=-100.0),
            dict(ROWS[0], trial=22, direction_deg=100.0, first_side="right"),
            dict(ROWS[0], trial=23, direction_deg=20.0), dict(ROWS[1], trial=24, direction_deg=90.0)]
    for r in rows:
        r.setdefault("first_side", "left")
    table = _table(rows)
    cap = push_capturability(table, nominal, model, robot)
    names = [STANCE_RELATIONS[r] for r in cap["relation"]]
    assert names == ["away from the stance foot", "towards the stance foot", "towards the stance foot",
                     "sagittal or double support", "sagittal or double support"]
    s = capture_summary(table, cap)
    counted = sum(s["per_relation"][n]["n"] for n in STANCE_RELATIONS)
    assert counted == s["capturable"]["n"] == sum(s["per_first_side"][f]["n"] for f in ("left", "right"))
    assert "relative to the stance foot" in format_capture_report(s)
