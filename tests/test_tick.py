"""The routes of a tick (``wbc.tick``): every tick of both controllers names its route, and the routes actually
taken over short fuzz samples and walks are the declared ones.

Route-count scenarios (module fixture ``taken``, about 30 s):

* kinematic: ``benchmarks/fuzz.py``'s chunk, seed 5, 300 ticks of 50-tick episodes, half of them started with leg
  joints past their limits (absurd and 1e6 m hand targets among the draws: infeasible strict levels), and
  ``wbc walk --steps 2`` (Talos, its JSON summary and npz log);
* inverse dynamics: ``benchmarks/fuzz_id.py``'s chunk, seed 4, 200 ticks with the compiled tick and 100 with
  DAQP (seed 4 draws a foot unloaded to 0 N under a CoM far off the sole: relaxed and failed ticks), and a
  two-step ID walk in MuJoCo (Talos, the options of ``wbc sim walk``) through the Python API.

The declared sets are written here, not imported from the code under test.
"""

from __future__ import annotations

import json
import sys
import warnings
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from wbc.exceptions import InvalidInputError
from wbc.tick import TickPath, count_paths

KINEMATIC = {"compiled", "general", "levels", "fallback"}
INVERSE_DYNAMICS = {"kernel", "general", "relaxed", "fallback"}
BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


@pytest.mark.parametrize("text, fields", [
    ("compiled", ("compiled", "", "", False, False)),
    ("compiled+daqp", ("compiled", "daqp", "", False, False)),
    ("general:daqp+return_rate+budget", ("general", "daqp", "", True, True)),
    ("levels+budget", ("levels", "", "", False, True)),
    ("fallback:contacts_held", ("fallback", "", "contacts_held", False, False)),
    ("kernel", ("kernel", "", "", False, False)),
    ("relaxed:fast", ("relaxed", "fast", "", False, False)),
    ("fallback:gravity", ("fallback", "", "gravity", False, False)),
])
def test_a_path_reads_back_from_its_string_form(text, fields):
    p = TickPath.parse(text)
    assert (p.route, p.solver, p.fallback, p.return_rate, p.budget) == fields
    assert str(p) == text and f"{p}" == text and p == text and hash(p) == hash(text)
    assert TickPath(*fields) == p


@pytest.mark.parametrize("bad", ["", "solved", "general:daqp+fast", "fallback", 3])
def test_a_bad_path_raises_a_typed_error(bad):
    with pytest.raises(InvalidInputError):
        TickPath.parse(bad)


def test_a_route_without_its_kind_or_with_a_foreign_one_is_refused():
    with pytest.raises(InvalidInputError, match="fallback"):
        TickPath("fallback")
    with pytest.raises(InvalidInputError, match="fallback"):
        TickPath("general", "daqp", fallback="hold")
    with pytest.raises(InvalidInputError, match="valid"):
        TickPath("rescue")


def test_count_paths_sums_routes_over_qualifiers():
    out = count_paths(["general:daqp", "general:daqp+return_rate", "levels", TickPath("levels"), ""])
    assert out == {"ticks_per_route": {"general": 2, "levels": 2},
                   "ticks_per_path": {"levels": 2, "general:daqp": 1, "general:daqp+return_rate": 1}}


def test_both_controllers_return_a_tick_result_with_a_path(robots):
    """One tick of each controller (Talos standing): the result derives from ``TickResultBase`` and names its
    route as a ``TickPath`` of its level; a strict level moves the kinematic tick to the ``levels`` route."""
    from conftest import standing_controller
    from wbc.configuration import Configuration
    from wbc.dynamics.balance import IDBalanceController
    from wbc.tasks import PostureTask
    from wbc.tick import TickResultBase

    robot = robots("talos")
    config = Configuration(robot)
    ctrl, _ = standing_controller(robot, config)
    res = ctrl.solve(config, 0.002)
    assert isinstance(res, TickResultBase) and isinstance(res.path, TickPath) and res.ok
    assert res.path.route in KINEMATIC and res.path.fallback == ""
    ctrl.add_task(PostureTask(robot), level=0)
    res = ctrl.solve(config, 0.002)
    assert res.ok and res.path == TickPath("levels")

    idc = IDBalanceController(robot, dt=0.002)
    idc.reset(robot.q_ref)
    cmd = idc.solve(robot.q_ref, np.zeros(robot.nv))
    assert isinstance(cmd, TickResultBase) and isinstance(cmd.path, TickPath) and cmd.ok
    assert cmd.path.route in INVERSE_DYNAMICS and cmd.path.route != "fallback"


