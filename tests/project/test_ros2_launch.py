"""examples/ros2/wbc_node.launch.py: the command line it starts is one `wbc ros2 node` accepts, for its defaults
and for the documented choices. ROS 2's `launch` package is not installable here, so the file runs against a stand-in
of the four launch names it uses that records the arguments and resolves each substitution to its value."""

import sys
import types
from pathlib import Path

import pytest

from wbc.cli import build_parser

LAUNCH = Path(__file__).resolve().parents[2] / "examples" / "ros2" / "wbc_node.launch.py"


def _launch_stub():
    class Config:
        def __init__(self, name):
            self.name = name

    class Expr:
        def __init__(self, parts):
            self.parts = parts

    class Recorded:
        def __init__(self, *a, **k):
            self.args, self.kwargs = a, k

    launch = types.ModuleType("launch")
    launch.LaunchDescription = Recorded
    actions = types.ModuleType("launch.actions")
    actions.DeclareLaunchArgument = actions.ExecuteProcess = Recorded
    conditions = types.ModuleType("launch.conditions")
    conditions.IfCondition = Recorded
    subs = types.ModuleType("launch.substitutions")
    subs.LaunchConfiguration, subs.PythonExpression = Config, Expr
    return {"launch": launch, "launch.actions": actions, "launch.conditions": conditions,
            "launch.substitutions": subs}, Config, Expr


@pytest.mark.parametrize("choices", [{}, {"backend": "rclpy", "time": "sim", "rate": "500", "sim": "true"},
                                     {"backend": "dds", "robot": "g1"}])
def test_the_launch_command_is_a_valid_wbc_node_command(monkeypatch, choices):
    modules, Config, Expr = _launch_stub()
    for name, module in modules.items():
        monkeypatch.setitem(sys.modules, name, module)
    ns = {"__name__": "wbc_node_launch"}
    exec(compile(LAUNCH.read_text(), str(LAUNCH), "exec"), ns)
    values = {**ns["ARGUMENTS"], **choices}

    def resolve(item):
        if isinstance(item, Config):
            return values[item.name]
        if isinstance(item, Expr):
            return str(eval("".join(resolve(p) for p in item.parts)))
        return item

    description = ns["generate_launch_description"]()
    actions = description.args[0]
    declared = {a.args[0]: a.kwargs["default_value"] for a in actions if "default_value" in a.kwargs}
    assert declared == ns["ARGUMENTS"]
    node = next(a for a in actions if a.kwargs.get("name") == "wbc_node")
    cmd = [resolve(c) for c in node.kwargs["cmd"]]
    assert cmd[:5] == [values["python"], "-m", "wbc", "ros2", "node"]
    args = build_parser().parse_args(cmd[3:])
    assert (args.robot, args.backend, args.time, args.rate, args.sim) == (
        values["robot"], values["backend"], values["time"], float(values["rate"]), values["sim"] == "true")
