"""`wbc ros2 node` exit codes a script can trust: 143 after SIGTERM, 130 after Ctrl-C (SIGINT), 0 at --duration,
2 for a bad --max-rtf (dds backend, DDS confined to 127.0.0.1 on a fresh domain)."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import dds_domain_id

pytest.importorskip("cyclonedds", reason="the optional extra wbc[ros2] is not installed (cyclonedds missing)")

ROOT = Path(__file__).parents[2]


def _node(tmp_path, *extra):
    env = dict(os.environ, ROS_DOMAIN_ID=str(dds_domain_id()), PYTHONPATH=str(ROOT))
    env.pop("CYCLONEDDS_URI", None)  # wbc's own loopback configuration
    out = tmp_path / "node.out"
    with open(out, "w") as f:
        # SIGINT at its default in the node: a process started with SIGINT ignored keeps it ignored (wbc's CLI, as
        # POSIX shells expect of background jobs), and a test process may have it ignored (seen in full-suite runs)
        proc = subprocess.Popen([sys.executable, "-m", "wbc", "ros2", "node", "--backend", "dds", *extra], env=env,
                                stdout=f, stderr=subprocess.PIPE, text=True,
                                preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    return proc, out


@pytest.mark.parametrize("sig, code", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_node_exit_code_after_a_signal(tmp_path, sig, code):
    proc, out = _node(tmp_path, "--time", "sim", "--max-rtf", "1")
    while proc.poll() is None and "wbc ros2 node:" not in out.read_text():
        time.sleep(0.1)
    time.sleep(0.5)  # in the loop
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    text = out.read_text()
    print(text, err)
    assert proc.returncode == code
    assert "node: " in text.splitlines()[-1] and "Traceback" not in err  # the summary, no traceback


def test_node_duration_exits_0_and_bad_max_rtf_is_refused(tmp_path):
    proc, out = _node(tmp_path, "--time", "sim", "--duration", "0.2")
    proc.communicate(timeout=120)
    assert proc.returncode == 0 and "node: 100 ticks, node time 0.200 s" in out.read_text()
    proc, out = _node(tmp_path, "--max-rtf", "2")  # real time: the cap has no meaning
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 2 and err.strip().splitlines()[-1].endswith(
        "--max-rtf 2 needs --time sim (real time runs at 1)")
    proc, out = _node(tmp_path, "--time", "sim", "--max-rtf", "-1")
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 2 and "'-1' is invalid: valid is a finite number > 0" in err


@pytest.mark.parametrize("options, real", [
    ({}, False),  # a logged/offline run: reproducible
    ({"live": False, "ros2": False, "ros2_unpaced": False}, False),
    ({"live": True}, True),  # paced by the viewer
    ({"live": False, "ros2": True, "ros2_unpaced": False}, True),  # paced by the publisher
    ({"live": False, "ros2": True, "ros2_unpaced": True}, False),  # as fast as it goes: not real time
    ({"live": True, "ros2": True, "ros2_unpaced": True}, True),
])
def test_real_time_is_live_or_a_paced_ros2_run(options, real):
    """wbc.cli.ros2.real_time: where a run's time is real (the controller's clock guard is on there, only there)."""
    from argparse import Namespace

    from wbc.cli.ros2 import real_time

    assert real_time(Namespace(**options)) is real
