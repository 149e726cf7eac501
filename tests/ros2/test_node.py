"""`wbc ros2 node` as a ROS 2 system: NavigateToPose action, /cmd_vel, parameters, /clock — driven by clients in a
separate process that does not import wbc (tests/ros2/ros2_node_client.py declares the ROS 2 IDL itself).

DDS is confined to 127.0.0.1 (CYCLONEDDS_URI: interface lo, multicast off, localhost peer) with a random
ROS_DOMAIN_ID. The node runs with ``--time sim`` (as fast as it can, /clock, stamps in node time), so rates and
durations are measured in node time from the messages' stamps and /clock. Skipped only when the extra wbc[ros2]
(cyclonedds, rosbags) is absent.
"""

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import dds_domain_id

for _mod in ("cyclonedds", "rosbags"):
    pytest.importorskip(_mod, reason=f"the optional extra wbc[ros2] is not installed ({_mod} missing)")

HERE = Path(__file__).parent
CLIENT = HERE / "ros2_node_client.py"
LOOPBACK = (
    '<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface name="lo"/></Interfaces>'
    "<AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex>"
    '<MaxAutoParticipantIndex>60</MaxAutoParticipantIndex><Peers><Peer address="127.0.0.1"/></Peers>'
    "</Discovery></Domain></CycloneDDS>"
)


@pytest.fixture(scope="module")
def node():
    """One `wbc ros2 node --time sim` for the module; yields the environment of its clients."""
    env = dict(os.environ)
    env["CYCLONEDDS_URI"] = LOOPBACK
    env["ROS_DOMAIN_ID"] = str(dds_domain_id())
    env.pop("PYTHONPATH", None)
    proc = subprocess.Popen([sys.executable, "-m", "wbc", "ros2", "node", "--robot", "humanoid15", "--time", "sim"],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            cwd=str(HERE.parents[1]))
    first = proc.stdout.readline()
    assert first.startswith("wbc ros2 node: humanoid15"), first + proc.stderr.read()
    yield env
    proc.terminate()
    out, err = proc.communicate(timeout=60)
    print(out[-2000:])


def _client(env, *args, timeout=400):
    r = subprocess.run([sys.executable, str(CLIENT), *map(str, args)], env=env, capture_output=True, text=True,
                       timeout=timeout, cwd="/")
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


def _sole_heights(joint_names, joints, odom, robot_name="humanoid15"):
    """Sole heights (N, 2) m and times from the published /joint_states and /odom (Pinocchio forward kinematics of
    the received q — independent of the node's own bookkeeping)."""
    import pinocchio as pin

    from wbc.robot import load_robot

    robot = load_robot(robot_name)
    model, data = robot.model, robot.model.createData()
    od = {round(o[0], 6): o[1:] for o in odom}
    idx = [model.joints[model.getJointId(n)].idx_q for n in joint_names]
    fl, fr = robot.frame_id(robot.left_sole), robot.frame_id(robot.right_sole)
    t, z = [], []
    for row in joints:
        base = od.get(round(row[0], 6))
        if base is None:
            continue
        q = robot.q_ref.copy()
        q[:7] = base
        q[idx] = row[1:]
        pin.framesForwardKinematics(model, data, q)
        t.append(row[0])
        z.append([data.oMf[fl].translation[2], data.oMf[fr].translation[2]])
    return np.array(t), np.array(z)


