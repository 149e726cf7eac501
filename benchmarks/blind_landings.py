"""Per touch-down figures of a blind rough-terrain walk, from its log (``wbc sim walk ... --blind --log FILE``).

For each touch-down (the scenario's support phase going from swing to loading) the plant's ground truth (logged
``q``, Pinocchio) gives: the sole's height above the highest terrain point under its rectangle (mm, negative:
pressed in), its roll and pitch from level at touch-down and 0.1 s later (deg: how far the landing sole turned to
rest on the terrain), the horizontal travel of the sole origin over the 0.2 s after touch-down (mm), the same tilt
in the controller's estimate 0.1 s after (deg), the measured DCM error (mm) and the largest joint speed ratio
(|q̇| / URDF limit) in the 0.3 s around it, with its joint. Then the joint speed exceedances of the run by joint and
by phase of the leg that carries the joint (swing, stance, loading, unloading).

    python benchmarks/blind_landings.py LOG.npz --terrain rough:0.02:SEED [--robot talos] [--until T]
"""

from __future__ import annotations

import argparse
import math
from collections import Counter

import numpy as np
import pinocchio as pin

from wbc.robot import load_robot
from wbc.terrain import parse_terrain

PHASES = ("stance", "unloading", "swing", "loading")


def _tilt(R: np.ndarray) -> tuple[float, float]:
    """(roll, pitch) deg of a rotation whose yaw is small."""
    rpy = pin.rpy.matrixToRpy(R)
    return math.degrees(rpy[0]), math.degrees(rpy[1])


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("log")
    p.add_argument("--terrain", required=True)
    p.add_argument("--robot", default="talos")
    p.add_argument("--until", type=float, default=None)
    args = p.parse_args()
    log = np.load(args.log, allow_pickle=True)
    terrain = parse_terrain(args.terrain)
    robot = load_robot(args.robot)
    model = robot.model
    data = model.createData()
    dt = float(log["dt"])
    t = log["t"]
    n = len(t) if args.until is None else min(len(t), int(round(args.until / dt)) + 1)
    q, qe = log["q"][:n], log["q_est"][:n] if "q_est" in log else None
    v = log["v"][:n]
    ph = log["support_phase"][:n]
    fid = {s: robot.frame_id(getattr(robot, f"{s}_sole")) for s in ("left", "right")}
    vlim = np.asarray(model.velocityLimit[6:], dtype=float)
    names = list(model.names[2:])
    ok = np.isfinite(vlim) & (vlim > 0)
    ratio = np.zeros((n, len(vlim)))
    ratio[:, ok] = np.abs(v[:, 6:][:, ok]) / vlim[ok]
    dcm_err = np.linalg.norm(log["dcm"][:n] - log["dcm_ref"][:n], axis=1) if "dcm" in log else np.full(n, np.nan)
    L, W = robot.sole_length, robot.sole_width
    gx, gy = np.meshgrid(np.linspace(-L / 2, L / 2, 11), np.linspace(-W / 2, W / 2, 7))
    grid = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], axis=1)

    def sole(k, s, qq=q):
        pin.framesForwardKinematics(model, data, qq[min(k, n - 1)])
        return data.oMf[fid[s]].copy()

    print(f"{'t':>6} {'side':>5} {'gap':>6} {'roll0':>6} {'pit0':>6} {'roll1':>6} {'pit1':>6} {'est r1':>6} "
          f"{'est p1':>6} {'slide':>6} {'dcm':>5} {'speed':>5}  joint")
    rows = []
    for k in range(1, n):
        for j, s in enumerate(("left", "right")):
            if ph[k - 1, j] == 2 and ph[k, j] == 3:
                rows.append((k, j, s))
    rows.sort()
    for k, j, s in rows:
        M0 = sole(k, s)
        pts = (M0.rotation @ grid.T).T + M0.translation
        ground = max(terrain.height(float(x), float(y)) for x, y, _ in pts)
        low = float(pts[:, 2].min())
        k1 = k + int(round(0.1 / dt))
        k2 = k + int(round(0.2 / dt))
        M1, M2 = sole(k1, s), sole(k2, s)
        r0, p0 = _tilt(M0.rotation)
        r1, p1 = _tilt(M1.rotation)
        re1, pe1 = _tilt(sole(k1, s, qe).rotation) if qe is not None else (math.nan, math.nan)
        slide = 1e3 * float(np.linalg.norm(M2.translation[:2] - M0.translation[:2]))
        a, b = max(0, k - int(round(0.1 / dt))), min(n, k + int(round(0.2 / dt)))
        jj = int(np.argmax(ratio[a:b].max(axis=0)))
        print(f"{t[k]:6.3f} {s:>5} {1e3 * (low - ground):6.1f} {r0:6.1f} {p0:6.1f} {r1:6.1f} {p1:6.1f} {re1:6.1f} "
              f"{pe1:6.1f} {slide:6.1f} {1e3 * dcm_err[k]:5.0f} {ratio[a:b, jj].max():5.2f}  {names[jj]}")
    over = ratio > 1.0
    print(f"joint speed exceedances (ticks x joints): {int(over.sum())}")
    by_joint = Counter()
    by_phase = Counter()
    for k, i in zip(*np.nonzero(over)):
        nm = names[i]
        by_joint[nm] += 1
        side = 0 if "left" in nm else 1 if "right" in nm else None
        by_phase[PHASES[ph[k, side]] if side is not None else "-"] += 1
    print("by joint:", dict(by_joint.most_common()))
    print("by phase of that joint's leg:", dict(by_phase))
    if over.any():
        ks = np.nonzero(over.any(axis=1))[0]
        print(f"first at {t[ks[0]]:.3f} s, last at {t[ks[-1]]:.3f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
