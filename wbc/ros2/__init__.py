"""ROS 2 interop without ROS 2: DDS traffic in ROS 2's wire format and rosbag2 recording (extra ``wbc[ros2]``).

wbc's core never imports this package's dependencies: ``cyclonedds`` (the DDS implementation ROS 2 Humble/Jazzy
ship as ``rmw_cyclonedds_cpp``) and ``rosbags`` (rosbag2 writer) are imported only by the submodules
:mod:`wbc.ros2.msgs`, :mod:`wbc.ros2.dds`, :mod:`wbc.ros2.publisher` and the command line :mod:`wbc.cli.ros2`.

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
                f"ROS 2 support needs the Python package {module!r}: pip install 'wbc[ros2]'"
            ) from exc
