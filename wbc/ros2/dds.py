"""DDS participant, QoS profiles and the network interface configuration (cyclonedds).

wbc's participants use the loopback interface by default: :func:`participant` calls :func:`use_interface` with
``"lo"`` unless ``CYCLONEDDS_URI`` is already set (the user's own Cyclone configuration always wins). Cyclone then
advertises and sends to 127.0.0.1 only, multicast off. Cyclone binds its unicast receive sockets (discovery and
data, 7400 + 250 domain + 10 + 2 index, + 1) to the wildcard address 0.0.0.0 whatever its configuration
(cyclonedds 11.0.1, ``ddsi_udp_create_conn``); with the loopback configuration :func:`participant` therefore
redirects Cyclone's ``bind`` calls to 127.0.0.1 while it creates the participant (:mod:`wbc.ros2.loopback_bind`;
``ss`` shows them as ``127.0.0.1:<port>``). Where that cannot be done (not Linux, ``pyelftools`` missing), it
warns once and binds the new sockets to the ``lo`` device just after their creation (``SO_BINDTODEVICE``; ``ss``
shows ``0.0.0.0%lo``): open on every interface for that moment.
``loopback_uri()`` returns the ``CYCLONEDDS_URI`` value confining Cyclone DDS to 127.0.0.1: the ``lo`` interface,
multicast off, and localhost as the only unicast peer. To reach other machines, choose an interface
(:func:`use_interface` ``("eth0")``, the ``--ros2-interface`` option of the command line) or ``"any"`` (Cyclone's
own choice of interface, multicast discovery) before the first participant is created.

The first :func:`participant` also registers an ``atexit`` handler that deletes every Cyclone DDS entity of the
process (``dds_delete`` of the library's root handle) while the interpreter is still whole. Left to the
interpreter's finalisation, the entities are deleted in whatever order their Python objects are collected; with
cyclonedds 11.0.1 a reader deleted then could wait forever for Cyclone's already stopped garbage-collector thread
(seen in ``dds_reader_close``, 1 exit in about 25 of the knee-subscriber tutorial).
"""

from __future__ import annotations

import contextlib
import os

from wbc.ros2 import loopback_bind

__all__ = ["loopback_uri", "interface_uri", "use_loopback", "use_interface", "domain_id", "participant", "qos_stream",
           "qos_latched", "ros_topic", "delete_all_entities", "LOOPBACK", "ANY_INTERFACE", "CYCLONEDDS_HANDLE"]

#: Interface name of the loopback configuration (the default).
LOOPBACK = "lo"
#: Interface choice that leaves Cyclone DDS its own default (an external interface, multicast discovery).
ANY_INTERFACE = "any"
_chosen: list[str] = []  # the interface set by use_interface in this process
_teardown_registered: list[bool] = []  # the atexit teardown is registered (once per process)
#: ``DDS_CYCLONEDDS_HANDLE`` of ``dds/dds.h``: the pseudo-entity owning every domain of the process
#: (``DDS_MIN_PSEUDO_HANDLE`` 0x7fff0000 + 256); ``dds_delete`` of it deletes all entities, children first.
CYCLONEDDS_HANDLE = 0x7FFF0000 + 256


def loopback_uri() -> str:
    """A Cyclone DDS XML configuration (as one string) that keeps every packet on the loopback interface."""
    return (
        "<CycloneDDS><Domain id=\"any\"><General><Interfaces><NetworkInterface name=\"lo\"/></Interfaces>"
        "<AllowMulticast>false</AllowMulticast></General>"
        "<Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>60</MaxAutoParticipantIndex>"
        "<Peers><Peer address=\"127.0.0.1\"/></Peers></Discovery></Domain></CycloneDDS>"
    )


def interface_uri(interface: str) -> str | None:
    """``CYCLONEDDS_URI`` value binding Cyclone DDS to the network interface ``interface`` (a name such as
    ``eth0`` or an IP address): :func:`loopback_uri` for ``"lo"``, None for ``"any"`` (Cyclone's default).

    Raises:
        wbc.exceptions.InvalidInputError: ``interface`` is empty or holds characters outside ``[A-Za-z0-9_.:-]``.
    """
    import re

    from wbc.exceptions import InvalidInputError

    if not isinstance(interface, str) or not re.fullmatch(r"[A-Za-z0-9_.:\-]+", interface):
        raise InvalidInputError(f"DDS interface {interface!r} is invalid: valid is an interface name (lo, eth0), "
                                f"an IP address, or {ANY_INTERFACE!r}")
    if interface == LOOPBACK:
        return loopback_uri()
    if interface == ANY_INTERFACE:
        return None
    return (f"<CycloneDDS><Domain id=\"any\"><General><Interfaces><NetworkInterface name=\"{interface}\"/>"
            "</Interfaces></General></Domain></CycloneDDS>")


