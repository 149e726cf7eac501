"""No Ray process outlives its driver: a small campaign on a local Ray (one worker, a trial that sleeps) whose
driver is killed by SIGKILL mid-trial leaves none of the processes it started (before: ``ray::DashboardAgent`` and
``ray::RuntimeEnvAgent`` ran on)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

try:
    import ray  # noqa: F401

    HAVE_RAY = True
except ImportError:  # pragma: no cover
    HAVE_RAY = False


def _tree(pid: int) -> dict[int, str]:
    """pid → command line of every descendant of ``pid`` (from /proc, children of all threads)."""
    out, todo = {}, [pid]
    while todo:
        parent = todo.pop()
        for task in os.listdir(f"/proc/{parent}/task") if os.path.isdir(f"/proc/{parent}/task") else []:
            try:
                children = [int(x) for x in open(f"/proc/{parent}/task/{task}/children").read().split()]
            except OSError:
                continue
            for c in children:
                if c not in out:
                    out[c] = _cmdline(c) or ""
                    todo.append(c)
    return out


def _cmdline(pid: int) -> str | None:
    try:
        return open(f"/proc/{pid}/cmdline", "rb").read().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return None


@pytest.mark.skipif(not HAVE_RAY or not sys.platform.startswith("linux"), reason="needs Ray and Linux /proc")
def test_killing_a_ray_campaigns_driver_leaves_no_ray_process(tmp_path):
    started = tmp_path / "started"
    driver = tmp_path / "driver.py"
    driver.write_text(textwrap.dedent(f"""
        import time
        from wbc.campaign import RayExecutor, default_spec, run

        def sleeping(spec, params):
            open({str(started)!r}, "w").close()
            time.sleep(600)

        run(default_spec("push", trials=1, seed=0), {str(tmp_path / "out")!r}, executor=RayExecutor(workers=1),
            trial_fn=sleeping, progress=False)
    """))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.Popen([sys.executable, str(driver)], env=env, cwd=tmp_path, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    tree = {}
    try:
        deadline = time.monotonic() + 300
        while not started.exists():
            assert proc.poll() is None, "the driver ended before its trial started"
            assert time.monotonic() < deadline, "no trial started within 300 s"
            time.sleep(0.2)
        tree = _tree(proc.pid)
        assert any("raylet" in c for c in tree.values()) and any("ray::" in c for c in tree.values()), tree
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=60)
        deadline = time.monotonic() + 60  # the watchdog polls every 0.5 s; Ray's own processes exit with the driver
        alive = tree
        while alive and time.monotonic() < deadline:
            time.sleep(0.5)
            alive = {p: c for p, c in tree.items() if _cmdline(p) == c}
        assert alive == {}, alive
    finally:
        if proc.poll() is None:
            proc.kill()
        for pid, cmd in tree.items():  # never leave a process behind, whatever failed
            if _cmdline(pid) == cmd:
                os.kill(pid, signal.SIGKILL)
