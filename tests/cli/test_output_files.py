"""The files of a run under kills: the JSON summary and the npz log are replaced as a pair (a SIGTERM during the
renames is handled after both: never a new summary beside an old log), an interrupted write leaves the previous
pair and no temporary, and the temporaries a SIGKILL leaves are removed by the next write."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]

linux_only = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="POSIX signals")

# A writer process: `write_outputs` of a summary and a log, both holding VALUE; the log's save calls HOOK first.
_WRITER = textwrap.dedent("""
    import os, signal, sys, time
    from types import SimpleNamespace
    import numpy as np
    from wbc.cli.output import write_outputs

    def terminated(signum, frame):  # as `wbc` does: SIGTERM unwinds the run, exit code 143
        raise SystemExit(143)

    signal.signal(signal.SIGTERM, terminated)
    folder, value, hook = sys.argv[1], float(sys.argv[2]), sys.argv[3]

    class Run:
        def save(self, f):
            if hook == "sleep":  # killed while it writes the log
                f.write(b"PK\\x03\\x04" + bytes(4096))
                f.flush()
                print("writing", flush=True)
                time.sleep(600)
            np.savez(f, t=np.full(10, value))

    if hook == "term-between-renames":  # SIGTERM right after the first file is renamed into place
        real = os.replace
        def replace(src, dst):
            real(src, dst)
            os.kill(os.getpid(), signal.SIGTERM)
        os.replace = replace
    args = SimpleNamespace(json=os.path.join(folder, "run.json"), log=os.path.join(folder, "run.npz"), plot=None,
                           out=None)
    write_outputs(args, {"value": value}, Run(), robot=None)
""")


def _writer(folder: Path, value: float, hook: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    return subprocess.Popen([sys.executable, "-c", _WRITER, str(folder), str(value), hook], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)


def _pair(folder: Path) -> tuple[float, float]:
    """(summary value, log value) of the pair in ``folder``."""
    with np.load(folder / "run.npz") as z:
        log = float(z["t"][0])
    return json.loads((folder / "run.json").read_text())["value"], log


def _first_pair(folder: Path) -> None:
    proc = _writer(folder, 1.0, "none")
    assert proc.wait(timeout=120) == 0, proc.stderr.read()[-2000:]
    assert _pair(folder) == (1.0, 1.0)


@linux_only
def test_sigterm_between_the_two_renames_still_replaces_the_pair(tmp_path):
    _first_pair(tmp_path)
    proc = _writer(tmp_path, 2.0, "term-between-renames")
    assert proc.wait(timeout=120) == 143, proc.stderr.read()[-2000:]
    assert _pair(tmp_path) == (2.0, 2.0)  # both new: the SIGTERM was handled after the second rename
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.json", "run.npz"]


def _killed_while_writing(folder: Path, sig: int) -> subprocess.Popen:
    """A writer of a second pair into ``folder`` (holding 1.0), sent ``sig`` while it writes the log; waited for."""
    _first_pair(folder)
    proc = _writer(folder, 2.0, "sleep")
    assert proc.stdout.readline().strip() == "writing"
    proc.send_signal(sig)
    proc.wait(timeout=120)
    assert _pair(folder) == (1.0, 1.0)  # the previous pair, untouched
    return proc


@linux_only
def test_sigterm_while_writing_keeps_the_previous_pair_and_leaves_no_partial(tmp_path):
    proc = _killed_while_writing(tmp_path, signal.SIGTERM)
    assert proc.returncode == 143, proc.stderr.read()[-2000:]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.json", "run.npz"]


@linux_only
def test_partials_left_by_a_sigkill_are_removed_by_the_next_write(tmp_path):
    proc = _killed_while_writing(tmp_path, signal.SIGKILL)
    left = sorted(p.name for p in tmp_path.iterdir() if ".partial" in p.name)
    assert len(left) == 2 and all(n.startswith(f".run.{proc.pid}-") for n in left), left  # json and npz temps
    proc = _writer(tmp_path, 3.0, "none")
    assert proc.wait(timeout=120) == 0, proc.stderr.read()[-2000:]
    assert _pair(tmp_path) == (3.0, 3.0)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.json", "run.npz"]
