"""What every run command (walk, balance, sim) shares: the output options, the summary printer, the writers of
the JSON summary / npz log / plots / meshcat recording, the live viewer and the progress bar.

Public, so that the command modules of :mod:`wbc.cli` use one implementation; nothing below the CLI layer
imports this module.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import sys
import threading
import time
import uuid
from pathlib import Path

import numpy as np

__all__ = [
    "add_outputs", "print_summary", "format_value", "write_outputs", "write_json", "write_plot", "write_recording",
    "open_live", "progress", "hold_live", "close_live", "deadline_misses", "add_deadline_misses", "jsonable", "atomic_output", "atomic_outputs", "write_log",
    "compile_notice", "uncompiled_kernels", "status", "on_sigterm", "sigterm_received", "Terminated",
]


def add_outputs(p: argparse.ArgumentParser) -> None:
    """Add ``--json --log --out --live --plot --quiet --hold`` to a run command's parser."""
    p.add_argument("--json", type=Path, metavar="FILE", help="write the summary as JSON")
    p.add_argument("--log", type=Path, metavar="FILE", help="write the time series as npz")
    p.add_argument("--out", type=Path, metavar="FILE", help="write a self-contained meshcat HTML recording")
    p.add_argument("--live", action="store_true",
                   help="show the motion live in meshcat (127.0.0.1 only, paced to real time); the motion starts when "
                        "a browser opens the printed URL (or at once with --live-start-now); the viewer stays up "
                        "after the motion until Ctrl-C or --hold")
    p.add_argument("--live-start-now", action="store_true",
                   help="with --live: start the motion without waiting for a browser to connect")
    p.add_argument("--plot", type=Path, metavar="PNG",
                   help="write plots of the run (CoM/ZMP/DCM, top view, joint limits, contact forces, tick times)")
    p.add_argument("--quiet", action="store_true", help="no progress bar (it is shown on a terminal for runs > 2 s)")
    p.add_argument("--hold", type=float, metavar="SECONDS", default=None,
                   help="with --live: keep the viewer up this long after the motion (default: until Ctrl-C)")


#: Printing resolution per unit suffix of a summary key: a value smaller in magnitude prints as 0 (a
#: -6.9e-18 m drift is floating-point noise); --json keeps full precision.
RESOLUTION = {"_m": 1e-6, "_rad": 1e-6, "_deg": 1e-4, "_s": 1e-6, "_n": 1e-3, "_nm": 1e-3, "_us": 0.1,
              "_mps": 1e-6, "_hz": 1e-3, "_kg": 1e-4}


def print_summary(summary: dict, indent: str = "  ", hide=()) -> None:
    """Print a run summary, one ``key value`` line per entry (a dict value on one line: ``k v, k v``), floats to 4
    significant digits and to the resolution of their unit (:data:`RESOLUTION`). Entries that are None or empty
    text (e.g. no fall time or fall reason when nothing fell) and the keys in ``hide`` (metrics that do not apply to the scenario) are not
    printed; ``--json`` has every key at full precision."""
    for key, value in summary.items():
        if value is None or (isinstance(value, str) and not value) or key in hide:
            continue
        if isinstance(value, dict):
            inner = ", ".join(f"{k} {format_value(v, key)}" for k, v in value.items() if v is not None)
            print(f"{indent}{key:28s} {inner}")
        else:
            print(f"{indent}{key:28s} {format_value(value, key)}")


def format_value(value, key: str = "") -> str:
    """Floats with 4 significant digits, 0 below the resolution of ``key``'s unit suffix (:data:`RESOLUTION`,
    default 1e-9); anything else as ``str``."""
    if isinstance(value, (float, np.floating)):
        value = float(value)
        if not np.isfinite(value):
            return str(value)
        resolution = next((r for suffix, r in RESOLUTION.items() if key.endswith(suffix)), 1e-9)
        if abs(value) < resolution:
            return "0"
        return f"{value:.4g}"
    return str(value)


def jsonable(x):
    """``json.dumps(default=...)`` hook: numpy scalars and arrays to Python numbers and lists."""
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    raise TypeError(type(x).__name__)


@contextlib.contextmanager
def atomic_output(path):
    """Write a file (or a folder) under a temporary name in its target folder, then rename it to ``path``.

    Yields the temporary path (same folder, same suffix, unique per process and call): the caller writes it.
    When the block ends normally the temporary is flushed to disk and renamed over ``path`` in one
    ``os.replace`` (atomic on POSIX), so a reader sees either the previous file or the complete new one, and
    concurrent writers leave the complete file of one of them. When the block raises (including Ctrl-C), the
    temporary is removed and ``path`` is left as it was. (:func:`atomic_outputs` with one path.)
    """
    with atomic_outputs([path]) as (tmp,):
        yield tmp


