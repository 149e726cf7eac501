"""Plots of a run's log (matplotlib, Agg backend): what the controller did, on one PNG.

:func:`plot_log` reads any of wbc's npz logs (``wbc walk``/``wbc balance``: ``com``, ``com_ref``, ``left_sole``,
``right_sole``, ``support``, ``tick_time``...; ``wbc sim``: ``com``, ``sole_pos``, ``sim_wrench``,
``contact_active``...) and draws, one axes each (titles are stable, tests look for them):

* ``CoM, ZMP, DCM: x`` and ``... : y`` vs time (m): CoM, CoM reference, planned ZMP (walk logs) or
  commanded CoP and planned DCM (sim walk logs: ``cop_cmd``, ``dcm_ref``), executed
  ZMP (cart-table ZMP of the CoM, Kajita 2003 eq. 3) or measured CoP (sim: from the ground-truth foot
  wrenches), DCM (c + ċ/ω, Englsberger 2015 eq. 7); shaded bands: single support (left / right stance);
* ``CoM, soles: z`` vs time (m): CoM height (and its reference), left and right sole heights (a squat, a jump,
  a swing foot); same bands;
* ``top view`` (x-y, m): sole-origin paths, footprints (sole outlines at the start and at each touchdown, with
  a loadable robot), CoM and ZMP/CoP paths;
* ``joint positions / limits``: each bounded joint's position mapped to [0, 1] over its URDF range (0 and 1
  are the limits, drawn as lines);
* ``contact forces`` (sim logs only): vertical ground reaction on each foot (N);
* ``tick time``: histogram of the controller's time per tick (ms) with the control period (e.g. 2 ms) line, over
  [0, max(5 periods, 1.1 × the 99.5th percentile)]; slower ticks are counted in the legend.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from wbc.exceptions import InvalidInputError
from wbc.scenarios.metrics import executed_multibody_zmp
from wbc.viz.overlays import cart_table_zmp, contact_items, cop_track, dcm_of

__all__ = ["plot_log", "load_log", "MIN_SPAN_M"]

#: Smallest vertical span of the position panels (x, y, z vs time), m: a panel whose data vary less is centred on
#: them with this span, so that sub-millimetre noise (40 µm) does not fill the panel and look like a swing.
MIN_SPAN_M = 0.01


def _floor_span(ax, span: float = MIN_SPAN_M) -> None:
    """Widen ``ax``'s y-limits to at least ``span`` around their centre."""
    lo, hi = ax.get_ylim()
    if hi - lo < span:
        mid = 0.5 * (lo + hi)
        ax.set_ylim(mid - 0.5 * span, mid + 0.5 * span)


def _sole_heights(log) -> dict[str, np.ndarray]:
    """Left and right sole-origin heights (m, world) of a walk/balance log (sole poses) or a sim log (sole_pos)."""
    if "left_sole" in log and "right_sole" in log:
        return {"left sole": np.asarray(log["left_sole"])[:, 2, 3], "right sole": np.asarray(log["right_sole"])[:, 2, 3]}
    if "sole_pos" in log:
        pos = np.asarray(log["sole_pos"])
        return {"left sole": pos[:, 0, 2], "right sole": pos[:, 1, 2]}
    return {}


def load_log(path: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """The arrays of an npz log as a dict.

    Raises:
        InvalidInputError: the file does not exist or is not an npz log with ``t``, ``q`` and ``com``.
    """
    path = Path(path)
    if not path.is_file():
        raise InvalidInputError(f"log {str(path)!r} does not exist (write one with --log FILE.npz)")
    try:
        with np.load(path, allow_pickle=False) as z:
            log = {k: z[k] for k in z.files}
    except Exception as exc:  # noqa: BLE001 - zipfile.BadZipFile, EOFError, ValueError...: not a readable npz
        reason = f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else 'truncated'}"
        if "pickle" in str(exc).lower():  # numpy's advice to load it unsafely is not passed on
            reason = "it holds pickled Python objects, which wbc never loads; a wbc log holds arrays only"
        raise InvalidInputError(f"{str(path)!r} is not a readable npz log ({reason})") from exc
    missing = [k for k in ("t", "q", "com") if k not in log]
    if missing:
        raise InvalidInputError(f"log {str(path)!r} lacks {missing} (not a wbc walk/balance/sim log)")
    return log


def _cop(log: Mapping[str, np.ndarray]) -> np.ndarray:
    return cop_track(np.asarray(log["sim_wrench"], float), np.asarray(log["sole_pos"], float))


def _stance_bands(log):
    """(t_start, t_end, label) of single-support phases."""
    t = log["t"]
    if "support" in log:
        s = np.asarray(log["support"]).astype(int)
        single = {1: "left stance", 2: "right stance"}
    elif "contact_active" in log:
        c = np.asarray(log["contact_active"]).astype(bool)
        s = np.where(c[:, 0] & ~c[:, 1], 1, np.where(c[:, 1] & ~c[:, 0], 2, 0))
        single = {1: "left stance", 2: "right stance"}
    else:
        return []
    out = []
    starts = np.r_[0, np.flatnonzero(np.diff(s)) + 1]
    ends = np.r_[starts[1:], len(s) - 1]
    for a, b in zip(starts, ends):
        if s[a] in single:
            out.append((float(t[a]), float(t[b]), single[s[a]]))
    return out