def test_navigate_to_pose_goal_feedback_result_then_cancel(node):
    got = _client(node, "goal", 1.5, 0.5, 0.0)
    assert got["accepted"]
    res = got["result"]
    f = np.array(got["feedback"])  # navigation_time (s), distance_remaining (m), stamp
    rate = (len(f) - 1) / (f[-1, 0] - f[0, 0])
    final = np.array(got["odom"][-1])
    yaw = math.atan2(2 * (final[7] * final[6] + final[4] * final[5]), 1 - 2 * (final[5] ** 2 + final[6] ** 2))
    err_xy = math.hypot(final[1] - 1.5, final[2] - 0.5)
    print(f"goal: {len(f)} feedback at {rate:.2f} Hz (node time), distance {f[0, 1]:.3f} -> {f[-1, 1]:.4f} m; "
          f"result {res}; /odom final base error {err_xy * 1e3:.1f} mm, {math.degrees(abs(yaw)):.2f} deg")
    assert res["status"] == 4 and res["error_code"] == 0  # SUCCEEDED, NONE
    assert rate >= 5.0
    assert np.all(np.diff(f[:, 0]) <= 0.2 + 1e-9)  # no gap longer than 0.2 s
    assert f[0, 1] > 1.5 and f[-1, 1] < 0.05
    assert np.all(np.diff(f[:, 1]) <= 1e-5)  # non-increasing (float32, µm contact drift)
    assert err_xy <= 0.05 and abs(math.degrees(yaw)) <= 5.0

    cancel_at = 3.0  # s of navigation time: mid-walk (the walk takes about 8.5 s)
    got = _client(node, "goal", 1.5, 0.5, 0.0, cancel_at)
    res = got["result"]
    assert got["cancel_return_code"] == 0 and res["status"] == 5, res  # ERROR_NONE, CANCELED
    t, z = _sole_heights(got["joint_names"], got["joints"], got["odom"])
    up = (z > 0.003).any(axis=1)  # a sole more than 3 mm above the ground (the swing rises 40 mm): single support
    after = t >= got["cancel_stamp"]
    lift_offs = int(np.sum(up[after][1:] & ~up[after][:-1]))
    final = np.array(got["odom"][-1])
    print(f"cancel at {cancel_at} s: lift-offs after the cancel {lift_offs}, swinging at the cancel {bool(up[after][0])}, "
          f"final sole heights {z[-1].round(5).tolist()} m, base x {final[1]:.3f} m; result {res['error_msg']}")
    assert final[1] < 1.45  # stopped short of the goal
    assert lift_offs <= 1  # at most one more step starts after the cancel (counted from the client's decision)
    assert np.all(np.abs(z[-1]) < 0.003)  # ends in double support (kinematic touch-down: within 3 mm)
    assert np.all(np.abs(np.diff(np.array(got["odom"])[-5:, 1:3], axis=0)) < 1e-6)  # at rest


def test_second_goal_preempts_the_first(node):
    got = _client(node, "preempt")
    print(f"pre-emption: first goal {got['a']}, second goal {got['b']}, final base xy {np.round(got['final'], 4)}")
    assert got["accepted_a"] and got["accepted_b"]
    assert got["a"][0] == 6 and "pre-empted" in got["a"][2]  # ABORTED
    assert got["b"][0] == 4  # SUCCEEDED
    assert math.hypot(got["final"][0] - 0.5, got["final"][1]) <= 0.05


def test_cmd_vel_walks_and_stops(node):
    vx, seconds = 0.3, 5.0
    got = _client(node, "cmdvel", vx, seconds)
    odom = np.array(got["odom"])
    start = np.array(got["start"])
    walked = math.hypot(odom[-1, 1] - start[1], odom[-1, 2] - start[2])
    print(f"/cmd_vel vx {vx} m/s for {got['t_stop'] - got['t_start']:.2f} s of /clock ({got['sent']} samples): walked "
          f"{walked:.3f} m (commanded {vx * seconds:.2f} m), standing at /clock {odom[-1, 0]:.2f} s")
    assert got["t_stop"] - got["t_start"] >= seconds
    assert abs(walked - vx * seconds) <= 0.10 * vx * seconds
    tail = odom[odom[:, 0] > odom[-1, 0] - 1.0]
    assert np.all(tail[:, 3] == 0.0)  # zero twist for the last second: it stopped


