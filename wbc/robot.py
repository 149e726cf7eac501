"""Robot models: URDF (+SRDF) → Pinocchio model with a free-flyer base and humanoid semantics.

A :class:`Robot` bundles the Pinocchio model, its geometry models, a reference standing configuration with both
soles on the ground plane z = 0, and the semantic frames the controllers need (left/right sole, torso, hands)
with the sole rectangle size.

Catalog robots are described by TOML descriptors in the repository's ``robots/`` folder (installed as
``wbc.robots``); ``load_robot(path_to_urdf, ...)`` loads any other humanoid.
"""

from __future__ import annotations

import difflib
import importlib.metadata
import importlib.resources
import math
import warnings
import xml.etree.ElementTree as ET
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

import numpy as np
import pinocchio as pin

from wbc.exceptions import (
    RobotDescriptionError,
    RobotFileNotFoundError,
    UnknownFrameError,
    UnknownJointError,
    UnknownRobotError,
)
from wbc.robot_file import (LIMIT_INVERSION_TOLERANCE, RobotSpec, check_urdf_values, check_xml, lock_zero_range_joints,
                            load_robot_file, package_roots, physical_inertials)

__all__ = ["Robot", "load_robot", "robot_spec", "build_robot", "catalog", "example_robot_data_dir"]

_ERD_PREFIX = "erd:"


@cache
def example_robot_data_dir() -> Path:
    """Folder that contains ``example-robot-data/robots`` (pass it as Pinocchio's ``package_dirs``).

    example-robot-data ships only data (no Python module), inside ``<site-packages>/cmeel.prefix/share``; the
    folder is found from the installed distribution's file list.

    Raises:
        RobotFileNotFoundError: example-robot-data is not installed.
    """
    try:
        files = importlib.metadata.files("example-robot-data") or []
    except importlib.metadata.PackageNotFoundError as exc:
        raise RobotFileNotFoundError(
            "example-robot-data is not installed; install it with `pip install example-robot-data==6.0.0`"
        ) from exc
    for f in files:
        parts = Path(str(f)).parts
        if "example-robot-data" in parts and "robots" in parts:
            located = Path(f.locate())
            while located.name != "example-robot-data":
                located = located.parent
            return located.parent
    raise RobotFileNotFoundError("example-robot-data is installed but contains no robots/ folder")


def _robots_dir() -> Path:
    return Path(str(importlib.resources.files("wbc.robots")))


def catalog() -> list[str]:
    """Names accepted by :func:`load_robot` (one ``robots/<name>.toml`` descriptor each)."""
    return sorted(p.stem for p in _robots_dir().glob("*.toml"))


class _GeometryBuilder:
    """Builds one geometry model of a URDF for a Pinocchio model when called (:class:`_LazyGeometry`)."""

    def __init__(self, model: pin.Model, urdf: Path, urdf_xml: str | None, kind: pin.GeometryType, dirs: list[str]):
        self.model, self.urdf, self.urdf_xml, self.kind, self.dirs = model, urdf, urdf_xml, kind, dirs

    def __call__(self) -> pin.GeometryModel:
        return _build_geometry(self.model, self.urdf, self.urdf_xml, self.kind, self.dirs)


class _LazyGeometry:
    """Data descriptor of :attr:`Robot.visual_model`: the instance holds a GeometryModel, or a
    :class:`_GeometryBuilder` replaced by the model it builds on the first read."""

    def __set_name__(self, owner, name: str) -> None:
        self._key = "_built_" + name

    def __get__(self, robot, owner=None):
        if robot is None:  # no class-level value: the dataclass field stays a required one
            raise AttributeError(self._key)
        value = robot.__dict__[self._key]
        if isinstance(value, _GeometryBuilder):
            value = robot.__dict__[self._key] = value()
        return value

    def __set__(self, robot, value) -> None:
        robot.__dict__[self._key] = value


