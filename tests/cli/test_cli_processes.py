"""Processes and files of a run under faults: the live viewer's meshcat server dies with its run (SIGTERM, SIGKILL,
SIGINT of the `wbc` process), a malformed message on its zmq socket is answered and dropped, outputs are written
atomically (concurrent writers, an interrupt during the write), Ctrl-C exits 130 without a traceback."""

from __future__ import annotations

import importlib.util
import json
import multiprocessing
import os
import signal
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import dds_domain_id

ROOT = Path(__file__).resolve().parents[2]

linux_only = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc (Linux only)")


def _kill_live():
    spec = importlib.util.spec_from_file_location("kill_live", ROOT / "benchmarks" / "kill_live.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@linux_only
@pytest.mark.parametrize("sig", [signal.SIGKILL])  # SIGTERM too in benchmarks/kill_live.py (20 s per signal)
def test_live_server_dies_with_its_run(sig):
    r = _kill_live().kill_once(sig, robot="humanoid15", timeout=15.0)
    assert len(r["pids"]) >= 2 and len(r["ports"]) >= 2, r  # wbc and its meshcat server, zmq + web ports
    assert r["left_pids"] == [] and r["left_ports"] == [], r
    assert r["exit_code"] == (143 if sig == signal.SIGTERM else -9), r
    assert not r["traceback"], r["stderr"][-2000:]


@linux_only
def test_ctrl_c_while_waiting_exits_130_and_keeps_the_previous_outputs(tmp_path):
    log, js = tmp_path / "run.npz", tmp_path / "run.json"
    np.savez(log, t=np.arange(3.0))
    js.write_text('{"previous": true}\n')
    before = (log.read_bytes(), js.read_bytes())
    r = _kill_live().kill_once(signal.SIGINT, robot="humanoid15", timeout=15.0, settle=3.0,
                               extra=["--log", str(log), "--json", str(js)])
    assert r["exit_code"] == 130, r
    # --live waited for a browser: in the 3 s after the URL the motion did not start (nothing more printed);
    # that a connection starts it is tests/viz/test_recording_browser.py::test_live_page_of_a_running_walk
    assert "starts when it connects" in r["url_line"] and r["stdout_after_url"] == "", r
    assert not r["traceback"] and "interrupted" in r["stderr"], r["stderr"][-2000:]
    assert r["left_pids"] == [] and r["left_ports"] == [], r
    assert (log.read_bytes(), js.read_bytes()) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.json", "run.npz"]  # no temporary left


def test_malformed_zmq_messages_are_dropped_and_the_server_goes_on(tmp_path):
    import zmq

    from wbc.viz import _server

    log = tmp_path / "server.log"
    proc, zmq_url, web_url = _server.start(log=log)
    sock = zmq.Context.instance().socket(zmq.REQ)
    sock.setsockopt(zmq.LINGER, 0)
    sock.setsockopt(zmq.RCVTIMEO, 10000)
    try:
        sock.connect(zmq_url)
        for frames in ([b"\xff\xfe\x00garbage"], [b"delete", b"\xff\xfe", b""], [b"set_transform", b"/a"],
                       [b"no such command"]):
            sock.send_multipart(frames)
            reply = sock.recv()
            assert reply.startswith(b"error"), (frames, reply)
        sock.send(b"url")
        assert sock.recv().decode() == web_url  # still serving
        assert proc.poll() is None
    finally:
        sock.close()
        proc.kill()
        proc.wait()
        proc.stdin.close()
        proc.stdout.close()
    text = log.read_text()
    assert text.count("dropped a malformed message") == 2, text  # the two meshcat's own handler raised on


class _FakeRun:
    """Anything with save(file) writing an npz: the interface of the run records."""

    def __init__(self, value: float, n: int):
        self.value, self.n = value, n

    def save(self, f):
        np.savez(f, t=np.full(self.n, self.value), q=np.full((self.n, 8), self.value))


def _writer(path: str, value: float, times: int) -> None:
    from wbc.cli.output import write_json, write_log

    for _ in range(times):
        write_log(Path(path), _FakeRun(value, 100_000))
        write_json(Path(path).with_suffix(".json"), {"value": value, "pad": [value] * 20000})


def test_concurrent_runs_never_corrupt_a_log(tmp_path):
    """Two processes write the same --log/--json 8 times each while the test reads them: every read is a complete
    file of one writer (all values equal), and no temporary is left."""
    path = tmp_path / "same.npz"
    ctx = multiprocessing.get_context("fork" if sys.platform.startswith("linux") else "spawn")
    procs = [ctx.Process(target=_writer, args=(str(path), float(v), 8)) for v in (1, 2)]
    for p in procs:
        p.start()
    reads = 0
    while any(p.is_alive() for p in procs):
        if path.exists():
            with np.load(path) as z:
                t, q = z["t"], z["q"]
            assert t.size == 100_000 and len(np.unique(t)) == 1 and np.all(q == t[0])
            js = path.with_suffix(".json")
            if js.exists():
                d = json.loads(js.read_text())
                assert set(d["pad"]) == {d["value"]}
            reads += 1
    for p in procs:
        p.join()
        assert p.exitcode == 0
    assert reads > 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["same.json", "same.npz"]


def test_an_interrupt_during_the_write_leaves_the_previous_file(tmp_path, monkeypatch):
    """Ctrl-C in the middle of writing the log: the previous log is intact, no partial file is left."""
    from wbc.cli.output import write_log

    path = tmp_path / "run.npz"
    write_log(path, _FakeRun(1.0, 1000))
    before = path.read_bytes()

    class Interrupted(_FakeRun):
        def save(self, f):
            f.write(b"PK\x03\x04" + b"\x00" * 4096)  # the first bytes of a zip, then Ctrl-C
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        write_log(path, Interrupted(2.0, 1000))
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["run.npz"]


def test_ctrl_c_during_a_run_exits_130_without_output(tmp_path, monkeypatch, capsys):
    """Ctrl-C while the controller runs: exit code 130, one line on stderr, the previous files untouched."""
    import wbc.scenarios.balance as balance

    from wbc.cli import main

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(balance, "run_balance", interrupted)
    log = tmp_path / "b.npz"
    np.savez(log, t=np.zeros(2))
    before = log.read_bytes()
    code = main(["balance", "shift", "--robot", "humanoid15", "--quiet", "--log", str(log)])
    err = capsys.readouterr().err
    assert code == 130 and "interrupted" in err and "Traceback" not in err
    assert log.read_bytes() == before


def test_log_without_suffix_prints_the_file_it_wrote(tmp_path, capsys):
    """`--log X` writes X.npz (numpy's rule) and says X.npz."""
    import argparse

    from wbc.cli.output import write_log
    from wbc.cli.validate import check_outputs

    target = tmp_path / "shift"
    args = argparse.Namespace(log=target, json=None, out=None, plot=None)
    check_outputs(args)
    write_log(args.log, _FakeRun(1.0, 10))
    out = capsys.readouterr().out
    assert out.strip() == f"log written to {target}.npz"
    assert [p.name for p in tmp_path.iterdir()] == ["shift.npz"]


def test_dds_uses_loopback_by_default_and_says_so(monkeypatch):
    """Without CYCLONEDDS_URI, a wbc participant is confined to `lo` (multicast off); --ros2-interface is in the
    help of every command that opens DDS; a user's CYCLONEDDS_URI is left alone."""
    pytest.importorskip("cyclonedds")
    from wbc.cli import build_parser
    from wbc.ros2 import dds

    monkeypatch.setenv("CYCLONEDDS_URI", "")  # recorded, restored after the test
    monkeypatch.delenv("CYCLONEDDS_URI")
    monkeypatch.setattr(dds, "_chosen", [])  # as in a fresh process
    part = dds.participant()
    assert os.environ.get("CYCLONEDDS_URI") == dds.loopback_uri()
    del part
    mine = dds.loopback_uri().replace("60", "61")  # the user's own configuration wins
    monkeypatch.setenv("CYCLONEDDS_URI", mine)
    dds.use_interface("eth0")
    assert os.environ["CYCLONEDDS_URI"] == mine
    assert "<AllowMulticast>false</AllowMulticast>" in dds.loopback_uri() and 'name="lo"' in dds.loopback_uri()
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    for name in ("walk", "balance", "sim"):
        text = " ".join(sub.choices[name].format_help().split())
        assert "--ros2-interface" in text and "127.0.0.1 only" in text, name


def test_bench_report_is_moved_into_place_whole(tmp_path):
    """`wbc bench` writes its report in a temporary folder of --out-dir and renames each file; a failing writer
    leaves the previous report and no temporary folder."""
    from wbc.cli.bench import _write_atomically

    out = tmp_path / "results"
    out.mkdir()
    (out / "results.json").write_text('{"previous": 1}')

    def writer(results, folder):
        (folder / "results.json").write_text(json.dumps(results))
        (folder / "results.md").write_text("# report\n")
        return {"json": folder / "results.json", "markdown": folder / "results.md"}

    def failing(results, folder):
        (folder / "results.json").write_text('{"half')
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        _write_atomically({"new": 2}, out, failing)
    assert json.loads((out / "results.json").read_text()) == {"previous": 1}
    assert sorted(p.name for p in out.iterdir()) == ["results.json"]
    paths = _write_atomically({"new": 2}, out, writer)
    assert paths["json"] == out / "results.json" and json.loads(paths["json"].read_text()) == {"new": 2}
    assert sorted(p.name for p in out.iterdir()) == ["results.json", "results.md"]


@linux_only
# 400 steps is minutes of work on any machine: a quiet one finished a 40-step walk inside the 6 s delay (exit 0)
@pytest.mark.parametrize("command,delay", [(["walk", "--steps", "400"], 1.5), (["walk", "--steps", "400"], 6.0),
                                           (["sim", "walk", "--steps", "400"], 6.0)],
                         ids=["walk-while-loading", "walk-mid-run", "sim-walk-mid-run"])
def test_sigint_to_a_running_cli_keeps_the_previous_log(tmp_path, command, delay):
    """SIGINT to a `wbc ... --log X` process (a real one, as Ctrl-C in a terminal sends it), while it loads or
    mid-run: exit code 130, one line on stderr and no traceback, and the previous X.npz either byte-identical or
    replaced by a complete loadable log; no temporary file left next to it."""
    import subprocess
    import time

    log = tmp_path / "X.npz"
    np.savez(log, t=np.arange(3.0))
    before = log.read_bytes()
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    # a shell that started the test suite in the background leaves SIGINT ignored, and children inherit that:
    # the child gets the default disposition, as a program started from a terminal has
    proc = subprocess.Popen([sys.executable, "-m", "wbc", *command, "--log", str(log), "--quiet"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    time.sleep(delay)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, (proc.returncode, err[:1500], err[-1500:])
    assert "Traceback" not in err and "interrupted (Ctrl-C)" in err, err[-2000:]
    assert len(err.strip().splitlines()) == 1, err
    if log.read_bytes() != before:  # a complete new log
        with np.load(log) as z:
            assert z["q"].shape[0] == z["t"].shape[0] > 3
    assert sorted(p.name for p in tmp_path.iterdir()) == ["X.npz"]


_SWALLOWING_CHILD = """
import ctypes, sys, time

import wbc.viz.progress as progress

def in_c_callback():  # Python called back from C, as numba's LLVM engine does while the kernels compile
    print("in the callback", flush=True)
    time.sleep(3.0)

callback = ctypes.CFUNCTYPE(None)(in_c_callback)
update = progress.ProgressViewer.update
ticks = [0]

def first_tick_calls_back(self, *args, **kwargs):
    ticks[0] += 1
    if ticks[0] == 1:
        callback()
        print("callback returned", flush=True)  # the KeyboardInterrupt did not leave the C call
    return update(self, *args, **kwargs)

progress.ProgressViewer.update = first_tick_calls_back
from wbc.cli import main

sys.exit(main(["walk", "--robot", "humanoid15", "--steps", "400", "--quiet"]))
"""


@linux_only
def test_a_ctrl_c_swallowed_by_a_c_callback_still_ends_the_run(tmp_path):
    """A Ctrl-C landing while Python runs inside a ctypes callback (numba compiling the kernels on a first run; the
    CI met it as `Exception ignored on calling ctypes callback function: ...KeyboardInterrupt`) is swallowed there:
    the 400-step walk must still stop at its next tick with 130, not run on for minutes, and say so once, with no
    traceback of the swallowed interrupt on stderr."""
    import subprocess
    import time

    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen([sys.executable, "-c", _SWALLOWING_CHILD], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        assert proc.stdout.readline().strip() == "in the callback", proc.poll()
        time.sleep(0.5)
        proc.send_signal(signal.SIGINT)
        t0 = time.monotonic()
        out, err = proc.communicate(timeout=60)
        waited = time.monotonic() - t0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert "callback returned" in out, (out, err[-2000:])  # it was swallowed where it landed
    assert "Traceback" not in err and "Exception ignored" not in err, err[-2000:]
    assert proc.returncode == 130, (proc.returncode, err[:1500], err[-1500:])
    assert "interrupted (Ctrl-C)" in err, err[-2000:]
    # the callback sleeps 2.5 s more; the walk itself would take minutes (400 steps, ~0.8 s each)
    assert waited < 30.0, waited



_CACHED_KERNEL = """
import numba

@numba.njit(cache=True)
def add(a, b):
    return a + b
"""

# A Ctrl-C landing while LLVM asks numba, through a ctypes callback, for a kernel's cached object code: the signal
# is sent from inside numba's hook (the interpreter runs the Python handler at the hook's next bytecode), at each
# kernel load.
_CTRL_C_IN_THE_OBJECT_CACHE = """
import os, signal, sys

import numba.core.codegen as codegen

hook = codegen.JITCodeLibrary._object_getbuffer_hook.__func__
sent = []

def ctrl_c_then_hook(cls, ll_module):  # at every kernel load: the first ones may have no cached object to hand over
    if RUN_PHASE():
        if not sent:
            sent.append(True)
            print("sent", flush=True)
        os.kill(os.getpid(), signal.SIGINT)
        sum(range(1000))  # bytecodes: the handler runs here, inside the callback
    return hook(cls, ll_module)

codegen.JITCodeLibrary._object_getbuffer_hook = classmethod(ctrl_c_then_hook)
"""


@linux_only
def test_a_ctrl_c_inside_the_object_cache_callback_does_not_crash_the_kernel_load(tmp_path):
    """numba loads a cached kernel through a ctypes callback from LLVM (the object cache); a KeyboardInterrupt raised
    inside it leaves LLVM without the kernel's code and the next call jumps to a null pointer (SIGSEGV, exit -11: a
    `wbc walk` Ctrl-C'd 1.5 s in died so in CI, with nothing on stderr). With the run commands' SIGINT handler the
    Ctrl-C is remembered there, the kernel loads and returns the right value, and nothing is printed."""
    import subprocess

    (tmp_path / "kmod.py").write_text(_CACHED_KERNEL)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), str(tmp_path), os.environ.get("PYTHONPATH", "")]))
    first = subprocess.run([sys.executable, "-c", "import kmod; print(kmod.add(1.0, 2.0))"], capture_output=True,
                           text=True, env=env, cwd=tmp_path, timeout=120)
    assert first.stdout.strip() == "3.0", first.stderr[-2000:]
    assert list((tmp_path / "__pycache__").glob("kmod.add-*.nbc")), "the kernel was not cached"
    child = _CTRL_C_IN_THE_OBJECT_CACHE.replace("RUN_PHASE()", "True") + (
        "from wbc.cli.output import on_sigint, sigint_received\n"
        "signal.signal(signal.SIGINT, on_sigint)\n"
        "import kmod\n"
        "print('result', kmod.add(1.0, 2.0), flush=True)\n"
        "print('remembered', sigint_received(), flush=True)\n")
    proc = subprocess.run([sys.executable, "-c", child], capture_output=True, text=True, env=env, cwd=tmp_path,
                          timeout=120)
    assert proc.returncode == 0, (proc.returncode, proc.stdout, proc.stderr[-2000:])
    assert proc.stdout.split("\n")[:3] == ["sent", "result 3.0", "remembered True"], proc.stdout
    assert proc.stderr == "", proc.stderr[-2000:]


