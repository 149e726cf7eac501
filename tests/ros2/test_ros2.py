"""ROS 2 interop (issue 12): wire format against rosbags, REP-2011 hash, two-process DDS on loopback, bags.

DDS is confined to 127.0.0.1 (CYCLONEDDS_URI: interface lo, multicast off, localhost peer) with a random
ROS_DOMAIN_ID per test. Skipped only when the extra wbc[ros2] (cyclonedds, rosbags, mcap) is absent.
"""

import json
import os
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

for _mod in ("cyclonedds", "rosbags", "mcap", "mcap_ros2"):
    pytest.importorskip(_mod, reason=f"the optional extra wbc[ros2] is not installed ({_mod} missing)")

from rosbags.typesys import Stores, get_typestore  # noqa: E402

from wbc.ros2 import msgs  # noqa: E402
from conftest import dds_domain_id

HERE = Path(__file__).parent
SUBSCRIBER = HERE / "ros2_subscriber.py"
LOOPBACK = (
    '<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface name="lo"/></Interfaces>'
    "<AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex>"
    '<MaxAutoParticipantIndex>60</MaxAutoParticipantIndex><Peers><Peer address="127.0.0.1"/></Peers>'
    "</Discovery></Domain></CycloneDDS>"
)
TS = get_typestore(Stores.ROS2_HUMBLE)


@pytest.fixture
def dds_env():
    """Environment of the child processes: loopback-only DDS on a random domain."""
    env = dict(os.environ)
    env["CYCLONEDDS_URI"] = LOOPBACK
    env["ROS_DOMAIN_ID"] = str(dds_domain_id())
    env.pop("PYTHONPATH", None)
    return env


def _urdf_joint_names(robot_name: str) -> list[str]:
    from wbc.robot import load_robot

    root = ET.parse(load_robot(robot_name).urdf_path).getroot()
    return [j.get("name") for j in root.iter("joint") if j.get("type") != "fixed"]


# --- wire format ----------------------------------------------------------------------------------------------
def _rand_str(rng, n=12):
    return "".join(rng.choice(list("abcdefghijklmnopqrstuvwxyz_/0123456789"), size=rng.integers(0, n)))


def _stamp(rng):
    return int(rng.integers(-2**31, 2**31)), int(rng.integers(0, 10**9))


@pytest.mark.parametrize("seed", range(20))
def test_cdr_bytes_equal_rosbags(seed):
    rng = np.random.default_rng(seed)
    T = TS.types
    n = int(rng.integers(0, 20))
    sec, nsec = _stamp(rng)
    frame = _rand_str(rng)
    names = [_rand_str(rng) for _ in range(n)]
    pos, vel, eff = (rng.normal(size=int(rng.integers(0, n + 1))).tolist() for _ in range(3))
    ours = msgs.JointState(msgs.Header(msgs.Time(sec, nsec), frame), names, pos, vel, eff)
    ref = T["sensor_msgs/msg/JointState"](
        T["std_msgs/msg/Header"](T["builtin_interfaces/msg/Time"](sec, nsec), frame), names,
        np.array(pos), np.array(vel), np.array(eff))
    assert msgs.to_bytes(ours) == bytes(TS.serialize_cdr(ref, "sensor_msgs/msg/JointState"))

    ours_tf, ref_tf = [], []
    for _ in range(int(rng.integers(0, 6))):
        sec, nsec = _stamp(rng)
        parent, child = _rand_str(rng), _rand_str(rng)
        xyz, quat = rng.normal(size=3), rng.normal(size=4)
        ours_tf.append(msgs.TransformStamped(msgs.Header(msgs.Time(sec, nsec), parent), child, msgs.Transform(
            msgs.Vector3(*xyz.tolist()), msgs.Quaternion(*quat.tolist()))))
        ref_tf.append(T["geometry_msgs/msg/TransformStamped"](
            T["std_msgs/msg/Header"](T["builtin_interfaces/msg/Time"](sec, nsec), parent), child,
            T["geometry_msgs/msg/Transform"](T["geometry_msgs/msg/Vector3"](*xyz),
                                             T["geometry_msgs/msg/Quaternion"](*quat))))
    assert msgs.to_bytes(msgs.TFMessage(ours_tf)) == bytes(
        TS.serialize_cdr(T["tf2_msgs/msg/TFMessage"](ref_tf), "tf2_msgs/msg/TFMessage"))

    text = _rand_str(rng, 300)
    assert msgs.to_bytes(msgs.String(text)) == bytes(
        TS.serialize_cdr(T["std_msgs/msg/String"](text), "std_msgs/msg/String"))