@dataclass
class Robot:
    """A humanoid model ready for whole-body control.

    Attributes:
        name: catalog name, or the URDF file stem.
        model: Pinocchio model with a free-flyer root joint (``nq = 7 + n``, ``nv = 6 + n`` for revolute joints).
            ``q[0:3]`` base position in world (m), ``q[3:7]`` base quaternion (x, y, z, w); ``v[0:6]`` base
            spatial velocity in the base frame (LOCAL).
        collision_model, visual_model: Pinocchio geometry models (meshes resolved). ``visual_model`` is built on
            its first read (its meshes are only needed to draw the robot; a controller run never reads it): a
            visual mesh that cannot be found raises :class:`~wbc.exceptions.RobotFileNotFoundError` there, not in
            :func:`load_robot`. A GeometryModel assigned or passed to the constructor is kept as is.
        q_ref: (nq,) reference standing configuration, soles on z = 0, mid-point of the soles at x = y = 0.
        left_sole, right_sole: frame names at the centre of each sole, z axis up out of the ground.
        torso: frame name of the upper body (orientation task target).
        left_hand, right_hand: frame names of the hands (may be None).
        sole_length, sole_width: size (m) of the contact rectangle, centred on the sole frame, x forward.
        urdf_path, srdf_path: source files.
        package_dirs: folders used to resolve ``package://`` URIs.
        added_frames: frames added to the URDF's ones: name -> (parent frame name, placement in parent).
        gait: default walking parameters for this robot (keyword arguments of ``wbc.gait.plan_walk``: step
            length, height, timing...), from the descriptor's ``[gait]`` table.
        spec: the robot file's content it was built from (with the overrides applied), incl. MuJoCo options.
        urdf_xml: the URDF text actually loaded when its inertials had to be made physical (massless moving links,
            point masses: :func:`wbc.robot_file.physical_inertials`), None when the file was loaded as is; the
            MuJoCo plant loads the same text.
        inertia_fixes: one sentence per link whose inertial was changed.
        locked_joints: URDF joints with an empty range, loaded as fixed joints at their only value
            (:func:`wbc.robot_file.lock_zero_range_joints`): not in ``model``, not variables of any QP.
    """

    name: str
    model: pin.Model
    collision_model: pin.GeometryModel
    visual_model: pin.GeometryModel = _LazyGeometry()
    q_ref: np.ndarray
    left_sole: str
    right_sole: str
    torso: str
    sole_length: float
    sole_width: float
    urdf_path: Path
    srdf_path: Path | None = None
    package_dirs: list[str] = field(default_factory=list)
    left_hand: str | None = None
    right_hand: str | None = None
    added_frames: dict[str, tuple[str, pin.SE3]] = field(default_factory=dict)
    gait: dict[str, float] = field(default_factory=dict)
    spec: RobotSpec | None = None
    urdf_xml: str | None = None
    inertia_fixes: list[str] = field(default_factory=list)
    locked_joints: list[str] = field(default_factory=list)

    @property
    def stairs(self) -> dict[str, float]:
        """Walk parameters of this robot on stairs that replace its defaults there (the robot file's ``[stairs]``
        table, :data:`wbc.robot_file.STAIRS_KEYS`: ``step_width`` in m); empty without one."""
        return dict(self.spec.stairs) if self.spec is not None else {}

    @property
    def nq(self) -> int:
        """Size of the configuration vector q."""
        return self.model.nq

    @property
    def nv(self) -> int:
        """Size of the velocity vector v (tangent space of q)."""
        return self.model.nv

    @property
    def mass(self) -> float:
        """Total mass (kg)."""
        return float(sum(inertia.mass for inertia in self.model.inertias))

    @property
    def gravity(self) -> float:
        """Gravity magnitude (m/s²) of the model: the norm of ``model.gravity.linear`` (Pinocchio's default 9.81)."""
        return float(np.linalg.norm(self.model.gravity.linear))

    @property
    def joint_names(self) -> list[str]:
        """Names of the actuated joints in Pinocchio's order (root joint excluded)."""
        return list(self.model.names[2:])

    def frame_id(self, name: str) -> int:
        """Pinocchio frame index of ``name``.

        Raises:
            UnknownFrameError: no such frame; the message lists the closest frame names.
        """
        if not isinstance(name, str) or not self.model.existFrame(name):
            names = [f.name for f in self.model.frames]
            close = difflib.get_close_matches(str(name), names, n=5, cutoff=0.4)
            raise UnknownFrameError(
                f"robot {self.name!r} has no frame {name!r}; close matches: {close or names[:10]}"
            )
        return self.model.getFrameId(name)

    def joint_id(self, name: str) -> int:
        """Pinocchio joint index of ``name``.

        Raises:
            UnknownJointError: no such joint; the message lists the valid joint names.
        """
        if not isinstance(name, str) or not self.model.existJointName(name):
            raise UnknownJointError(f"robot {self.name!r} has no joint {name!r}; valid: {self.joint_names}")
        return self.model.getJointId(name)

    def sole_corners_local(self) -> np.ndarray:
        """(4, 3) corners of the sole rectangle in the sole frame (m), counter-clockwise seen from above."""
        a, b = 0.5 * self.sole_length, 0.5 * self.sole_width
        return np.array([[a, b, 0.0], [-a, b, 0.0], [-a, -b, 0.0], [a, -b, 0.0]])


