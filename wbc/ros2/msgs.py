"""ROS 2 message types declared in cyclonedds IDL with rosidl's DDS layout, and REP-2011 type hashes.

Each class is a ``@final`` struct named ``<pkg>::msg::dds_::<Msg>_`` with the fields in rosidl's order, so its
XCDR1 serialization is ROS 2's CDR (byte-identical to ``rosbags``' ROS 2 serializer, tested). Service types
(``std_srvs/srv/Trigger``, the ``rcl_interfaces`` parameter services, an action's ``send_goal``, ``get_result`` and
``cancel_goal``) carry rmw_cyclonedds' 16-byte request header (client guid, sequence number) in front of the
fields, as ``rmw_cyclonedds_cpp`` puts it on the wire.

Actions (ROS 2 design article "Actions"; ``rcl_action`` names): action ``/a`` is the services
``/a/_action/send_goal`` (``<Action>_SendGoal``), ``/a/_action/get_result`` (``<Action>_GetResult``),
``/a/_action/cancel_goal`` (``action_msgs/srv/CancelGoal``) and the topics ``/a/_action/feedback``
(``<Action>_FeedbackMessage``) and ``/a/_action/status`` (``action_msgs/msg/GoalStatusArray``); the DDS type of
``pkg/action/A_SendGoal_Request`` is ``pkg::action::dds_::A_SendGoal_Request_``.
"""


import hashlib
import json
import types
import typing
from dataclasses import dataclass, field

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.annotations import final
from cyclonedds.idl.types import array, float32, float64, int8, int16, int32, int64, sequence, uint8, uint16, uint32, uint64

__all__ = [
    "Time", "Header", "JointState", "Vector3", "Quaternion", "Transform", "TransformStamped", "TFMessage",
    "String", "TriggerRequest", "TriggerReply", "Duration", "Point", "Pose", "PoseStamped", "Twist",
    "PoseWithCovariance", "TwistWithCovariance", "Odometry", "Clock", "UUID", "GoalInfo", "GoalStatus",
    "GoalStatusArray", "CancelGoalRequest", "CancelGoalReply", "NavigateToPoseGoal", "NavigateToPoseResult",
    "NavigateToPoseFeedback", "NavigateToPoseFeedbackMessage", "NavigateToPoseSendGoalRequest",
    "NavigateToPoseSendGoalReply", "NavigateToPoseGetResultRequest", "NavigateToPoseGetResultReply",
    "ParameterValue", "Parameter", "SetParametersResult", "FloatingPointRange", "IntegerRange", "ParameterDescriptor",
    "ListParametersResult", "GetParametersRequest", "GetParametersReply", "SetParametersRequest",
    "SetParametersReply", "SetParametersAtomicallyRequest", "SetParametersAtomicallyReply", "ListParametersRequest",
    "ListParametersReply", "DescribeParametersRequest", "DescribeParametersReply", "GetParameterTypesRequest",
    "GetParameterTypesReply", "Gid", "NodeEntitiesInfo", "ParticipantEntitiesInfo", "rihs01", "TYPE_DESCRIPTIONS",
    "to_bytes",
]


def _default(idl_type):
    """The ROS default of a field of ``idl_type``: 0, 0.0, False, "", an empty list, a zero-filled array, or a fresh
    nested struct (a class or a zero-argument function: called for each instance)."""
    if idl_type is str:
        return ""
    if idl_type is bool:
        return False
    if isinstance(idl_type, type):  # a nested struct
        return idl_type
    base, holder = typing.get_args(idl_type)
    if isinstance(holder, sequence):
        return list
    if isinstance(holder, array):
        item = _default(holder.subtype)
        return lambda: [item] * holder.length
    return base()  # int or float: 0 or 0.0


