"""wbc.ros2.backend: the choice of transport, and what a missing one says: the ROS 2 example and the node without
the extra stop at once with one line naming the package and the install command; --backend rclpy without rclpy
says how to get it."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).parents[2]


def _without(tmp_path, *packages) -> dict:
    """An environment in which importing ``packages`` fails (stub packages raising ImportError come first)."""
    import os

    for name in packages:
        stub = tmp_path / "stub" / name
        stub.mkdir(parents=True)
        (stub / "__init__.py").write_text(f"raise ImportError('No module named {name} (test stub)')\n")
    return dict(os.environ, PYTHONPATH=f"{tmp_path / 'stub'}{os.pathsep}{ROOT}")


def test_ros2_example_without_the_extra_stops_at_once_with_one_line(tmp_path):
    r = subprocess.run([sys.executable, str(ROOT / "examples" / "ros2_publish.py"), "--quick"],
                       env=_without(tmp_path, 'cyclonedds'), capture_output=True, text=True, timeout=120)
    print(r.stdout, r.stderr)
    assert r.returncode == 1
    assert r.stdout == ""  # no walk ran
    assert r.stderr.strip().splitlines() == [
        "ros2_publish.py: ROS 2 support needs the Python package 'cyclonedds': pip install -e \".[ros2]\" "
        "(from the wbc clone)"]


def test_node_dds_backend_without_the_extra_is_one_line(tmp_path):
    r = subprocess.run([sys.executable, "-m", "wbc", "ros2", "node", "--backend", "dds", "--duration", "0.1"],
                       env=_without(tmp_path, 'cyclonedds'), capture_output=True, text=True, timeout=120)
    assert r.returncode != 0 and "Traceback" not in r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "'cyclonedds'" in lines[0] and 'pip install -e ".[ros2]"' in lines[0], r.stderr


def test_rclpy_backend_without_rclpy_is_one_line(tmp_path):
    r = subprocess.run([sys.executable, "-m", "wbc", "ros2", "echo-joint", "right_knee", "--backend", "rclpy",
                        "--timeout", "0.1"], env=_without(tmp_path, "rclpy"), capture_output=True, text=True,
                       timeout=120)
    lines = r.stderr.strip().splitlines()
    assert r.returncode != 0 and len(lines) == 1, r.stderr
    assert "--backend rclpy needs rclpy" in lines[0] and "or use --backend dds" in lines[0]


def test_auto_without_rclpy_is_dds_and_a_bad_choice_is_refused(tmp_path):
    code = ("from wbc.ros2.backend import resolve\n"
            "from wbc.exceptions import InvalidInputError\n"
            "print(resolve('auto'), resolve('dds'))\n"
            "try:\n    resolve('fastdds')\nexcept InvalidInputError as e:\n    print(e)\n")
    r = subprocess.run([sys.executable, "-c", code], env=_without(tmp_path, "rclpy"), capture_output=True,
                       text=True, timeout=120)
    assert r.stdout.splitlines() == ["dds dds", "ROS 2 backend 'fastdds' is invalid: valid are ('auto', 'rclpy', 'dds')"]


def test_echo_joint_timeout_says_no_sample_came(tmp_path):
    """dds backend on a domain nobody publishes on: one line saying no sample came, exit 1."""
    import os

    from conftest import dds_domain_id

    env = dict(os.environ, ROS_DOMAIN_ID=str(dds_domain_id()), PYTHONPATH=str(ROOT))
    r = subprocess.run([sys.executable, "-m", "wbc", "ros2", "echo-joint", "right_knee", "--backend", "dds",
                        "--timeout", "1"], env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 1
    assert r.stdout.strip().splitlines() == [
        f"echo-joint: no /joint_states sample in 1 s (dds backend, domain {env['ROS_DOMAIN_ID']})"]
