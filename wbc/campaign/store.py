"""A campaign's results on disk: a folder holding the spec and a Parquet dataset of one row per trial.

Layout of ``OUT/``::

    campaign.json          the spec (``CampaignSpec.as_dict``) the rows were made with
    trials/part-*.parquet  one file per finished trial, written to a temporary name and renamed (atomic)
    trials/compact-*.parquet  the parts merged once a run completes (then the parts are removed)

Any Parquet reader takes the ``trials/`` folder as one table (``pyarrow.dataset``, ``pandas.read_parquet``);
:func:`read_results` also applies the one-row-per-trial rule below.

**Finished and unfinished rows.** A row is *finished* when the trial ran to its end: it survived, fell, failed,
or its trial function raised (``outcome = "error"``, ``error_kind = "exception"``: a trial is a pure function of
(seed, index), so the exception is its result and would recur). A row is *unfinished* when the executor lost the
trial (``outcome = "error"``, ``error_kind = "lost"``): its worker died more often than the retries allow, the Ray
node or raylet went away, or the driver was being interrupted. Rows written before ``error_kind`` existed are
classified by ``worker``: a trial function's exception row always names the worker that ran it, the executor's
own error row does not (:func:`is_finished`). A run stopped at any point (Ctrl-C, SIGKILL, a lost machine) leaves
only complete files; a run restarted on the same folder skips the trials that have a finished row and runs the
others again (:meth:`ResultStore.done`).

**One campaign per folder at a time.** A store holds an exclusive lock (``flock``) on ``OUT/campaign.lock``, which
names the holder's pid, until :meth:`ResultStore.close` or the end of its process (the kernel releases it even
after a SIGKILL); a second campaign on the folder is refused with that pid instead of running every trial again.

**One row per trial.** Should several rows hold the same ``trial`` (a rerun of an unfinished trial, a crash
between compaction and the removal of its parts), the reader keeps one: a finished row over an unfinished one,
and among those the latest written (file modification time, then file name, then row order).
"""

from __future__ import annotations

import json
import os
import socket
import time
from pathlib import Path

from wbc.exceptions import InvalidInputError

__all__ = ["ResultStore", "read_results", "is_finished", "finished_mask", "lock_folder", "unlock_folder",
           "LOCK_NAME"]


class ResultStore:
    """Append-only store of trial rows in ``out`` (module docstring).

    Args:
        out: the campaign folder (created if missing; its parent must exist).
        spec_dict: the spec as a mapping; a folder made by another spec is refused.

    Raises:
        InvalidInputError: ``out`` is a file, its parent does not exist or is not writable, or the folder holds
            another campaign's results (its ``campaign.json`` differs).
    """

    def __init__(self, out, spec_dict: dict):
        import pyarrow  # noqa: F401  (fail here, before any trial runs, if pyarrow is missing)

        self.out = Path(out)
        if self.out.exists() and not self.out.is_dir():
            raise InvalidInputError(f"campaign output {self.out} is a file; give a folder")
        if not self.out.parent.is_dir():
            raise InvalidInputError(f"campaign output {self.out}: parent folder {self.out.parent} does not exist")
        self.trials_dir = self.out / "trials"
        try:
            self.trials_dir.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise InvalidInputError(f"campaign output {self.out}: cannot create it ({e.strerror or e})") from None
        if not os.access(self.trials_dir, os.W_OK):
            raise InvalidInputError(f"campaign output {self.out}: not writable")
        lock_folder(self.out)
        meta = self.out / "campaign.json"
        text = json.dumps(spec_dict, indent=2, sort_keys=True)
        if meta.exists():
            try:
                old = json.loads(meta.read_text())
            except (OSError, ValueError) as e:
                raise InvalidInputError(f"{meta}: unreadable ({e}); remove the folder or choose another") from None
            if old != json.loads(text):
                raise InvalidInputError(f"{self.out} holds the results of another campaign (its campaign.json "
                                        "differs from this spec); choose another --results or remove it")
        else:
            _atomic_write_text(meta, text)
        self._seq = 0
        self._tag = f"{socket.gethostname()}-{os.getpid()}-{int(time.time() * 1e3)}"

    def close(self) -> None:
        """Release the folder's lock (:func:`unlock_folder`); the store writes no more rows."""
        unlock_folder(self.out)

    def done(self, *, rerun_errors: bool = False) -> set:
        """Indices of the trials with a finished row (module docstring): the trials a resumed run skips.

        Args:
            rerun_errors: also leave out the trials whose row is a trial function's exception (to run them again
                after the cause was fixed); unfinished (lost) trials are always left out.
        """
        table = read_results(self.out, missing_ok=True)
        if table is None:
            return set()
        trials = table.column("trial").to_pylist()
        keep = finished_mask(table)
        if rerun_errors:
            outcome = table.column("outcome").to_pylist() if "outcome" in table.column_names else [None] * len(trials)
            keep = [k and o != "error" for k, o in zip(keep, outcome)]
        return {t for t, k in zip(trials, keep) if k}

    def append(self, row: dict) -> None:
        """Record one finished trial's row (atomically: a temporary file renamed into ``trials/``)."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        self._seq += 1
        path = self.trials_dir / f"part-{self._tag}-{self._seq:07d}.parquet"
        tmp = path.with_name("." + path.name + ".tmp")
        pq.write_table(pa.Table.from_pylist([row]), tmp)
        os.replace(tmp, path)

    def compact(self) -> Path | None:
        """Merge every file of ``trials/`` into one (written atomically, then the merged files removed)."""
        import pyarrow.parquet as pq

        files = _files(self.trials_dir)
        if len(files) <= 1:
            return files[0] if files else None
        table = read_results(self.out)
        path = self.trials_dir / f"compact-{self._tag}.parquet"
        tmp = path.with_name("." + path.name + ".tmp")
        pq.write_table(table, tmp)
        os.replace(tmp, path)
        for f in files:
            if f != path:
                f.unlink(missing_ok=True)
        return path


#: The lock file of a campaign folder (module docstring).
LOCK_NAME = "campaign.lock"
_LOCKS: dict[str, int] = {}  # resolved folder -> descriptor of its lock file, for the folders this process holds


def lock_folder(out) -> None:
    """Hold the exclusive lock of campaign folder ``out`` for this process (again: nothing to do).

    Raises:
        InvalidInputError: another process holds it (the message names its pid).
    """
    import fcntl

    key = str(Path(out).resolve())
    if key in _LOCKS:
        return
    fd = os.open(Path(out) / LOCK_NAME, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        holder = os.pread(fd, 200, 0).decode(errors="replace").strip() or "unknown"
        os.close(fd)
        raise InvalidInputError(f"campaign output {out} is in use by another campaign ({holder}); wait for it to "
                                f"end, or choose another --results") from None
    os.ftruncate(fd, 0)
    os.pwrite(fd, f"pid {os.getpid()} on {socket.gethostname()}\n".encode(), 0)
    _LOCKS[key] = fd


def unlock_folder(out) -> None:
    """Release this process's lock of campaign folder ``out`` (not held: nothing to do)."""
    fd = _LOCKS.pop(str(Path(out).resolve()), None)
    if fd is not None:
        os.close(fd)