@linux_only
def test_a_ctrl_c_while_a_run_loads_its_kernels_ends_it_with_130(tmp_path):
    """The same Ctrl-C in a real `wbc walk`: sent from inside the object-cache callback at the first kernel the run
    loads after its loading phase (the run's SIGINT handler installed): exit 130 and one line on stderr, not a
    segfault, and the 400-step walk does not run on."""
    import subprocess

    child = _CTRL_C_IN_THE_OBJECT_CACHE.replace(
        "RUN_PHASE()", "signal.getsignal(signal.SIGINT) is output.on_sigint") + (
        "import wbc.cli.output as output\n"
        "from wbc.cli import main\n"
        "sys.exit(main(['walk', '--robot', 'humanoid15', '--steps', '400', '--quiet']))\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, "-c", child], capture_output=True, text=True, env=env, cwd=tmp_path,
                          timeout=300, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    assert proc.stdout.startswith("sent"), (proc.returncode, proc.stdout[-500:], proc.stderr[-2000:])
    assert proc.returncode == 130, (proc.returncode, proc.stderr[-2000:])
    assert "Traceback" not in proc.stderr and "interrupted (Ctrl-C)" in proc.stderr, proc.stderr[-2000:]
    assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr


def _udp_sockets_of(pid: int) -> dict[int, str]:
    """{inode: local address (hex, as /proc/<pid>/net/udp* writes it)} of the UDP sockets process ``pid`` holds."""
    held = set()
    for fd in os.listdir(f"/proc/{pid}/fd"):
        try:
            link = os.readlink(f"/proc/{pid}/fd/{fd}")
        except OSError:
            continue
        if link.startswith("socket:["):
            held.add(int(link[8:-1]))
    found = {}
    for name in ("udp", "udp6"):
        for row in Path(f"/proc/{pid}/net/{name}").read_text().splitlines()[1:]:
            cols = row.split()
            if int(cols[9]) in held:
                found[int(cols[9])] = cols[1]
    return found


@linux_only
def test_ros2_run_binds_dds_to_loopback_only(tmp_path):
    """`wbc walk --ros2` with no CYCLONEDDS_URI of the user's: every UDP socket of the process is either bound to
    127.0.0.1 (/proc/<pid>/net/udp) or, for Cyclone's wildcard-bound receive sockets, restricted to the `lo`
    device (`ss` shows 0.0.0.0%lo); nothing listens on TCP."""
    import random
    import shutil
    import subprocess
    import time

    pytest.importorskip("cyclonedds")
    ss = shutil.which("ss")
    assert ss is not None, "iproute2's ss is needed to read the device a socket is bound to"
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
               ROS_DOMAIN_ID=str(dds_domain_id()))
    env.pop("CYCLONEDDS_URI", None)
    # a 400-step walk outlasts both reads below (an 8-step walk could end between /proc and ss; SIGINT ends it)
    # SIGINT ends it below: the child gets the default disposition (a suite started from a background shell has
    # SIGINT ignored, and children inherit that)
    proc = subprocess.Popen([sys.executable, "-m", "wbc", "walk", "--robot", "humanoid15", "--steps", "400", "--ros2",
                             "--quiet"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        deadline = time.monotonic() + 90.0
        udp = {}
        while time.monotonic() < deadline and proc.poll() is None:
            udp = _udp_sockets_of(proc.pid)
            if len(udp) >= 3:  # Cyclone: discovery and data receive sockets, one transmit socket
                time.sleep(0.5)  # the participant is complete once the binding has run
                udp = _udp_sockets_of(proc.pid)
                break
            time.sleep(0.2)
        assert len(udp) >= 3, (udp, proc.poll())
        lines = subprocess.run([ss, "-H", "-uanp"], capture_output=True, text=True, check=True).stdout.splitlines()
        mine = [ln.split()[3] for ln in lines if f"pid={proc.pid}," in ln]
        tcp = subprocess.run([ss, "-H", "-ltnp"], capture_output=True, text=True, check=True).stdout.splitlines()
    finally:
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    loopback = {a for a in udp.values() if a.startswith("0100007F:")}
    wildcard = {a for a in udp.values() if a.split(":")[0] in ("00000000", "0" * 32)}
    assert loopback and len(loopback) + len(wildcard) == len(udp), udp  # 127.0.0.1 or 0.0.0.0, nothing else
    assert len(mine) == len(udp), (mine, udp)
    for local in mine:
        assert local.startswith("127.0.0.1:") or "%lo:" in local, mine
    assert not [ln for ln in tcp if f"pid={proc.pid}," in ln], tcp
    assert proc.returncode in (0, 130) and "Traceback" not in err, err[-2000:]
