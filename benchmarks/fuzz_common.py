"""Pieces shared by the fuzz benchmarks (kinematic ``fuzz.py``, inverse-dynamics ``fuzz_id.py``): the independent
feasibility check (scipy HiGHS LP of a QP's hard set), the robots with their joint limits loaded once per process,
and the chunked, resumable, multi-process driver with its aggregation.
"""

from __future__ import annotations

import argparse
import gc
import json
import multiprocessing
import resource
import time
import warnings
from pathlib import Path
from typing import Callable

import numba
import numpy as np
import scipy.optimize

import wbc
from wbc.constraints.limits import bounded_joints

ROBOTS = ("talos", "g1", "humanoid15")


def acceptance_verdict(items: list[tuple[str, object, bool]]) -> str:
    """The last acceptance line: "ACCEPTANCE: all <n> items PASS", or "ACCEPTANCE: <k> of <n> items FAIL (<names>)"."""
    failed = [what for what, _, ok in items if not ok]
    if not failed:
        return f"ACCEPTANCE: all {len(items)} items PASS"
    return f"ACCEPTANCE: {len(failed)} of {len(items)} items FAIL ({'; '.join(failed)})"


def highs_feasible(A, b, C, l, u, lb, ub, tol: float = 1e-7) -> bool:
    """Independent check (scipy HiGHS LP, primal feasibility tolerance ``tol``): does any x meet A x = b,
    l ≤ C x ≤ u, lb ≤ x ≤ ub? (±inf entries are absent bounds.)"""
    n = A.shape[1] if A.shape[0] else C.shape[1] if C.shape[0] else lb.shape[0]
    A_ub, b_ub = [], []
    for rows, hi, sign in ((C, u, 1.0), (C, l, -1.0)):
        m = np.isfinite(hi)
        if m.any():
            A_ub.append(sign * rows[m])
            b_ub.append(sign * hi[m])
    r = scipy.optimize.linprog(np.zeros(n), A_ub=np.vstack(A_ub) if A_ub else None,
                               b_ub=np.concatenate(b_ub) if b_ub else None, A_eq=A if A.shape[0] else None,
                               b_eq=b if A.shape[0] else None,
                               bounds=[(lo if np.isfinite(lo) else None, hi if np.isfinite(hi) else None)
                                       for lo, hi in zip(lb, ub)], method="highs",
                               options={"primal_feasibility_tolerance": tol})
    return r.status == 0


_ROBOTS: dict = {}


def joint_limits(robot) -> tuple:
    """(iq, q_lo, q_hi, v_max) of ``robot``'s bounded joints: their indices in q, position limits (rad or m) and
    velocity limits (inf where the model gives none)."""
    iq, _ = bounded_joints(robot.model)
    vmax = robot.model.velocityLimit[6:]
    return (iq, robot.model.lowerPositionLimit[iq], robot.model.upperPositionLimit[iq],
            np.where(np.isfinite(vmax) & (vmax >= 0), vmax, np.inf))


def load_robots() -> tuple[dict, dict]:
    """({name: Robot}, {name: :func:`joint_limits`}) for :data:`ROBOTS`, loaded once per process."""
    if not _ROBOTS:
        warnings.simplefilter("ignore")
        robots = {n: wbc.load_robot(n) for n in ROBOTS}
        _ROBOTS.update(robots=robots, limits={n: joint_limits(r) for n, r in robots.items()})
    return _ROBOTS["robots"], _ROBOTS["limits"]


_FROZEN: set = set()


def freeze_after_first(key) -> None:
    """After the first controller of ``key`` (a robot, a solver) in this process: ``gc.freeze()``. What the robots
    and the first controllers load (models, compiled kernels) lives for the whole run; frozen, it is out of the
    collector's reach, so that a full (generation-2) collection inside a tick walks only what the ticks allocate
    (otherwise such a collection was measured to take 45–60 ms of a tick's thread CPU time). A real-time loop
    does the same once set up."""
    if key not in _FROZEN:
        _FROZEN.add(key)
        gc.collect()
        gc.freeze()


def collect_between_episodes() -> None:
    """A full collection after an episode's controller is built, before its first tick: the previous episodes'
    controllers (reference cycles) are collected here rather than by a generation-2 collection that lands inside
    a measured tick (such collections took up to 41 ms of thread CPU time in a 25 000-tick chunk: the harness's
    garbage, not the tick's work). A real-time loop builds its controller once and collects outside its ticks."""
    gc.collect()


