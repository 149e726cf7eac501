"""A real ROS 2 client for the tests: rclpy from the package index, in its own venv, on Fast DDS confined to
127.0.0.1.

The ROS 2 wheels (``ros-kilted-rclpy[fastrtps]`` and the ``ros-*`` message wheels for Kilted; ``ros-jazzy-*`` for
Jazzy) link ``librcl`` to ``librmw_fastrtps_cpp``, the default RMW of both distributions. Their ``.pth``
bootstrapper re-executes every Python process of the venv they are installed in, so they live in a venv of their own
(``python -m venv --system-site-packages``: the client scripts also see the project's numpy), built once and kept
under ``~/.cache/wbc-tests/ros2-<distro>-<key>`` (``WBC_TEST_CACHE`` overrides ``~/.cache/wbc-tests``), ``<key>``
a hash of the pinned requirements and the Python version. A file lock makes concurrent test processes build it once.

Fast DDS is never started without :func:`loopback_profile`: one UDPv4 transport with the interface allow-list
127.0.0.1, no built-in transports, unicast and metatraffic locators on 127.0.0.1 and 127.0.0.1 as the only initial
peer. ``ROS_AUTOMATIC_DISCOVERY_RANGE=SYSTEM_DEFAULT`` keeps rclpy from replacing that profile's discovery settings
(``LOCALHOST``, the default, still listens on every interface). :func:`client_env` sets the profile, that range and
the caller's ``ROS_DOMAIN_ID``; :func:`run_client` runs a Python script in the venv with it.

Not a test module: ``tests/ros2/conftest.py`` offers :class:`RosClient` as the fixtures ``kilted`` and ``jazzy``.
"""

from __future__ import annotations

import fcntl
import hashlib
import os
import shutil
import site
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

#: Kilted Kaiju: rclpy 9.1.2 on Fast DDS 3.2.3 (the wheels' pins).
KILTED_REQUIREMENTS = (
    "ros-kilted-rclpy[fastrtps]==9.1.2",
    "ros-sensor-msgs==5.5.1",
    "ros-std-msgs==5.5.1",
    "ros-std-srvs==5.5.1",
    "ros-geometry-msgs==5.5.1",
    "ros-nav-msgs==5.5.1",
    "ros-rcl-interfaces==2.3.0",
)
#: Jazzy Jalisco: rclpy 7.1.6 on Fast DDS 2.14.5.
JAZZY_REQUIREMENTS = (
    "ros-jazzy-rclpy[fastrtps]==7.1.6",
    "ros-jazzy-sensor-msgs==5.3.6",
    "ros-jazzy-std-msgs==5.3.6",
    "ros-jazzy-std-srvs==5.3.6",
    "ros-jazzy-geometry-msgs==5.3.6",
    "ros-jazzy-nav-msgs==5.3.6",
    "ros-jazzy-rcl-interfaces==2.0.3",
)
#: The Cyclone DDS configuration of wbc's side: interface lo, multicast off, 127.0.0.1 the only peer.
CYCLONE_LOOPBACK = (
    '<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface name="lo"/></Interfaces>'
    "<AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex>"
    '<MaxAutoParticipantIndex>60</MaxAutoParticipantIndex><Peers><Peer address="127.0.0.1"/></Peers>'
    "</Discovery></Domain></CycloneDDS>"
)
LOOPBACK_ADDRESS = "127.0.0.1"


