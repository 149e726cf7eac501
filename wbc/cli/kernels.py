"""``wbc compile``: compile every numba kernel ahead of time, in parallel over the cores.

wbc's kernels are compiled on first use and cached on disk (``__pycache__`` next to each source file, or under
``NUMBA_CACHE_DIR``): a command's first run compiles the kernels it needs (the loaders its objects call at
construction, one line per module on stderr) and later runs load them. ``wbc compile`` compiles all of them at once:
it runs every kernel loader (:func:`compile_all`) in worker processes, one module per process at a time and as many
processes as cores (numba compiles in one thread under a process-wide lock; its cache is written file by file,
atomically, so processes share it), a module only after the modules of :data:`AFTER` whose kernels it calls; then it
runs each command of :data:`WARM_UP_RUNS` for two steps in a child process (:func:`run_warm_up`): a kernel a command
calls with array types or layouts no loader used (a MuJoCo contact slice, a column-major mass matrix, the
inverse-dynamics tick) is compiled and cached there; beside them it builds the C++ self-collision narrow phase
(:data:`BUILDS`), which the install does not build. A progress bar on a terminal, one line per module otherwise.
Run again, it loads the cached kernels and takes seconds.

A run command's first run (walk, balance, sim) does the same for the modules its controller needs
(:data:`COMMAND_MODULES`, :func:`compile_for_command`), before it builds the controller, which then loads them.
"""

from __future__ import annotations

import os
import sys
import time
from typing import Callable, Iterable

from wbc.exceptions import InvalidInputError

__all__ = ["AFTER", "BUILDS", "COMMAND_MODULES", "COMPILED_TWICE", "LOADER_MODULES", "PARTS", "WARM_UP_RUNS",
           "register", "check_compile_args", "cmd_compile", "compile_all", "compile_for_command", "default_jobs", "loader_modules",
           "run_warm_up"]

#: Every module with a :func:`wbc.compiled.once_per_process` loader, the kinematic controller's first (what
#: ``wbc walk`` loads; the longest compilations first), then the inverse-dynamics controller's and the simulation's
#: (``wbc sim``).
LOADER_MODULES = (
    "wbc.solvers.active_set", "wbc.formulations.velocity_kernel", "wbc.tasks.frame", "wbc.configuration", "wbc.tasks.com",
    "wbc.tasks.posture", "wbc.constraints.contact", "wbc.constraints.zmp", "wbc.constraints.acceleration",
    "wbc.constraints.braking", "wbc.constraints.limits",
    "wbc.formulations.idkernel", "wbc.controllers.inverse_dynamics", "wbc.dynamics.actuator_compensation",
    "wbc.constraints.joint_acceleration_bounds",
    "wbc.sim.actuators", "wbc.sim.closed_loop", "wbc.sim.conventions", "wbc.sim.estimated_state",
    "wbc.sim.outcome", "wbc.sim.sensors", "wbc.sim.walk",
)

#: The loader modules whose loaders each run command's controllers call (:func:`compile_for_command`): the kinematic
#: controller's for ``walk`` and ``balance`` (the 11 modules whose loaders a ``wbc walk`` runs, listed by
#: :func:`wbc.compiled.set_load_listener`, the active-set solver's first: the ``fast`` backend and the kinematic
#: kernels link it), every module
#: for ``sim`` (the inverse-dynamics controller on MuJoCo).
COMMAND_MODULES = {"walk": LOADER_MODULES[:11], "balance": LOADER_MODULES[:11], "sim": LOADER_MODULES}

