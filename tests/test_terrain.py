"""wbc.terrain: heights, normals and sole support against closed-form geometry; typed errors for bad descriptions."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from wbc.exceptions import InvalidInputError, TerrainError
from wbc.terrain import FLOOR, HEIGHTFIELD, Box, Heightfield, Terrain, parse_terrain


def test_flat_is_the_plane_z0():
    t = parse_terrain("flat")
    assert t.is_flat
    x = np.linspace(-5, 5, 11)
    assert np.array_equal(t.height(x, -x), np.zeros(11))
    assert np.array_equal(t.normal(1.0, 2.0), [0.0, 0.0, 1.0])
    assert t.part_at(0.0, 0.0) == FLOOR


@pytest.mark.parametrize("rise,tread,n", [(0.1, 0.3, 3), (0.15, 0.3, 10), (0.1, 0.25, 5)])
def test_stairs_up_heights_are_k_times_the_rise(rise, tread, n):
    t = parse_terrain(f"stairs:{rise}:{tread}:{n}:up")
    x0 = max(0.5 * tread, 0.2)  # first riser (module docstring)
    for k in range(1, n + 1):
        xc = x0 + (k - 0.5) * tread  # middle of tread k
        assert t.height(xc, 0.3) == pytest.approx(k * rise, abs=1e-12)
        assert np.allclose(t.normal(xc, 0.3), [0, 0, 1])
    assert t.height(x0 - 1e-6, 0.0) == 0.0
    assert t.height(x0 + (n - 1) * tread + 1.0, 0.0) == pytest.approx(n * rise)  # top landing
    assert t.height(x0 + 0.5 * tread, 1.5) == 0.0  # beside the 2 m wide stairs


def test_stairs_down_and_updown_come_back():
    d = parse_terrain("stairs:0.15:0.3:4:down")
    assert d.floor_z == pytest.approx(-0.6)
    assert d.height(0.0, 0.0) == 0.0  # the start platform
    assert d.height(0.2 + 0.15, 0.0) == pytest.approx(-0.15)
    assert d.height(10.0, 0.0) == pytest.approx(-0.6)
    u = parse_terrain("stairs:0.1:0.3:3:updown")
    z = [u.height(x, 0.0) for x in np.arange(0.0, 4.0, 0.05)]
    assert max(z) == pytest.approx(0.3) and z[-1] == 0.0
    assert [tr[2] for tr in u.treads] == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.2, 0.1, 0.0])


def test_slope_height_and_normal_are_those_of_the_incline():
    deg, length = 10.0, 2.0
    t = parse_terrain(f"slope:{deg}:{length}")
    th = math.radians(deg)
    for x in (0.5, 1.0, 2.0):
        assert t.height(x, 0.2) == pytest.approx((x - 0.3) * math.tan(th), abs=1e-12)
        assert np.allclose(t.normal(x, 0.2), [-math.sin(th), 0.0, math.cos(th)], atol=1e-12)
    top = length * math.tan(th)
    assert t.height(2.8, 0.0) == pytest.approx(top)
    assert t.height(0.3 + 2 * length + 1.0 - 0.5, 0.0) == pytest.approx(0.5 * math.tan(th))
    assert np.allclose(t.normal(4.0, 0.0), [math.sin(th), 0.0, math.cos(th)])


def test_rotated_box_top_face_from_a_file(tmp_path):
    """A box rolled by 15 deg: top-face height at a point = plane through the face centre with normal R e_z."""
    f = tmp_path / "t.json"
    f.write_text(json.dumps({"boxes": [{"center": [1, 0, 0.1], "size": [1.0, 1.0, 0.2], "rpy_deg": [15, 0, 0]}]}))
    t = parse_terrain(str(f))
    r = math.radians(15)
    n = np.array([0.0, -math.sin(r), math.cos(r)])
    ct = np.array([1, 0, 0.1]) + 0.1 * n
    for y in (-0.3, 0.0, 0.2):
        assert t.height(1.1, y) == pytest.approx(ct[2] - n[1] * (y - ct[1]) / n[2], abs=1e-12)
    assert np.allclose(t.normal(1.1, 0.0), n)
    assert t.part_at(1.1, 0.0) == 0


def test_heightfield_reproduces_a_plane_exactly():
    """The triangle interpolant is exact on an affine function z = a x + b y + c."""
    a, b, c = 0.1, -0.05, 0.02
    xs, ys = np.arange(0, 2.01, 0.1), np.arange(-1, 1.01, 0.1)
    H = a * xs[None, :] + b * ys[:, None] + c
    t = Terrain("hf", -1.0, (), Heightfield(np.array([0.0, -1.0]), 0.1, H))
    rng = np.random.default_rng(0)
    px, py = rng.uniform(0, 2, 50), rng.uniform(-1, 1, 50)
    assert np.allclose(t.height(px, py), a * px + b * py + c, atol=1e-12)
    nrm = np.array([-a, -b, 1.0]) / math.sqrt(1 + a * a + b * b)
    assert np.allclose(t.normal(1.03, 0.21), nrm)
    assert t.part_at(1.03, 0.21) == HEIGHTFIELD
    assert t.height(5.0, 0.0) == -1.0  # outside the grid: the base plane


def test_rough_is_seeded_and_bounded():
    a = parse_terrain("rough:0.02:3")
    b = parse_terrain("rough:0.02:3")
    c = parse_terrain("rough:0.02:4")
    assert np.array_equal(a.heightfield.heights, b.heightfield.heights)
    assert not np.array_equal(a.heightfield.heights, c.heightfield.heights)
    x = np.linspace(-0.5, 11, 500)
    z = a.height(x, 0.05 * np.sin(x))
    assert np.abs(z).max() <= 0.02 and np.abs(z).max() > 0.01
    assert np.all(a.height(np.linspace(-0.5, 0.4, 20), 0.0) == 0.0)  # the start area is flat


def test_sole_support_sees_edges_and_margins():
    t = parse_terrain("stairs:0.1:0.3:3")  # tread 1 spans x in [0.2, 0.5] at z 0.1
    L, W = 0.22, 0.13
    assert t.sole_support(0.35, 0.0, 0.0, L, W) == 0.0  # centred: 4 cm each side
    assert t.sole_support(0.35, 0.0, 0.0, L, W, margin=0.035) == 0.0
    assert t.sole_support(0.35, 0.0, 0.0, L, W, margin=0.045) == pytest.approx(0.1)  # margin reaches both risers
    assert t.sole_support(0.30, 0.0, 0.0, L, W) == pytest.approx(0.1)  # heel overhangs the lower tread
    s = parse_terrain("slope:10")
    assert s.sole_support(1.0, 0.0, 0.3, L, W, margin=0.02) < 1e-12  # fully on the incline, any heading


@pytest.mark.parametrize("spec,words", [
    ("stairs:0:0.3:3", ["RISE", "0 < RISE <= 0.5"]),
    ("stairs:0.1:x:3", ["TREAD", "number"]),
    ("stairs:0.1:0.3:0", ["N", "1 <= N <= 100"]),
    ("stairs:0.1:0.3", ["stairs:RISE:TREAD:N"]),
    ("stairs:0.1:0.3:3:sideways", ["sideways", "up, down, updown"]),
    ("slope:45", ["DEG", "0 < DEG <= 30"]),
    ("rough:0.5:1", ["AMPLITUDE", "0.1"]),
    ("rough:0.02", ["rough:AMPLITUDE:SEED"]),
    ("hills", ["unknown terrain", "stairs:RISE:TREAD:N"]),
    ("flat:1", ["no parameters"]),
    ("", ["non-empty"]),
])
def test_bad_descriptions_raise_typed_errors_naming_the_field(spec, words):
    with pytest.raises(TerrainError) as e:
        parse_terrain(spec)
    assert isinstance(e.value, InvalidInputError)
    for w in words:
        assert w in str(e.value)


def test_bad_files_and_boxes(tmp_path):
    with pytest.raises(TerrainError, match="cannot be read"):
        parse_terrain(str(tmp_path / "missing.toml"))
    bad = tmp_path / "bad.toml"
    bad.write_text("boxes = [ {center = [0, 0]")
    with pytest.raises(TerrainError, match="not valid TOML"):
        parse_terrain(str(bad))
    bad.write_text("walls = 1")
    with pytest.raises(TerrainError, match="unknown key"):
        parse_terrain(str(bad))
    bad.write_text("[[boxes]]\ncenter = [0, 0, 0]\nsize = [1, -1, 1]\n")
    with pytest.raises(TerrainError, match=r"boxes\[0\].*size must be 3 finite numbers > 0"):
        parse_terrain(str(bad))
    with pytest.raises(TerrainError, match="tilted"):
        Box([0, 0, 0], [1, 1, 1], np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], dtype=float))
    with pytest.raises(TerrainError, match="spacing"):
        Heightfield(np.zeros(2), 0.0, np.zeros((2, 2)))
    good = tmp_path / "ok.toml"
    good.write_text("floor_z = 0.0\n[[boxes]]\ncenter = [1.0, 0.0, 0.05]\nsize = [0.4, 1.0, 0.1]\n")
    assert parse_terrain(str(good)).height(1.0, 0.0) == pytest.approx(0.1)


def test_cli_refuses_a_bad_terrain_in_one_line_with_exit_2():
    import os
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-m", "wbc", "walk", "--terrain", "stairs:0.1:0.3:0"], capture_output=True,
                       text=True, env=os.environ.copy(), timeout=120)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "N = 0 is out of range (valid: 1 <= N <= 100)" in lines[0]
