"""Cyclone DDS entity handles of the Python binding's entities, through Cyclone's public C API.

The Python binding (cyclonedds 11.0.1) keeps an entity's C handle to itself. Two wbc features need it:
:mod:`wbc.ros2.endpoints` (a topic's sertype, ``dds_get_entity_sertype``) and :mod:`wbc.ros2.discovery` (the
readers and writers of a participant, ``dds_get_children``). A participant's handle is the participant of its
domain (``dds_lookup_participant``) with its GUID (``dds_get_guid``); a topic's is the child of its participant
with its name (``dds_get_name``).
"""

from __future__ import annotations

import ctypes

__all__ = ["participant_handle", "topic_handle", "children", "guid_of", "sertype_address"]

_GUID = ctypes.c_uint8 * 16
_SIGNATURES = {  # name: (argument types, return type), from dds/dds.h
    "dds_lookup_participant": ([ctypes.c_uint32, ctypes.POINTER(ctypes.c_int32), ctypes.c_size_t], ctypes.c_int32),
    "dds_get_guid": ([ctypes.c_int32, ctypes.POINTER(_GUID)], ctypes.c_int32),
    "dds_get_children": ([ctypes.c_int32, ctypes.POINTER(ctypes.c_int32), ctypes.c_size_t], ctypes.c_int32),
    "dds_get_name": ([ctypes.c_int32, ctypes.c_char_p, ctypes.c_size_t], ctypes.c_int32),
    "dds_get_entity_sertype": ([ctypes.c_int32, ctypes.POINTER(ctypes.c_void_p)], ctypes.c_int32),
}
_bound: dict = {}


def _c(name: str):
    """The Cyclone C function ``name`` with its signature (bound once per process)."""
    if name not in _bound:
        from cyclonedds.internal import load_cyclonedds

        fn = getattr(load_cyclonedds(), name)
        fn.argtypes, fn.restype = _SIGNATURES[name]
        _bound[name] = fn
    return _bound[name]


def _handles(fn_name: str, first) -> list[int]:
    """The handles a ``(first, buffer, size)`` listing call returns (asked once for the count, then filled)."""
    fn = _c(fn_name)
    n = fn(first, None, 0)
    if n <= 0:
        return []
    buf = (ctypes.c_int32 * n)()
    got = fn(first, buf, n)
    return list(buf[:max(0, min(n, got))])


def guid_of(handle: int) -> bytes | None:
    """The 16-byte GUID of the entity ``handle``, None for an entity without one (or an invalid handle)."""
    g = _GUID()
    return bytes(g) if _c("dds_get_guid")(handle, ctypes.byref(g)) == 0 else None


def children(handle: int) -> list[int]:
    """Handles of the children of the entity ``handle`` (``dds_get_children``; empty when it has none)."""
    return _handles("dds_get_children", handle)


def participant_handle(part) -> int:
    """The C handle of the cyclonedds ``DomainParticipant`` ``part``; 0 if Cyclone does not list it."""
    want = part.guid.bytes
    for h in _handles("dds_lookup_participant", part.domain_id):
        if guid_of(h) == want:
            return h
    return 0


def topic_handle(topic) -> int:
    """The C handle of a cyclonedds ``Topic`` (a topic of its participant with its name); 0 if none is found."""
    name = topic.get_name().encode()
    buf = ctypes.create_string_buffer(len(name) + 2)
    for h in children(participant_handle(topic.participant)):
        if _c("dds_get_name")(h, buf, len(buf)) >= 0 and buf.value == name:
            return h
    return 0


def sertype_address(topic) -> int:
    """Address of the ``ddsi_sertype`` of a cyclonedds ``Topic`` (``dds_get_entity_sertype``); 0 if unknown."""
    h = topic_handle(topic)
    out = ctypes.c_void_p()
    if not h or _c("dds_get_entity_sertype")(h, ctypes.byref(out)) != 0:
        return 0
    return out.value or 0
