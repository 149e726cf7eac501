"""The checks :func:`wbc.robot.load_robot` runs on a humanoid it loads, and the sole geometry they read.

Each check takes the loaded robot (a :class:`wbc.robot.Robot`) and raises
:class:`wbc.exceptions.RobotDescriptionError` naming what is wrong with the model and what would be valid: the
group state of the SRDF, an upright model, the joint limits and the reference posture within them, two distinct legs
below the base, the soles at the bottom of their feet; :func:`stand_on_ground` puts the reference posture's soles
on z = 0. The sole geometry (:func:`geometry_points`, :func:`floor_points`, :func:`foot_points`,
:func:`sole_rectangle_from_collision`) reads the collision meshes.
"""

from __future__ import annotations

import difflib
import math
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin

from wbc.exceptions import RobotDescriptionError
from wbc.robot_file import LIMIT_INVERSION_TOLERANCE

__all__ = ["check_group_state", "check_upright", "check_limit_order", "check_posture_limits", "check_soles_distinct",
           "check_legs", "check_sole_heights", "check_loaded_robot", "stand_on_ground", "joint_chain", "geometry_points",
           "floor_points", "foot_points", "sole_rectangle_from_collision", "SOLE_HEIGHT_TOLERANCE", "MIN_ROBOT_MASS"]


def check_group_state(srdf: Path, tree, reference: str, model: pin.Model) -> None:
    """Every joint of the SRDF ``group_state`` ``reference`` is a joint of the URDF with a numeric value (Pinocchio
    skips unknown names silently).

    Raises:
        RobotDescriptionError: names the unknown joints (with close matches) or the non-numeric values.
    """
    known = set(model.names) | {f.name for f in model.frames if f.type == pin.FrameType.FIXED_JOINT}
    for state in tree.getroot().iter("group_state"):
        if state.get("name") != reference:
            continue
        unknown = [j.get("name") for j in state.iter("joint") if j.get("name") not in known]
        if unknown and len(unknown) == len(list(state.iter("joint"))):
            close = difflib.get_close_matches(str(unknown[0]), sorted(known), n=3)
            raise RobotDescriptionError(
                f"SRDF {srdf}: group_state {reference!r} sets no joint of the URDF (e.g. {unknown[0]!r}; close "
                f"matches {close}): it describes another robot")
        if unknown:  # SRDFs shared by several URDF variants name joints some variants lack
            warnings.warn(f"SRDF {srdf}: group_state {reference!r} sets {len(unknown)} joints that are not in the "
                          f"URDF (ignored): {unknown[:5]}", stacklevel=4)
        for joint in state.iter("joint"):
            name, value = joint.get("name"), joint.get("value")
            if name not in known:
                continue
            try:
                values = [float(x) for x in str(value).split()]
            except ValueError:
                values = []
            if not values or not all(math.isfinite(x) for x in values):
                raise RobotDescriptionError(
                    f"SRDF {srdf}: group_state {reference!r} joint {name!r} has value {value!r}; give finite "
                    f"numbers (rad or m)")


def check_upright(robot, q: np.ndarray) -> None:
    """Diagnose a model that is not z-up in its reference posture: the soles must lie below the floating base
    (along −z), not beside it.

    Raises:
        RobotDescriptionError: the base-to-soles direction is more than 45° from −z; the message names the axis the
            model uses as up and the ``base_rpy`` that stands it up.
    """
    model = robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    mid = 0.5 * (data.oMf[model.getFrameId(robot.left_sole)].translation
                 + data.oMf[model.getFrameId(robot.right_sole)].translation)
    d = mid - data.oMi[1].translation
    n = float(np.linalg.norm(d))
    if n < 1e-6 or -d[2] >= math.cos(math.radians(45.0)) * n:
        return
    axis = int(np.argmax(np.abs(d)))
    sign = -1.0 if d[axis] < 0 else 1.0
    up = f"{'+' if sign < 0 else '-'}{'xyz'[axis]}"
    # rotation taking the model's "up" (−d direction) to +z
    u = -d / n
    rot = pin.Quaternion.FromTwoVectors(u, np.array([0.0, 0.0, 1.0])).matrix()
    rpy = [round(float(a), 4) for a in pin.rpy.matrixToRpy(rot @ data.oMi[1].rotation)]
    tilt = math.degrees(math.acos(max(-1.0, min(1.0, float(-d[2] / n)))))
    kind = f"{up.upper()[1:]}-up" if tilt > 80 else f"tilted {tilt:.0f}° from z-up"
    raise RobotDescriptionError(
        f"{robot.name}: the model is {kind}: in the reference posture its soles {robot.left_sole!r}/"
        f"{robot.right_sole!r} are along {np.round(d / n, 3).tolist()} from the base, not below it (wbc needs z "
        f"up). Fix: set base_rpy = {rpy} in the robot file (the base orientation of the reference posture), and "
        f"sole frames whose z axis points up in that posture")