def _resolve_path(spec: str, base: Path) -> Path:
    if spec.startswith(_ERD_PREFIX):
        return example_robot_data_dir() / "example-robot-data" / "robots" / spec[len(_ERD_PREFIX):]
    p = Path(spec)
    return p if p.is_absolute() else base / p


def _placement(xyz, rpy) -> pin.SE3:
    return pin.SE3(pin.rpy.rpyToMatrix(*map(float, rpy)), np.asarray(xyz, dtype=float))


def load_robot(
    name_or_urdf: str | Path,
    *,
    srdf: str | Path | None = None,
    reference: str | None = None,
    reference_joints: dict[str, float] | None = None,
    left_sole: str | None = None,
    right_sole: str | None = None,
    torso: str | None = None,
    left_hand: str | None = None,
    right_hand: str | None = None,
    sole_length: float | None = None,
    sole_width: float | None = None,
    package_dirs: list[str | Path] | None = None,
) -> Robot:
    """Load a catalog robot by name, a robot file (``.toml``), or any humanoid URDF.

    Args:
        name_or_urdf: a catalog name (see :func:`catalog`: ``talos``, ``g1``, ``humanoid15``), a path to a robot
            file (``.toml``, format in ``docs/pages/how-to/robot-file.md``, see :mod:`wbc.robot_file`) or a path
            to a ``.urdf``.
        srdf: SRDF path providing named reference configurations (``reference``).
        reference: name of the SRDF reference configuration to use as ``q_ref``.
        reference_joints: joint name -> angle (rad) set in ``q_ref`` (on top of the SRDF reference when given).
        left_sole, right_sole, torso: frame names (required for a URDF path).
        left_hand, right_hand: optional hand frame names.
        sole_length, sole_width: contact rectangle (m), centred on the sole frames.
        package_dirs: folders for ``package://`` URIs (example-robot-data's folder is always appended). For a
            catalog name or a robot file, every argument given (not None) overrides the file's value and is checked
            like it.

    Returns:
        A :class:`Robot` whose ``q_ref`` puts both soles on z = 0.

    Raises:
        UnknownRobotError: ``name_or_urdf`` is neither a catalog name nor a ``.urdf``/``.toml`` path (lists the
            catalog).
        RobotFileNotFoundError: the robot file, URDF, SRDF or a mesh does not exist.
        UnknownFrameError: a semantic frame is not in the model.
        UnknownJointError: a ``reference_joints`` key is not a joint.
        RobotDescriptionError: a robot-file key problem, malformed URDF/SRDF XML (with its line), missing semantic
            frames, unknown SRDF reference, a non-positive or non-finite sole size, a Y-up or tilted model.
    """
    spec = robot_spec(name_or_urdf)
    overrides = dict(srdf=None if srdf is None else str(Path(srdf).absolute()), reference=reference,
                     reference_joints=reference_joints, left_sole=left_sole, right_sole=right_sole, torso=torso,
                     left_hand=left_hand, right_hand=right_hand, sole_length=sole_length, sole_width=sole_width,
                     package_dirs=[str(Path(p).absolute()) for p in (package_dirs or [])])
    return build_robot(spec.with_overrides(**overrides))


