"""Where trials run: in this process (:class:`SerialExecutor`, the default) or on Ray (:class:`RayExecutor`: a
local Ray on this machine's cores, or an existing cluster).

An executor's ``map(fn, spec, indices)`` yields ``(index, row)`` as trials finish, in any order; ``row`` is the
trial function's dict plus ``wall_s`` (its run time, s) and ``worker`` (host:pid); for a trial that raised,
``{"outcome": "error", "error_kind": "exception", "error": "<type>: <message>", ...}`` (a finished trial: the
exception is its result); for a trial the executor lost (:func:`lost_row`: its worker died more often than the
retries allow, the Ray node went away) ``{"outcome": "error", "error_kind": "lost", ...}``, which the results
folder does not count as finished (:mod:`wbc.campaign.store`: a resumed run runs it again). A trial is a pure
function of (spec, index), so where it ran does not change its row (apart from ``wall_s`` and ``worker``).

**Ray.** Each trial is a Ray task (``max_retries`` 3: a task whose worker process died — killed, out of memory — is
run again on another worker; an exception inside the trial is not retried, it is the trial's result). Workers are
Ray's reused worker processes: the robot model and the numba kernels are loaded by a worker's first trial and kept
for the next ones (:func:`wbc.campaign.trials.cached_robot`). At most ``2 × workers`` tasks are in flight, so a
stopped driver leaves little work unrecorded.

**Loopback.** A local Ray (no ``address``) is started with its servers reachable on this machine only: Ray 2.60's
GCS, raylet and worker servers listen on every interface whatever ``node_ip_address`` says, so
:func:`confine_to_loopback` first moves this process into a private network namespace whose only interface is
``lo`` (Linux ``unshare(CLONE_NEWNET)``; root, or an unprivileged user namespace before any thread is started).
Where that is not possible the executor refuses with the reason, unless ``loopback=False``.

**No Ray process outlives its driver.** A local Ray is watched by :mod:`wbc.campaign.reaper`, which kills the
processes the driver started (Ray's agents survive it otherwise) when the driver dies without closing Ray (SIGKILL).
"""

from __future__ import annotations

import os
import socket
import time
import traceback

from wbc.exceptions import InvalidInputError

__all__ = ["SerialExecutor", "RayExecutor", "confine_to_loopback", "run_one", "lost_row"]