#: Largest distance (m) between a sole frame and the bottom of its foot's geometry (:func:`check_sole_heights`).
SOLE_HEIGHT_TOLERANCE = 0.01


def geometry_points(geo) -> np.ndarray | None:
    """Points (k, 3) bounding a collision geometry in its own frame (mesh vertices, box corners, sphere/cylinder
    extremes), or None for an unsupported shape."""
    if hasattr(geo, "vertices"):
        return np.asarray(geo.vertices(), dtype=float).reshape(-1, 3)
    if hasattr(geo, "halfSide"):
        h = np.asarray(geo.halfSide, dtype=float)
        return np.array([[sx * h[0], sy * h[1], sz * h[2]] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    if hasattr(geo, "radius"):
        r = float(geo.radius)
        hl = float(getattr(geo, "halfLength", 0.0))
        return np.array([[sx * r, sy * r, sz * (hl + (r if not hasattr(geo, "halfLength") else 0.0))]
                         for sx in (-1, 0, 1) for sy in (-1, 0, 1) for sz in (-1, 1)])
    return None


def floor_points(geo, placement: pin.SE3, up: np.ndarray) -> np.ndarray | None:
    """Points (k, 3) m, in the frame of ``placement`` (the geometry's placement in it), of a collision geometry
    that can touch a floor below it (normal ``up``, unit (3,) in that frame): a sphere's lowest point, a capsule's
    two lowest points (its segment's ends lowered by the radius), every bounding point of other shapes (mesh
    vertices, box corners). None for an unsupported shape.

    A sphere or capsule touches a floor at one point (one line); its bounding box's corners would widen the
    contact patch (and a sole rectangle measured on it) by the radius."""
    if hasattr(geo, "radius") and not hasattr(geo, "vertices") and not hasattr(geo, "halfSide"):
        r = float(geo.radius)
        kind = type(geo).__name__.lower()
        if "sphere" in kind:
            return (placement.translation - r * up)[None, :]
        if "capsule" in kind:
            axis = placement.rotation[:, 2] * float(getattr(geo, "halfLength", 0.0))
            return np.array([placement.translation + axis - r * up, placement.translation - axis - r * up])
    local = geometry_points(geo)
    if local is None:
        return None
    return local @ placement.rotation.T + placement.translation


def foot_points(robot, frame: str, geometry_model) -> np.ndarray | None:
    """Points (k, 3) m of the geometry attached to the joint carrying ``frame`` that can touch a floor under the
    sole (:func:`floor_points` with the sole frame's z up), expressed in that frame, or None when that joint has
    no (supported) geometry."""
    model = robot.model
    fr = model.frames[model.getFrameId(frame)]
    s_m_j = fr.placement.inverse()
    pts = []
    for g in geometry_model.geometryObjects:
        if g.parentJoint != fr.parentJoint:
            continue
        p = floor_points(g.geometry, s_m_j * g.placement, np.array([0.0, 0.0, 1.0]))
        if p is not None:
            pts.append(p)
    return np.vstack(pts) if pts else None


def check_sole_heights(robot, tolerance: float = SOLE_HEIGHT_TOLERANCE) -> None:
    """Each sole frame is at the bottom of its foot and over it: the lowest point of the foot's collision geometry
    (its visual geometry when it has none) is within ``tolerance`` m of the sole plane z = 0 of the sole frame, and
    the frame's origin is within ``tolerance`` m of the foot's contact patch (the geometry's points within 1 cm of
    its lowest one; their x-y bounding box in the sole frame), whatever sole rectangle the robot file gives. A robot
    whose feet carry no geometry at all is not checked.

    Raises:
        RobotDescriptionError: a sole frame above the bottom of its foot (the foot would sink into the ground when
            the frame is put on it, e.g. an ankle frame named as the sole) or below it (the foot floats), or beside
            its foot's contact patch (the distance from the patch's centre and how far outside it, in m).
    """
    for side, frame in (("left", robot.left_sole), ("right", robot.right_sole)):
        for kind in ("collision", "visual"):  # the visual model read (built) only when the collision one has no foot
            gm = robot.collision_model if kind == "collision" else robot.visual_model
            p = foot_points(robot, frame, gm) if gm is not None else None
            if p is not None:
                break
        if p is None:
            continue
        z = float(p[:, 2].min())
        if abs(z) > tolerance:
            where = "above" if z < 0 else "below"
            raise RobotDescriptionError(
                f"{robot.name}: {side} sole frame {frame!r} is {abs(z):.3f} m {where} the bottom of its foot's "
                f"{kind} geometry (at most {tolerance} m); standing it on the ground would put the foot "
                f"{'into' if z < 0 else 'above'} the ground. Name the frame at the bottom of the foot, or add one "
                f"to the URDF (a fixed joint from the foot link, origin at the centre of the foot's underside, "
                f"x forward, z up)")
        patch = p[p[:, 2] <= z + 0.01, :2]
        lo, hi = patch.min(axis=0), patch.max(axis=0)
        outside = float(np.linalg.norm(np.maximum(np.maximum(lo, -hi), 0.0)))
        if outside > tolerance:
            centre = 0.5 * (lo + hi)
            raise RobotDescriptionError(
                f"{robot.name}: {side} sole frame {frame!r} is {float(np.linalg.norm(centre)):.3f} m from the centre "
                f"of its foot's contact patch (centre at ({centre[0]:.3f}, {centre[1]:.3f}) m in the sole frame, x "
                f"forward) and {outside:.3f} m outside the patch (at most {tolerance} m, patch "
                f"{hi[0] - lo[0]:.3f} x {hi[1] - lo[1]:.3f} m from its {kind} geometry): the robot would stand beside "
                f"its foot. Name a frame at the centre of the foot's underside")


def sole_rectangle_from_collision(robot, contact_band: float = 0.01) -> tuple[float, float]:
    """Sole rectangle (length, width) m derived from the feet's collision geometry.

    The collision geometry attached to each sole's parent joint is expressed in the sole frame; its points within
    ``contact_band`` m of the lowest one are the contact patch; the rectangle, centred on the sole frame (x
    forward), is the largest one inside that patch's bounding box: length = 2 min(x_max, −x_min), width =
    2 min(y_max, −y_min). The smaller of the two feet is returned.

    Raises:
        RobotDescriptionError: a foot has no collision geometry, or the sole frame is not above its contact patch
            (pass ``sole_length`` / ``sole_width`` explicitly, or fix the sole frame).
    """
    sizes = []
    for frame in (robot.left_sole, robot.right_sole):
        p = foot_points(robot, frame, robot.collision_model)
        if p is None:
            raise RobotDescriptionError(
                f"{robot.name}: no collision geometry on the link of sole frame {frame!r}; pass sole_length and "
                f"sole_width (m) explicitly (--sole-length/--sole-width)")
        patch = p[p[:, 2] <= p[:, 2].min() + contact_band]
        length = 2.0 * min(patch[:, 0].max(), -patch[:, 0].min())
        width = 2.0 * min(patch[:, 1].max(), -patch[:, 1].min())
        span = patch[:, :2].max(axis=0) - patch[:, :2].min(axis=0)
        centre = 0.5 * (patch[:, :2].max(axis=0) + patch[:, :2].min(axis=0))
        along = (" The patch is longer along the sole frame's y axis than along its x axis: x must point along "
                 "the foot." if span[1] > span[0] else "")
        if length > 0.01 and width > 0.01 and (length < 0.5 * span[0] or width < 0.5 * span[1]):
            raise RobotDescriptionError(
                f"{robot.name}: sole frame {frame!r} is off the centre of its foot's contact patch by "
                f"({centre[0]:.3f}, {centre[1]:.3f}) m (patch {span[0]:.3f} x {span[1]:.3f} m in the sole frame, "
                f"x forward); a centred rectangle would be only {length:.3f} x {width:.3f} m.{along} Add a sole "
                f"frame at the patch centre (a fixed frame, x forward, z up) or pass sole_length and sole_width "
                f"explicitly")
        if not (length > 0.01 and width > 0.01):
            raise RobotDescriptionError(
                f"{robot.name}: sole frame {frame!r} is not above its foot's contact patch (x in "
                f"[{patch[:, 0].min():.3f}, {patch[:, 0].max():.3f}], y in [{patch[:, 1].min():.3f}, "
                f"{patch[:, 1].max():.3f}] m in the sole frame); put the sole frame inside the foot's footprint or "
                f"pass sole_length and sole_width explicitly")
        sizes.append((length, width))
    return min(s[0] for s in sizes), min(s[1] for s in sizes)


#: Largest tilt (deg) of a sole's z axis from the world vertical in the reference posture.
MAX_SOLE_TILT_DEG = 5.0
#: Tolerance (rad or m) on the reference posture's joint limits.
LIMIT_TOLERANCE = 1e-6

#: kg: a URDF whose links weigh less in total has lost its inertials (the smallest humanoids weigh a few kg)
MIN_ROBOT_MASS = 1.0
#: How far (m) a joint on a sole's chain may sit above the floating base's origin (hips hang below the pelvis).
LEG_ABOVE_BASE_TOLERANCE = 0.02
#: How far (m) a joint origin may sit below the soles' plane before the soles are judged not to be the feet.
BELOW_SOLE_TOLERANCE = 0.03


def joint_chain(model: pin.Model, joint_id: int) -> list[int]:
    """Joint ids from the first joint after the universe down to ``joint_id`` (included); [] for the universe."""
    out = []
    while joint_id > 0:
        out.append(joint_id)
        joint_id = model.parents[joint_id]
    return out[::-1]


def check_soles_distinct(robot) -> None:
    """Left and right soles are different frames on different legs (branches after the floating base)."""
    model = robot.model
    if robot.left_sole == robot.right_sole:
        raise RobotDescriptionError(
            f"{robot.name}: left_sole and right_sole are the same frame {robot.left_sole!r}; name the left foot's "
            f"sole frame and the right foot's sole frame")
    jl = model.frames[model.getFrameId(robot.left_sole)].parentJoint
    jr = model.frames[model.getFrameId(robot.right_sole)].parentJoint
    cl, cr = joint_chain(model, jl), joint_chain(model, jr)
    # index 0 is the free-flyer; the legs must split right after it (or after a shared pelvis chain)
    if jl in cr or jr in cl or jl == jr:
        raise RobotDescriptionError(
            f"{robot.name}: soles {robot.left_sole!r} and {robot.right_sole!r} are on the same kinematic chain "
            f"(joint {model.names[jl]!r} / {model.names[jr]!r}); each sole must be on its own leg")


def _root_link(model: pin.Model) -> str:
    """Name of the URDF root link (the body moved by the floating base)."""
    return next((f.name for f in model.frames if f.parentJoint == 1 and f.type == pin.FrameType.BODY), "base")


def check_legs(robot, q: np.ndarray) -> None:
    """Each sole hangs at the end of a leg: every joint between the floating base and the sole is below the base
    origin in the posture q (hips hang from the pelvis; an arm starts at a shoulder above it).

    Raises:
        RobotDescriptionError: a joint of a sole's chain is above the base (a legless robot, hands named as soles).
    """
    model = robot.model
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    base_z = float(data.oMi[1].translation[2])
    for side, frame in (("left", robot.left_sole), ("right", robot.right_sole)):
        chain = joint_chain(model, model.frames[model.getFrameId(frame)].parentJoint)[1:]  # after the free flyer
        if not chain:
            raise RobotDescriptionError(
                f"{robot.name}: {side} sole frame {frame!r} is on the floating base itself, not on a leg; name the "
                f"{side} foot's sole frame")
        top = max(chain, key=lambda j: data.oMi[j].translation[2])
        above = float(data.oMi[top].translation[2]) - base_z
        if above > LEG_ABOVE_BASE_TOLERANCE:
            raise RobotDescriptionError(
                f"{robot.name}: {side} sole frame {frame!r} is reached through joint {model.names[top]!r}, "
                f"{above:.3f} m above the floating base link {_root_link(model)!r}; "
                f"soles must be at the end of legs hanging below the base — a legless robot (e.g. hands named as "
                f"soles) cannot stand or walk. Name the feet's sole frames of a robot with legs")


def check_limit_order(model: pin.Model, urdf: Path) -> None:
    """Every finite position range has lower ≤ upper. One inverted by at most ``LIMIT_INVERSION_TOLERANCE`` is the
    round-off of a locked joint: both limits are set to their middle (the joint keeps a position limit, zero wide;
    see ``KinematicController.locked_joints``), with a warning.

    Raises:
        RobotDescriptionError: a range inverted by more (names up to 5 joints with their limits).
    """
    lo, hi = model.lowerPositionLimit, model.upperPositionLimit
    bad, snapped = [], []
    for j in range(1, model.njoints):
        joint = model.joints[j]
        for iq in range(joint.idx_q, joint.idx_q + joint.nq):
            if np.isfinite(lo[iq]) and np.isfinite(hi[iq]) and lo[iq] > hi[iq]:
                (snapped if lo[iq] - hi[iq] <= LIMIT_INVERSION_TOLERANCE else bad).append((model.names[j], iq))
    if bad:
        desc = ", ".join(f"{n}: lower {lo[iq]:.9g} > upper {hi[iq]:.9g}" for n, iq in bad[:5])
        raise RobotDescriptionError(f"{urdf}: inverted joint limits ({desc}); fix the URDF <limit lower upper>")
    if snapped:
        new_lo, new_hi = lo.copy(), hi.copy()
        for _, iq in snapped:
            new_lo[iq] = new_hi[iq] = 0.5 * (lo[iq] + hi[iq])
        model.lowerPositionLimit, model.upperPositionLimit = new_lo, new_hi
        warnings.warn(f"{urdf}: joint limits inverted by ≤ {LIMIT_INVERSION_TOLERANCE:g} (round-off) on "
                      f"{', '.join(n for n, _ in snapped[:5])}: read as locked joints (lower = upper = the middle)",
                      stacklevel=4)


def check_posture_limits(robot, q: np.ndarray) -> None:
    """The reference posture q is inside the joint limits (± ``LIMIT_TOLERANCE``).

    Raises:
        RobotDescriptionError: names up to 5 joints outside their range, with their value and range.
    """
    model, name = robot.model, robot.name
    lo, hi = model.lowerPositionLimit, model.upperPositionLimit
    out = [(model.names[j], float(q[model.joints[j].idx_q]), float(lo[model.joints[j].idx_q]),
            float(hi[model.joints[j].idx_q])) for j in range(2, model.njoints) if model.joints[j].nq == 1
           and not (lo[model.joints[j].idx_q] - LIMIT_TOLERANCE <= q[model.joints[j].idx_q]
                    <= hi[model.joints[j].idx_q] + LIMIT_TOLERANCE)]
    if out:
        desc = ", ".join(f"{n} = {v:.3f} rad not in [{a:.3f}, {b:.3f}]" for n, v, a, b in out[:5])
        raise RobotDescriptionError(
            f"{name}: the reference posture is outside the joint limits ({desc}); fix the SRDF group_state / "
            f"reference_joints or the URDF <limit>")


def check_loaded_robot(robot) -> None:
    """Validate a loaded humanoid (called by :func:`wbc.robot.load_robot`).

    Raises:
        RobotDescriptionError: mass ≤ 0 or non-finite inertias; reference posture outside the joint limits;
            a sole tilted more than ``MAX_SOLE_TILT_DEG`` from flat; a joint below the soles (the named soles
            are not the lowest points: not feet); soles not below the floating base (a legless robot).
    """
    model, name = robot.model, robot.name
    bad_inertia = [model.names[j] for j in range(1, model.njoints)
                   if not (np.isfinite(model.inertias[j].mass) and np.isfinite(model.inertias[j].lever).all()
                           and np.isfinite(model.inertias[j].inertia).all() and model.inertias[j].mass >= 0)]
    if bad_inertia:
        raise RobotDescriptionError(
            f"{name}: non-finite or negative inertial parameters on the bodies of joints {bad_inertia[:5]}; "
            f"give every <link> a finite <inertial> (mass ≥ 0, inertia matrix)")
    mass = float(sum(model.inertias[j].mass for j in range(1, model.njoints)))
    if not mass > 0:
        raise RobotDescriptionError(
            f"{name}: total mass is {mass} kg; the URDF has no <inertial> elements — add masses and inertias "
            f"(the CoM is undefined without them)")
    q = robot.q_ref
    check_posture_limits(robot, q)
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    for side, frame in (("left", robot.left_sole), ("right", robot.right_sole)):
        z = data.oMf[model.getFrameId(frame)].rotation[:, 2]
        tilt = math.degrees(math.acos(max(-1.0, min(1.0, float(z[2])))))
        if tilt > MAX_SOLE_TILT_DEG:
            raise RobotDescriptionError(
                f"{name}: {side} sole frame {frame!r} is tilted {tilt:.1f}° from flat in the reference posture "
                f"(z axis {np.round(z, 3).tolist()}, at most {MAX_SOLE_TILT_DEG}° allowed); name a frame whose z "
                f"axis points up when the robot stands (add one with a fixed rpy), or fix the reference posture")
    low = [(model.names[j], float(data.oMi[j].translation[2])) for j in range(1, model.njoints)
           if data.oMi[j].translation[2] < -BELOW_SOLE_TOLERANCE]
    if low:
        n, z = min(low, key=lambda x: x[1])
        raise RobotDescriptionError(
            f"{name}: joint {n!r} is {-z:.3f} m below the named soles {robot.left_sole!r}/{robot.right_sole!r}; "
            f"the soles must be the lowest points of a standing humanoid — name the feet's sole frames")
    base_z = float(data.oMi[1].translation[2])
    if base_z < 0.1:
        raise RobotDescriptionError(
            f"{name}: the floating base is {base_z:.3f} m above the soles {robot.left_sole!r}/"
            f"{robot.right_sole!r}; a humanoid stands on legs below its base (≥ 0.1 m) — a legless robot or "
            f"hands named as soles cannot walk")


def stand_on_ground(robot, q: np.ndarray) -> np.ndarray:
    """Move the base so both soles rest on z = 0 with their mid-point at x = y = 0 (orientation kept)."""
    model = robot.model
    q = q.copy()
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    pl = data.oMf[model.getFrameId(robot.left_sole)].translation
    pr = data.oMf[model.getFrameId(robot.right_sole)].translation
    mid = 0.5 * (pl + pr)
    q[0:3] -= mid
    if abs(pl[2] - pr[2]) > 1e-3:
        raise RobotDescriptionError(
            f"reference configuration of {robot.name!r} has the soles at different heights "
            f"({pl[2]:.4f} m vs {pr[2]:.4f} m); a standing posture needs both on the ground"
        )
    return q