def robot_spec(name_or_path: str | Path) -> RobotSpec:
    """The :class:`~wbc.robot_file.RobotSpec` of a catalog name, a robot file (``.toml``) or a bare URDF path (no
    semantic frames: give them as overrides).

    Raises:
        UnknownRobotError: neither a catalog name nor a ``.urdf``/``.toml`` path.
        RobotFileNotFoundError, RobotDescriptionError: see :func:`wbc.robot_file.load_robot_file`.
    """
    text = str(name_or_path)
    if text.lower().endswith(".toml"):
        return load_robot_file(text)
    if text.lower().endswith(".urdf"):
        p = Path(text).absolute()
        return RobotSpec(name=p.stem, base_dir=p.parent, urdf=str(p))
    names = catalog()
    if text not in names:
        raise UnknownRobotError(
            f"unknown robot {text!r}: the catalog has {names}; or pass a robot file (.toml, see `wbc robot init`) "
            f"or a .urdf path"
        )
    return load_robot_file(_robots_dir() / f"{text}.toml")


def build_robot(spec: RobotSpec) -> Robot:
    """Build the :class:`Robot` of a robot spec (see :func:`load_robot` for the errors raised)."""
    base = spec.base_dir
    frames = {fr.name: (fr.parent, _placement(fr.xyz, fr.rpy)) for fr in spec.frames}
    robot = _build(
        name=spec.name,
        urdf=_resolve_path(spec.urdf, base),
        srdf=_resolve_path(spec.srdf, base) if spec.srdf is not None else None,
        reference=spec.reference,
        reference_joints=dict(spec.reference_joints),
        frames=frames,
        left_sole=spec.left_sole,
        right_sole=spec.right_sole,
        torso=spec.torso,
        left_hand=spec.left_hand,
        right_hand=spec.right_hand,
        sole_length=spec.sole_length,
        sole_width=spec.sole_width,
        package_dirs=[str(_resolve_path(d, base)) for d in spec.package_dirs] + [str(base)],
        gait=dict(spec.gait),
        base_rpy=spec.base_rpy,
        armature=spec.mujoco.armature,
    )
    robot.spec = spec
    return robot


def _check_group_state(srdf: Path, tree, reference: str, model: pin.Model) -> None:
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


def _check_upright(robot: Robot, q: np.ndarray) -> None:
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


@contextmanager
def _urdf_errors(urdf: Path, dirs: list[str]):
    """Turn urdfdom's / Pinocchio's errors while reading ``urdf`` into wbc's (their message carries the reason).

    Raises:
        RobotFileNotFoundError: a mesh file not found in ``dirs``.
        RobotDescriptionError: any other parse error.
    """
    try:
        yield
    except (ValueError, RuntimeError) as exc:
        text = str(exc)
        if "mesh" in text.lower() and ("not found" in text.lower() or "could not" in text.lower()):
            raise RobotFileNotFoundError(
                f"URDF {urdf}: a mesh file is missing ({text.strip()}); searched package folders {dirs} — add the "
                f"folder containing the package to package_dirs in the robot file (--package-dir)") from exc
        raise RobotDescriptionError(f"cannot parse URDF {urdf}: {text} (fix the URDF: it must be well-formed XML "
                                    f"with one root link and valid joints/links)") from exc


def _build_geometry(model: pin.Model, urdf: Path, urdf_xml: str | None, kind: pin.GeometryType,
                    dirs: list[str]) -> pin.GeometryModel:
    """The geometry model of type ``kind`` of ``urdf`` (of ``urdf_xml``, its corrected text, when not None) for
    ``model``, its meshes resolved in ``dirs``.

    Raises:
        RobotFileNotFoundError, RobotDescriptionError: as :func:`_urdf_errors`.
    """
    with _urdf_errors(urdf, dirs):
        if urdf_xml is None:
            return pin.buildGeomFromUrdf(model, str(urdf), kind, None, dirs)
        return pin.buildGeomFromUrdfString(model, urdf_xml, kind, None, dirs)


