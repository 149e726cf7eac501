"""`--robot FILE.toml` on `wbc bench` and `wbc ros2 joint-publisher|node`: a robot file outside the catalog folder
is loaded by every command, a missing or malformed one is refused with one line and exit 2 before any work.

The robot file is humanoid15's, copied out of the catalog with an absolute URDF/SRDF path (a user's file)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import dds_domain_id

ROOT = Path(__file__).resolve().parents[2]
LOOPBACK = (
    '<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface name="lo"/></Interfaces>'
    "<AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex>"
    '<MaxAutoParticipantIndex>60</MaxAutoParticipantIndex><Peers><Peer address="127.0.0.1"/></Peers>'
    "</Discovery></Domain></CycloneDDS>"
)


@pytest.fixture(scope="module")
def robot_file(tmp_path_factory) -> Path:
    cat = (ROOT / "robots").resolve()  # the catalog in the repository (installed as wbc.robots)
    text = (cat / "humanoid15.toml").read_text()
    text = text.replace('urdf = "humanoid15.urdf"', f'urdf = "{cat / "humanoid15.urdf"}"')
    text = text.replace('srdf = "humanoid15.srdf"', f'srdf = "{cat / "humanoid15.srdf"}"')
    text = "name = \"my_humanoid\"\n" + text
    out = tmp_path_factory.mktemp("robotfile") / "my_humanoid.toml"
    out.write_text(text)
    return out


@pytest.fixture(scope="module")
def bad_file(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("badfile") / "bad.toml"
    out.write_text('urdf = "nowhere.urdf"\nleft_sole = "l"\nright_sole = "r"\ntorso = "t"\nsole_colour = 3\n')
    return out


def _env(dds: bool = False) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT)
    if dds:
        env["CYCLONEDDS_URI"] = LOOPBACK
        env["ROS_DOMAIN_ID"] = str(dds_domain_id())
    return env


def _run(args, timeout=300, dds=False):
    return subprocess.run([sys.executable, "-m", "wbc", *args], capture_output=True, text=True, timeout=timeout,
                          cwd=str(ROOT), env=_env(dds))


def _refused(r, *words):
    assert r.returncode == 2, (r.stdout[-2000:], r.stderr[-2000:])
    last = r.stderr.strip().splitlines()[-1]
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr
    for w in words:
        assert w in last, last


@pytest.mark.parametrize("command", [["bench", "--quick", "--sections", "gait"],
                                     ["ros2", "joint-publisher", "--duration", "1"],
                                     ["ros2", "node", "--time", "sim", "--duration", "0.5"]])
def test_missing_and_malformed_robot_files_refused(command, bad_file, tmp_path):
    _refused(_run([*command, "--robot", str(tmp_path / "missing.toml")], dds=True), "missing.toml")
    _refused(_run([*command, "--robot", str(bad_file)], dds=True), "sole_colour")


def test_bench_takes_a_robot_file(robot_file, tmp_path):
    pytest.importorskip("placo")
    r = _run(["bench", "--quick", "--sections", "gait", "--robot", str(robot_file), "--out-dir", str(tmp_path)])
    assert r.returncode in (0, 1), r.stderr[-3000:]  # 1 = a benchmark target missed, not an error
    results = json.loads((tmp_path / "results.json").read_text())
    assert results["config"]["robot"] == str(robot_file)
    assert "my_humanoid" in json.dumps(results["gait"])


@pytest.mark.parametrize("command", [["ros2", "joint-publisher", "--steps", "2", "--duration", "1"],
                                     ["ros2", "node", "--time", "sim", "--duration", "0.5"]])
def test_ros2_takes_a_robot_file(command, robot_file):
    pytest.importorskip("cyclonedds")
    r = _run([*command, "--robot", str(robot_file)], dds=True)
    assert r.returncode == 0, r.stderr[-3000:]
    assert r.stdout.startswith(f"wbc {command[0]} {command[1]}: my_humanoid"), r.stdout[:500]
