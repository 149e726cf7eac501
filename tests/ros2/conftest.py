"""Fixtures of the ROS 2 tests: a real rclpy client (tests/ros2/kilted.py) on Fast DDS confined to 127.0.0.1.

``kilted`` / ``jazzy``: a :class:`kilted.ClientSession` on a fresh ROS_DOMAIN_ID (tests/conftest.py's
``dds_domain_id``) with its own profile directory. The distribution's venv is built on first use (about 100 s,
pip from the package index) and cached; a failed build fails the test with pip's output.
"""

from __future__ import annotations

import subprocess

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