def use_interface(interface: str = LOOPBACK) -> None:
    """Bind this process's DDS participants to ``interface`` (see :func:`interface_uri`) by setting
    ``CYCLONEDDS_URI``, unless the user already set it. Call before the first participant is created."""
    uri = interface_uri(interface)
    _chosen[:] = [interface]
    if uri is not None:
        os.environ.setdefault("CYCLONEDDS_URI", uri)


def use_loopback() -> None:
    """Set ``CYCLONEDDS_URI`` to :func:`loopback_uri` in this process unless it is already set."""
    use_interface(LOOPBACK)


def domain_id() -> int:
    """``ROS_DOMAIN_ID`` (0–232 as ROS 2 allows), default 0.

    Raises:
        wbc.exceptions.InvalidInputError: the variable is not an integer in 0..232.
    """
    from wbc.exceptions import InvalidInputError

    raw = os.environ.get("ROS_DOMAIN_ID", "0").strip() or "0"
    try:
        value = int(raw)
    except ValueError:
        value = -1
    if not 0 <= value <= 232:
        raise InvalidInputError(f"ROS_DOMAIN_ID={raw!r} is invalid: valid values are integers 0..232")
    return value


def participant(domain: int | None = None):
    """A ``cyclonedds.domain.DomainParticipant`` on ``domain`` (default :func:`domain_id`), bound to the
    loopback interface unless :func:`use_interface` chose another or ``CYCLONEDDS_URI`` is set.

    Cyclone reads ``CYCLONEDDS_URI`` when it creates a domain; without it, Cyclone's default configuration picks a
    non-loopback interface and multicast discovery. That default is used only when it was asked for
    (:func:`use_interface` ``("any")``). With no choice made, or the loopback one, a missing ``CYCLONEDDS_URI``
    is set to :func:`loopback_uri` again.

    Raises:
        wbc.exceptions.ConfigurationError: an interface other than ``lo`` and ``any`` was chosen but
            ``CYCLONEDDS_URI`` is unset or empty now (it was removed after :func:`use_interface`): Cyclone would
            fall back to its all-interface default instead of the chosen interface.
    """
    from cyclonedds.domain import DomainParticipant

    if not _chosen:
        use_interface(LOOPBACK)
    if not os.environ.get("CYCLONEDDS_URI", "").strip() and _chosen[0] != ANY_INTERFACE:
        if _chosen[0] != LOOPBACK:
            from wbc.exceptions import ConfigurationError

            raise ConfigurationError(
                f"DDS interface {_chosen[0]!r} was chosen but CYCLONEDDS_URI is unset: Cyclone would use its "
                "default configuration (every interface, multicast) instead; call use_interface() again before "
                "participant(), set CYCLONEDDS_URI, or choose 'lo' (127.0.0.1 only) or 'any' (Cyclone's default)")
        os.environ["CYCLONEDDS_URI"] = loopback_uri()
    confine = _chosen == [LOOPBACK] and os.environ.get("CYCLONEDDS_URI") == loopback_uri()
    # Cyclone binds its receive sockets to 0.0.0.0 whatever its configuration says: its calls to bind() are
    # redirected to 127.0.0.1 (wbc.ros2.loopback_bind); where that cannot be done, the new sockets are restricted to
    # the lo device just after they were made (open on every interface until then)
    redirected = confine and loopback_bind.install()
    if confine and not redirected:
        _warn_not_redirected()
    before = _wildcard_udp_sockets() if confine and not redirected else {}
    with loopback_bind.confined() if redirected else contextlib.nullcontext():
        part = DomainParticipant(domain_id() if domain is None else domain)
    if not _teardown_registered:
        import atexit

        atexit.register(delete_all_entities)
        _teardown_registered.append(True)
    if confine and not redirected:
        _bind_to_loopback_device({fd: inode for fd, inode in _wildcard_udp_sockets().items()
                                  if inode not in before.values()})
    return part


