"""For the Cyclone DDS test clients (tests/ros2/ros2_node_client.py, ros2_subscriber.py), which use no part of wbc's
ROS 2 code but its socket confinement: Cyclone binds its unicast receive sockets to 0.0.0.0 whatever its
configuration. :func:`loopback_participant` creates the client's ``DomainParticipant`` with Cyclone's ``bind`` calls
redirected to 127.0.0.1 (:mod:`wbc.ros2.loopback_bind`, as ``wbc.ros2.dds.participant`` does for wbc's own
participants); where that cannot be done, :func:`bind_to_lo` restricts the wildcard-bound sockets to the ``lo``
device just after (``SO_BINDTODEVICE``). Not a test module."""

import os
import socket


def loopback_participant(domain: int):
    """A ``DomainParticipant`` on ``domain`` whose receive sockets are bound to 127.0.0.1 (or, failing the
    redirection, restricted to ``lo`` just after their creation)."""
    from cyclonedds.domain import DomainParticipant

    from wbc.ros2 import loopback_bind

    if loopback_bind.install():
        with loopback_bind.confined():
            return DomainParticipant(domain)
    participant = DomainParticipant(domain)
    bind_to_lo()
    return participant


def bind_to_lo() -> int:
    """Bind every UDP socket of this process bound to the IPv4/IPv6 wildcard address to ``lo``; returns how many."""
    wild = set()
    for name, zero in (("udp", "00000000"), ("udp6", "0" * 32)):
        with open(f"/proc/self/net/{name}") as f:
            wild |= {c[9] for c in (r.split() for r in f.read().splitlines()[1:]) if c[1].split(":")[0] == zero}
    n = 0
    for fd in os.listdir("/proc/self/fd"):
        try:
            link = os.readlink(f"/proc/self/fd/{fd}")
        except OSError:
            continue
        if link.startswith("socket:[") and link[8:-1] in wild:
            sock = socket.socket(fileno=os.dup(int(fd)))
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_BINDTODEVICE, b"lo\0")
            sock.close()
            n += 1
    return n
