"""Every example in examples/ is at most 80 lines, has a --quick flag, and runs with it: exit 0 (each example
exits 1 when what it demonstrates did not happen: a fall, a failed walk, a missing output)."""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import dds_domain_id

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = sorted((ROOT / "examples").glob("*.py"))


def test_the_examples_the_docs_promise_exist():
    names = {p.stem for p in EXAMPLES}
    assert {"id_balance_push", "custom_gait", "mujoco_closed_loop", "recording_with_overlays", "plots_from_log",
            "ros2_publish", "custom_task", "custom_robot"} <= names


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda p: p.stem)
def test_example_runs_quick(example, tmp_path):
    text = example.read_text()
    assert len(text.splitlines()) <= 80, f"{example.name}: {len(text.splitlines())} lines"
    assert "--quick" in text
    private = re.findall(r"\b(?:from|import) [\w.]*\b_\w+|\.\_(?!_)\w+|import \_\w+", text)
    assert not private, f"{example.name} uses private names {private}: an API gap"
    if "wbc.ros2" in text and importlib.util.find_spec("cyclonedds") is None:
        pytest.skip("the ros2 extra (cyclonedds) is not installed")
    from wbc.ros2.dds import loopback_uri

    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
               MPLBACKEND="Agg", CYCLONEDDS_URI=loopback_uri(), ROS_DOMAIN_ID=str(dds_domain_id()),
               TMPDIR=str(tmp_path))
    out = subprocess.run([sys.executable, str(example), "--quick"], capture_output=True, text=True, timeout=300,
                         env=env, cwd=tmp_path)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    assert out.stdout.strip()


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda p: p.stem)
def test_example_help_is_its_whole_first_paragraph(example):
    """`--help` shows the docstring's whole first paragraph, not its first line cut mid-sentence."""
    out = subprocess.run([sys.executable, str(example), "--help"], capture_output=True, text=True, timeout=120,
                         env=dict(os.environ, COLUMNS="2000"), cwd=ROOT)
    assert out.returncode == 0, out.stderr[-2000:]
    doc = example.read_text().split('"""')[1]
    first = " ".join(doc.split("\n\n")[0].split())
    assert first in out.stdout, out.stdout
    assert first.endswith((".", ")")), first
