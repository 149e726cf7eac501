"""Self-collision avoidance: a velocity damper on the coal distance of each close pair of collision bodies.

For a pair (o1, o2) at distance d (m) with witness points p1 ∈ o1, p2 ∈ o2 and unit normal n from o1 to o2
(coal, through ``pin.computeDistance``: d = nᵀ(p2 − p1), negative when they penetrate), the distance rate is
ḋ = nᵀ(ṗ2 − ṗ1), with ṗ_k the velocity of the material point of body k at p_k:

    ṗ_k = J_k,lin v + J_k,ang v × p_k      (J_k: WORLD Jacobian of o_k's parent joint — linear velocity of the
                                           body point at the world origin, angular velocity; ``data.J`` columns
                                           of the joint's support)
    ⇒  ḋ = [nᵀJ2,lin + (p2 × n)ᵀ J2,ang − nᵀJ1,lin − (p1 × n)ᵀ J1,ang] v.

Each pair closer than the activation distance d_i gets the velocity damper (Faverjon & Tournassoud, ICRA 1987;
Kanoun, Lamiraux, Wieber, IEEE T-RO 27(4) 2011: ḋ ≥ −ξ (d − d_s)/(d_i − d_s)), written with a gain
γ = ξ/(d_i − d_s) (1/s) capped at 1/dt:

    ḋ ≥ −γ (d − f)      with the pair's floor f = d_s, so d never drops below d_s: d⁺ − d_s ≥ (1 − γ dt)(d − d_s).

Pairs closer than d_s occur in reference postures (Talos ``half_sitting``: thighs 11.9 mm, torso–upper arms 14 mm
apart, convex hulls). Demanding that they separate at once can be infeasible (feet in contact lock the thighs), so
each pair keeps a ratcheting floor: f = min(d_s, max(f_prev, d) + recovery_speed·dt), starting at min(d_s, d) when
the pair is first seen. A pair that starts too close is kept from coming closer and is pushed apart at
``recovery_speed`` (default 0: only held); once it has separated past d_s its floor is d_s. The same damper pulls a
pair back up to its floor when the first-order step let it sink slightly below (linearisation error: the witness
points of polyhedra jump between faces), instead of letting that error accumulate.

d_s = ``min_distance`` + ``safety_margin`` (default 3 mm: the first-order dips described below stay above
``min_distance``). Distances come from coal; nothing is re-derived. By default the collision meshes are
replaced by their convex hulls (coal ``buildConvexHull``, qhull): GJK on hulls costs ~2 µs per pair against
~250 µs for mesh BVHs, and a hull contains its mesh, so the mesh distance is never smaller than the hull's. A
bounding-sphere test (one sphere per geometry, from coal's local AABB) skips the pairs that cannot be within d_i.

Default pairs: every pair of ``robot.collision_model`` minus the SRDF's ``disable_collisions`` (when
``robot.srdf_path`` is set) minus pairs on the same or on adjacent joints (parent–child in the kinematic tree).
The row count is fixed (``max_active``): the closest active pairs fill the rows, unused rows are −inf ≤ 0.

Limits (measured): one witness pair per body pair is a first-order model of a piecewise-smooth distance. When a
body rotates while sliding along another, a different vertex can become the closest one within a tick; the
damper then restores the floor over the next ticks. Driving a hand through the torso with the damper at 20 mm
(no safety margin): Talos min 19.6 mm, g1 (hulls of large non-convex meshes, fast wrist rotation) 18.3 mm; hence
the default 3 mm safety margin (with 2 mm, g1 still dipped to 19.84 mm). Broad phase (compiled): the sphere test, then
(``temporal_pruning``) a pair whose last coal distance minus a bound on how far its bodies moved since stays above
d_i is skipped (a rigorous lower bound: the same pairs get rows, their distances equal to GJK's tolerance). Measured on Talos (883 pairs; 2-core machine at
load ≈ 22, thread CPU time): standing, 78 pairs pass the sphere test, 34 need coal, 181 µs per call (310 µs before
the compiled broad phase and rows); driving the hand through the torso (load ≈ 20), 37.7 coal calls per tick
instead of 135.8, 627 µs instead of 970 µs per call (``benchmarks/self_collision.py``).
"""

from __future__ import annotations

import heapq
import math

import coal
import numba as nb
import numpy as np
import pinocchio as pin

from wbc.configuration import Configuration
from wbc.constraints.base import InequalityConstraint
from wbc.exceptions import InvalidInputError
from wbc.geometry import check_count, check_scalar

__all__ = ["SelfCollisionConstraint", "default_collision_pairs"]


