"""Overlay quantities against closed forms, and overlay lines in a recording's scene."""

from __future__ import annotations

import base64
import gzip
import re
import struct

import numpy as np
import pytest
import umsgpack

from wbc.viz import record_html
from wbc.viz.overlays import cart_table_zmp, dcm_of


def test_cart_table_zmp_of_a_constant_acceleration_com():
    t = np.linspace(0.0, 1.0, 501)
    a, z, g = 0.8, 0.85, 9.81
    com = np.c_[0.5 * a * t**2, 0.1 * t, np.full_like(t, z)]
    zmp = cart_table_zmp(t, com, g=g)
    inner = slice(2, -2)  # one-sided differences at the ends
    np.testing.assert_allclose(zmp[inner, 0], 0.5 * a * t[inner] ** 2 - z / g * a, atol=1e-9)
    np.testing.assert_allclose(zmp[inner, 1], 0.1 * t[inner], atol=1e-9)
    assert np.all(zmp[:, 2] == 0.0)


def test_dcm_of_a_constant_velocity_com():
    t = np.linspace(0.0, 1.0, 101)
    z, g, v = 0.9, 9.81, 0.3
    com = np.c_[v * t, np.zeros_like(t), np.full_like(t, z)]
    np.testing.assert_allclose(dcm_of(t, com, g=g)[:, 0], v * t + v / np.sqrt(g / z), atol=1e-12)


@pytest.fixture(scope="module")
def talos(robots):
    return robots("talos")


def _commands(path):
    text = path.read_text()
    payload = re.search(r'<script id="wbc-scene"[^>]*>([^<]*)</script>', text).group(1)
    blob = gzip.decompress(base64.b64decode(payload))
    out, offset = [], 0
    while offset < len(blob):
        (n,) = struct.unpack_from("<I", blob, offset)
        out.append(umsgpack.unpackb(blob[offset + 4:offset + 4 + n]))
        offset += 4 + n
    return out


def test_recording_draws_paths_and_outlines_each_under_its_own_path(talos, tmp_path):
    t = np.arange(3) * 0.1
    q = np.tile(talos.q_ref, (3, 1))
    square = np.array([[0, 0, 0], [0.2, 0, 0], [0.2, 0.1, 0], [0, 0.1, 0]], float)
    path = record_html(talos, t, q, tmp_path / "r.html", overlays={"com": np.zeros((3, 3))},
                       paths={"swing_left": [square[:2]]}, outlines={"footprints": [square, square + 1.0]})
    objects = {c["path"]: c["object"] for c in _commands(path) if c["type"] == "set_object"}
    assert objects["/meshcat/overlays/swing_left/0"]["object"]["type"] == "Line"
    assert [objects[f"/meshcat/overlays/footprints/{i}"]["object"]["type"] for i in range(2)] == ["LineLoop"] * 2
    assert "/meshcat/overlays/com" in objects
    html = path.read_text()
    legend = re.search(r'<div id="wbc-legend".*?</div></div>', html, re.S).group(0)
    assert all(name in legend for name in ("com", "swing_left", "footprints"))
    from wbc.exceptions import InvalidInputError

    with pytest.raises(InvalidInputError, match="footprints"):
        record_html(talos, t, q, tmp_path / "bad.html", outlines={"footprints": [np.zeros((1, 3))]})


def test_force_arrow_points_along_the_force_and_scales_with_it(talos, tmp_path):
    from scipy.spatial.transform import Rotation

    t = np.arange(3) * 0.1
    q = np.tile(talos.q_ref, (3, 1))
    origin = np.tile([0.1, 0.2, 0.0], (3, 1))
    force = np.array([[0.0, 0.0, 450.0], [300.0, 0.0, 400.0], [0.0, -100.0, 0.0]])
    path = record_html(talos, t, q, tmp_path / "a.html", arrows={"contact_force_left": (origin, force)})
    cmds = _commands(path)
    anim = next(c for c in cmds if c["type"] == "set_animation")
    clip = next(a["clip"] for a in anim["animations"] if a["path"] == "/meshcat/overlays/contact_force_left")
    tracks = {tr["name"]: np.frombuffer(tr["values"].data, "<f4").reshape(3, -1) for tr in clip["tracks"]}
    for k in range(3):
        length = np.linalg.norm(force[k]) * 1e-3  # 1 mm per N
        assert tracks[".scale"][k][1] == pytest.approx(length, rel=1e-6)
        tip_dir = Rotation.from_quat(tracks[".quaternion"][k]).apply([0.0, 1.0, 0.0])  # cylinder axis: local y
        np.testing.assert_allclose(tip_dir, force[k] / np.linalg.norm(force[k]), atol=1e-6)
        np.testing.assert_allclose(tracks[".position"][k], origin[k] + 0.5e-3 * force[k], atol=1e-6)
    assert "contact_force_left" in path.read_text().split('id="wbc-legend"')[1][:2000]


def test_overlays_drawn_together_have_distinct_colours():
    from wbc.viz._scene import overlay_color

    walk = ["com", "com_ground", "zmp_planned", "zmp_executed", "dcm_planned", "dcm_executed", "support_polygon",
            "footsteps_planned", "footprints", "swing_left", "swing_right"]
    physics = ["com", "com_ground", "cop", "zmp_planned", "dcm_planned", "dcm_executed", "support_polygon",
               "footsteps_planned", "footprints", "swing_left", "swing_right", "contact_force_left",
               "contact_force_right", "push"]
    balance = ["com", "com_ground", "com_reference", "zmp_executed", "dcm_executed", "support_polygon",
               "footprints", "swing_left", "swing_right"]
    for names in (walk, physics, balance):
        colours = [overlay_color(n, i) for i, n in enumerate(names)]
        assert len(set(colours)) == len(names), dict(zip(names, map(hex, colours)))


