"""Self-collision avoidance: a velocity damper on the coal distance of each close pair of collision bodies.

For a pair (o1, o2) at distance d (m) with witness points p1 ∈ o1, p2 ∈ o2 and unit normal n from o1 to o2
(coal, through ``pin.computeDistance``: d = nᵀ(p2 − p1), negative when they penetrate), the distance rate is
ḋ = nᵀ(ṗ2 − ṗ1), with ṗ_k the velocity of the material point of body k at p_k:

    ṗ_k = J_k,lin v + J_k,ang v × p_k      (J_k: WORLD Jacobian of o_k's parent joint — linear velocity of the
                                           body point at the world origin, angular velocity; ``data.J`` columns
                                           of the joint's support)
    ⇒  ḋ = [nᵀJ2,lin + (p2 × n)ᵀ J2,ang − nᵀJ1,lin − (p1 × n)ᵀ J1,ang] v.

Only the witness line matters: p2 = p1 + d n gives p2 × n = p1 × n, so coal's p1 and n are read and p2 is taken
on that line (coal's own p2 is on it to its GJK tolerance: within 2.3e-16 m on Talos).

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
replaced by their convex hulls (coal ``buildConvexHull``, qhull): GJK on a hull is about a hundred times cheaper
than on a mesh BVH, and a hull contains its mesh, so the mesh distance is never smaller than the hull's.

Default pairs: every pair of ``robot.collision_model`` minus the SRDF's ``disable_collisions`` (when
``robot.srdf_path`` is set) minus pairs on the same or on adjacent joints (parent–child in the kinematic tree).
The row count is fixed (``max_active``): the closest active pairs fill the rows, unused rows are −inf ≤ 0.

Limits: one witness pair per body pair is a first-order model of a piecewise-smooth distance. When a body
rotates while sliding along another, a different vertex can become the closest one within a tick; the damper then
restores the floor over the next ticks. Driving a hand through the torso with the damper at 20 mm and no safety
margin, the distance dips below the floor by up to a few millimetres (``benchmarks/README.md``); hence the
default 3 mm safety margin.

Broad phase (``broad_phase=True``; one compiled pass over the pairs, then coal on the candidates only: the
narrow phase below). Each geometry g has a bounding sphere
(centre c_g in its joint's frame and radius r_g, from coal's local AABB: the sphere around the box contains the
geometry). Placements are taken in the root joint's frame (``data.oMi``; a distance does not depend on the frame,
and this one leaves out the floating base's motion). Per call and geometry, every point p = c_g + R (p_loc − c_loc)
moves by at most |Δc_g| + ‖ΔR‖₂ r_g = |Δc_g| + ‖ΔR‖_F r_g / √2 (ΔR = R₁ − R₀ = R₀(R₀ᵀR₁ − I), whose singular values
are 2 sin(θ/2) twice and 0 for a rotation by θ; rotations orthonormal to rounding, which BOUND_SLACK covers); these
are summed since the start (``moved_g``). A distance
is 1-Lipschitz in each body's displacement, so for a pair (a, b) last computed by coal at distance d_k:

    L_k = max(|c_a − c_b| − r_a − r_b,  d_k − (moved_a + moved_b − moved_at_k))  ≤  d  ≤  U_k = d_k + (...)

(U = ∞ for a pair never computed). The summed motions bound the pair's relative motion loosely (both bodies moving
with the floating base's correction, or back and forth): where that bound leaves a computed pair in question, the
displacement since d_k of the points of one body in the other's frame bounds it instead, from the pair's relative
placement kept when coal computed it (the smaller-radius geometry m in the other's frame f: sphere centre
R_fᵀ(c_m − c_f) and rotation R_fᵀR_m; |Δc| + ‖ΔR‖_F r_m / √2), and the smaller of the two bounds is used in L_k
(for a pair that was no candidate at the previous call: one that was has one call's motion summed). When it is the
relative one, it replaces the summed motions in L_k and U_k, which then count on from it.
The sphere gap is kept likewise: recomputed only when its value at its last computation minus the summed motions
since then is below the cut-offs (a far pair costs one comparison per call).
With τ = the ``max_active``-th smallest U_k below d_i (d_i if fewer), coal runs
only on the pairs with L_k < d_i and L_k ≤ τ: any other pair is farther than d_i, or farther than ``max_active``
pairs that are computed. The rows are therefore those of coal on every pair (``broad_phase=False``, the
reference): same pairs, distances equal to coal's tolerances (GJK 1e-9 m; coal warm-starts a pair from its previous
call, so a pair computed at fewer calls can end elsewhere within tolerance; EPA 1e-6 m when penetrating) —
``tests/constraints/test_self_collision.py`` checks this against coal on all pairs along the hand-through-torso drive and
under random motion and jumps. No static pruning beyond the SRDF and adjacency: a far pair costs a few
floating-point operations per call.

Narrow phase (``compiled``). The compiled one, ``wbc.constraints.narrow_phase`` (C++, ``narrow_phase.cpp``, built by
``wbc compile`` against the ``libcoal`` wheel's headers: :mod:`wbc.constraints.narrow_phase_build`), owns its own
coal geometries (the same shapes; a mesh's hull is rebuilt by coal's ``ConvexBase::convexHull`` from the same vertices and qhull command
as ``buildConvexHull``), one ``coal::ComputeDistance`` functor, request and result per pair as
``pinocchio::GeometryData`` has (coal keeps a pair's GJK guess in its request), and the geometry placements
oMg = oMi · jMg as ``pin.updateGeometryPlacements`` computes them: one call computes the candidates' distances,
witness points and normals — bitwise those of Pinocchio's ``computeDistances`` (tests/constraints/test_self_collision.py),
without one bound call per value read back. The joint placements ``data.oMi`` are read as a view of the Data's
own memory (:func:`joint_placements_view`, checked when built), not one bound call per joint. Without the
extension (no C++ compiler at install), with meshes and ``convex=False``, or with ``compiled=False``: Pinocchio's
``computeDistances`` on a ``GeometryData`` whose active pairs are the candidates, results read through the bindings.

Cost per call and of the controller tick, with and without the compiled narrow phase:
``python benchmarks/self_collision.py`` (results in ``benchmarks/README.md``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import coal
import numpy as np
import pinocchio as pin

from wbc.configuration import Configuration
from wbc.constraints.base import InequalityConstraint
from wbc.constraints.narrow_phase_build import BUILD_HINT
from wbc.compiled import CHECK_TYPES, specialise
from wbc.constraints.self_collision_kernels import (BroadPhaseState, DamperRows, broad_phase, close_pairs,
                                                   close_pairs_damper, damper_rows, narrow_phase_done, pair_dampers)
from wbc.exceptions import InvalidInputError
from wbc.geometry import check_count, check_scalar

try:  # the compiled narrow phase (C++ on coal, built by wbc compile: wbc.constraints.narrow_phase_build)
    from wbc.constraints import narrow_phase as compiled_narrow_phase
except ImportError as error:
    compiled_narrow_phase = None
    COMPILED_NARROW_PHASE_MISSING = (f"wbc.constraints.narrow_phase was not built or does not load ({error}); "
                                     f"{BUILD_HINT}")
else:
    COMPILED_NARROW_PHASE_MISSING = (
        None if compiled_narrow_phase.coal_version == coal.__version__ else
        f"wbc.constraints.narrow_phase was built against coal {compiled_narrow_phase.coal_version}, "
        f"coal {coal.__version__} is loaded ({BUILD_HINT})")

__all__ = ["ClosePairs", "SelfCollisionConstraint", "default_collision_pairs", "joint_placements_view"]


#: m, coal's GJK tolerance for every pair (coal's default 1e-6 m is too coarse for the distance rate: noise / dt)
GJK_TOLERANCE = 1e-9



def _shape(geometry, convex: bool):
    """The compiled narrow phase's description of a coal geometry (``narrow_phase.cpp``: ``make_shape``), or None
    if it has none (meshes without ``convex``, other shapes, swept-sphere radii)."""
    if isinstance(geometry, coal.BVHModelBase):
        # the hull is rebuilt by coal from the same vertices and qhull command as buildConvexHull(True, "Qt")
        return ("hull", np.ascontiguousarray(geometry.vertices(), dtype=np.float64)) if convex else None
    if not isinstance(geometry, coal.ShapeBase) or geometry.getSweptSphereRadius() != 0.0:
        return None
    if isinstance(geometry, coal.Box):
        return ("box", *(2.0 * np.asarray(geometry.halfSide, dtype=float)).tolist())
    if isinstance(geometry, coal.Sphere):
        return ("sphere", float(geometry.radius))
    if isinstance(geometry, (coal.Cylinder, coal.Capsule)):
        kind = "cylinder" if isinstance(geometry, coal.Cylinder) else "capsule"
        return (kind, float(geometry.radius), 2.0 * float(geometry.halfLength))
    return None


def joint_placements_view(data: pin.Data) -> np.ndarray | None:
    """A read-only (njoints, 12) float64 view of the joint placements ``data.oMi`` in ``data``'s own memory (per
    joint j, the placement of joint j in WORLD: its rotation matrix column-major, then its translation in m), or None
    if the memory is not laid out that way.

    Args:
        data: a ``pin.Data`` (its ``oMi``, filled by forward kinematics).

    Raises:
        InvalidInputError: ``data`` is not a ``pin.Data``.

    Pinocchio's bindings (eigenpy) give ``data.oMi[j].rotation`` and ``.translation`` as NumPy views of the
    C++ ``SE3`` objects in ``data.oMi`` (a std::vector); this view spans them all. It is checked here, not assumed:
    every joint's rotation and translation must be at the addresses and strides of one (njoints, 12) C-contiguous
    array of float64, and the view must equal them. The view follows ``data`` (forward kinematics write in place) and
    is valid while ``data`` lives: the caller keeps ``data`` alive as long as it uses the view."""
    if not isinstance(data, pin.Data):
        raise InvalidInputError(f"joint_placements_view takes a pin.Data, got {type(data).__name__}")
    placements = data.oMi
    nj = len(placements)

    def address(a):
        return a.__array_interface__["data"][0]

    first = placements[0].rotation
    base = address(first)
    for j, M in enumerate(placements):
        rotation, translation = M.rotation, M.translation
        if (rotation.strides != (8, 24) or translation.strides != (8,) or address(rotation) != base + 96 * j
                or address(translation) != base + 96 * j + 72 or rotation.dtype != np.float64):
            return None
    view = np.lib.stride_tricks.as_strided(first, shape=(nj, 12), strides=(96, 8), writeable=False)
    for j, M in enumerate(placements):
        if not (np.array_equal(view[j, :9], M.rotation.ravel(order="F"))
                and np.array_equal(view[j, 9:], M.translation)):
            return None
    return view


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


class ClosePairs(NamedTuple):
    """The pairs closer than the activation distance at one configuration, closest first (at most ``max_active``).

    Attributes:
        pairs: (m,) indices into ``SelfCollisionConstraint.pairs``.
        distance: (m,) coal distances (m; negative when penetrating).
        normal: (m, 3) unit normals from body 1 to body 2, WORLD frame (coal's).
        p1, p2: (m, 3) witness points on body 1 (coal's) / body 2 (p1 + distance · normal: the point of the
            witness line on body 2; coal's own differs by its GJK tolerance),
            WORLD frame (m).
    """

    pairs: np.ndarray
    distance: np.ndarray
    normal: np.ndarray
    p1: np.ndarray
    p2: np.ndarray


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
            (module docstring) stay above ``min_distance``.
        recovery_speed: rate (m/s, ≥ 0) at which the floor of a pair already closer than d_s rises towards d_s
            (0: the pair is only kept from coming closer).
        max_active: number of rows (the closest active pairs; ≥ 1).
        convex: use the convex hulls of mesh geometries (True, module docstring) or the meshes themselves.
        broad_phase: True: coal only for the pairs whose distance bounds (module docstring: broad phase) leave
            them possibly among the ``max_active`` closest pairs within the activation distance (same rows as
            False, which calls coal for every pair at every call: the exhaustive reference).
        compiled: the narrow phase (module docstring): True: the compiled extension
            ``wbc.constraints.narrow_phase`` (raises if it is unavailable or a watched geometry has no compiled
            description); False: Pinocchio's ``computeDistances`` and the Python bindings; None (default): the
            compiled one when possible. Both give bitwise the same distances, witness points and normals.
        name: label in reports.

    Attributes:
        pairs: (npairs, 2) geometry indices of the watched pairs; ``pair_names`` their geometry names.
        active: after each ``compute``, list of (geometry name 1, geometry name 2, distance m) of the pairs that
            got a row, closest first.
        coal_calls: number of coal distances computed by the last ``compute``/``close_pairs``.
        narrow_phase: ``"compiled"`` or ``"pinocchio"``: which narrow phase runs; ``narrow_phase_note`` why the
            compiled one does not (None when it does).

    Raises:
        InvalidInputError: inconsistent distances/gain, unknown names, no pair left, or ``compiled=True`` without
            the compiled narrow phase (the message says why).
    """

    def __init__(self, robot, *, min_distance: float = 0.02, pairs=None, activation_distance: float = 0.1,
                 gain: float = 50.0, safety_margin: float = 0.003, recovery_speed: float = 0.0,
                 max_active: int = 32, convex: bool = True, broad_phase: bool = True,
                 compiled: bool | None = None, name: str = "self_collision"):
        check_scalar(min_distance, "min_distance", "m")
        if not (math.isfinite(activation_distance) and activation_distance > min_distance):
            raise InvalidInputError(f"activation_distance must be > min_distance, got {activation_distance!r}")
        check_scalar(gain, "gain", "1/s", strict=True)
        check_scalar(safety_margin, "safety_margin", "m")
        check_scalar(recovery_speed, "recovery_speed", "m/s")
        check_count(max_active, "max_active")
        if compiled is not None and not isinstance(compiled, (bool, np.bool_)):
            raise InvalidInputError(f"compiled must be None (the compiled narrow phase when possible), True or False, "
                                    f"got {compiled!r}")
        self.model = model = robot.model
        self.name = name
        self.min_distance = float(min_distance)
        self.activation_distance = float(activation_distance)
        self.gain = float(gain)
        self.recovery_speed = float(recovery_speed)
        self.safety_margin = float(safety_margin)
        self.dim = int(max_active)
        gm = robot.collision_model.copy()
        index_pairs = default_collision_pairs(robot) if pairs is None else self._resolve(model, gm, pairs)
        if not index_pairs:
            raise InvalidInputError(f"{name}: no collision pair to watch")
        in_pairs = {g for pair in index_pairs for g in pair}
        shapes = [_shape(geom.geometry, convex) if g in in_pairs else None
                  for g, geom in enumerate(gm.geometryObjects)]
        if convex:
            for geom in gm.geometryObjects:
                if isinstance(geom.geometry, coal.BVHModelBase):
                    geom.geometry.buildConvexHull(True, "Qt")  # qhull; True keeps faces (GJK hill climbing)
                    geom.geometry = geom.geometry.convex
        gm.removeAllCollisionPairs()
        for a, b in index_pairs:
            gm.addCollisionPair(pin.CollisionPair(a, b))
        self.geometry_model = gm
        self.geometry_data = gd = pin.GeometryData(gm)
        for req in gd.distanceRequests:
            req.gjk_tolerance = GJK_TOLERANCE
        self._results = list(gd.distanceResults)  # references into gd (filled in place by computeDistances)
        result = type(self._results[0])
        # per call, the rows' witness points and normals are read with these unbound getters mapped over the rows'
        # results, and their (3,) arrays joined into one buffer (bytes.join: 0.7× np.concatenate's time)
        self._witness = (result.getNearestPoint1, result.normal.fget)
        self._distance = result.min_distance.fget
        self._homogeneous = pin.SE3.homogeneous.fget
        self._activate, self._deactivate = gd.activateCollisionPair, gd.deactivateCollisionPair
        self.pairs = np.array([(cp.first, cp.second) for cp in gm.collisionPairs], dtype=np.int64)
        self.pair_names = [(gm.geometryObjects[int(a)].name, gm.geometryObjects[int(b)].name) for a, b in self.pairs]
        npairs = len(self.pairs)
        # bounding sphere of each geometry (centre in its parent joint frame, radius), from coal's local AABB
        geoms = np.unique(self.pairs)
        self._joint = np.array([int(geom.parentJoint) for geom in gm.geometryObjects], dtype=np.int64)
        self._centre_local = np.zeros((gm.ngeoms, 3))
        self._radius = np.zeros(gm.ngeoms)
        for g in geoms:
            geom = gm.geometryObjects[int(g)]
            geom.geometry.computeLocalAABB()
            self._centre_local[g] = geom.placement.act(np.asarray(geom.geometry.aabb_center))
            self._radius[g] = geom.geometry.aabb_radius
        self._pair_joint = self._joint[self.pairs]  # (npairs, 2)
        self.broad_phase = bool(broad_phase)
        # reference frame of the broad phase's displacements: the root joint (its motion moves every body alike)
        self._ref = 1 if model.njoints > 1 else 0
        # velocity of a point p of joint j's body: columns of data.J (WORLD) in j's support, ṗ = v_O + ω × p
        # (row j: the count, then the columns; a dense 0/1 mask cost a branch per pair, side and column)
        self._support = np.zeros((model.njoints, 1 + model.nv), dtype=np.int32)
        for j in range(1, model.njoints):
            cols = sorted(c for i in model.supports[j] if i > 0
                          for c in range(model.joints[i].idx_v, model.joints[i].idx_v + model.joints[i].nv))
            self._support[j, 0] = len(cols)
            self._support[j, 1:1 + len(cols)] = cols
        self._C = np.zeros((self.dim, model.nv))
        self._l = np.full(self.dim, -np.inf)
        self._u = np.full(self.dim, np.inf)
        self._empty = np.zeros((0, 3))
        self._on = np.zeros(npairs, dtype=bool)  # the pairs active in geometry_data (broad phase)
        self._toggle = np.empty(npairs, dtype=np.int64)
        self._cand = np.empty(npairs, dtype=np.int64)
        self._buf = np.empty(npairs)
        self._rows = np.empty(self.dim, dtype=np.int64)
        # row of each active pair (compute; −1: none), pair of each row (−1: unused), row of each close pair
        self._slot_of = np.full(npairs, -1, dtype=np.int64)
        self._in_slot = np.full(self.dim, -1, dtype=np.int64)
        self._slot = np.empty(self.dim, dtype=np.int64)
        self._identity = np.arange(self.dim, dtype=np.int64)
        self._rows_at = None  # (config, dt) of the rows in _C/_l (compute), with _rows_q its q; None: stale
        self._rows_q = np.empty(model.nq)
        self._floor = np.full(npairs, np.nan)
        self._d_known = np.full(npairs, np.inf)
        self._exact = np.zeros(npairs, dtype=bool)
        self._moved = np.zeros(gm.ngeoms)
        self._moved_at = np.zeros(npairs)
        self._prev_c = np.zeros((gm.ngeoms, 3))
        self._prev_r = np.zeros((model.njoints, 3, 3))
        self._first = True
        self._placements_of = None  # (data, its joint placements view or None): _joint_placements
        self._gap_known = np.full(npairs, -np.inf)
        # the compiled kernels' workspaces (wbc.constraints.self_collision_kernels), of the arrays above
        self._state = BroadPhaseState(
            self._ref, self.dim, self._joint, self._centre_local, self._radius, self.pairs, self._prev_c, self._prev_r,
            self._moved, self._moved_at, self._d_known, self._exact, self._on, self._toggle, self._cand, self._buf,
            self._rows, np.zeros((npairs, 12)), np.zeros(12), self._gap_known, np.zeros(npairs))
        self._damper_rows = DamperRows(self._pair_joint, self._support, self._C, self._l, self._floor, self._slot_of,
                                       self._in_slot, self._slot)
        # their compiled versions for the argument types of the first call, which are fixed (wbc.compiled.specialise;
        # with kernel type checks on, the dispatchers)
        self._broad_kernel = self._close_kernel = self._damper_kernel = None
        self._found = ClosePairs(np.zeros(0, dtype=np.int64), np.zeros(0), self._empty, self._empty, self._empty)
        self.coal_calls = 0
        note = COMPILED_NARROW_PHASE_MISSING
        if note is None:
            unsupported = [gm.geometryObjects[g].name for g in sorted(in_pairs) if shapes[g] is None]
            if unsupported:
                note = (f"no compiled description of geometries {unsupported[:3]}{'...' if len(unsupported) > 3 else ''}"
                        " (meshes need convex=True; boxes, spheres, cylinders, capsules)")
        if compiled and note is not None:
            raise InvalidInputError(f"{name}: compiled=True, but {note}")
        self._pair_set = None
        self.narrow_phase, self.narrow_phase_note = "pinocchio", note if compiled is None else "compiled=False"
        if compiled is not False and note is None:
            placements = np.array([geom.placement.homogeneous for geom in gm.geometryObjects])
            self._pair_set = compiled_narrow_phase.new(shapes, placements, self._joint.copy(), self.pairs.copy(),
                                                       model.njoints, GJK_TOLERANCE)
            self._wit = np.empty(7 * npairs)  # distances, witness points p1, normals of the candidates
            self.narrow_phase, self.narrow_phase_note = "compiled", None
        if self.broad_phase:
            gd.deactivateAllCollisionPairs()  # then switched per call (_on)
        else:
            self._cand[:] = np.arange(npairs)
            for k in range(npairs):
                gd.activateCollisionPair(k)

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

    def distances(self, config: Configuration, pair_indices=None) -> np.ndarray:
        """Coal distances (m) of the watched pairs (all, or ``pair_indices``) at ``config`` (no broad phase)."""
        gm, gd = self.geometry_model, self.geometry_data
        pin.updateGeometryPlacements(self.model, config.data, gm, gd)
        idx = range(len(self.pairs)) if pair_indices is None else pair_indices
        return np.array([pin.computeDistance(gm, gd, int(k)).min_distance for k in idx])

    def close_pairs(self, config: Configuration) -> ClosePairs:
        """The (at most ``max_active``) pairs closer than the activation distance at ``config``, closest first, with
        their coal distances, normals and witness points (:class:`ClosePairs`: arrays of this call, not updated by
        later calls). ``config.data`` must hold the joint placements of ``config.q`` (as after
        ``Configuration.update``). With ``broad_phase``, coal runs only on the candidates of the module docstring's
        bounds, which are updated from the placements of the previous call (any jump is accounted for); the
        result is the same as without."""
        self._narrow(config)
        return self._found

    def _narrow(self, config: Configuration, damper: tuple | None = None) -> bool:
        """Broad phase, coal on the candidates, the rows' witness points and normals: fills ``self._found``. With
        ``damper`` (``pair_dampers``'s arguments after the close pairs': J, rows, gamma, ds, rise), the compiled
        narrow phase also writes the damper rows; returns whether it did."""
        self._rows_at = None  # compute's rows (and the barrier's, which share _C) are recomputed
        data = config.data
        gm, gd = self.geometry_model, self.geometry_data
        pair_set = self._pair_set
        if pair_set is None:
            pin.updateGeometryPlacements(self.model, data, gm, gd)
        if self.broad_phase or pair_set is not None:
            placements = self._joint_placements(data)
        if self.broad_phase:
            args = (placements, self._first, self.activation_distance, self._state)
            if self._broad_kernel is None:
                self._broad_kernel = broad_phase if CHECK_TYPES else specialise(broad_phase, *args)
            n, nt = self._broad_kernel(*args)
            self._first = False
            cand = self._cand[:n]
            if nt and pair_set is None:  # the candidates differ little from one call to the next: switch those
                activate, deactivate = self._activate, self._deactivate
                for k in self._toggle[:nt].tolist():
                    if k >= 0:
                        activate(k)
                    else:
                        deactivate(~k)
        else:
            n = len(self.pairs)
            cand = self._cand  # all pairs (__init__)
        self.coal_calls = n
        if pair_set is not None:
            # one call: geometry placements, coal on the candidates, distances / witness points / normals written;
            # then one compiled call for the rows
            compiled_narrow_phase.distances(pair_set, placements, cand, self._wit)
            args = (n, self._wit, self.activation_distance, self._state)
            if damper is None:
                if self._close_kernel is None:
                    self._close_kernel = close_pairs if CHECK_TYPES else specialise(close_pairs, *args)
                self._found = ClosePairs(*self._close_kernel(*args))
                return False
            if self._damper_kernel is None:
                self._damper_kernel = close_pairs_damper if CHECK_TYPES else specialise(close_pairs_damper, *args,
                                                                                        *damper)
            self._found = ClosePairs(*self._damper_kernel(*args, *damper))
            return True
        pin.computeDistances(gm, gd)
        res = self._results
        dist = np.array(list(map(self._distance, map(res.__getitem__, cand.tolist()))))
        m = narrow_phase_done(n, dist, self.activation_distance, self._state)
        k = cand[self._rows[:m]]
        d = dist[self._rows[:m]]
        if m:
            rl = list(map(res.__getitem__, k.tolist()))
            g1, gn = self._witness
            # coal's normal, not (p2 − p1) / d: on g1 they differ by up to ~1e-6 (witness points of GJK's last
            # simplex), enough to change a closed-loop run. p2 = p1 + d n: a row depends on the witness line only
            # (p2 × n = p1 × n; module docstring), and this saves a third of the reads (one per row)
            p1, normal = np.frombuffer(b"".join([*map(g1, rl), *map(gn, rl)])).reshape(2, m, 3)
            p2 = p1 + d[:, None] * normal
        else:
            p1 = p2 = normal = self._empty
        self._found = ClosePairs(k, d, normal, p1, p2)
        return False

    def _joint_placements(self, data: pin.Data) -> np.ndarray:
        """(njoints, 12) joint placements ``data.oMi`` of ``data``: per joint the rotation column-major, then the
        translation — a read-only view of ``data``'s own memory when ``joint_placements_view`` gives one (built once
        per Data object, which is kept alive with it), else read through the bindings."""
        at = self._placements_of
        if at is None or at[0] is not data:
            self._placements_of = at = (data, joint_placements_view(data))
        if at[1] is not None:
            return at[1]
        # each SE3.homogeneous is a fresh C-contiguous (4, 4) array; one bytes.join and one view
        h = np.frombuffer(b"".join(map(self._homogeneous, data.oMi.tolist()))).reshape(-1, 4, 4)
        return np.concatenate([h[:, :3, :3].transpose(0, 2, 1).reshape(-1, 9), h[:, :3, 3]], axis=1)

    def distance_jacobian(self, config: Configuration, close: ClosePairs, out: np.ndarray | None = None) -> np.ndarray:
        """(m, nv) rows ∂d/∂v of the distances of ``close`` (module docstring: ḋ = row · v), from ``config.data.J``
        (WORLD joint Jacobians, filled by ``Configuration.update``); written to ``out`` (m, nv) if given."""
        m = len(close.pairs)
        C = np.zeros((m, self.model.nv)) if out is None else out
        C[:m] = 0.0
        k = close.pairs
        damper_rows(close.normal, close.p1, close.p2, self._joint[self.pairs[k, 0]], self._joint[self.pairs[k, 1]],
                     config.data.J, self._support, C, self._identity[:m])
        return C

    @property
    def active(self) -> list[tuple[str, str, float]]:
        names = self.pair_names
        return [(*names[k], d) for k, d in zip(self._found.pairs.tolist(), self._found.distance.tolist())]

    def compute(self, config: Configuration, dt: float):
        """(C (max_active, nv), l, u) with one velocity-damper row per active pair (module docstring); a pair keeps
        its row while it stays active (rows in no particular distance order: :attr:`active` lists the pairs
        closest first).

        A second call with the same ``config`` object at a bitwise-equal q and the same dt returns the rows of the
        first without recomputing them (and without advancing the floors or the broad phase's bounds): the
        kinematic controller's general path re-assembles a tick that its compiled path could not finish."""
        at = self._rows_at
        if at is not None and at[0] is config and at[1] == dt and np.array_equal(self._rows_q, config.q):
            return self._C, self._l, self._u
        damper = (config.data.J, self._damper_rows, min(self.gain, 1.0 / dt), self.min_distance + self.safety_margin,
                  self.recovery_speed * dt)
        if not self._narrow(config, damper):
            f = self._found
            pair_dampers(f.pairs, f.distance, f.p1, f.p2, f.normal, *damper)
        self._rows_at = (config, dt)
        self._rows_q[:] = config.q
        return self._C, self._l, self._u

    def barrier(self, state, dt: float):
        """(h (max_active,) m, G (max_active, nv), Ġv (max_active,) m/s²) at a DynamicsState: per active pair
        h = d − f (its floor, module docstring, updated as by :meth:`compute`), G the damper row (ḋ = G v), and
        Ġv = nᵀ(p̈2 − p̈1) with p̈_k the classical acceleration at v̇ = 0 of body k's material point at its witness
        point (Pinocchio's joint velocity and acceleration ``data.v``, ``data.a``). The terms of the witness
        normal's rotation (2ṅᵀ(ṗ2 − ṗ1) − d|ṅ|²) are left out: first order in the bodies' relative angular
        velocity, they vanish for translating bodies. Unused rows: h = +inf, G = 0, Ġv = 0."""
        close = self.close_pairs(state)
        m = len(close.pairs)
        G = self._C
        G[:] = 0.0
        h = np.full(self.dim, np.inf)
        drift = np.zeros(self.dim)
        if not m:
            return h, G, drift
        self.distance_jacobian(state, close, out=G)
        k, d = close.pairs, close.distance
        prev = self._floor[k]
        floor = np.minimum(self.min_distance + self.safety_margin,
                           np.where(np.isnan(prev), d, np.fmax(prev, d) + self.recovery_speed * dt))
        self._floor[k] = floor
        h[:m] = d - floor
        data = state.data
        for r in range(m):
            acc = []
            for side, p in ((0, close.p1[r]), (1, close.p2[r])):
                j = int(self._joint[self.pairs[k[r], side]])
                at = pin.SE3(np.eye(3), data.oMi[j].actInv(np.asarray(p)))  # the point, joint axes
                v, a = at.actInv(data.v[j]), at.actInv(data.a[j])
                acc.append(data.oMi[j].rotation @ (a.linear + np.cross(v.angular, v.linear)))
            drift[r] = close.normal[r] @ (acc[1] - acc[0])
        return h, G, drift

    def reset(self) -> None:
        """Forget the per-pair floors (module docstring) and the broad phase's bounds, e.g. after teleporting."""
        self._floor[:] = np.nan
        self._first = True
        self._exact[:] = False
        self._gap_known[:] = -np.inf
        self._slot_of[:] = -1
        self._in_slot[:] = -1
        self._rows_at = None
