"""Inverse-dynamics controller tick: state (q, v) → QP (:mod:`wbc.formulations.acceleration`) → torques τ.

:class:`InverseDynamicsController`, the sibling of :class:`wbc.controllers.kinematic.KinematicController`: one
:meth:`~InverseDynamicsController.solve` per control period updates :class:`~wbc.state.DynamicsState`, solves the QP
(its answer passes the QP's output check, :meth:`~wbc.formulations.acceleration.InverseDynamicsQP.verify`) and returns
τ, v̇ and the contact forces; ``IDCommand.path`` names the route (``kernel``, ``general:<backend>``,
``relaxed:<backend>``, ``fallback:hold|feasible|gravity``). The tick's CPU budget: the constructor; the fallback
chain's stages: :mod:`wbc.solvers.fallback`, docs/inverse-dynamics-controller.md.

Failure handling (the tick never raises :class:`~wbc.exceptions.SolverError`; the violated or conflicting
constraints in ``IDCommand.conflicts``, named by :meth:`InverseDynamicsQP.diagnose` inside the tick only with
``diagnose=True``):

1. the full QP fails → the same QP without joint acceleration bounds and torque limits (``solve_relaxed``; the
   drives still clamp): ``relaxed`` True, τ clipped to the (scaled) URDF limits;
2. that fails too → the previous tick's solved command for one tick (``fallback:hold``; kept while the failures are
   the budget's: a cut full QP whose hard set has a point, which is commanded, ``fallback:feasible``, when there is
   no command to hold, and held on the next tick if that one fails too); else contact-consistent gravity
   compensation with joint damping (``fallback:gravity``):

       W = argmin ‖W‖  s.t.  (J_cᵀ)_u W = h_u   (least norm over the active sole wrenches, LOCAL, 6 per sole)
       τ = h_a − (J_cᵀ)_a W − K_d v_a,    K_d,i = 0.5 I_eff,i / dt,  I_eff,i = 1 / (M⁻¹)_ii   (clipped to ±τ_max)

   (the largest damping a 1-tick explicit loop keeps stable on light links). A held command keeps the QP's joint
   speed bounds at the new state: τᵢ += I_eff,i (clip(v̇ᵢ, lᵢ, uᵢ) − v̇ᵢ) (diagonal inertia). ``ok`` is False.
"""

from __future__ import annotations

from collections import Counter, namedtuple
import math
from time import perf_counter, thread_time

import numba as nb
import numpy as np

from wbc.compiled import FASTMATH, once_per_process
from wbc.formulations.acceleration import IDCommand, InverseDynamicsQP
from wbc.formulations.idkernel import inverse_diagonal
from wbc.solvers.compiled_id import kernel_iterations
from wbc.solvers.fallback import daqp_attempt_iterations, tick_work_iterations
from wbc.state import DynamicsState
from wbc.exceptions import InvalidInputError, SolverError
from wbc.geometry import Flag
from wbc.solvers.linalg import backward_substitution, cholesky_lower, forward_substitution
from wbc.tick import TickPath

__all__ = ["InverseDynamicsController", "GravityWorkspace", "gravity_torques"]

#: smallest Cholesky pivot of BᵀB (relative to its diagonal entry; B = (J_c)_u, conditioned ~10) for which
#: :func:`gravity_torques` solves the normal equations
NORMAL_EQUATION_PIVOT = 1e-8

#: the workspace of :func:`gravity_torques`: L (nv, nv), y (nv,) of the Cholesky of M, dinv (nv,) ← diag(M⁻¹),
#: N (6, 6) and w (6,) of the normal equations
GravityWorkspace = namedtuple("GravityWorkspace", "L y dinv N w")


def gravity_workspace(nv: int) -> GravityWorkspace:
    """A :data:`GravityWorkspace` for ``nv`` velocities."""
    return GravityWorkspace(np.empty((nv, nv)), np.empty(nv), np.empty(nv), np.empty((6, 6)), np.empty(6))


