#!/usr/bin/env python
"""Regenerate every benchmark table and plot in one process: ``python benchmarks/run_all.py``.

Same as ``wbc bench`` (all sections, 2000 ticks × 5 interleaved repeats), with the outputs in
``benchmarks/results/`` next to this file: results.json, results.md, latency.png, latencies.npz.
Extra arguments are passed to ``wbc bench`` (e.g. ``--repeats 7``, ``--quick``). Exit code: that of ``wbc bench``
(0 = every acceptance criterion met, 1 = not).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

# BLAS threads are also limited at run time by `wbc bench --blas-threads 1`; the environment variables cover
# libraries that read them only when loaded.
for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")

from wbc.cli import main  # noqa: E402

if __name__ == "__main__":
    out_dir = Path(__file__).resolve().parent / "results"
    argv = ["bench", "--out-dir", str(out_dir), *sys.argv[1:]]
    sys.exit(main(argv))