@pytest.fixture(scope="module")
def taken(tmp_path_factory) -> dict[str, dict[str, Counter]]:
    """{level: {scenario: Counter(path string → ticks)}} over the scenarios of the module docstring."""
    sys.path.insert(0, str(BENCHMARKS))
    import fuzz
    import fuzz_id
    from wbc.cli import main
    from wbc.robot import load_robot
    from wbc.sim.mujoco_model import build_mujoco_model
    from wbc.sim.physics_scenarios import walk_options_for
    from wbc.sim.scenarios import make_controller, run_scenario
    from wbc.sim.walk import WalkScenario

    def no_freeze(key):  # the scripts' gc.freeze is for long runs, not for the test process
        return None

    mp = pytest.MonkeyPatch()
    mp.setattr(fuzz, "freeze_after_first", no_freeze)
    mp.setattr(fuzz_id, "freeze_after_first", no_freeze)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            robots, limits = fuzz.load_robots()
            kin_fuzz = fuzz.run_chunk(robots, limits, 300, 50, 5, past_limits=0.5)["paths"]
            id_fuzz = Counter(fuzz_id.run_chunk(200, 4)["paths"])
            id_fuzz.update(fuzz_id.run_chunk(100, 4, solver="daqp")["paths"])
    finally:
        mp.undo()

    folder = tmp_path_factory.mktemp("routes")
    js, log = folder / "walk.json", folder / "walk.npz"
    assert main(["walk", "--steps", "2", "--quiet", "--json", str(js), "--log", str(log)]) == 0
    summary = json.loads(js.read_text())
    with np.load(log) as z:
        logged = Counter(str(p) for p in z["path"])
    assert summary["ticks_per_path"] == dict(logged) and sum(logged.values()) == summary["ticks"]
    assert summary["ticks_per_route"] == count_paths(logged.elements())["ticks_per_route"]

    robot = load_robot("talos")
    sim = build_mujoco_model(robot)
    controller = make_controller(robot, "id", dt=sim.timestep, **walk_options_for(robot))
    run, s = run_scenario(sim, controller, WalkScenario(2, 0.2, 0.6))
    sim_logged = Counter(str(p) for p in run.path)
    assert s["ticks_per_path"] == dict(sim_logged) and sum(sim_logged.values()) == len(run.t)
    assert s["tick_budget"]["paths"] == s["ticks_per_path"] and s["tick_budget"]["routes"] == s["ticks_per_route"]

    return {"kinematic": {"fuzz": Counter(kin_fuzz), "wbc walk": logged},
            "inverse dynamics": {"fuzz_id": id_fuzz, "sim walk": sim_logged}}


@pytest.mark.parametrize("level, declared", [("kinematic", KINEMATIC), ("inverse dynamics", INVERSE_DYNAMICS)])
def test_every_tick_takes_a_declared_route(taken, level, declared):
    """Each tick's path parses, its route is one of the level's four, and the scenarios take at least three of
    them (the fallback among them). The table printed is the one in docs/architecture.md's route counts."""
    per_route: Counter = Counter()
    print(f"\n{level}: route, ticks per scenario")
    for scenario, paths in taken[level].items():
        routes = count_paths(paths.elements())["ticks_per_route"]
        per_route.update(routes)
        print(f"  {scenario}: {routes}; paths {dict(paths)}")
    unnamed = set(per_route) - declared
    assert not unnamed, f"{level} ticks took routes outside {sorted(declared)}: {sorted(unnamed)}"
    assert len(per_route) >= 3 and "fallback" in per_route, dict(per_route)