@contextlib.contextmanager
def atomic_outputs(paths):
    """Write several files (or folders) as one set: :func:`atomic_output` for each, renamed together.

    Yields their temporary paths, in order. When the block ends normally every temporary is flushed, then all are
    renamed into place with SIGINT and SIGTERM held back (a signal that arrives meanwhile is handled after the last
    rename, :func:`_signals_held`), so that an interrupt leaves either the previous set or the new one, never a new JSON summary beside an
    old npz log. When the block raises, every temporary is removed and the paths are left as they were. A process
    killed without a chance to clean up (SIGKILL) leaves its temporaries (``.NAME.PID-XXXXXXXX.partial.SUFFIX``):
    the next write of the same path removes those whose process no longer runs.
    """
    paths = [Path(p) for p in paths]
    for path in paths:
        _remove_stale_temporaries(path)
    tmps = [p.with_name(f".{p.stem}.{os.getpid()}-{uuid.uuid4().hex[:8]}.partial{p.suffix}") for p in paths]
    try:
        yield tmps
        for tmp in tmps:
            if tmp.is_file():
                with open(tmp, "rb+") as f:
                    os.fsync(f.fileno())
        with _signals_held():
            for tmp, path in zip(tmps, paths):
                os.replace(tmp, path)
    except BaseException:
        for tmp in tmps:
            _remove(tmp)
        raise


def _remove(path: Path) -> None:
    with contextlib.suppress(OSError):
        if path.is_dir():
            import shutil

            shutil.rmtree(path)
        else:
            path.unlink()


def _remove_stale_temporaries(path: Path) -> None:
    """Remove the temporaries of ``path`` (:func:`atomic_outputs`) left by processes that no longer run."""
    for tmp in path.parent.glob(f".{path.stem}.*-*.partial{path.suffix}"):
        pid = tmp.name[len(path.stem) + 2:].partition("-")[0]
        if not pid.isdigit() or int(pid) == os.getpid():
            continue
        try:
            os.kill(int(pid), 0)
        except ProcessLookupError:
            _remove(tmp)
        except OSError:  # another user's process: running
            pass


@contextlib.contextmanager
def _signals_held():
    """Hold SIGINT and SIGTERM back: a signal that arrives in the block is raised again, to the handler that was in
    place, when the block ends. In the main thread only (elsewhere, and for a handler not set from Python: nothing
    held). A thread mask would not do: the kernel hands a process's signal to any thread that does not block it
    (numpy's BLAS threads), and Python runs its handler in the main thread at once."""
    import signal

    numbers = (signal.SIGINT, signal.SIGTERM)
    if threading.current_thread() is not threading.main_thread() or None in map(signal.getsignal, numbers):
        yield
        return
    pending: list[int] = []
    previous = {n: signal.signal(n, lambda signum, frame: pending.append(signum)) for n in numbers}
    try:
        yield
    finally:
        for n, handler in previous.items():
            signal.signal(n, handler)
        for n in dict.fromkeys(pending):
            signal.raise_signal(n)


def _json_into(tmp: Path, summary: dict) -> str:
    tmp.write_text(json.dumps(summary, indent=2, default=jsonable) + "\n")
    return "summary written to {}"


def _log_into(tmp: Path, run) -> str:
    with open(tmp, "wb") as f:
        run.save(f)
    return "log written to {}"


def _recording_into(tmp: Path, robot, run, **scene) -> str:
    from wbc.viz import record_html

    record_html(robot, run.t, run.q, tmp, **scene)
    return "meshcat recording written to {} (" + f"{tmp.stat().st_size / 1e6:.1f} MB)"


def _plot_into(tmp: Path, run) -> str:
    from wbc.viz.plots import plot_log

    buf = io.BytesIO()
    run.save(buf)
    buf.seek(0)
    with np.load(buf, allow_pickle=False) as z:
        log = {k: z[k] for k in z.files}
    plot_log(log, tmp)
    return "plots written to {}"


def _write(path, into, *args, **kwargs) -> None:
    with atomic_output(path) as tmp:
        line = into(tmp, *args, **kwargs)
    print(line.format(path))


def write_json(path: Path, summary: dict) -> None:
    """Write the summary as indented JSON to ``path`` (atomically: :func:`atomic_output`)."""
    _write(path, _json_into, summary)