def test_rihs01_hash_of_joint_state():
    h = msgs.rihs01("sensor_msgs/msg/JointState")
    # Known ROS 2 value (Jazzy's sensor_msgs JointState type hash).
    assert h.startswith("RIHS01_a13ee3a3") and h.endswith("260e") and len(h) == 7 + 64
    # every type rosbags' store knows (nav2_msgs' action types: tests/ros2/test_node.py registers them first)
    known = [name for name in msgs.TYPE_DESCRIPTIONS if name in TS.types]
    assert len(known) >= len(msgs.TYPE_DESCRIPTIONS) - 8
    for name in known:
        assert msgs.rihs01(name) == TS.hash_rihs01(name), name


def test_core_imports_without_the_extra():
    code = (
        "import sys\n"
        "class Block:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] in ('cyclonedds', 'rosbags', 'mcap', 'mcap_ros2'):\n"
        "            raise ImportError('blocked ' + name)\n"
        "sys.meta_path.insert(0, Block())\n"
        "import wbc, wbc.cli\n"
        "p = wbc.cli.build_parser()\n"
        "from wbc.robot import load_robot\n"
        "from wbc.ros2 import Ros2UnavailableError\n"
        "from wbc.ros2.publisher import Ros2Publisher\n"
        "try:\n"
        "    Ros2Publisher(load_robot('humanoid15'))\n"
        "except Ros2UnavailableError as e:\n"
        "    print('unavailable:', e)\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('cyclonedds', 'rosbags')))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert "unavailable: ROS 2 support needs the Python package 'cyclonedds'" in out.stdout
    assert out.stdout.strip().endswith("[]")


def test_bad_options_raise_typed_errors():
    from wbc.exceptions import InvalidInputError
    from wbc.robot import load_robot
    from wbc.ros2.publisher import Ros2Publisher

    robot = load_robot("humanoid15")
    for kwargs in ({"rate": 0}, {"rate": 501}, {"tf": "links"}, {"storage": "rosbag"}):
        with pytest.raises(InvalidInputError):
            Ros2Publisher(robot, dds=False, **kwargs)


# --- two processes on loopback ----------------------------------------------------------------------------------
def _walk_and_subscribe(env, rate: int, seconds: float):
    # counted: messages naming a humanoid15 joint (another test's node on the same random domain is not counted)
    sub = subprocess.Popen([sys.executable, str(SUBSCRIBER), "joint_states", str(seconds), "left_hip_pitch"], env=env,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd="/")
    assert sub.stdout.readline().strip() == "ready"
    walk = subprocess.run([sys.executable, "-m", "wbc", "walk", "--robot", "humanoid15", "--steps", "2", "--ros2",
                           "--ros2-rate", str(rate)], env=env, capture_output=True, text=True, timeout=300)
    assert walk.returncode == 0, walk.stderr + walk.stdout
    line = [ln for ln in walk.stdout.splitlines() if ln.startswith("ros2: published")]
    assert line, walk.stdout
    published = int(line[0].split()[2])
    out, err = sub.communicate(timeout=seconds + 60)
    got = json.loads(out.strip().splitlines()[-1])
    return published, got


@pytest.mark.parametrize("rate", [500, 50])
def test_two_processes_joint_states(dds_env, rate):
    # a listening window far beyond the walk (it ends 5 s after the last sample): a loaded machine took > 45 s
    published, got = _walk_and_subscribe(dds_env, rate, seconds=300.0)
    print(f"rate {rate} Hz: published {published}, received {got['received']}, "
          f"latency p50 {got['p50_us']:.0f} µs, p99 {got['p99_us']:.0f} µs")
    # humanoid15 walks 2 steps: several seconds of motion -> hundreds (50 Hz) to thousands (500 Hz) of samples.
    assert published >= (1000 if rate == 500 else 100)
    assert got["received"] >= 0.99 * published
    assert got["received"] <= published
    assert sorted(got["names"]) == sorted(_urdf_joint_names("humanoid15"))
    assert got["frames"] == ["pelvis"]
    assert "bad_lengths" not in got


def test_joint_publisher_late_joiner_echo_and_reset(dds_env):
    pub = subprocess.Popen([sys.executable, "-m", "wbc", "ros2", "joint-publisher", "--robot", "humanoid15",
                            "--rate", "50", "--steps", "2", "--duration", "300"], env=dds_env,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        first = pub.stdout.readline()
        assert first.startswith("wbc ros2 joint-publisher: humanoid15"), first + pub.stderr.read()
        time.sleep(1.0)  # the subscriber below joins late: the latched samples were written long before
        late = subprocess.run([sys.executable, str(SUBSCRIBER), "latched", "20"], env=dds_env,
                              capture_output=True, text=True, timeout=180, cwd="/")
        got = json.loads(late.stdout.strip().splitlines()[-1])
        urdf = ET.fromstring(got["description"])
        assert urdf.tag == "robot" and urdf.get("name")
        fixed = {(j.find("parent").get("link"), j.find("child").get("link"))
                 for j in urdf.iter("joint") if j.get("type") == "fixed"}
        assert fixed and {tuple(x) for x in got["tf_static"]} == fixed

        echo = subprocess.run([sys.executable, "-m", "wbc", "ros2", "echo-joint", "right_knee", "--count", "20",
                               "--timeout", "60"], env=dds_env, capture_output=True, text=True, timeout=180)
        assert echo.returncode == 0, echo.stderr
        lines = echo.stdout.strip().splitlines()
        assert len(lines) == 20
        knee = [float(ln.split()[2]) for ln in lines]
        assert all(ln.split()[1] == "right_knee" for ln in lines)
        from wbc.robot import load_robot

        robot = load_robot("humanoid15")
        lo = robot.model.lowerPositionLimit[robot.model.joints[robot.joint_id("right_knee")].idx_q]
        hi = robot.model.upperPositionLimit[robot.model.joints[robot.joint_id("right_knee")].idx_q]
        assert all(lo - 1e-9 <= k <= hi + 1e-9 for k in knee)

        reset = subprocess.run([sys.executable, str(SUBSCRIBER), "reset", "20"], env=dds_env,
                               capture_output=True, text=True, timeout=180, cwd="/")
        reply = json.loads(reset.stdout.strip().splitlines()[-1])["reply"]
        assert reply["success"] is True and reply["seq"] >= 1 and "reset" in reply["message"]
    finally:
        pub.terminate()
        out, err = pub.communicate(timeout=30)
    assert "/reset_robot: reset 1" in out, out + err


# --- rosbag2 --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_bag_read_back_identical(tmp_path, storage):
    from rosbags.highlevel import AnyReader

    from wbc.robot import load_robot
    from wbc.ros2.publisher import Ros2Publisher
    from wbc.scenarios.walk import plan_default_walk, run_walk

    robot = load_robot("humanoid15")
    run = run_walk(robot, plan_default_walk(robot, n_steps=1))
    bag = tmp_path / "bag"
    pub = Ros2Publisher(robot, rate=500, dds=False, bag=bag, storage=storage, dt=run.dt, clock="sim")
    for k in range(len(run.t)):
        pub.update(run.q[k], run.t[k])
    pub.close()
    assert pub.published == len(run.t)

    with AnyReader([bag]) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        js = [(ts, reader.deserialize(raw, c.msgtype)) for c, ts, raw in reader.messages()
              if c.topic == "/joint_states"]
    assert counts["/joint_states"] == counts["/tf"] == len(run.t)
    assert counts["/robot_description"] == counts["/tf_static"] == 1
    pos = np.array([m.position for _, m in js])
    np.testing.assert_array_equal(pos, run.q[:, 7:])
    np.testing.assert_array_equal(np.array([ts for ts, _ in js]), np.round(run.t * 1e9).astype(np.int64))
    vel = np.array([m.velocity for _, m in js])
    np.testing.assert_allclose(vel[1:], np.diff(run.q[:, 7:], axis=0) / run.dt, rtol=0, atol=1e-9)
    assert sorted(js[0][1].name) == sorted(_urdf_joint_names("humanoid15"))  # URDF names, Pinocchio order

    if storage == "mcap":
        from mcap.reader import make_reader
        from mcap_ros2.decoder import DecoderFactory

        files = list(bag.glob("*.mcap"))
        with open(files[0], "rb") as f:
            mpos = [list(m.position) for _, ch, _, m in make_reader(f, decoder_factories=[DecoderFactory()])
                    .iter_decoded_messages(topics=["/joint_states"])]
        np.testing.assert_array_equal(np.array(mpos), pos)


@pytest.mark.parametrize("seed", range(5))
def test_preallocated_encoders_equal_cyclonedds_serializer(seed):
    from wbc.ros2.cdr import JointStatePacker, TFPacker

    rng = np.random.default_rng(100 + seed)
    names = [_rand_str(rng) + str(i) for i in range(int(rng.integers(1, 30)))]
    frame = _rand_str(rng)
    packer = JointStatePacker(names, frame)
    for _ in range(3):
        sec, nsec = _stamp(rng)
        p, v = rng.normal(size=len(names)), rng.normal(size=len(names))
        ref = msgs.JointState(msgs.Header(msgs.Time(sec, nsec), frame), names, p.tolist(), v.tolist(), [])
        assert packer.encode(sec, nsec, p, v) == msgs.to_bytes(ref)
    pairs = [(_rand_str(rng), _rand_str(rng)) for _ in range(int(rng.integers(1, 12)))]
    tf = TFPacker(pairs)
    sec, nsec = _stamp(rng)
    x = rng.normal(size=(len(pairs), 7))
    ref = msgs.TFMessage([msgs.TransformStamped(msgs.Header(msgs.Time(sec, nsec), a), b, msgs.Transform(
        msgs.Vector3(*x[i, :3].tolist()), msgs.Quaternion(*x[i, 3:].tolist()))) for i, (a, b) in enumerate(pairs)])
    assert tf.encode(sec, nsec, x) == msgs.to_bytes(ref)


def test_bag_tf_chain_reproduces_pinocchio_frames(tmp_path):
    """Composing /tf_static and /tf from odom gives every link's pose as Pinocchio's oMf (independent path)."""
    import pinocchio as pin
    from rosbags.highlevel import AnyReader

    from wbc.robot import load_robot
    from wbc.ros2.publisher import Ros2Publisher

    robot = load_robot("humanoid15")
    rng = np.random.default_rng(3)
    q = pin.randomConfiguration(robot.model, -np.ones(robot.nq), np.ones(robot.nq))
    q[:3] = rng.normal(size=3)
    pub = Ros2Publisher(robot, rate=500, dds=False, bag=tmp_path / "b", clock="sim")
    pub.update(q, 1.0)
    pub.close()
    edges = {}
    with AnyReader([tmp_path / "b"]) as reader:
        for c, _, raw in reader.messages():
            if c.topic in ("/tf", "/tf_static"):
                for ts in reader.deserialize(raw, c.msgtype).transforms:
                    tr, r = ts.transform.translation, ts.transform.rotation
                    edges[ts.child_frame_id] = (ts.header.frame_id, pin.SE3(
                        pin.Quaternion(r.w, r.x, r.y, r.z).matrix(), np.array([tr.x, tr.y, tr.z])))
    # /tf_static was written for q_ref; fixed-joint placements do not depend on q.
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    links = [f.name for f in robot.model.frames if f.type == pin.FrameType.BODY]
    assert set(links) == set(edges)
    for fid, f in enumerate(robot.model.frames):
        if f.type != pin.FrameType.BODY:
            continue
        pose, name = pin.SE3.Identity(), f.name
        while name != "odom":
            parent, rel = edges[name]
            pose, name = rel * pose, parent
        np.testing.assert_allclose(pose.homogeneous, data.oMf[fid].homogeneous, atol=1e-12)


@pytest.mark.parametrize("command", [["sim", "stand", "--robot", "g1", "--duration", "0.4"],
                                     ["balance", "shift", "--robot", "humanoid15"]])
def test_balance_and_sim_record_bags(tmp_path, command):
    """`--bag` on `wbc sim` and `wbc balance`: the bag holds the four topics, /joint_states at --ros2-rate with the
    URDF's joint names, and its positions equal the run's own npz log at the decimated ticks."""
    from rosbags.rosbag2 import Reader

    bag, log = tmp_path / "bag", tmp_path / "run.npz"
    r = subprocess.run([sys.executable, "-m", "wbc", *command, "--bag", str(bag), "--ros2-rate", "50",
                        "--log", str(log), "--quiet"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr + r.stdout
    data = np.load(log, allow_pickle=True)
    with Reader(bag) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        js = [TS.deserialize_cdr(raw, c.msgtype) for c, _, raw in reader.messages()
              if c.topic == "/joint_states"]
    assert set(counts) == {"/joint_states", "/tf", "/tf_static", "/robot_description"}
    duration = float(data["t"][-1] - data["t"][0]) + float(data["dt"])
    assert abs(counts["/joint_states"] - duration * 50) <= 1
    import wbc

    model = wbc.load_robot(command[command.index("--robot") + 1]).model
    names = [model.names[j] for j in range(2, model.njoints)]  # every joint after the universe and the free flyer
    assert list(js[0].name) == names
    # positions: every published sample is one of the logged joint configurations (q[7:] for a free flyer)
    logged = np.asarray(data["q"])[:, 7:]
    for msg in js[:: max(1, len(js) // 5)]:
        assert np.min(np.abs(logged - np.asarray(msg.position)).max(axis=1)) < 1e-9


def test_walk_bag_spans_the_run_time(tmp_path):
    """`wbc walk --bag`: message times are the run's time, so the bag spans the walk's duration (not the wall
    time of an unpaced run, which is several times shorter)."""
    from rosbags.rosbag2 import Reader

    bag, log = tmp_path / "bag", tmp_path / "run.npz"
    r = subprocess.run([sys.executable, "-m", "wbc", "walk", "--robot", "humanoid15", "--steps", "8", "--bag",
                        str(bag), "--ros2-rate", "50", "--log", str(log), "--quiet"],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode in (0, 1), r.stderr + r.stdout
    data = np.load(log, allow_pickle=True)
    duration = float(data["t"][-1] - data["t"][0]) + float(data["dt"])
    with Reader(bag) as reader:
        times = np.array([ts for c, ts, _ in reader.messages() if c.topic == "/joint_states"]) * 1e-9
        stamps = [TS.deserialize_cdr(raw, c.msgtype).header.stamp for c, _, raw in reader.messages()
                  if c.topic == "/joint_states"]
    span = times[-1] - times[0] + 1.0 / 50
    print(f"walk {duration:.3f} s, bag /joint_states span {span:.3f} s ({len(times)} samples)")
    assert duration > 9.0
    assert abs(span - duration) <= 0.01 * duration
    stamp_s = np.array([s.sec + 1e-9 * s.nanosec for s in stamps])
    np.testing.assert_allclose(stamp_s, times, atol=1e-9)  # header stamps = bag times


def test_delete_all_entities_deletes_every_entity_then_dds_works_again(dds_env):
    """dds.delete_all_entities (registered at exit by the first participant) deletes the participants, readers and
    writers of the process, as Cyclone itself reports, and a later participant works again."""
    code = """
import atexit
from cyclonedds.core import DDSException
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from wbc.ros2 import dds, msgs

dds.use_loopback()
part = dds.participant()
topic = Topic(part, dds.ros_topic("/chatter"), msgs.String)
reader, writer = DataReader(part, topic), DataWriter(part, topic)
assert dds.delete_all_entities() == 0
for entity in (part, reader, writer):
    try:
        entity.get_qos()
    except DDSException as e:
        print("deleted:", type(entity).__name__, e.code)
    else:
        raise SystemExit(f"{entity} still exists")
assert dds.delete_all_entities() == -4            # nothing left: DDS_RETCODE_PRECONDITION_NOT_MET
again = dds.participant()
t2 = Topic(again, dds.ros_topic("/chatter"), msgs.String)
w2, r2 = DataWriter(again, t2, qos=dds.qos_latched()), DataReader(again, t2, qos=dds.qos_latched())
w2.write(msgs.String(data="after"))
import time
for _ in range(100):
    got = [s.data for s in r2.take(N=10)]
    if got:
        break
    time.sleep(0.02)
print("received", got)
assert got == ["after"]
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, env=dds_env,
                         cwd=Path(__file__).resolve().parents[2])
    assert out.returncode == 0, out.stdout + out.stderr
    assert out.stdout.count("deleted:") == 3, out.stdout
