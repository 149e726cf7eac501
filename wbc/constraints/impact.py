"""Joint speed limits after a touch-down: an impact-aware constraint of the inverse-dynamics QP (x = [v̇; f]).

A sole that touches down is stopped in a few milliseconds. Modelled as an inelastic impact of the rigid multibody on
the contacts (the landing sole and the soles already down, their stacked Jacobian J_c, nv columns), the velocity
jumps from v⁻ to the contact-consistent

    v⁺ = P v⁻,   P = I − M⁻¹ J_cᵀ (J_c M⁻¹ J_cᵀ)⁻¹ J_c

(the impact map: M (v⁺ − v⁻) = J_cᵀ Λ with J_c v⁺ = 0; Featherstone, *Rigid Body Dynamics Algorithms*, 2008, §11.6;
Pinocchio's ``impulseDynamics``; Wang and Kheddar, "Impact-friendly robust control design with task-space quadratic
optimization", RSS 2019, bound such post-impact velocities in a QP). A sole landing on a nearly straight leg while
the body moves onto it gives a knee rate past its limit although every joint was under its limit before; a sole
that lands on its heel or toe first spins the hip yaw or the ankle. Each landing sole gives 1 + 4 impact models:
the sole flat (its 6-D Jacobian), and with ``corners`` a point impact at each sole corner alone (the 3 linear rows
of the corner's velocity, ṗ_c = v_o + ω × r).

While a touch-down is expected (:meth:`ImpactSpeedBounds.expect`), the velocity the commanded acceleration leads
to, v⁻ = v + v̇ h dt, is bounded after each modelled impact on the joints of the legs (every joint on a kinematic
chain from the floating base to a sole):

    −s q̇_max ≤ P_j (v + v̇ h dt) ≤ s q̇_max,    s = 1 − margin,

one inequality row per such joint j and impact model (P_j the row of P; force columns zero); h, the speed horizon,
as in :class:`wbc.constraints.joint_velocity.JointSpeedBounds`. A row whose post-impact rate is already past its
bound at v̇ = 0, which the body's own momentum can set, is freed (±∞): holding it would ask the QP for an
acceleration it may not have within the horizon (on the ideal plant that made the solve fail). With no touch-down
expected the rows are free (C = 0, ±∞). The constraint is relaxable: the relaxed solve drops it.

:class:`ImpactSpeedExcess` is the soft form of the freed rows: each post-impact rate already past its bound becomes a
weighted task row asking P_j v̇ = −(P_j v − clip(P_j v, ±s q̇_max))/(h dt), the rate back at its bound after the
horizon, which the other tasks may outweigh (a hard row there left the QP no answer).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
from scipy.linalg import cho_factor, cho_solve

from wbc.constraints.base import IDConstraint
from wbc.constraints.joint_velocity import speed_margins
from wbc.exceptions import InvalidInputError
from wbc.tasks.base import Task

__all__ = ["ImpactSpeedBounds", "ImpactSpeedExcess"]


class ImpactSpeedBounds(IDConstraint):
    """Post-impact joint speed bounds of the legs (module docstring): inequality rows P_j v̇ h dt within
    ±s q̇_max − P_j v (a row whose bound is already passed at v̇ = 0 freed) for every leg joint j and impact model, while a touch-down is
    expected; dim = (leg joints) × (1 + 4 with ``corners``).

    Args:
        robot: the robot (:class:`wbc.robot.Robot`).
        soles: {name: sole frame}, the contacts a touch-down may close (e.g. ``{"left": robot.left_sole, "right":
            robot.right_sole}``); their chains from the floating base give the bounded joints.
        margin: fraction of the URDF speed limit kept free, in [0, 1): one number, or (nv − 6,) per actuated joint.
        horizon: h, ticks (≥ 1).
        corners: add a point impact at each corner of the landing sole (its rectangle ``robot.sole_length`` ×
            ``robot.sole_width`` about the sole frame) to the flat one.
        name: label in reports (default ``"impact_speed"``).

    Attributes:
        joints: (n_joints,) velocity indices of the bounded joints. vmax: (n_joints,) s q̇_max (rad/s).
        vmax_rows: (dim,) s q̇_max of every row (rad/s).
        corners: (4, 3) or (0, 3) corner positions in the sole frame (m).
        frame_ids: {sole name: Pinocchio frame index}.
        landing: name of the sole expected to touch down, or None (rows free). support: names of the soles down.
            Both read-only: set them with :meth:`expect`.

    Raises:
        InvalidInputError: no soles, a margin outside [0, 1), a horizon < 1 or not finite.
        UnknownFrameError: an unknown sole frame.
    """

    kind = "inequality"

    def __init__(self, robot, soles: dict, margin=0.0, horizon: float = 1.0, *, corners: bool = False,
                 name: str = "impact_speed"):
        if not soles:
            raise InvalidInputError("soles must name at least one sole frame")
        if not (isinstance(horizon, (int, float)) and math.isfinite(horizon) and horizon >= 1.0):
            raise InvalidInputError(f"horizon must be a finite number of ticks ≥ 1, got {horizon!r}")
        model = robot.model
        self.name, self.relaxable, self.horizon = str(name), True, float(horizon)
        self.frame_ids = {str(s): robot.frame_id(f) for s, f in soles.items()}
        joints = sorted({int(model.joints[j].idx_v) for fid in self.frame_ids.values()
                         for j in model.supports[model.frames[fid].parentJoint]
                         if model.joints[j].idx_v >= 6 and model.joints[j].nv == 1})
        self.joints = np.array(joints, dtype=np.int64)
        margins = speed_margins(robot, margin)
        self.vmax = (1.0 - margins[self.joints - 6]) * np.asarray(model.velocityLimit, dtype=float)[self.joints]
        self.n_joints = len(joints)
        #: impact models per expected touch-down: the flat sole, then (``corners``) a point impact at each corner
        self.corners = np.array([[sx * robot.sole_length / 2, sy * robot.sole_width / 2, 0.0]
                                 for sx in (1, -1) for sy in (1, -1)]) if corners else np.zeros((0, 3))
        self.dim = self.n_joints * (1 + len(self.corners))
        self.vmax_rows = np.tile(self.vmax, 1 + len(self.corners))
        self._landing: str | None = None
        self._support: tuple[str, ...] = ()
        self._rows_at: tuple = (None, None)  # (key, rows) of the last post_impact_rows (its state's q and contacts)

    @property
    def landing(self) -> str | None:
        """The sole expected to touch down (None: none expected)."""
        return self._landing

    @property
    def support(self) -> tuple[str, ...]:
        """The soles down while :attr:`landing` touches down."""
        return self._support

    def expect(self, landing: str | None, support=()) -> None:
        """Expect the sole ``landing`` to touch down with the soles ``support`` down (names of :attr:`frame_ids`);
        ``None``: no touch-down expected (the rows are free).

        Raises:
            InvalidInputError: an unknown sole name, or the landing sole among the support.
        """
        names = tuple(support)
        for s in (() if landing is None else (landing,)) + names:
            if s not in self.frame_ids:
                raise InvalidInputError(f"{self.name}: unknown sole {s!r}; known: {sorted(self.frame_ids)}")
        if landing is not None and landing in names:
            raise InvalidInputError(f"{self.name}: the landing sole {landing!r} cannot be among the soles down")
        self._landing, self._support = landing, names

    def post_impact_rows(self, state) -> np.ndarray:
        """(dim, nv) rows P_j of the impact maps at ``state`` (a :class:`wbc.state.DynamicsState`) for the expected
        contacts (module docstring): the landing sole flat, then (``corners``) at each of its corners alone.

        Every model's contact Jacobian is B J, J the landing and support soles' stacked (world-aligned) Jacobians and
        B a constant-size selection (a corner: [I, −[r]×] on the landing sole's rows), so one factorization of M and
        one Y = M⁻¹ Jᵀ serve them all: P = I − Y Bᵀ (B J Y Bᵀ)⁻¹ B J. P depends on q and the contacts only: the
        rows of the last call are returned again (the same array, not to be written) for the same q and contacts
        (the bounds and :class:`ImpactSpeedExcess` of one tick share them)."""
        key = (self.landing, self.support, state.q.tobytes())
        if self._rows_at[0] == key:
            return self._rows_at[1]
        J = np.vstack([state.frame_jacobian(self.frame_ids[s]) for s in (self.landing, *self.support)])
        Y = cho_solve(cho_factor(state.M), J.T)  # M⁻¹ Jᵀ (nv, m)
        G, Yj = J @ Y, Y[self.joints]
        out = np.empty((self.dim, state.v.size))
        out[:self.n_joints] = -Yj @ np.linalg.solve(G, J)
        if len(self.corners):
            R = state.data.oMf[self.frame_ids[self.landing]].rotation
            m = J.shape[0]
            B = np.zeros((len(self.corners), m - 3, m))  # per corner: its 3 rows, then the support soles' rows
            B[:, :3, :3] = np.eye(3)
            B[:, 3:, 6:] = np.eye(m - 6)
            for B_c, c in zip(B, self.corners):
                B_c[:3, 3:6] = -pin.skew(R @ c)  # ṗ_c = v_o + ω × r = v_o − [r]× ω, r = corner − sole origin (world)
            Bt = B.transpose(0, 2, 1)
            X = np.linalg.solve(B @ G @ Bt, B @ J)  # (corners, m − 3, nv)
            out[self.n_joints:] = -(Yj @ Bt @ X).reshape(-1, state.v.size)
        for i in range(1 + len(self.corners)):
            out[i * self.n_joints + np.arange(self.n_joints), self.joints] += 1.0
        self._rows_at = (key, out)
        return out

    def write(self, ctx, C, l, u):
        if self.landing is None:
            C[:] = 0.0
            l[:] = -np.inf
            u[:] = np.inf
            return
        P = self.post_impact_rows(ctx.state)
        post = P @ ctx.state.v
        hdt = self.horizon * ctx.dt
        C[:, :ctx.nv] = P
        C[:, ctx.nv:] = 0.0
        np.divide(-self.vmax_rows - post, hdt, out=l)
        np.divide(self.vmax_rows - post, hdt, out=u)
        past = (l > 0.0) | (u < 0.0)  # a post-impact rate already past its bound at v̇ = 0: the row is freed
        l[past], u[past] = -np.inf, np.inf


class ImpactSpeedExcess(Task):
    """The post-impact rates of ``bounds`` already past their bound, pulled back by weighted rows (module docstring):
    for each row r of ``bounds`` with |P_r v| > s q̇_max (a row the bounds free),

        J_r = P_r,   ė*_r = clip(P_r v, ±s q̇_max),   e_r = 0,   J̇v taken as 0 (P held over the horizon, as the bounds do),

    and zero rows elsewhere (no cost). In the inverse-dynamics QP as an
    :class:`~wbc.formulations.reference.AccelerationReference` with Kp = 0 and Kd = 1/(h dt) (h: ``bounds.horizon``,
    dt: the control period), a row asks P_r v̇ = −(P_r v − ė*_r)/(h dt). With no touch-down expected every row is
    zero. Acceleration level only (P needs the mass matrix of a :class:`~wbc.state.DynamicsState`).

    Args:
        bounds: the :class:`ImpactSpeedBounds` whose rows and expected touch-down it follows.
        weight: scalar or (bounds.dim,) cost weights, ≥ 0 ((rad/s²)⁻² per row).
        name: label (default ``"impact_excess"``).

    Attributes:
        dim: bounds.dim. past: (dim,) bool, the rows past their bound at the last state (all False when none).

    Raises:
        InvalidInputError: ``bounds`` not an :class:`ImpactSpeedBounds`, a bad weight.
    """

    def __init__(self, bounds: ImpactSpeedBounds, weight=1.0, *, name: str = "impact_excess"):
        if not isinstance(bounds, ImpactSpeedBounds):
            raise InvalidInputError(f"{name}: bounds must be an ImpactSpeedBounds, got {type(bounds).__name__}")
        self.bounds, self.dim = bounds, bounds.dim
        super().__init__(gain=0.0, weight=weight, name=name)
        self.past = np.zeros(self.dim, dtype=bool)
        self._zero, self._ff = np.zeros(self.dim), np.zeros(self.dim)

    def compute(self, config) -> tuple[np.ndarray, np.ndarray]:
        """(zeros (dim,), J (dim, nv)) at ``config`` (a :class:`~wbc.state.DynamicsState`: P needs M)."""
        J = np.empty((self.dim, config.v.size))
        self.compute_with_drift_into(config, np.empty(self.dim), J, np.empty(self.dim))
        return self._zero, J

    def compute_with_drift_into(self, state, error_out, jac_out, drift_out) -> None:
        """J (the past rows P_r, zeros elsewhere) into jac_out, zeros into error_out and drift_out, at ``state`` (a
        :class:`~wbc.state.DynamicsState`); ė* for :meth:`feedforward`."""
        error_out[:] = 0.0
        drift_out[:] = 0.0
        jac_out[:] = 0.0
        self._ff[:] = 0.0
        self.past[:] = False
        b = self.bounds
        if b.landing is not None:
            P = b.post_impact_rows(state)
            post = P @ state.v
            np.greater(np.abs(post), b.vmax_rows, out=self.past)
            if self.past.any():
                jac_out[self.past] = P[self.past]
                self._ff[self.past] = np.clip(post[self.past], -b.vmax_rows[self.past], b.vmax_rows[self.past])

    def feedforward(self) -> np.ndarray:
        """(dim,) ė*: the past rows' rates clipped to their bound (rad/s), zeros elsewhere."""
        return self._ff

    def drift(self, state) -> np.ndarray:
        """(dim,) zeros (class docstring)."""
        return self._zero