def write_log(path: Path, run) -> None:
    """Write ``run``'s npz log (``run.save``) to ``path`` (atomically: :func:`atomic_output`)."""
    _write(path, _log_into, run)


def write_recording(robot, run, path: Path, **scene) -> None:
    """Write the self-contained meshcat HTML recording of ``run`` (``run.t``, ``run.q``) to ``path`` (atomically);
    ``scene`` goes to :func:`wbc.viz.record_html` (overlays, arrows, polygons, paths, outlines)."""
    _write(path, _recording_into, robot, run, **scene)


#: Entries of a run's scene (:mod:`wbc.viz.overlays`) passed on to :func:`wbc.viz.record_html`.
SCENE_KEYS = ("polygons", "paths", "outlines", "arrows", "terrain")


def write_outputs(args, summary: dict, run, robot, overlays: dict | None = None, scene: dict | None = None) -> None:
    """Write what ``args`` asks for (``--json``, ``--log``, ``--plot``, ``--out``) for a finished run, as one set
    (:func:`atomic_outputs`: an interrupt leaves all the previous files or all the new ones)."""
    jobs = []
    if args.json:
        jobs.append((args.json, _json_into, (summary,), {}))
    if args.log:
        jobs.append((args.log, _log_into, (run,), {}))
    if getattr(args, "plot", None):
        jobs.append((args.plot, _plot_into, (run,), {}))
    if args.out:
        extra = {} if scene is None else {k: scene[k] for k in SCENE_KEYS if k in scene}
        jobs.append((args.out, _recording_into, (robot, run), {"overlays": overlays, **extra}))
    if not jobs:
        return
    with atomic_outputs([path for path, *_ in jobs]) as tmps:
        lines = [into(tmp, *a, **kw) for tmp, (_, into, a, kw) in zip(tmps, jobs)]
    for line, (path, *_) in zip(lines, jobs):
        print(line.format(path))


def write_plot(path, run) -> None:
    """Plot a run (anything with ``save(file)`` writing an npz log) to the PNG ``path``."""
    _write(path, _plot_into, run)


_LIVE_VIEWERS: list = []  # viewers opened by open_live, closed by close_live() after the hold


class _HeldViewer:
    """A LiveViewer whose ``close()`` (called by the commands when the motion ends) is deferred to close_live()."""

    def __init__(self, viewer):
        self._viewer = viewer

    def __getattr__(self, name):
        return getattr(self._viewer, name)

    def close(self) -> None:
        pass


def open_live(robot, start_now: bool = False, terrain=None):
    """(viewer, pacer) for --live: a meshcat server on 127.0.0.1 (every port) and a real-time pacer; ``terrain``
    (a :class:`wbc.terrain.Terrain`, or None for the floor alone) is drawn under the robot.

    The URL is printed before the motion starts; unless ``start_now``, the motion waits for a browser to open it
    (and says so). :func:`wbc.cli.main` keeps the viewer up after the command until Ctrl-C or ``--hold`` seconds
    (:func:`hold_live`), then closes it (:func:`close_live`).
    """
    import sys

    from wbc.viz import LiveViewer, RealTimePacer

    print("meshcat viewer: starting the server on 127.0.0.1 ...", file=sys.stderr, flush=True)
    viewer = LiveViewer(robot, terrain=terrain)
    _LIVE_VIEWERS.append(viewer)
    if start_now:
        print(f"meshcat viewer: {viewer.url} (open it in a browser; the motion starts now)", flush=True)
    else:
        print(f"meshcat viewer: {viewer.url} (open it in a browser; the motion starts when it connects, "
              "--live-start-now not to wait; Ctrl-C to stop)", flush=True)
        viewer.wait_for_browser()
        print("meshcat viewer: browser connected, motion starting", flush=True)
    return _HeldViewer(viewer), RealTimePacer()


#: Modules whose numba kernels (``cache=True``) a kinematic run (walk, balance) compiles on first use: the
#: on-disk caches a fresh ``wbc walk`` wrote (``NUMBA_CACHE_DIR`` set to an empty folder).
KINEMATIC_KERNELS = ("wbc.formulations.velocity_kernel", "wbc.solvers.active_set",
                     "wbc.solvers.linalg", "wbc.tasks.com", "wbc.tasks.frame", "wbc.tasks.posture",
                     "wbc.constraints.limits", "wbc.constraints.braking", "wbc.constraints.acceleration", "wbc.constraints.contact",
                     "wbc.constraints.zmp")