def _struct(name: str, ros_type: str, doc: str, /, **fields) -> type:
    """A ``@final`` IDL struct dataclass ``name`` for the ROS 2 type ``ros_type`` (``pkg/msg/Name``; DDS type
    ``pkg::msg::dds_::Name_``); ``fields``: field name → IDL type (default from :func:`_default`) or ``(IDL type,
    default)``, in rosidl's order, a class or ``list`` as default meaning a fresh instance each."""
    fields = {k: f if isinstance(f, tuple) else (f, _default(f)) for k, f in fields.items()}
    namespace = {"__annotations__": {k: t for k, (t, _) in fields.items()}, "__doc__": doc, "__module__": __name__,
                 "__qualname__": name}
    for k, (_, default) in fields.items():
        namespace[k] = field(default_factory=default) if callable(default) else default
    pkg, kind, base = ros_type.split("/")
    typename = f"{pkg}::{kind}::dds_::{base}_"
    cls = types.new_class(name, (IdlStruct,), {"typename": typename}, lambda ns: ns.update(namespace))
    return dataclass(final(cls))


def _service(name: str, ros_type: str, doc: str, /, **fields) -> type:
    """A service request/reply struct: rmw_cyclonedds' header (client guid, sequence number) then ``fields``."""
    return _struct(name, ros_type, doc + " (with rmw_cyclonedds' request header)", client_guid=uint64, seq=int64,
                   **fields)


Time = _struct("Time", "builtin_interfaces/msg/Time",
               "builtin_interfaces/msg/Time: seconds and nanoseconds since the epoch.", sec=int32, nanosec=uint32)
Header = _struct("Header", "std_msgs/msg/Header", "std_msgs/msg/Header: stamp and frame id.", stamp=Time, frame_id=str)
JointState = _struct("JointState", "sensor_msgs/msg/JointState",
                     "sensor_msgs/msg/JointState: names, positions (rad or m), velocities (rad/s), efforts (N·m).",
                     header=Header, name=sequence[str], position=sequence[float64], velocity=sequence[float64],
                     effort=sequence[float64])
Vector3 = _struct("Vector3", "geometry_msgs/msg/Vector3", "geometry_msgs/msg/Vector3 (m).", x=float64, y=float64,
                  z=float64)
Quaternion = _struct("Quaternion", "geometry_msgs/msg/Quaternion",
                     "geometry_msgs/msg/Quaternion (x, y, z, w; ROS default w = 1).", x=float64, y=float64, z=float64,
                     w=(float64, 1.0))
Transform = _struct("Transform", "geometry_msgs/msg/Transform",
                    "geometry_msgs/msg/Transform: pose of the child frame in the parent frame.", translation=Vector3,
                    rotation=Quaternion)
TransformStamped = _struct("TransformStamped", "geometry_msgs/msg/TransformStamped",
                           "geometry_msgs/msg/TransformStamped: header.frame_id is the parent, child_frame_id the "
                           "child.", header=Header, child_frame_id=str, transform=Transform)
TFMessage = _struct("TFMessage", "tf2_msgs/msg/TFMessage",
                    "tf2_msgs/msg/TFMessage: a list of stamped transforms (/tf, /tf_static).",
                    transforms=sequence[TransformStamped])
String = _struct("String", "std_msgs/msg/String", "std_msgs/msg/String (e.g. /robot_description, the URDF text).",
                 data=str)
TriggerRequest = _service("TriggerRequest", "std_srvs/srv/Trigger_Request", "std_srvs/srv/Trigger request",
                          structure_needs_at_least_one_member=uint8)
TriggerReply = _service("TriggerReply", "std_srvs/srv/Trigger_Response",
                        "std_srvs/srv/Trigger response (the header echoes the request's guid and sequence)",
                        success=bool, message=str)
Duration = _struct("Duration", "builtin_interfaces/msg/Duration", "builtin_interfaces/msg/Duration (s, ns).",
                   sec=int32, nanosec=uint32)
Point = _struct("Point", "geometry_msgs/msg/Point", "geometry_msgs/msg/Point (m).", x=float64, y=float64, z=float64)
Pose = _struct("Pose", "geometry_msgs/msg/Pose", "geometry_msgs/msg/Pose: position (m), orientation.", position=Point,
               orientation=Quaternion)