@pytest.fixture(scope="module")
def sim_node():
    """One `wbc ros2 node --robot g1 --sim --time sim` for the module; yields (client environment, the node's stdout
    lines so far — a list a reader thread appends to)."""
    import threading

    env = dict(os.environ)
    env["CYCLONEDDS_URI"] = LOOPBACK
    env["ROS_DOMAIN_ID"] = str(dds_domain_id())
    env.pop("PYTHONPATH", None)
    proc = subprocess.Popen([sys.executable, "-m", "wbc", "ros2", "node", "--robot", "g1", "--sim", "--time", "sim"],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=str(HERE.parents[1]))
    first = proc.stdout.readline()
    if not first.startswith("wbc ros2 node: g1"):
        proc.kill()
        pytest.fail(first + proc.stderr.read())
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(iter(proc.stdout.readline, "")), daemon=True)
    reader.start()
    yield env, lines
    proc.terminate()
    proc.communicate(timeout=120)
    reader.join(timeout=10)


NUM = r"(-?\d+\.\d+)"


def test_sim_cmd_vel_walks_and_stops_in_double_support(sim_node):
    """`wbc ros2 node --sim`: /cmd_vel vx 0.3 m/s for 5 s of /clock → the MuJoCo robot (ID controller, realistic
    plant, estimated state) walks; /odom (the estimate) is checked against the plant's ground truth the node
    prints, and the robot stands on both feet (MuJoCo contact forces) once the commands stop."""
    import re

    env, lines_out = sim_node
    n0 = len(lines_out)
    vx, seconds, settle = 0.3, 5.0, 4.0
    got = _client(env, "cmdvel-sim", vx, seconds, settle)
    out = "".join(lines_out[n0:])
    odom = np.array(got["odom"])
    start = np.array(got["start"])
    walked = math.hypot(odom[-1, 1] - start[1], odom[-1, 2] - start[2])
    lines = re.findall(rf"sim: (walking|standing) at t = {NUM} s; ground truth base x {NUM} m, y {NUM} m, .*?"
                       rf"estimate x {NUM} m, y {NUM} m, .*?feet normal force left {NUM} N, right {NUM} N", out)
    assert lines, out[-2000:]
    kind, t_stand, gx, gy, ex, ey, fl, fr = lines[-1]
    t_stand, gx, gy, ex, ey, fl, fr = map(float, (t_stand, gx, gy, ex, ey, fl, fr))
    truth = math.hypot(gx - float(lines[0][2]), gy - float(lines[0][3]))
    print(out[-3000:])
    print(f"--sim /cmd_vel vx {vx} m/s for {got['t_stop'] - got['t_start']:.2f} s of /clock: /odom walked "
          f"{walked:.3f} m, plant ground truth {truth:.3f} m (from the first segment's start); standing at "
          f"t = {t_stand:.2f} s with feet normal forces {fl:.0f} N, {fr:.0f} N; estimate - truth at the stand "
          f"{math.hypot(ex - gx, ey - gy) * 1e3:.1f} mm")
    assert "FELL" not in out
    assert got["t_stop"] - got["t_start"] >= seconds
    # The walk advances in whole steps of vx T (T = 0.8 s, the node's step duration: 0.24 m), and the stop takes effect
    # at the first touch-down after the 0.5 s /cmd_vel timeout: where the last command falls in a step decides
    # whether one more step is taken. The distance is therefore vx · seconds within one step length (quiet: 1.447 m;
    # with both cores busy, one step more: 1.681 m, which a 10 % band called a failure).
    step = vx * 0.8
    assert abs(walked - vx * seconds) <= step
    assert abs(truth - walked) <= 0.05  # /odom (the estimate) vs the plant's ground truth, 5 cm
    assert kind == "standing" and got["t_stop"] < t_stand < got["t_end"]  # stopped after the commands stopped
    # the stop (0.5 s /cmd_vel timeout) takes effect at the next touch-down, then one closing step (0.8 s) and the
    # final double support of 1 s: standing within 0.5 + 0.8 + 0.8 + 1.0 s (+ 0.1 s late touch-downs)
    assert t_stand - got["t_stop"] <= 3.2
    assert fl > 50.0 and fr > 50.0  # double support: both feet loaded in MuJoCo
    tail = odom[odom[:, 0] > t_stand + 0.2]
    assert len(tail) > 10 and np.ptp(tail[:, 1]) < 0.01 and np.ptp(tail[:, 2]) < 0.01  # standing still
    js = np.array(got["joints"])
    assert len(js) > 100 and np.all(js[:, 1:5] == js[0, 1])  # names, position, velocity, effort all filled
    assert js[:, 5].max() > 1.0  # effort: the applied torques (N·m)


