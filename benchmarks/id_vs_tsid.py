#!/usr/bin/env python
"""wbc's inverse-dynamics tick beside TSID 1.10 on Talos: the same tasks, the same states, timed alternately.

``python benchmarks/id_vs_tsid.py [--ticks 400] [--repeats 5] [--json out.json]``

TSID cannot be installed beside placo (``benchmarks/tsid_venv.sh`` says why), so it runs in its own virtual
environment, in a child process of this one (this file with ``--tsid-child``; it imports only numpy, pinocchio
and tsid). The scenario is ``wbc bench``'s ID tick (:mod:`wbc.bench.dynamics`, :class:`DynamicsSpec` defaults):
Talos in ``half_sitting`` on both soles, μ = 0.3, the CoM sways 3 cm at 0.5 Hz (PD 100 / 20 + feed-forward, weight
1000), torso orientation (PD 100 / 20, weight 10), posture of every actuated joint (PD 50 / 14, weight 1), torque
limits (URDF efforts) and joint velocity limits.

1. wbc's ``IDBalanceController`` runs the scenario closed on itself (v += v̇ dt, q ⊕= v dt) for warm-up + ticks;
   its states (q_k, v_k) are recorded.
2. Both libraries then solve the tick at every recorded state (set the CoM reference of tick k + solve at
   (q_k, v_k)): wbc here, TSID (``computeProblemData`` + ``SolverHQuadProgFast.solve`` + reading v̇, τ, forces)
   in the child; blocks alternate A B A B over ``--repeats`` rounds, each block's per-tick wall and CPU times
   (``perf_counter_ns``, ``thread_time_ns``) in its own process. Reported: median over rounds of the block medians,
   and the ratio wbc / TSID per round, then its median. The load average is printed at start and end.
3. Each library's command is checked against the rigid-body dynamics with Pinocchio in its own process, outside
   the library: ‖M(q) v̇ + h(q, v) − Sᵀτ − Σ_c J_c(q)ᵀ w_c‖_∞, w_c each sole's wrench at its origin (wbc: its
   ``wrenches``, world axes, J in LOCAL_WORLD_ALIGNED; TSID: its 12 corner forces mapped by the corner positions
   of the contact, sole axes, J in LOCAL). Both must be ≤ 1e-6. And how well each command tracks the CoM task:
   max ‖c̈(q, v, v̇) − c̈_des‖ over the states (Pinocchio's CoM acceleration against the PD + feed-forward).

What maps and what does not: wbc's sole contacts are 4 corner forces in an inscribed friction pyramid with a
contact damping (kd 20); TSID's ``Contact6d`` is the same 4 corners (same rectangle) in TSID's linearised cone,
with Kp 0, Kd 20 on the contact acceleration and a 1e-5 force regularisation. wbc also has a centroidal
angular-momentum task (weight 0.1) and joint position limits, which TSID's tick here does not. wbc's speed
limits use its horizon; TSID's ``TaskJointBounds`` bounds v + v̇ dt by the URDF velocity limits. The solvers are
wbc's default (``fast``: its compiled active-set kernel) and TSID's ``SolverHQuadProgFast`` (eiquadprog).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
DYNAMICS_TOL = 1e-6


def _residual(pin, model, data, q, v, dv, tau, terms) -> float:
    """‖M v̇ + h − Sᵀτ − Σ J_cᵀ w_c‖_∞; ``terms``: (frame id, reference frame, wrench) per contact."""
    M = pin.crba(model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    h = pin.rnea(model, data, q, v, np.zeros(model.nv))
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    rhs = np.concatenate([np.zeros(6), tau])
    for fid, ref, w in terms:
        rhs = rhs + pin.getFrameJacobian(model, data, fid, ref).T @ w
    return float(np.max(np.abs(M @ dv + h - rhs)))


def _com_tracking(pin, model, data, q, v, dv, ref, kp: float, kd: float) -> float:
    """‖c̈(q, v, v̇) − c̈_des‖ (m/s²): the command's CoM acceleration (Pinocchio) against the CoM task's PD +
    feed-forward, ``ref`` = (position, velocity, acceleration) references."""
    pin.centerOfMass(model, data, q, v, dv)
    want = ref[2] + kp * (ref[0] - data.com[0]) + kd * (ref[1] - data.vcom[0])
    return float(np.linalg.norm(data.acom[0] - want))


def _timed_block(tick, n: int) -> tuple[float, float]:
    wall = np.empty(n, dtype=np.int64)
    cpu = np.empty(n, dtype=np.int64)
    for k in range(n):
        t0, c0 = time.perf_counter_ns(), time.thread_time_ns()
        tick(k)
        wall[k], cpu[k] = time.perf_counter_ns() - t0, time.thread_time_ns() - c0
    return float(np.median(wall)) / 1e3, float(np.median(cpu)) / 1e3


# ---------------------------------------------------------------------------------------------------- TSID child
def tsid_child(npz_path: str) -> None:
    """The TSID side (run by the venv's python): builds the formulation from the parent's npz, prints READY, then
    for each ``run`` line times one block and prints a JSON line; ``check`` prints the dynamics residual."""
    import pinocchio as pin
    import tsid

    d = np.load(npz_path, allow_pickle=False)
    urdf, dirs = str(d["urdf"]), [str(p) for p in d["package_dirs"]]
    robot = tsid.RobotWrapper(urdf, dirs, pin.JointModelFreeFlyer(), False)
    model = robot.model()
    names = [str(n) for n in d["joint_names"]]
    if list(model.names) != names:
        raise SystemExit(f"TSID's model has other joints than wbc's: {list(model.names)[:5]}…")
    qs, vs = d["qs"], d["vs"]
    com_p, com_v, com_a = d["com_pos"], d["com_vel"], d["com_acc"]
    dt, mu = float(d["dt"]), float(d["mu"])
    g = {k: float(x) for k, x in zip([str(s) for s in d["gain_names"]], d["gain_values"])}
    a, b = 0.5 * float(d["sole_length"]), 0.5 * float(d["sole_width"])
    corners = np.array([[a, -a, -a, a], [b, b, -b, -b], [0.0, 0.0, 0.0, 0.0]])  # wbc's corner order, sole frame

    form = tsid.InverseDynamicsFormulationAccForce("tsid", robot, False)
    form.computeProblemData(0.0, qs[0], vs[0])
    data = form.data()
    contacts = []
    for frame in (str(d["left_sole"]), str(d["right_sole"])):
        c = tsid.Contact6d("contact_" + frame, robot, frame, corners, np.array([0.0, 0.0, 1.0]), mu, 0.0, 1e4)
        c.setKp(np.zeros(6))
        c.setKd(g["contact_kd"] * np.ones(6))
        c.setReference(robot.framePosition(data, model.getFrameId(frame)))
        form.addRigidContact(c, 1e-5)
        contacts.append((c, model.getFrameId(frame)))
    com = tsid.TaskComEquality("com", robot)
    com.setKp(g["com_kp"] * np.ones(3))
    com.setKd(g["com_kd"] * np.ones(3))
    form.addMotionTask(com, g["com_weight"], 1, 0.0)
    torso = tsid.TaskSE3Equality("torso", robot, str(d["torso"]))
    torso.setKp(g["torso_kp"] * np.ones(6))
    torso.setKd(g["torso_kd"] * np.ones(6))
    torso.setMask(np.array([0.0, 0.0, 0.0, 1.0, 1.0, 1.0]))
    torso_ref = tsid.TrajectorySE3Constant("torso_ref", robot.framePosition(data, model.getFrameId(str(d["torso"]))))
    torso.setReference(torso_ref.computeNext())
    form.addMotionTask(torso, g["torso_weight"], 1, 0.0)
    posture = tsid.TaskJointPosture("posture", robot)
    posture.setKp(g["posture_kp"] * np.ones(model.nv - 6))
    posture.setKd(g["posture_kd"] * np.ones(model.nv - 6))
    posture_ref = tsid.TrajectoryEuclidianConstant("posture_ref", d["q_ref"][7:])
    posture.setReference(posture_ref.computeNext())
    form.addMotionTask(posture, g["posture_weight"], 1, 0.0)
    torque = tsid.TaskActuationBounds("torque", robot)
    torque.setBounds(-model.effortLimit[6:], model.effortLimit[6:])
    form.addActuationTask(torque, 1.0, 0, 0.0)
    speed = tsid.TaskJointBounds("speed", robot, dt)
    speed.setVelocityBounds(-model.velocityLimit[6:], model.velocityLimit[6:])
    form.addMotionTask(speed, 1.0, 0, 0.0)
    solver = tsid.SolverHQuadProgFast("eiquadprog")
    solver.resize(form.nVar, form.nEq, form.nIn)
    sample = tsid.TrajectorySample(3)
    out = {}

    def tick(k: int) -> None:
        sample.value(com_p[k])
        sample.derivative(com_v[k])
        sample.second_derivative(com_a[k])
        com.setReference(sample)
        hqp = form.computeProblemData(k * dt, qs[k], vs[k])
        sol = solver.solve(hqp)
        if sol.status != 0:
            raise SystemExit(f"TSID tick {k}: solver status {sol.status}")
        out["k"] = k
        out["dv"] = form.getAccelerations(sol)
        out["tau"] = form.getActuatorForces(sol)
        out["f"] = [form.getContactForce(c.name, sol) for c, _ in contacts]

    for k in range(len(qs)):  # the same state sequence once untimed (warm-up)
        tick(k)
    print("READY", flush=True)
    pdata = model.createData()
    for line in sys.stdin:
        if line.startswith("run"):
            wall, cpu = _timed_block(tick, len(qs))
            print(json.dumps({"wall_us": wall, "cpu_us": cpu}), flush=True)
        elif line.startswith("check"):
            worst, com_err = 0.0, 0.0
            for k in range(len(qs)):
                tick(k)
                terms = [(fid, pin.LOCAL, c.getForceGeneratorMatrix @ f) for (c, fid), f in zip(contacts, out["f"])]
                worst = max(worst, _residual(pin, model, pdata, qs[k], vs[k], out["dv"], out["tau"], terms))
                com_err = max(com_err, _com_tracking(pin, model, pdata, qs[k], vs[k], out["dv"],
                                                     (com_p[k], com_v[k], com_a[k]), g["com_kp"], g["com_kd"]))
            from importlib.metadata import version

            print(json.dumps({"residual": worst, "com_err": com_err, "tsid_version": version("tsid"),
                              "pin": pin.__version__}), flush=True)
        else:
            break


# ---------------------------------------------------------------------------------------------------------- parent
def _ask(child: subprocess.Popen, command: str) -> dict | None:
    """Send one command line to the TSID child; its JSON answer (None for ``quit``, which has none)."""
    child.stdin.write(command + "\n")
    child.stdin.flush()
    return None if command == "quit" else json.loads(child.stdout.readline())


def _stop(child: subprocess.Popen) -> None:
    try:
        child.wait(timeout=60)
    except subprocess.TimeoutExpired:
        child.kill()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ticks", type=int, default=400, help="states per timed block (after 30 warm-up ticks)")
    ap.add_argument("--repeats", type=int, default=5, help="rounds of (wbc block, TSID block)")
    ap.add_argument("--json", type=Path, default=None, help="write the figures here")
    args = ap.parse_args(argv)
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    import pinocchio as pin

    from wbc.bench.dynamics import DynamicsSpec
    from wbc.bench.stats import limit_blas_threads
    from wbc.dynamics.balance import DEFAULT_GAINS, IDBalanceController
    from wbc.robot import load_robot

    limit_blas_threads(1)
    print(f"id_vs_tsid: start {time.strftime('%Y-%m-%dT%H:%M:%S%z')}, load {open('/proc/loadavg').read().strip()}")
    venv_python = subprocess.run(["bash", str(HERE / "tsid_venv.sh")], capture_output=True, text=True, check=True)
    venv_python = venv_python.stdout.strip().splitlines()[-1]
    robot = load_robot("talos")
    model = robot.model
    spec = DynamicsSpec(ticks=args.ticks, warmup=30)
    s = spec
    gains = {"com_kp": s.com_kp, "com_kd": s.com_kd, "com_weight": s.com_weight, "torso_kp": s.torso_kp,
             "torso_kd": s.torso_kd, "torso_weight": s.torso_weight, "posture_kp": s.posture_kp,
             "posture_kd": s.posture_kd, "posture_weight": s.posture_weight}
    ctrl = IDBalanceController(robot, dt=s.dt, mu=s.mu, gains=gains)
    q, v = robot.q_ref.copy(), np.zeros(model.nv)
    ctrl.reset(q, v)
    data = model.createData()
    com0 = pin.centerOfMass(model, data, q).copy()
    pos, vel, acc = spec.com_references(com0)
    n_all = spec.warmup + spec.ticks
    qs, vs = np.empty((n_all, model.nq)), np.empty((n_all, model.nv))
    for k in range(n_all):  # 1. wbc closed on itself: the states both libraries solve at
        qs[k], vs[k] = q, v
        ctrl.set_com_reference(pos[k], vel[k], acc[k])
        cmd = ctrl.solve(q, v)
        if not cmd.ok:
            raise SystemExit(f"wbc tick {k} failed: {cmd.message}")
        v = v + cmd.dv * s.dt
        q = pin.integrate(model, q, v * s.dt)
    qs, vs = qs[spec.warmup:], vs[spec.warmup:]
    pos, vel, acc = pos[spec.warmup:], vel[spec.warmup:], acc[spec.warmup:]

    ctrl = IDBalanceController(robot, dt=s.dt, mu=s.mu, gains=gains)
    ctrl.reset(qs[0], vs[0])
    last = {}

    def wbc_tick(k: int) -> None:
        ctrl.set_com_reference(pos[k], vel[k], acc[k])
        last["cmd"] = ctrl.solve(qs[k], vs[k])

    with tempfile.TemporaryDirectory() as tmp:
        npz = Path(tmp) / "scenario.npz"
        all_gains = {**DEFAULT_GAINS, **gains}
        np.savez(npz, urdf=str(robot.urdf_path), package_dirs=np.array(robot.package_dirs),
                 joint_names=np.array(list(model.names)), qs=qs, vs=vs, com_pos=pos, com_vel=vel, com_acc=acc,
                 dt=s.dt, mu=s.mu, gain_names=np.array(list(all_gains)), gain_values=np.array(list(all_gains.values())),
                 sole_length=robot.sole_length, sole_width=robot.sole_width, left_sole=robot.left_sole,
                 right_sole=robot.right_sole, torso=robot.torso, q_ref=robot.q_ref)
        child = subprocess.Popen([venv_python, str(Path(__file__).resolve()), "--tsid-child", str(npz)],
                                 stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        try:
            line = child.stdout.readline().strip()
            if line != "READY":
                raise SystemExit(f"TSID child: {line!r}")
            for k in range(len(qs)):  # untimed pass over the same states (warm-up, as the child's)
                wbc_tick(k)
            rounds = []
            for r in range(args.repeats):  # 2. A B A B
                w_wall, w_cpu = _timed_block(wbc_tick, len(qs))
                t = _ask(child, "run")
                rounds.append({"wbc_wall_us": w_wall, "wbc_cpu_us": w_cpu, "tsid_wall_us": t["wall_us"],
                               "tsid_cpu_us": t["cpu_us"]})
                print(f"  round {r + 1}: wbc {w_wall:7.1f} µs (CPU {w_cpu:7.1f}), TSID {t['wall_us']:7.1f} µs "
                      f"(CPU {t['cpu_us']:7.1f}), wbc/TSID {w_wall / t['wall_us']:.3f} (CPU "
                      f"{w_cpu / t['cpu_us']:.3f})", flush=True)
            tsid_check = _ask(child, "check")
            _ask(child, "quit")
        finally:
            _stop(child)

    # 3. wbc's commands against the dynamics (Pinocchio, outside the controller)
    lwa = pin.LOCAL_WORLD_ALIGNED
    wbc_res, wbc_com = 0.0, 0.0
    for k in range(len(qs)):
        wbc_tick(k)
        cmd = last["cmd"]
        terms = [(model.getFrameId(f), lwa, cmd.wrenches[side])
                 for side, f in (("left", robot.left_sole), ("right", robot.right_sole))]
        wbc_res = max(wbc_res, _residual(pin, model, data, qs[k], vs[k], cmd.dv, cmd.tau, terms))
        wbc_com = max(wbc_com, _com_tracking(pin, model, data, qs[k], vs[k], cmd.dv, (pos[k], vel[k], acc[k]),
                                             s.com_kp, s.com_kd))

    def med(key):
        return float(np.median([r[key] for r in rounds]))

    ratio_wall = float(np.median([r["wbc_wall_us"] / r["tsid_wall_us"] for r in rounds]))
    ratio_cpu = float(np.median([r["wbc_cpu_us"] / r["tsid_cpu_us"] for r in rounds]))
    ok = wbc_res <= DYNAMICS_TOL and tsid_check["residual"] <= DYNAMICS_TOL
    print(f"TSID {tsid_check['tsid_version']} (pin {tsid_check['pin']}) in {venv_python}; wbc pin {pin.__version__}")
    print(f"ID tick, Talos, {len(qs)} states × {args.repeats} rounds: wbc median {med('wbc_wall_us'):.1f} µs "
          f"(CPU {med('wbc_cpu_us'):.1f}), TSID {med('tsid_wall_us'):.1f} µs (CPU {med('tsid_cpu_us'):.1f}); "
          f"wbc / TSID = {ratio_wall:.3f} wall, {ratio_cpu:.3f} CPU (median of per-round ratios)")
    print(f"dynamics residual ‖M v̇ + h − Sᵀτ − Jᵀw‖∞ (Pinocchio): wbc {wbc_res:.2e}, TSID {tsid_check['residual']:.2e}"
          f" (≤ {DYNAMICS_TOL:g}: {'yes' if ok else 'NO'})")
    print(f"CoM task: max ‖c̈ − c̈_des‖ over the states (Pinocchio): wbc {wbc_com:.2e}, TSID {tsid_check['com_err']:.2e}"
          " m/s² (the soft CoM task of weight 1000 against the others)")
    print(f"id_vs_tsid: end {time.strftime('%Y-%m-%dT%H:%M:%S%z')}, load {open('/proc/loadavg').read().strip()}")
    if args.json:
        args.json.write_text(json.dumps({"rounds": rounds, "ratio_wall": ratio_wall, "ratio_cpu": ratio_cpu,
                                         "wbc_residual": wbc_res, "wbc_com_err": wbc_com,
                                         "tsid": tsid_check}, indent=1))
    return 0 if ok else 1


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--tsid-child":
        tsid_child(sys.argv[2])
    else:
        sys.exit(main())