@numba.njit(cache=True)
def _canary_work(buf: np.ndarray, rounds: int) -> float:
    """A fixed amount of work: ``rounds`` passes of a dependent multiply-add chain over ``buf`` (L1-resident)."""
    s = 0.0
    for _ in range(rounds):
        for i in range(buf.shape[0]):
            s = s * 0.999999 + buf[i]
    return s


class TickProbe:
    """What a measured tick contained besides its own work, to attribute a slow tick: the garbage collections that
    ran inside it (``gc.callbacks``: generation, thread CPU time), the thread's resource usage over it
    (``getrusage(RUSAGE_THREAD)``: user and system CPU time, minor and major page faults, voluntary and involuntary
    context switches), and the machine's speed next to it: a canary, the same fixed work (:func:`_canary_work`,
    about 8 us) timed by ``time.thread_time`` just before the tick (after an untimed run that warms its code and data) and just after it, as a ratio to the canary's median
    over this process's previous ``CANARY_WINDOW`` ticks. A canary that runs slow beside a slow tick says the
    machine ran slow then (the CPU time a VM's host takes without reporting it as steal, another tenant on the
    core); a normal canary says nothing about the tick's inside. ``start()`` before the tick, ``stop()`` after it
    (outside the tick's own timing)."""

    CANARY_WINDOW = 1024
    CANARY_ROUNDS = 48  # over 128 values (1 kB), about 8 us

    def __init__(self):
        self._gc: list = []
        self._gc_t0 = 0.0
        self._r0 = None
        self._canary_buf = np.linspace(0.0, 1.0, 128)
        self._canary = np.zeros(self.CANARY_WINDOW)
        self._canary_n = 0
        self._canary_ref = 0.0
        self._canary_before = 0.0
        _canary_work(self._canary_buf, self.CANARY_ROUNDS)  # compiled before any timing
        gc.callbacks.append(self._on_gc)

    def _on_gc(self, phase: str, info: dict) -> None:
        if phase == "start":
            self._gc_t0 = time.thread_time()
        else:
            self._gc.append((info["generation"], time.thread_time() - self._gc_t0))

    def _time_canary(self) -> float:
        """One canary's thread CPU time (s), kept in the window; the reference median is renewed after the
        first 64 and each time the window fills."""
        t = time.thread_time()
        _canary_work(self._canary_buf, self.CANARY_ROUNDS)
        t = time.thread_time() - t
        self._canary[self._canary_n % self.CANARY_WINDOW] = t
        self._canary_n += 1
        if self._canary_n % self.CANARY_WINDOW == 0 or self._canary_n == 64 or self._canary_ref == 0.0:
            self._canary_ref = float(np.median(self._canary[:min(self._canary_n, self.CANARY_WINDOW)]))
        return t

    def start(self) -> None:
        _canary_work(self._canary_buf, self.CANARY_ROUNDS)  # warms the canary's code and data after the harness's work
        self._canary_before = self._time_canary()
        self._gc.clear()
        self._r0 = resource.getrusage(resource.RUSAGE_THREAD)

    def stop(self) -> str:
        """The tick's attribution: "user U ms sys S ms minflt F majflt J csw V/I gc [gen: ms, ...] canary B/A x"
        (B, A: the canaries before and after the tick over their median)."""
        r0, r = self._r0, resource.getrusage(resource.RUSAGE_THREAD)
        after = self._time_canary()
        ref = self._canary_ref
        gcs = ", ".join(f"{g}: {1e3 * t:.2f} ms" for g, t in self._gc) or "none"
        return (f"user {1e3 * (r.ru_utime - r0.ru_utime):.2f} ms sys {1e3 * (r.ru_stime - r0.ru_stime):.2f} ms "
                f"minflt {r.ru_minflt - r0.ru_minflt} majflt {r.ru_majflt - r0.ru_majflt} "
                f"csw {r.ru_nvcsw - r0.ru_nvcsw}/{r.ru_nivcsw - r0.ru_nivcsw} gc [{gcs}] "
                f"canary {self._canary_before / ref:.2f}/{after / ref:.2f} x")


def slow_canary_ticks(worst: list[tuple[float, str]], over: float = 2.0, slow: float = 1.5) -> list[str]:
    """The slow ticks (ratio > ``over`` of their budget) with a canary (:class:`TickProbe`) before or after them
    at more than ``slow`` times its median: the machine ran slow beside the tick. ``worst``: (ratio, "… canary B/A
    x") records of the harnesses' slowest ticks."""
    import re

    out = []
    for ratio, where in worst:
        m = re.search(r"canary ([0-9.]+)/([0-9.]+) x", where)
        if ratio > over and m and max(float(m.group(1)), float(m.group(2))) > slow:
            out.append(where)
    return out


