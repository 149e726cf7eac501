"""Cyclone DDS's receive sockets bound to the loopback address from their creation on.

Cyclone DDS 11.0.1 binds its unicast receive sockets to the wildcard address, whatever interface its configuration
names (``ddsi_udp_create_conn`` in ``ddsi_udp.c``: ``bind_to_any`` for a receive socket); no configuration element
changes that. Restricting them to the ``lo`` device afterwards (``SO_BINDTODEVICE``, what :func:`wbc.ros2.dds.participant`
does when this module cannot be used) leaves them open on every interface between Cyclone's ``bind`` and that call.

:func:`install` points Cyclone's library's procedure-linkage-table slot for ``bind`` (its ``.got.plt`` entry, which
lazy binding leaves writable) at :func:`_bind`: inside :func:`confined`, a socket asked for the IPv4 or IPv6 wildcard
address is bound to 127.0.0.1 or ::1, same port; every other call goes to the C library's ``bind`` unchanged, and
its result and ``errno`` come back to Cyclone as they were (a port in use still makes Cyclone try the next
participant index). Only Cyclone's library is redirected, not the process's other sockets.
"""

from __future__ import annotations

import contextlib
import ctypes
import threading
from typing import Iterator

__all__ = ["confined", "install", "installed"]

_AF_INET, _AF_INET6 = 2, 10
_LOOPBACK4 = bytes((127, 0, 0, 1))
_LOOPBACK6 = bytes(15) + b"\x01"

_libc = ctypes.CDLL(None, use_errno=True)
_libc_bind = _libc.bind
_libc_bind.argtypes, _libc_bind.restype = [ctypes.c_int, ctypes.c_void_p, ctypes.c_uint32], ctypes.c_int

_lock = threading.Lock()
_state = {"installed": None, "confined": 0}  # installed: None (not tried), True, or the reason it was not


def _bind(fd: int, address: int | None, length: int) -> int:
    """Cyclone's ``bind``: a wildcard address becomes the loopback one (same family and port) inside
    :func:`confined`; the C library's ``bind`` does the rest (``errno`` passed back through ctypes)."""
    if _state["confined"] and address:
        family = ctypes.c_ushort.from_address(address).value
        raw = ctypes.string_at(address, length)
        if family == _AF_INET and length >= 16 and raw[4:8] == bytes(4):
            return _libc_bind(fd, ctypes.create_string_buffer(raw[:4] + _LOOPBACK4 + raw[8:], length), length)
        if family == _AF_INET6 and length >= 28 and raw[8:24] == bytes(16):
            return _libc_bind(fd, ctypes.create_string_buffer(raw[:8] + _LOOPBACK6 + raw[24:], length), length)
    return _libc_bind(fd, address, length)


_BIND_TYPE = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_int, ctypes.c_void_p, ctypes.c_uint32, use_errno=True)
_bind_pointer = _BIND_TYPE(_bind)  # lives as long as the process: Cyclone's slot points at it


class _DlInfo(ctypes.Structure):
    _fields_ = [("dli_fname", ctypes.c_char_p), ("dli_fbase", ctypes.c_void_p), ("dli_sname", ctypes.c_char_p),
                ("dli_saddr", ctypes.c_void_p)]


def _library() -> tuple[str, int]:
    """(path, load address) of the Cyclone DDS C library the ``cyclonedds`` binding loaded."""
    from cyclonedds.internal import load_cyclonedds

    lib = load_cyclonedds()
    info = _DlInfo()
    dladdr = _libc.dladdr
    dladdr.argtypes, dladdr.restype = [ctypes.c_void_p, ctypes.POINTER(_DlInfo)], ctypes.c_int
    if not dladdr(ctypes.cast(lib.dds_create_participant, ctypes.c_void_p), ctypes.byref(info)):
        raise OSError("dladdr found no library for dds_create_participant")
    return info.dli_fname.decode(), int(info.dli_fbase)


def _bind_slots(path: str) -> tuple[list[int], int]:
    """(addresses relative to the load address of the library's ``bind`` jump slots, lowest loaded address)."""
    from elftools.elf.elffile import ELFFile
    from elftools.elf.enums import ENUM_RELOC_TYPE_AARCH64, ENUM_RELOC_TYPE_x64
    from elftools.elf.relocation import RelocationSection

    jump_slots = {ENUM_RELOC_TYPE_x64["R_X86_64_JUMP_SLOT"], ENUM_RELOC_TYPE_AARCH64["R_AARCH64_JUMP_SLOT"]}
    with open(path, "rb") as f:
        elf = ELFFile(f)
        lowest = min(seg["p_vaddr"] for seg in elf.iter_segments() if seg["p_type"] == "PT_LOAD")
        slots = []
        for section in elf.iter_sections():
            if not isinstance(section, RelocationSection) or not section["sh_link"]:
                continue
            symbols = elf.get_section(section["sh_link"])
            for reloc in section.iter_relocations():
                if reloc["r_info_type"] in jump_slots and \
                        symbols.get_symbol(reloc["r_info_sym"]).name == "bind":
                    slots.append(reloc["r_offset"])
    return slots, lowest & ~0xFFF


def _writable(address: int) -> bool:
    """Whether ``address`` lies in a writable mapping of this process (/proc/self/maps)."""
    with open("/proc/self/maps") as f:
        for line in f:
            span, perms = line.split()[:2]
            lo, hi = (int(x, 16) for x in span.split("-"))
            if lo <= address < hi:
                return perms[1] == "w"
    return False


def install() -> bool:
    """Redirect the Cyclone DDS library's calls to ``bind`` to this module (once per process; later calls return the
    first answer). Call it before the process's first DDS domain is created: sockets bound before stay as they are.

    Returns:
        True when the redirection is in place; False when it could not be (not Linux or no ``/proc``, ``pyelftools``
        missing, a library linked without a writable ``bind`` slot): :func:`installed` then gives the reason.
    """
    with _lock:
        if _state["installed"] is None:
            try:
                path, base = _library()
                slots, lowest = _bind_slots(path)
                if not slots:
                    raise OSError(f"{path} has no 'bind' jump slot")
                addresses = [base - lowest + offset for offset in slots]
                if not all(_writable(a) for a in addresses):
                    raise OSError(f"the 'bind' slot of {path} is read-only (linked with full RELRO)")
                target = ctypes.cast(_bind_pointer, ctypes.c_void_p).value
                for address in addresses:
                    ctypes.c_void_p.from_address(address).value = target
                _state["installed"] = True
            except (ImportError, OSError, ValueError, AttributeError) as exc:
                _state["installed"] = f"{type(exc).__name__}: {exc}"
        return _state["installed"] is True


def installed() -> bool | str | None:
    """True once :func:`install` succeeded; the reason it failed (a string); None before it was called."""
    return _state["installed"]


@contextlib.contextmanager
def confined() -> Iterator[None]:
    """Within this block, Cyclone sockets asked for the wildcard address are bound to the loopback one (when
    :func:`install` succeeded; nothing changes otherwise). Nestable; thread-safe for its counter."""
    with _lock:
        _state["confined"] += 1
    try:
        yield
    finally:
        with _lock:
            _state["confined"] -= 1