def _build(
    *,
    name: str,
    urdf: Path,
    srdf: Path | None,
    reference: str | None,
    reference_joints: dict[str, float],
    frames: dict[str, tuple[str, pin.SE3]],
    left_sole: str | None,
    right_sole: str | None,
    torso: str | None,
    left_hand: str | None,
    right_hand: str | None,
    sole_length: float,
    sole_width: float,
    package_dirs: list[str],
    gait: dict[str, float] | None = None,
    base_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0),
    armature: float = 0.0,
) -> Robot:
    if not urdf.is_file():
        raise RobotFileNotFoundError(f"URDF file not found: {urdf}")
    if srdf is not None and not srdf.is_file():
        raise RobotFileNotFoundError(f"SRDF file not found: {srdf}")
    if left_sole is None or right_sole is None or torso is None:
        raise RobotDescriptionError(
            "left_sole, right_sole and torso frame names are required to load a humanoid from a URDF path"
        )
    if not all(x is None or (isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) and x > 0)
               for x in (sole_length, sole_width)):
        raise RobotDescriptionError(f"sole size must be finite and positive (m), got {sole_length} x {sole_width}")
    urdf_tree = check_xml(urdf, "URDF")
    check_urdf_values(urdf, urdf_tree.getroot())
    srdf_tree = check_xml(srdf, "SRDF") if srdf is not None else None
    dirs = [*package_dirs, str(urdf.parent), *package_roots(urdf, urdf_tree.getroot()), str(example_robot_data_dir())]
    locked = lock_zero_range_joints(urdf_tree.getroot())
    inertia_fixes = physical_inertials(urdf_tree.getroot())
    urdf_xml = None
    if inertia_fixes or locked:  # Pinocchio and MuJoCo both load the corrected text (wbc.robot_file.physical_inertials)
        for mesh in urdf_tree.getroot().iter("mesh"):
            ref = mesh.get("filename", "")
            if ref and "://" not in ref and not Path(ref).is_absolute():
                mesh.set("filename", str((urdf.parent / ref).resolve()))
        urdf_xml = ET.tostring(urdf_tree.getroot(), encoding="unicode")
    with _urdf_errors(urdf, dirs):
        if urdf_xml is None:
            model = pin.buildModelFromUrdf(str(urdf), pin.JointModelFreeFlyer())
        else:
            model = pin.buildModelFromXML(urdf_xml, pin.JointModelFreeFlyer())
    collision_model = _build_geometry(model, urdf, urdf_xml, pin.GeometryType.COLLISION, dirs)
    visual_model = _GeometryBuilder(model, urdf, urdf_xml, pin.GeometryType.VISUAL, dirs)  # built on first read
    if armature:
        model.armature[6:] = float(armature)
    model.name = name
    mass = sum(model.inertias[j].mass for j in range(1, model.njoints))
    if mass < MIN_ROBOT_MASS:
        raise RobotDescriptionError(
            f"URDF {urdf}: total mass is {mass:.3g} kg ({len(inertia_fixes)} massless or non-physical inertials "
            f"were given the minimal one): its <inertial> elements are missing — add masses and inertias to the "
            f"links (a whole-body controller needs them; valid: a total mass ≥ {MIN_ROBOT_MASS:g} kg)")
    _check_limit_order(model, urdf)
    for fname, (parent, placement) in frames.items():
        if not model.existFrame(parent):
            raise UnknownFrameError(f"descriptor of {name!r}: parent frame {parent!r} of {fname!r} not in URDF")
        if model.existFrame(fname):
            kind = model.frames[model.getFrameId(fname)].type.name.lower().replace("_", " ")
            raise RobotDescriptionError(
                f"descriptor of {name!r}: [[frames]] name {fname!r} is already a frame of the URDF (a {kind}); "
                f"give the added frame a name of its own")
        pid = model.getFrameId(parent)
        pframe = model.frames[pid]
        model.addFrame(
            pin.Frame(fname, pframe.parentJoint, pid, pframe.placement * placement, pin.FrameType.OP_FRAME)
        )
    robot = Robot(
        locked_joints=locked,
        urdf_xml=urdf_xml,
        inertia_fixes=inertia_fixes,
        name=name,
        model=model,
        collision_model=collision_model,
        visual_model=visual_model,
        q_ref=pin.neutral(model),
        left_sole=left_sole,
        right_sole=right_sole,
        torso=torso,
        left_hand=left_hand,
        right_hand=right_hand,
        sole_length=float(sole_length) if sole_length is not None else math.nan,
        sole_width=float(sole_width) if sole_width is not None else math.nan,
        urdf_path=urdf,
        srdf_path=srdf,
        package_dirs=dirs,
        added_frames=frames,
        gait=dict(gait or {}),
    )
    for f in (left_sole, right_sole, torso, left_hand, right_hand):
        if f is not None:
            robot.frame_id(f)
    q = pin.neutral(model)
    if reference is not None:
        if srdf is None:
            raise RobotDescriptionError(f"reference configuration {reference!r} requested but no SRDF given")
        try:
            pin.loadReferenceConfigurations(model, str(srdf), False)
        except (ValueError, RuntimeError) as exc:
            raise RobotDescriptionError(f"cannot read the reference configurations of SRDF {srdf}: "
                                        f"{str(exc).strip()} (fix the group_state entries: joint names of the URDF, "
                                        f"one value per joint)") from exc
        names = [entry.key() for entry in model.referenceConfigurations]
        if reference not in names:
            raise RobotDescriptionError(f"SRDF {srdf} has no reference configuration {reference!r}; has {names}")
        _check_group_state(srdf, srdf_tree, reference, model)
        q = np.array(model.referenceConfigurations[reference], dtype=float)
    for jname, angle in reference_joints.items():
        jid = robot.joint_id(jname)
        try:
            ok = math.isfinite(float(angle))
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise RobotDescriptionError(f"reference_joints[{jname!r}] must be a finite angle (rad), got {angle!r}")
        q[model.joints[jid].idx_q] = float(angle)
    if any(base_rpy):
        q[3:7] = pin.Quaternion(pin.rpy.rpyToMatrix(*map(float, base_rpy))).coeffs()
    _check_posture_limits(robot, q)
    _check_upright(robot, q)
    _check_soles_distinct(robot)
    _check_legs(robot, q)
    check_sole_heights(robot)
    if sole_length is None or sole_width is None:
        length, width = sole_rectangle_from_collision(robot)
        robot.sole_length = float(sole_length) if sole_length is not None else length
        robot.sole_width = float(sole_width) if sole_width is not None else width
    robot.q_ref = _stand_on_ground(robot, q)
    _check_robot(robot)
    if not robot.gait:
        robot.gait = scaled_gait(robot)
    return robot