PoseStamped = _struct("PoseStamped", "geometry_msgs/msg/PoseStamped", "geometry_msgs/msg/PoseStamped.", header=Header,
                      pose=Pose)
Twist = _struct("Twist", "geometry_msgs/msg/Twist", "geometry_msgs/msg/Twist: linear (m/s) and angular (rad/s) "
                "velocity.", linear=Vector3, angular=Vector3)
PoseWithCovariance = _struct("PoseWithCovariance", "geometry_msgs/msg/PoseWithCovariance",
                             "geometry_msgs/msg/PoseWithCovariance: pose and its 6x6 row-major covariance.", pose=Pose,
                             covariance=array[float64, 36])
TwistWithCovariance = _struct("TwistWithCovariance", "geometry_msgs/msg/TwistWithCovariance",
                              "geometry_msgs/msg/TwistWithCovariance: twist and its 6x6 row-major covariance.",
                              twist=Twist, covariance=array[float64, 36])
Odometry = _struct("Odometry", "nav_msgs/msg/Odometry",
                   "nav_msgs/msg/Odometry: pose in header.frame_id, twist in child_frame_id.", header=Header,
                   child_frame_id=str, pose=PoseWithCovariance, twist=TwistWithCovariance)
Clock = _struct("Clock", "rosgraph_msgs/msg/Clock", "rosgraph_msgs/msg/Clock (/clock, sim time).", clock=Time)

# -- actions: action_msgs, unique_identifier_msgs, nav2_msgs/action/NavigateToPose (Jazzy) -------------------------
UUID = _struct("UUID", "unique_identifier_msgs/msg/UUID", "unique_identifier_msgs/msg/UUID (16 bytes).",
               uuid=array[uint8, 16])
GoalInfo = _struct("GoalInfo", "action_msgs/msg/GoalInfo", "action_msgs/msg/GoalInfo: goal id, accept time.",
                   goal_id=UUID, stamp=Time)
GoalStatus = _struct("GoalStatus", "action_msgs/msg/GoalStatus",
                     "action_msgs/msg/GoalStatus: status 0 unknown, 1 accepted, 2 executing, 3 canceling, 4 "
                     "succeeded, 5 canceled, 6 aborted.", goal_info=GoalInfo, status=int8)
GoalStatusArray = _struct("GoalStatusArray", "action_msgs/msg/GoalStatusArray",
                          "action_msgs/msg/GoalStatusArray (the action's status topic).",
                          status_list=sequence[GoalStatus])
CancelGoalRequest = _service("CancelGoalRequest", "action_msgs/srv/CancelGoal_Request",
                             "action_msgs/srv/CancelGoal request", goal_info=GoalInfo)
CancelGoalReply = _service("CancelGoalReply", "action_msgs/srv/CancelGoal_Response",
                           "action_msgs/srv/CancelGoal response: return_code 0 none, 1 rejected, 2 unknown goal id, 3 "
                           "goal terminated", return_code=int8, goals_canceling=sequence[GoalInfo])
NavigateToPoseGoal = _struct("NavigateToPoseGoal", "nav2_msgs/action/NavigateToPose_Goal",
                             "nav2_msgs/action/NavigateToPose goal (Jazzy).", pose=PoseStamped, behavior_tree=str)
NavigateToPoseResult = _struct("NavigateToPoseResult", "nav2_msgs/action/NavigateToPose_Result",
                               "nav2_msgs/action/NavigateToPose result (Jazzy): error_code 0 NONE, 9000 UNKNOWN, 9001 "
                               "FAILED_TO_LOAD_BEHAVIOR_TREE, 9002 TF_ERROR, 9003 TIMEOUT; error_msg.",
                               error_code=uint16, error_msg=str)
NavigateToPoseFeedback = _struct("NavigateToPoseFeedback", "nav2_msgs/action/NavigateToPose_Feedback",
                                 "nav2_msgs/action/NavigateToPose feedback (Jazzy).", current_pose=PoseStamped,
                                 navigation_time=Duration, estimated_time_remaining=Duration,
                                 number_of_recoveries=int16, distance_remaining=float32)
