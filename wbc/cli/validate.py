"""Checks of the command line's values, shared by every command and run before any work.

Each check raises :class:`wbc.exceptions.InvalidInputError` with a one-line message that names the option as the
user typed it, the value, why it is refused (memory, physics, file system) and what would be valid; ``wbc``
prints it and exits 2. The argparse ``type=`` converters (:func:`video_size`, :func:`count`, :func:`seconds`...)
raise ``argparse.ArgumentTypeError`` instead, which the parser turns into the same one-line error.

Unit convention of the command line: lengths in m, times in s, forces in N, and **every angle in degrees**
(``--turn`` deg per step, ``--wz`` deg/s, ``--push-dir`` deg).
"""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path

from wbc.exceptions import InvalidInputError

__all__ = [
    "OUTPUT_SUFFIXES", "check_outputs", "output_path", "available_memory", "check_ticks", "check_range",
    "video_size", "count", "seconds", "finite", "real", "solver_name", "BYTES_PER_TICK",
]

#: Output option -> the file suffix it writes (``--bag`` is a folder: no suffix).
OUTPUT_SUFFIXES = {"json": ".json", "log": ".npz", "out": ".html", "plot": ".png", "video": ".mp4"}

#: Memory a run holds per control tick (bytes): its log (q, v, CoM, sole poses, references...) and, for a walk,
#: the gait plan's per-tick arrays. Upper estimate: the peak traced memory (tracemalloc) grows by 1.8 kB per tick
#: for a talos walk (4 vs 12 steps) and 2.0 kB per tick for ``sim stand`` (1 vs 3 s); a 100000-step talos walk
#: failed allocating 298 GiB in one array, 5.8 kB per tick.
BYTES_PER_TICK = 8_000

_VIRTUAL_ROOTS = (Path("/proc"), Path("/sys"), Path("/dev"))


def _fail(message: str):
    raise InvalidInputError(message)


def output_path(option: str, path, suffix: str | None) -> Path:
    """The file an output option will write, checked: its folder exists and is writable, it is not a folder,
    not a device or a pseudo file system (/proc, /sys, /dev), and it has the option's suffix.

    Args:
        option: the option as typed (``"--json"``), for the message.
        path: the value given.
        suffix: the required suffix (``".json"``), or None for a folder output (``--bag``: must not exist yet).
            ``--log`` without a suffix gets ``.npz`` (what numpy writes); any other missing or wrong suffix is
            refused.

    Returns:
        the path that will be written (with ``.npz`` appended for a bare ``--log`` name).

    Raises:
        InvalidInputError: any of the above does not hold.
    """
    path = Path(path)
    text = str(path)
    if not text or text.endswith(os.sep) and suffix is not None:
        _fail(f"{option} {text!r}: expected a file name (valid: a name ending in {suffix})")
    if path.is_dir():
        _fail(f"{option} {text}: is an existing folder (valid: a {'new folder name' if suffix is None else 'file name'}"
              f" inside it, e.g. {path / ('out' + (suffix or ''))})")
    if suffix == ".npz" and path.suffix == "":
        path = path.with_name(path.name + ".npz")
    if suffix is not None and path.suffix.lower() != suffix:
        _fail(f"{option} {text}: wrong file type {path.suffix or '(no suffix)'!r} (valid: a name ending in {suffix})")
    parent = path.parent
    if not parent.is_dir():
        _fail(f"{option} {text}: directory {str(parent)!r} does not exist (create it first)")
    real_parent = parent.resolve()
    for root in _VIRTUAL_ROOTS:
        if real_parent == root or root in real_parent.parents:
            _fail(f"{option} {text}: {root} is a pseudo file system, not a place for files (valid: a folder on disk)")
    if suffix is None and path.exists():
        _fail(f"{option} {text}: already exists (valid: a folder name that does not exist yet)")
    if path.exists() and not path.is_file():
        _fail(f"{option} {text}: is not a regular file (a device or a socket); valid: a file on disk")
    if not os.access(real_parent, os.W_OK | os.X_OK):
        _fail(f"{option} {text}: directory {str(parent)!r} is not writable")
    return path