def test_sim_goal_cancel_stands_in_double_support_within_one_step(sim_node):
    """`wbc ros2 node --sim`: a NavigateToPose goal 1.5 m ahead / 0.5 m left, cancelled 3 s into the walk → the
    walk is re-planned in the double support of the next touch-down (the node's ground-truth print: MuJoCo's
    contact forces on both feet) within one step duration (0.8 s) of the cancel, at most one step (the closing
    one) lifts off after it (sole heights from the published /joint_states and /odom), and the robot stands on
    both feet with no fall."""
    import re

    env, lines_out = sim_node
    n0 = len(lines_out)
    step = 0.8  # s, the node's default step_duration
    got = _client(env, "goal", 1.5, 0.5, 0.0, 3.0)
    out = "".join(lines_out[n0:])
    res = got["result"]
    print(out[-3000:])
    assert got["cancel_return_code"] == 0 and res["status"] == 5, res  # ERROR_NONE, CANCELED
    assert "FELL" not in out
    t_cancel = float(re.search(rf"canceling at t = {NUM} s", out).group(1))
    replan = re.search(rf"sim: re-planned at a touch-down at t = {NUM} s \(closing step\);.*?feet normal force "
                       rf"left {NUM} N, right {NUM} N", out)
    assert replan, out[-2000:]
    t_ds, fl_ds, fr_ds = map(float, replan.groups())
    stand = re.findall(rf"sim: standing at t = {NUM} s; ground truth base x {NUM} m, y {NUM} m, .*?feet normal "
                       rf"force left {NUM} N, right {NUM} N", out)
    assert stand, out[-2000:]
    t_stand, gx, gy, fl, fr = map(float, stand[-1])
    t, z = _sole_heights(got["joint_names"], got["joints"], got["odom"], "g1")
    up = np.abs(z[:, 0] - z[:, 1]) > 0.02  # one sole 2 cm above the other (the swing rises 5 cm): single support
    after = t >= got["cancel_stamp"]
    lift_offs = int(np.sum(up[after][1:] & ~up[after][:-1]))
    print(f"--sim cancel at t = {t_cancel:.3f} s (node time): double support re-planned at t = {t_ds:.3f} s "
          f"(+{t_ds - t_cancel:.3f} s, feet {fl_ds:.0f} N, {fr_ds:.0f} N), lift-offs after the cancel {lift_offs}, "
          f"standing at t = {t_stand:.3f} s (+{t_stand - t_cancel:.3f} s) with feet {fl:.0f} N, {fr:.0f} N, "
          f"ground-truth base x {gx:.3f} m, y {gy:.3f} m; result {res['error_msg']}")
    assert 0.0 <= t_ds - t_cancel <= step + 0.1  # in double support at the next touch-down (+ late touch-down)
    assert fl_ds > 5.0 and fr_ds > 5.0  # MuJoCo: both soles on the floor there (a swinging sole carries 0 N)
    assert lift_offs <= 1  # the closing step only
    # then the closing step (one step) and the plan's final double support (1 s): standing
    assert t_stand - t_ds <= step + 1.0 + 0.1
    assert fl > 50.0 and fr > 50.0
    assert gx < 1.4  # stopped short of the goal