#: Loader modules whose kernels call kernels that other loader modules compile (module -> those modules; a warm-up
#: run of :data:`WARM_UP_RUNS` too, as ``"wbc sim walk --steps 2"``): ``wbc compile`` starts a module's loaders only
#: once those modules' loaders have finished, so that the shared kernels are compiled by one process and loaded from
#: the cache by the others (two processes compiling the same kernel do the work twice). Every loader module that
#: imports a kernel of another loader module lists it, except the imports of :data:`COMPILED_TWICE`. The kinematic
#: solver's kernels link the active-set kernels (as the ``fast`` backend does): these compile first (a ``wbc
#: walk``'s longest chain: active_set, then velocity_kernel).
AFTER = {
    "wbc.formulations.velocity_kernel": ("wbc.solvers.active_set", "wbc.tasks.frame", "wbc.constraints.limits"),
    "wbc.tasks.frame": ("wbc.configuration",),
    "wbc.constraints.contact": ("wbc.tasks.frame", "wbc.configuration"),
    "wbc.formulations.idkernel": ("wbc.constraints.joint_acceleration_bounds", "wbc.solvers.active_set"),
    "wbc.sim.closed_loop": ("wbc.formulations.velocity_kernel",),
    "wbc.controllers.inverse_dynamics": ("wbc.formulations.idkernel",),
}

#: Imports of a loader module's kernels that do not make the importer wait (:data:`AFTER`): the importer compiles
#: them itself, at the same time as their own module does. None today.
COMPILED_TWICE: dict[str, tuple[str, ...]] = {}

#: Loaders that a compilation runs as items of their own, ahead of their module's (module -> loader function names):
#: a module's kernels that link no kernel of the modules it waits for (:data:`AFTER`) compile in another process
#: while those do, and the module's own item then loads them from the cache. The kinematic kernels' item
#: ``"wbc.formulations.velocity_kernel:load_kinematic_parts"`` (cost formation, contact drifts, the general route's
#: reduced QP: 6.5 s of compilation on one core) runs beside the active-set solver's, so that a first walk's longest
#: chain (active_set, then velocity_kernel) holds only the compiled tick.
PARTS = {"wbc.formulations.velocity_kernel": ("load_kinematic_parts",)}

#: Functions ``wbc compile`` (all modules) also runs, as ``"module:function"``, beside the loaders: the build of the
#: C++ self-collision narrow phase (:func:`wbc.constraints.narrow_phase_build.build_or_explain`; nothing to do when
#: it is built and newer than its source; a failure is one line, not an error), which the install does not build.
BUILDS = ("wbc.constraints.narrow_phase_build:build_or_explain",)

#: ``wbc`` commands ``wbc compile`` runs (two steps each, ``--quiet``) after the loaders: they call kernels no loader
#: reaches with their real argument types (the closed loop on MuJoCo: inverse-dynamics tick, state estimator,
#: outcome checks on MuJoCo's contact arrays).
WARM_UP_RUNS = (("sim", "walk", "--steps", "2"),)

# the closed-loop walk calls kernels of every loader module (the kinematic solver's too, through the closed loop's
# kinematic side): it waits for all of them, so that each kernel is compiled and written by one process (two processes
# compiling one kernel write its cache index twice, and the run's compilation would race the loader's)
AFTER["wbc sim walk --steps 2"] = LOADER_MODULES


def run_warm_up(argv: tuple[str, ...]) -> float:
    """Run ``python -m wbc *argv --quiet`` in a child process (same interpreter, same environment, so the same numba
    cache), its output discarded (but for numba's cache log, passed on to this process's standard output when
    ``NUMBA_DEBUG_CACHE`` is set): every kernel it calls is loaded from numba's on-disk cache, or compiled and
    written there.

    Args:
        argv: a ``wbc`` command line without the program name, e.g. ``("sim", "walk", "--steps", "2")``.

    Returns:
        The wall time in seconds the run took.

    Raises:
        SimulationError: the run exited with a code other than 0 or 1 (1: its acceptance failed, which a warm-up
            does not judge; the last lines of its standard error in the message).
    """
    import subprocess

    from wbc.exceptions import SimulationError

    t0 = time.perf_counter()
    # numba's cache log (NUMBA_DEBUG_CACHE=1) of the run is part of compile's: which kernels the run loaded or wrote
    debug = os.environ.get("NUMBA_DEBUG_CACHE", "0") not in ("", "0")
    out = subprocess.run([sys.executable, "-m", "wbc", *argv, "--quiet"], stdout=subprocess.PIPE if debug else
                         subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                         preexec_fn=_default_sigint)  # Ctrl-C stops the run
    if debug:
        for line in out.stdout.splitlines():  # a line per write (see _init_worker)
            if line.startswith("[cache]"):
                print(line, flush=True)
    if out.returncode not in (0, 1):  # 1: the run's acceptance failed, its kernels ran all the same
        raise SimulationError(f"`wbc {' '.join(argv)}` (run by wbc compile to compile its kernels) exited with "
                              f"{out.returncode}: {out.stderr.strip()[-500:]}")
    return time.perf_counter() - t0