def loopback_profile() -> str:
    """Fast DDS XML profile (default participant profile) keeping every packet on 127.0.0.1."""
    loc = f"<locator><udpv4><address>{LOOPBACK_ADDRESS}</address></udpv4></locator>"
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        '<dds xmlns="http://www.eprosima.com"><profiles>\n'
        "<transport_descriptors><transport_descriptor>"
        "<transport_id>wbc_loopback_udpv4</transport_id><type>UDPv4</type>"
        f"<interfaceWhiteList><address>{LOOPBACK_ADDRESS}</address></interfaceWhiteList>"
        "</transport_descriptor></transport_descriptors>\n"
        '<participant profile_name="wbc_loopback" is_default_profile="true"><rtps>'
        "<userTransports><transport_id>wbc_loopback_udpv4</transport_id></userTransports>"
        "<useBuiltinTransports>false</useBuiltinTransports>"
        f"<defaultUnicastLocatorList>{loc}</defaultUnicastLocatorList>"
        f"<builtin><metatrafficUnicastLocatorList>{loc}</metatrafficUnicastLocatorList>"
        f"<initialPeersList>{loc}</initialPeersList></builtin>"
        "</rtps></participant>\n"
        "</profiles></dds>\n"
    )


def cache_root() -> Path:
    return Path(os.environ.get("WBC_TEST_CACHE") or Path.home() / ".cache" / "wbc-tests")