def is_finished(row: dict) -> bool:
    """Whether a row is a finished trial's (module docstring): not an executor's lost-trial error row."""
    if row.get("outcome") != "error":
        return True
    kind = row.get("error_kind")
    if kind is not None:
        return kind != "lost"
    return row.get("worker") is not None  # a row written before error_kind: the executor's own names no worker


def finished_mask(table) -> list:
    """:func:`is_finished` of each row of a results table (``pyarrow.Table``), as a list of bools."""
    names = [c for c in ("outcome", "error_kind", "worker") if c in table.column_names]
    cols = {c: table.column(c).to_pylist() for c in names}
    return [is_finished({c: cols[c][i] for c in names}) for i in range(table.num_rows)]


def read_results(out, *, missing_ok: bool = False):
    """The campaign's rows as a ``pyarrow.Table``: one row per trial (a finished one over an unfinished one, then
    the latest written: module docstring), sorted by ``trial``.

    Args:
        out: the campaign folder (or its ``trials/`` folder, or one Parquet file).
        missing_ok: return None instead of raising when no row is recorded yet.

    Raises:
        InvalidInputError: no such folder / no rows (unless ``missing_ok``), or a file that is not Parquet.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    out = Path(out)
    if out.is_file():
        files = [out]
    else:
        d = out / "trials" if (out / "trials").is_dir() else out
        files = _files(d) if d.is_dir() else []
    if not files:
        if missing_ok:
            return None
        raise InvalidInputError(f"no campaign results in {out} (expected {out}/trials/*.parquet)")
    files.sort(key=_written_order)  # oldest first
    tables = []
    for f in files:
        try:
            tables.append(pq.read_table(f))
        except (OSError, pa.ArrowInvalid) as e:
            raise InvalidInputError(f"{f}: not a readable Parquet file ({e})") from None
    table = pa.concat_tables(tables, promote_options="permissive")
    trial = table.column("trial").to_pylist()
    finished = finished_mask(table)
    best: dict = {}
    for i, t in enumerate(trial):  # rows in written order: a later row of the same rank replaces an earlier one
        j = best.get(t)
        if j is None or finished[i] >= finished[j]:
            best[t] = i
    table = table.take(pa.array(sorted(best.values()), type=pa.int64()))
    return table.sort_by("trial")


def _written_order(path: Path) -> tuple:
    try:
        mtime = path.stat().st_mtime_ns
    except OSError:  # removed meanwhile (a concurrent compaction): its rows are in the compacted file
        mtime = 0
    return mtime, path.name


def _files(d: Path) -> list:
    return sorted(p for p in d.glob("*.parquet") if not p.name.startswith("."))


def _atomic_write_text(path: Path, text: str) -> None:
    tmp = path.with_name("." + path.name + f".{os.getpid()}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)