@nb.njit(cache=True, fastmath=FASTMATH)
def gravity_torques(M, h, v, J, k, dt, tau_max, ws, W, tau) -> int:
    """Joint torques of the gravity fallback (module docstring, step 2; τ clipped where τ_max is finite and > 0),
    W by the normal equations.

    Args:
        M (nv, nv), h (nv,) (N, N·m), v (nv,): the state's inertia matrix, non-linear effects and velocity.
        J (≥ k, nv): the stacked active sole Jacobians (LOCAL) in its first k = 6 × (active soles) rows.
        dt: control period (s). tau_max: (nv − 6,) torque limits (N·m; not finite or ≤ 0: none).
        ws: a :data:`GravityWorkspace` (``ws.dinv`` ← diag(M⁻¹)). W (≥ k,) ← the LOCAL sole wrenches, 6 per sole;
            tau (nv − 6,) ← τ (N·m).

    Returns:
        0; 1: M is not positive definite; 2: the normal equations are not well conditioned
        (:data:`NORMAL_EQUATION_PIVOT`). Nothing is written to tau on 1 or 2.
    """
    nv = M.shape[0]
    L, y, dinv, N, w = ws.L, ws.y, ws.dinv, ws.N, ws.w
    if not inverse_diagonal(M, L, y, dinv):
        return 1
    if k > 0:
        for a in range(6):
            for b in range(a + 1):
                t = 0.0
                for r in range(k):
                    t += J[r, a] * J[r, b]
                N[a, b] = t
            w[a] = h[a]
        if not cholesky_lower(N, 6, NORMAL_EQUATION_PIVOT):
            return 2
        forward_substitution(N, 6, w)
        backward_substitution(N, 6, w)
        for r in range(k):
            t = 0.0
            for a in range(6):
                t += J[r, a] * w[a]
            W[r] = t
    for j in range(nv - 6):
        c = 6 + j
        t = 0.0
        for r in range(k):
            t += J[r, c] * W[r]
        t = h[c] - t
        t -= 0.5 * (1.0 / dinv[c]) / dt * v[c]
        lim = tau_max[j]
        if math.isfinite(lim) and lim > 0:
            if t > lim:
                t = lim
            elif t < -lim:
                t = -lim
        tau[j] = t
    return 0


@once_per_process
def _load_kernels() -> None:
    """Load the kernels at construction (M column-major as a DynamicsState's), not inside a failed tick."""
    nv = 7
    M = np.asfortranarray(np.eye(nv))
    gravity_torques(M, np.zeros(nv), np.zeros(nv), np.zeros((6, nv)), 6, 0.002, np.ones(nv - 6), gravity_workspace(nv),
                    np.empty(6), np.empty(nv - 6))
    inverse_diagonal(M, np.empty((nv, nv)), np.empty(nv), np.empty(nv))


