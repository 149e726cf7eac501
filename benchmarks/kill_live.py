"""Kill `wbc walk --live` with a signal and show that nothing of it is left running or listening.

For each signal (default SIGTERM, SIGKILL, SIGINT) the script starts ``python -m wbc walk --live`` (which waits for
a browser after printing its URL), lists the process tree and the TCP ports it listens on (from /proc), sends the
signal to the ``wbc`` process only (not its process group: the meshcat server runs in a session of its own), then
polls for up to ``--timeout`` s until no process of the tree is alive and none of its ports is in LISTEN state
(any owner, from /proc/net/tcp{,6}). Prints one line per signal and exits 1 if anything was left. Linux only.

    python benchmarks/kill_live.py [--signals TERM KILL INT] [--robot humanoid15] [--timeout 10]
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import time
from pathlib import Path


def tree(pid: int) -> list[int]:
    """``pid`` and its live descendants (from /proc/<p>/stat parent ids)."""
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


def socket_inodes(pids: list[int]) -> set[str]:
    inodes = set()
    for pid in pids:
        try:
            for fd in Path(f"/proc/{pid}/fd").iterdir():
                try:
                    link = os.readlink(fd)
                except OSError:
                    continue
                if link.startswith("socket:["):
                    inodes.add(link[8:-1])
        except OSError:
            pass
    return inodes


def listening(inodes: set[str] | None = None) -> set[int]:
    """TCP ports in LISTEN state (of the sockets ``inodes``, or of anyone when None)."""
    ports = set()
    for table in ("tcp", "tcp6"):
        for line in Path(f"/proc/net/{table}").read_text().splitlines()[1:]:
            cols = line.split()
            if cols[3] == "0A" and (inodes is None or cols[9] in inodes):
                ports.add(int(cols[1].split(":")[1], 16))
    return ports


def alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def kill_once(sig: signal.Signals, robot: str = "humanoid15", timeout: float = 10.0,
              startup: float = 600.0, extra: list[str] = (), settle: float = 0.5) -> dict:
    """Start `wbc walk --live` (with ``extra`` options), send ``sig`` once its URL is printed; returns what was left
    and when."""
    proc = subprocess.Popen([sys.executable, "-m", "wbc", "walk", "--robot", robot, "--steps", "2", "--live",
                             "--quiet", *extra], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONUNBUFFERED": "1"},
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        deadline = time.monotonic() + startup
        line = ""
        while time.monotonic() < deadline:
            line = proc.stdout.readline()
            if not line or line.startswith("meshcat viewer: http"):
                break
        if not line.startswith("meshcat viewer: http"):
            raise RuntimeError(f"wbc walk --live did not print its URL: exit {proc.poll()}, {proc.stderr.read()}")
        time.sleep(settle)
        pids = tree(proc.pid)
        ports = listening(socket_inodes(pids))
        t0 = time.monotonic()
        os.kill(proc.pid, sig)
        code = proc.wait(timeout=timeout)
        left_pids, left_ports = pids, ports
        while time.monotonic() - t0 < timeout:
            left_pids = [p for p in pids if alive(p)]
            left_ports = ports & listening()
            if not left_pids and not left_ports:
                break
            time.sleep(0.05)
        stderr = proc.stderr.read()
        rest = proc.stdout.read()
        return {"signal": sig.name, "exit_code": code, "pids": pids, "ports": sorted(ports),
                "left_pids": left_pids, "left_ports": sorted(left_ports),
                "cleanup_s": time.monotonic() - t0, "traceback": "Traceback" in stderr, "stderr": stderr,
                "url_line": line, "stdout_after_url": rest}
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        for p in tree(proc.pid)[1:]:
            try:
                os.kill(p, signal.SIGKILL)
            except OSError:
                pass


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--signals", nargs="+", default=["TERM", "KILL", "INT"])
    ap.add_argument("--robot", default="humanoid15")
    ap.add_argument("--timeout", type=float, default=10.0)
    args = ap.parse_args(argv)
    bad = 0
    for name in args.signals:
        r = kill_once(signal.Signals["SIG" + name.upper()], args.robot, args.timeout)
        ok = not r["left_pids"] and not r["left_ports"]
        bad += not ok
        print(f"SIG{name.upper():4s}: wbc exit {r['exit_code']}, processes {r['pids']} listening on {r['ports']}; "
              f"after {r['cleanup_s']:.2f} s left running {r['left_pids'] or 'none'}, left listening "
              f"{r['left_ports'] or 'none'}; traceback on stderr: {'yes' if r['traceback'] else 'no'} "
              f"-> {'PASS' if ok else 'FAIL'}", flush=True)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