NavigateToPoseFeedbackMessage = _struct("NavigateToPoseFeedbackMessage",
                                        "nav2_msgs/action/NavigateToPose_FeedbackMessage",
                                        "NavigateToPose feedback message: goal id and feedback.", goal_id=UUID,
                                        feedback=NavigateToPoseFeedback)
NavigateToPoseSendGoalRequest = _service("NavigateToPoseSendGoalRequest",
                                         "nav2_msgs/action/NavigateToPose_SendGoal_Request",
                                         "NavigateToPose send_goal request", goal_id=UUID, goal=NavigateToPoseGoal)
NavigateToPoseSendGoalReply = _service("NavigateToPoseSendGoalReply",
                                       "nav2_msgs/action/NavigateToPose_SendGoal_Response",
                                       "NavigateToPose send_goal response", accepted=bool, stamp=Time)
NavigateToPoseGetResultRequest = _service("NavigateToPoseGetResultRequest",
                                          "nav2_msgs/action/NavigateToPose_GetResult_Request",
                                          "NavigateToPose get_result request", goal_id=UUID)
NavigateToPoseGetResultReply = _service("NavigateToPoseGetResultReply",
                                        "nav2_msgs/action/NavigateToPose_GetResult_Response",
                                        "NavigateToPose get_result response: the goal's final status and result",
                                        status=int8, result=NavigateToPoseResult)

# -- rcl_interfaces: parameters --------------------------------------------------------------------------------
ParameterValue = _struct("ParameterValue", "rcl_interfaces/msg/ParameterValue",
                         "rcl_interfaces/msg/ParameterValue: type 0 not set, 1 bool, 2 integer, 3 double, 4 string, "
                         "5 byte[], 6 bool[], 7 integer[], 8 double[], 9 string[].", type=uint8, bool_value=bool,
                         integer_value=int64, double_value=float64, string_value=str,
                         byte_array_value=sequence[uint8], bool_array_value=sequence[bool],
                         integer_array_value=sequence[int64], double_array_value=sequence[float64],
                         string_array_value=sequence[str])
Parameter = _struct("Parameter", "rcl_interfaces/msg/Parameter", "rcl_interfaces/msg/Parameter.", name=str,
                    value=ParameterValue)
SetParametersResult = _struct("SetParametersResult", "rcl_interfaces/msg/SetParametersResult",
                              "rcl_interfaces/msg/SetParametersResult.", successful=bool, reason=str)
FloatingPointRange = _struct("FloatingPointRange", "rcl_interfaces/msg/FloatingPointRange",
                             "rcl_interfaces/msg/FloatingPointRange.", from_value=float64, to_value=float64,
                             step=float64)
IntegerRange = _struct("IntegerRange", "rcl_interfaces/msg/IntegerRange", "rcl_interfaces/msg/IntegerRange.",
                       from_value=int64, to_value=int64, step=uint64)
ParameterDescriptor = _struct("ParameterDescriptor", "rcl_interfaces/msg/ParameterDescriptor",
                              "rcl_interfaces/msg/ParameterDescriptor.", name=str, type=uint8, description=str,
                              additional_constraints=str, read_only=bool, dynamic_typing=bool,
                              floating_point_range=sequence[FloatingPointRange, 1],
                              integer_range=sequence[IntegerRange, 1])
ListParametersResult = _struct("ListParametersResult", "rcl_interfaces/msg/ListParametersResult",
                               "rcl_interfaces/msg/ListParametersResult.", names=sequence[str],
                               prefixes=sequence[str])
GetParametersRequest = _service("GetParametersRequest", "rcl_interfaces/srv/GetParameters_Request",
                                "rcl_interfaces/srv/GetParameters request", names=sequence[str])
GetParametersReply = _service("GetParametersReply", "rcl_interfaces/srv/GetParameters_Response",
                              "rcl_interfaces/srv/GetParameters response", values=sequence[ParameterValue])
