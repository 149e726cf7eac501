"""`wbc ... --live`: every listening socket of the command and its meshcat server is on 127.0.0.1, the URL is
printed before the motion, and the viewer stays up after the motion until --hold expires."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

if not sys.platform.startswith("linux"):
    pytest.skip("reads /proc to list listening sockets (Linux only)", allow_module_level=True)


def _tree(pid: int) -> list[int]:
    """pid and all its descendants (from /proc/<p>/stat parent ids)."""
    parent = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                parent[int(d.name)] = int((d / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                pass
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        todo.extend(c for c, pp in parent.items() if pp == p)
    return out


def _listening(pids: list[int]) -> list[tuple[str, int]]:
    """(address, port) of every TCP socket in LISTEN state owned by ``pids`` (from /proc/net/tcp{,6})."""
    inodes = set()
    for pid in pids:
        fd_dir = Path(f"/proc/{pid}/fd")
        try:
            for fd in fd_dir.iterdir():
                try:
                    link = os.readlink(fd)
                except OSError:
                    continue
                if link.startswith("socket:["):
                    inodes.add(link[8:-1])
        except OSError:
            pass
    found = []
    for table, v6 in (("tcp", False), ("tcp6", True)):
        for line in Path(f"/proc/net/{table}").read_text().splitlines()[1:]:
            cols = line.split()
            local, state, inode = cols[1], cols[3], cols[9]
            if state != "0A" or inode not in inodes:
                continue
            addr_hex, port_hex = local.split(":")
            if v6:
                raw = bytes.fromhex(addr_hex)
                words = [raw[i:i + 4][::-1] for i in range(0, 16, 4)]
                b = b"".join(words)
                addr = ":".join(b[i:i + 2].hex() for i in range(0, 16, 2))
                if b == bytes(15) + b"\x01":
                    addr = "::1"
                elif b[:12] == bytes(10) + b"\xff\xff":
                    addr = ".".join(str(x) for x in b[12:])  # v4-mapped
            else:
                addr = ".".join(str(x) for x in bytes.fromhex(addr_hex)[::-1])
            found.append((addr, int(port_hex, 16)))
    return found


def _run_live(extra: list[str]) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "wbc", *extra], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"},
                            # SIGINT as in a terminal, even when the test runner was started with SIGINT ignored
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def test_live_viewer_listens_on_loopback_only_and_holds():
    proc = _run_live(["balance", "shift", "--live", "--live-start-now", "--hold", "5"])
    try:
        lines = []
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline:
            line = proc.stdout.readline()
            assert line, f"wbc exited early: {proc.wait()} {proc.stderr.read()}"
            lines.append(line)
            if line.startswith("meshcat viewer:"):
                break
        # The URL comes before the motion's summary.
        assert not any(l.startswith("wbc balance") for l in lines)
        assert "http://127.0.0.1:" in lines[-1]
        time.sleep(1.0)
        sockets = _listening(_tree(proc.pid))
        assert len(sockets) >= 2, sockets  # meshcat's zmq port and web port at least
        assert all(addr == "127.0.0.1" for addr, _ in sockets), sockets
        web_port = int(lines[-1].split("127.0.0.1:")[1].split("/")[0])
        assert web_port in {port for _, port in sockets}
        # The motion ends; the viewer stays up (hold) and says so; its sockets are still open.
        while True:
            line = proc.stdout.readline()
            assert line, f"wbc exited without holding: {proc.wait()} {proc.stderr.read()}"
            if line.startswith("motion done; meshcat viewer stays up"):
                break
        assert "5 s" in line
        time.sleep(1.0)
        assert proc.poll() is None
        still = _listening(_tree(proc.pid))
        assert web_port in {port for _, port in still} and all(a == "127.0.0.1" for a, _ in still)
        assert proc.wait(timeout=60) in (0, 1)  # the hold expires on its own
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            proc.wait(timeout=30)


def test_live_viewer_shows_the_com_when_the_loop_gives_none(robots):
    import time as _time

    from wbc.viz import LiveViewer

    talos = robots("talos")
    viewer = LiveViewer(talos, fps=25.0)
    try:
        viewer.update(talos.q_ref, 0.0)  # what run_walk does: no overlays
        deadline = _time.monotonic() + 30
        while viewer.frames_displayed == 0 and _time.monotonic() < deadline and viewer.error is None:
            _time.sleep(0.05)
        assert viewer.error is None and viewer.frames_displayed >= 1
        assert {"com", "com_ground"} <= viewer._markers
    finally:
        viewer.close()
