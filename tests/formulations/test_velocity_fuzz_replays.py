"""Failed strict-level ticks of the kinematic fuzz (``benchmarks/fuzz.py``, default flags: dt = 2 ms, counted budget)
replayed: each tick's command is checked against references computed here (Pinocchio forward kinematics on its own
Data, quadprog on the QP the solver received), not against the controller's own report."""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from wbc.solvers.daqp import DaqpBackend

DT = 0.002
SOLE_DRIFT = 5e-5  # m: the fuzz's bound on an ok tick's stance-sole drift (issue 8)


def _default_fuzz_episode(robots, seed: int, episode: int):
    """(name, kind, strict, config, controller) of ``benchmarks/fuzz.py``'s episode ``episode`` of chunk ``seed``
    (its random streams replayed; default flags: every episode at dt = 2 ms, none past the limits)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    import fuzz

    robots_ = {n: robots(n) for n in ("talos", "g1", "humanoid15")}
    rng = np.random.default_rng(seed)
    extra = np.random.default_rng(seed + 7_000_000)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for _ in range(episode + 1):
            name = str(rng.choice(list(robots_)))
            kind = str(rng.choice(["reachable", "absurd", "far"]))
            strict = bool(rng.random() < 0.5)
            extra.choice((DT,))
            past = bool(extra.random() < 0.0)
            config, ctrl = fuzz.build_episode(robots_[name], name, rng, kind, strict, past_limits=past)
    return name, kind, strict, config, ctrl


def _sole_drift_fk(ctrl, config, v) -> float:
    """Largest distance (m) between where a stance sole ends after one tick with v (Pinocchio, own Data) and where
    its contact row sends it: placement · exp((1 − K dt) e), e the sole's error before the tick."""
    model = ctrl.robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, config.q)
    before = [data.oMf[c.frame_id].copy() for c in ctrl.constraints[:2]]
    pin.framesForwardKinematics(model, data, pin.integrate(model, config.q, v * DT))
    worst = 0.0
    for c, oMf in zip(ctrl.constraints[:2], before):
        e = pin.log6(c.placement.actInv(oMf)).vector
        sent = c.placement * pin.exp6(e * (1.0 - min(c.gain, 1.0 / DT) * DT))
        worst = max(worst, float(np.linalg.norm(data.oMf[c.frame_id].translation - sent.translation)))
    return worst


def _run_to(ctrl, config, tick: int):
    for _ in range(tick):
        res = ctrl.solve(config, DT)
        config.update(config.integrate(res.v, DT))


def _quadprog(H, g, A, b, lb, ub) -> np.ndarray:
    """min ½ xᵀHx + gᵀx, A x = b, lb ≤ x ≤ ub (finite bounds only) by quadprog (Goldfarb–Idnani), the cost scaled
    by 1 / max |g| (the same minimiser)."""
    import quadprog

    s = 1.0 / max(1.0, float(np.abs(g).max()))
    n = H.shape[0]
    eye = np.eye(n)
    lo, hi = np.isfinite(lb), np.isfinite(ub)
    Cm = np.hstack([A.T, eye[:, lo], -eye[:, hi]])
    bm = np.concatenate([b, lb[lo], -ub[hi]])
    return quadprog.solve_qp(H * s, -g * s, Cm, bm, A.shape[0])[0]


def test_a_weighted_form_qp_that_cycles_daqp_workspace_is_solved_within_the_tick(robots, monkeypatch):
    """Fuzz seed 100012 episode 58 tick 6 (humanoid15, strict levels answered by their weighted form, Hessian
    conditioned 1e6, ‖g‖∞ 3e8): DAQP's warm and cold workspaces each stopped at 1000 iterations where its one-shot
    call solves the QP in 16; the 2016 iterations spent the tick's count, its contact correction and trust region
    were skipped and the tick failed (sole drift 7.5e-5 m, ``fallback:contacts_held``). Now the one-shot call follows
    the warm workspace's stop: the tick is ok, its first QP's solution agrees with quadprog's and the soles stay
    within the drift bound by forward kinematics."""
    name, kind, strict, config, ctrl = _default_fuzz_episode(robots, 100012, 58)
    assert (name, strict) == ("humanoid15", True)
    _run_to(ctrl, config, 6)
    calls = []
    solve = DaqpBackend.solve

    def recorded(self, H, g, A, b, C, l, u, lb, ub, **kw):
        x = solve(self, H, g, A, b, C, l, u, lb, ub, **kw)
        calls.append(([np.array(a, copy=True) for a in (H, g, A, b, C, lb, ub)], x.copy()))
        return x

    monkeypatch.setattr(DaqpBackend, "solve", recorded)
    res = ctrl.solve(config, DT)
    assert res.ok, res.message
    assert _sole_drift_fk(ctrl, config, res.v) <= SOLE_DRIFT
    (H, g, A, b, C, lb, ub), x = calls[0]
    assert C.shape[0] == 0
    assert np.linalg.cond(H) > 1e5 and np.abs(g).max() > 1e7  # the ill-conditioned weighted form of the fuzz tick
    ref = _quadprog(H, g, A, b, lb, ub)
    assert np.abs(x - ref).max() <= 1e-6 * max(1.0, np.abs(ref).max())


def test_trust_region_projects_contact_rows_that_became_dependent_since_the_rank_was_computed(robots):
    """Fuzz seed 100022 episode 195 tick 9 (humanoid15, hand on strict level 0): the solve kept all 12 contact rows
    (their rank computed at an earlier tick, kept while the rows stay met), but at this tick J_c has σ_min / σ_max
    < 1e-3 (rank_rtol): the near-dependent row's drift correction asked ~10 rad/s, no trust region inside that was
    feasible and the tick failed (5.66e-5 m). The trust region now takes the rank of this tick's J_c (the rows'
    corrections projected onto its range): the tick is ok and each sole stays within the drift bound by forward
    kinematics."""
    name, kind, strict, config, ctrl = _default_fuzz_episode(robots, 100022, 195)
    assert (name, strict) == ("humanoid15", True)
    _run_to(ctrl, config, 9)
    model = ctrl.robot.model
    data = model.createData()
    pin.computeJointJacobians(model, data, config.q)
    pin.updateFramePlacements(model, data)
    J = np.vstack([pin.getFrameJacobian(model, data, c.frame_id, pin.LOCAL) for c in ctrl.constraints[:2]])
    s = np.linalg.svd(J, compute_uv=False)
    assert s[-1] / s[0] < 1e-3  # the contact rows are (numerically) dependent at this tick
    res = ctrl.solve(config, DT)
    assert res.ok, res.message
    assert _sole_drift_fk(ctrl, config, res.v) <= SOLE_DRIFT
    _, _, _, _, _, _, _, lb, ub = ctrl.assemble(config, DT)
    assert np.all(res.v >= lb - 1e-9) and np.all(res.v <= ub + 1e-9)


if __name__ == "__main__":
    sys.exit(pytest.main([__file__, "-q"]))
