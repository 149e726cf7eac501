"""numba's on-disk kernel caches dropped when any of wbc's kernel sources changes.

numba keys a cached kernel (``cache=True``) by the modification time and size of the kernel's own source file
(numba documentation, "Notes on caching": "Changes in other files, such as functions called from the cached
function, are not detected"). wbc's kernels call kernels of other files (the kinematic tick calls the dense active
set, the ID tick the block solver): after an edit of ``wbc/solvers/active_set.py`` alone, the cached kinematic tick
kept running the old active set. :func:`drop_stale_caches` runs when :mod:`wbc` is imported: it keeps, next to the
caches, a record of every wbc source file (modification time, size, and the SHA-1 of each kernel source's content)
and, when a kernel source's content differs from the record (or there is no record yet), deletes every cached
kernel of wbc (``*.nbi``/``*.nbc``), so that each kernel compiles again against the current sources on its next
call. A file touched without a change of content (a ``git checkout``) drops nothing.

Where the caches are: ``__pycache__`` next to each source, or under ``NUMBA_CACHE_DIR`` when it is set (numba's
first two cache locators); a source folder where neither is writable (an installation without write access, whose
sources do not change) is not checked. Cost when nothing changed: one ``stat`` per wbc source file (about 150) and
one small JSON read.

Limit: a process started before an edit that writes a cache after it (its kernels compiled from the old sources)
leaves a stale entry the next import does not see; edit kernels with no wbc process running.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

__all__ = ["KERNEL_DECORATOR", "RECORD_NAME", "cache_folder", "drop_stale_caches", "kernel_sources"]

#: A numba kernel cached on disk, as wbc's sources declare one: an ``njit`` decorator with ``cache=True``.
KERNEL_DECORATOR = re.compile(r"@(?:nb\.|numba\.)?n?jit\([^)]*cache=True")

#: The record's file name: in ``wbc/__pycache__``, or under ``NUMBA_CACHE_DIR`` prefixed with the checkout's folder
#: name and a hash of its path (one cache folder may serve several checkouts).
RECORD_NAME = "wbc-kernel-sources.json"


def cache_folder(source: Path, cache_dir: str | None = None) -> Path:
    """The folder where numba writes the caches of the kernels defined in ``source``.

    Args:
        source: path of a Python source file.
        cache_dir: the value of ``NUMBA_CACHE_DIR`` (None or empty: unset).

    Returns:
        ``__pycache__`` next to ``source``, or numba's sub-folder for ``source`` under ``cache_dir``.
    """
    if not cache_dir:
        return source.parent / "__pycache__"
    from numba.core.caching import UserProvidedCacheLocator

    return Path(cache_dir) / UserProvidedCacheLocator.get_suitable_cache_subpath(str(source))


def kernel_sources(root: Path | None = None) -> list[Path]:
    """wbc's source files that define at least one on-disk cached numba kernel (:data:`KERNEL_DECORATOR`).

    Args:
        root: the package folder (default: the installed ``wbc``).

    Returns:
        The files, sorted.
    """
    root = Path(__file__).resolve().parent if root is None else root
    return sorted(p for p in root.rglob("*.py") if KERNEL_DECORATOR.search(_read(p)))


def drop_stale_caches(root: Path | None = None, cache_dir: str | None = None) -> list[Path]:
    """Delete every cached wbc kernel when a kernel source changed since the record was written (module docstring).

    Args:
        root: the package folder (default: the installed ``wbc``).
        cache_dir: where numba writes its caches (default: the environment's ``NUMBA_CACHE_DIR``; unset or empty:
            ``__pycache__`` next to each source).

    Returns:
        The cache files deleted (empty when nothing changed, or when the record's folder is not writable).
    """
    root = Path(__file__).resolve().parent if root is None else root
    cache_dir = os.environ.get("NUMBA_CACHE_DIR") if cache_dir is None else cache_dir
    record_path = (Path(cache_dir) / f"{root.parent.name}-{_path_hash(root)}-{RECORD_NAME}" if cache_dir else
                   root / "__pycache__" / RECORD_NAME)
    try:
        record_path.parent.mkdir(parents=True, exist_ok=True)
    except OSError:
        return []
    if not os.access(record_path.parent, os.W_OK):
        return []
    try:
        old = json.loads(record_path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        old = {}
    if not isinstance(old, dict) or not all(isinstance(e, list) and len(e) == 3 for e in old.values()):
        old = {}  # not a record this function wrote: trusted as little as none
    new = {}
    for path in root.rglob("*.py"):
        name = str(path.relative_to(root))
        try:
            st = path.stat()
        except OSError:
            continue
        entry = old.get(name)
        if entry is not None and entry[:2] == [st.st_mtime_ns, st.st_size]:
            new[name] = entry
            continue
        text = _read(path)
        digest = _sha1(text) if KERNEL_DECORATOR.search(text) else None
        new[name] = [st.st_mtime_ns, st.st_size, digest]
    if new == old:
        return []
    deleted = []
    if _kernels(new) != _kernels(old):
        for name in set(_kernels(new)) | set(_kernels(old)):
            source = root / name
            for cached in cache_folder(source, cache_dir).glob(f"{source.stem}.*.nb[ic]"):
                try:
                    cached.unlink()
                    deleted.append(cached)
                except OSError:
                    pass
    try:
        partial = record_path.with_name(f"{record_path.name}.{os.getpid()}")
        partial.write_text(json.dumps(new, sort_keys=True), encoding="utf-8")
        os.replace(partial, record_path)
    except OSError:
        pass
    return deleted


def _kernels(record: dict) -> dict:
    """The record's kernel sources and their content hashes."""
    return {name: entry[2] for name, entry in record.items() if entry[2] is not None}


def _sha1(text: str) -> str:
    """The SHA-1 of a text (hashlib imported here: its import costs more than the check when nothing changed)."""
    import hashlib

    return hashlib.sha1(text.encode("utf-8")).hexdigest()


def _path_hash(path: Path) -> str:
    """A short hash of a folder's path."""
    return _sha1(str(path))[:12]


def _read(path: Path) -> str:
    """A source file's text ('' when unreadable)."""
    try:
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return ""
