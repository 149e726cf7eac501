"""wbc.ros2.handles: the C handles of the Python binding's entities, checked against the GUIDs the binding reports."""

import pytest
from conftest import dds_domain_id

for _mod in ("cyclonedds", "rosbags"):
    pytest.importorskip(_mod, reason=f"the optional extra wbc[ros2] is not installed ({_mod} missing)")

from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402

from wbc.ros2 import dds, msgs  # noqa: E402
from wbc.ros2.handles import children, guid_of, participant_handle, sertype_address, topic_handle  # noqa: E402


def test_handles_of_two_participants_on_one_domain_and_their_writers():
    domain = dds_domain_id()
    a, b = dds.participant(domain), DomainParticipant(domain)
    ha, hb = participant_handle(a), participant_handle(b)
    assert ha and hb and ha != hb
    assert (guid_of(ha), guid_of(hb)) == (a.guid.bytes, b.guid.bytes)
    q = dds.qos_stream(10)
    w = DataWriter(b, Topic(b, "rt/wbc_handles", msgs.String, qos=q), qos=q)
    endpoint_guids = {guid_of(h) for group in children(hb) for h in children(group)}
    assert w.guid.bytes in endpoint_guids
    assert not any(guid_of(h) == w.guid.bytes for group in children(ha) for h in children(group))


def test_topic_handle_and_sertype_of_a_topic():
    part = dds.participant(dds_domain_id())
    t1 = Topic(part, "rt/wbc_handles_one", msgs.JointState)
    t2 = Topic(part, "rt/wbc_handles_two", msgs.JointState)
    t3 = Topic(part, "rt/wbc_handles_three", msgs.String)
    h1, h2, h3 = topic_handle(t1), topic_handle(t2), topic_handle(t3)
    assert len({h1, h2, h3}) == 3 and 0 not in (h1, h2, h3)
    # one sertype per type: the two JointState topics share Cyclone's registered sertype, String has its own
    assert sertype_address(t1) == sertype_address(t2) != sertype_address(t3)
    assert guid_of(-1) is None and children(-1) == []