def test_parameters_update_rate_and_refusal(node):
    got = _client(node, "params", "wbc_node")
    assert set(got["list"]) >= {"update_rate", "step_duration", "max_velocity"}
    assert got["describe"]["type"] == 3 and got["describe"]["range"] == [[1.0, 500.0]]
    assert got["set_50"] == [True, ""]
    (ok1, why1), (ok2, why2) = got["set_bad"]
    assert not ok1 and "update_rate" in why1 and "500" in why1
    assert not ok2 and "max_velocity" in why2 and "string" in why2
    assert got["after_bad"] == [50.0, 0.3]  # nothing of the refused values applied
    s = np.array(got["stamps"])
    rate = (len(s) - 1) / (s[-1] - s[0])
    print(f"update_rate=50: {len(s)} /joint_states over {s[-1] - s[0]:.2f} s of node time -> {rate:.3f} Hz; "
          f"refused: {why1!r}, {why2!r}")
    assert s[-1] - s[0] >= 9.0
    assert abs(rate - 50.0) <= 0.02 * 50.0


def test_action_type_hashes_match_ros2():
    """RIHS01 of NavigateToPose's goal/result/feedback/service types and action_msgs' types, ours vs rosbags'
    ``hash_rihs01`` of the Jazzy definitions (nav2_msgs is not in rosbags' store: registered from the .action text)."""
    from rosbags.typesys import Stores, get_typestore, get_types_from_msg

    from wbc.ros2 import msgs

    ts = get_typestore(Stores.ROS2_JAZZY)
    action = "nav2_msgs/action/NavigateToPose"
    defs = {
        "_Goal": "geometry_msgs/PoseStamped pose\nstring behavior_tree\n",
        "_Result": "uint16 NONE=0\nuint16 UNKNOWN=9000\nuint16 FAILED_TO_LOAD_BEHAVIOR_TREE=9001\nuint16 TF_ERROR=9002\n"
                   "uint16 TIMEOUT=9003\nuint16 error_code\nstring error_msg\n",
        "_Feedback": "geometry_msgs/PoseStamped current_pose\nbuiltin_interfaces/Duration navigation_time\n"
                     "builtin_interfaces/Duration estimated_time_remaining\nint16 number_of_recoveries\n"
                     "float32 distance_remaining\n",
        "_FeedbackMessage": f"unique_identifier_msgs/UUID goal_id\n{action}_Feedback feedback\n",
        "_SendGoal_Request": f"unique_identifier_msgs/UUID goal_id\n{action}_Goal goal\n",
        "_SendGoal_Response": "bool accepted\nbuiltin_interfaces/Time stamp\n",
        "_GetResult_Request": "unique_identifier_msgs/UUID goal_id\n",
        "_GetResult_Response": f"int8 status\n{action}_Result result\n",
    }
    for suffix, text in defs.items():
        ts.register(get_types_from_msg(text, action + suffix))
    names = [action + s for s in defs] + ["action_msgs/msg/GoalInfo", "action_msgs/msg/GoalStatus",
                                          "action_msgs/msg/GoalStatusArray", "unique_identifier_msgs/msg/UUID",
                                          "rosgraph_msgs/msg/Clock", "geometry_msgs/msg/Twist"]
    for name in names:
        assert msgs.rihs01(name) == ts.hash_rihs01(name), name


def test_node_refuses_bad_options_before_work():
    for extra in (["--duration", "-1"], ["--sim", "--plant", "stiff"]):
        r = subprocess.run([sys.executable, "-m", "wbc", "ros2", "node", "--robot", "humanoid15", *extra],
                           capture_output=True, text=True, timeout=120, cwd=str(HERE.parents[1]))
        assert r.returncode == 2, (extra, r.stdout, r.stderr)
        assert "valid" in r.stderr.strip().splitlines()[-1], r.stderr


def test_sim_commanded_walk_typed_errors():
    from wbc.exceptions import InvalidInputError
    from wbc.robot import load_robot
    from wbc.sim.commanded import SimCommandedWalk

    walk = SimCommandedWalk(load_robot("g1"))
    for bad in ((-0.1, 0.0, 0.0), (0.5, 0.0, 0.0), (float("nan"), 0.0, 0.0), (0.1, 0.0, 0.9), (0.0, 0.5, 0.0)):
        with pytest.raises(InvalidInputError):
            walk.set_velocity(*bad)
    for value in (0.1, float("inf"), "1"):
        with pytest.raises(InvalidInputError):
            walk.step_duration = value
    with pytest.raises(InvalidInputError):
        walk.max_velocity = 0.0
    with pytest.raises(InvalidInputError):
        walk.set_goal(1.0, float("nan"), 0.0)
    with pytest.raises(InvalidInputError):
        SimCommandedWalk(load_robot("g1"), plant="stiff")
    assert np.all(walk.command == 0.0) and walk.idle and walk.step_duration == 0.8  # nothing applied


