"""Standalone ROS 2 subscriber/client for tests/ros2/test_ros2.py. Does NOT import wbc: it declares ROS 2's IDL itself.

Usage: python tests/ros2/ros2_subscriber.py joint_states SECONDS [JOINT] | latched SECONDS | reset SECONDS
(joint_states with JOINT: only messages naming that joint are counted, others are "foreign" — another process on
the same random domain id.)
Prints one JSON line with what it received.
"""
import json
import sys
import time
from dataclasses import dataclass

from cyclonedds.core import Policy, Qos
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.annotations import final
from cyclonedds.idl.types import float64, int32, int64, sequence, uint8, uint32, uint64
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration
from loopback_sockets import loopback_participant
import os


@dataclass
@final
class Time_(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32
    nanosec: uint32


@dataclass
@final
class Header_(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time_
    frame_id: str


@dataclass
@final
class JointState_(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    header: Header_
    name: sequence[str]
    position: sequence[float64]
    velocity: sequence[float64]
    effort: sequence[float64]


@dataclass
@final
class Vector3_(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64
    y: float64
    z: float64


@dataclass
@final
class Quaternion_(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64
    y: float64
    z: float64
    w: float64


@dataclass
@final
class Transform_(IdlStruct, typename="geometry_msgs::msg::dds_::Transform_"):
    translation: Vector3_
    rotation: Quaternion_


@dataclass
@final
class TransformStamped_(IdlStruct, typename="geometry_msgs::msg::dds_::TransformStamped_"):
    header: Header_
    child_frame_id: str
    transform: Transform_


@dataclass
@final
class TFMessage_(IdlStruct, typename="tf2_msgs::msg::dds_::TFMessage_"):
    transforms: sequence[TransformStamped_]


@dataclass
@final
class String_(IdlStruct, typename="std_msgs::msg::dds_::String_"):
    data: str


@dataclass
@final
class Trigger_Request_(IdlStruct, typename="std_srvs::srv::dds_::Trigger_Request_"):
    client_guid: uint64  # rmw_cyclonedds request header
    seq: int64
    structure_needs_at_least_one_member: uint8


@dataclass
@final
class Trigger_Response_(IdlStruct, typename="std_srvs::srv::dds_::Trigger_Response_"):
    client_guid: uint64
    seq: int64
    success: bool
    message: str


def main():
    mode, seconds = sys.argv[1], float(sys.argv[2])
    dp = loopback_participant(int(os.environ.get("ROS_DOMAIN_ID", "0")))  # on 127.0.0.1 only (conftest.py checks)
    rel = Policy.Reliability.Reliable(duration(seconds=1))
    stream = Qos(rel, Policy.History.KeepLast(1000), Policy.Durability.Volatile)
    latched = Qos(rel, Policy.History.KeepLast(1), Policy.Durability.TransientLocal)
    out = {}
    t_end = time.monotonic() + seconds
    if mode == "joint_states":
        r = DataReader(dp, Topic(dp, "rt/joint_states", JointState_, qos=stream), qos=stream)
        print("ready", flush=True)
        lat, names, frames, n, foreign = [], None, set(), 0, 0
        joint = sys.argv[3] if len(sys.argv) > 3 else None
        last = time.monotonic()
        while time.monotonic() < t_end and not (n and time.monotonic() - last > 5.0):  # 5 s silence: done
            got = r.take(N=1000)
            now = time.time()
            if got:
                last = time.monotonic()
            for s in got:
                if isinstance(s, JointState_):
                    if joint is not None and joint not in s.name:
                        foreign += 1
                        continue
                    n += 1
                    names = list(s.name)
                    frames.add(s.header.frame_id)
                    lat.append(now - (s.header.stamp.sec + 1e-9 * s.header.stamp.nanosec))
                    if len(s.position) != len(s.name) or len(s.velocity) != len(s.name):
                        out["bad_lengths"] = True
            if not got:
                time.sleep(0.0005)
        lat.sort()
        out.update(received=n, foreign=foreign, names=names, frames=sorted(frames),
                   p50_us=1e6 * lat[len(lat) // 2] if lat else None,
                   p99_us=1e6 * lat[min(len(lat) - 1, int(0.99 * len(lat)))] if lat else None)
    elif mode == "latched":
        rd = DataReader(dp, Topic(dp, "rt/robot_description", String_, qos=latched), qos=latched)
        rs = DataReader(dp, Topic(dp, "rt/tf_static", TFMessage_, qos=latched), qos=latched)
        while time.monotonic() < t_end and not ("description" in out and "tf_static" in out):
            for s in rd.take(N=10):
                if isinstance(s, String_):
                    out["description"] = s.data
            for s in rs.take(N=10):
                if isinstance(s, TFMessage_):
                    out["tf_static"] = [[t.header.frame_id, t.child_frame_id] for t in s.transforms]
            time.sleep(0.01)
    elif mode == "reset":
        q = Qos(rel, Policy.History.KeepLast(10), Policy.Durability.Volatile)
        w = DataWriter(dp, Topic(dp, "rq/reset_robotRequest", Trigger_Request_, qos=q), qos=q)
        r = DataReader(dp, Topic(dp, "rr/reset_robotReply", Trigger_Response_, qos=q), qos=q)
        guid, seq = 0x1234ABCD, 1
        next_send = 0.0
        while time.monotonic() < t_end and "reply" not in out:
            if time.monotonic() >= next_send:  # resend until matched (no service discovery wait here)
                w.write(Trigger_Request_(guid, seq, 0))
                next_send = time.monotonic() + 0.5
                seq += 1
            for s in r.take(N=10):
                if isinstance(s, Trigger_Response_) and s.client_guid == guid:
                    out["reply"] = {"seq": s.seq, "success": s.success, "message": s.message}
            time.sleep(0.01)
    print(json.dumps(out), flush=True)


if __name__ == "__main__":
    main()