#: The same for the inverse-dynamics runs (``wbc sim``): the compiled ID tick.
DYNAMICS_KERNELS = ("wbc.formulations.idkernel",)


def uncompiled_kernels(modules=None) -> list[str]:
    """Modules among ``modules`` (names; default: every wbc module with a ``@...jit(cache=True)`` kernel) that have
    no on-disk numba cache yet (no ``<module>.*.nbi`` in ``__pycache__`` next to the source, or in numba's folder for
    that source under ``NUMBA_CACHE_DIR`` when that variable moves the cache): their kernels compile on first use,
    30–80 s on a 2-core machine."""
    import wbc
    from wbc.kernel_cache import cache_folder, kernel_sources

    cache_dir = os.environ.get("NUMBA_CACHE_DIR")
    root = Path(wbc.__file__).resolve().parent
    if modules is None:
        modules = [".".join(p.relative_to(root.parent).with_suffix("").parts) for p in kernel_sources(root)]
    missing = []
    for name in modules:
        path = root.parent.joinpath(*name.split(".")).with_suffix(".py")
        if path.is_file() and not any(cache_folder(path, cache_dir).glob(f"{path.stem}.*.nbi")):
            missing.append(name)
    return missing


_NOTIFIED: set[str] = set()  # kernel modules already announced by compile_notice in this process


def compile_notice(desc: str, modules=None, stream=None) -> bool:
    """Say on stderr that the numba kernels of ``modules`` (see :func:`uncompiled_kernels`) compile now (first run
    after an install), so that the silent minute before the first tick is explained; then, through
    :func:`wbc.compiled.set_load_listener`, one line per module whose kernels took ≥ 0.5 s to become ready (the
    progress of the compilation). Returns True when printed."""
    import sys

    missing = [m for m in uncompiled_kernels(modules) if m not in _NOTIFIED]
    _NOTIFIED.update(missing)
    if missing:
        out = stream or sys.stderr
        print(f"{desc}: compiling the numba kernels on first use ({len(missing)} modules; 30–80 s once, cached for "
              "later runs; `wbc compile` does it ahead of time) ...", file=out, flush=True)
        from wbc.compiled import set_load_listener

        def report(module: str, seconds: float) -> None:  # one line per module as its kernels become ready
            if seconds >= 0.5:
                print(f"{desc}: {module} kernels ready ({seconds:.1f} s)", file=out, flush=True)

        set_load_listener(report)
    return bool(missing)


def status(args, text: str) -> None:
    """One line on stderr saying what the command does now (loading, planning...), on a terminal and without
    --quiet, so that the seconds before the progress bar are not silent."""
    import sys

    if not getattr(args, "quiet", False) and getattr(sys.stderr, "isatty", lambda: False)():
        print(text, file=sys.stderr, flush=True)


def progress(args, total: float | None, viewer=None, desc: str = ""):
    """Wrap ``viewer`` (None or a live viewer) in a progress bar on stderr, unless --quiet or not a terminal; say
    first (unless --quiet) when the numba kernels are about to compile (:func:`compile_notice`).

    Args:
        total: simulated duration of the run (s), None when unknown.
    """
    from wbc.viz.progress import ProgressViewer

    kernels = DYNAMICS_KERNELS if desc.startswith("wbc sim") else KINEMATIC_KERNELS
    compiling = bool(uncompiled_kernels(kernels))
    if not getattr(args, "quiet", False):
        compile_notice(desc, kernels)
    # while the kernels compile (first run), the bar is drawn every second with its elapsed time
    return ProgressViewer(total, viewer, desc=desc, enabled=False if getattr(args, "quiet", False) else None,
                          heartbeat=1.0 if compiling else None, interrupted=_stop_requested)


_SIGINT_RECEIVED = threading.Event()
_SIGTERM_RECEIVED = threading.Event()


def _stop_requested() -> bool:
    return _SIGINT_RECEIVED.is_set() or _SIGTERM_RECEIVED.is_set()


class Terminated(BaseException):
    """SIGTERM, raised in the main thread by :func:`on_sigterm` so that the run unwinds (temporary files removed,
    viewers closed); ``wbc`` then exits with 143."""


def _in_llvm_callback(frame) -> bool:
    while frame is not None:
        if _LLVM_CALLBACK_DIR in frame.f_code.co_filename:
            return True
        frame = frame.f_back
    return False