def _robot(log):
    """The robot named in the log (None if it cannot be loaded by name or does not match ``q``)."""
    if "robot" not in log:
        return None
    try:
        from wbc.robot import load_robot

        robot = load_robot(str(log["robot"]))
    except Exception:  # noqa: BLE001 - a custom URDF may not be loadable by name: skip what needs it
        return None
    return robot if robot.nq == log["q"].shape[1] else None


def _footprints(log, robot) -> list[np.ndarray]:
    """Closed sole outlines (K, 3) where each foot stood: at the start and at each touchdown (m, world).

    Walk/balance logs: realized sole poses and support codes. Sim logs: sole poses of ``q`` (Pinocchio) and
    contact from the plant's vertical foot force (> 10 N)."""
    if robot is None:
        return []
    t = np.asarray(log["t"], float)
    if "left_sole" in log and "support" in log:
        left, right, support = log["left_sole"], log["right_sole"], np.asarray(log["support"]).astype(int)
    elif "sim_wrench" in log:
        import pinocchio as pin

        model, data = robot.model, robot.model.createData()
        frames = (robot.frame_id(robot.left_sole), robot.frame_id(robot.right_sole))
        soles = np.empty((2, len(t), 4, 4))
        for i, q in enumerate(np.asarray(log["q"], float)):
            pin.framesForwardKinematics(model, data, q)
            for j, f in enumerate(frames):
                soles[j, i] = data.oMf[f].homogeneous
        left, right = soles
        down = np.asarray(log["sim_wrench"])[:, :, 2] > 10.0
        support = np.where(down[:, 0] & down[:, 1], 0, np.where(down[:, 0], 1, np.where(down[:, 1], 2, 3)))
    else:
        return []
    _, prints, _ = contact_items(t, support, left, right, robot.sole_length, robot.sole_width)
    return prints


def _limits(robot):
    """(lo, hi, q_columns) of the robot's bounded joints, or None without a robot."""
    if robot is None:
        return None
    from wbc.constraints.limits import bounded_joints

    idx_q, _ = bounded_joints(robot.model)
    return robot.model.lowerPositionLimit[idx_q], robot.model.upperPositionLimit[idx_q], idx_q


