"""The node in the ROS 2 graph: ``ros_discovery_info`` as every rmw publishes it.

ROS 2's graph (``ros2 node list``, ``rclpy.node.Node.get_node_names_and_namespaces``) is not DDS discovery: every
rmw (rmw_fastrtps, rmw_cyclonedds, rmw_connextdds) publishes on the DDS topic ``ros_discovery_info`` (no ``rt/``
prefix; type ``rmw_dds_common/msg/ParticipantEntitiesInfo``; reliable, transient-local, keep-last 1) its
participant's GID and, per node, the node's namespace, name and the GIDs of its readers and writers (rmw_dds_common
``GraphCache``). A participant that publishes nothing there owns its endpoints as ``_CREATED_BY_BARE_DDS_APP_``.
:class:`GraphAnnouncement` publishes that sample for a Cyclone participant: the node's readers and writers are all
the readers and writers of the participant at :meth:`GraphAnnouncement.publish` time (Cyclone's entity tree).
A GID is the entity's DDS GUID (12-byte prefix, 4-byte entity id), as rmw_fastrtps and rmw_cyclonedds (ROS 2 Iron
and later: 16 bytes) compute it.
"""

from __future__ import annotations

import re

__all__ = ["GraphAnnouncement", "DISCOVERY_TOPIC", "gid"]

#: The DDS topic of the ROS 2 graph (rmw_dds_common).
DISCOVERY_TOPIC = "ros_discovery_info"
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def gid(entity):
    """The ``rmw_dds_common/msg/Gid`` of a cyclonedds entity: its GUID's 16 bytes."""
    from wbc.ros2 import msgs

    return msgs.Gid(data=list(entity.guid.bytes))


def _endpoints(part) -> tuple[list, list]:
    """(readers, writers) of the cyclonedds participant ``part``: the Python readers and writers among the children
    of its publishers and subscribers (implicit ones included, which have no Python object)."""
    from cyclonedds.core import Entity
    from cyclonedds.pub import DataWriter
    from cyclonedds.sub import DataReader

    from wbc.ros2.handles import children, participant_handle

    readers, writers = [], []
    for group in children(participant_handle(part)):
        for handle in children(group):
            e = Entity.get_entity(handle)
            if isinstance(e, DataReader):
                readers.append(e)
            elif isinstance(e, DataWriter):
                writers.append(e)
    return readers, writers


class GraphAnnouncement:
    """Announce the node ``name`` in ``namespace`` (default "/") of the cyclonedds participant ``part`` on
    ``ros_discovery_info``. Creating it publishes once; call :meth:`publish` again after creating more readers or
    writers.

    Raises:
        wbc.exceptions.InvalidInputError: ``name`` is not a valid ROS 2 node name (letters, digits, underscores,
            not starting with a digit) or ``namespace`` does not start with "/".
    """

    def __init__(self, part, name: str, namespace: str = "/"):
        from wbc.exceptions import InvalidInputError
        from wbc.ros2 import dds, msgs
        from wbc.ros2.endpoints import writer

        if not isinstance(name, str) or not _NAME.fullmatch(name):
            raise InvalidInputError(f"ROS 2 node name {name!r} is invalid: valid are letters, digits and '_', not "
                                    "starting with a digit")
        if not isinstance(namespace, str) or not namespace.startswith("/"):
            raise InvalidInputError(f"ROS 2 namespace {namespace!r} is invalid: valid namespaces start with '/'")
        self.part, self.name, self.namespace = part, name, namespace
        self._writer = writer(part, DISCOVERY_TOPIC, msgs.ParticipantEntitiesInfo, dds.qos_latched())
        self.publish()

    def message(self):
        """The ``ParticipantEntitiesInfo`` sample for the participant's readers and writers now."""
        from wbc.ros2 import msgs

        readers, writers = _endpoints(self.part)
        node = msgs.NodeEntitiesInfo(node_namespace=self.namespace, node_name=self.name,
                                     reader_gid_seq=[gid(r) for r in readers],
                                     writer_gid_seq=[gid(w) for w in writers if w is not self._writer])
        return msgs.ParticipantEntitiesInfo(gid=gid(self.part), node_entities_info_seq=[node])

    def publish(self) -> None:
        """Publish :meth:`message` (transient-local: late joiners receive the last one)."""
        self._writer.write(self.message())
