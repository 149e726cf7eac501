"""DDS readers and writers that ROS 2's default RMW matches: endpoints announced without XTypes type information.

Fast DDS 3 (ROS 2 Kilted's ``rmw_fastrtps_cpp``, on its defaults) announces XTypes type information with every
reader and writer and answers type-lookup requests with its type objects. Cyclone DDS matches two endpoints that
both carry type information only once it has resolved both types (XTypes 1.3 §7.6.3.4.2; ``ddsi_qos_match_mask_p``
of cyclonedds 11); the type objects of Fast DDS 3.2.3 for ``sensor_msgs/JointState``, ``nav_msgs/Odometry``,
``tf2_msgs/TFMessage`` and ``action_msgs/GoalStatusArray`` are rejected by cyclonedds 11.0.1 (``ddsi_xt_type_init_impl
with invalid type object``, a ``PLAIN_SEQUENCE_SMALL`` identifier), so those endpoints never match and no sample
flows, although the Fast DDS side reports the match. When either endpoint carries no type information the type
names decide (the same clause), which is how ``rmw_cyclonedds_cpp`` interoperates with Fast DDS.

The Python binding of cyclonedds 11.0.1 always gives a topic's sertype its type information (it builds the
topic's serializer from it). :func:`without_type_information` hides it while an endpoint is created: the endpoint
then has no type identifiers, announces none and matches by type name; the topic keeps its type information
(restored on leaving), so later topics of the same type are created as usual. The field it clears is the
``typeinfo_ser_sz`` member of the binding's ``ddspy_sertype`` (``clayer/pysertype.c``), found by its content (the
pointer and size of the type's own serialized TypeInformation), never by a fixed offset; where it is not found
(another cyclonedds build) the endpoint is created with type information and a ``RuntimeWarning`` says that
Fast DDS 3 peers will not receive its samples.

Services are another matter (:func:`services_notice`): rmw_fastrtps takes a reply only when the reply's inline QoS
names the request's sample identity (writer GUID and sequence number); the Python binding neither reports a
received sample's sequence number nor writes a related sample identity, so wbc's DDS services answer the
rmw_cyclonedds convention (request id in the payload) only.
"""

from __future__ import annotations

import contextlib
import ctypes
import threading
import warnings

__all__ = ["writer", "reader", "without_type_information", "services_notice", "SERTYPE_SCAN_BYTES"]

#: How far into the sertype the type-information field is searched (bytes). It sits at 96 in cyclonedds 11.0.1,
#: followed in the same allocation by the type map and the serializer's descriptor; the search stops there.
SERTYPE_SCAN_BYTES = 256
_lock = threading.Lock()


def _serialized_type_information(data_type) -> bytes:
    """The XTypes TypeInformation of the IDL type ``data_type`` as the binding hands it to Cyclone (XCDR2, little
    endian, without the encapsulation header)."""
    from cyclonedds.idl import Endianness

    idl = data_type.__idl__
    idl.fill_type_data()
    return idl.get_type_info().serialize(endianness=Endianness.Little, use_version_2=True)[4:]


def _typeinfo_size_field(topic):
    """The ``typeinfo_ser_sz`` field (a ``ctypes.c_uint32`` over Cyclone's memory) of ``topic``'s sertype, or None
    where no (pointer, size) pair holding the type's serialized TypeInformation is found."""
    from wbc.ros2.handles import sertype_address

    info = _serialized_type_information(topic.data_type)
    base = sertype_address(topic)
    if not base or not info:
        return None
    step = ctypes.sizeof(ctypes.c_void_p)
    for off in range(0, SERTYPE_SCAN_BYTES, step):
        ptr = ctypes.c_void_p.from_address(base + off).value
        size = ctypes.c_uint32.from_address(base + off + step)
        if ptr and ptr % step == 0 and size.value == len(info) and ctypes.string_at(ptr, size.value) == info:
            return size
    return None


@contextlib.contextmanager
def without_type_information(topic):
    """Within the block, endpoints created on the cyclonedds ``topic`` carry no XTypes type information (see the
    module docstring); the topic's own is restored on leaving."""
    with _lock:
        field = _typeinfo_size_field(topic)
        if field is None:
            warnings.warn(f"DDS: cannot hide the type information of {topic.get_type_name()} in this cyclonedds "
                          "build (wbc measured 11.0.1); Fast DDS 3 (ROS 2 Kilted) readers will not match this "
                          "endpoint", RuntimeWarning, stacklevel=3)
            yield
            return
        size = field.value
        field.value = 0
        try:
            yield
        finally:
            field.value = size


def writer(part, topic: str, data_type, qos):
    """A ``cyclonedds.pub.DataWriter`` of the IDL type ``data_type`` on the DDS topic ``topic`` (e.g.
    ``rt/joint_states``), ``qos`` for topic and writer, announced without type information."""
    from cyclonedds.pub import DataWriter
    from cyclonedds.topic import Topic

    t = Topic(part, topic, data_type, qos=qos)
    with without_type_information(t):
        return DataWriter(part, t, qos=qos)


def reader(part, topic: str, data_type, qos):
    """A ``cyclonedds.sub.DataReader``, otherwise as :func:`writer`."""
    from cyclonedds.sub import DataReader
    from cyclonedds.topic import Topic

    t = Topic(part, topic, data_type, qos=qos)
    with without_type_information(t):
        return DataReader(part, t, qos=qos)


def services_notice(node_name: str = "wbc_node") -> str:
    """The one line a DDS-backend node prints at start-up: what answers which ROS 2 clients, and the way to the
    rclpy backend for the default RMW (Fast DDS)."""
    return (f"DDS backend: topics and the ROS graph (/{node_name} in `ros2 node list`) work with every RMW; the "
            f"services and actions (/reset_robot, /{node_name}/*_parameters, navigate_to_pose) answer only "
            "rmw_cyclonedds_cpp clients (RMW_IMPLEMENTATION=rmw_cyclonedds_cpp); for Fast DDS clients, the default "
            "RMW of Jazzy and Kilted, use the rclpy backend: source a ROS 2 install (or pip install the ROS 2 "
            "wheels, ros-kilted-rclpy[fastrtps]) and run with --backend rclpy")