def check_outputs(args) -> None:
    """Check every output option of ``args`` (``--json --log --out --plot --video --bag``) with :func:`output_path`;
    replaces each by the path that will be written. A command whose options write other file types sets
    ``output_suffixes`` (option dest -> suffix) in its parser defaults.

    Raises:
        InvalidInputError: see :func:`output_path`; two options name the same file.
    """
    seen: dict[Path, str] = {}
    suffixes = getattr(args, "output_suffixes", OUTPUT_SUFFIXES)
    for opt, suffix in [*suffixes.items(), ("bag", None)]:
        value = getattr(args, opt, None)
        if value is None:
            continue
        path = output_path(f"--{opt}", value, suffix)
        key = path.resolve()
        if key in seen:
            _fail(f"--{opt} {value}: same file as {seen[key]} (valid: one file per output)")
        seen[key] = f"--{opt}"
        setattr(args, opt, path if suffix is not None else str(path))


def available_memory() -> int:
    """Bytes of memory available to a new allocation (Linux ``MemAvailable``; else the physical memory)."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return int(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover - non-POSIX
        return 8 << 30


def _gib(n: float) -> str:
    return f"{n / 2**30:.3g} GiB"


def check_ticks(what: str, seconds_: float, dt: float, *, bytes_per_tick: int = BYTES_PER_TICK) -> int:
    """Refuse a run whose ``seconds_ / dt`` ticks would not fit in memory (half of what is available).

    Args:
        what: the options that set the duration, as typed (``"--steps 100000"``), for the message.
        seconds_: simulated duration (s). dt: control period (s).

    Returns:
        the number of ticks.

    Raises:
        InvalidInputError: the run needs more than half the available memory.
    """
    ticks = math.ceil(seconds_ / dt)
    need = float(ticks) * bytes_per_tick
    have = available_memory()
    if need > have / 2:
        longest = have / 2 / bytes_per_tick * dt
        _fail(f"{what}: {seconds_:.4g} s at dt {dt:g} s is {ticks:.3g} ticks, which need ≈ {_gib(need)} of memory "
              f"(~{bytes_per_tick // 1000} kB per tick) and {_gib(have)} is available (valid: at most ≈ "
              f"{longest:.4g} s of run at this dt)")
    return ticks


def check_range(option: str, value: float, lo: float | None, hi: float | None, reason: str = "", *,
                lo_open: bool = False) -> None:
    """Refuse a non-finite ``value`` or one outside ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``).

    Raises:
        InvalidInputError: naming ``option``, the valid range and ``reason``.
    """
    ok = math.isfinite(value)
    if ok and lo is not None:
        ok = value > lo if lo_open else value >= lo
    if ok and hi is not None:
        ok = value <= hi
    if not ok:
        left = "" if lo is None else f"{lo:g} {'<' if lo_open else '<='} "
        right = "" if hi is None else f" <= {hi:g}"
        why = f": {reason}" if reason else ""
        _fail(f"{option} {value:g} is out of range (valid: {left}{option.lstrip('-')}{right}){why}")


# --- argparse type converters (errors become one-line `wbc X: error: argument --opt: ...`) ---------------------

def video_size(text: str) -> tuple[int, int]:
    """``"WxH"`` -> (W, H) pixels, each 16..4096."""
    parts = text.lower().split("x")
    try:
        w, h = (int(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not WIDTHxHEIGHT in pixels (e.g. 640x480)") from None
    if not (16 <= w <= 4096 and 16 <= h <= 4096):
        raise argparse.ArgumentTypeError(f"{text!r}: width and height must be 16..4096 pixels")
    return w, h


def count(lo: int = 1, hi: int | None = None):
    """An argparse type: an integer in ``[lo, hi]``."""
    def convert(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if value < lo or (hi is not None and value > hi):
            raise argparse.ArgumentTypeError(f"{value} is out of range (valid: {lo}..{hi})" if hi is not None
                                             else f"{value} is out of range (valid: >= {lo})")
        return value

    convert.__name__ = "integer"
    return convert


def finite(lo: float | None = None, hi: float | None = None, *, lo_open: bool = False, unit: str = "",
           valid: str | None = None):
    """An argparse type: a finite float in ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``).

    Args:
        valid: what the message names as valid, when the bounds alone do not say it (e.g. a ± bound given as its
            magnitude); default: the range, or "a finite number" without bounds.
    """
    def convert(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        ok = math.isfinite(value) and (lo is None or (value > lo if lo_open else value >= lo)) and (
            hi is None or value <= hi)
        if not ok:
            left = "" if lo is None else f"{lo:g}{unit} {'<' if lo_open else '<='} "
            right = "" if hi is None else f" <= {hi:g}{unit}"
            what = valid or (f"{left}value{right}" if left or right else "a finite number")
            problem = "is out of range" if math.isfinite(value) else "is not a finite number"
            raise argparse.ArgumentTypeError(f"{text} {problem} (valid: {what})")
        return value

    convert.__name__ = "number"
    return convert


def real(text: str) -> float:
    """An argparse type: any float, NaN and ±inf included, for an option whose valid range depends on the robot
    (``--step-length``, ``--vx``...): the command refuses a value outside it once the robot is loaded, with the
    robot's range in the message (:func:`wbc.cli.walk.check_command_values`)."""
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None