def test_live_overlays_against_closed_forms(talos):
    """LiveOverlays on a base moving at constant acceleration a along x (joints fixed): CoM from Pinocchio, DCM
    c + ċ/ω with ċ by a backward difference, cart-table ZMP c − z/g c̈ at the middle frame; feet on the ground
    all along: both footprints once, one support polygon (hull of both soles), swing paths every 5 frames."""
    import pinocchio as pin

    from wbc.viz.live_overlays import LiveOverlays

    src = LiveOverlays(talos, trail_every=5)
    a, h = 0.5, 0.04  # m/s^2, s between displayed frames
    data = talos.model.createData()
    frames = []
    for k in range(6):
        q = talos.q_ref.copy()
        q[0] += 0.5 * a * (k * h) ** 2  # the whole robot slides: soles stay on the ground (z unchanged)
        frames.append((q, src.frame(q, k * h)))
    q5, last = frames[-1]
    com = pin.centerOfMass(talos.model, data, q5)
    np.testing.assert_allclose(last["points"]["com"], com, atol=1e-12)
    np.testing.assert_allclose(last["points"]["com_ground"], [com[0], com[1], 0.0], atol=1e-12)
    g, omega = 9.81, np.sqrt(9.81 / com[2])
    v_backward = a * (5 * h - 0.5 * h)  # (x(t5) - x(t4)) / h for x = a t^2 / 2
    assert last["points"]["dcm_executed"][0] == pytest.approx(com[0] + v_backward / omega, abs=1e-9)
    c4 = pin.centerOfMass(talos.model, data, frames[4][0])
    assert last["points"]["zmp_executed"][0] == pytest.approx(c4[0] - c4[2] / g * a, abs=1e-9)
    assert last["points"]["zmp_executed"][1] == pytest.approx(c4[1], abs=1e-9)
    first = frames[0][1]
    assert len(first["footprints"]) == 2 and "dcm_executed" not in first["points"]
    assert first["support_polygon"] is not None and len(first["support_polygon"]) >= 4
    assert all(f["support_polygon"] is None and not f["footprints"] for _, f in frames[1:])
    assert [bool(f["trails"]) for _, f in frames] == [False, False, False, False, True, False]
    assert frames[4][1]["trails"]["swing_left"].shape == (5, 3)


def test_live_overlays_touchdown_from_the_sole_height(talos):
    """Without a plan: a sole more than 5 mm up is not in contact; putting it back down adds its footprint."""
    import pinocchio as pin

    from wbc.viz.live_overlays import LiveOverlays

    src = LiveOverlays(talos)
    src.frame(talos.q_ref, 0.0)
    q = talos.q_ref.copy()
    q[2] += 0.05  # whole robot 5 cm up: no contact
    out = src.frame(q, 0.04)
    assert out["support_polygon"].shape == (0, 3) and not out["footprints"]
    out = src.frame(talos.q_ref, 0.08)
    assert len(out["footprints"]) == 2 and len(out["support_polygon"]) >= 4
    data = talos.model.createData()
    pin.framesForwardKinematics(talos.model, data, talos.q_ref)
    left = data.oMf[talos.frame_id(talos.left_sole)].translation
    np.testing.assert_allclose(out["footprints"][0][:, :2].mean(axis=0), left[:2], atol=1e-9)


@pytest.mark.parametrize("every", [1, 20, 650])
def test_live_overlays_footprints_of_every_touchdown_whatever_frames_are_skipped(talos, every):
    """With a walk plan, a footprint per foot at the start and one per touch-down of the plan, whether every
    sample is displayed or only one in 20 or 650 (1.3 s: whole single supports unseen, as when the display
    thread is starved on a loaded machine); a skipped touch-down's footprint is the plan's sole at that sample,
    a displayed foot still down is outlined where it is."""
    from wbc.scenarios.walk import plan_default_walk
    from wbc.viz.live_overlays import LiveOverlays

    plan = plan_default_walk(talos, n_steps=8)
    sup = plan.support.astype(int)
    touchdowns = [(j, i) for i in range(1, len(sup)) for j, codes in enumerate(((0, 1), (0, 2)))
                  if sup[i] in codes and sup[i - 1] not in codes]
    assert len(touchdowns) == 8
    src = LiveOverlays(talos, plan)
    prints = []
    samples = list(range(0, len(sup), every))
    if samples[-1] != len(sup) - 1:
        samples.append(len(sup) - 1)
    for k in samples:
        out = src.frame(talos.q_ref, float(plan.t[k]))  # the pose does not matter for the plan's touch-downs
        prints += out["footprints"]
    assert len(prints) == 2 + len(touchdowns)
    # each touch-down's outline is centred on the plan's sole at it, unless the foot was displayed still down
    # (then it is the displayed sole: here q_ref's)
    for (j, i), outline in zip(touchdowns, prints[2:]):
        plan_sole = (plan.left_sole if j == 0 else plan.right_sole)[i][:2, 3]
        centre = outline[:, :2].mean(axis=0)
        assert outline.shape[1] == 3
        if every == 650:
            shown = [k for k in samples if k >= i]
            still_down = shown and all(sup[m] in ((0, 1), (0, 2))[j] for m in range(i, shown[0] + 1))
            if not still_down:
                np.testing.assert_allclose(centre, plan_sole, atol=1e-9)
