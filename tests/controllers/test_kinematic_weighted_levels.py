"""Graceful degradation of strict levels: a cascade that does not fit the tick's counted budget (its levels, contact
corrections and trust regions stop ``WEIGHTED_RESERVE`` budgets early) is answered by the weighted single-QP form of
the same levels (path ``levels+budget+weighted``), with or without the clock guard, and the next
``WEIGHTED_TICKS`` ticks solve that form directly (``levels+weighted``, one QP solve). Oracle: the weighted QP
written out in the test (closed-form level rows from the tasks' own Jacobians) solved by quadprog; the soles by
Pinocchio forward kinematics. No wall-clock assertion: the cuts are forced by a count (a tiny budget, or a CPU-time
weight of 1e12) and the work checked is QP solves."""

from __future__ import annotations

import math

import numpy as np
import pytest
import quadprog

from wbc.exceptions import InvalidInputError
from wbc.controllers import general_route
from wbc.tick import TickPath

from conftest import count_cascades, hand_over_posture

DT = 0.002


def _weighted_reference(ctrl, config, level_tasks, ratio=100.0):
    """The weighted form by hand: soft cost + ratio^(p − k) ‖√w (J_k v − v*_k)‖², under the hard set (quadprog)."""
    H, g, A, b, C, l, u, lb, ub = ctrl.assemble(config, DT)
    H, g = H.copy(), g.copy()
    p = len(level_tasks)
    for k, task in enumerate(level_tasks):
        err, jac = task.compute(config)
        w = np.broadcast_to(np.asarray(task.weight, dtype=float), (jac.shape[0],))
        J, t = jac * np.sqrt(w)[:, None], task.velocity_target(err) * np.sqrt(w)
        H += ratio ** (p - k) * J.T @ J
        g -= ratio ** (p - k) * J.T @ t
    fin_l, fin_u = np.isfinite(l), np.isfinite(u)
    fin_lb, fin_ub = np.isfinite(lb), np.isfinite(ub)
    n = H.shape[0]
    I = np.eye(n)
    G = np.hstack([A.T, C[fin_l].T, -C[fin_u].T, I[:, fin_lb], -I[:, fin_ub]])
    h = np.concatenate([b, l[fin_l], -u[fin_u], lb[fin_lb], -ub[fin_ub]])
    return quadprog.solve_qp(0.5 * (H + H.T), -g, G, h, A.shape[0])[0]


def test_tick_path_declares_the_weighted_qualifier():
    """'levels+weighted' (and with '+budget') is a declared path; only the 'levels' route has a weighted form."""
    for text in ("levels+weighted", "levels+budget+weighted", "levels+return_rate+budget+weighted"):
        path = TickPath.parse(text)
        assert path.route == "levels" and path.weighted and str(path) == text
        assert str(path.with_budget()).endswith("+budget+weighted") or path.budget is False
    assert TickPath("levels", weighted=True).with_budget() == "levels+budget+weighted"
    with pytest.raises(InvalidInputError, match="weighted"):
        TickPath("general", "fast", weighted=True)
    with pytest.raises(InvalidInputError, match="weighted"):
        TickPath.parse("general:fast+weighted")