def coincident_stalls(worst: list[tuple[float, str]], over: float = 2.0, within: float = 0.002) -> list[str]:
    """The slow ticks (ratio > ``over`` of their budget) whose wall-clock interval overlaps that of a slow tick of
    another chunk — run by another process at the same time: a stall of the machine, not of one tick's work.
    ``worst``: (ratio, "seed S … at T s … wall W ms …") records of the harnesses' slowest ticks, T the wall-clock
    time (s) at the tick's end, W its wall time: the tick ran over [T − W, T]; each interval is widened by
    ``within`` (s) at both ends (the 1 ms rounding of T); a record without its wall time is the instant T."""
    import re

    marks = []
    for ratio, where in worst:
        t, seed = re.search(r" at ([0-9.]+) s", where), re.search(r"seed (\d+)", where)
        wall = re.search(r"wall ([0-9.]+) ms", where)
        if t and seed:
            end = float(t.group(1))
            start = end - (1e-3 * float(wall.group(1)) if wall else 0.0)
            marks.append((ratio, start - within, end + within, seed.group(1), where))
    return [where for ratio, s0, s1, seed, where in marks if ratio > over and any(
        s2 != seed and a0 <= s1 and s0 <= a1 for _, a0, a1, s2, _ in marks)]


REPLAYS = 3  #: times a tick over 2 x its budget is re-run (its episode replayed) for the tick-CPU line
MAX_OVER = 200  #: ticks over 2 x budget recorded per chunk for replay; more fail the tick-CPU line unreplayed


def record_over(c: dict, seed: int, chunk_ticks: int, ep: int, tick: int, ratio: float, over: float = 2.0) -> None:
    """Keep in ``c["over_2x"]`` the tick (seed, chunk ticks, episode, tick, CPU / budget) when its ratio is over
    ``over``: what :func:`replay_over` needs to run its episode again. At most :data:`MAX_OVER` per chunk; the
    count of the others is ``c["over_2x_unkept"]``."""
    if ratio > over:
        if len(c.setdefault("over_2x", [])) < MAX_OVER:
            c["over_2x"].append([int(seed), int(chunk_ticks), int(ep), int(tick), float(ratio)])
        else:
            c["over_2x_unkept"] = c.get("over_2x_unkept", 0) + 1


def replay_over(over: list, replay: Callable[[int, int, int], list], repeats: int = REPLAYS,
                limit: float = 2.0) -> dict:
    """Re-measure the ticks over ``limit`` x their budget: each one's episode is run again ``repeats`` times in this
    process (``replay(seed, chunk_ticks, episode)`` -> that episode's CPU / budget per tick, in tick order; the
    episodes interleaved: A B A B), and a tick's figure is the median of its replays. The same draws give the same
    ticks: a tick that is slow again is slow by its own work; one that is not was slowed by the machine (a VM's
    stall, another tenant) while the run measured it. A tick its replay did not reach counts as slow.

    Returns {"over": ticks given, "slow": ticks whose median is over ``limit``, "max_median": the largest median,
    "records": ["seed S episode E tick T: R x in the run, replays a/b/c x (median m x)", ...]}."""
    episodes: dict = {}
    for seed, chunk_ticks, ep, tick, ratio in over:
        episodes.setdefault((seed, chunk_ticks, ep), []).append((tick, ratio))
    runs: dict = {key: [] for key in episodes}
    for _ in range(repeats):
        for key in episodes:
            runs[key].append(replay(*key))
    records, slow, max_median = [], 0, 0.0
    for (seed, chunk_ticks, ep), ticks in episodes.items():
        for tick, ratio in ticks:
            again = [run[tick] if tick < len(run) else float("inf") for run in runs[(seed, chunk_ticks, ep)]]
            median = float(np.median(again))
            slow += int(median > limit)
            max_median = max(max_median, median)
            records.append(f"seed {seed} episode {ep} tick {tick}: {ratio:.2f} x in the run, replays "
                           f"{'/'.join(f'{x:.2f}' for x in again)} x (median {median:.2f} x)")
    return {"over": len(over), "slow": slow, "max_median": max_median, "records": records}