@nb.njit(cache=True, nogil=True)
def _broad_phase(homogeneous, slot, centre_local, radius, pairs, activation, pruning, prev, moved, d_known,
                 moved_at, out, lower):
    """Candidate pairs (indices written to ``out``, count returned): bounding spheres closer than ``activation``
    and, with ``pruning``, ``d_known − (moved_a + moved_b − moved_at) < activation`` (nan d_known: never
    computed, a candidate). ``homogeneous`` (joints, 4, 4) placements of the joints carrying geometries, ``slot``
    (ngeoms,) a geometry's row in it; ``prev`` (joints, 4, 4) the placements of the previous call (NaN at the
    first), overwritten; ``moved`` (ngeoms,) each geometry's accumulated displacement bound, updated:
    |Δ centre| + ‖ΔR‖_F · radius per call."""
    ng = slot.shape[0]
    centre = np.empty((ng, 3))
    first = np.isnan(prev[0, 0, 0])
    for g in range(ng):
        s = slot[g]
        for i in range(3):
            c = homogeneous[s, i, 3]
            for j in range(3):
                c += homogeneous[s, i, j] * centre_local[g, j]
            centre[g, i] = c
        if pruning and not first:
            dc = 0.0
            dr = 0.0
            for i in range(3):
                pc = prev[s, i, 3]
                for j in range(3):
                    pc += prev[s, i, j] * centre_local[g, j]
                    e = homogeneous[s, i, j] - prev[s, i, j]
                    dr += e * e
                dc += (centre[g, i] - pc) ** 2
            moved[g] += np.sqrt(dc) + np.sqrt(dr) * radius[g]
    if pruning:
        prev[:] = homogeneous
    n = 0
    for k in range(pairs.shape[0]):
        a = pairs[k, 0]
        b = pairs[k, 1]
        d2 = 0.0
        for i in range(3):
            d2 += (centre[a, i] - centre[b, i]) ** 2
        gap = np.sqrt(d2) - radius[a] - radius[b]
        if gap >= activation:
            continue
        bound = d_known[k] - (moved[a] + moved[b] - moved_at[k])  # nan when never computed
        if pruning and bound >= activation:
            continue
        out[n] = k
        lower[n] = bound if pruning and bound > gap else gap
        n += 1
    return n


@nb.njit(cache=True, nogil=True)
def _damper_rows(normal, p1, p2, joint1, joint2, J, support, C):
    """C[r] = nᵀJ2,lin + (p2 × n)ᵀJ2,ang − nᵀJ1,lin − (p1 × n)ᵀJ1,ang restricted to each body's support columns
    (module docstring), for the rows r < normal.shape[0]."""
    nv = J.shape[1]
    for r in range(normal.shape[0]):
        n0, n1, n2 = normal[r, 0], normal[r, 1], normal[r, 2]
        for side in range(2):
            p = p2[r] if side == 1 else p1[r]
            sign = 1.0 if side == 1 else -1.0
            jt = joint2[r] if side == 1 else joint1[r]
            x0 = p[1] * n2 - p[2] * n1
            x1 = p[2] * n0 - p[0] * n2
            x2 = p[0] * n1 - p[1] * n0
            for c in range(nv):
                if support[jt, c] != 0.0:
                    C[r, c] += sign * (n0 * J[0, c] + n1 * J[1, c] + n2 * J[2, c]
                                       + x0 * J[3, c] + x1 * J[4, c] + x2 * J[5, c])


def _adjacent(model: pin.Model, j1: int, j2: int) -> bool:
    return j1 == j2 or model.parents[j1] == j2 or model.parents[j2] == j1


def default_collision_pairs(robot) -> list[tuple[int, int]]:
    """Geometry index pairs of ``robot.collision_model``: all pairs, minus the SRDF's ``disable_collisions``
    (if ``robot.srdf_path``), minus pairs whose parent joints are the same or parent and child."""
    gm = robot.collision_model.copy()
    gm.addAllCollisionPairs()
    if robot.srdf_path is not None:
        pin.removeCollisionPairs(robot.model, gm, str(robot.srdf_path), False)
    geoms = gm.geometryObjects
    return [(cp.first, cp.second) for cp in gm.collisionPairs
            if not _adjacent(robot.model, geoms[cp.first].parentJoint, geoms[cp.second].parentJoint)]


