"""The kinematic tick's counted work (``KinematicController`` budget, :class:`wbc.solvers.base.TickWork`) on ticks of
the kinematic fuzz that ran past twice their budget of CPU time (``benchmarks/fuzz.py --dts 0.002,0.005,0.01,0.02
--past-limits 0.2``, 10^6 ticks from seed 550000 on 784bc14): the count of each tick stays within a bound written
here, the answers are the same on a second run (a count, no clock), and every command is safe by references
computed here (Pinocchio forward kinematics on its own Data, the model's velocity limits)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from conftest import fuzz_episode

DTS = (0.002, 0.005, 0.01, 0.02)
SOLE_DRIFT = 5e-5  # m: the fuzz's bound on an ok tick's stance-sole drift (issue 8)


def _sole_drift_fk(ctrl, config, v, dt) -> float:
    """Largest distance (m) between where a stance sole ends after one tick with v (Pinocchio, own Data) and where its
    contact row sends it: placement · exp((1 − K dt) e), e the sole's error before the tick."""
    model = ctrl.robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, config.q)
    before = [data.oMf[c.frame_id].copy() for c in ctrl.constraints[:2]]
    pin.framesForwardKinematics(model, data, pin.integrate(model, config.q, v * dt))
    worst = 0.0
    for c, oMf in zip(ctrl.constraints[:2], before):
        e = pin.log6(c.placement.actInv(oMf)).vector
        sent = c.placement * pin.exp6(e * (1.0 - min(c.gain, 1.0 / dt) * dt))
        worst = max(worst, float(np.linalg.norm(data.oMf[c.frame_id].translation - sent.translation)))
    return worst


def _replay(robots, seed, episode, ticks):
    """(name, dt, [(counted solves, cap, path, ok, v, drift by FK or None)]) of the episode's first ``ticks`` ticks."""
    name, _, _, dt, config, ctrl = fuzz_episode(robots, seed, episode, dts=DTS, past_limits=0.2)
    vmax = ctrl.robot.model.velocityLimit[6:]
    out = []
    for _ in range(ticks):
        res = ctrl.solve(config, dt)
        assert np.isfinite(res.v).all()
        assert np.all(np.abs(res.v[6:]) <= vmax + 1e-9)  # within the model's velocity limits
        drift = _sole_drift_fk(ctrl, config, res.v, dt) if res.ok else None
        out.append((ctrl._work.solves, ctrl._work.cap, str(res.path), res.ok, res.v.copy(), drift))
        config.update(config.integrate(res.v, dt))
    return name, dt, out


def test_a_held_contact_run_of_failed_ticks_now_solves_within_its_count(robots):
    """Seed 550014 episode 4 (humanoid15, strict levels, joints past their limits, dt = 2 ms: 8 counted solves):
    ticks 1–12 were 'fallback:contacts_held' after 17 counted solves each (the strict cascade's retries and the
    return-rate ladder started with the count nearly spent; 2.1–3.4 × the budget of CPU time in the 10^6-tick run).
    Now a stage starts only when its re-solve fits: each of the 13 ticks counts at most 1.75 × 8 = 14 solves, its
    command is finite and within the velocity limits, every ok tick keeps both soles within 0.05 mm of where their
    rows send them (forward kinematics), most of them are ok, and a second run gives the same counts, paths and
    bitwise the same commands."""
    name, dt, out = _replay(robots, 550014, 4, 13)
    assert (name, dt) == ("humanoid15", 0.002)
    assert all(cap == 8 for _, cap, *_ in out)
    assert max(s for s, *_ in out) <= 14, [s for s, *_ in out]
    for _, _, path, ok, _, drift in out:
        assert not ok or drift <= SOLE_DRIFT, (path, drift)
    assert sum(ok for *_, ok, _, _ in out) >= 10, [p for _, _, p, *_ in out]
    _, _, again = _replay(robots, 550014, 4, 13)
    assert [(s, p, ok) for s, _, p, ok, _, _ in again] == [(s, p, ok) for s, _, p, ok, _, _ in out]
    assert [r[4].tobytes() for r in again] == [r[4].tobytes() for r in out]


def test_a_new_layout_counts_its_build(robots):
    """The first tick of a controller builds its row layout and solver workspaces (in the fuzz, ~0.9 ms of CPU time
    beyond its counted solves): it counts 4 solves more than the same tick solved again by the same controller at the
    same state (whose layout is kept); the commands agree to 1e-9."""
    _, _, _, dt, config, ctrl = fuzz_episode(robots, 550039, 0, dts=DTS, past_limits=0.2)
    first = ctrl.solve(config, dt)
    n_first = ctrl._work.solves
    second = ctrl.solve(config, dt)
    n_second = ctrl._work.solves
    assert n_first - n_second == 4, (n_first, n_second, str(first.path), str(second.path))
    assert np.max(np.abs(first.v - second.v)) <= 1e-9