def loader_modules(names: Iterable[str] = ()) -> list[str]:
    """The kernel modules ``names`` checked against :data:`LOADER_MODULES` (all of them when ``names`` is empty).

    Raises:
        InvalidInputError: a name is not in :data:`LOADER_MODULES`.
    """
    names = list(names)
    unknown = [m for m in names if m not in LOADER_MODULES]
    if unknown:
        raise InvalidInputError(f"no numba kernel loader in {', '.join(unknown)}; the modules with one: "
                                f"{', '.join(LOADER_MODULES)}")
    return names or list(LOADER_MODULES)


def compile_all(modules: Iterable[str] = (), jobs: int = 1,
                on_done: Callable[[str, float, float], None] | None = None,
                on_start: Callable[[str], None] | None = None,
                runs: Iterable[tuple[str, ...]] = (), calls: Iterable[str] = ()) -> dict[str, float]:
    """Import each module and run its loaders (:func:`wbc.compiled.run_loaders`): every kernel they call is compiled
    and written to numba's on-disk cache, or loaded from it when already there; then run each command of ``runs``
    (:func:`run_warm_up`).

    A module with :data:`PARTS` is two or more items: each of those loaders, then the module's (which waits for them).
    With ``jobs`` > 1 the modules and runs are done in that many worker processes (same interpreter and environment,
    so the same cache), each once the items :data:`AFTER` lists for it (among those given) are done, the ready ones that
    most items wait for first (then in the order given); the kernels are then in the on-disk cache, not in this process.

    Args:
        modules: names among :data:`LOADER_MODULES` (default, or empty: all of them).
        jobs: the number of processes (1: in this process, one item after the other).
        on_done: called ``on_done(item, wall_seconds, cpu_seconds)`` in this process as each item finishes (a module
            name, one of its :data:`PARTS` as ``"module:loader"``, or a run as ``"wbc sim walk --steps 2"``; CPU: of
            the worker, or of a run's child process).
        on_start: called ``on_start(item)`` in this process as each item starts.
        runs: ``wbc`` command lines without the program name (e.g. :data:`WARM_UP_RUNS`).
        calls: functions without arguments to run as items too, as ``"module:function"`` (e.g. :data:`BUILDS`).

    Returns:
        The wall time in seconds each item took (import and loaders; a run: the whole command), by item.

    Raises:
        InvalidInputError: a name is not in :data:`LOADER_MODULES` (before any module is imported), or ``jobs`` < 1.
        SimulationError: a run failed (see :func:`run_warm_up`), or a worker process died (killed, or crashed in the
            compiler) before it returned its item.
    """
    items = {}
    for name in loader_modules(modules):
        items.update({f"{name}:{part}": f"{name}:{part}" for part in PARTS.get(name, ())})
        items[name] = name
    items.update({call: call for call in calls})
    items.update({_run_label(argv): tuple(argv) for argv in runs})
    if jobs < 1:
        raise InvalidInputError(f"jobs must be at least 1, got {jobs}")
    seconds = {}

    def finished(label: str, wall: float, cpu: float) -> None:
        seconds[label] = wall
        if on_done is not None:
            on_done(label, wall, cpu)

    if jobs == 1 or len(items) == 1:
        for label, item in items.items():
            if on_start is not None:
                on_start(label)
            finished(*_compile_item(item))
        return seconds

    import multiprocessing
    import queue

    from wbc.exceptions import SimulationError

    parts = {label: {f"{label}:{part}" for part in PARTS.get(label, ())} & set(items) for label in items}
    waiting = {label: {m for m in AFTER.get(label, ()) if m in items} | parts[label] for label in items}
    # the ready items that other items wait for go first (the most waiting ones first, then in the order given): a
    # first walk's longest chain ends in the kinematic tick, which waits for five items; started as soon as they are
    # done rather than after the other modules (a first walk 31.0 s -> 28 s on 2 quiet cores)
    waited_for = {label: sum(label in deps for deps in waiting.values()) for label in items}
    order = {label: k for k, label in enumerate(items)}
    running: set[str] = set()
    results: queue.Queue = queue.Queue()  # (label, result or None, exception or None), put by the pool's thread
    # spawn: a fresh interpreter per worker (a fork would copy this process's LLVM state and threads); the workers
    # ignore Ctrl-C (inside numba's compiler it would be swallowed, with a traceback): this process stops them
    pool = multiprocessing.get_context("spawn").Pool(min(jobs, len(items)), initializer=_init_worker)
    workers = {p.pid for p in multiprocessing.active_children()}  # the pool starts its workers at once
    try:
        while waiting or running:
            ready = sorted((n for n, deps in waiting.items() if not deps), key=lambda n: (-waited_for[n], order[n]))
            for label in ready[:max(0, jobs - len(running))]:
                del waiting[label]
                running.add(label)
                pool.apply_async(_compile_item, (items[label],),
                                 callback=lambda result, label=label: results.put((label, result, None)),
                                 error_callback=lambda error, label=label: results.put((label, None, error)))
                if on_start is not None:
                    on_start(label)
            try:
                label, result, error = results.get(timeout=1.0)
            except queue.Empty:  # a worker that died (a signal, a crash in the compiler) never returns its item
                if not workers <= {p.pid for p in multiprocessing.active_children()}:
                    raise SimulationError(f"a compile worker process died while compiling {', '.join(sorted(running))}"
                                          " (its kernels are compiled on first use instead)") from None
                continue
            running.discard(label)
            if error is not None:
                raise error
            finished(*result)
            for deps in waiting.values():
                deps.discard(label)
        pool.close()
    finally:
        pool.terminate()  # nothing left to run, or stopped early (an error, Ctrl-C): the workers end now
        pool.join()
    return seconds


