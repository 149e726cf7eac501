"""Plots from a log: run a balance behaviour, save its per-tick log (npz), load it back and plot it, then read
a few numbers from the arrays yourself.

Run: python examples/plots_from_log.py [--behaviour squat] [--out-dir DIR] [--quick]
"""

import argparse
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")                                    # files only, no window

import numpy as np  # noqa: E402

import wbc  # noqa: E402
from wbc.scenarios.balance import run_balance  # noqa: E402
from wbc.viz.plots import load_log, plot_log  # noqa: E402

parser = argparse.ArgumentParser(description=" ".join(__doc__.split("\n\n")[0].split()))  # the first paragraph
parser.add_argument("--robot", default="talos", help="catalog robot (default talos)")
parser.add_argument("--behaviour", default="squat", help="shift, one-leg, wave, squat or reach (default squat)")
parser.add_argument("--out-dir", type=Path, default=Path(tempfile.gettempdir()), help="where the npz and PNG go")
parser.add_argument("--quick", action="store_true", help="humanoid15, a CoM shift (CI)")
args = parser.parse_args()

robot = wbc.load_robot("humanoid15" if args.quick else args.robot)
behaviour = "shift" if args.quick else args.behaviour
run = run_balance(robot, behaviour)
log_path = args.out_dir / f"wbc_{behaviour}.npz"
run.save(log_path)                                       # what `wbc balance ... --log` writes

log = load_log(log_path)                                 # dict of arrays: t, q, v, com, com_ref, soles, ...
png = args.out_dir / f"wbc_{behaviour}.png"
plot_log(log, png)                                       # the figure of `wbc plot LOG.npz --out PNG`
print(f"log {log_path} ({', '.join(sorted(log)[:8])}, ...), figure {png}")

com, com_ref, t = log["com"], log["com_ref"], log["t"]
err = np.linalg.norm(com - com_ref, axis=1)
print(f"CoM moved {np.ptp(com[:, 0]) * 1e3:.1f} mm in x, {np.ptp(com[:, 1]) * 1e3:.1f} mm in y, "
      f"{np.ptp(com[:, 2]) * 1e3:.1f} mm in z over {t[-1]:.2f} s; "
      f"largest tracking error {err.max() * 1e3:.2f} mm at t = {t[err.argmax()]:.2f} s")
raise SystemExit(0 if png.stat().st_size > 10_000 else 1)