def plot_log(log: Mapping[str, np.ndarray] | str | os.PathLike[str], out: str | os.PathLike[str] | None = None):
    """Draw the panels of the module docstring for one run; returns the matplotlib Figure (saved to ``out``).

    Args:
        log: an npz path or the dict of its arrays (:func:`load_log`).
        out: PNG path (its folder must exist), or None to only return the figure.

    Raises:
        InvalidInputError: see :func:`load_log`; ``out``'s folder does not exist.
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    if not isinstance(log, Mapping):
        log = load_log(log)
    if out is not None and not Path(out).parent.is_dir():
        raise InvalidInputError(f"plot folder {str(Path(out).parent)!r} does not exist")
    t, com = np.asarray(log["t"], float), np.asarray(log["com"], float)
    physics = "sim_wrench" in log
    robot = _robot(log)
    if physics:
        zmp_name, zmp = "CoP measured", _cop(log)
    elif robot is not None and all(k in log for k in ("q", "v", "left_sole", "right_sole", "support")):
        # the multi-body ZMP the summaries judge (wbc.scenarios.metrics.executed_multibody_zmp)
        zmp_name = "ZMP executed"
        zmp = executed_multibody_zmp(robot.model, robot.mass, float(t[1] - t[0]), com, log["q"], log["v"],
                                     log["left_sole"], log["right_sole"], log["support"])
    else:  # a robot that cannot be loaded by name: the CoM-only (cart-table) ZMP, labelled as such
        zmp_name, zmp = "ZMP executed (CoM only)", cart_table_zmp(t, com)
    dcm = dcm_of(t, com)
    limits = _limits(robot)
    n_panels = 5 + (limits is not None) + physics
    fig, axes = plt.subplots(n_panels, 1, figsize=(10, 3.2 * n_panels), constrained_layout=True)
    axes = list(axes)
    bands = _stance_bands(log)

    def draw_bands(ax):
        for k, (a, b, label) in enumerate(bands):
            color = "#d9c2f0" if label.startswith("left") else "#c2eaf0"
            ax.axvspan(a, b, color=color, alpha=0.5, lw=0, label=label if label not in
                       [bb[2] for bb in bands[:k]] else None)

    for i, coord in enumerate("xy"):
        ax = axes.pop(0)
        ax.set_title(f"CoM, ZMP, DCM: {coord}")
        ax.plot(t, com[:, i], color="#e0262b", label="CoM")
        if "com_ref" in log:
            ax.plot(t, log["com_ref"][:, i], color="#e0262b", ls="--", label="CoM reference")
        if "zmp_ref" in log:
            ax.plot(t, log["zmp_ref"][:, i], color="#1fa34a", ls="--", label="ZMP planned")
        if "cop_cmd" in log:
            ax.plot(t, log["cop_cmd"][:, i], color="#1fa34a", ls="--", label="CoP commanded")
        ax.plot(t, zmp[:, i], color="#1fa34a", alpha=0.8, label=zmp_name)
        ax.plot(t, dcm[:, i], color="#2b6fe0", label="DCM")
        if "dcm_ref" in log:
            ax.plot(t, log["dcm_ref"][:, i], color="#2b6fe0", ls="--", label="DCM planned")
        draw_bands(ax)
        ax.set_xlabel("t (s)")
        ax.set_ylabel(f"{coord} (m)")
        ax.legend(loc="upper left", fontsize=7, ncol=3)
        _floor_span(ax)
    ax = axes.pop(0)
    ax.set_title("CoM, soles: z")
    ax.plot(t, com[:, 2], color="#e0262b", label="CoM")
    if "com_ref" in log:
        ax.plot(t, np.asarray(log["com_ref"])[:, 2], color="#e0262b", ls="--", label="CoM reference")
    for (name, z), color in zip(_sole_heights(log).items(), ("#9b3fd1", "#15a5b5")):
        ax.plot(t, z, color=color, label=name)
    draw_bands(ax)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("z (m)")
    ax.legend(loc="center right", fontsize=7, ncol=2)
    _floor_span(ax)
    ax = axes.pop(0)
    ax.set_title("top view")
    if "left_sole" in log:
        feet = {"left sole": log["left_sole"][:, :2, 3], "right sole": log["right_sole"][:, :2, 3]}
    elif "sole_pos" in log:
        feet = {"left sole": log["sole_pos"][:, 0, :2], "right sole": log["sole_pos"][:, 1, :2]}
    else:
        feet = {}
    for (name, xy), color in zip(feet.items(), ("#9b3fd1", "#15a5b5")):
        ax.plot(xy[:, 0], xy[:, 1], color=color, lw=0.8, label=name)
    for k, outline in enumerate(_footprints(log, robot)):
        closed = np.vstack([outline, outline[:1]])
        ax.plot(closed[:, 0], closed[:, 1], color="#222222", lw=0.8, label="footprints" if k == 0 else None)
    ax.plot(com[:, 0], com[:, 1], color="#e0262b", label="CoM path")
    ax.plot(zmp[:, 0], zmp[:, 1], color="#1fa34a", lw=0.8, label=f"{zmp_name} path")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="upper left", fontsize=7)
    if limits is not None:
        lo, hi, idx = limits
        ax = axes.pop(0)
        ax.set_title("joint positions / limits")
        frac = (np.asarray(log["q"])[:, idx] - lo) / np.where(hi > lo, hi - lo, 1.0)
        names = list(log["joint_names"]) if "joint_names" in log and len(log["joint_names"]) == len(idx) else None
        for j in range(frac.shape[1]):
            ax.plot(t, frac[:, j], lw=0.7, label=str(names[j]) if names else f"joint {j}")
        ax.axhline(0.0, color="k", lw=1.2, label="lower limit")
        ax.axhline(1.0, color="k", lw=1.2, ls="--", label="upper limit")
        ax.set_xlabel("t (s)")
        ax.set_ylabel("(q - lower) / (upper - lower)")
    if physics:
        ax = axes.pop(0)
        ax.set_title("contact forces")
        w = log["sim_wrench"]
        ax.plot(t, w[:, 0, 2], color="#9b3fd1", label="left foot f_z")
        ax.plot(t, w[:, 1, 2], color="#15a5b5", label="right foot f_z")
        if "ext_force" in log and np.any(log["ext_force"]):
            ax.plot(t, np.linalg.norm(log["ext_force"], axis=1), color="#ff2020", label="push |f|")
        ax.set_xlabel("t (s)")
        ax.set_ylabel("force (N)")
        ax.legend(loc="upper left", fontsize=7)
    ax = axes.pop(0)
    ax.set_title("tick time")
    tick_ms = 1e3 * np.asarray(log["tick_time"], float)
    dt_ms = 1e3 * float(log["dt"]) if "dt" in log else 2.0
    # range: up to 5 periods or the 99.5th percentile (+10 %), so one slow tick (a first-call compilation, the
    # machine busy) does not squeeze every other tick into the first bin; ticks beyond are counted in the label
    upper = max(5.0 * dt_ms, 1.1 * float(np.percentile(tick_ms, 99.5))) if tick_ms.size else 5.0 * dt_ms
    beyond = tick_ms > upper
    label = "controller tick"
    if beyond.any():
        label += f" ({int(beyond.sum())} > {upper:.3g} ms not shown, max {tick_ms.max():.4g} ms)"
    ax.hist(tick_ms[~beyond], bins=60, range=(0.0, upper), color="#777777", label=label)
    ax.axvline(dt_ms, color="#e0262b", label=f"period {dt_ms:g} ms")
    ax.set_xlabel("time per tick (ms)")
    ax.set_ylabel("ticks")
    ax.set_yscale("log")
    ax.legend(loc="upper right", fontsize=7)
    if out is not None:
        fig.savefig(out, dpi=90)
    return fig
