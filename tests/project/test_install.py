"""The core install: placo and Pink belong to the ``bench`` extra, imageio to ``video``. With them hidden, every
module outside ``wbc.bench`` imports, a non-bench command runs, and ``wbc bench`` refuses with a one-line error
(exit 2) naming the extra. The supported Python range in pyproject.toml is 3.11–3.13."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())

# the optional packages made unimportable, as on a core-only install (None in sys.modules: import raises
# ModuleNotFoundError, importlib.util.find_spec returns None)
HIDE = """
import sys
for name in ("placo", "pink", "imageio", "imageio_ffmpeg"):
    sys.modules[name] = None
"""


def _run(code: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", HIDE + code], capture_output=True, text=True, timeout=300,
                          cwd=ROOT)


def test_optional_packages_are_not_core_dependencies():
    core = " ".join(PYPROJECT["project"]["dependencies"]).lower()
    for name in ("placo", "pin-pink", "imageio"):
        assert name not in core, name
    extras = PYPROJECT["project"]["optional-dependencies"]
    assert any(d.startswith("placo") for d in extras["bench"])
    assert any(d.startswith("pin-pink") for d in extras["bench"])
    assert any(d.startswith("imageio-ffmpeg") for d in extras["video"])
    assert PYPROJECT["project"]["requires-python"] == ">=3.11,<3.14"


def test_every_non_bench_module_imports_without_placo_pink_imageio():
    code = """
import importlib, pkgutil, wbc
names = [m.name for m in pkgutil.walk_packages(wbc.__path__, "wbc.") if not m.name.startswith("wbc.bench") and m.name != "wbc.__main__"]
for name in names:
    importlib.import_module(name)
optional = {"placo", "pink", "imageio"}
bad = sorted(m for m, mod in sys.modules.items() if mod is not None and m.split(".")[0] in optional)
print(len(names), bad)
"""
    out = _run(code)
    assert out.returncode == 0, out.stderr[-2000:]
    count, bad = out.stdout.split(" ", 1)
    assert int(count) > 80 and bad.strip() == "[]", out.stdout


def test_non_bench_command_runs_and_bench_names_the_extra():
    out = _run("from wbc.cli import main; raise SystemExit(main(['robots']))")
    assert out.returncode == 0, out.stderr[-2000:]
    assert "talos" in out.stdout
    out = _run("from wbc.cli import main; raise SystemExit(main(['bench', '--quick']))")
    assert out.returncode == 2, (out.stdout[-500:], out.stderr[-2000:])
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "placo" in lines[0], out.stderr
    assert 'pip install -e ".[bench]" (from the wbc clone)' in lines[0], out.stderr
    assert out.stdout == ""  # refused before any work
