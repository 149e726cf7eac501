"""wbc.viz.plots: each figure's axes hold the expected series (by title and line label), from synthetic logs."""

from __future__ import annotations

import numpy as np
import pytest

from wbc.exceptions import InvalidInputError
from wbc.viz.plots import plot_log


@pytest.fixture(scope="module")
def talos(robots):
    return robots("talos")


def _base_log(talos, n=200, dt=0.002):
    t = np.arange(n) * dt
    q = np.tile(talos.q_ref, (n, 1))
    com = np.c_[0.01 * t, 0.05 * np.sin(t), np.full(n, 0.87)]
    tick = np.full(n, 0.5e-3)
    tick[::50] = 3e-3  # four ticks over the 2 ms budget
    v = np.zeros((n, talos.model.nv))  # no angular momentum: the multi-body ZMP reduces to the cart-table one
    return {"t": t, "q": q, "v": v, "com": com, "com_ref": com.copy(), "tick_time": tick, "dt": np.array(dt),
            "robot": np.array("talos")}


def _panels(fig):
    return {ax.get_title(): ax for ax in fig.axes}


def _labels(ax):
    """Legend labels of the lines (matplotlib names unlabelled lines ``_child<k>``)."""
    return [line.get_label() for line in ax.get_lines() if not line.get_label().startswith("_")]


def test_walk_log_panels(talos, tmp_path):
    log = _base_log(talos)
    n = len(log["t"])
    sole = np.tile(np.eye(4), (n, 1, 1))
    log.update(zmp_ref=np.zeros((n, 2)), left_sole=sole, right_sole=sole.copy(),
               support=np.r_[np.zeros(50), np.ones(50), np.zeros(50), 2 * np.ones(50)].astype(int))
    fig = plot_log(log, tmp_path / "p.png")
    assert (tmp_path / "p.png").stat().st_size > 10_000
    panels = _panels(fig)
    assert set(panels) == {"CoM, ZMP, DCM: x", "CoM, ZMP, DCM: y", "CoM, soles: z", "top view",
                           "joint positions / limits", "tick time"}
    for coord in "xy":
        ax = panels[f"CoM, ZMP, DCM: {coord}"]
        assert _labels(ax) == ["CoM", "CoM reference", "ZMP planned", "ZMP executed", "DCM"]
        assert {p.get_label() for p in ax.patches} >= {"left stance", "right stance"}  # support bands
    np.testing.assert_allclose(panels["CoM, ZMP, DCM: y"].get_lines()[0].get_ydata(), log["com"][:, 1])
    top = panels["top view"]
    assert _labels(top) == ["left sole", "right sole", "footprints", "CoM path", "ZMP executed path"]
    # footprints: each foot at the start, and the right foot at its touchdown (left stance 1 -> double 0; the
    # log ends with the left foot in the air): 3 closed rectangles of Talos's sole size on the sole origin (0, 0)
    outlines = [ln for ln in top.get_lines() if ln.get_color() == "#222222"]
    assert len(outlines) == 3
    for ln in outlines:
        x, y = ln.get_xdata(), ln.get_ydata()
        assert len(x) == 5 and (x[0], y[0]) == (x[-1], y[-1])
        assert np.ptp(x) == pytest.approx(talos.sole_length) and np.ptp(y) == pytest.approx(talos.sole_width)
        assert np.mean(x[:4]) == pytest.approx(0.0, abs=1e-12)
    joints = panels["joint positions / limits"]
    n_bounded = talos.model.nq - 7  # Talos: every actuated joint is bounded
    assert len(joints.get_lines()) == n_bounded + 2 and _labels(joints)[-2:] == ["lower limit", "upper limit"]
    hist = panels["tick time"]
    assert _labels(hist) == ["period 2 ms"] and hist.get_lines()[0].get_xdata()[0] == pytest.approx(2.0)
    assert sum(p.get_height() for p in hist.patches) == n  # every tick in the histogram