def _default_sigint() -> None:  # in a child process: Ctrl-C stops it (a compile worker ignores it)
    import signal

    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _init_worker() -> None:
    """A compile worker: ignores Ctrl-C (this process stops it), and writes its output a line at a time. The workers
    share this process's standard output (a pipe when captured): a line is one write() of under PIPE_BUF bytes,
    which a pipe never interleaves with another process's, where a block-buffered flush (several kB) can be cut by
    another worker's mid-line (numba's cache log lines were lost that way under load)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    sys.stdout.reconfigure(line_buffering=True)
    sys.stderr.reconfigure(line_buffering=True)


def _item_count(modules: list[str] | tuple[str, ...]) -> int:
    """The number of items :func:`compile_all` runs for ``modules``: each module and each of its :data:`PARTS`."""
    return sum(1 + len(PARTS.get(m, ())) for m in modules)


def _run_label(argv: tuple[str, ...]) -> str:
    return "wbc " + " ".join(argv)


def _compile_item(item: str | tuple[str, ...]) -> tuple[str, float, float]:
    """Import the module ``item`` and run its loaders, or run the ``wbc`` command line ``item`` (a tuple); returns
    (its label, wall seconds, CPU seconds of this process or of the command's child process)."""
    try:
        return _timed_item(item)
    finally:  # the pool terminates its workers once all is done: what they printed must be out before the result
        sys.stdout.flush()
        sys.stderr.flush()


def _timed_item(item: str | tuple[str, ...]) -> tuple[str, float, float]:
    """:func:`_compile_item`'s work: (label, wall seconds, CPU seconds)."""
    import resource

    t0, c0 = time.perf_counter(), time.process_time()
    if isinstance(item, tuple):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        run_warm_up(item)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
        return _run_label(item), time.perf_counter() - t0, cpu
    import importlib

    from wbc.compiled import run_loaders

    name, _, part = item.partition(":")
    module = importlib.import_module(name)
    if part:  # one loader of the module (PARTS), or a function of BUILDS
        getattr(module, part)()
    else:
        run_loaders(name)
    return item, time.perf_counter() - t0, time.process_time() - c0


def default_jobs() -> int:
    """The number of cores this process may run on (its CPU affinity): ``wbc compile``'s default ``--jobs``."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def register(sub, add_outputs=None) -> None:
    """Add the ``compile`` sub-command to ``wbc``'s sub-parsers (``add_outputs`` is not used)."""
    p = sub.add_parser("compile", help="compile every numba kernel now, in parallel, and cache it on disk",
                       description="Compile all of wbc's numba kernels now, in parallel over the cores, and cache "
                                   "them on disk, so that no later run (walk, sim, balance...) compiles any; "
                                   "without it each command compiles the kernels it needs on its first run. A "
                                   "second `wbc compile` only loads the cached kernels.")
    p.add_argument("modules", nargs="*", metavar="MODULE",
                   help=f"only these modules' kernels (default: all {len(LOADER_MODULES)}: "
                        f"{', '.join(LOADER_MODULES)})")
    p.add_argument("--jobs", "-j", type=int, default=default_jobs(), metavar="N",
                   help="compile in N processes (default: the cores available, %(default)s)")
    p.add_argument("--quiet", action="store_true", help="no progress bar or per-module lines, only the final line")
    p.set_defaults(func=cmd_compile, check=check_compile_args)


def check_compile_args(args) -> None:
    """Raises InvalidInputError: a module without kernel loader (see :data:`LOADER_MODULES`), or ``--jobs`` < 1."""
    loader_modules(args.modules)
    if args.jobs < 1:
        raise InvalidInputError(f"--jobs must be a whole number of processes >= 1, got {args.jobs}")


def cmd_compile(args) -> int:
    """`wbc compile`: run the loaders of every (or each given) kernel module in ``--jobs`` processes
    (:func:`compile_all`), and (all modules only) the functions of :data:`BUILDS`, then the commands of
    :data:`WARM_UP_RUNS`; with a progress bar on a terminal naming the modules or command being compiled (redrawn
    every second from the start), one line per module otherwise (its wall and CPU seconds, as each finishes); prints
    the total time. Exit code 0.

    Raises:
        SimulationError: a command of :data:`WARM_UP_RUNS` failed.
    """
    from wbc.cli.output import uncompiled_kernels

    modules = loader_modules(args.modules)
    runs, calls = ((), ()) if args.modules else (WARM_UP_RUNS, BUILDS)
    jobs = min(args.jobs, len(modules) + len(runs) + len(calls))
    t0 = time.perf_counter()
    missing = 0 if args.quiet else len(uncompiled_kernels(modules))
    where = f"in {jobs} processes" if jobs > 1 else "in this process"
    with _Progress("wbc compile", _item_count(modules) + len(runs) + len(calls),
                   f"wbc compile: compiling the numba kernels of {len(modules)} modules {where} ({missing} without "
                   "on-disk cache; a minute or two once on 2 cores) ..." if missing else
                   f"wbc compile: loading the cached numba kernels of {len(modules)} modules ...",
                   show=not args.quiet) as shown:
        compile_all(modules, jobs=jobs, on_done=shown.finished, on_start=shown.started, runs=runs, calls=calls)
    ran = f" and {len(runs)} warm-up run{'s' if len(runs) > 1 else ''} ({', '.join(' '.join(r) for r in runs)})" \
        if runs else ""
    print(f"wbc compile: the numba kernels of {len(modules)} modules{ran} compiled and cached in "
          f"{time.perf_counter() - t0:.1f} s")
    return 0


def compile_for_command(command: str, quiet: bool = False) -> float | None:
    """A run command's first run: when some of the kernel modules its controllers need have no on-disk cache yet,
    run the loaders of :data:`COMMAND_MODULES` ``[command]`` now, in :func:`default_jobs` worker processes
    (:func:`compile_all`, the modules of :data:`AFTER` first), so that the controller built next loads its kernels
    from the cache. Prints on stderr (unless ``quiet``) a first line at once, then a progress bar redrawn every
    second on a terminal, or one line per module as each finishes otherwise (its wall and CPU seconds).

    Args:
        command: the ``wbc`` command (``"walk"``, ``"balance"``, ``"sim"``); another one compiles nothing here.
        quiet: no output (the modules are compiled all the same).

    Returns:
        The wall seconds the compilation took, or None when there was nothing to compile here (every module
        cached, or a command without controller).

    A worker process that dies (killed, or crashed in the compiler) is said in one line; the command goes on and
    compiles what is still missing in its own process, on first use.

    Raises:
        KeyboardInterrupt: Ctrl-C during the compilation (the worker processes are stopped).
    """
    from wbc.cli.output import DYNAMICS_KERNELS, KINEMATIC_KERNELS, uncompiled_kernels
    from wbc.exceptions import SimulationError

    modules = COMMAND_MODULES.get(command)
    sources = KINEMATIC_KERNELS + (DYNAMICS_KERNELS if command == "sim" else ())
    if modules is None or not uncompiled_kernels(sources):
        return None
    jobs = min(default_jobs(), len(modules))
    t0 = time.perf_counter()
    with _Progress(f"wbc {command}", _item_count(modules),
                   f"wbc {command}: first run: compiling the numba kernels of {len(modules)} modules in {jobs} "
                   "processes (once; cached on disk for later runs) ...", show=not quiet) as shown:
        try:
            compile_all(modules, jobs=jobs, on_done=shown.finished, on_start=shown.started)
        except SimulationError as exc:  # a worker died: this process compiles what is still missing, as it needs it
            print(f"wbc {command}: {exc}", file=sys.stderr, flush=True)
    return time.perf_counter() - t0


class _Progress:
    """What a compilation shows on stderr: a first line at once, then a progress bar naming the items being
    compiled, redrawn every second (on a terminal), or one line per item as it finishes (otherwise)."""

    def __init__(self, desc: str, total: int, first_line: str, show: bool = True):
        import threading

        self.desc, self.busy, self.show = desc, [], show
        self.bar = self.beat = None
        if show:
            print(first_line, file=sys.stderr, flush=True)
        if show and getattr(sys.stderr, "isatty", lambda: False)():
            from tqdm import tqdm

            self.bar = tqdm(total=total, desc=desc, unit="item", file=sys.stderr,
                            bar_format="{desc}: {n_fmt}/{total_fmt} |{bar}| {elapsed}{postfix}")  # postfix: the items
            self.bar.refresh()
            self.beat = threading.Event()

            def redraw() -> None:  # the elapsed time moves while a module compiles
                while not self.beat.wait(1.0):
                    self.bar.refresh()

            threading.Thread(target=redraw, daemon=True, name="wbc-compile-heartbeat").start()

    def __enter__(self) -> "_Progress":
        return self

    def __exit__(self, *exc) -> None:
        if self.bar is not None:
            self.beat.set()
            self.bar.set_postfix_str("")
            self.bar.close()

    def started(self, name: str) -> None:
        self.busy.append(name)
        if self.bar is not None:
            self.bar.set_postfix_str(", ".join(self.busy))

    def finished(self, name: str, wall: float, cpu: float) -> None:
        from wbc.cli.output import sigint_received

        self.busy.remove(name)
        if sigint_received():  # a Ctrl-C swallowed inside numba's compiler (a C callback): stop here
            raise KeyboardInterrupt
        if self.bar is not None:
            self.bar.set_postfix_str(", ".join(self.busy))
            self.bar.update()
        elif self.show:
            print(f"{self.desc}: {name} ({wall:.1f} s, {cpu:.1f} s CPU)", file=sys.stderr, flush=True)
