"""The watchdog of a local Ray: no Ray process outlives the campaign driver that started it.

Ray 2.60's GCS server and raylet die with the process that started them, but the raylet's agents
(``ray::DashboardAgent``, ``ray::RuntimeEnvAgent``) do not: a driver killed by SIGKILL leaves them running.
:class:`wbc.campaign.executors.RayExecutor` starts this file as a script (``python reaper.py DRIVER_PID``; it
imports nothing of wbc) right after ``ray.init``. Every ``PERIOD`` s it records the driver's descendants (pid and
start time, from ``/proc``); once the driver is gone (this process's parent changes) it sends SIGKILL to every
recorded process still running with the same start time (not a reused pid), then exits. The executor's ``close``
terminates it after ``ray.shutdown``. Linux only (``/proc``).
"""

from __future__ import annotations

import os
import signal
import sys
import time

#: s between two records of the driver's descendants (and two checks that the driver is alive).
PERIOD = 0.5


def start_time(pid: int) -> str | None:
    """The start time of process ``pid`` (clock ticks after boot, field 22 of ``/proc/PID/stat``), None when it is
    gone."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            stat = f.read().decode(errors="replace")
    except OSError:
        return None
    return stat.rpartition(")")[2].split()[19]


def descendants(pid: int) -> dict[int, str]:
    """pid → start time of every descendant of ``pid`` (children of all its threads, recursively)."""
    out: dict[int, str] = {}
    todo = [pid]
    while todo:
        parent = todo.pop()
        try:
            tasks = os.listdir(f"/proc/{parent}/task")
        except OSError:
            continue
        for task in tasks:
            try:
                with open(f"/proc/{parent}/task/{task}/children") as f:
                    children = [int(x) for x in f.read().split()]
            except OSError:
                continue
            for child in children:
                start = start_time(child)
                if start is not None and child not in out:
                    out[child] = start
                    todo.append(child)
    return out


def watch(driver: int) -> list[int]:
    """Record ``driver``'s descendants until it is gone, then kill those still running; returns their pids."""
    me = os.getpid()
    seen: dict[int, str] = {}
    while os.getppid() == driver:
        seen = {p: s for p, s in seen.items() if start_time(p) == s}
        seen.update(descendants(driver))
        time.sleep(PERIOD)
    killed = []
    for pid, start in seen.items():
        if pid != me and start_time(pid) == start:
            try:
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
            except OSError:
                pass
    return killed


if __name__ == "__main__":
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # a Ctrl-C to the terminal's process group is the driver's to handle
    watch(int(sys.argv[1]))
