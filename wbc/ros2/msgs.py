"""ROS 2 message types declared in cyclonedds IDL with rosidl's DDS layout, and REP-2011 type hashes.

Each class is a ``@final`` struct named ``<pkg>::msg::dds_::<Msg>_`` with the fields in rosidl's order, so its
XCDR1 serialization is ROS 2's CDR (byte-identical to ``rosbags``' ROS 2 serializer, tested). Service types for
``std_srvs/srv/Trigger`` carry rmw_cyclonedds' 16-byte request header (client guid, sequence number) in front of
the fields, as ``rmw_cyclonedds_cpp`` puts it on the wire.
"""


import hashlib
import json
import types
from dataclasses import dataclass, field

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.annotations import final
from cyclonedds.idl.types import float64, int32, int64, sequence, uint8, uint32, uint64

__all__ = [
    "Time", "Header", "JointState", "Vector3", "Quaternion", "Transform", "TransformStamped", "TFMessage",
    "String", "TriggerRequest", "TriggerReply", "rihs01", "TYPE_DESCRIPTIONS", "to_bytes",
]


def _struct(name: str, typename: str, doc: str, /, **fields) -> type:
    """A ``@final`` IDL struct dataclass ``name`` with DDS type ``typename``; ``fields``: field name →
    ``(IDL type, default)`` in rosidl's order, a class or ``list`` as default meaning a fresh instance each."""
    namespace = {"__annotations__": {k: t for k, (t, _) in fields.items()}, "__doc__": doc, "__module__": __name__,
                 "__qualname__": name}
    for k, (_, default) in fields.items():
        namespace[k] = field(default_factory=default) if isinstance(default, type) else default
    cls = types.new_class(name, (IdlStruct,), {"typename": typename}, lambda ns: ns.update(namespace))
    return dataclass(final(cls))


Time = _struct("Time", "builtin_interfaces::msg::dds_::Time_",
               "builtin_interfaces/msg/Time: seconds and nanoseconds since the epoch.",
               sec=(int32, 0), nanosec=(uint32, 0))
Header = _struct("Header", "std_msgs::msg::dds_::Header_", "std_msgs/msg/Header: stamp and frame id.",
                 stamp=(Time, Time), frame_id=(str, ""))
JointState = _struct(
    "JointState", "sensor_msgs::msg::dds_::JointState_",
    "sensor_msgs/msg/JointState: names, positions (rad or m), velocities (rad/s), efforts (N·m).",
    header=(Header, Header), name=(sequence[str], list), position=(sequence[float64], list),
    velocity=(sequence[float64], list), effort=(sequence[float64], list))
Vector3 = _struct("Vector3", "geometry_msgs::msg::dds_::Vector3_", "geometry_msgs/msg/Vector3 (m).",
                  x=(float64, 0.0), y=(float64, 0.0), z=(float64, 0.0))
Quaternion = _struct("Quaternion", "geometry_msgs::msg::dds_::Quaternion_",
                     "geometry_msgs/msg/Quaternion (x, y, z, w; ROS default w = 1).",
                     x=(float64, 0.0), y=(float64, 0.0), z=(float64, 0.0), w=(float64, 1.0))
Transform = _struct("Transform", "geometry_msgs::msg::dds_::Transform_",
                    "geometry_msgs/msg/Transform: pose of the child frame in the parent frame.",
                    translation=(Vector3, Vector3), rotation=(Quaternion, Quaternion))
TransformStamped = _struct(
    "TransformStamped", "geometry_msgs::msg::dds_::TransformStamped_",
    "geometry_msgs/msg/TransformStamped: header.frame_id is the parent, child_frame_id the child.",
    header=(Header, Header), child_frame_id=(str, ""), transform=(Transform, Transform))
TFMessage = _struct("TFMessage", "tf2_msgs::msg::dds_::TFMessage_",
                    "tf2_msgs/msg/TFMessage: a list of stamped transforms (/tf, /tf_static).",
                    transforms=(sequence[TransformStamped], list))
String = _struct("String", "std_msgs::msg::dds_::String_",
                 "std_msgs/msg/String (e.g. /robot_description, the URDF text).", data=(str, ""))
