"""A campaign: many closed-loop trials whose parameters are drawn from factors, each trial a pure function of
(campaign seed, trial index).

A campaign is a TOML file (or the same mapping from Python / CLI options)::

    kind = "push"                 # push | robustness | sweep
    seed = 0
    trials = 1000                 # sweep: points × trials_per_point

    [scenario]                    # options of the walk every trial runs (wbc sim walk's, see SCENARIO_KEYS)
    robot = "talos"
    steps = 8
    step_length = 0.25
    step_duration = 0.6
    first_side = "random"         # the foot that swings first: left | right | random (drawn per trial)
    contact_events = false        # contacts follow the measured events (wbc sim walk --contact-events; estimated)

    [factors]                     # what varies from trial to trial
    force = [300.0, 500.0]        # [lo, hi]: uniform; a number: fixed; {values = [...]}: uniform choice
    direction_deg = [0.0, 360.0]
    phase = [0.0, 1.0]            # push start, fraction of the walking steps
    push_duration = 0.1

    [sweep]                       # kind = "sweep" only
    method = "grid"               # grid | random
    points = 200
    trials_per_point = 5
    [sweep.params]                # controller / gait options swept, [lo, hi] each
    k_xi = [1.0, 6.0]
    k_i = [0.0, 3.0]

    [metrics]
    keep = ["walked_distance_m", "max_stance_slip_m"]   # summary keys kept per trial (default: every scalar)

Draws use ``numpy.random.default_rng([seed, index])`` (a trial's parameters do not depend on any other trial);
a sweep draws the pushes of repeat ``r`` from ``[seed, r]`` so every point meets the same pushes (common random
numbers) and its point from the grid (``grid``: a ``ceil(sqrt)`` × … lattice of ``points`` points in row-major
order over the params' boxes) or from ``[seed, 2**31 + p]`` (``random``). With ``first_side = "random"`` (the
default) the first swing foot is drawn from ``[seed, index, 1]`` (a stream of its own: the factors' draws are those
of a campaign without it): with a fixed first foot, the push window holds more of one foot's single supports than of
the other's, and the lateral pushes towards the stance foot fall more on one side (records/40).
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from wbc.exceptions import InvalidInputError

__all__ = ["CampaignSpec", "load_spec", "KINDS", "SCENARIO_KEYS", "FACTOR_KEYS", "trial_params", "default_spec"]

KINDS = ("push", "robustness", "sweep")

#: Scenario options (``wbc sim walk``'s): name → (type, default).
SCENARIO_KEYS = {
    "robot": (str, "talos"), "steps": (int, 8), "step_length": (float, 0.25), "step_duration": (float, 0.6),
    "step_adjust": (bool, True), "solver": (str, "fast"), "sole_margin": (float, None),
    "state": (str, "estimated"), "zmp_feedback": (float, None), "plant": (str, "realistic"),
    "first_side": (str, "random"), "contact_events": (bool, False),
}

#: Factors a trial may vary: name → (unit, valid range). Push factors, then plant ≠ model (robustness).
FACTOR_KEYS = {
    "force": ("N", (0.0, 5000.0)), "direction_deg": ("deg, 0 = +x forward, 90 = +y left", (-360.0, 720.0)),
    "phase": ("fraction of the walking steps", (0.0, 1.0)), "push_duration": ("s", (0.0, 2.0)),
    "mass_error": ("% (uniform ± per link)", (0.0, 50.0)), "payload": ("kg", (0.0, 50.0)),
    "friction": ("N·m", (0.0, 20.0)), "armature": ("kg·m²", (0.0, 5.0)), "delay": ("ticks", (0.0, 50.0)),
    "q_noise_deg": ("deg", (0.0, 5.0)), "v_noise": ("rad/s", (0.0, 1.0)),
    "ground_timeconst": ("s, the ground contacts' normal time constant (smaller: stiffer)", (0.004, 0.1)),
}

#: Sweepable options: DCM stabilizer gains (``wbc.gait.stabilizer.DcmStabilizer``) and walk options.
SWEEP_KEYS = {"k_xi": (0.0, 50.0), "k_i": (0.0, 50.0), "k_z": (0.0, 10.0), "cop_margin": (0.0, 0.05),
              "cmp_offset": (0.0, 0.1), "adjust_dead_band": (0.0, 0.2), "impact_window": (0.0, 0.2)}

_DEFAULT_FACTORS = {
    "push": {"force": [300.0, 500.0], "direction_deg": [0.0, 360.0], "phase": [0.0, 1.0], "push_duration": 0.1},
    "robustness": {"mass_error": [0.0, 10.0], "friction": [0.0, 2.0], "armature": [0.0, 0.1],
                   "delay": {"values": [0, 1, 2]}, "q_noise_deg": [0.0, 0.1], "v_noise": [0.0, 0.02]},
    "sweep": {"force": [300.0, 500.0], "direction_deg": [0.0, 360.0], "phase": [0.0, 1.0], "push_duration": 0.1},
}


@dataclass
class CampaignSpec:
    """A validated campaign (module docstring).

    Attributes:
        kind: one of :data:`KINDS`. seed: campaign seed (int ≥ 0). trials: number of trials (≥ 1; a sweep:
            ``points × trials_per_point``).
        scenario: the walk options (:data:`SCENARIO_KEYS`). factors: name → fixed value, ``(lo, hi)`` or
            ``{"values": [...]}`` (:data:`FACTOR_KEYS`).
        sweep: ``{"method", "points", "trials_per_point", "params": {name: (lo, hi)}}`` for kind ``sweep``.
        keep: summary keys kept per trial (empty: every scalar key).
    """

    kind: str = "push"
    seed: int = 0
    trials: int = 20
    scenario: dict = field(default_factory=dict)
    factors: dict = field(default_factory=dict)
    sweep: dict = field(default_factory=dict)
    keep: list = field(default_factory=list)

    def as_dict(self) -> dict:
        """The spec as a plain mapping (TOML/JSON-able; what ``load_spec`` reads)."""
        d = {"kind": self.kind, "seed": self.seed, "trials": self.trials, "scenario": dict(self.scenario),
             "factors": {k: (list(v) if isinstance(v, tuple) else v) for k, v in self.factors.items()},
             "metrics": {"keep": list(self.keep)}}
        if self.sweep:
            d["sweep"] = {**self.sweep, "params": {k: list(v) for k, v in self.sweep["params"].items()}}
        return d


def default_spec(kind: str = "push", **overrides) -> CampaignSpec:
    """The default campaign of ``kind`` with top-level ``overrides`` (validated by :func:`load_spec`)."""
    d = {"kind": kind, "factors": dict(_DEFAULT_FACTORS.get(kind, {}))}
    if kind == "sweep":
        d["sweep"] = {"method": "grid", "points": 200, "trials_per_point": 5,
                      "params": {"k_xi": [1.0, 6.0], "k_i": [0.0, 3.0]}}
    d.update(overrides)
    return load_spec(d)


def load_spec(source) -> CampaignSpec:
    """Read and validate a campaign from a TOML file path or a mapping.

    Args:
        source: ``str``/``Path`` of a TOML file, or a dict with the same keys (module docstring).

    Returns:
        :class:`CampaignSpec` with defaults filled in.

    Raises:
        InvalidInputError: unreadable file, malformed TOML, an unknown key (named, with the valid ones), a value of
            the wrong type, out of range or not finite.
    """
    if isinstance(source, (str, Path)):
        path = Path(source)
        try:
            raw = tomllib.loads(path.read_text())
        except OSError as e:
            raise InvalidInputError(f"campaign file {path}: cannot be read ({e.strerror or e})") from None
        except tomllib.TOMLDecodeError as e:
            raise InvalidInputError(f"campaign file {path}: malformed TOML ({e})") from None
        where = str(path)
    elif isinstance(source, dict):
        raw, where = source, "campaign"
    else:
        raise InvalidInputError(f"a campaign is a TOML file path or a mapping, got {type(source).__name__}")
    _only(raw, {"kind", "seed", "trials", "scenario", "factors", "sweep", "metrics"}, where)
    kind = raw.get("kind", "push")
    if kind not in KINDS:
        raise InvalidInputError(f"{where}: kind must be one of {', '.join(KINDS)}, got {kind!r}")
    seed = _int(raw.get("seed", 0), f"{where}: seed", 0, 2**62)
    scenario = {k: d for k, (_, d) in SCENARIO_KEYS.items()}
    sc = raw.get("scenario", {})
    _table(sc, f"{where}: [scenario]")
    _only(sc, set(SCENARIO_KEYS), f"{where}: [scenario]")
    for k, v in sc.items():
        typ = SCENARIO_KEYS[k][0]
        scenario[k] = _typed(v, typ, f"{where}: scenario.{k}")
    if scenario["steps"] < 1 or scenario["steps"] > 200:
        raise InvalidInputError(f"{where}: scenario.steps must be in [1, 200], got {scenario['steps']}")
    if not 0.2 < scenario["step_duration"] <= 5.0:
        raise InvalidInputError(f"{where}: scenario.step_duration must be in (0.2, 5] s, got {scenario['step_duration']}")
    if scenario["plant"] not in ("realistic", "ideal"):
        raise InvalidInputError(f"{where}: scenario.plant must be realistic or ideal, got {scenario['plant']!r}")
    if scenario["first_side"] not in ("left", "right", "random"):
        raise InvalidInputError(f"{where}: scenario.first_side must be left, right or random, got "
                                f"{scenario['first_side']!r}")
    if scenario["state"] not in ("estimated", "ground-truth"):
        raise InvalidInputError(f"{where}: scenario.state must be estimated or ground-truth, got {scenario['state']!r}")
    if scenario["contact_events"] and scenario["state"] != "estimated":
        raise InvalidInputError(f"{where}: scenario.contact_events reads the ankle F/T of scenario.state = estimated, "
                                f"got {scenario['state']!r}")
    if not -1.0 <= scenario["step_length"] <= 1.0:
        raise InvalidInputError(f"{where}: scenario.step_length must be in [-1, 1] m, got {scenario['step_length']}")
    factors = {}
    fs = raw.get("factors", _DEFAULT_FACTORS[kind] if "factors" not in raw else {})
    _table(fs, f"{where}: [factors]")
    _only(fs, set(FACTOR_KEYS), f"{where}: [factors]")
    for k, v in fs.items():
        factors[k] = _factor(v, k, f"{where}: factors.{k}")
    sweep = {}
    if kind == "sweep":
        sw = raw.get("sweep")
        if sw is None:
            raise InvalidInputError(f"{where}: kind 'sweep' needs a [sweep] table with params")
        _table(sw, f"{where}: [sweep]")
        _only(sw, {"method", "points", "trials_per_point", "params"}, f"{where}: [sweep]")
        method = sw.get("method", "grid")
        if method not in ("grid", "random"):
            raise InvalidInputError(f"{where}: sweep.method must be grid or random, got {method!r}")
        params = sw.get("params", {})
        _table(params, f"{where}: [sweep.params]")
        if not params:
            raise InvalidInputError(f"{where}: [sweep.params] names no parameter (valid: {', '.join(SWEEP_KEYS)})")
        _only(params, set(SWEEP_KEYS), f"{where}: [sweep.params]")
        boxes = {}
        for k, v in params.items():
            lo, hi = _range(v, f"{where}: sweep.params.{k}", *SWEEP_KEYS[k])
            boxes[k] = (lo, hi)
        sweep = {"method": method, "points": _int(sw.get("points", 200), f"{where}: sweep.points", 1, 10**6),
                 "trials_per_point": _int(sw.get("trials_per_point", 5), f"{where}: sweep.trials_per_point", 1,
                                          10**4),
                 "params": boxes}
        trials = sweep["points"] * sweep["trials_per_point"]
        if "trials" in raw and _int(raw["trials"], f"{where}: trials", 1, 10**7) != trials:
            raise InvalidInputError(f"{where}: a sweep has points × trials_per_point = {trials} trials; "
                                    f"trials = {raw['trials']} disagrees (leave it out)")
    else:
        trials = _int(raw.get("trials", 20), f"{where}: trials", 1, 10**7)
    metrics = raw.get("metrics", {})
    _table(metrics, f"{where}: [metrics]")
    _only(metrics, {"keep"}, f"{where}: [metrics]")
    keep = metrics.get("keep", [])
    if not (isinstance(keep, list) and all(isinstance(k, str) for k in keep)):
        raise InvalidInputError(f"{where}: metrics.keep must be a list of summary key names, got {keep!r}")
    return CampaignSpec(kind=kind, seed=seed, trials=trials, scenario=scenario, factors=factors, sweep=sweep,
                        keep=list(keep))


def trial_params(spec: CampaignSpec, index: int) -> dict:
    """Parameters of trial ``index`` (0 ≤ index < ``spec.trials``): a pure function of (seed, index).

    Returns:
        ``{"trial": index, <factor>: value, ..., "first_side": "left" | "right"}``, plus ``"point"``, ``"repeat"``
        and the swept params for a sweep.

    Raises:
        InvalidInputError: ``index`` out of range.
    """
    if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or not 0 <= index < spec.trials:
        raise InvalidInputError(f"trial index must be an integer in [0, {spec.trials}), got {index!r}")
    index = int(index)
    out = {"trial": index}
    draw_index = index
    if spec.kind == "sweep":
        per = spec.sweep["trials_per_point"]
        point, repeat = divmod(index, per)
        out["point"], out["repeat"] = point, repeat
        draw_index = repeat  # common random numbers: every point meets the same pushes
        out.update(_sweep_point(spec, point))
    rng = np.random.default_rng([spec.seed, draw_index])
    for name in sorted(spec.factors):  # fixed order: a trial's draws do not depend on the spec's key order
        f = spec.factors[name]
        if isinstance(f, tuple):
            out[name] = float(rng.uniform(f[0], f[1]))
        elif isinstance(f, dict):
            vals = f["values"]
            out[name] = vals[int(rng.integers(len(vals)))]
        else:
            out[name] = f
    side = spec.scenario.get("first_side", "random")
    if side == "random":  # a stream of its own (module docstring)
        side = ("left", "right")[int(np.random.default_rng([spec.seed, draw_index, 1]).integers(2))]
    out["first_side"] = side
    return out


def _sweep_point(spec: CampaignSpec, point: int) -> dict:
    params = spec.sweep["params"]
    names = sorted(params)
    n = spec.sweep["points"]
    if spec.sweep["method"] == "random":
        rng = np.random.default_rng([spec.seed, 2**31 + point])
        return {k: float(rng.uniform(*params[k])) for k in names}
    # grid: per-dimension counts whose product is ≥ points, as even as possible; row-major
    dims = len(names)
    base = max(1, int(math.floor(n ** (1.0 / dims) + 1e-9)))
    counts = [base] * dims
    i = 0
    while math.prod(counts) < n:
        counts[i % dims] += 1
        i += 1
    idx = np.unravel_index(point, counts)
    out = {}
    for k, c, j in zip(names, counts, idx):
        lo, hi = params[k]
        out[k] = float(lo if c == 1 else lo + (hi - lo) * j / (c - 1))
    return out


# -- validation helpers --------------------------------------------------------------------------------------

def _only(table: dict, valid: set, where: str) -> None:
    bad = sorted(set(table) - valid)
    if bad:
        raise InvalidInputError(f"{where}: unknown key {bad[0]!r} (valid: {', '.join(sorted(valid))})")


def _table(v, where: str) -> None:
    if not isinstance(v, dict):
        raise InvalidInputError(f"{where} must be a table, got {type(v).__name__}")


def _int(v, where: str, lo: int, hi: int) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= hi:
        raise InvalidInputError(f"{where} must be an integer in [{lo}, {hi}], got {v!r}")
    return int(v)


def _typed(v, typ, where: str):
    if typ is float:
        if v is None:
            return None
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise InvalidInputError(f"{where} must be a finite number, got {v!r}")
        return float(v)
    if typ is int:
        return _int(v, where, -10**9, 10**9)
    if not isinstance(v, typ):
        raise InvalidInputError(f"{where} must be a {typ.__name__}, got {v!r}")
    return v


def _range(v, where: str, lo: float, hi: float) -> tuple:
    if not (isinstance(v, (list, tuple)) and len(v) == 2):
        raise InvalidInputError(f"{where} must be [lo, hi], got {v!r}")
    a, b = (_typed(x, float, where) for x in v)
    if not lo <= a <= b <= hi:
        raise InvalidInputError(f"{where} must satisfy {lo} ≤ lo ≤ hi ≤ {hi}, got [{a}, {b}]")
    return a, b


def _factor(v, name: str, where: str):
    unit, (lo, hi) = FACTOR_KEYS[name]
    if isinstance(v, dict):
        _only(v, {"values"}, where)
        vals = v.get("values")
        if not (isinstance(vals, list) and vals):
            raise InvalidInputError(f"{where}: values must be a non-empty list")
        out = []
        for x in vals:
            x = _typed(x, float, where)
            if not lo <= x <= hi:
                raise InvalidInputError(f"{where}: value {x} outside [{lo}, {hi}] ({unit})")
            out.append(x)
        return {"values": out}
    if isinstance(v, (list, tuple)):
        return _range(v, f"{where} ({unit})", lo, hi)
    x = _typed(v, float, where)
    if not lo <= x <= hi:
        raise InvalidInputError(f"{where} = {x} outside [{lo}, {hi}] ({unit})")
    return x
