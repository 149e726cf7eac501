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
