"""Compare the npz logs of two runs (``wbc walk/balance/sim --log``) array by array.

    python benchmarks/compare_logs.py A.npz B.npz [--tol 1e-9]
    python benchmarks/compare_logs.py DIR_A DIR_B [--tol 1e-9]     # every *.npz present in both folders

Prints, per array, the largest absolute difference (numeric arrays of equal shape), ``shape`` when the shapes
differ, ``differs``/``equal`` for non-numeric arrays, and ``missing`` for an array in one log only. Arrays of
wall-clock times (``tick_time``, ``solve_time`` and any name ending in ``_time``) are measured, not computed: they
are reported but never count as a difference. Exit code 0 when every other array matches to ``--tol``, 1 otherwise.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np


def is_timing(name: str) -> bool:
    """Whether the array holds wall-clock measurements (they differ between any two runs)."""
    return name.endswith("_time") or name in ("tick_time", "solve_time", "wall_time")


def compare(a: Path, b: Path, tol: float) -> tuple[bool, list[str]]:
    """(match, report lines) for two npz files."""
    lines = []
    ok = True
    with np.load(a, allow_pickle=False) as za, np.load(b, allow_pickle=False) as zb:
        for key in sorted(set(za.files) | set(zb.files)):
            if key not in za.files or key not in zb.files:
                lines.append(f"  {key:24s} missing in {'A' if key not in za.files else 'B'}")
                ok = False
                continue
            x, y = za[key], zb[key]
            if x.shape != y.shape:
                verdict, bad = f"shape {x.shape} vs {y.shape}", True
            elif x.dtype.kind in "fiub" and y.dtype.kind in "fiub":
                xf, yf = x.astype(float), y.astype(float)
                same_nan = np.array_equal(np.isnan(xf), np.isnan(yf))
                d = float(np.max(np.abs(np.nan_to_num(xf) - np.nan_to_num(yf)), initial=0.0))
                verdict, bad = f"max |diff| {d:.3g}" + ("" if same_nan else " (NaN pattern differs)"), (
                    d > tol or not same_nan)
            else:
                bad = not np.array_equal(x, y)
                verdict = "differs" if bad else "equal"
            if is_timing(key):
                verdict += " (wall clock, ignored)"
                bad = False
            ok &= not bad
            lines.append(f"  {key:24s} {verdict}{'   <-- DIFFERENT' if bad else ''}")
    return ok, lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("a", type=Path)
    parser.add_argument("b", type=Path)
    parser.add_argument("--tol", type=float, default=1e-9, help="largest accepted absolute difference")
    parser.add_argument("--brief", action="store_true", help="print only the differing arrays")
    args = parser.parse_args(argv)
    if args.a.is_dir():
        names = sorted({p.name for p in args.a.glob("*.npz")} | {p.name for p in args.b.glob("*.npz")})
        pairs = [(args.a / n, args.b / n) for n in names]
    else:
        pairs = [(args.a, args.b)]
    all_ok = True
    for pa, pb in pairs:
        if not (pa.exists() and pb.exists()):
            print(f"{pa.name}: missing in {'A' if not pa.exists() else 'B'}")
            all_ok = False
            continue
        ok, lines = compare(pa, pb, args.tol)
        all_ok &= ok
        print(f"{pa.name}: {'match' if ok else 'DIFFER'} (tol {args.tol:g})")
        for line in lines:
            if not args.brief or "DIFFERENT" in line or "missing" in line:
                print(line)
    print("all logs match" if all_ok else "some logs differ")
    return 0 if all_ok else 1


if __name__ == "__main__":
    sys.exit(main())
