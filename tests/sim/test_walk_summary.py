"""A physics walk's summary: ``completed`` means the commanded motion was done — the run reached its end without a
fall *and* every planned step touched down — not merely that the run ended standing."""

from wbc.robot import load_robot
from wbc.sim.mujoco_model import build_mujoco_model
from wbc.sim.physics_scenarios import walk_options_for
from wbc.sim.scenarios import make_controller, run_scenario
from wbc.sim.walk import WalkScenario


class _LastTouchdownLost(WalkScenario):
    """The same walk, its switcher's last touch-down event removed before the summary: as if the last planned step
    never landed (a foot held up by an obstacle, a touch-down never detected) while the robot stood to the end."""

    def extra_summary(self, run) -> dict:
        events = self.switcher.events
        last = max(i for i, e in enumerate(events) if e[2] == "touchdown")
        del events[last]
        return super().extra_summary(run)


def _walk(scenario_type):
    robot = load_robot("humanoid15")
    sim = build_mujoco_model(robot)
    controller = make_controller(robot, "id", dt=sim.timestep, **walk_options_for(robot))
    return run_scenario(sim, controller, scenario_type(2, 0.1, 0.8))[1]


def test_a_walk_whose_last_step_never_landed_is_not_completed():
    whole = _walk(WalkScenario)
    assert not whole["fell"] and whole["touchdowns"] == 2 and whole["completed"] is True
    lost = _walk(_LastTouchdownLost)
    assert not lost["fell"] and lost["touchdowns"] == 1
    assert lost["completed"] is False
    assert any(c.startswith("walk completed (ran to its end without a fall, every planned step landed)")
               for c in lost["failed_criteria"]), lost["failed_criteria"]
