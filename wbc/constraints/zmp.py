"""Dynamic balance for the kinematic QP: the ZMP of the executed motion and the DCM stay in the support polygon.

A kinematic controller chooses velocities; the motion it executes is q_{k+1} = q_k ⊕ v_k dt. Its CoM c_k has the
acceleration of the central second difference c̈_k = (c_{k+1} − 2 c_k + c_{k−1}) / dt², its centroidal angular
momentum over tick k is L_k = A_G,ang(q_k) v_k (Pinocchio's centroidal momentum matrix; Orin, Goswami & Lee,
"Centroidal dynamics of a humanoid robot", Autonomous Robots 2013) and L̇_k = (L_k − L_{k−1}) / dt. The ZMP on
flat ground of height z_g of this multi-body motion (Newton–Euler about the CoM with the ground wrench at p;
Kajita et al., "Introduction to Humanoid Robotics", 2014, ch. 3, ZMP from the robot's motion), with h = c_z − z_g, m the mass, is

    p_x = c_x − (m h c̈_x + L̇_y) / (m (g + c̈_z)),      p_y = c_y − (m h c̈_y − L̇_x) / (m (g + c̈_z)).

This is exactly how :mod:`wbc.scenarios.metrics` measures the executed motion; these two constraints make the
controller produce a motion that meets it, instead of a motion with unbounded CoM acceleration or angular
momentum rate whenever a task switches or a hard limit becomes active.

:class:`ExecutedZmpConstraint` — for each edge i of the support polygon shrunk by ``margin`` (unit outward
normal n_i, offset b_i), with s_i = b_i − n_i·c_xy and g + c̈_z > 0,

    n_i·p ≤ b_i   ⇔   −h n_i·c̈_xy − s_i c̈_z − (n_i × L̇)_z / m ≤ s_i g         (linear in c̈ and L̇, exact)

valid while the ground pushes, g + c̈_z > 0; one more row keeps the normal force at least ``min_normal_ratio``
of the weight, c̈_z ≥ −(1 − min_normal_ratio) g (a CoM in free fall makes every ZMP row meaningless). c̈_k and L̇_k are
linear in v_k: c_{k+1} = c_k + J_com v_k dt + r, where r, the second-order part of the CoM step, is
linearised about the previous command: r(v) ≈ r_{k−1} + dt (J_com,k − J_com,k−1)(v − v_{k−1}), with r_{k−1} =
c_k − c_{k−1} − J_com,k−1 v_{k−1} dt measured over the previous tick (½ dt² vᵀ∇²c v has gradient dt² ∇²c v, and
dt ∇²c v_{k−1} ≈ J_com,k − J_com,k−1); below, J_com stands for 2 J_com,k − J_com,k−1 and r for
r_{k−1} − dt (J_com,k − J_com,k−1) v_{k−1}. And
L̇_k = (A_G,ang v_k − L_{k−1}) / dt. With e_i = (n_i,y, −n_i,x, 0) (so that −(n_i × L̇)_z = e_i·L̇), divided
by h (units m/s), the row is

    [(−n_i, −s_i/h)·J_com + e_i·A_G,ang / (m h)] v
        ≤ s_i g dt / h + (n_i, s_i/h)·(r − Δc) / dt + e_i·L_{k−1} / (m h),         Δc = c_k − c_{k−1}.

It needs the previous command (``needs_previous_command``) and the previous CoM, both recorded by the
controller's tick; until one tick has been solved (or after :meth:`reset`) its rows are inactive. It is
``relaxable``: a tick on which it cannot hold together with the hard constraints (e.g. a joint position limit
that stops a joint within one tick) is solved without it and reported in ``TickResult.relaxed``.

:class:`DcmPolygonConstraint` — the ZMP constraint alone is not enough near the edge of the CoM polygon: a CoM
that reaches the polygon's edge with speed has to stop within one tick, and no ZMP inside the feet can do that.
Keeping the divergent component of motion (capture point) ξ = c + ċ/ω, ω = √(g/h), inside the shrunk polygon
(Pratt et al., "Capture point: a step toward humanoid push recovery", Humanoids 2006; Englsberger et al., IEEE
T-RO 2015) caps the CoM speed towards edge i at ω s_i, so the CoM approaches the edge exponentially, with
deceleration ω² s_i, whose ZMP (p = c − c̈/ω²) is at most on the shrunk edge itself. Row: n_i·J_com,xy v ≤ ω s_i
(and, as in :class:`~wbc.constraints.ComPolygonConstraint`, a CoM already outside is pulled back at no more than
``recovery_speed``).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
import pinocchio as pin

from wbc.compiled import NO_NRT, once_per_process
from wbc.configuration import Configuration
from wbc.constants import GRAVITY
from wbc.constraints.base import InequalityConstraint
from wbc.constraints.com_polygon import ComPolygonConstraint
from wbc.exceptions import InvalidInputError
from wbc.geometry import ReadOnly, as_se3, check_count, check_scalar, support_corners, yaw_of

__all__ = ["DcmPolygonConstraint", "ExecutedZmpConstraint"]


#: rows of one tick slot of :class:`ExecutedZmpConstraint`'s memory array: CoM (first 3 entries), CoM Jacobian (3),
#: angular rows of the centroidal map (3), command; two slots, then J_eff (3 rows), a scratch row, the shrunk support
#: polygon's edges (3 rows: outward normal x, y and offset, one edge per column) and a row of constants (_PARAMS:
#: ground height, mass, gravity, min_normal_ratio, use_momentum, edge count), read by the compiled tick from that one array
_SLOT = 8
_J_EFF = 2 * _SLOT
_SCRATCH = _J_EFF + 3
_EDGES = _SCRATCH + 1
_PARAMS = _EDGES + 3


@nb.njit(cache=True, nogil=True, **NO_NRT)
def _zmp_tick(c, J, Ag, W, now, dt_prev, dt, C, l, u):
    """:meth:`ExecutedZmpConstraint.compute` in one compiled call: keep this tick's CoM c, CoM Jacobian J and
    (use_momentum) the angular rows of the centroidal map Ag (6, nv) in slot ``now`` of the memory W; then, when the
    previous tick is known (``dt_prev`` not NaN: the other slot's CoM c_prev, Jacobians J_prev, A_prev and command
    v_prev over dt_prev s, all finite), write the rows of the module docstring into C (rows 0..k−1 and the last one; the
    rows between are unused: 0 ≤ +inf) and u, l = −inf, else make every row inactive (0 ≤ +inf). Edge e of the
    shrunk polygon (outward normal (x, y), offset) is column e of rows _EDGES.._EDGES+2 of W, the constants (ground
    height z_g, mass, g, min_normal_ratio, use_momentum, edge count k) row _PARAMS. All kinematic quantities come from
    Pinocchio; this is assembly arithmetic only."""
    ground_z, mass, gravity = W[_PARAMS, 0], W[_PARAMS, 1], W[_PARAMS, 2]
    min_normal_ratio, use_momentum, k = W[_PARAMS, 3], W[_PARAMS, 4] != 0.0, int(W[_PARAMS, 5])
    nv = J.shape[1]
    s0 = now * 8
    p0 = (1 - now) * 8
    for i in range(3):
        W[s0, i] = c[i]
        for j in range(nv):
            W[s0 + 1 + i, j] = J[i, j]
            if use_momentum:
                W[s0 + 4 + i, j] = Ag[3 + i, j]
    last = C.shape[0] - 1
    for e in range(C.shape[0]):
        l[e] = -np.inf
    for e in range(k, last):
        for j in range(nv):
            C[e, j] = 0.0
        u[e] = np.inf
    h = c[2] - ground_z
    active = not np.isnan(dt_prev)
    if active:
        for j in range(nv):
            if not np.isfinite(W[p0 + 7, j]):
                active = False
                break
    if k == 0 or not active or h <= 0.0:
        for e in range(k):
            for j in range(nv):
                C[e, j] = 0.0
            u[e] = np.inf
        for j in range(nv):
            C[last, j] = 0.0
        u[last] = np.inf
        return
    # the previous tick: c_pred = c_{k−1} + J_{k−1} v_{k−1} dt (first-order prediction of c_k), L_{k−1} = A_{k−1} v_{k−1}
    sc = _SCRATCH  # c_pred [0:3], L_prev [3:6], r [6:9], dc [9:12]
    inv_mh = 1.0 / (mass * h)
    for i in range(3):  # one pass per row: the previous tick's products and J_eff = J + (J − J_{k−1})
        s = 0.0
        m = 0.0
        sd = 0.0
        for j in range(nv):
            vj = W[p0 + 7, j]
            jp = W[p0 + 1 + i, j]
            s += jp * vj
            m += W[p0 + 4 + i, j] * vj
            dj = J[i, j] - jp
            sd += dj * vj
            W[_J_EFF + i, j] = J[i, j] + dj
        W[sc, i] = W[p0, i] + s * dt_prev
        W[sc, 3 + i] = m
        W[sc, 6 + i] = (c[i] - W[sc, i]) - dt * sd
        W[sc, 9 + i] = c[i] - W[p0, i]
    r0, r1, r2 = W[sc, 6], W[sc, 7], W[sc, 8]
    d0, d1, d2 = W[sc, 9], W[sc, 10], W[sc, 11]
    for e in range(k):
        nx, ny = W[_EDGES, e], W[_EDGES + 1, e]
        se = W[_EDGES + 2, e] - (nx * c[0] + ny * c[1])
        a0, a1, a2 = -nx, -ny, se / -h
        u[e] = (se * gravity * dt * dt / h - (a0 * (r0 - d0) + a1 * (r1 - d1) + a2 * (r2 - d2))) / dt
        if use_momentum:
            e0, e1 = ny * inv_mh, -nx * inv_mh
            for j in range(nv):
                C[e, j] = (a0 * W[_J_EFF, j] + a1 * W[_J_EFF + 1, j] + a2 * W[_J_EFF + 2, j]) + (
                    e0 * W[s0 + 4, j] + e1 * W[s0 + 5, j])
            u[e] += e0 * W[sc, 3] + e1 * W[sc, 4]
        else:
            for j in range(nv):
                C[e, j] = a0 * W[_J_EFF, j] + a1 * W[_J_EFF + 1, j] + a2 * W[_J_EFF + 2, j]
    for j in range(nv):
        C[last, j] = -W[_J_EFF + 2, j]
    u[last] = (1.0 - min_normal_ratio) * gravity * dt + (r2 - d2) / dt


@once_per_process
def _warm_up() -> None:
    """Load :func:`_zmp_tick` (on-disk cache) once per process, at construction (C-ordered arrays, as Pinocchio's
    CoM Jacobian and centroidal map are)."""
    c, J, W = np.zeros(3), np.zeros((3, 1)), np.zeros((_PARAMS + 1, 12))
    W[_PARAMS, :6] = 0.0, 1.0, GRAVITY, 0.5, 1.0, 1.0
    _zmp_tick(c, J, np.zeros((6, 1)), W, 0, 0.002, 0.002, np.zeros((2, 1)), np.zeros(2), np.zeros(2))


class ExecutedZmpConstraint(InequalityConstraint):
    """ZMP of the executed CoM motion inside the support polygon shrunk by ``margin`` (module docstring).

    Args:
        robot: the robot (sole rectangle ``robot.sole_length`` × ``robot.sole_width``).
        margin: inward shrink of the support polygon (m, ≥ 0).
        min_normal_ratio: smallest vertical ground force as a fraction of the weight, in [0, 1): row
            c̈_z ≥ −(1 − min_normal_ratio) g.
        max_soles: most soles ever passed to :meth:`set_support` (rows: 4 × max_soles + 1).
        gravity: g (m/s², > 0); default None: the model's (``robot.gravity``).
        angular_momentum: include L̇ (the multi-body ZMP); False: L̇ = 0 (the CoM-only, LIPM-like ZMP).
        name: label in reports.

    Call :meth:`set_support` before the first solve (until then every row is inactive).

    Raises:
        InvalidInputError: negative or non-finite margin, min_normal_ratio outside [0, 1), gravity ≤ 0,
            max_soles < 1.
    """

    needs_previous_command = True
    relaxable = True
    # constants of the compiled tick, kept in its memory array (row _PARAMS): read-only after construction
    min_normal_ratio = ReadOnly("Smallest vertical ground force as a fraction of the weight, in [0, 1).")
    gravity = ReadOnly("g (m/s², > 0).")
    mass = ReadOnly("Total mass m of the model (kg).")
    angular_momentum = ReadOnly("Whether the rows include L̇ (the multi-body ZMP); False: the CoM-only ZMP.")
    ground_z = ReadOnly("Ground height z_g (m, world): the mean z of the soles of the last :meth:`set_support`.")

    def __init__(self, robot, *, margin: float = 0.002, min_normal_ratio: float = 0.5, max_soles: int = 2,
                 gravity: float | None = None, angular_momentum: bool = True, name: str = "executed_zmp"):
        self.robot, self.name = robot, name
        self.margin = check_scalar(margin, "margin", "m")
        self._min_normal_ratio = check_scalar(min_normal_ratio, "min_normal_ratio", "fraction of the weight")
        if self._min_normal_ratio >= 1.0:
            raise InvalidInputError(f"min_normal_ratio must be in [0, 1), got {min_normal_ratio!r}")
        self._gravity = check_scalar(robot.gravity if gravity is None else gravity, "gravity", "m/s²", strict=True)
        self.max_soles = check_count(max_soles, "max_soles")
        nv = robot.model.nv
        self.dim = 4 * self.max_soles + 1   # last row: the normal-force row
        self.nv = nv
        self.normals = np.zeros((0, 2))
        self.offsets = np.zeros(0)
        self._ground_z = 0.0
        self._C = np.zeros((self.dim, nv))
        self._l = np.full(self.dim, -np.inf)
        self._u = np.full(self.dim, np.inf)
        self._angular_momentum = bool(angular_momentum)
        self._model = robot.model
        self._data = robot.model.createData()
        self._mass = float(sum(i.mass for i in robot.model.inertias))
        # tick memory (:func:`_zmp_tick`): two slots of c, J_com, A_G,ang and a command; "now" = those of the last
        # compute (its dt), "rec" = the other slot, those of the tick whose command set_previous recorded (c_{k−1},
        # J_{k−1}, A_{k−1}, v_{k−1} over dt_{k−1}). set_previous writes the command into the now slot, which becomes
        # rec: no copy but the command's. Then the edges and constants rows (set by set_support)
        self._mem = np.zeros((_PARAMS + 1, max(nv, 12, self.dim)))
        self._mem[_PARAMS, :5] = 0.0, self._mass, self._gravity, self._min_normal_ratio, float(self._angular_momentum)
        self._v_rows = (self._mem[7, :nv], self._mem[_SLOT + 7, :nv])
        self._v_shape = (nv,)
        self._own_compute = type(self).compute is ExecutedZmpConstraint.compute
        self._ag_kept = None  # the last configuration seen keeping its centroidal map (keep_centroidal_map)
        self._slot = 0             # index of the now slot (rec: 1 − slot)
        self._dt_now = 0.0
        self._have_now = False
        self._now_in_rec = False   # set_previous since the last compute: its values are in rec
        self._rec_dt = 0.0
        self._rec_valid = False
        self._undo: tuple | None = None
        _warm_up()

    def set_support(self, sole_placements) -> None:
        """Support polygon = hull of the sole rectangles at these placements (pin.SE3 or (4, 4), world); the ground
        height is their mean z.

        Raises:
            InvalidInputError: no sole or more than ``max_soles``, malformed pose, polygon smaller than the margin.
        """
        poses = [as_se3(p, "sole placement") for p in sole_placements]
        if not 1 <= len(poses) <= self.max_soles:
            raise InvalidInputError(f"set_support needs 1..{self.max_soles} sole placements, got {len(poses)}")
        self.set_support_trusted(poses)

    def set_support_trusted(self, sole_placements) -> None:
        """:meth:`set_support` without validating the placements, for a controller's own support switches (e.g.
        :class:`~wbc.scenarios.stance.StanceController` with its contacts' placements, validated when they were
        set): ``sole_placements`` 1..``max_soles`` pin.SE3 with rotation blocks that are rotations. The polygon is
        built from plain floats (:func:`wbc.geometry.support_corners`), the same numbers as
        :func:`wbc.geometry.support_polygon`.

        Raises:
            InvalidInputError: polygon smaller than the margin.
        """
        length, width = self.robot.sole_length, self.robot.sole_width
        soles, ground = [], 0.0
        for M in sole_placements:
            t = M.translation
            soles.append((float(t[0]), float(t[1]), yaw_of(M)))
            ground += float(t[2])
        poly = support_corners(soles, length, width)
        # half-planes of the CCW polygon in plain floats: the arithmetic of com_polygon.halfplanes, edge by edge
        k = len(poly)
        cx, cy = sum(p[0] for p in poly) / k, sum(p[1] for p in poly) / k
        normals, offsets, inner = [], [], math.inf
        for i in range(k):
            (x0, y0), (x1, y1) = poly[i], poly[(i + 1) % k]
            ex, ey = x1 - x0, y1 - y0
            norm = math.sqrt(ey * ey + ex * ex)
            nx, ny = ey / norm, -ex / norm
            d = nx * x0 + ny * y0
            normals.append((nx, ny))
            offsets.append(d - self.margin)
            inner = min(inner, d - (nx * cx + ny * cy))
        if inner <= self.margin:
            raise InvalidInputError(f"{self.name}: support polygon is too small for margin {self.margin} m")
        self.normals, self.offsets = np.array(normals), np.array(offsets)
        self._ground_z = ground / len(sole_placements)
        mem = self._mem
        mem[_EDGES:_EDGES + 2, :k] = self.normals.T
        mem[_EDGES + 2, :k] = self.offsets
        mem[_PARAMS, 0], mem[_PARAMS, 5] = self._ground_z, k

    def reset(self) -> None:
        """Forget the previous tick (rows inactive until one tick has been solved): call after moving the robot
        by anything else than the controller's commands."""
        self._rec_valid = False
        self._have_now = False
        self._undo = None

    def _slot_arrays(self, slot: int) -> tuple:
        """Views (c (3,), J (3, nv), A (3, nv), v (nv,)) of a memory slot."""
        m, nv, r = self._mem, self.nv, slot * _SLOT
        return m[r, :3], m[r + 1:r + 4, :nv], m[r + 4:r + 7, :nv], m[r + 7, :nv]

    def state(self) -> tuple:
        """Snapshot of the tick memory (previous tick's CoM, CoM Jacobian, centroidal rows, command, period) for
        :meth:`restore`: to solve the same tick again after :meth:`set_previous` has been called with a command that
        is not sent (:meth:`undo_previous` does the same without copies)."""
        c, J, A, v = self._slot_arrays(1 - self._slot)
        return c.copy(), J.copy(), A.copy(), v.copy(), self._rec_dt, self._rec_valid

    def restore(self, state: tuple) -> None:
        """Back to a :meth:`state` snapshot; the next :meth:`set_previous` again refers to the configuration of
        the last :meth:`compute`."""
        c, J, A, v, dt, valid = state
        if self._now_in_rec:  # the last compute's values went to rec with set_previous: take them back
            self._slot = 1 - self._slot
            self._now_in_rec = False
        for dst, src in zip(self._slot_arrays(1 - self._slot), (c, J, A, v)):
            dst[...] = src
        self._rec_dt, self._rec_valid = dt, valid
        self._have_now = True
        self._undo = None

    def set_previous(self, v) -> None:
        """Record the command v (nv,) applied from the configuration of the last :meth:`compute`
        (:meth:`undo_previous` takes it back). A v that is not finite leaves the next tick's rows inactive."""
        if not self._have_now:
            self._undo = None
            return
        self._undo = (self._rec_dt, self._rec_valid)
        if not (type(v) is np.ndarray and v.shape == self._v_shape):
            v = np.asarray(v, dtype=float)
            if v.shape != self._v_shape:
                self._rec_valid = False
                self._have_now = False
                return
        slot = self._slot
        self._v_rows[slot][...] = v
        self._slot = 1 - slot  # the now slot becomes rec, the old rec slot the next now
        self._rec_dt = self._dt_now
        self._rec_valid = True
        self._now_in_rec = True
        self._have_now = False

    def undo_previous(self) -> None:
        """Take back the last :meth:`set_previous` (no-op when it recorded nothing or was already taken back): the
        tick memory is again that of before it and the next :meth:`set_previous` again refers to the configuration
        of the last :meth:`compute` — to solve the same tick once more, as :meth:`state` / :meth:`restore` do,
        without copying the memory every tick."""
        undo = self._undo
        if undo is None:
            return
        self._undo = None
        if self._now_in_rec:  # the slots back: the last compute's values are the now slot again
            self._slot = 1 - self._slot
        self._rec_dt, self._rec_valid = undo
        self._now_in_rec = False
        self._have_now = True

    def _rows_into(self, config: Configuration, dt: float, C: np.ndarray, l: np.ndarray, u: np.ndarray) -> None:
        """The rows of :meth:`compute` at ``config`` written into C (dim, nv), l, u (dim,) (its own buffers or a
        controller's rows), this tick's kinematics kept in the memory."""
        J = config.com_jacobian
        if not self._angular_momentum:
            Ag = J
        elif config is self._ag_kept or config.keeps_centroidal_map:  # computed by the configuration's update
            self._ag_kept = config  # (keep_centroidal_map is for good: asked once per configuration)
            Ag = config.centroidal_momentum_matrix
        else:  # on a Data of its own: computeCentroidalMap rewrites the CoM the configuration's data holds
            Ag = pin.computeCentroidalMap(self._model, self._data, config.q)
        # Δc = c_k − c_{k−1}; second-order part of this step, r(v) ≈ r_{k−1} + dt (J_k − J_{k−1})(v − v_{k−1})
        # (module docstring): c_{k+1} ≈ c_k + (2 J_k − J_{k−1}) v dt + r_{k−1} − dt (J_k − J_{k−1}) v_{k−1};
        # slack s_i = b_i − n_i·c_xy of the CoM to each shrunk edge; rows a_i = (−n_i, −s_i/h) on J, e_i/(m h) on
        # A_G,ang; last row −c̈_z ≤ (1 − ρ) g ⇔ −J_z v ≤ (1 − ρ) g dt + (r_z − Δc_z)/dt (compiled, one call)
        dt = float(dt)
        _zmp_tick(config.com, J, Ag, self._mem, self._slot, self._rec_dt if self._rec_valid else math.nan, dt, C, l,
                  u)
        self._dt_now = dt
        self._have_now = True
        self._now_in_rec = False
        self._undo = None

    def compute(self, config: Configuration, dt: float):
        """(C (dim, nv), l, u) of the module docstring; inactive rows are 0 ≤ +inf."""
        self._rows_into(config, dt, self._C, self._l, self._u)
        return self._C, self._l, self._u

    def write(self, ctx, M_rows: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> None:
        """The rows of :meth:`compute` written in place into C[rows] (dim, nv), l[rows], u[rows] (dim,) (a controller's
        stacked buffers) at ``ctx.config``, ``ctx.dt``; a subclass that overrides :meth:`compute` is written from it."""
        if self._own_compute:
            self._rows_into(ctx.config, ctx.dt, M_rows, lo, hi)
        else:
            super().write(ctx, M_rows, lo, hi)


class DcmPolygonConstraint(ComPolygonConstraint):
    """The divergent component of motion ξ = c + ċ/ω inside the support polygon shrunk by ``margin`` (module
    docstring): rows n_i·J_com,xy v ≤ max(ω s_i, −recovery_speed), ω = √(g / (c_z − z_ground)).

    Args: those of :class:`~wbc.constraints.ComPolygonConstraint`, plus ``gravity`` (m/s², > 0; default None:
    ``robot.gravity``). The ground height is the mean z of the soles given to :meth:`set_support`.
    """

    def __init__(self, robot, *, gravity: float | None = None, name: str = "dcm_polygon", **kwargs):
        gravity = check_scalar(robot.gravity if gravity is None else gravity, "gravity", "m/s²", strict=True)
        super().__init__(robot, name=name, **kwargs)
        self.gravity = gravity
        self.ground_z = 0.0

    def set_support(self, sole_placements) -> None:
        poses = [as_se3(p, "sole placement") for p in sole_placements]
        super().set_support(poses)
        self.ground_z = float(np.mean([M.translation[2] for M in poses]))

    def compute(self, config: Configuration, dt: float):
        k = len(self.offsets)
        if k:
            C, u = self._C, self._u
            np.matmul(self.normals, config.com_jacobian[:2], out=C[:k])
            h = max(float(config.com[2]) - self.ground_z, 1e-3)
            omega = math.sqrt(self.gravity / h)
            slack = self.offsets - self.margin - self.normals @ config.com[:2]
            u[:k] = np.maximum(np.minimum(omega * slack, slack / dt), -self.recovery_speed)
        return self._C, self._l, self._u