def test_sim_log_has_contact_forces_and_measured_cop(talos):
    log = _base_log(talos)
    n = len(log["t"])
    wrench = np.zeros((n, 2, 6))
    wrench[:, :, 2] = 450.0
    wrench[:, 0, 4] = -450.0 * 0.01  # left CoP 1 cm ahead of the sole origin: m_y = -(c_x - p_x) f_z
    sole_pos = np.zeros((n, 2, 3))
    sole_pos[:, 0, 1], sole_pos[:, 1, 1] = 0.085, -0.085
    push = np.zeros((n, 3))
    push[100:110, 1] = 150.0
    dcm_ref = np.c_[np.linspace(0, 0.1, n), np.zeros(n)]
    log.update(sim_wrench=wrench, sole_pos=sole_pos, contact_active=np.ones((n, 2), bool),
               ext_force=push, dcm_ref=dcm_ref, cop_cmd=np.zeros((n, 2)))
    panels = _panels(plot_log(log))
    assert set(panels) == {"CoM, ZMP, DCM: x", "CoM, ZMP, DCM: y", "CoM, soles: z", "top view",
                           "joint positions / limits", "contact forces", "tick time"}
    z = panels["CoM, soles: z"]
    assert _labels(z) == ["CoM", "CoM reference", "left sole", "right sole"]
    np.testing.assert_allclose(z.get_lines()[2].get_ydata(), sole_pos[:, 0, 2])
    assert _labels(panels["contact forces"]) == ["left foot f_z", "right foot f_z", "push |f|"]
    np.testing.assert_allclose(panels["contact forces"].get_lines()[2].get_ydata(), np.linalg.norm(push, axis=1))
    assert _labels(panels["CoM, ZMP, DCM: x"]) == ["CoM", "CoM reference", "CoP commanded", "CoP measured", "DCM",
                                                   "DCM planned"]
    np.testing.assert_allclose(panels["CoM, ZMP, DCM: x"].get_lines()[5].get_ydata(), dcm_ref[:, 0])
    # both feet loaded all along (f_z 450 N > 10 N): one footprint per foot, at the sole frames of q (q_ref)
    assert "footprints" in _labels(panels["top view"])
    x = panels["CoM, ZMP, DCM: x"]
    assert "CoP measured" in _labels(x)
    cop_x = x.get_lines()[_labels(x).index("CoP measured")].get_ydata()
    np.testing.assert_allclose(cop_x, 0.005, atol=1e-12)  # (0.01 * 450 + 0 * 450) / 900
    cop_y = panels["CoM, ZMP, DCM: y"].get_lines()[_labels(x).index("CoP measured")].get_ydata()
    np.testing.assert_allclose(cop_y, 0.0, atol=1e-12)


def test_balance_log_panels(talos):
    """A balance log (no planned ZMP): CoM, its reference, executed ZMP and DCM; left-stance band only."""
    log = _base_log(talos)
    n = len(log["t"])
    sole = np.tile(np.eye(4), (n, 1, 1))
    right = sole.copy()
    right[:, 1, 3] = -0.17
    support = np.r_[np.zeros(60), np.ones(80), np.zeros(60)].astype(np.int8)
    log.update(left_sole=sole, right_sole=right, support=support, com_margin=np.full(n, 0.05),
               solver_ok=np.ones(n, bool), behaviour=np.array("one-leg"))
    panels = _panels(plot_log(log))
    assert "contact forces" not in panels
    y = panels["CoM, ZMP, DCM: y"]
    assert _labels(y) == ["CoM", "CoM reference", "ZMP executed", "DCM"]
    assert [p.get_label() for p in y.patches] == ["left stance"]
    band = y.patches[0]  # the single-support phase: ticks 60 .. 140
    assert band.get_x() == pytest.approx(log["t"][60])
    assert band.get_x() + band.get_width() == pytest.approx(log["t"][140])
    # the executed ZMP is the multi-body ZMP; with v = 0 (L̇ = 0) and a constant CoM height on a z = 0 stance it
    # is the cart-table ZMP of the logged CoM (independent closed form: c - z/g * c'')
    from wbc.viz.overlays import cart_table_zmp

    zmp = y.get_lines()[_labels(y).index("ZMP executed")].get_ydata()
    # (interior samples: the end rows differ by the finite-difference convention at the ends)
    np.testing.assert_allclose(zmp[2:-2], cart_table_zmp(log["t"], log["com"])[2:-2, 1])
    top = panels["top view"]
    outlines = [ln for ln in top.get_lines() if ln.get_color() == "#222222"]
    assert len(outlines) == 3  # left at start, right at start, right at its touchdown (t = 140 dt)
    assert sorted(round(float(np.mean(ln.get_ydata()[:4])), 6) for ln in outlines) == [-0.17, -0.17, 0.0]