SetParametersRequest = _service("SetParametersRequest", "rcl_interfaces/srv/SetParameters_Request",
                                "rcl_interfaces/srv/SetParameters request", parameters=sequence[Parameter])
SetParametersReply = _service("SetParametersReply", "rcl_interfaces/srv/SetParameters_Response",
                              "rcl_interfaces/srv/SetParameters response", results=sequence[SetParametersResult])
SetParametersAtomicallyRequest = _service("SetParametersAtomicallyRequest",
                                          "rcl_interfaces/srv/SetParametersAtomically_Request",
                                          "rcl_interfaces/srv/SetParametersAtomically request",
                                          parameters=sequence[Parameter])
SetParametersAtomicallyReply = _service("SetParametersAtomicallyReply",
                                        "rcl_interfaces/srv/SetParametersAtomically_Response",
                                        "rcl_interfaces/srv/SetParametersAtomically response",
                                        result=SetParametersResult)
ListParametersRequest = _service("ListParametersRequest", "rcl_interfaces/srv/ListParameters_Request",
                                 "rcl_interfaces/srv/ListParameters request", prefixes=sequence[str], depth=uint64)
ListParametersReply = _service("ListParametersReply", "rcl_interfaces/srv/ListParameters_Response",
                               "rcl_interfaces/srv/ListParameters response", result=ListParametersResult)
DescribeParametersRequest = _service("DescribeParametersRequest", "rcl_interfaces/srv/DescribeParameters_Request",
                                     "rcl_interfaces/srv/DescribeParameters request", names=sequence[str])
DescribeParametersReply = _service("DescribeParametersReply", "rcl_interfaces/srv/DescribeParameters_Response",
                                   "rcl_interfaces/srv/DescribeParameters response",
                                   descriptors=sequence[ParameterDescriptor])
GetParameterTypesRequest = _service("GetParameterTypesRequest", "rcl_interfaces/srv/GetParameterTypes_Request",
                                    "rcl_interfaces/srv/GetParameterTypes request", names=sequence[str])
GetParameterTypesReply = _service("GetParameterTypesReply", "rcl_interfaces/srv/GetParameterTypes_Response",
                                  "rcl_interfaces/srv/GetParameterTypes response", types=sequence[uint8])

Gid = _struct("Gid", "rmw_dds_common/msg/Gid", "rmw_dds_common/msg/Gid: a DDS entity's GUID (12-byte prefix, "
              "4-byte entity id; ``char[16]`` in rosidl, the same bytes).", data=array[uint8, 16])
NodeEntitiesInfo = _struct("NodeEntitiesInfo", "rmw_dds_common/msg/NodeEntitiesInfo",
                           "rmw_dds_common/msg/NodeEntitiesInfo: a node and the GIDs of its readers and writers.",
                           node_namespace=str, node_name=str, reader_gid_seq=sequence[Gid],
                           writer_gid_seq=sequence[Gid])
ParticipantEntitiesInfo = _struct("ParticipantEntitiesInfo", "rmw_dds_common/msg/ParticipantEntitiesInfo",
                                  "rmw_dds_common/msg/ParticipantEntitiesInfo (the DDS topic ros_discovery_info): "
                                  "a participant's GID and its nodes.", gid=Gid,
                                  node_entities_info_seq=sequence[NodeEntitiesInfo])


def to_bytes(msg: IdlStruct) -> bytes:
    """ROS 2 CDR (XCDR1, little endian, with the 4-byte encapsulation header) of ``msg``, as rosbag2 stores it."""
    return msg.serialize(use_version_2=False)


