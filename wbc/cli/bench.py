"""``wbc bench``: run the benchmark suite (:mod:`wbc.bench.suite`) and write its report (:mod:`wbc.bench.report`).

Exit code 0 when every acceptance criterion of the report is met, 1 when a measured one is missed (each missed one
is printed as "target missed: <criterion>: measured …, goal …"; the report is written in both cases). A criterion
that could not be measured (e.g. the instruction count without valgrind) is reported "not measured" and does not
set the exit code. The ``instructions`` section (callgrind, minutes) is left out of ``--quick`` unless named in
``--sections``. With ``--quick`` the run is a pipeline check: wall-clock criteria are reported but do not set the exit
code (a few ticks on a loaded machine say nothing about speed); every correctness criterion (same-work check, plan
ZMP margin) still must hold.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

__all__ = ["register", "cmd_bench", "require_bench_extra"]

SECTIONS = ("kinematic", "breakdown", "solvers", "scaling", "dynamics", "gait", "walk", "frame_tasks",
            "instructions")


def register(subparsers, add_outputs=None) -> None:
    """Add the ``bench`` sub-command (``add_outputs`` is not used: the outputs go to ``--out-dir``)."""
    p = subparsers.add_parser("bench", help="benchmark wbc against placo and Pink (tick latency, solvers, gait)")
    p.add_argument("--ticks", type=int, default=2000, help="timed ticks per run (default 2000)")
    p.add_argument("--repeats", type=int, default=5, help="interleaved repeats per library (default 5)")
    p.add_argument("--warmup", type=int, default=100, help="untimed ticks before each run (default 100)")
    p.add_argument("--robot", default="talos", help="robot of the comparisons (default talos)")
    p.add_argument("--out-dir", type=Path, default=Path("benchmarks/results"),
                   help="folder for results.json, results.md, latency.png (default benchmarks/results)")
    p.add_argument("--sections", nargs="+", choices=SECTIONS, default=None, metavar="SECTION",
                   help=f"subset to run (default all: {' '.join(SECTIONS)}; with --quick all but instructions)")
    p.add_argument("--quick", action="store_true", help="a few ticks and repeats: checks the pipeline in seconds")
    p.add_argument("--blas-threads", type=int, default=1,
                   help="OpenBLAS threads during the run (default 1; 0 keeps the library default)")
    p.set_defaults(func=cmd_bench)


def require_bench_extra() -> None:
    """Check that the libraries ``wbc bench`` measures wbc against are installed (the ``bench`` extra).

    Raises:
        InvalidInputError: placo or pin-pink is missing; names it and the extra that provides it.
    """
    import importlib.util

    from wbc.exceptions import InvalidInputError

    missing = [dist for module, dist in (("placo", "placo"), ("pink", "pin-pink"))
               if importlib.util.find_spec(module) is None]
    if missing:
        raise InvalidInputError(f"needs {' and '.join(missing)} (the libraries it compares wbc with): "
                                "pip install 'wbc[bench]'")


def cmd_bench(args: argparse.Namespace) -> int:
    require_bench_extra()
    from wbc.bench.report import acceptance, write_report
    from wbc.bench.stats import limit_blas_threads
    from wbc.bench.suite import SuiteConfig, run_suite

    blas = limit_blas_threads(args.blas_threads) if args.blas_threads > 0 else {}
    if args.sections is None:  # callgrind runs take minutes: not part of the quick pipeline check unless asked
        args.sections = [s for s in SECTIONS if not (args.quick and s == "instructions")]
    if args.quick:
        cfg = SuiteConfig.quick()
        cfg = SuiteConfig(**{**cfg.__dict__, "robot": args.robot, "sections": tuple(args.sections)})
    else:
        cfg = SuiteConfig(robot=args.robot, ticks=args.ticks, repeats=args.repeats, warmup=args.warmup,
                          sections=tuple(args.sections))
    t0 = time.perf_counter()
    results = run_suite(cfg)
    results["machine"]["blas_threads"] = blas or "library default"
    paths = write_report(results, args.out_dir)
    print(paths["markdown"].read_text())
    for kind, path in paths.items():
        print(f"{kind}: {path}")
    print(f"wbc bench: {time.perf_counter() - t0:.1f} s")
    rows = acceptance(results)
    if args.quick:
        # A pipeline check: a few ticks say nothing about speed, so only the non-timing criteria decide.
        rows = [a for a in rows if not a.get("timing")]
        print("wbc bench --quick: pipeline check; timing criteria not judged on a few ticks")
    missed = [a for a in rows if a["met"] is False]
    for a in missed:
        value = f"{a['value']:.3g}" if isinstance(a["value"], float) else a["value"]
        print(f"wbc bench: target missed: {a['criterion']}: measured {value}, goal {a['goal']}")
    if not rows:
        print("wbc bench: no criterion could be evaluated")
    return 0 if rows and not missed else 1