def test_tick_histogram_keeps_its_range_when_one_tick_is_very_slow(talos):
    log = _base_log(talos)
    n = len(log["t"])
    log["tick_time"] = np.full(n, 0.3e-3)
    log["tick_time"][:3] = [0.58, 2.5e-3, 1.0e-3]  # a 580 ms first tick (compilation), one deadline miss
    hist = _panels(plot_log(log))["tick time"]
    assert hist.get_xlim()[1] < 20.0  # not stretched to 580 ms
    assert sum(p.get_height() for p in hist.patches) == n - 1  # all but the outlier are drawn
    labels = [h.get_label() for h in hist.patches[:1]] + _labels(hist)
    assert any("1 > 10 ms not shown, max 580 ms" in lb for lb in labels), labels


def test_bad_logs_are_refused(tmp_path):
    with pytest.raises(InvalidInputError, match="does not exist"):
        plot_log(tmp_path / "missing.npz")
    np.savez(tmp_path / "x.npz", a=np.zeros(3))
    with pytest.raises(InvalidInputError, match="lacks"):
        plot_log(tmp_path / "x.npz")


def test_z_panel_shows_a_squat_and_sole_heights(talos):
    """A 15 cm squat (CoM z down and up) and a foot lifted 10 cm are drawn on the z panel at their true scale."""
    log = _base_log(talos)
    n = len(log["t"])
    log["com"][:, 2] = 0.87 - 0.15 * np.sin(np.linspace(0.0, np.pi, n))
    sole = np.tile(np.eye(4), (n, 1, 1))
    right = sole.copy()
    right[:, 2, 3] = 0.1 * np.sin(np.linspace(0.0, np.pi, n))
    right[:, 1, 3] = -0.17
    log.update(left_sole=sole, right_sole=right, support=np.ones(n, dtype=int))
    panels = _panels(plot_log(log))
    z = panels["CoM, soles: z"]
    assert _labels(z) == ["CoM", "CoM reference", "left sole", "right sole"]
    np.testing.assert_allclose(z.get_lines()[0].get_ydata(), log["com"][:, 2])
    np.testing.assert_allclose(z.get_lines()[3].get_ydata(), right[:, 2, 3])
    lo, hi = z.get_ylim()
    assert lo <= 0.0 and hi >= 0.87  # soles on the floor and the standing CoM in view


def test_autoscale_has_a_floor_on_its_span(talos):
    """40 µm of noise on a flat CoM y must not fill its panel: the span is at least 1 cm (noise < 0.5 % of it)."""
    log = _base_log(talos)
    n = len(log["t"])
    rng = np.random.default_rng(0)
    log["com"][:, 1] = 0.00140 + 40e-6 * rng.random(n)
    log["com_ref"] = log["com"].copy()
    ax = _panels(plot_log(log))["CoM, ZMP, DCM: y"]
    lo, hi = ax.get_ylim()
    assert hi - lo >= 0.01 - 1e-12
    assert lo < 0.00140 and hi > 0.00144
    assert 40e-6 / (hi - lo) <= 0.005
    # CoM x creeping 4 mm (DCM 3 mm ahead): data spanning 7 mm get a 1 cm panel
    lo, hi = _panels(plot_log(_base_log(talos)))["CoM, ZMP, DCM: x"].get_ylim()
    assert hi - lo == pytest.approx(0.01)
