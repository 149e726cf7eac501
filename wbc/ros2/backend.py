"""Which transport a ROS 2 command uses: ``rclpy`` (a real ROS 2 node) or ``dds`` (Cyclone DDS in ROS 2's format).

``auto`` picks rclpy when it imports with the message packages the node needs (a sourced ROS 2 install, or the
``ros-*`` wheels from the package index), else dds (the extra ``wbc[ros2]``). What each can do:
docs/pages/how-to/ros2-system.md.
"""

from __future__ import annotations

from wbc.exceptions import InvalidInputError

__all__ = ["BACKENDS", "resolve"]

#: The choices of ``--backend``.
BACKENDS = ("auto", "rclpy", "dds")


def resolve(choice: str) -> str:
    """``"rclpy"`` or ``"dds"`` for ``choice`` (one of :data:`BACKENDS`).

    Raises:
        InvalidInputError: ``choice`` is not one of :data:`BACKENDS`.
        wbc.ros2.Ros2UnavailableError: the chosen backend's packages do not import (``auto``: neither's).
    """
    from wbc.ros2 import Ros2UnavailableError, require
    from wbc.ros2.rclpy_node import rclpy_available

    if choice not in BACKENDS:
        raise InvalidInputError(f"ROS 2 backend {choice!r} is invalid: valid are {BACKENDS}")
    if choice == "rclpy" or (choice == "auto" and rclpy_available()):
        if not rclpy_available():
            raise Ros2UnavailableError("--backend rclpy needs rclpy and the ROS 2 message packages sensor_msgs, "
                                       "geometry_msgs, nav_msgs, std_srvs, rosgraph_msgs (source a ROS 2 install, "
                                       "or pip install the ros-* wheels); or use --backend dds")
        return "rclpy"
    require()
    return "dds"
