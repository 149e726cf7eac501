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
    return {"t": t, "q": q, "com": com, "com_ref": com.copy(), "tick_time": tick, "dt": np.array(dt),
            "robot": np.array("talos")}


def _panels(fig):
    return {ax.get_title(): ax for ax in fig.axes}


def _labels(ax):
    return [line.get_label() for line in ax.get_lines()]


def test_walk_log_panels(talos, tmp_path):
    log = _base_log(talos)
    n = len(log["t"])
    sole = np.tile(np.eye(4), (n, 1, 1))
    log.update(zmp_ref=np.zeros((n, 2)), left_sole=sole, right_sole=sole.copy(),
               support=np.r_[np.zeros(50), np.ones(50), np.zeros(50), 2 * np.ones(50)].astype(int))
    fig = plot_log(log, tmp_path / "p.png")
    assert (tmp_path / "p.png").stat().st_size > 10_000
    panels = _panels(fig)
    assert set(panels) == {"CoM, ZMP, DCM: x", "CoM, ZMP, DCM: y", "top view", "joint positions / limits",
                           "tick time"}
    for coord in "xy":
        ax = panels[f"CoM, ZMP, DCM: {coord}"]
        assert _labels(ax) == ["CoM", "CoM reference", "ZMP planned", "ZMP executed", "DCM"]
        assert {p.get_label() for p in ax.patches} >= {"left stance", "right stance"}  # support bands
    np.testing.assert_allclose(panels["CoM, ZMP, DCM: y"].get_lines()[0].get_ydata(), log["com"][:, 1])
    assert _labels(panels["top view"]) == ["left sole", "right sole", "CoM path", "ZMP executed path"]
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
    log.update(sim_wrench=wrench, sole_pos=sole_pos, contact_active=np.ones((n, 2), bool),
               ext_force=np.zeros((n, 3)))
    panels = _panels(plot_log(log))
    assert _labels(panels["contact forces"]) == ["left foot f_z", "right foot f_z"]
    x = panels["CoM, ZMP, DCM: x"]
    assert "CoP measured" in _labels(x)
    cop_x = x.get_lines()[_labels(x).index("CoP measured")].get_ydata()
    np.testing.assert_allclose(cop_x, 0.005, atol=1e-12)  # (0.01 * 450 + 0 * 450) / 900
    cop_y = panels["CoM, ZMP, DCM: y"].get_lines()[_labels(x).index("CoP measured")].get_ydata()
    np.testing.assert_allclose(cop_y, 0.0, atol=1e-12)


def test_bad_logs_are_refused(tmp_path):
    with pytest.raises(InvalidInputError, match="does not exist"):
        plot_log(tmp_path / "missing.npz")
    np.savez(tmp_path / "x.npz", a=np.zeros(3))
    with pytest.raises(InvalidInputError, match="lacks"):
        plot_log(tmp_path / "x.npz")
