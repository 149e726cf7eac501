"""Timing statistics and machine description shared by every benchmark.

Durations are measured as integer nanoseconds (``time.perf_counter_ns`` for wall time, ``time.thread_time_ns``
for the CPU time of the calling thread) and reported in microseconds.
"""

from __future__ import annotations

import datetime
import importlib.metadata
import os
import platform
import sys
from time import perf_counter_ns
from typing import Callable

import numpy as np

__all__ = ["summarize_us", "pooled_summary_us", "time_calls_us", "machine_info"]

PERCENTILES = (50, 90, 99)


def summarize_us(durations_ns: np.ndarray) -> dict[str, float]:
    """Median, p90, p99, max and mean (µs) of a (N,) array of durations in ns."""
    d = np.asarray(durations_ns, dtype=float) / 1e3
    if d.size == 0:
        return {"median": float("nan"), "p90": float("nan"), "p99": float("nan"), "max": float("nan"),
                "mean": float("nan"), "n": 0}
    p50, p90, p99 = np.percentile(d, PERCENTILES)
    return {"median": float(p50), "p90": float(p90), "p99": float(p99), "max": float(d.max()),
            "mean": float(d.mean()), "n": int(d.size)}


def pooled_summary_us(per_repeat_ns: list[np.ndarray]) -> dict[str, float]:
    """Summary over repeats: ``median`` is the median of the per-repeat medians; p90/p99/max/mean are computed
    on all samples pooled (µs)."""
    pooled = summarize_us(np.concatenate(per_repeat_ns)) if per_repeat_ns else summarize_us(np.zeros(0))
    medians = [summarize_us(x)["median"] for x in per_repeat_ns]
    pooled["median_of_repeat_medians"] = float(np.median(medians)) if medians else float("nan")
    pooled["pooled_median"] = pooled["median"]
    pooled["median"] = pooled["median_of_repeat_medians"]
    pooled["repeats"] = len(per_repeat_ns)
    return pooled


def time_calls_us(fn: Callable[[], object], repeats: int, warmup: int = 3) -> tuple[dict[str, float], object]:
    """Call ``fn`` ``warmup + repeats`` times; summary (µs) of the last ``repeats`` calls and the last result."""
    out = None
    for _ in range(warmup):
        out = fn()
    durations = np.empty(repeats, dtype=np.int64)
    for i in range(repeats):
        t0 = perf_counter_ns()
        out = fn()
        durations[i] = perf_counter_ns() - t0
    return summarize_us(durations), out


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.lower().startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _version(dist: str) -> str | None:
    try:
        return importlib.metadata.version(dist)
    except importlib.metadata.PackageNotFoundError:
        return None


def machine_info() -> dict[str, object]:
    """CPU model, core counts, load average, OS, and the versions of Python and the compared libraries."""
    try:
        load = list(os.getloadavg())
    except OSError:
        load = None
    affinity = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None
    return {
        "date_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "hostname": platform.node(),
        "cpu_model": _cpu_model(),
        "logical_cores": os.cpu_count(),
        "usable_cores": affinity,
        "load_average_1_5_15": load,
        "os": platform.platform(),
        "python": sys.version.split()[0],
        "versions": {name: _version(name) for name in
                     ("wbc", "numpy", "scipy", "pin", "placo", "pin-pink", "qpsolvers", "proxsuite", "daqp",
                      "osqp", "quadprog", "matplotlib")},
    }


_BLAS_SETTERS = ("scipy_openblas_set_num_threads64_", "scipy_openblas_set_num_threads", "openblas_set_num_threads64_",
                 "openblas_set_num_threads")
_BLAS_GETTERS = ("scipy_openblas_get_num_threads64_", "scipy_openblas_get_num_threads", "openblas_get_num_threads64_",
                 "openblas_get_num_threads")


def limit_blas_threads(n: int = 1) -> dict[str, int]:
    """Set the thread count of every OpenBLAS loaded in this process (numpy's, scipy's) to ``n``.

    A 500 Hz controller multiplies matrices of a few dozen rows: BLAS threads only add synchronisation and compete
    with other processes for the cores. placo (Eigen) and proxsuite run single-threaded. Linux only (reads
    ``/proc/self/maps``); elsewhere does nothing.

    Returns:
        library path -> thread count after the call (empty when no OpenBLAS was found).
    """
    import ctypes

    try:
        with open("/proc/self/maps", encoding="utf-8") as f:
            paths = sorted({line.split()[-1] for line in f if "openblas" in line.lower() and "/" in line})
    except OSError:
        return {}
    out: dict[str, int] = {}
    for path in paths:
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        setter = next((getattr(lib, s) for s in _BLAS_SETTERS if hasattr(lib, s)), None)
        getter = next((getattr(lib, s) for s in _BLAS_GETTERS if hasattr(lib, s)), None)
        if setter is None:
            continue
        setter(ctypes.c_int(n))
        out[path.rsplit("/", 1)[-1]] = int(getter()) if getter is not None else n
    return out