@dataclass(frozen=True)
class RosClient:
    """One ROS 2 distribution's rclpy in its own venv. ``distro``: "kilted" or "jazzy"; ``requirements``: pinned
    pip requirements; ``profile_variable``: the variable by which its Fast DDS reads an XML profile file
    (``FASTDDS_DEFAULT_PROFILES_FILE`` for Fast DDS 3; Fast DDS 2 reads ``FASTRTPS_DEFAULT_PROFILES_FILE``)."""

    distro: str
    requirements: tuple[str, ...]
    profile_variable: str

    @property
    def venv(self) -> Path:
        # a venv's interpreter: its own environment is added to the client's (see build), so it is part of the key
        env = (sys.prefix,) if sys.prefix != sys.base_prefix else ()
        key = hashlib.sha256("\n".join((sys.version, *env, *self.requirements)).encode()).hexdigest()[:12]
        return cache_root() / f"ros2-{self.distro}-{key}"

    @property
    def python(self) -> Path:
        return self.venv / "bin" / "python"

    def build(self, log=None) -> Path:
        """Create the venv unless a complete one is cached; return its Python. A failed pip install leaves no
        venv behind and raises ``subprocess.CalledProcessError`` (its output in the exception)."""
        done = self.venv / ".complete"
        if done.is_file():
            return self.python
        self.venv.parent.mkdir(parents=True, exist_ok=True)
        with open(self.venv.parent / f".{self.venv.name}.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            if done.is_file():
                return self.python
            shutil.rmtree(self.venv, ignore_errors=True)  # an interrupted build
            subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(self.venv)], check=True,
                           capture_output=True, text=True)
            if sys.prefix != sys.base_prefix:
                # run from a venv: --system-site-packages gives the base interpreter's packages, not this venv's
                # (wbc and its dependencies, which the rclpy backend's node imports); its site folders are added
                # after the client's own, .pth files included, as the base's are
                site_packages = subprocess.run([str(self.python), "-c", "import sysconfig; "
                                                "print(sysconfig.get_paths()['purelib'])"], check=True,
                                               capture_output=True, text=True).stdout.strip()
                (Path(site_packages) / "_wbc_test_environment.pth").write_text(
                    f"import site; [site.addsitedir(p) for p in {site.getsitepackages()!r}]\n")
            pip = subprocess.run([str(self.python), "-m", "pip", "install", "--no-input", "-q", *self.requirements],
                                 capture_output=True, text=True)
            if pip.returncode:
                shutil.rmtree(self.venv, ignore_errors=True)
                raise subprocess.CalledProcessError(pip.returncode, pip.args, pip.stdout, pip.stderr)
            done.write_text("\n".join(self.requirements) + "\n")
        return self.python

    def client_env(self, domain_id: int, profile_dir: Path, base: dict | None = None) -> dict:
        """Environment for a client process: ``base`` (default ``os.environ``) with the loopback profile written
        to ``profile_dir`` and named by :attr:`profile_variable`, ``ROS_AUTOMATIC_DISCOVERY_RANGE=SYSTEM_DEFAULT``
        and ``ROS_DOMAIN_ID=domain_id``; no ROS variable of the base environment is kept."""
        env = {k: v for k, v in (os.environ if base is None else base).items()
               if not k.startswith(("ROS_", "RMW_", "FASTDDS_", "FASTRTPS_", "_ROS_WHEELS"))}
        profile = Path(profile_dir) / "fastdds_loopback.xml"
        profile.parent.mkdir(parents=True, exist_ok=True)
        profile.write_text(loopback_profile())
        env[self.profile_variable] = str(profile)
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "SYSTEM_DEFAULT"
        env["ROS_DOMAIN_ID"] = str(int(domain_id))
        env.pop("PYTHONPATH", None)
        env["PYTHONUNBUFFERED"] = "1"
        return env

    def run_client(self, script: str, timeout: float, domain_id: int, profile_dir: Path, args=(),
                   base_env: dict | None = None) -> subprocess.CompletedProcess:
        """Run the Python source ``script`` in this client's venv (built if needed) on ``domain_id`` with
        :meth:`client_env`; text output captured. Raises ``subprocess.TimeoutExpired`` after ``timeout`` s."""
        python = self.build()
        return subprocess.run([str(python), "-c", script, *map(str, args)], env=self.client_env(
            domain_id, profile_dir, base_env), capture_output=True, text=True, timeout=timeout)

    def start_client(self, script: str, domain_id: int, profile_dir: Path, args=(),
                     base_env: dict | None = None) -> subprocess.Popen:
        """:meth:`run_client` without waiting: the started process (text pipes for stdout and stderr)."""
        python = self.build()
        return subprocess.Popen([str(python), "-c", script, *map(str, args)], env=self.client_env(
            domain_id, profile_dir, base_env), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


KILTED = RosClient("kilted", KILTED_REQUIREMENTS, "FASTDDS_DEFAULT_PROFILES_FILE")
JAZZY = RosClient("jazzy", JAZZY_REQUIREMENTS, "FASTRTPS_DEFAULT_PROFILES_FILE")


class ClientSession:
    """One test's ROS 2 client: ``client`` on the DDS domain ``domain_id`` with its profile under ``workdir``.
    Processes started by :meth:`start_client` are killed by :meth:`close` (the fixture's teardown)."""

    def __init__(self, client: RosClient, domain_id: int, workdir: Path):
        self.client, self.domain_id, self.workdir = client, int(domain_id), Path(workdir)
        self._started: list[subprocess.Popen] = []

    @property
    def env(self) -> dict:
        """The client processes' environment (:meth:`RosClient.client_env`)."""
        return self.client.client_env(self.domain_id, self.workdir)

    def wbc_env(self, base: dict | None = None) -> dict:
        """Environment for a wbc process talking to this client: ``base`` (default ``os.environ``) with Cyclone
        confined to ``lo`` and the same ``ROS_DOMAIN_ID``; no ``PYTHONPATH`` change."""
        env = dict(os.environ if base is None else base)
        env["CYCLONEDDS_URI"] = CYCLONE_LOOPBACK
        env["ROS_DOMAIN_ID"] = str(self.domain_id)
        return env

    def run_client(self, script: str, timeout: float, args=()) -> subprocess.CompletedProcess:
        """Run the Python source ``script`` (``sys.argv[1:]`` = ``args``) with the client's rclpy; output
        captured as text. Raises ``subprocess.TimeoutExpired`` after ``timeout`` s."""
        return self.client.run_client(script, timeout, self.domain_id, self.workdir, args)

    def start_client(self, script: str, args=()) -> subprocess.Popen:
        """:meth:`run_client` without waiting."""
        proc = self.client.start_client(script, self.domain_id, self.workdir, args)
        self._started.append(proc)
        return proc

    def close(self) -> None:
        for proc in self._started:
            if proc.poll() is None:
                proc.kill()
            proc.communicate()
