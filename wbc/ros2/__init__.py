"""ROS 2 interop: a real ROS 2 node through rclpy, or DDS traffic in ROS 2's wire format without ROS 2, and rosbag2.

Two transports (:mod:`wbc.ros2.backend` chooses): **rclpy** (:mod:`wbc.ros2.rclpy_node`,
:mod:`wbc.ros2.rclpy_publisher`; needs a sourced ROS 2 or the ``ros-*`` wheels, and runs on the user's RMW) and
**dds** (extra ``wbc[ros2]``: :mod:`wbc.ros2.msgs`, :mod:`wbc.ros2.dds`, :mod:`wbc.ros2.publisher`,
:mod:`wbc.ros2.node`). The controller node's behaviour is written once in :mod:`wbc.ros2.node_core`.
wbc's core never imports either transport's dependencies: ``cyclonedds`` (the DDS implementation ROS 2 Humble/Jazzy
ship as ``rmw_cyclonedds_cpp``) and ``rosbags`` (rosbag2 writer), or ``rclpy``, are imported only by those
submodules and the command line :mod:`wbc.cli.ros2`.

ROS 2 conventions followed (ROS 2 design article "Topic and Service name mapping to DDS"): a topic ``/x`` is the
DDS topic ``rt/x``; message ``pkg/msg/M`` is the DDS type ``pkg::msg::dds_::M_`` (final struct, XCDR1); service
``/s`` uses ``rq/sRequest`` and ``rr/sReply``.
"""

from __future__ import annotations

from wbc.exceptions import WbcError

__all__ = ["Ros2UnavailableError", "require"]


class Ros2UnavailableError(WbcError, ImportError):
    """The optional extra ``wbc[ros2]`` (cyclonedds, rosbags, mcap) is not installed."""


def require() -> None:
    """Raise :class:`Ros2UnavailableError` unless cyclonedds and rosbags import.

    Raises:
        Ros2UnavailableError: names the missing module and the extra that provides it.
    """
    for module in ("cyclonedds", "rosbags"):
        try:
            __import__(module)
        except ImportError as exc:
            raise Ros2UnavailableError(
                f"ROS 2 support needs the Python package {module!r}: pip install -e \".[ros2]\" (from the wbc clone)"
            ) from exc