# REP-2011 type descriptions: (field name, type id, nested type name). Type ids of
# type_description_interfaces/msg/FieldType: INT32 6, UINT32 7, DOUBLE 11, STRING 17, NESTED 1;
# an unbounded sequence adds 144.
_SEQ = 144
_ARRAY = 48  # a fixed-size array adds 48 (its size is the field's capacity)
TYPE_DESCRIPTIONS: dict[str, list[tuple]] = {  # (name, type id, nested type[, capacity])
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
    "builtin_interfaces/msg/Duration": [("sec", 6, ""), ("nanosec", 7, "")],
    "geometry_msgs/msg/Point": [("x", 11, ""), ("y", 11, ""), ("z", 11, "")],
    "geometry_msgs/msg/Pose": [("position", 1, "geometry_msgs/msg/Point"),
                               ("orientation", 1, "geometry_msgs/msg/Quaternion")],
    "geometry_msgs/msg/PoseStamped": [("header", 1, "std_msgs/msg/Header"), ("pose", 1, "geometry_msgs/msg/Pose")],
    "geometry_msgs/msg/Twist": [("linear", 1, "geometry_msgs/msg/Vector3"), ("angular", 1, "geometry_msgs/msg/Vector3")],
    "rosgraph_msgs/msg/Clock": [("clock", 1, "builtin_interfaces/msg/Time")],
    "unique_identifier_msgs/msg/UUID": [("uuid", 3 + _ARRAY, "", 16)],
    "action_msgs/msg/GoalInfo": [("goal_id", 1, "unique_identifier_msgs/msg/UUID"),
                                 ("stamp", 1, "builtin_interfaces/msg/Time")],
    "action_msgs/msg/GoalStatus": [("goal_info", 1, "action_msgs/msg/GoalInfo"), ("status", 2, "")],
    "action_msgs/msg/GoalStatusArray": [("status_list", 1 + _SEQ, "action_msgs/msg/GoalStatus")],
    "nav2_msgs/action/NavigateToPose_Goal": [("pose", 1, "geometry_msgs/msg/PoseStamped"), ("behavior_tree", 17, "")],
    "nav2_msgs/action/NavigateToPose_Result": [("error_code", 5, ""), ("error_msg", 17, "")],
    "nav2_msgs/action/NavigateToPose_Feedback": [
        ("current_pose", 1, "geometry_msgs/msg/PoseStamped"), ("navigation_time", 1, "builtin_interfaces/msg/Duration"),
        ("estimated_time_remaining", 1, "builtin_interfaces/msg/Duration"), ("number_of_recoveries", 4, ""),
        ("distance_remaining", 10, ""),
    ],
    "nav2_msgs/action/NavigateToPose_FeedbackMessage": [
        ("goal_id", 1, "unique_identifier_msgs/msg/UUID"), ("feedback", 1, "nav2_msgs/action/NavigateToPose_Feedback"),
    ],
    "nav2_msgs/action/NavigateToPose_SendGoal_Request": [
        ("goal_id", 1, "unique_identifier_msgs/msg/UUID"), ("goal", 1, "nav2_msgs/action/NavigateToPose_Goal"),
    ],
    "nav2_msgs/action/NavigateToPose_SendGoal_Response": [("accepted", 15, ""),
                                                          ("stamp", 1, "builtin_interfaces/msg/Time")],
    "nav2_msgs/action/NavigateToPose_GetResult_Request": [("goal_id", 1, "unique_identifier_msgs/msg/UUID")],
    "nav2_msgs/action/NavigateToPose_GetResult_Response": [
        ("status", 2, ""), ("result", 1, "nav2_msgs/action/NavigateToPose_Result"),
    ],
}


def _describe(name: str) -> dict:
    return {
        "type_name": name,
        "fields": [
            {"name": f[0], "type": {"type_id": f[1], "capacity": f[3] if len(f) > 3 else 0, "string_capacity": 0,
                                     "nested_type_name": f[2]}}
            for f in TYPE_DESCRIPTIONS[name]
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
        for f in TYPE_DESCRIPTIONS[todo.pop()]:
            nested = f[2]
            if nested and nested not in refs:
                refs.add(nested)
                todo.append(nested)
    doc = {
        "type_description": _describe(type_name),
        "referenced_type_descriptions": [_describe(r) for r in sorted(refs)],
    }
    return "RIHS01_" + hashlib.sha256(json.dumps(doc).encode()).hexdigest()