def on_sigterm(signum, frame) -> None:
    """SIGTERM handler of every command: remember it, then raise :class:`Terminated`, except inside a callback that
    LLVM makes into Python, where it would be swallowed (see :func:`on_sigint`): there the run stops at its next
    progress tick (``KeyboardInterrupt``, reported as SIGTERM since :func:`sigterm_received` is True) or, in a
    campaign, before its next trial.

    Raises:
        Terminated: outside LLVM's callbacks.
    """
    _SIGTERM_RECEIVED.set()
    if not _in_llvm_callback(frame):
        raise Terminated()


def sigterm_received() -> bool:
    """True once :func:`on_sigterm` has seen a SIGTERM in this run."""
    return _SIGTERM_RECEIVED.is_set()


_LLVM_CALLBACK_DIR = f"{os.sep}llvmlite{os.sep}"  # llvmlite's Python code: the callbacks LLVM makes into Python


def on_sigint(signum, frame) -> None:
    """SIGINT handler of a run command: remember the Ctrl-C, then raise KeyboardInterrupt, except inside a callback
    that LLVM makes into Python (any frame of llvmlite on the stack ``frame`` heads).

    There the Ctrl-C is only remembered; the run loop's progress viewer (see :func:`progress`) raises the
    KeyboardInterrupt at its next tick. Raised inside such a ctypes callback the KeyboardInterrupt would be
    swallowed ("Exception ignored"), and in the object-cache callback through which numba hands LLVM a cached
    kernel it leaves LLVM without the kernel's code: numba then calls a null function pointer and the process dies
    of SIGSEGV (numba 0.68, llvmlite 0.50: ``CPUCodeLibrary._object_getbuffer_hook``).

    Args:
        signum: the signal number (SIGINT).
        frame: the Python frame that was running when the signal arrived (None outside Python code).

    Raises:
        KeyboardInterrupt: outside LLVM's callbacks.
    """
    _SIGINT_RECEIVED.set()
    if not _in_llvm_callback(frame):
        raise KeyboardInterrupt


def quiet_swallowed_interrupt(unraisable) -> None:
    """``sys.unraisablehook`` of a run command: a KeyboardInterrupt that a C callback swallowed after
    :func:`on_sigint` saw the Ctrl-C is not reported (no "Exception ignored ... Traceback" on stderr: the run stops at
    its next tick and says so once); anything else goes to Python's default hook."""
    if unraisable.exc_type is not None and issubclass(unraisable.exc_type, (KeyboardInterrupt, Terminated)) \
            and _stop_requested():
        return
    sys.__unraisablehook__(unraisable)


def sigint_received() -> bool:
    """True once :func:`on_sigint` has seen a Ctrl-C in this run (also one whose KeyboardInterrupt was swallowed by a
    C callback): loops that do not tick a progress viewer (the ROS 2 commands) check it each iteration."""
    return _SIGINT_RECEIVED.is_set()


def clear_sigint() -> None:
    """Forget a Ctrl-C seen by :func:`on_sigint` and a SIGTERM seen by :func:`on_sigterm` (a new run in the same
    process starts clean)."""
    _SIGINT_RECEIVED.clear()
    _SIGTERM_RECEIVED.clear()


def hold_live(seconds: float | None) -> None:
    """Keep the live viewers up for ``seconds`` (None: until Ctrl-C)."""
    if not _LIVE_VIEWERS:
        return
    urls = ", ".join(v.url for v in _LIVE_VIEWERS)
    bound = "Ctrl-C" if seconds is None else f"{seconds:g} s or Ctrl-C"
    print(f"motion done; meshcat viewer stays up at {urls} (until {bound})", flush=True)
    try:
        if seconds is None:
            while True:
                time.sleep(3600)
        time.sleep(max(0.0, seconds))
    except KeyboardInterrupt:
        pass


def close_live() -> None:
    """Close every viewer opened by :func:`open_live`."""
    while _LIVE_VIEWERS:
        _LIVE_VIEWERS.pop().close()


def deadline_misses(tick_time, dt: float) -> int:
    """Number of ticks whose controller time (s) exceeded the control period ``dt`` (s)."""
    return int(np.count_nonzero(np.asarray(tick_time, dtype=float) > dt))


def add_deadline_misses(summary: dict, tick_time, dt: float) -> None:
    """``summary['deadline_misses']`` = :func:`deadline_misses` (tick_time, dt), placed right after
    ``tick_time_us`` (printed beside the tick's median/p99/max; at the end when the summary has none)."""
    n = deadline_misses(tick_time, dt)
    summary.pop("deadline_misses", None)
    items = list(summary.items())
    summary.clear()
    for key, value in items:
        summary[key] = value
        if key == "tick_time_us":
            summary["deadline_misses"] = n
    summary.setdefault("deadline_misses", n)