def test_commanded_walk_typed_errors():
    from wbc.exceptions import InvalidInputError
    from wbc.robot import load_robot
    from wbc.scenarios.commanded_walk import CommandedWalk

    walk = CommandedWalk(load_robot("humanoid15"))
    assert not walk.can_turn  # no hip yaw joint
    for bad in ((0.5, 0.0, 0.0), (float("nan"), 0.0, 0.0), (0.1, 0.0, 0.2), (0.0, 0.5, 0.0)):
        with pytest.raises(InvalidInputError):
            walk.set_velocity(*bad)
    for value in (0.1, float("inf"), "1"):
        with pytest.raises(InvalidInputError):
            walk.step_duration = value
    with pytest.raises(InvalidInputError):
        walk.max_velocity = -0.1
    with pytest.raises(InvalidInputError):
        walk.set_goal(1.0, float("nan"), 0.0)
    assert np.all(walk.command == 0.0) and walk.idle  # nothing applied


def test_node_trims_the_heap_periodically(monkeypatch):
    """spin(trim_every=T) calls malloc_trim once per T s of node time (counted, timed: module docstring "Memory"),
    and a bad period is refused with a typed error before any tick. glibc's malloc_trim returns 1 when it released
    memory: after freeing a fragmented heap (every second one of 20,000 small arrays) it must have something to
    give back."""
    import ctypes
    import ctypes.util

    from wbc.exceptions import InvalidInputError
    from wbc.robot import load_robot
    from wbc.ros2.node import ControllerNode

    monkeypatch.setenv("CYCLONEDDS_URI", LOOPBACK)
    monkeypatch.setenv("ROS_DOMAIN_ID", str(dds_domain_id()))
    node = ControllerNode(load_robot("humanoid15"), time_mode="sim")
    try:
        for bad in (0.0, -1.0, float("nan"), "10", True):
            with pytest.raises(InvalidInputError):
                node.spin(0.1, trim_every=bad)
        assert node.ticks == 0 and node.heap_trims == 0
        node.spin(0.2, trim_every=0.02)
        assert node.ticks == 100 and node.heap_trims == 10  # ticks 10, 20, ..., 100 (2 ms each)
        assert 0.0 < node.last_trim_s < 1.0
    finally:
        node.close()
    libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
    if hasattr(libc, "malloc_trim"):  # glibc (Linux): an independent call of the same function
        keep = [np.ones(2000) for _ in range(20000)]
        del keep[::2]
        assert libc.malloc_trim(0) == 1


def test_node_stops_at_the_tick_after_an_interrupt_it_was_told_of(monkeypatch):
    """spin(interrupted=f) asks f before every tick and raises KeyboardInterrupt when it says True: a Ctrl-C whose
    KeyboardInterrupt a C callback swallowed (the CLI's flag, wbc.cli.output.sigint_received) still stops the node
    after the tick it was in, not at --duration."""
    from wbc.robot import load_robot
    from wbc.ros2.node import ControllerNode

    monkeypatch.setenv("CYCLONEDDS_URI", LOOPBACK)
    monkeypatch.setenv("ROS_DOMAIN_ID", str(dds_domain_id()))
    node = ControllerNode(load_robot("humanoid15"), time_mode="sim")
    asked = []

    def interrupted():
        asked.append(node.ticks)
        return node.ticks >= 7  # the Ctrl-C arrives during tick 7

    try:
        with pytest.raises(KeyboardInterrupt):
            node.spin(1.0, interrupted=interrupted)
        assert node.ticks == 7 and asked == list(range(8))  # 1 s would be 500 ticks
    finally:
        node.close()