TriggerRequest = _struct(
    "TriggerRequest", "std_srvs::srv::dds_::Trigger_Request_",
    "std_srvs/srv/Trigger request with rmw_cyclonedds' request header (client guid, sequence number).",
    client_guid=(uint64, 0), seq=(int64, 0), structure_needs_at_least_one_member=(uint8, 0))
TriggerReply = _struct(
    "TriggerReply", "std_srvs::srv::dds_::Trigger_Response_",
    "std_srvs/srv/Trigger response with rmw_cyclonedds' header echoing the request's guid and sequence.",
    client_guid=(uint64, 0), seq=(int64, 0), success=(bool, False), message=(str, ""))


def to_bytes(msg: IdlStruct) -> bytes:
    """ROS 2 CDR (XCDR1, little endian, with the 4-byte encapsulation header) of ``msg``, as rosbag2 stores it."""
    return msg.serialize(use_version_2=False)


# REP-2011 type descriptions: (field name, type id, nested type name). Type ids of
# type_description_interfaces/msg/FieldType: INT32 6, UINT32 7, DOUBLE 11, STRING 17, NESTED 1;
# an unbounded sequence adds 144.
_SEQ = 144
TYPE_DESCRIPTIONS: dict[str, list[tuple[str, int, str]]] = {
    "builtin_interfaces/msg/Time": [("sec", 6, ""), ("nanosec", 7, "")],
    "std_msgs/msg/Header": [("stamp", 1, "builtin_interfaces/msg/Time"), ("frame_id", 17, "")],
    "sensor_msgs/msg/JointState": [
        ("header", 1, "std_msgs/msg/Header"), ("name", 17 + _SEQ, ""), ("position", 11 + _SEQ, ""),
        ("velocity", 11 + _SEQ, ""), ("effort", 11 + _SEQ, ""),
    ],
    "std_msgs/msg/String": [("data", 17, "")],
    "geometry_msgs/msg/Vector3": [("x", 11, ""), ("y", 11, ""), ("z", 11, "")],
    "geometry_msgs/msg/Quaternion": [("x", 11, ""), ("y", 11, ""), ("z", 11, ""), ("w", 11, "")],
    "geometry_msgs/msg/Transform": [
        ("translation", 1, "geometry_msgs/msg/Vector3"), ("rotation", 1, "geometry_msgs/msg/Quaternion"),
    ],
    "geometry_msgs/msg/TransformStamped": [
        ("header", 1, "std_msgs/msg/Header"), ("child_frame_id", 17, ""),
        ("transform", 1, "geometry_msgs/msg/Transform"),
    ],
    "tf2_msgs/msg/TFMessage": [("transforms", 1 + _SEQ, "geometry_msgs/msg/TransformStamped")],
}


def _describe(name: str) -> dict:
    return {
        "type_name": name,
        "fields": [
            {"name": fname, "type": {"type_id": tid, "capacity": 0, "string_capacity": 0,
                                     "nested_type_name": nested}}
            for fname, tid, nested in TYPE_DESCRIPTIONS[name]
        ],
    }


def rihs01(type_name: str) -> str:
    """REP-2011 type hash ``RIHS01_<sha256>`` of a message in :data:`TYPE_DESCRIPTIONS`.

    The hash is SHA-256 over the JSON of ``{"type_description", "referenced_type_descriptions"}`` (fields reduced
    to name and type, referenced types sorted by name, Python ``json.dumps`` default separators), as rosidl's
    ``generate_type_hash`` computes it (REP-2011, "Hashing algorithm").

    Raises:
        KeyError: ``type_name`` is not one of :data:`TYPE_DESCRIPTIONS` (message lists the known ones).
    """
    if type_name not in TYPE_DESCRIPTIONS:
        raise KeyError(f"no type description for {type_name!r}; known: {sorted(TYPE_DESCRIPTIONS)}")
    refs: set[str] = set()
    todo = [type_name]
    while todo:
        for _, _, nested in TYPE_DESCRIPTIONS[todo.pop()]:
            if nested and nested not in refs:
                refs.add(nested)
                todo.append(nested)
    doc = {
        "type_description": _describe(type_name),
        "referenced_type_descriptions": [_describe(r) for r in sorted(refs)],
    }
    return "RIHS01_" + hashlib.sha256(json.dumps(doc).encode()).hexdigest()