#: Talos's gait (robots/talos.toml) and its base height above the soles in half_sitting (m): the reference of
#: :func:`scaled_gait`.
_REFERENCE_GAIT = {"step_length": 0.15, "step_height": 0.05, "t_ss": 0.8, "t_ds": 0.3}
_REFERENCE_LEG = 1.019


def scaled_gait(robot: Robot) -> dict[str, float]:
    """Default gait of a robot without a ``[gait]`` table: Talos's gait scaled to the robot.

    Lengths scale with the leg (base height above the soles in ``q_ref``, ratio s = leg / 1.019 m); the step
    length is also capped at 0.75 × the sole length (a step no longer than the foot keeps the ZMP transfer short);
    durations scale with √s (equal Froude number, Alexander 1984, "The gaits of bipedal and quadrupedal animals").

    Returns:
        keyword arguments of :func:`wbc.gait.plan_walk`: step_length, step_height (m), t_ss, t_ds (s).
    """
    s = float(robot.q_ref[2]) / _REFERENCE_LEG
    g = _REFERENCE_GAIT
    return {"step_length": round(float(min(g["step_length"] * s, 0.75 * robot.sole_length)), 3),
            "step_height": round(g["step_height"] * s, 3),
            "t_ss": round(g["t_ss"] * math.sqrt(s), 3), "t_ds": round(g["t_ds"] * math.sqrt(s), 3)}


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


def foot_points(robot: Robot, frame: str, geometry_model) -> np.ndarray | None:
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


def check_sole_heights(robot: Robot, tolerance: float = SOLE_HEIGHT_TOLERANCE) -> None:
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


def sole_rectangle_from_collision(robot: Robot, contact_band: float = 0.01) -> tuple[float, float]:
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


def _check_soles_distinct(robot: Robot) -> None:
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


def _check_legs(robot: Robot, q: np.ndarray) -> None:
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


def _check_limit_order(model: pin.Model, urdf: Path) -> None:
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


def _check_posture_limits(robot: Robot, q: np.ndarray) -> None:
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


def _check_robot(robot: Robot) -> None:
    """Validate a loaded humanoid (called by :func:`load_robot`).

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
    _check_posture_limits(robot, q)
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


def _stand_on_ground(robot: Robot, q: np.ndarray) -> np.ndarray:
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