def test_cut_cascade_answers_with_its_weighted_form_and_then_one_solve_per_tick(robots, monkeypatch):
    """Tick 1: a CPU-time weight of 1e12 cuts the cascade after level 0; the tick answers with the weighted form
    (quadprog on the QP written out here, to 1e-6 m/s — on the old code: level 0's command, 0.1+ away). Tick 2 (the
    guard still on, its clock weighted to count nothing): the weighted form again, ``levels+weighted``, one QP solve and no cascade (the
    cascade of the same tick counts ≥ 2 solves: one per level). Guard off: the cascade, as before."""
    robot, config, ctrl, tasks = hand_over_posture(robots, budget=1.0, clock_guard=True, CLOCK_WEIGHT=1e12,
                                                    contact_correction=0.0, sole_drift_tolerance=None)
    ref = _weighted_reference(ctrl, config, tasks)
    cut = ctrl.solve(config, DT)
    assert cut.ok and cut.path == "levels+budget+weighted", (cut.path, cut.message)
    assert np.max(np.abs(cut.v - ref)) <= 1e-6, np.max(np.abs(cut.v - ref))
    ctrl.CLOCK_WEIGHT = 1e-12  # the clock never reaches a limit: the counted solves decide
    calls = []
    flat_solve = ctrl.backend.solve
    ctrl.backend.solve = lambda *a, **k: calls.append("flat") or flat_solve(*a, **k)
    cascade = general_route.solve_lexicographic
    monkeypatch.setattr(general_route, "solve_lexicographic", lambda *a, **k: calls.append("cascade") or cascade(*a, **k))
    nxt = ctrl.solve(config, DT)
    assert nxt.ok and nxt.path == "levels+weighted" and not nxt.over_budget, (nxt.path, nxt.message)
    assert np.max(np.abs(nxt.v - ref)) <= 1e-6
    assert calls == ["flat"]  # one QP solve, no cascade
    monkeypatch.undo()
    # the cascade of the same tick (guard off: never degraded) is a different answer and ≥ 2 counted solves
    _, _, plain, _ = hand_over_posture(robots, budget=1.0, contact_correction=0.0, sole_drift_tolerance=None)
    full = plain.solve(config, DT)
    assert full.ok and full.path == "levels"
    assert plain._work._solves >= 2
    assert np.max(np.abs(full.v - ref)) > 1e-4


def test_count_cut_cascade_answers_with_its_weighted_form_without_the_clock_guard(robots):
    """Guard off, a budget of 1e-9 s (0 counted solves): the cascade cannot fit the count and is not started
    (``_plan_levels``; before that rule the count cut it after level 0) and the tick answers with the
    weighted form of its levels, 'levels+budget+weighted' (quadprog on the QP written out here, to 1e-6 m/s; the cut
    cascade's level-0 command was 0.1+ away); a second controller fed the same inputs answers bitwise the same (a
    count, no clock); the next tick is 'levels+weighted'."""
    _, config, ctrl, tasks = hand_over_posture(robots, budget=1e-9, contact_correction=0.0,
                                                sole_drift_tolerance=None)
    assert ctrl.clock_guard is False
    ref = _weighted_reference(ctrl, config, tasks)
    cut = ctrl.solve(config, DT)
    assert cut.ok and cut.over_budget and cut.path == "levels+budget+weighted", (cut.path, cut.message)
    assert "the cascade of 2 priority levels (at least 3 counted solves: their weighted form's command)" in cut.message
    assert np.max(np.abs(cut.v - ref)) <= 1e-6, np.max(np.abs(cut.v - ref))
    _, _, twin, _ = hand_over_posture(robots, budget=1e-9, contact_correction=0.0, sole_drift_tolerance=None)
    assert twin.solve(config, DT).v.tobytes() == cut.v.tobytes()
    nxt = ctrl.solve(config, DT)
    assert nxt.ok and nxt.path.weighted, nxt.path
    assert np.max(np.abs(nxt.v - ref)) <= 1e-6


