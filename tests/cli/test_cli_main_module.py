"""``python -m wbc`` (wbc/__main__.py): the exit code is main()'s, also after a Ctrl-C was caught inside code that an
extension ran through ``PyRun_String``. CPython keeps a record of such an interrupt and, under ``python -m``, ends
the process by SIGINT after finalization whatever the exit code (seen in CI: `wbc ros2 node` returned −2, not 130,
after printing its interrupted line)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

# Runs `wbc robots` once in-process (every module it needs loaded: an import may itself clear the record), then lets
# a KeyboardInterrupt leave a PyRun_String frame and catches it, then runs `python -m wbc robots` in the same process.
_INTERRUPTED_THEN_WBC = """
import contextlib, ctypes, io, runpy, sys
from wbc.cli import main
with contextlib.redirect_stdout(io.StringIO()):
    assert main(["robots"]) == 0
run = ctypes.pythonapi.PyRun_String
run.restype = ctypes.py_object
run.argtypes = [ctypes.c_char_p, ctypes.c_int, ctypes.py_object, ctypes.py_object]
scope = {}
try:
    run(b"raise KeyboardInterrupt", 257, scope, scope)  # 257: Py_file_input
except KeyboardInterrupt:
    print("caught", file=sys.stderr)
sys.argv = ["wbc", "robots"]
runpy.run_module("wbc", run_name="__main__")
"""


def _run_as_module(tmp_path: Path, source: str) -> subprocess.CompletedProcess:
    (tmp_path / "interrupted_then_wbc.py").write_text(source)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), str(ROOT), os.environ.get("PYTHONPATH", "")])}
    return subprocess.run([sys.executable, "-m", "interrupted_then_wbc"], capture_output=True, text=True, env=env,
                          cwd=tmp_path, timeout=300)


def test_a_caught_interrupt_does_not_turn_the_exit_code_into_a_signal(tmp_path):
    r = _run_as_module(tmp_path, _INTERRUPTED_THEN_WBC)
    assert "caught" in r.stderr and "talos" in r.stdout, r.stderr[-2000:]
    assert r.returncode == 0, (r.returncode, r.stderr[-2000:])


def test_the_reproduction_needs_the_fix(tmp_path):
    """The same process without wbc/__main__.py's clearing (main() called directly, then sys.exit) dies by SIGINT:
    the case above would pass for the wrong reason if CPython no longer did this."""
    source = _INTERRUPTED_THEN_WBC.replace('runpy.run_module("wbc", run_name="__main__")',
                                           "sys.exit(main(['robots']))")
    r = _run_as_module(tmp_path, source)
    assert "caught" in r.stderr and "talos" in r.stdout, r.stderr[-2000:]
    assert r.returncode == -2, (r.returncode, r.stderr[-2000:])
