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
from wbc.robot_checks import (MIN_ROBOT_MASS, check_group_state, check_legs, check_limit_order, check_loaded_robot,
                              check_posture_limits, check_sole_heights, check_soles_distinct, check_upright,
                              sole_rectangle_from_collision, stand_on_ground)
from wbc.robot_file import (RobotSpec, check_urdf_values, check_xml, lock_zero_range_joints,
                            load_robot_file, package_roots, physical_inertials)

__all__ = ["Robot", "load_robot", "robot_spec", "build_robot", "catalog", "example_robot_data_dir"]

#: Fraction of a model's height (lowest to highest frame, neutral configuration) above its lowest frame within which
#: a frame is offered as a close match for a sole frame name.
SOLE_CANDIDATE_BAND = 0.25

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


def _sole_candidates(model) -> list[str]:
    """Frames that can be a sole: the frames (joint frames excepted) within :data:`SOLE_CANDIDATE_BAND` of the
    model's height above its lowest frame, in the neutral configuration (a foot; never a head camera or a hand),
    lowest first."""
    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    frames = [(float(data.oMf[i].translation[2]), f.name) for i, f in enumerate(model.frames)
              if f.type != pin.FrameType.JOINT and f.name != "universe"]
    if not frames:
        return []
    z = [h for h, _ in frames]
    top = min(z) + SOLE_CANDIDATE_BAND * (max(z) - min(z))
    return [n for h, n in sorted(frames) if h <= top]


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
    check_limit_order(model, urdf)
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
    for side, f in (("left", left_sole), ("right", right_sole)):
        if not model.existFrame(f):
            candidates = _sole_candidates(model)
            close = difflib.get_close_matches(str(f), candidates, n=5, cutoff=0.4)
            raise UnknownFrameError(
                f"robot {name!r} has no frame {f!r} for its {side} sole; close matches among the frames at the feet: "
                f"{close or candidates[:10]}")
    for f in (torso, left_hand, right_hand):
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
        check_group_state(srdf, srdf_tree, reference, model)
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
    check_posture_limits(robot, q)
    check_upright(robot, q)
    check_soles_distinct(robot)
    check_legs(robot, q)
    check_sole_heights(robot)
    if sole_length is None or sole_width is None:
        length, width = sole_rectangle_from_collision(robot)
        robot.sole_length = float(sole_length) if sole_length is not None else length
        robot.sole_width = float(sole_width) if sole_width is not None else width
    robot.q_ref = stand_on_ground(robot, q)
    check_loaded_robot(robot)
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


