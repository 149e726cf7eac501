"""The README stays true: its Python example runs and does what its comments say."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

README = Path(__file__).resolve().parents[2] / "README.md"


def test_readme_python_example_runs_and_tracks():
    block = re.search(r"```python\n(.*?)```", README.read_text(), re.S).group(1)
    out = subprocess.run([sys.executable, "-c", block], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    com_mm, hand_mm = map(float, re.findall(r"([0-9.]+) mm", out.stdout))
    assert com_mm < 5.0 and hand_mm < 5.0, out.stdout


def test_readme_commands_match_ci():
    text = README.read_text()
    ci = (README.parent / ".ci" / "run").read_text()
    test_cmd = 'pip install -e ".[test,bench]" && wbc compile && python -m pytest -q -n 2 --dist loadfile'
    assert test_cmd in text and test_cmd in ci
    assert "pip install -e . && wbc compile && wbc walk" in text