def over_line(total: dict, max_ratio: float, n_over: int, n_over_1: int) -> tuple[str, str, bool]:
    """The tick-CPU acceptance item (what, value, ok): every tick over 2 x its budget in the run re-measured by
    :func:`replay_over` (``total["replayed"]``) at or under 2 x; without replays, no tick over 2 x."""
    what = (f"max tick CPU time (time.thread_time) <= 2 x its budget; a tick over it in the run is re-measured: its "
            f"episode replayed {REPLAYS} x in one process after the run, the median")
    value = f"{max_ratio:.3f} x budget in the run ({n_over} ticks over 2 x, {n_over_1} over 1 x)"
    rep, unkept = total.get("replayed"), total.get("over_2x_unkept", 0)
    if rep is None:
        return what, value + "; not replayed", n_over == 0
    value += (f"; replayed {rep['over']} of them: {rep['slow']} over 2 x (medians up to {rep['max_median']:.2f} x)"
              + (f"; {unkept} not kept for replay" if unkept else ""))
    return what, value, rep["slow"] == 0 and unkept == 0 and rep["over"] == n_over


_PROBE: list = []


def tick_probe() -> TickProbe:
    """This process's :class:`TickProbe` (one: its ``gc`` callback is registered once)."""
    if not _PROBE:
        _PROBE.append(TickProbe())
    return _PROBE[0]


def _run_job(job: tuple) -> tuple[int, dict]:
    i, run_chunk, ticks, seed, n_chunks, out, options = job
    ch = run_chunk(ticks, seed, progress=f"chunk {i + 1}/{n_chunks} (seed {seed}) ", **options)
    if out is not None:
        tmp = Path(out).with_suffix(".tmp")
        tmp.write_text(json.dumps(ch))
        tmp.replace(out)
    return i, ch


def chunk_arguments(p: argparse.ArgumentParser, ticks: int) -> None:
    """The driver's options: --ticks --jobs --seed --chunk --out --aggregate-only."""
    p.add_argument("--ticks", type=int, default=ticks, help="total ticks")
    p.add_argument("--jobs", type=int, default=1, help="processes (chunks run in parallel, results summed)")
    p.add_argument("--seed", type=int, default=0, help="seed of the first chunk (chunk i uses seed + i)")
    p.add_argument("--chunk", type=int, default=50_000, help="ticks per chunk (one result file each)")
    p.add_argument("--out", type=Path, default=None,
                   help="folder of per-chunk results: finished chunks are skipped (resume), all are aggregated")
    p.add_argument("--aggregate-only", action="store_true",
                   help="run nothing: aggregate every finished chunk file in --out")


def run_chunks(a: argparse.Namespace, run_chunk: Callable, aggregate: Callable, report: Callable, tag: str,
               confirm: Callable | None = None, **options) -> None:
    """Run ``run_chunk(ticks, seed, progress=..., **options) -> dict`` over the chunks of ``a`` (see
    :func:`chunk_arguments`), in ``a.jobs`` processes, saving/resuming per-chunk files ``<tag>_<seed>_<ticks>.json``
    in ``a.out``; print ``report(total)``, ``total = aggregate(chunks)`` after ``confirm(total)`` (when given: the
    re-measurements that run in this process after the chunks, e.g. :func:`replay_over`)."""
    if a.aggregate_only:
        files = sorted(a.out.glob(f"{tag}_*.json"))
        print(f"{len(files)} chunk files in {a.out}", flush=True)
        total = aggregate([json.loads(f.read_text()) for f in files])
        if confirm is not None:
            confirm(total)
        print(report(total), flush=True)
        return
    t0 = time.time()
    n_chunks = max(1, -(-a.ticks // a.chunk))
    if a.out is not None:
        a.out.mkdir(parents=True, exist_ok=True)
    chunks: dict[int, dict] = {}
    jobs = []
    for i in range(n_chunks):
        ticks = min(a.chunk, a.ticks - i * a.chunk)
        f = a.out / f"{tag}_{a.seed + i}_{ticks}.json" if a.out is not None else None
        if f is not None and f.exists():
            chunks[i] = json.loads(f.read_text())
            print(f"chunk {i + 1}/{n_chunks} (seed {a.seed + i}) already done: {f}", flush=True)
            continue
        jobs.append((i, run_chunk, ticks, a.seed + i, n_chunks, None if f is None else str(f), options))
    if a.jobs <= 1:
        results = map(_run_job, jobs)
    else:
        pool = multiprocessing.get_context("fork").Pool(a.jobs)
        results = pool.imap_unordered(_run_job, jobs)
    for i, ch in results:
        chunks[i] = ch
        print(f"chunk {i + 1}/{n_chunks} (seed {a.seed + i}) done", flush=True)
    if a.jobs > 1:
        pool.close()
        pool.join()
    print(f"wall time {time.time() - t0:.0f} s with {a.jobs} process(es)", flush=True)
    total = aggregate([chunks[i] for i in sorted(chunks)])
    if confirm is not None:
        confirm(total)
    print(report(total), flush=True)