def seconds(text: str) -> float:
    """An argparse type: a finite duration > 0 s."""
    return finite(0.0, lo_open=True, unit=" s")(text)


def solver_name(text: str) -> str:
    """An argparse type: a QP backend name of :func:`wbc.solvers.available_solvers` (``fast``, ``daqp``, ``proxqp``
    or any installed qpsolvers backend). The list is read only for a name other than ``fast`` (the default), so that
    building the parser does not import qpsolvers."""
    if text == "fast":
        return text
    from wbc.solvers import available_solvers

    names = available_solvers()
    if text not in names:
        raise argparse.ArgumentTypeError(f"invalid choice: {text!r} (choose from {', '.join(names)})")
    return text


#: Largest mean vertical ground force of a jump's push, in body weights (m g). A planned CoM rise h over a push
#: stroke s needs a mean force m g (1 + h / s) (constant acceleration g h / s over s); elite human jumpers peak
#: at 3–5 body weights, so 10 is a generous bound on any humanoid's legs.
MAX_PUSH_WEIGHTS = 10.0


def check_jump(height: float, stroke: float, count: int, dt: float, *, seconds_per_jump: float = 3.0) -> None:
    """Refuse a jump the legs cannot push or a run that would not fit in memory.

    Args:
        height: ``--height``, planned apex CoM rise (m). stroke: the plan's push stroke, crouch + extension (m).
        count: ``--count``. dt: control period (s). seconds_per_jump: run time per jump (crouch, push, flight,
            landing) used for the memory bound.

    Raises:
        InvalidInputError: ``height`` <= 0, not finite, or above ``(MAX_PUSH_WEIGHTS - 1) * stroke``; ``count`` < 1
            or too many ticks.
    """
    if not (math.isfinite(height) and height > 0):
        _fail(f"--height {height:g} is out of range (valid: height > 0 m)")
    h_max = (MAX_PUSH_WEIGHTS - 1.0) * stroke
    if height > h_max:
        _fail(f"--height {height:g} m: the push over the {stroke:g} m stroke would need a mean ground force of "
              f"{1 + height / stroke:.3g} × the robot's weight (m g (1 + h / stroke)); valid: 0 < height <= "
              f"{h_max:.3g} m (at most {MAX_PUSH_WEIGHTS:g} × the weight)")
    if count < 1:
        _fail(f"--count {count} is out of range (valid: count >= 1)")
    check_ticks(f"--count {count}", count * seconds_per_jump + 2.0, dt)