def test_count_cut_cascade_keeps_the_soles_and_returns_to_the_cascade_by_count(robots):
    """Guard off, default contact handling (correction, trust region, sole_drift_tolerance 0.05 mm), a budget of
    1e-9 s: the degraded tick is ok and each sole ends within 0.05 mm of where it was (both placed where they stand;
    Pinocchio forward kinematics at pin.integrate(q, v dt)). Then with a budget of 1 s the next WEIGHTED_TICKS
    ticks (3 here) are 'levels+weighted' with at most 1 counted solve each, and the tick after them, its weighted
    predecessor cheap by count, solves the cascade again ('levels'); the same sequence twice gives the same paths
    and bitwise the same commands."""
    import pinocchio as pin

    def run():
        robot, config, ctrl, _ = hand_over_posture(robots, budget=1e-9)
        ctrl.WEIGHTED_TICKS = 3
        out = [ctrl.solve(config, DT)]
        ctrl.budget = 1.0
        for _ in range(4):
            out.append(ctrl.solve(config, DT))
            assert ctrl._work.solves <= 1 or not out[-1].path.weighted
        return robot, config, out

    robot, config, out = run()
    first = out[0]
    assert first.ok and first.path == "levels+budget+weighted", (first.path, first.message)
    model, data = robot.model, robot.model.createData()
    pin.framesForwardKinematics(model, data, pin.integrate(model, config.q, first.v * DT))
    for frame in (robot.left_sole, robot.right_sole):
        fid = model.getFrameId(frame)
        assert np.linalg.norm(data.oMf[fid].translation - config.frame_placement(fid).translation) <= 5e-5
    assert [str(r.path) for r in out[1:]] == ["levels+weighted"] * 3 + ["levels"]
    assert all(r.ok for r in out)
    _, _, again = run()
    assert [r.v.tobytes() for r in again] == [r.v.tobytes() for r in out]


def test_a_cascade_that_cannot_fit_beside_a_new_layout_starts_on_its_weighted_form(robots, monkeypatch):
    """The budget's rule for a tick's first solve (``_plan_levels``), at the default 2 ms budget (a
    cap of 8 counted solves, the stages within 1.75 × 8 = 14, the weighted form's reserve 0.75 × 8 = 6, 2 levels):

    * a fresh controller's first tick counts its new layout (``LAYOUT_WORK`` = 4): its cascade and one contact
      correction, at least 2 × 2 × (1 + ``LEVEL_WORK``) = 6 solves, would end past 14 (4 + 6 + 6 = 16); the cascade
      is not started (no ``solve_lexicographic`` call), 'levels+budget+weighted';
    * without contact correction one cascade counts: 4 + 6 + 3 = 13 ≤ 14, the first tick runs the cascade ('levels');
      with ``LEVEL_WORK`` = 1.5 on that instance, 4 + 6 + 5 = 15 > 14: the weighted form, its command the weighted
      QP's optimum written out here (quadprog, to 1e-6 m/s);
    * after the new layout's tick (paid at an unlimited budget), a tick at the default budget runs the cascade and
      its correction (0 + 6 + 6 = 12 ≤ 14): 'levels'."""
    cascades = count_cascades(monkeypatch)
    _, config, ctrl, _ = hand_over_posture(robots)
    first = ctrl.solve(config, DT)
    assert first.ok and first.path == "levels+budget+weighted", (first.path, first.message)
    assert cascades == [] and ctrl._work.cap == 8
    assert "the cascade of 2 priority levels (with its contact correction, at least 6 counted solves" in first.message

    _, _, plain, _ = hand_over_posture(robots, contact_correction=0.0, sole_drift_tolerance=None)
    assert plain.solve(config, DT).path == "levels" and cascades == [1]
    _, _, heavy, tasks = hand_over_posture(robots, contact_correction=0.0, sole_drift_tolerance=None, LEVEL_WORK=1.5)
    res = heavy.solve(config, DT)
    ref = _weighted_reference(heavy, config, tasks)  # (after the tick: its assembly would build the layout first)
    assert res.path == "levels+budget+weighted" and cascades == [1], (res.path, res.message)
    assert "the cascade of 2 priority levels (at least 5 counted solves" in res.message
    assert np.max(np.abs(res.v - ref)) <= 1e-6, np.max(np.abs(res.v - ref))

    _, _, warm, _ = hand_over_posture(robots)
    warm.budget = math.inf
    assert warm.solve(config, DT).path == "levels" and cascades == [1, 1]
    warm.budget = None
    res = warm.solve(config, DT)
    assert res.ok and res.path == "levels" and cascades == [1, 1, 1], (res.path, res.message)
