"""The denominator of a push campaign: which of its pushes a robot of this reach and step time could have survived
at all (:mod:`wbc.analysis.capturability`), and the survival on those pushes, per number of steps N, per
push-direction octant, with Wilson 95 % intervals (:func:`wbc.campaign.report.wilson_interval`).

Each trial's state at its push onset is read from the **nominal walk**: the campaign's walk without a push (the log
of ``wbc sim walk --steps S --step-length L --step-duration T --log nominal.npz`` with the campaign's scenario):
before its push a trial walks that walk. From it, at the push time: the CoM and its velocity (the log's ``com``
and its time derivative by central differences), the soles in contact (the controller's ``contact_active``) with
their positions and headings (forward kinematics of the logged ``q``), and the time to the next touch-down of the
swinging sole (the first later tick it is in contact again; from double support the model's shortest swing).
The nominal walk swings the left foot first (``wbc sim walk``'s default); a trial whose walk swings the right foot
first (its ``first_side`` column) is its sagittal mirror image (records/40: the plans agree to 1e-12 m), so its
onset state is the nominal one mirrored about the walking axis y = 0 (y, ẏ and the soles' y and heading negated,
the left sole's place taken by the right one).

Besides the world octants, the capturable pushes are counted by where they point relative to the stance foot at
their onset: **towards** the stance foot (the lateral component points to its side: the swing foot cannot step
there without crossing), **away** from it, or **sagittal** (within 22.5° of the walking axis, or in double
support).

A trial survives here as a robot's operator would sign it: its verdict is ``survived`` and no plant joint went
past its speed limit (``joint_speed_exceedances`` = 0, whatever verdict the row was recorded with).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from wbc.campaign.report import wilson_interval
from wbc.exceptions import InvalidInputError

__all__ = ["NominalWalk", "load_nominal", "capture_model", "push_capturability", "operator_survival", "capture_summary",
           "format_capture_report", "plot_capture_map", "boundary_forces", "OCTANTS", "STANCE_RELATIONS"]

#: Push-direction octants (deg, world: 0 = +x forward, 90 = +y left), centred on their names' directions.
OCTANTS = ("forward", "forward-left", "left", "back-left", "back", "back-right", "right", "forward-right")
#: Where a push points relative to the stance foot at its onset (module docstring).
STANCE_RELATIONS = ("towards the stance foot", "away from the stance foot", "sagittal or double support")


@dataclass(frozen=True)
class NominalWalk:
    """The campaign's walk without a push (module docstring), as arrays over its ticks.

    Attributes:
        t: (n,) s. com: (n, 3) m, world. com_velocity: (n, 3) m/s. contact: (n, 2) bool, left/right in contact.
        q: (n, nq) the plant's configuration (Pinocchio order). robot: the robot's name.
    """

    t: np.ndarray
    com: np.ndarray
    com_velocity: np.ndarray
    contact: np.ndarray
    q: np.ndarray
    robot: str


def load_nominal(path) -> NominalWalk:
    """Read a ``wbc sim walk --log`` file as the nominal walk.

    Raises:
        InvalidInputError: no such file, or not a walk log (the keys it lacks).
    """
    p = Path(path)
    if not p.is_file():
        raise InvalidInputError(f"nominal walk log {p} does not exist (write it with wbc sim walk ... --log FILE)")
    try:
        d = np.load(p, allow_pickle=False)
    except (OSError, ValueError) as e:
        raise InvalidInputError(f"nominal walk log {p}: not a .npz log ({e})") from None
    missing = [k for k in ("t", "com", "contact_active", "q", "robot", "scenario") if k not in d.files]
    if missing or str(d["scenario"]) != "walk":
        raise InvalidInputError(f"nominal walk log {p}: not a wbc sim walk log (missing {missing or 'scenario=walk'})")
    t, com = np.asarray(d["t"], dtype=float), np.asarray(d["com"], dtype=float)
    return NominalWalk(t=t, com=com, com_velocity=np.gradient(com, t, axis=0),
                       contact=np.asarray(d["contact_active"], dtype=bool), q=np.asarray(d["q"], dtype=float),
                       robot=str(d["robot"]))


def capture_model(robot, nominal: NominalWalk, step_time: float):
    """The :class:`~wbc.analysis.capturability.CaptureModel` of ``robot`` for the campaign's walk: its step time
    (s, the scenario's ``step_duration``: swing + double support) and, as the shortest swing, the longest time a
    sole of the nominal walk is out of contact."""
    from wbc.analysis.capturability import CaptureModel

    swing, lift_offs = 0.0, []
    for side in (0, 1):
        off = ~nominal.contact[:, side]
        edges = np.flatnonzero(np.diff(np.r_[0, off.astype(int), 0]))
        lift_offs.append(nominal.t[edges[::2]])
        for a, b in zip(edges[::2], edges[1::2]):
            swing = max(swing, float(nominal.t[min(b, len(nominal.t) - 1)] - nominal.t[a]))
    if swing <= 0.0:
        raise InvalidInputError("the nominal walk never lifts a sole: not a walk with steps")
    period = np.diff(np.sort(np.concatenate(lift_offs)))
    dt = float(np.median(np.diff(nominal.t)))
    if period.size and abs(float(np.median(period)) - step_time) > 2.0 * dt:
        raise InvalidInputError(f"the nominal walk's steps last {float(np.median(period)):.3f} s, the campaign's "
                                f"{step_time:.3f} s: log the campaign's walk (--step-duration {step_time:g})")
    return CaptureModel.of_robot(robot, step_time, min(swing, step_time))


def push_capturability(table, nominal: NominalWalk, model, robot, n_max: int | None = None) -> dict:
    """Capturability of every trial's push (``force``, ``direction_deg``, ``push_duration``, ``push_time_s``
    columns) at the nominal walk's state at its onset (module docstring).

    Args:
        table: the results (``pyarrow.Table``). nominal: :func:`load_nominal`. model:
            :class:`~wbc.analysis.capturability.CaptureModel`. robot: the :class:`~wbc.robot.Robot` of the walk.
        n_max: most steps tried (default :data:`~wbc.analysis.capturability.CAPTURE_STEPS_MAX`).

    Returns:
        ``{"trial": (m,), "steps": (m,) int (−1: not capturable within n_max), "distance_m": (m,) (the capture
        point after the push, outside the stance sole), "t_first_s": (m,), "states": [(com, com velocity, stance
        soles, t_first, push duration)] (the arguments of :func:`~wbc.analysis.capturability.capturability`)}`` for
        the m rows that are not errors, and ``"relation": (m,) int``, the index in :data:`STANCE_RELATIONS`.

    Raises:
        InvalidInputError: a column missing, a push outside the nominal walk's time span, another robot's log.
    """
    import pinocchio as pin

    from wbc.analysis.capturability import CAPTURE_STEPS_MAX, capturability

    n_max = CAPTURE_STEPS_MAX if n_max is None else n_max
    if nominal.robot != robot.name:
        raise InvalidInputError(f"the nominal walk is of {nominal.robot!r}, the campaign of {robot.name!r}")
    cols = {k: table.column(k).to_pylist() for k in table.column_names}
    need = [k for k in ("trial", "outcome", "force", "direction_deg", "push_time_s") if k not in cols]
    if need:
        raise InvalidInputError(f"the results lack the push columns {need} (a push campaign's rows have them)")
    data = robot.model.createData()
    fids = [robot.frame_id(f) for f in (robot.left_sole, robot.right_sole)]
    out = {"trial": [], "steps": [], "distance_m": [], "t_first_s": [], "relation": [], "states": []}
    durations = cols.get("push_duration", [0.1] * len(cols["trial"]))
    sides = cols.get("first_side", ["left"] * len(cols["trial"]))  # rows of campaigns before the column: left
    for trial, outcome, f, deg, t0, dur, side in zip(cols["trial"], cols["outcome"], cols["force"],
                                                     cols["direction_deg"], cols["push_time_s"], durations, sides):
        if outcome == "error" or t0 is None:
            continue
        if not nominal.t[0] <= t0 <= nominal.t[-1]:
            raise InvalidInputError(f"trial {trial}: push at {t0} s, outside the nominal walk's "
                                    f"{nominal.t[0]}–{nominal.t[-1]} s")
        i = int(np.searchsorted(nominal.t, t0))
        pin.framesForwardKinematics(robot.model, data, nominal.q[i])
        mirror = -1.0 if side == "right" else 1.0  # the mirror image of the nominal (left-first) walk
        stance, t_first = [], model.swing_time
        for foot in (0, 1):
            if nominal.contact[i, foot]:
                m = data.oMf[fids[foot]]
                stance.append((m.translation[0], mirror * m.translation[1],
                               mirror * math.atan2(m.rotation[1, 0], m.rotation[0, 0])))
            else:
                later = np.flatnonzero(nominal.contact[i:, foot])
                t_first = float(nominal.t[i + later[0]] - nominal.t[i]) if later.size else model.swing_time
        com, com_velocity = nominal.com[i] * (1.0, mirror, 1.0), nominal.com_velocity[i] * (1.0, mirror, 1.0)
        a = math.radians(deg)
        lateral = math.sin(a - stance[0][2]) if stance else 0.0  # the push's sideways part, stance sole's axes
        if len(stance) != 1 or abs(lateral) < math.sin(math.radians(22.5)):
            out["relation"].append(2)
        else:  # the stance sole at +y of the walk (the nominal's left one, mirrored: its right one) or at −y
            out["relation"].append(0 if (lateral > 0) == (bool(nominal.contact[i, 0]) == (mirror > 0)) else 1)
        r = capturability(model, com, com_velocity, (f * math.cos(a), f * math.sin(a)),
                          0.1 if dur is None else dur, stance, t_first, n_max)
        out["trial"].append(trial)
        out["states"].append((com, com_velocity, stance, t_first, 0.1 if dur is None else dur))
        out["steps"].append(-1 if r.steps is None else r.steps)
        out["distance_m"].append(r.distance)
        out["t_first_s"].append(t_first)
    states = out.pop("states")
    return {**{k: np.asarray(v) for k, v in out.items()}, "states": states}


def boundary_forces(model, states: list, directions_deg, steps: int, f_max: float = 5000.0) -> np.ndarray:
    """The capture boundary along each push direction for each of ``states`` (:func:`push_capturability`'s): the
    largest force (N, to 1 N, up to ``f_max``) the state captures with at most ``steps`` steps, by bisection on
    :func:`~wbc.analysis.capturability.capturability` (its steps grow with the force); 0 when it cannot capture
    even no push. Returns (directions, states)."""
    from wbc.analysis.capturability import capturability

    def ok(f, u, st):
        return capturability(model, st[0], st[1], f * u, st[4], st[2], st[3], steps).steps is not None

    out = np.zeros((len(directions_deg), len(states)))
    for i, deg in enumerate(np.asarray(directions_deg, dtype=float)):
        u = np.array([math.cos(math.radians(deg)), math.sin(math.radians(deg))])
        for j, st in enumerate(states):
            if not ok(0.0, u, st):
                continue
            lo, hi = 0.0, f_max
            if ok(hi, u, st):
                lo = hi
            while hi - lo > 1.0:
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if ok(mid, u, st) else (lo, mid)
            out[i, j] = lo
    return out


def operator_survival(table) -> dict:
    """{trial: survived} as an operator signs it (module docstring), for the rows that are not errors."""
    cols = {k: table.column(k).to_pylist() for k in table.column_names}
    exceed = cols.get("joint_speed_exceedances", [0] * len(cols["trial"]))
    return {t: o == "survived" and not (e or 0) for t, o, e in zip(cols["trial"], cols["outcome"], exceed)
            if o != "error"}


def _rate(ok: np.ndarray) -> dict:
    n, k = int(ok.size), int(np.sum(ok))
    return {"n": n, "survived": k, "rate": k / n if n else math.nan, "wilson95": wilson_interval(k, n)}


def _octant(deg: np.ndarray) -> np.ndarray:
    return (np.floor((np.mod(deg, 360.0) + 22.5) / 45.0).astype(int)) % 8


def capture_summary(table, capture: dict) -> dict:
    """Survival overall, on the capturable pushes, per N and per push-direction octant of the capturable pushes.

    Args:
        table: the results. capture: :func:`push_capturability`'s arrays.

    Returns:
        ``{"overall", "capturable", "not_capturable", "share_capturable": (k, n, (lo, hi)), "per_steps": {N: ...},
        "per_octant": {name: ...}, "per_relation": {relation: ...}, "per_first_side": {"left", "right"}}`` (the
        last three on the capturable pushes; relations: :data:`STANCE_RELATIONS`), each entry ``{"n", "survived",
        "rate", "wilson95"}``.
    """
    alive = operator_survival(table)
    cols = {k: table.column(k).to_pylist() for k in ("trial", "direction_deg")}
    deg = dict(zip(cols["trial"], cols["direction_deg"]))
    first = dict(zip(cols["trial"], table.column("first_side").to_pylist() if "first_side" in table.column_names
                     else ["left"] * len(cols["trial"])))
    trials, steps = capture["trial"], capture["steps"]
    ok = np.array([alive[t] for t in trials], dtype=bool)
    cap = steps >= 0
    octant = _octant(np.array([deg[t] for t in trials], dtype=float))
    relation = np.asarray(capture["relation"])
    side = np.array([first[t] for t in trials])
    n_cap = int(cap.sum())
    return {"overall": _rate(ok), "capturable": _rate(ok[cap]), "not_capturable": _rate(ok[~cap]),
            "share_capturable": (n_cap, int(cap.size), wilson_interval(n_cap, int(cap.size))),
            "per_steps": {int(s): _rate(ok[steps == s]) for s in sorted(set(steps.tolist()))},
            "per_octant": {OCTANTS[o]: _rate(ok[cap & (octant == o)]) for o in range(8)},
            "per_relation": {name: _rate(ok[cap & (relation == r)]) for r, name in enumerate(STANCE_RELATIONS)},
            "per_first_side": {s: _rate(ok[cap & (side == s)]) for s in ("left", "right")}}


def _line(name: str, r: dict) -> str:
    lo, hi = r["wilson95"]
    rate = f"{r['rate']:.3f}" if r["n"] else "  -  "
    return f"  {name:<26} {r['survived']:>4}/{r['n']:<4} {rate} [{lo:.3f}, {hi:.3f}]"


def format_capture_report(summary: dict) -> str:
    """The text of :func:`capture_summary` (survived/n, rate, Wilson 95 % interval per line)."""
    k, n, (lo, hi) = summary["share_capturable"]
    lines = ["survival as an operator signs it (no fall, no joint past its speed limit), Wilson 95 %:",
             _line("all pushes", summary["overall"]), _line("capturable pushes", summary["capturable"]),
             _line("not capturable", summary["not_capturable"]),
             f"  capturable share            {k:>4}/{n:<4} {k / n if n else math.nan:.3f} [{lo:.3f}, {hi:.3f}]",
             "per number of steps the LIPM needs (-1: more than n_max):"]
    lines += [_line(f"{s}-step" if s >= 0 else "not capturable", r) for s, r in summary["per_steps"].items()]
    lines.append("capturable pushes per direction octant (0° = +x forward, 90° = +y left):")
    lines += [_line(name, r) for name, r in summary["per_octant"].items()]
    lines.append("capturable pushes by direction relative to the stance foot at the onset:")
    lines += [_line(name, r) for name, r in summary["per_relation"].items()]
    lines.append("capturable pushes by the foot that swings first:")
    lines += [_line(f"{name} first", r) for name, r in summary["per_first_side"].items()]
    return "\n".join(lines)


def plot_capture_map(table, capture: dict, path, model=None) -> Path:
    """Push force against direction and against the gait phase, each trial coloured by the steps its push needs
    (grey: not capturable) and marked survived (o) or failed (x); with ``model`` (the
    :class:`~wbc.analysis.capturability.CaptureModel`), the 0-, 1- and 2-step boundaries over the direction
    (:func:`boundary_forces` over every trial's onset state); written to ``path`` (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    alive = operator_survival(table)
    cols = {k: table.column(k).to_pylist() for k in table.column_names}
    row = {t: i for i, t in enumerate(cols["trial"])}
    idx = [row[t] for t in capture["trial"]]
    force = np.array([cols["force"][i] for i in idx], dtype=float)
    deg = np.mod(np.array([cols["direction_deg"][i] for i in idx], dtype=float), 360.0)
    phase = np.array([(cols.get("phase") or cols["push_time_s"])[i] for i in idx], dtype=float)
    ok = np.array([alive[t] for t in capture["trial"]], dtype=bool)
    steps = capture["steps"]
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.5))
    colours = {0: "tab:green", 1: "tab:blue", 2: "tab:orange", 3: "tab:purple"}
    for ax, x, label in ((axes[0], deg, "push direction (deg, 0 = +x forward, 90 = +y left)"),
                         (axes[1], phase, "push onset (fraction of the walking steps)" if "phase" in cols
                          else "push onset (s)")):
        for s in sorted(set(steps.tolist())):
            colour = colours.get(s, "tab:red") if s >= 0 else "0.6"
            name = f"{s}-step" if s >= 0 else "not capturable"
            for good, marker in ((True, "o"), (False, "x")):
                m = (steps == s) & (ok == good)
                if m.any():
                    ax.scatter(x[m], force[m], c=colour, marker=marker, s=22,
                               label=f"{name}, {'survived' if good else 'failed'}")
        ax.set_xlabel(label)
        ax.set_ylabel("push force (N)")
    if model is not None:  # the boundaries: below a solid line every trial's onset captures with ≤ N steps,
        grid = np.arange(0.0, 361.0, 10.0)  # below a dashed one half of them do
        top = float(force.max()) * 1.6 if force.size else 1000.0
        for s in range(0, 3):
            b = boundary_forces(model, capture["states"], grid, s, f_max=top)
            axes[0].plot(grid, b.min(axis=1), color=colours[s], lw=1.2, label=f"{s}-step boundary, every onset")
            axes[0].plot(grid, np.median(b, axis=1), color=colours[s], lw=1.0, ls="--",
                         label=f"{s}-step boundary, half the onsets")
        axes[0].set_ylim(0.0, top)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=7, loc="lower center", ncol=4)
    fig.suptitle("pushes by the steps the LIPM needs to capture them (o survived, x failed)")
    fig.tight_layout(rect=(0.0, 0.14, 1.0, 1.0))
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