class SelfCollisionConstraint(InequalityConstraint):
    """Keep the watched collision pairs at least ``min_distance`` apart (module docstring).

    Args:
        robot: the robot (``collision_model`` and ``srdf_path`` are used).
        min_distance: d_s (m, ≥ 0).
        pairs: None (default set, module docstring) or a list of (name1, name2): geometry object names (e.g.
            ``"torso_2_link_0"``) or link/frame names (every geometry attached to that link).
        activation_distance: d_i (m, > min_distance): pairs farther apart get no row.
        gain: γ (1/s, > 0), capped at 1/dt.
        safety_margin: m (≥ 0) added to d_s by the damper, so the first-order dips of polyhedral distances
            (module docstring: up to 2.2 mm measured) stay above ``min_distance``.
        recovery_speed: rate (m/s, ≥ 0) at which the floor of a pair already closer than d_s rises towards d_s
            (0: the pair is only kept from coming closer).
        max_active: number of rows (the closest active pairs; ≥ 1).
        convex: use the convex hulls of mesh geometries (True, module docstring) or the meshes themselves.
        temporal_pruning: skip the coal distance of a pair while its last coal distance, minus a bound on how far
            each of its two bodies moved since (|Δ sphere centre| + ‖ΔR‖_F · sphere radius, summed over calls),
            stays ≥ the activation distance (a rigorous lower bound: the rows are those of the unpruned
            computation, distances equal to GJK's 1e-9 m tolerance: coal warm-starts each pair from its previous
            call, which pruning makes an older one), and compute
            the remaining candidates in increasing order of that bound, stopping once the bound exceeds the
            ``max_active``-th smallest distance found. False: coal for every pair that passes the sphere test.
        name: label in reports.

    Attributes:
        active: after each ``compute``, list of (geometry name 1, geometry name 2, distance m) of the pairs that
            got a row, closest first.

    Raises:
        InvalidInputError: inconsistent distances/gain, unknown names, or no pair left.
    """

    def __init__(self, robot, *, min_distance: float = 0.02, pairs=None, activation_distance: float = 0.1,
                 gain: float = 50.0, safety_margin: float = 0.003, recovery_speed: float = 0.0,
                 max_active: int = 32, convex: bool = True, temporal_pruning: bool = True,
                 name: str = "self_collision"):
        check_scalar(min_distance, "min_distance", "m")
        if not (math.isfinite(activation_distance) and activation_distance > min_distance):
            raise InvalidInputError(f"activation_distance must be > min_distance, got {activation_distance!r}")
        check_scalar(gain, "gain", "1/s", strict=True)
        check_scalar(safety_margin, "safety_margin", "m")
        check_scalar(recovery_speed, "recovery_speed", "m/s")
        check_count(max_active, "max_active")
        self.model = robot.model
        self.name = name
        self.min_distance = float(min_distance)
        self.activation_distance = float(activation_distance)
        self.gain = float(gain)
        self.recovery_speed = float(recovery_speed)
        self.safety_margin = float(safety_margin)
        self.dim = int(max_active)
        gm = robot.collision_model.copy()
        index_pairs = default_collision_pairs(robot) if pairs is None else self._resolve(robot.model, gm, pairs)
        if not index_pairs:
            raise InvalidInputError(f"{name}: no collision pair to watch")
        if convex:
            for geom in gm.geometryObjects:
                if isinstance(geom.geometry, coal.BVHModelBase):
                    geom.geometry.buildConvexHull(True, "Qt")  # qhull; True keeps faces (GJK hill climbing)
                    geom.geometry = geom.geometry.convex
        gm.removeAllCollisionPairs()
        for a, b in index_pairs:
            gm.addCollisionPair(pin.CollisionPair(a, b))
        self.geometry_model = gm
        self.geometry_data = pin.GeometryData(gm)
        for req in self.geometry_data.distanceRequests:
            req.gjk_tolerance = 1e-9  # default 1e-6 m: too coarse for the distance rate (noise / dt)
        self.pairs = np.array([(cp.first, cp.second) for cp in gm.collisionPairs], dtype=int)
        self.pair_names = [(gm.geometryObjects[int(a)].name, gm.geometryObjects[int(b)].name) for a, b in self.pairs]
        # bounding sphere of each geometry (centre in its parent joint frame, radius), from coal's local AABB
        geoms = np.unique(self.pairs)
        self._joint = np.array([int(geom.parentJoint) for geom in gm.geometryObjects], dtype=int)
        self._joints = [int(j) for j in np.unique(self._joint[geoms])]
        slot = {j: i for i, j in enumerate(self._joints)}
        self._slot = np.array([slot.get(int(j), 0) for j in self._joint], dtype=int)
        self._centre_local = np.zeros((gm.ngeoms, 3))
        self._radius = np.zeros(gm.ngeoms)
        for g in geoms:
            geom = gm.geometryObjects[int(g)]
            geom.geometry.computeLocalAABB()
            self._centre_local[g] = geom.placement.act(np.asarray(geom.geometry.aabb_center))
            self._radius[g] = geom.geometry.aabb_radius
        # velocity of a point p of joint j's body: columns of data.J (WORLD) in j's support, ṗ = v_O + ω × p
        self._support = np.zeros((self.model.njoints, self.model.nv))
        for j in range(1, self.model.njoints):
            for i in self.model.supports[j]:
                joint = self.model.joints[i]
                if i > 0:
                    self._support[j, joint.idx_v:joint.idx_v + joint.nv] = 1.0
        self._C = np.zeros((self.dim, self.model.nv))
        self._l = np.full(self.dim, -np.inf)
        self._u = np.full(self.dim, np.inf)
        self.active: list[tuple[str, str, float]] = []
        self._floor = np.full(len(self.pairs), np.nan)
        self.temporal_pruning = bool(temporal_pruning)
        self._forget_distances()

    @staticmethod
    def _resolve(model: pin.Model, gm: pin.GeometryModel, pairs) -> list[tuple[int, int]]:
        def geoms(name: str) -> list[int]:
            if gm.existGeometryName(name):
                return [gm.getGeometryId(name)]
            found = [i for i, g in enumerate(gm.geometryObjects) if model.frames[g.parentFrame].name == name]
            if not found:
                raise InvalidInputError(f"no collision geometry or link named {name!r}")
            return found

        out = []
        for pair in pairs:
            if len(pair) != 2:
                raise InvalidInputError(f"a collision pair is two names, got {pair!r}")
            for a in geoms(pair[0]):
                for b in geoms(pair[1]):
                    if a != b:
                        out.append((min(a, b), max(a, b)))
        return sorted(set(out))

    def _candidates(self, data: pin.Data) -> np.ndarray:
        """Pair indices that may be closer than the activation distance: their bounding spheres are, and (with
        ``temporal_pruning``) so may their last coal distance minus how far the two bodies moved since then:
        every point p of a geometry moved by at most |Δc| + ‖ΔR‖₂ r ≤ |Δc| + ‖ΔR‖_F r per call (c its sphere
        centre, r its radius, R its joint's rotation: p − c = R (p_local − c_local)), and a distance is
        1-Lipschitz in each body's displacement: d_now ≥ d_then − moved_a − moved_b."""
        oMi = data.oMi
        homogeneous = np.array([oMi[j].homogeneous for j in self._joints])  # (joints, 4, 4)
        n = _broad_phase(homogeneous, self._slot, self._centre_local, self._radius, self.pairs,
                         self.activation_distance, self.temporal_pruning, self._prev, self._moved, self._d_known,
                         self._moved_at, self._cand, self._lower)
        return self._cand[:n], self._lower[:n]

    def distances(self, config: Configuration, pair_indices=None) -> np.ndarray:
        """Coal distances (m) of the watched pairs (all, or ``pair_indices``) at ``config``."""
        gm, gd = self.geometry_model, self.geometry_data
        pin.updateGeometryPlacements(self.model, config.data, gm, gd)
        idx = range(len(self.pairs)) if pair_indices is None else pair_indices
        return np.array([pin.computeDistance(gm, gd, int(k)).min_distance for k in idx])

    def _closest(self, cand: np.ndarray, lower: np.ndarray) -> tuple[np.ndarray, list]:
        """Coal distances of the candidates in increasing order of their distance lower bound, stopping once the
        next bound exceeds the ``max_active``-th smallest distance below the activation distance found so far
        (a pair left out is farther than every pair that gets a row). Returns (computed pair indices in their
        original order, their coal results)."""
        gm, gd = self.geometry_model, self.geometry_data
        act, k_max = self.activation_distance, self.dim
        heap: list[float] = []  # −distance of the k_max closest pairs within the activation distance
        done, results = [], []
        for i in np.argsort(lower, kind="stable").tolist():
            if len(heap) == k_max and lower[i] > -heap[0]:
                break
            res = pin.computeDistance(gm, gd, int(cand[i]))
            done.append(i)
            results.append(res)
            d = res.min_distance
            if d < act:
                if len(heap) < k_max:
                    heapq.heappush(heap, -d)
                elif d < -heap[0]:
                    heapq.heapreplace(heap, -d)
        perm = np.argsort(done, kind="stable")
        return cand[np.asarray(done)[perm]], [results[p] for p in perm.tolist()]

    def compute(self, config: Configuration, dt: float):
        """(C (max_active, nv), l, u) with one velocity-damper row per active pair (module docstring)."""
        C, l, d, floor, _ = self._rows(config, dt)
        m = d.size
        if m:
            l[:m] = -min(self.gain, 1.0 / dt) * (d - floor)
        return C, l, self._u

    def barrier(self, state, dt: float):
        """(h (max_active,) m, G (max_active, nv), Ġv (max_active,) m/s²) at a DynamicsState: per active pair
        h = d − f (its floor, module docstring), G the damper row (ḋ = G v), and Ġv = nᵀ(p̈2 − p̈1) with p̈_k the
        classical acceleration at v̇ = 0 of body k's material point at its witness point (Pinocchio's joint
        velocity and acceleration ``data.v``, ``data.a``). The terms of the witness normal's rotation
        (2ṅᵀ(ṗ2 − ṗ1) − d|ṅ|²) are left out: first order in the bodies' relative angular velocity, they vanish for
        translating bodies. Unused rows: h = +inf."""
        C, _, d, floor, found = self._rows(state, dt)
        m = d.size
        h = np.full(self.dim, np.inf)
        drift = np.zeros(self.dim)
        if m:
            h[:m] = d - floor
            data = state.data
            for r, (_, k, res) in enumerate(found):
                n = np.asarray(res.normal)
                acc = []
                for side, p in ((0, res.getNearestPoint1()), (1, res.getNearestPoint2())):
                    j = int(self._joint[self.pairs[k, side]])
                    at = pin.SE3(np.eye(3), data.oMi[j].actInv(np.asarray(p)))  # the point, joint axes
                    v, a = at.actInv(data.v[j]), at.actInv(data.a[j])
                    acc.append(data.oMi[j].rotation @ (a.linear + np.cross(v.angular, v.linear)))
                drift[r] = n @ (acc[1] - acc[0])
        return h, C, drift

    def _rows(self, config: Configuration, dt: float):
        """(C with the damper rows of the active pairs, l with unused rows at −inf, d (m,), floors (m,), found
        [(d, pair index, coal result)]) for the m active pairs, closest first; updates the floors."""
        model, data = self.model, config.data
        gm, gd = self.geometry_model, self.geometry_data
        pin.updateGeometryPlacements(model, data, gm, gd)
        cand, lower = self._candidates(data)
        if self.temporal_pruning and cand.size > self.dim:
            cand, results = self._closest(cand, lower)
        else:
            results = [pin.computeDistance(gm, gd, k) for k in cand.tolist()]
        dist = np.array([res.min_distance for res in results])
        if self.temporal_pruning and cand.size:
            self._d_known[cand] = dist
            self._moved_at[cand] = self._moved[self.pairs[cand, 0]] + self._moved[self.pairs[cand, 1]]
        within = np.flatnonzero(dist < self.activation_distance)
        order = within[np.argsort(dist[within], kind="stable")][:self.dim]  # closest first
        found = [(results[i].min_distance, int(cand[i]), results[i]) for i in order.tolist()]
        m = len(found)
        C, l = self._C, self._l
        C[m:] = 0.0
        l[m:] = -np.inf
        self.active = [(*self.pair_names[k], float(d)) for d, k, _ in found]
        if not m:
            return C, l, np.zeros(0), np.zeros(0), found
        d = np.array([item[0] for item in found])
        k = np.array([item[1] for item in found])
        n = np.array([item[2].normal for item in found])
        p1 = np.array([item[2].getNearestPoint1() for item in found])
        p2 = np.array([item[2].getNearestPoint2() for item in found])
        C[:m] = 0.0
        # data.J: (6, nv) joint Jacobians in WORLD, filled by computeJointJacobians (Configuration.update)
        _damper_rows(n, p1, p2, self._joint[self.pairs[k, 0]], self._joint[self.pairs[k, 1]], data.J,
                     self._support, C)
        ds = self.min_distance + self.safety_margin
        prev = self._floor[k]
        floor = np.minimum(ds, np.where(np.isnan(prev), d, np.fmax(prev, d) + self.recovery_speed * dt))
        self._floor[k] = floor
        return C, l, d, floor, found

    def reset(self) -> None:
        """Forget the per-pair floors (module docstring), e.g. after teleporting the robot."""
        self._floor[:] = np.nan
        self._forget_distances()

    def _forget_distances(self) -> None:
        self._d_known = np.full(len(self.pairs), np.nan)
        self._moved_at = np.zeros(len(self.pairs))
        self._moved = np.zeros(self.geometry_model.ngeoms)
        self._prev = np.full((len(self._joints), 4, 4), np.nan)
        self._cand = np.empty(len(self.pairs), dtype=np.int64)
        self._lower = np.empty(len(self.pairs))
