"""Robot-file inference and validation: what ``wbc robot init`` guesses from a URDF and what ``wbc robot check``
reports about a robot file.

:func:`infer_robot_spec` reads a humanoid URDF and infers, from the kinematic tree and the collision geometry:
the up axis (the longest extent of the joint origins, its sign pointing from the feet to the base), the two feet
(the two lowest branch tips, on different branches, apart laterally), left and right (link names, else the
+y side), the forward axis (the long axis of a foot's contact patch, towards the toes), a sole frame at the
centre of each foot's contact patch (added as a frame when the URDF has none), the sole rectangle, the torso
(the upper body: :func:`upper_body_link`),
the hands, an SRDF beside the URDF and a bent-knee reference posture (the feet raised towards the base by a
fraction of the leg length with Pinocchio's frame Jacobians, damped least squares). Every guess is returned as
a note.

:func:`check_robot` loads a robot file and measures what a user needs to trust it: mass, CoM height, leg chains,
sole frames against the foot geometry, joint limits and locked joints.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pinocchio as pin

from wbc.exceptions import InvalidInputError, RobotDescriptionError, RobotFileNotFoundError
from wbc.geometry import convex_hull, polygon_margin, rectangle_in_polygon, signed_distance, support_polygon
from wbc.robot import Robot, build_robot, example_robot_data_dir, load_robot
from wbc.robot_checks import floor_points, foot_points, geometry_points, joint_chain
from wbc.robot_file import FrameSpec, MujocoOptions, RobotSpec, check_xml, package_roots

__all__ = ["infer_robot_spec", "upper_body_link", "check_robot", "locked_joints", "KNEE_LIFT", "MIN_COM_MARGIN", "ASSUMED_ARMATURE",
           "FLAT_BAND", "MIN_FLAT_PATCH"]

#: Rotor armature (kg·m², every actuated joint) written by ``wbc robot init`` when the robot has no drive data
#: (no SRDF ``<rotor_params>``): the value of MuJoCo Menagerie's Unitree G1 (``unitree_g1/g1.xml``, default class
#: joint armature). Real drives have reflected rotor inertia (Talos's SRDF: 0.1); massless rotors let a light
#: foot spin at several times its joint speed limit under small torques.
ASSUMED_ARMATURE = 0.01

#: Smallest distance (m) of the reference posture's CoM inside the support polygon for `wbc robot check`.
MIN_COM_MARGIN = 0.01

#: Height band (m) above a foot geometry's lowest point taken as what touches a flat floor (the plant's contacts
#: are soft: a loaded foot sinks about a millimetre).
FLAT_BAND = 0.002

#: ``wbc robot init`` writes ``[mujoco] foot = "urdf"`` (the robot's own foot geometry in the plant) when, on each
#: foot, the geometry within ``FLAT_BAND`` of its lowest point spans at least this fraction of the sole rectangle
#: in length and in width; otherwise ``"box"`` (a foot that touches on a smaller patch rocks on the floor).
MIN_FLAT_PATCH = 0.5

#: Feet raised towards the base by this fraction of the leg length in the inferred reference posture (bent knees:
#: a straight leg is a singular posture for CoM height tracking).
KNEE_LIFT = 0.06


def _side_from_name(name: str) -> str | None:
    """'left'/'right' from a link or joint name (``left``/``l`` tokens, ``LAnkle`` camel case), else None."""
    tokens = {t.lower() for t in re.split(r"[_\W\d]+", name) if t}
    low = name.lower()
    left = bool(tokens & {"l", "left"}) or "left" in low or bool(re.match(r"L[A-Z]", name))
    right = bool(tokens & {"r", "right"}) or "right" in low or bool(re.match(r"R[A-Z]", name))
    return "left" if left and not right else "right" if right and not left else None


def _geometry_points_world(model, data, gmodel, joint: int, up: np.ndarray | None = None) -> np.ndarray | None:
    """Points (k, 3) m, world frame, of the geometry on ``joint``: bounding points, or with ``up`` (unit (3,),
    world) the points that can touch a floor of that normal (:func:`wbc.robot_checks.floor_points`)."""
    pts = []
    for g in gmodel.geometryObjects:
        if g.parentJoint != joint:
            continue
        m = data.oMi[joint] * g.placement
        if up is not None:
            p = floor_points(g.geometry, m, up)
        else:
            local = geometry_points(g.geometry)
            p = None if local is None else local @ m.rotation.T + m.translation
        if p is not None:
            pts.append(p)
    return np.vstack(pts) if pts else None


def touch_rectangle(xy: np.ndarray, z: np.ndarray, footprint: np.ndarray,
                    band: float | None = None) -> np.ndarray:
    """The largest rectangle centred on the sole frame origin, x along the foot, inside the convex hull of the
    foot geometry's points within ``band`` of its lowest point (where a flat floor touches it).

    The rectangle's proportions are searched from the footprint's (length, width) to ones narrowed in width (to
    0.3×, 15 steps), each candidate scaled up to the hull (:func:`wbc.geometry.rectangle_in_polygon`); the
    largest one at least 80 % of the footprint's length is kept (the sagittal reach of the CoP, which the CoM of
    a standing robot needs most; a tapered foot, narrow at the heel, would otherwise give a short square), else
    the longest.

    Args:
        xy: (k, 2) points in the sole frame (m); z: (k,) their heights above the sole plane (m).
        footprint: (2,) the footprint's (length, width) (m), the starting proportions.
        band: height band (m), default :data:`FLAT_BAND`.

    Returns:
        (2,) (length, width) m; zeros when the touching points have no area around the origin.
    """
    band = FLAT_BAND if band is None else band
    pts = xy[z <= z.min() + band]
    try:
        poly = convex_hull(pts)
    except InvalidInputError:
        return np.zeros(2)
    rects = [np.array(rectangle_in_polygon(poly, float(footprint[0]), float(t * footprint[1])))
             for t in np.linspace(0.3, 1.0, 15)]
    long = [r for r in rects if r[0] >= 0.8 * footprint[0]]
    if long:
        return max(long, key=lambda r: r[0] * r[1])
    return max(rects, key=lambda r: r[0])


def upper_body_link(model: pin.Model, feet: list[int]) -> str:
    """The upper body of a humanoid: the link above its waist — from the floating base (joint 1) up the one chain
    of joints that leads to no foot, to the first link where that chain branches (arms, head) or ends. The root
    link when no such chain leaves the base, or when several do (arms on the pelvis: no waist).

    Args:
        model: the Pinocchio model (a free-flyer root). feet: the joint ids carrying the feet (the legs' ends).

    Returns:
        The name of the link (its BODY frame).
    """
    legs = {j for f in feet for j in joint_chain(model, f)}
    children: dict[int, list[int]] = {}
    for j in range(2, model.njoints):
        children.setdefault(model.parents[j], []).append(j)
    j = 1
    up = [c for c in children.get(1, []) if c not in legs]
    if len(up) == 1:
        j = up[0]
        while len(children.get(j, [])) == 1:
            j = children[j][0]
    return next(f.name for f in model.frames if f.parentJoint == j and f.type == pin.FrameType.BODY)


def locked_joints(model: pin.Model, tolerance: float = 1e-9) -> list[str]:
    """Names of the 1-DoF joints whose position range is empty (upper − lower ≤ ``tolerance`` rad or m)."""
    out = []
    for j in range(2, model.njoints):
        jm = model.joints[j]
        if jm.nq == 1 and model.upperPositionLimit[jm.idx_q] - model.lowerPositionLimit[jm.idx_q] <= tolerance:
            out.append(model.names[j])
    return out


def infer_robot_spec(urdf: str | Path, package_dirs: list[str] | None = None) -> tuple[RobotSpec, list[str]]:
    """Infer a robot file for a humanoid URDF (module docstring: what is inferred, and how).

    Args:
        urdf: path of the URDF.
        package_dirs: extra folders for ``package://`` URIs.

    Returns:
        ``(spec, notes)``: the inferred :class:`~wbc.robot_file.RobotSpec` (paths absolute) and one sentence per
        guess.

    Raises:
        RobotFileNotFoundError: no such URDF.
        RobotDescriptionError: malformed XML, no two feet found (the message says what was found), or the spec
            inferred does not load (the loader's message).
    """
    urdf = Path(urdf).absolute()
    if not urdf.is_file():
        raise RobotFileNotFoundError(f"URDF file not found: {urdf}")
    tree = check_xml(urdf, "URDF")
    dirs = [str(Path(d).absolute()) for d in (package_dirs or [])]
    search = [*dirs, str(urdf.parent), *package_roots(urdf, tree.getroot()), str(example_robot_data_dir())]
    try:
        model, cmodel, vmodel = pin.buildModelsFromUrdf(str(urdf), search, pin.JointModelFreeFlyer())
    except (ValueError, RuntimeError) as exc:
        raise RobotDescriptionError(f"cannot load URDF {urdf}: {str(exc).strip()} (searched package folders "
                                    f"{search}; pass --package-dir for a package:// folder elsewhere)") from exc
    notes: list[str] = []
    if not len(cmodel.geometryObjects):
        cmodel = vmodel
        notes.append("the URDF has no <collision> geometry: the feet are measured on the visual meshes, and the "
                     "plant's feet touch the ground through them (their convex hulls, [mujoco] foot = \"urdf\")")
    data = model.createData()
    q0 = pin.neutral(model)
    pin.framesForwardKinematics(model, data, q0)
    base = data.oMi[1].translation
    pos = np.array([data.oMi[j].translation for j in range(1, model.njoints)])
    children = {j: [c for c in range(2, model.njoints) if model.parents[c] == j] for j in range(1, model.njoints)}
    leaves = [j for j in range(2, model.njoints) if not children[j]]
    # up axis: the longest extent of the joint origins; its sign: where the feet are not (two branch tips at
    # the same extreme, apart laterally)
    ext = pos.max(axis=0) - pos.min(axis=0)
    axis = int(np.argmax(ext))
    best = None
    for sign in (-1.0, 1.0):
        tips = sorted(leaves, key=lambda j: sign * data.oMi[j].translation[axis], reverse=True)
        a = tips[0]
        for b in tips[1:]:
            ca, cb = joint_chain(model, a), joint_chain(model, b)
            split = len([x for x, y in zip(ca, cb) if x == y])
            da, db = sign * data.oMi[a].translation[axis], sign * data.oMi[b].translation[axis]
            lat = np.delete(data.oMi[a].translation - data.oMi[b].translation, axis)
            if da - db < 0.05 and np.linalg.norm(lat) > 0.05 and split <= 2:
                reach = da - sign * base[axis]
                if best is None or reach > best[0]:
                    best = (reach, sign, a, b)
                break
    if best is None:
        raise RobotDescriptionError(
            f"{urdf.name}: no two feet found (two branch tips of the kinematic tree at the same lowest height, "
            f"apart sideways); write the robot file by hand (docs/pages/how-to/robot-file.md) naming left_sole/right_sole")
    _, sign, fa, fb = best
    down = np.zeros(3)
    down[axis] = sign
    up_name = f"{'+' if sign < 0 else '-'}{'xyz'[axis]}"
    # the foot joints: walk up from the tip to the first joint carrying collision geometry
    feet = []
    for tip in (fa, fb):
        j = tip
        while j > 1 and _geometry_points_world(model, data, cmodel, j) is None:
            j = model.parents[j]
        feet.append(j if j > 1 else tip)
    # lateral axis: the horizontal axis separating the feet; left/right from the link names when they say so,
    # then forward = left × up (x = y × z); else forward from the toes (the foot's contact patch reaches further
    # in front of the ankle than behind it) and left = the +y side
    horiz = [i for i in range(3) if i != axis]
    sep = data.oMi[feet[0]].translation - data.oMi[feet[1]].translation
    lat_axis = horiz[int(np.argmax(np.abs(sep[horiz])))]
    fwd_axis = next(i for i in horiz if i != lat_axis)
    up = -down
    names = [model.names[j] for j in feet]
    sides = [_side_from_name(n) for n in names]
    if sides[0] is not None and sides[1] is not None and sides[0] != sides[1]:
        left_dir = np.zeros(3)
        left_dir[lat_axis] = np.sign(sep[lat_axis]) * (1.0 if sides[0] == "left" else -1.0)
        fwd = np.cross(left_dir, up)
        how = "link names"
    else:
        pts = _geometry_points_world(model, data, cmodel, feet[0])
        fsign = 1.0
        if pts is not None:
            low = pts[sign * pts[:, axis] >= (sign * pts[:, axis]).max() - 0.01]
            offset = 0.5 * (low[:, fwd_axis].max() + low[:, fwd_axis].min()) - data.oMi[feet[0]].translation[fwd_axis]
            span = float(low[:, fwd_axis].max() - low[:, fwd_axis].min())
            if abs(offset) > 0.1 * span:
                fsign = 1.0 if offset > 0 else -1.0
        fwd = np.zeros(3)
        fwd[fwd_axis] = fsign
        left_dir = np.cross(up, fwd)
        sides = ["left", "right"] if float(sep @ left_dir) > 0 else ["right", "left"]
        how = "the +y side (forward: the toes)"
    rot = np.vstack([fwd, np.cross(up, fwd), up])  # world ← model: rows are the model's axes that become x, y, z
    base_rpy = (0.0, 0.0, 0.0)
    fwd_name = f"{'+' if fwd[fwd_axis] > 0 else '-'}{'xyz'[fwd_axis]}"
    if not np.allclose(rot, np.eye(3)):
        base_rpy = tuple(round(float(a), 6) for a in pin.rpy.matrixToRpy(rot))
        notes.append(f"up axis: the model's {up_name}, forward {fwd_name}; base_rpy = {list(base_rpy)} turns it "
                     f"z-up, x forward")
    else:
        notes.append("up axis: +z, forward +x (no base rotation)")
    foot = dict(zip(sides, feet))
    notes.append(f"feet: joints {model.names[foot['left']]!r} (left) and {model.names[foot['right']]!r} (right), "
                 f"the lowest branch tips, left/right from {how}")
    # sole frames: an existing '*sole*' frame on the foot joint, else one at the centre of the contact patch
    frames: list[FrameSpec] = []
    soles = {}
    patches, flats = [], []
    for side, j in foot.items():
        p = _geometry_points_world(model, data, cmodel, j, up)
        body = next(f for f in model.frames if f.parentJoint == j and f.type == pin.FrameType.BODY)
        if p is None:
            raise RobotDescriptionError(
                f"{urdf.name}: the {side} foot (joint {model.names[j]!r}) has no geometry to put a sole frame on; "
                f"add a [[frames]] sole frame and a [sole] rectangle by hand (docs/pages/how-to/robot-file.md)")
        pw = p @ rot.T
        low = pw[pw[:, 2] <= pw[:, 2].min() + 0.01]
        c = np.array([0.5 * (low[:, 0].max() + low[:, 0].min()), 0.5 * (low[:, 1].max() + low[:, 1].min()),
                      pw[:, 2].min()])
        patches.append(low.max(axis=0) - low.min(axis=0))
        flats.append(touch_rectangle(pw[:, :2] - c[:2], pw[:, 2] - c[2], patches[-1][:2]))
        existing = [f for f in model.frames if f.parentJoint == j and "sole" in f.name.lower()
                    and f.type in (pin.FrameType.BODY, pin.FrameType.OP_FRAME)]
        for f in existing:
            w_m_f = pin.SE3(rot, np.zeros(3)) * data.oMf[model.getFrameId(f.name)]
            if (w_m_f.rotation[2, 2] > math.cos(math.radians(5)) and w_m_f.rotation[0, 0] > math.cos(
                    math.radians(10)) and np.linalg.norm(w_m_f.translation - c) < 0.01):
                soles[side] = f.name
                notes.append(f"{side} sole: the URDF's frame {f.name!r}")
                break
        if side in soles:
            continue
        if existing:
            notes.append(f"{side} sole: the URDF's frames {[f.name for f in existing][:3]}"
                         f"{'...' if len(existing) > 3 else ''} are not at the centre of the foot's contact patch "
                         f"with z up and x forward (within 1 cm, 5°/10°)")
        w_m_body = pin.SE3(rot, np.zeros(3)) * data.oMf[model.getFrameId(body.name)]
        w_m_sole = pin.SE3(np.eye(3), c)
        body_m_sole = w_m_body.inverse() * w_m_sole
        name = f"{side}_sole"
        while model.existFrame(name):
            name = f"wbc_{name}"
        frames.append(FrameSpec(name, body.name, tuple(round(float(x), 5) for x in body_m_sole.translation),
                                tuple(round(float(x), 6) for x in pin.rpy.matrixToRpy(body_m_sole.rotation))))
        soles[side] = name
        notes.append(f"{side} sole: new frame {name!r} on link {body.name!r} at the centre of the foot's contact "
                     f"patch (lowest 1 cm of its geometry), z up, x forward")
    # torso and hands
    bodies = [f.name for f in model.frames if f.type == pin.FrameType.BODY]
    root = next(f.name for f in model.frames if f.parentJoint == 1 and f.type == pin.FrameType.BODY)
    plain = [n for n in sorted(bodies, key=len) if not _side_from_name(n)
             and not any(k in n.lower() for k in ("imu", "sensor", "camera", "frame", "gyro", "accel"))]
    torso = upper_body_link(model, list(foot.values()))
    how = "the root link: no waist joint above it" if torso == root else "the link above the waist joints"
    if torso == root:  # no waist: a link named as a torso on the root (fixed joints merged), else the root
        torso = next((n for key in ("torso", "chest", "trunk", "upper_body", "body") for n in plain
                      if key in n.lower() and model.frames[model.getFrameId(n)].parentJoint == 1), root)
        how = how if torso == root else "by name, on the root (no waist joint)"
    notes.append(f"torso: {torso!r} ({how})")
    hands = {}
    for side in ("left", "right"):
        for key in ("hand", "gripper", "palm", "wrist"):
            cands = [n for n in bodies if key in n.lower() and _side_from_name(n) == side]
            if cands:
                hands[side] = min(cands, key=lambda n: (len(joint_chain(model, model.frames[model.getFrameId(n)]
                                                                             .parentJoint)), len(n)))
                break
    if hands:
        notes.append(f"hands: {hands} (by name)")
    # SRDF beside the URDF
    srdf = reference = None
    for cand in [urdf.with_suffix(".srdf"), urdf.parent.parent / "srdf" / f"{urdf.stem}.srdf",
                 *sorted((urdf.parent.parent / "srdf").glob("*.srdf"))]:
        if cand.is_file():
            try:
                tree = check_xml(cand, "SRDF")
            except RobotDescriptionError:
                continue
            states = [s.get("name") for s in tree.getroot().iter("group_state")]
            if states:
                srdf = str(cand)
                reference = next((s for s in ("half_sitting", "standing", "stand") if s in states), states[0])
                notes.append(f"reference posture: group_state {reference!r} of {cand} (has {states})")
                break
    # joints whose zero is outside their limits start at the nearest limit
    clipped = {}
    if reference is None:
        for j in range(2, model.njoints):
            jm = model.joints[j]
            lo, hi = model.lowerPositionLimit[jm.idx_q], model.upperPositionLimit[jm.idx_q]
            if jm.nq == 1 and not lo <= 0.0 <= hi:
                inside = min(0.05 * float(hi - lo), 0.05)  # rad (or m) inside the range, off the limit
                clipped[model.names[j]] = round(float(lo + inside if lo > 0 else hi - inside), 4)
        if clipped:
            notes.append(f"reference posture: joints whose zero is outside their limits start 0.05 rad (at most 5 % "
                         f"of their range) inside the nearest limit: {clipped}")
    flat = min(float(min(f[0] / p[0], f[1] / p[1])) for f, p in zip(flats, patches))
    if flat >= MIN_FLAT_PATCH:
        mujoco = MujocoOptions(foot="urdf")
        length = round(0.95 * min(float(f[0]) for f in flats), 3)
        width = round(0.95 * min(float(f[1]) for f in flats), 3)
        how = (f"95 % of the largest rectangle at least 80 % of the footprint's length, centred on the sole frame "
               f"inside the convex hull of the smaller foot's geometry within {FLAT_BAND * 1000:.0f} mm of its "
               f"lowest point: where it touches a flat floor")
        notes.append(f"plant's feet: the robot's own foot geometry ([mujoco] foot = \"urdf\"): it touches a flat "
                     f"floor on a patch holding a rectangle of ≥ {flat:.0%} of its footprint's length and width")
    else:
        mujoco = MujocoOptions(foot="box")
        length = round(0.95 * min(float(p[0]) for p in patches), 3)
        width = round(0.95 * min(float(p[1]) for p in patches), 3)
        how = "95 % of the smaller foot's footprint, the lowest 1 cm of its geometry"
        notes.append(f"plant's feet: boxes of the sole rectangle ([mujoco] foot = \"box\"), not the robot's own "
                     f"foot geometry: within {FLAT_BAND * 1000:.0f} mm of its lowest point it touches a flat floor "
                     f"on a patch holding only {flat:.0%} of its footprint's length or width (a rounded or tilted "
                     f"foot bottom rocks on the floor; needs ≥ {MIN_FLAT_PATCH:.0%})")
    missing = _joints_without_rotor_data(model, srdf)
    if missing:
        mujoco = MujocoOptions(foot=mujoco.foot, armature=ASSUMED_ARMATURE)
        notes.append(f"drives: no rotor data (SRDF <rotor_params>) for {len(missing)} joints (e.g. {missing[0]!r}): "
                     f"[mujoco] armature = {ASSUMED_ARMATURE} kg·m² assumed for them (MuJoCo Menagerie's G1); set "
                     f"your drives' rotor inertia × gear ratio²")
    name = urdf.stem if urdf.stem.lower() not in ("model", "robot", "urdf") else urdf.parent.name
    spec = RobotSpec(name=name, base_dir=urdf.parent, urdf=str(urdf), srdf=srdf, reference=reference,
                     reference_joints=clipped,
                     left_sole=soles["left"], right_sole=soles["right"], torso=torso, left_hand=hands.get("left"),
                     right_hand=hands.get("right"), frames=tuple(frames), package_dirs=tuple(dirs),
                     base_rpy=base_rpy, mujoco=mujoco)
    notes.append(f"sole rectangle: {length} x {width} m ({how})")
    spec = RobotSpec(**{**spec.__dict__, "sole_length": length, "sole_width": width})
    robot = build_robot(spec)
    if reference is None:
        joints = _bent_knees(robot, notes)
        spec = RobotSpec(**{**spec.__dict__, "reference_joints": {**clipped, **joints}})
        robot = build_robot(spec)
    gait = {k: float(v) for k, v in robot.gait.items()}
    notes.append(f"gait: {gait} (scaled from Talos's by the leg length)")
    return RobotSpec(**{**spec.__dict__, "gait": gait}), notes


def _rectangle_outside(points: np.ndarray, length: float, width: float) -> float | None:
    """Largest distance (m, rounded to 0.1 mm) of a corner of the ``length`` × ``width`` rectangle centred on the
    sole frame outside the convex hull of the foot points (sole frame, (k, 3)) within :data:`FLAT_BAND` of the
    lowest; 0 when all corners are inside, None when those points have no area."""
    touch = points[points[:, 2] <= points[:, 2].min() + FLAT_BAND, :2]
    try:
        poly = convex_hull(touch)
    except InvalidInputError:
        return None
    corners = np.array([[sx * length / 2, sy * width / 2] for sx in (-1, 1) for sy in (-1, 1)])
    return round(max(0.0, -float(signed_distance(corners, poly).min())), 4)


def _joints_without_rotor_data(model: pin.Model, srdf: str | None) -> list[str]:
    """Names of the actuated joints whose SRDF ``<rotor_params>`` give no rotor inertia (all of them without an
    SRDF or without rotor_params)."""
    names = [model.names[j] for j in range(2, model.njoints) if model.joints[j].nv > 0]
    if srdf is None or "rotor_params" not in Path(srdf).read_text():
        return names
    m = model.copy()
    pin.loadRotorParameters(m, str(srdf), False)
    arm = np.asarray(m.rotorInertia) * np.asarray(m.rotorGearRatio) ** 2
    return [model.names[j] for j in range(2, model.njoints) if model.joints[j].nv > 0
            and not np.any(arm[model.joints[j].idx_v:model.joints[j].idx_v + model.joints[j].nv] > 0)]


def reach_frame(model: pin.Model, data: pin.Data, q: np.ndarray, fid: int, chain: list[int], target: pin.SE3, *,
                iterations: int, tolerance: float, damping: float) -> None:
    """Move frame ``fid`` towards ``target`` by the joints of ``chain``, in place on ``q``.

    Damped least squares (Levenberg–Marquardt step, Wampler 1986; Buss 2004 eq. 10):
    Δq = Jᵀ (J Jᵀ + λ I)⁻¹ e with e = log6(oMf⁻¹ · target) (6-D, the frame's LOCAL velocity that reaches the target
    in unit time) and J Pinocchio's LOCAL frame Jacobian restricted to the chain's columns; each step clipped into
    the joints' position limits.

    Args:
        model, data: Pinocchio model and a data of it (its placements are overwritten).
        q: configuration (nq,), updated in place.
        fid: frame index; target: its goal placement in the world frame.
        chain: indices of one-dof joints (nq = nv = 1) that move it.
        iterations: at most this many steps; tolerance: stop once ‖e‖ < tolerance; damping: λ (≥ 0).
    """
    iv = [model.joints[j].idx_v for j in chain]
    iq = [model.joints[j].idx_q for j in chain]
    lo, hi = model.lowerPositionLimit[iq], model.upperPositionLimit[iq]
    for _ in range(iterations):
        pin.framesForwardKinematics(model, data, q)
        err = pin.log6(data.oMf[fid].actInv(target)).vector
        if np.linalg.norm(err) < tolerance:
            break
        jac = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL)[:, iv]
        dq = jac.T @ np.linalg.solve(jac @ jac.T + damping * np.eye(6), err)
        q[iq] = np.clip(q[iq] + dq, lo, hi)


def _bent_knees(robot: Robot, notes: list[str]) -> dict[str, float]:
    """Leg joint angles that raise each sole towards the base by ``KNEE_LIFT`` × the leg length, the sole
    orientation kept (damped least squares on Pinocchio's frame Jacobian, joint limits clipped); the knee (the
    middle joint of the leg chain) is seeded towards its wider range to leave the straight-leg singularity."""
    model = robot.model
    data = model.createData()
    q = robot.q_ref.copy()
    out = {}
    for frame in (robot.left_sole, robot.right_sole):
        fid = model.getFrameId(frame)
        chain = [j for j in joint_chain(model, model.frames[fid].parentJoint)[1:] if model.joints[j].nq == 1]
        if len(chain) < 3:
            continue
        pin.framesForwardKinematics(model, data, q)
        length = float(abs(data.oMf[fid].translation[2] - data.oMi[chain[0]].translation[2]))
        target = data.oMf[fid].copy()
        target.translation = target.translation + np.array([0.0, 0.0, KNEE_LIFT * length])
        knee = max(chain[1:-1], key=lambda j: min(np.linalg.norm(data.oMi[j].translation
                                                                 - data.oMi[chain[0]].translation),
                                                  np.linalg.norm(data.oMi[j].translation
                                                                 - data.oMf[fid].translation)))
        iq = model.joints[knee].idx_q
        lo, hi = model.lowerPositionLimit[iq], model.upperPositionLimit[iq]
        q[iq] = np.clip(0.3 if hi >= -lo else -0.3, lo, hi)
        reach_frame(model, data, q, fid, chain, target, iterations=200, tolerance=1e-6, damping=1e-4)
        for j in chain:
            out[model.names[j]] = round(float(q[model.joints[j].idx_q]), 4)
    notes.append(f"reference posture: no SRDF found; knees bent (feet {KNEE_LIFT:.0%} of the leg length closer to "
                 f"the base, soles flat): {out}")
    return out


def check_robot(path_or_name: str | Path | Robot) -> dict:
    """Load a robot (file, catalog name or URDF; or take a loaded one) and measure it; any failure is the loader's
    typed error.

    Returns:
        a report: ``name``, ``nq``, ``nv``, ``mass_kg``, ``com_height_m`` (above the soles in ``q_ref``),
        ``base_height_m``, ``legs`` (side → joint names from the base to the sole), ``soles`` (side → frame,
        height of the foot geometry's lowest point in the sole frame in m, contact patch size),
        ``sole_rectangle_m``, ``locked_joints``, ``inertia_fixes``, ``no_velocity_limit`` / ``no_effort_limit``
        (joint names), ``massless_joint_bodies``; per sole, ``patch_minus_rectangle_m``: how far the foot's contact
        patch (its geometry's lowest 1 cm) reaches beyond the sole rectangle at the front, back, left and right
        (m), ``rectangle_outside_touch_m``: how far a corner of the sole rectangle lies outside where the foot
        touches a flat floor (convex hull of its geometry within ``FLAT_BAND`` of the lowest point; 0 inside), and
        ``plant_foot``: the plant's feet (``[mujoco] foot``).

    Raises:
        RobotDescriptionError: also when the reference CoM is less than ``MIN_COM_MARGIN`` inside the support
            polygon, or a foot's contact patch is turned across the walking direction; otherwise the typed errors
            of :func:`wbc.robot.load_robot`.
    """
    robot = path_or_name if isinstance(path_or_name, Robot) else load_robot(path_or_name)
    model = robot.model
    data = model.createData()
    pin.centerOfMass(model, data, robot.q_ref)
    pin.framesForwardKinematics(model, data, robot.q_ref)
    legs, soles = {}, {}
    for side in ("left", "right"):
        frame = getattr(robot, f"{side}_sole")
        chain = joint_chain(model, model.frames[model.getFrameId(frame)].parentJoint)[1:]
        legs[side] = [model.names[j] for j in chain]
        p = foot_points(robot, frame, robot.collision_model)
        if p is None and robot.visual_model is not None:  # no collision geometry: the plant uses the visual
            p = foot_points(robot, frame, robot.visual_model)
        if p is None:
            soles[side] = {"frame": frame, "foot_geometry": None}
        else:
            patch = p[p[:, 2] <= p[:, 2].min() + 0.01]
            span = patch.max(axis=0) - patch.min(axis=0)
            if span[1] > 1.5 * span[0]:
                raise RobotDescriptionError(
                    f"{robot.name}: the {side} foot's contact patch is {span[0]:.3f} m long (x, forward) and "
                    f"{span[1]:.3f} m wide (y) in sole frame {frame!r}: the foot geometry is turned across the "
                    f"walking direction (a mesh rotated in the URDF, e.g. a Collada <up_axis> not applied by the "
                    f"loaders, or a sole frame with x sideways). Fix the foot's <collision> origin rpy, or name a "
                    f"sole frame whose x axis points along the foot")
            a, b = 0.5 * robot.sole_length, 0.5 * robot.sole_width
            soles[side] = {"frame": frame, "foot_bottom_m": round(float(p[:, 2].min()), 4),
                           # how far the foot's contact patch (the plant's foot with [mujoco] foot = "urdf")
                           # reaches beyond the controller's sole rectangle: front, back, left, right (m)
                           "patch_minus_rectangle_m": [round(float(patch[:, 0].max() - a), 3),
                                                       round(float(-patch[:, 0].min() - a), 3),
                                                       round(float(patch[:, 1].max() - b), 3),
                                                       round(float(-patch[:, 1].min() - b), 3)],
                           # how far the rectangle's corners reach outside where the foot touches a flat floor
                           # (convex hull of its geometry within FLAT_BAND of the lowest point; 0: inside)
                           "rectangle_outside_touch_m": _rectangle_outside(p, robot.sole_length, robot.sole_width),
                           "plant_foot": robot.spec.mujoco.foot if robot.spec is not None else "box",
                           "patch_x_m": [round(float(patch[:, 0].min()), 3), round(float(patch[:, 0].max()), 3)],
                           "patch_y_m": [round(float(patch[:, 1].min()), 3), round(float(patch[:, 1].max()), 3)]}
    poses = [data.oMf[model.getFrameId(f)] for f in (robot.left_sole, robot.right_sole)]
    polygon = support_polygon(poses, robot.sole_length, robot.sole_width)
    margin = polygon_margin(data.com[0][:2], polygon)
    if margin < MIN_COM_MARGIN:
        raise RobotDescriptionError(
            f"{robot.name}: in the reference posture the CoM (x, y) = {np.round(data.com[0][:2], 3).tolist()} m is "
            f"{'inside' if margin >= 0 else 'outside'} the feet's support polygon by {abs(margin):.3f} m (needs "
            f"≥ {MIN_COM_MARGIN} m inside to start a walk); change the reference posture ([reference_joints] / "
            f"reference) or the sole frames and [sole] rectangle so that the CoM is over the feet")
    no_vel = [model.names[j] for j in range(2, model.njoints)
              if not (0 < model.velocityLimit[model.joints[j].idx_v] < np.inf)]
    no_eff = [model.names[j] for j in range(2, model.njoints)
              if not (0 < model.effortLimit[model.joints[j].idx_v] < np.inf)]
    massless = [model.names[j] for j in range(1, model.njoints) if model.inertias[j].mass <= 0]
    return {"name": robot.name, "nq": robot.nq, "nv": robot.nv, "mass_kg": round(robot.mass, 3),
            "com_height_m": round(float(data.com[0][2]), 4), "base_height_m": round(float(robot.q_ref[2]), 4),
            "legs": legs, "soles": soles, "sole_rectangle_m": [robot.sole_length, robot.sole_width],
            "torso": robot.torso, "hands": [robot.left_hand, robot.right_hand],
            "locked_joints": robot.locked_joints, "inertia_fixes": robot.inertia_fixes, "no_velocity_limit": no_vel, "no_effort_limit": no_eff,
            "massless_joint_bodies": massless, "gait": robot.gait}
