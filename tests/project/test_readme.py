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
    """README's two commands: the first installs and walks (the walk compiles what it needs); the second is the last
    line of `.ci/run`, character for character."""
    text = README.read_text()
    ci = (README.parent / ".ci" / "run").read_text().strip().splitlines()
    commands = re.findall(r"## Two commands.*?```bash\n(.*?)\n```.*?```bash\n(.*?)\n```", text, re.S)[0]
    assert commands[0] == "pip install -e . && wbc walk"
    assert commands[1] == ci[-1]
    assert commands[1] == 'pip install -e ".[test,bench]" && wbc compile && python -m pytest -q -n 2 --dist loadfile'