class InverseDynamicsController:
    """One inverse-dynamics QP per control tick (module docstring).

    Args:
        qp: the problem (tasks and contacts are edited on it between ticks).
        dt: control period (s), > 0.
        budget: CPU time a tick may use (s, > 0; default dt; ``math.inf``: unbounded); sets the iteration caps
            ``qp.kernel_max_iterations`` (:func:`~wbc.solvers.compiled_id.kernel_iterations`),
            ``qp.chain.daqp_attempt_iterations`` and ``qp.chain.tick_work_iterations``.
        diagnose: name the conflicting constraints inside every failed tick (a least-squares QP per failure).
        clock_guard: the failure path is stopped by the CPU time since the tick began (``FallbackChain.tick_clock``;
            a relaxed command whose full QP lost a check to the clock has path ``relaxed:<solver>+budget``). Default
            False: a tick's answer is a function of its inputs; True (a real-time loop): it depends on the machine's
            speed on a slow tick. Settable as an attribute.

    Attributes:
        n_ticks, n_failures (fallback ticks), n_relaxed, n_over_budget: counts since construction.
        deadline_misses: ticks since construction whose CPU time exceeded the control period dt.
        paths: path (string form of :class:`wbc.tick.TickPath`) → number of ticks that took it.
        routes: route (:data:`wbc.tick.ID_ROUTES`) → number of ticks that took it.

    Raises:
        InvalidInputError: dt or budget not finite and > 0 (budget may be inf).
    """

    clock_guard = Flag("A failed full QP past the budget is not retried (constructor docstring).")

    def __init__(self, qp: InverseDynamicsQP, dt: float = 0.002, *, budget: float | None = None,
                 diagnose: bool = False, clock_guard: bool = False):
        if not (np.isfinite(dt) and dt > 0):
            raise InvalidInputError(f"dt must be finite and > 0 (s), got {dt!r}")
        self.qp = qp
        self.robot = qp.robot
        self.dt = float(dt)
        self.budget = self.dt if budget is None else budget
        self.diagnose_failures = bool(diagnose)
        self.clock_guard = clock_guard
        self.state = DynamicsState(self.robot)
        self.last_solution: IDCommand | None = None  # the last solved tick's command
        self._last_ok: IDCommand | None = None  # the last solved command, for one tick of zero-order hold
        self._last_point: IDCommand | None = None  # the last tick's commanded point of the hard set (``_fail``)
        self.n_ticks = 0
        self.n_failures = 0
        self.n_relaxed = 0
        self.n_over_budget = 0
        self.deadline_misses = 0
        self.paths: Counter = Counter()
        self._path_key: tuple = (None, "")  # (path object, its string form) of the last tick
        self.routes: Counter = Counter()
        nv, nc = qp.nv, len(qp.contacts)
        # gravity_torques' stacked active sole Jacobians, sole wrenches, workspace
        self._safe = (np.zeros((6 * nc, nv)), np.zeros(6 * nc), gravity_workspace(nv))
        _load_kernels()

    @property
    def budget(self) -> float:
        """CPU time a tick may use (s, > 0; ``math.inf``: unbounded). Raises InvalidInputError on assignment of
        anything but a number > 0."""
        return self._budget

    @budget.setter
    def budget(self, value) -> None:
        if not (isinstance(value, (int, float, np.floating)) and not isinstance(value, bool) and value > 0):
            raise InvalidInputError(f"budget must be a number of seconds > 0 (math.inf: unbounded), got {value!r}")
        self._budget = float(value)
        self.qp.kernel_max_iterations = kernel_iterations(self._budget)
        self.qp.chain.daqp_attempt_iterations = daqp_attempt_iterations(self._budget)
        self.qp.chain.tick_work_iterations = tick_work_iterations(self._budget)

    def solve(self, q: np.ndarray, v: np.ndarray) -> IDCommand:
        """Compute the torques for the measured state.

        Args:
            q: (nq,) configuration (Pinocchio conventions). v: (nv,) velocity.

        Returns:
            :class:`IDCommand` (on QP failure: the fallback of the module docstring, ``ok`` False).

        Raises:
            ConfigurationError: q or v with a wrong size, NaN/inf, or a non-unit base quaternion.
        """
        t0 = perf_counter()
        c0 = thread_time()
        self.qp.chain.tick_clock = (c0, self._budget) if self._clock_guard else None
        self.state.update(q, v)
        t1 = perf_counter()
        try:
            sol = self.qp.solve(self.state, self.dt)
        except SolverError as exc:  # named: the output check's violations, else the tasks with non-finite inputs
            # (cheap: a NaN written in place past the setters), else (diagnosis mode) the diagnosis
            conflicts = (list(self.qp.last_violations) or self.qp.nonfinite_inputs()
                         or (self.diagnose() if self.diagnose_failures else []))
            message = str(exc) + ("; conflicting constraints: " + ", ".join(f"{n} ({v:.3g})" for n, v in conflicts)
                                  if conflicts else "")
            try:  # as the full QP's, a relaxed command that ends past the budget is used and counted over budget
                sol = self.qp.solve_relaxed(self.state, self.dt, reuse_assembly=True)
            except SolverError as exc2:
                return self._fail(f"{message}; relaxed QP: {exc2}", conflicts, t0, t1, c0)
            sol.relaxed, sol.message, sol.conflicts = True, message, conflicts
            self.n_relaxed += 1
            if self.qp.chain.budget_cut:  # the clock guard cut a check of the full QP (or one of its DAQP calls)
                sol.path = sol.path.with_budget()
            lim = self.qp.torque_limits
            if lim.dim:
                sol.tau[lim.joints] = np.clip(sol.tau[lim.joints], -lim.tau_max[lim.joints],
                                              lim.tau_max[lim.joints])
        sol.timings = {"pinocchio": t1 - t0, **sol.timings, "total": perf_counter() - t0}
        self.last_solution = self._last_ok = sol
        self._last_point = None
        return self._count(sol, c0)

    def _count(self, cmd: IDCommand, c0: float) -> IDCommand:
        cpu = thread_time() - c0
        cmd.timings["cpu"] = cpu
        cmd.over_budget = cpu > self.budget
        self.n_ticks += 1
        self.n_over_budget += int(cmd.over_budget)
        self.deadline_misses += cpu > self.dt
        path = cmd.path
        if path is not self._path_key[0]:  # the string form of the last path (the compiled tick's is one object)
            self._path_key = (path, str(path))
        self.paths[self._path_key[1]] += 1
        self.routes[path.route] += 1
        return cmd

    def _fail(self, message: str, conflicts, t0: float, t1: float, c0: float) -> IDCommand:
        self.n_failures += 1
        prev = self._last_ok
        # a failure of the budget, not of the problem (the counted work cut a full QP whose hard set has a point):
        # the last solved command stays held while the next ticks resume the cut stages
        # (not with a task's numbers non-finite: no solver could answer that QP, whatever its budget)
        spent = self.qp.chain.budget_cut and self.qp.chain.hard_set_point and not self.qp.nonfinite_inputs()
        if not spent:
            self._last_ok = None
            if prev is None:  # the previous tick commanded a point of its hard set (no solved command): held
                prev = self._last_point
        self._last_point = None
        if prev is not None:  # the previous tick was solved: hold its command for this one tick (zero-order hold)
            why = ("the tick's budget was spent on a full QP whose hard set has a point: the last solved command is "
                   "held" if spent else
                   "the previous tick's command is held for this tick (a second failed tick in a row takes the safe "
                   "command)")
            cmd = IDCommand(tau=prev.tau.copy(), dv=prev.dv.copy(), forces=prev.forces.copy(),
                            wrenches={k: w.copy() for k, w in prev.wrenches.items()}, ok=False,
                            message=f"{message}; {why}", dynamics_residual=float("nan"),
                            path=TickPath("fallback", fallback="hold"))
            self._hold_speed_bounds(cmd)
        elif spent:  # no command to hold: the point of the hard set that the tick's check found (every hard row met)
            cmd = self.qp.solution_from(self.state, self.qp.chain.hard_set_x,
                                        path=TickPath("fallback", fallback="feasible"))
            cmd.ok = False
            cmd.message = (f"{message}; the tick's budget was spent on a full QP whose hard set has a point, with no "
                           "solved command to hold: that point is commanded")
            self._last_point = cmd
        else:
            cmd = self.fallback(message)
        cmd.conflicts = conflicts
        cmd.path_reason = f"full and relaxed QP failed → {cmd.path.fallback}"
        cmd.timings = {"pinocchio": t1 - t0, "total": perf_counter() - t0}
        return self._count(cmd, c0)

    def _hold_speed_bounds(self, cmd: IDCommand) -> None:
        """Brake the held command into the joint speed bounds (module docstring, step 2), in place."""
        sb = self.qp.joint_speed_limits
        if sb is None or not sb.dim:
            return
        st = self.state
        lo, hi = sb.bounds(st.v, self.dt)
        idx = sb.indices
        a = cmd.dv[idx]
        target = np.minimum(np.maximum(a, lo), hi)
        out = target != a
        if not out.any():
            return
        iv = idx[out]
        ws = self._safe[2]
        if not inverse_diagonal(st.M, ws.L, ws.y, ws.dinv):  # (M of a model is positive definite)
            return
        i_eff = 1.0 / ws.dinv[iv]
        j = iv - 6
        lim = self.qp.tau_max[j]
        lim = np.where(np.isfinite(lim) & (lim > 0), lim, np.inf)
        cmd.tau[j] = np.clip(cmd.tau[j] + i_eff * (target[out] - a[out]), -lim, lim)
        cmd.dv[iv] = target[out]
        cmd.message += f"; {int(out.sum())} joint(s) braked to the joint speed bounds"

    def diagnose(self) -> list[tuple[str, float]]:
        """:meth:`~wbc.formulations.acceleration.InverseDynamicsQP.diagnose` at the last tick's state; [] when the
        hard set is feasible or the diagnosis fails (never raises). Off the control path (a least-squares QP)."""
        try:
            return self.qp.diagnose(self.state, self.dt)
        except Exception:  # noqa: BLE001 — diagnosis is best effort on a tick that already failed
            return []

    def summary(self) -> dict:
        """Counts since construction: ``ticks``, ``budget_ms``, ``over_budget``, ``deadline_misses``,
        ``fallback_rate`` (fallback ticks / ticks), ``relaxed``, ``routes`` and ``paths`` (→ ticks)."""
        n = max(self.n_ticks, 1)
        return {"ticks": self.n_ticks, "budget_ms": 1e3 * self.budget, "over_budget": self.n_over_budget,
                "deadline_misses": self.deadline_misses, "fallback_rate": self.n_failures / n,
                "relaxed": self.n_relaxed, "routes": dict(self.routes), "paths": dict(self.paths)}

    def fallback(self, message: str = "") -> IDCommand:
        """Contact-consistent gravity compensation at the current state (module docstring): :func:`gravity_torques`
        on preallocated buffers (h_a clipped, no contact wrench, when it declines)."""
        qp, st = self.qp, self.state
        nv = qp.nv
        active = [c for c in qp.contacts if c.active]
        J, W, ws = self._safe
        k = 6 * len(active)
        for i, c in enumerate(active):
            J[6 * i:6 * i + 6] = c.jacobian(st)
        tau = np.empty(nv - 6)
        if gravity_torques(st.M, st.h, st.v, J, k, self.dt, qp.tau_max, ws, W, tau) != 0:
            # (never for a model: M and the soles' normal equations, of full-rank adjoints, are positive definite)
            lim = np.where(np.isfinite(qp.tau_max) & (qp.tau_max > 0), qp.tau_max, np.inf)
            tau[:], W[:] = np.clip(st.h[6:], -lim, lim), 0.0
        wrenches = {c.name: np.zeros(6) for c in qp.contacts}
        for i, c in enumerate(active):
            R = st.data.oMf[c.frame_id].rotation  # LOCAL sole wrench -> world axes
            wrenches[c.name] = np.concatenate([R @ W[6 * i:6 * i + 3], R @ W[6 * i + 3:6 * i + 6]])
        return IDCommand(tau=tau, dv=np.zeros(nv), forces=np.zeros(qp.n - nv), wrenches=wrenches, ok=False,
                         message=message or "fallback", dynamics_residual=float("nan"),
                         path=TickPath("fallback", fallback="gravity"))