def run_one(fn, spec, params: dict) -> dict:
    """Run trial ``params`` with ``fn(spec, params)``: its row plus ``wall_s`` and ``worker``, or an error row."""
    t0 = time.perf_counter()
    try:
        row = dict(fn(spec, params))
    except Exception as e:  # a trial's failure is its result; the campaign goes on
        row = {"outcome": "error", "survived": None, "error_kind": "exception",
               "error": f"{type(e).__name__}: {e}".splitlines()[0][:500],
               "traceback": traceback.format_exc()[-2000:]}
    row["wall_s"] = time.perf_counter() - t0
    row["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    return {**params, **row}


def lost_row(params: dict, exc: BaseException) -> dict:
    """The row of a trial the executor lost (``exc``: why), marked ``error_kind = "lost"``: not a finished trial,
    run again on resume (module docstring). It names no ``worker``."""
    return {**params, "outcome": "error", "survived": None, "error_kind": "lost",
            "error": f"{type(exc).__name__}: {exc}".splitlines()[0][:500]}


class SerialExecutor:
    """Trials one after the other in this process (no Ray)."""

    name = "serial"
    workers = 1

    def map(self, fn, spec, indices):
        """Yield ``(index, row)`` for each trial index (module docstring)."""
        from wbc.campaign.spec import trial_params

        for i in indices:
            yield i, run_one(fn, spec, trial_params(spec, i))

    def close(self) -> None:
        """Nothing to release."""


class RayExecutor:
    """Trials as Ray tasks (module docstring).

    Args:
        address: ``"HOST:PORT"`` of an existing Ray cluster to join, or None to start a local Ray.
        workers: local Ray's worker processes (default: this machine's cores). Ignored with ``address``.
        loopback: confine a local Ray to ``lo`` (:func:`confine_to_loopback`; default True).
        max_retries: retries of a task whose worker died (default 3).

    Raises:
        InvalidInputError: Ray is not installed (``pip install -e ".[ray]"``), ``workers`` < 1, a malformed
            ``address``, or the loopback confinement is impossible here (the reason is in the message).
    """

    name = "ray"

    def __init__(self, address: str | None = None, *, workers: int | None = None, loopback: bool = True,
                 max_retries: int = 3):
        try:
            import ray  # noqa: F401
        except ImportError:
            raise InvalidInputError("Ray is not installed: pip install -e \".[ray]\" (from the wbc clone; or run the "
                                    "campaign serially)") from None
        if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
            raise InvalidInputError(f"workers must be an integer ≥ 1, got {workers!r}")
        if address is not None:
            host, _, port = str(address).rpartition(":")
            if not host or not port.isdigit():
                raise InvalidInputError(f"Ray address must be HOST:PORT, got {address!r}")
        self.address, self.loopback, self.max_retries = address, bool(loopback), int(max_retries)
        self.workers = workers or (os.cpu_count() or 1)
        self._started = False
        self._reaper = None

    def _start(self) -> None:
        import ray

        if ray.is_initialized():
            return
        if self.address is None:
            if self.loopback:
                confine_to_loopback()
            # Ray starts its workers at nice 15 (``worker_niceness``); a campaign's trials are the work itself, and at
            # nice 15 any other load on the machine starves them
            os.environ.setdefault("RAY_worker_niceness", "0")
            self._reaper = _start_reaper()  # before Ray starts anything: a driver killed while Ray starts is covered
            try:
                ray.init(num_cpus=self.workers, include_dashboard=False, log_to_driver=False,
                         configure_logging=False)
            except BaseException:
                self._started = True  # close() shuts down what started and stops the reaper
                self.close()
                raise
        else:
            ray.init(address=self.address, log_to_driver=False, configure_logging=False)
            self.workers = int(ray.cluster_resources().get("CPU", 1))
        self._started = True

    def map(self, fn, spec, indices):
        """Yield ``(index, row)`` as tasks finish (module docstring)."""
        import ray

        from wbc.campaign.spec import trial_params

        self._start()
        remote = ray.remote(num_cpus=1, max_retries=self.max_retries, retry_exceptions=False)(run_one)
        spec_ref = ray.put(spec)
        fn_ref = ray.put(fn)
        pending = list(indices)[::-1]
        inflight = {}
        window = 2 * self.workers
        while pending or inflight:
            while pending and len(inflight) < window:
                i = pending.pop()
                inflight[remote.remote(fn_ref, spec_ref, trial_params(spec, i))] = i
            ready, _ = ray.wait(list(inflight), num_returns=1)
            ref = ready[0]
            i = inflight.pop(ref)
            try:
                row = ray.get(ref)
            except ray.exceptions.RayError as e:
                # the worker died more than max_retries times, the node or raylet is gone, or the task raised
                # outside the trial function's guard (a KeyboardInterrupt: Ctrl-C reaches the process group)
                row = lost_row(trial_params(spec, i), e)
            yield i, row

    def close(self) -> None:
        """Shut the local Ray down (a joined cluster is left running)."""
        if self._started:
            import ray

            ray.shutdown()
            self._started = False
        if self._reaper is not None:
            self._reaper.terminate()
            self._reaper.wait()
            self._reaper = None


def _start_reaper():
    """Start :mod:`wbc.campaign.reaper` on this process (Linux; None elsewhere): it kills the local Ray's processes
    should this process die without closing Ray."""
    import subprocess
    import sys
    from pathlib import Path

    if not os.path.isdir(f"/proc/{os.getpid()}/task"):
        return None
    return subprocess.Popen([sys.executable, str(Path(__file__).with_name("reaper.py")), str(os.getpid())],
                            stdin=subprocess.DEVNULL, close_fds=True)


_CLONE_NEWNET = 0x40000000
_CLONE_NEWUSER = 0x10000000


def confine_to_loopback() -> None:
    """Move this process into a new network namespace with only the loopback interface, up.

    Everything it starts afterwards (Ray's servers and workers) can listen and connect on 127.0.0.1 only. Tried
    as root (``CLONE_NEWNET``), then as an unprivileged user (``CLONE_NEWUSER | CLONE_NEWNET``, possible only
    while the process has a single thread). Idempotent: a process already confined is left as it is.

    Raises:
        InvalidInputError: not Linux, or the kernel refused both (the errno's message, and the way out:
            ``--ray-address`` to a cluster started by hand, or ``loopback=False``).
    """
    import ctypes
    import errno

    if os.environ.get("WBC_LOOPBACK_NAMESPACE") == str(os.getpid()):
        return
    if not os.uname().sysname == "Linux":
        raise InvalidInputError("a loopback-only local Ray needs Linux network namespaces; use --ray-address "
                                "with a cluster you started, or loopback=False")
    libc = ctypes.CDLL(None, use_errno=True)
    uid, gid = os.getuid(), os.getgid()
    if libc.unshare(_CLONE_NEWNET) != 0:
        err = ctypes.get_errno()
        if libc.unshare(_CLONE_NEWUSER | _CLONE_NEWNET) != 0:
            err2 = ctypes.get_errno()
            raise InvalidInputError(
                "cannot confine the local Ray to loopback: unshare(CLONE_NEWNET) failed "
                f"({errno.errorcode.get(err, err)}) and an unprivileged user namespace too "
                f"({errno.errorcode.get(err2, err2)}); start the campaign before other threads, run it as root, "
                "join a cluster you started with --ray-address, or pass loopback=False")
        for path, text in (("/proc/self/setgroups", "deny"), ("/proc/self/uid_map", f"0 {uid} 1"),
                           ("/proc/self/gid_map", f"0 {gid} 1")):
            with open(path, "w") as f:
                f.write(text)
    _loopback_up()
    os.environ["WBC_LOOPBACK_NAMESPACE"] = str(os.getpid())


def _loopback_up() -> None:
    """Set the ``lo`` interface up (ioctl SIOCGIFFLAGS / SIOCSIFFLAGS)."""
    import fcntl
    import struct

    siocgifflags, siocsifflags, iff_up = 0x8913, 0x8914, 0x1
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        req = struct.pack("16sh", b"lo", 0)
        flags = struct.unpack("16sh", fcntl.ioctl(s, siocgifflags, req))[1]
        fcntl.ioctl(s, siocsifflags, struct.pack("16sh", b"lo", flags | iff_up))
