"""Signal exit codes of the CLI commands: SIGTERM ends a run with 143 and SIGINT with 130, one line on stderr, no
traceback, no temporary file left (the signal sent once the command's handlers are installed, as read from
/proc/PID/status)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
from issue62_inputs import catches  # noqa: E402  (reads SigCgt of /proc/PID/status)


@pytest.fixture(autouse=True)
def _forget_the_ctrl_c():
    """The in-process tests below leave the run's Ctrl-C flag set (``wbc.cli.output.sigint_received``); a later test
    of the same pytest worker that compiles kernels (``tests/cli/test_kernels.py``) would then stop on it."""
    yield
    from wbc.cli.output import clear_sigint

    clear_sigint()


def _signalled(args: list[str], sig: int, cwd: Path, settle: float = 2.0) -> subprocess.CompletedProcess:
    """Run `wbc args`, send ``sig`` ``settle`` s after its SIGTERM handler is installed (the command runs), return
    the finished process. A ``ros2`` command runs on a DDS domain of its own (loopback, wbc's default)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    if args[0] == "ros2":
        from conftest import dds_domain_id

        env["ROS_DOMAIN_ID"] = str(dds_domain_id())
        env.pop("CYCLONEDDS_URI", None)
    proc = subprocess.Popen([sys.executable, "-m", "wbc", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env=env, cwd=cwd, preexec_fn=lambda: signal.signal(signal.SIGINT,
                                                                                           signal.SIG_DFL))
    try:
        deadline = time.monotonic() + 300
        while not catches(proc.pid, signal.SIGTERM):
            assert proc.poll() is None, proc.communicate()[1][-2000:]
            assert time.monotonic() < deadline, "the command did not start within 300 s"
            time.sleep(0.01)
        time.sleep(settle)
        assert proc.poll() is None, "the command ended before the signal"
        proc.send_signal(sig)
        out, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return subprocess.CompletedProcess(args, proc.returncode, out, err)


SIGNALS = {"SIGTERM": (signal.SIGTERM, 143, "terminated (SIGTERM)"), "SIGINT": (signal.SIGINT, 130, "interrupted")}
COMMANDS = {
    "walk": ["walk", "--robot", "humanoid15", "--steps", "400", "--quiet", "--log", "run.npz", "--json", "run.json"],
    "campaign": ["campaign", "run", "--kind", "push", "--trials", "50", "--no-plots", "--no-progress", "--results",
                 "c", "--set", "scenario.robot=humanoid15", "--set", "scenario.steps=2"],
    "ros2 node": ["ros2", "node", "--robot", "humanoid15", "--backend", "dds", "--duration", "600"],
}


@pytest.fixture(scope="module")
def signalled(tmp_path_factory):
    """Every (command, signal) pair run at once (each in its own folder, its own thread): (result, folder)."""
    from concurrent.futures import ThreadPoolExecutor

    pairs = [(c, s) for c in COMMANDS for s in SIGNALS]
    folders = {p: tmp_path_factory.mktemp(f"{p[0]}-{p[1]}") for p in pairs}
    with ThreadPoolExecutor(len(pairs)) as pool:
        futures = {p: pool.submit(_signalled, COMMANDS[p[0]], SIGNALS[p[1]][0], folders[p]) for p in pairs}
    return {p: (f.result(), folders[p]) for p, f in futures.items()}


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc (Linux only)")
@pytest.mark.parametrize("sig", list(SIGNALS))
@pytest.mark.parametrize("command", list(COMMANDS))
def test_a_signal_ends_a_command_with_its_exit_code(signalled, command, sig):
    r, folder = signalled[command, sig]
    _, code, words = SIGNALS[sig]
    assert r.returncode == code, (r.returncode, r.stderr[-2000:])
    err = r.stderr.strip()
    assert "Traceback" not in err and words in err, err[-2000:]
    assert len(err.splitlines()) == 1, err
    left = [p.name for p in folder.rglob("*") if ".partial" in p.name or p.name.endswith(".tmp")]
    assert left == [], left


@pytest.mark.parametrize("cause, code, line", [
    (KeyboardInterrupt, 130, "wbc walk: interrupted (Ctrl-C); no output written for the unfinished step"),
    ("terminated", 143, "wbc walk: terminated (SIGTERM)")])
def test_a_signal_inside_a_compiled_kernel_call_ends_with_its_exit_code(monkeypatch, capsys, cause, code, line):
    """A signal whose handler runs while a numba kernel is being called (the handler's exception set when the kernel
    returns) reaches the command as ``SystemError`` raised from it (CPython: "returned a result with an exception
    set"; seen once in the suite's SIGINT test under load): the run still ends with the signal's exit code and one
    line, and a SystemError of another cause is not taken for a signal."""
    import wbc.cli as cli
    from wbc.cli.output import Terminated

    exc = KeyboardInterrupt() if cause is KeyboardInterrupt else Terminated()

    def kernel_call(args):
        raise SystemError("CPUDispatcher(<function _tick_kernel>) returned a result with an exception set") from exc

    monkeypatch.setattr(cli, "check_args", kernel_call)
    assert cli.main(["walk"]) == code
    assert capsys.readouterr().err.strip() == line

    def other(args):
        raise SystemError("a C extension's own error") from ValueError("x")

    monkeypatch.setattr(cli, "check_args", other)
    with pytest.raises(SystemError, match="own error"):
        cli.main(["walk"])


def test_a_system_error_after_a_ctrl_c_ends_with_130(monkeypatch, capsys):
    """A SystemError that names no signal in its chain, raised after the run's SIGINT handler saw a Ctrl-C (the
    handler's exception swallowed by a callback and another error left set): exit 130 and the one line."""
    import signal as sig

    import wbc.cli as cli
    from wbc.cli import output

    def kernel_call(args):
        try:
            output.on_sigint(sig.SIGINT, None)  # the run's handler: remembers the Ctrl-C, raises KeyboardInterrupt
        except KeyboardInterrupt:
            pass  # (swallowed, as by a C callback)
        raise SystemError("CPUDispatcher(<function _tick_kernel>) returned a result with an exception set")

    monkeypatch.setattr(cli, "check_args", kernel_call)
    assert cli.main(["walk"]) == 130
    assert capsys.readouterr().err.strip() == ("wbc walk: interrupted (Ctrl-C); no output written for the unfinished "
                                               "step")