def delete_all_entities() -> int:
    """Delete every Cyclone DDS entity of this process (participants, readers, writers, topics of all domains).

    Registered with ``atexit`` by the first :func:`participant`; a program may also call it when it is done with
    DDS. Python objects of deleted entities stay valid to release (their own deletion then finds nothing to do)
    but not to use. Returns Cyclone's return code (0: deleted; ``DDS_RETCODE_PRECONDITION_NOT_MET`` -4 when no
    entity existed)."""
    import ctypes

    from cyclonedds.internal import load_cyclonedds

    dds_delete = load_cyclonedds().dds_delete
    dds_delete.argtypes, dds_delete.restype = [ctypes.c_int32], ctypes.c_int32
    return int(dds_delete(CYCLONEDDS_HANDLE))


def _wildcard_udp_sockets() -> dict[int, int]:
    """{file descriptor: socket inode} of this process's UDP sockets bound to the IPv4/IPv6 wildcard address
    (from ``/proc/self/net/udp*`` and ``/proc/self/fd``); empty where /proc is not available."""
    inodes = set()
    for name, wildcard in (("udp", "00000000"), ("udp6", "0" * 32)):
        try:
            with open(f"/proc/self/net/{name}") as f:
                rows = f.read().splitlines()[1:]
        except OSError:
            continue
        for row in rows:
            cols = row.split()
            if len(cols) > 9 and cols[1].split(":")[0] == wildcard:
                inodes.add(int(cols[9]))
    found = {}
    try:
        fds = os.listdir("/proc/self/fd")
    except OSError:
        return found
    for fd in fds:
        try:
            link = os.readlink(f"/proc/self/fd/{fd}")
        except OSError:
            continue
        if link.startswith("socket:[") and int(link[8:-1]) in inodes:
            found[int(fd)] = int(link[8:-1])
    return found


def _warn_not_redirected() -> None:
    """Warn once per process that Cyclone's receive sockets are bound to 0.0.0.0 before they are restricted."""
    if _warned_not_redirected:
        return
    import warnings

    _warned_not_redirected.append(True)
    warnings.warn(f"DDS: Cyclone's bind() could not be redirected to 127.0.0.1 ({loopback_bind.installed()}); its "
                  "receive sockets are bound to 0.0.0.0 and restricted to the lo device just after (pip install "
                  "pyelftools, on Linux, to bind them to 127.0.0.1 from the start)", RuntimeWarning, stacklevel=3)


_warned_not_redirected: list[bool] = []


def _bind_to_loopback_device(sockets: dict[int, int]) -> None:
    """Restrict the sockets ``{fd: inode}`` (Cyclone's wildcard-bound receive sockets) to the ``lo`` device."""
    import socket
    import warnings

    for fd in sockets:
        try:
            sock = socket.socket(fileno=os.dup(fd))
        except OSError:
            continue
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_BINDTODEVICE, b"lo\0")
        except (OSError, AttributeError) as exc:  # not Linux, or Linux < 5.7 without CAP_NET_RAW
            warnings.warn(f"DDS: could not bind Cyclone's receive socket (fd {fd}) to the loopback device ({exc}); "
                          "it stays on 0.0.0.0 (packets are still sent to 127.0.0.1 only)", RuntimeWarning,
                          stacklevel=3)
        finally:
            sock.close()  # closes the duplicate only; Cyclone keeps its descriptor


def qos_stream(depth: int):
    """Reliable, volatile, keep-last(``depth``) — /joint_states, /tf."""
    from cyclonedds.core import Policy, Qos
    from cyclonedds.util import duration

    return Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(int(depth)),
               Policy.Durability.Volatile)


def qos_latched():
    """Reliable, transient-local, keep-last(1) — /robot_description, /tf_static (late joiners get the sample)."""
    from cyclonedds.core import Policy, Qos
    from cyclonedds.util import duration

    return Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(1),
               Policy.Durability.TransientLocal)


def ros_topic(name: str) -> str:
    """DDS topic name of the ROS 2 topic ``name``: ``/joint_states`` → ``rt/joint_states``."""
    return "rt/" + name.lstrip("/")
