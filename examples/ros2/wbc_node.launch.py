"""Launch wbc's controller node in a ROS 2 system: ``ros2 launch examples/ros2/wbc_node.launch.py``.

wbc is a pip package, not an ament one, so the node is started as a process (``wbc ros2 node``) of the Python in
which wbc is installed. With a sourced ROS 2 that Python sees rclpy and the node is a real ROS 2 node on your RMW
(``backend:=rclpy``; ``auto`` picks it). Arguments (``name:=value``):

  robot        catalog name or robot file (default humanoid15)
  backend      auto | rclpy | dds (default auto)
  time         real | sim (default real; sim publishes /clock: give the other nodes use_sim_time:=true)
  rate         /joint_states, /tf, /odom rate, Hz (default 50)
  sim          true: the MuJoCo closed loop with the inverse-dynamics controller (default false)
  python       the interpreter with wbc installed (default python3)

RViz2 with wbc's display config comes up beside it with ``rviz:=true``.
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PythonExpression

ARGUMENTS = {"robot": "humanoid15", "backend": "auto", "time": "real", "rate": "50", "sim": "false",
             "python": "python3", "rviz": "false"}


def generate_launch_description():
    arg = LaunchConfiguration
    node = ExecuteProcess(
        cmd=[arg("python"), "-m", "wbc", "ros2", "node", "--robot", arg("robot"), "--backend", arg("backend"),
             "--time", arg("time"), "--rate", arg("rate"),
             PythonExpression(["'--sim' if '", arg("sim"), "' == 'true' else '--tf=all'"])],
        name="wbc_node", output="screen", sigterm_timeout="10")
    rviz = ExecuteProcess(cmd=["rviz2", "-d", "docs/pages/how-to/rviz/wbc.rviz"], output="screen",
                          condition=IfCondition(arg("rviz")))
    return LaunchDescription([DeclareLaunchArgument(k, default_value=v) for k, v in ARGUMENTS.items()]
                             + [node, rviz])
