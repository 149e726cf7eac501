"""Fixtures of the ROS 2 tests: a real rclpy client (tests/ros2/kilted.py) on Fast DDS confined to 127.0.0.1, and
the loopback guard.

The guard (``_udp_on_loopback_only``, every test of this directory): a thread takes an ``ss -uanp`` snapshot
(iproute2) every 0.5 s from the first ROS 2 test of the session on, and keeps every UDP socket of the test process
and its descendants (the wbc nodes and rclpy clients it starts) whose local address is not 127.0.0.1, ::1 or
bound to the ``lo`` device (``0.0.0.0%lo``, Cyclone's receive sockets), or whose peer is not loopback. A test
during which such a socket was seen fails at teardown with the sockets listed. ``ss`` shows bindings, not the
destinations of unconnected sends: those are checked by tests/ros2/test_dds.py under strace.

``kilted`` / ``jazzy``: a :class:`kilted.ClientSession` on a fresh ROS_DOMAIN_ID (tests/conftest.py's
``dds_domain_id``) with its own profile directory. The distribution's venv is built on first use (about 100 s,
pip from the package index) and cached; a failed build fails the test with pip's output.
"""

from __future__ import annotations

import os
import re
import subprocess
import threading
import time

import pytest
from conftest import dds_domain_id

from . import kilted as _clients


def _session(client, tmp_path, monkeypatch):
    # this process's own participants (the tests' in-process wbc side) on loopback whatever an earlier test of the same
    # worker left: Cyclone reads CYCLONEDDS_URI when it creates a domain, and wbc.ros2.dds binds a participant's new
    # sockets to `lo` only while its interface choice is the loopback one
    from wbc.ros2 import dds

    monkeypatch.setenv("CYCLONEDDS_URI", dds.loopback_uri())
    monkeypatch.setattr(dds, "_chosen", [])
    try:
        client.build()
    except subprocess.CalledProcessError as exc:
        pytest.fail(f"building the {client.distro} rclpy venv at {client.venv} failed:\n{exc.stdout}\n{exc.stderr}")
    session = _clients.ClientSession(client, dds_domain_id(), tmp_path / f"ros2-{client.distro}")
    return session


@pytest.fixture
def kilted(tmp_path, monkeypatch):
    """rclpy 9.1.2 on Kilted's Fast DDS 3.2.3 (its defaults apart from the loopback profile)."""
    session = _session(_clients.KILTED, tmp_path, monkeypatch)
    yield session
    session.close()


@pytest.fixture
def jazzy(tmp_path, monkeypatch):
    """rclpy 7.1.6 on Jazzy's Fast DDS 2.14.5 (its defaults apart from the loopback profile)."""
    session = _session(_clients.JAZZY, tmp_path, monkeypatch)
    yield session
    session.close()


_LOCAL_OK = re.compile(r"^(127\.\d+\.\d+\.\d+|\[::1\]|\[::ffff:127\.\d+\.\d+\.\d+\]|0\.0\.0\.0%lo|\*%lo|\[::\]%lo):\d+$")
_PEER_OK = re.compile(r"^(0\.0\.0\.0|\*|\[::\]|127\.\d+\.\d+\.\d+|\[::1\]|\[::ffff:127\.\d+\.\d+\.\d+\]):(\*|\d+)$")


def descendants(root: int) -> set[int]:
    """``root`` and every process below it (from /proc/<pid>/stat's parent ids)."""
    parent = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    parent[int(entry)] = int(f.read().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
    family, grew = {root}, True
    while grew:
        new = {p for p, pp in parent.items() if pp in family and p not in family}
        family |= new
        grew = bool(new)
    return family


def udp_sockets_off_loopback(pids: set[int]) -> tuple[list[str], int]:
    """(``ss -uanp`` rows of the processes ``pids`` with a non-loopback local or peer address, number of their UDP
    sockets in the snapshot)."""
    out = subprocess.run(["ss", "-uanp"], capture_output=True, text=True, timeout=10).stdout
    bad, n = [], 0
    for row in out.splitlines()[1:]:
        cols = row.split()
        owners = {int(p) for p in re.findall(r"pid=(\d+),", row)}
        if len(cols) < 5 or not owners & pids:
            continue
        n += 1
        if not _LOCAL_OK.match(cols[3]) or not _PEER_OK.match(cols[4]):
            bad.append(" ".join(cols))
    return bad, n


class LoopbackGuard:
    """The background ``ss -uanp`` sampler of the test process's family (module docstring)."""

    def __init__(self, every: float = 0.5):
        self.every, self.snapshots, self.sockets_seen, self.bad = every, 0, 0, []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            self.sample()
            self._stop.wait(self.every)

    def sample(self) -> None:
        try:
            bad, n = udp_sockets_off_loopback(descendants(os.getpid()))
        except (OSError, subprocess.SubprocessError) as exc:  # ss missing: the guard itself fails the tests
            bad, n = [f"ss -uanp failed: {exc}"], 0
        self.snapshots += 1
        self.sockets_seen += n
        self.bad.extend(b for b in bad if b not in self.bad)

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=15)


@pytest.fixture(scope="session")
def loopback_guard():
    """The session's :class:`LoopbackGuard` (started by the first ROS 2 test)."""
    guard = LoopbackGuard()
    yield guard
    guard.stop()


@pytest.fixture(autouse=True)
def _udp_on_loopback_only(loopback_guard):
    seen = len(loopback_guard.bad)
    yield
    loopback_guard.sample()  # the test's last state, whatever the sampler's phase
    new = loopback_guard.bad[seen:]
    if new:
        pytest.fail(f"UDP sockets beyond 127.0.0.1 during this test ({len(new)}; ss -uanp):\n" + "\n".join(new))
