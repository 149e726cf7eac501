"""Signals of one mirror pair of ``push_mirror_pairs.py`` side by side (record 40): ``python
benchmarks/mirror_pair_signals.py A.npz B.npz --push-time T [--robot talos]``. A swung the left foot first and was
pushed towards d, B is its mirror image (right first, -d). Prints, before the push and in windows after it, the
largest mirror deviation of the DCM (|M dcm_A - dcm_B|, M = diag(1, -1)), of the vertical ground force under each
foot (A's left against B's right and vice versa, from MuJoCo's ankle wrench), of the measured CoP margin, and the
joint whose mirrored speed differs most (A's joint against B's mirror joint, with the sign of the mirrored angle;
grippers left out).
"""

from __future__ import annotations

import argparse

import numpy as np

import wbc

M = np.diag([1.0, -1.0, 1.0])
AXES = {"JointModelRX": (1.0, 0.0, 0.0), "JointModelRY": (0.0, 1.0, 0.0), "JointModelRZ": (0.0, 0.0, 1.0)}


def joint_mirror(model):
    """(names, index in v of each actuated joint, index in v of its mirror joint, sign of the mirrored angle)."""
    names, iv, ivm, sign = [], [], [], []
    for j in range(2, model.njoints):
        n = model.names[j]
        if n.startswith("gripper"):  # the right gripper's joint frame is not the left one's mirror image
            continue
        other = n.replace("left", "@").replace("right", "left").replace("@", "right")
        jm = model.getJointId(other)
        a, b = (np.array(AXES[model.joints[k].shortname()]) for k in (j, jm))
        names.append(n)
        iv.append(model.joints[j].idx_v)
        ivm.append(model.joints[jm].idx_v)
        sign.append(float(-M @ a @ b))
    return names, np.array(iv), np.array(ivm), np.array(sign)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--push-time", type=float, required=True)
    ap.add_argument("--robot", default="talos")
    args = ap.parse_args()
    za, zb = np.load(args.a), np.load(args.b)
    n = min(len(za["t"]), len(zb["t"]))
    t = za["t"][:n]
    names, iv, ivm, sign = joint_mirror(wbc.load_robot(args.robot).model)
    dcm = np.linalg.norm(za["dcm"][:n] * [1.0, -1.0] - zb["dcm"][:n], axis=1)
    fz_a, fz_b = za["sim_wrench"][:n, :, 2], zb["sim_wrench"][:n, :, 2]  # (left, right) vertical force
    dfz = np.abs(fz_a - fz_b[:, ::-1]).max(axis=1)
    cop = np.abs(za["measured_cop_margin"][:n] - zb["measured_cop_margin"][:n])
    va, vb = za["v"][:n, 6:], zb["v"][:n, 6:]
    dv = np.abs(sign * va[:, iv - 6] - vb[:, ivm - 6])
    tp = args.push_time
    windows = [("start, t < 0.1 s", t < 0.1), ("0.1 s to the push", (t >= 0.1) & (t < tp))] + [(f"push + [{a:.1f}, {b:.1f}) s", (t >= tp + a) & (t < tp + b))
                                               for a, b in ((0.0, 0.2), (0.2, 0.5), (0.5, 1.0), (1.0, 3.0))]
    print(f"A {args.a}: fell {bool(za['fell'])} {za['fall_reason']}; B {args.b}: fell {bool(zb['fell'])} "
          f"{zb['fall_reason']}; {n} common ticks")

    def mx(x, m):
        m = m & np.isfinite(x) if x.ndim == 1 else m
        return float(np.nanmax(x[m])) if m.any() else float("nan")

    for name, m in windows:
        if not m.any():
            continue
        k = int(np.nanargmax(np.where(m[:, None], dv, -1.0)) // dv.shape[1])
        j = int(np.argmax(dv[k]))
        print(f"  {name:22s} DCM {mx(dcm, m) * 1e3:7.2f} mm | foot Fz {mx(dfz, m):7.1f} N | CoP margin "
              f"{mx(cop, m) * 1e3:6.2f} mm | joint speed {dv[k, j]:6.3f} rad/s ({names[j]} at {t[k]:.3f} s: A "
              f"{sign[j] * va[k, iv[j] - 6]:+.3f}, B {vb[k, ivm[j] - 6]:+.3f})")


if __name__ == "__main__":
    main()
