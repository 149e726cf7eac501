"""DDS participant, QoS profiles and the loopback-only configuration (cyclonedds).

``loopback_uri()`` returns a ``CYCLONEDDS_URI`` value confining Cyclone DDS to 127.0.0.1: the ``lo`` interface,
multicast off, and localhost as the only unicast peer. Export it (``export CYCLONEDDS_URI=...``) before starting
any process, or call :func:`use_loopback` before the first participant is created.
"""

from __future__ import annotations

import os

__all__ = ["loopback_uri", "use_loopback", "domain_id", "participant", "qos_stream", "qos_latched", "ros_topic"]


def loopback_uri() -> str:
    """A Cyclone DDS XML configuration (as one string) that keeps every packet on the loopback interface."""
    return (
        "<CycloneDDS><Domain id=\"any\"><General><Interfaces><NetworkInterface name=\"lo\"/></Interfaces>"
        "<AllowMulticast>false</AllowMulticast></General>"
        "<Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>60</MaxAutoParticipantIndex>"
        "<Peers><Peer address=\"127.0.0.1\"/></Peers></Discovery></Domain></CycloneDDS>"
    )


def use_loopback() -> None:
    """Set ``CYCLONEDDS_URI`` to :func:`loopback_uri` in this process unless it is already set."""
    os.environ.setdefault("CYCLONEDDS_URI", loopback_uri())


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
    """A ``cyclonedds.domain.DomainParticipant`` on ``domain`` (default :func:`domain_id`)."""
    from cyclonedds.domain import DomainParticipant

    return DomainParticipant(domain_id() if domain is None else domain)


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
