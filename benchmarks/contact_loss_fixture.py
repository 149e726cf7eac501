"""Cut a short contact-loss fixture out of a ``wbc sim ... --log`` file, for tests/estimation/test_contact_events.py.

From the log's plant state (``q``, MuJoCo's ground truth) the soles' placements (Pinocchio forward kinematics), from
``sim_wrench`` MuJoCo's ground reaction on each foot at its sole origin (world axes → sole axes), with the
controller's contact state (``contact_active``) and the QP's normal force on each sole (``qp_forces``), over the
ticks ``--from`` .. ``--to`` (s). Writes an ``.npz`` (float32 where the values allow it).

Usage: python benchmarks/contact_loss_fixture.py LOG.npz OUT.npz --from T0 --to T1 [--robot NAME]
"""

from __future__ import annotations

import argparse

import numpy as np
import pinocchio as pin

import wbc


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("log")
    ap.add_argument("out")
    ap.add_argument("--from", dest="t0", type=float, required=True)
    ap.add_argument("--to", dest="t1", type=float, required=True)
    ap.add_argument("--robot", default=None, help="default: the log's robot")
    args = ap.parse_args()
    log = np.load(args.log, allow_pickle=False)
    robot = wbc.load_robot(args.robot or str(log["robot"]))
    t = log["t"]
    i0, i1 = np.searchsorted(t, args.t0), np.searchsorted(t, args.t1)
    model, data = robot.model, robot.model.createData()
    fids = [robot.frame_id(robot.left_sole), robot.frame_id(robot.right_sole)]
    n = i1 - i0
    R, p, wrench = np.empty((n, 2, 3, 3)), np.empty((n, 2, 3)), np.empty((n, 2, 6))
    for k in range(n):
        pin.framesForwardKinematics(model, data, log["q"][i0 + k])
        for j, fid in enumerate(fids):
            M = data.oMf[fid]
            R[k, j], p[k, j] = M.rotation, M.translation
            w = log["sim_wrench"][i0 + k, j]
            wrench[k, j] = np.r_[M.rotation.T @ w[:3], M.rotation.T @ w[3:]]
    qpf = log["qp_forces"][i0:i1]
    qp_normal = np.stack([qpf[:, 2:12:3].sum(axis=1), qpf[:, 14:24:3].sum(axis=1)], axis=1)
    np.savez_compressed(args.out, t=t[i0:i1], rotation=R, position=p, wrench=wrench,
                        contact_active=log["contact_active"][i0:i1], qp_normal_force=qp_normal,
                        sole_length=robot.sole_length, sole_width=robot.sole_width,
                        weight=robot.mass * robot.gravity, dt=float(log["dt"]), robot=robot.name)
    print(f"{args.out}: {n} ticks, t = {t[i0]:.3f} .. {t[i1 - 1]:.3f} s")


if __name__ == "__main__":
    main()
