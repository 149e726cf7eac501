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

from wbc.cli.validate import count

__all__ = ["register", "cmd_bench", "require_bench_extra"]

SECTIONS = ("kinematic", "breakdown", "solvers", "scaling", "dynamics", "gait", "walk", "frame_tasks",
            "instructions")


def register(subparsers, add_outputs=None) -> None:
    """Add the ``bench`` sub-command (``add_outputs`` is not used: the outputs go to ``--out-dir``)."""
    p = subparsers.add_parser("bench", help="benchmark wbc against placo and Pink (tick latency, solvers, gait)")
    p.add_argument("--ticks", type=count(1, 1_000_000), default=2000, help="timed ticks per run (default 2000; 1..10^6)")
    p.add_argument("--repeats", type=count(1, 1000), default=5,
                   help="interleaved repeats per library (default 5; 1..1000)")
    p.add_argument("--warmup", type=count(0, 1_000_000), default=100,
                   help="untimed ticks before each run (default 100; 0..10^6)")
    p.add_argument("--robot", default="talos",
                   help="robot of the comparisons: catalog name or robot file (.toml) (default talos)")
    p.add_argument("--out-dir", type=Path, default=Path("benchmarks/results"),
                   help="folder for results.json, results.md, latency.png (default benchmarks/results)")
    p.add_argument("--sections", nargs="+", choices=SECTIONS, default=None, metavar="SECTION",
                   help=f"subset to run (default all: {' '.join(SECTIONS)}; with --quick all but instructions)")
    p.add_argument("--quick", action="store_true", help="a few ticks and repeats: checks the pipeline in seconds")
    p.add_argument("--blas-threads", type=count(0, 256), default=1,
                   help="OpenBLAS threads during the run (default 1; 0 keeps the library default)")
    p.set_defaults(func=cmd_bench, check=check_bench_args)


def _write_atomically(results: dict, out_dir: Path, write_report) -> dict:
    """Write the report into a hidden temporary folder inside ``out_dir``, then move each file over its final name
    (``os.replace``, atomic): an interrupted or concurrent run never leaves a half-written results file."""
    import os
    import shutil
    import tempfile

    out_dir.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=".partial-", dir=out_dir))
    try:
        written = write_report(results, tmp)
        final = {}
        for kind, path in written.items():
            final[kind] = out_dir / Path(path).name
            os.replace(path, final[kind])
        return final
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def check_bench_args(args) -> None:
    """``wbc bench`` checks before any run: ``--out-dir`` is a folder that exists or can be created in a writable
    folder (not a file, not in /proc).

    Raises:
        InvalidInputError: naming ``--out-dir``.
    """
    import os

    from wbc.exceptions import InvalidInputError

    out = Path(args.out_dir)
    if out.exists() and not out.is_dir():
        raise InvalidInputError(f"--out-dir {out}: is a file (valid: a folder, created if missing)")
    parent = out.absolute()
    while not parent.exists():  # created with its parents: the nearest existing folder must be writable
        parent = parent.parent
    if not parent.is_dir():
        raise InvalidInputError(f"--out-dir {out}: {str(parent)!r} is a file (valid: a folder)")
    real = parent.resolve()
    if any(real == Path(r) or Path(r) in real.parents for r in ("/proc", "/sys", "/dev")) or not os.access(
            real, os.W_OK | os.X_OK):
        raise InvalidInputError(f"--out-dir {out}: {str(parent)!r} is not a writable folder on disk")


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
                                "pip install -e \".[bench]\" (from the wbc clone)")


def cmd_bench(args: argparse.Namespace) -> int:
    require_bench_extra()
    from wbc.bench.report import benchmark_goals, write_report
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
    paths = _write_atomically(results, Path(args.out_dir), write_report)
    print(paths["markdown"].read_text())
    for kind, path in paths.items():
        print(f"{kind}: {path}")
    print(f"wbc bench: {time.perf_counter() - t0:.1f} s")
    rows = benchmark_goals(results)
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
