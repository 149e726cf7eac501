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
import tomllib
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

__all__ = ["Robot", "load_robot", "catalog", "example_robot_data_dir"]

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


@dataclass
class Robot:
    """A humanoid model ready for whole-body control.

    Attributes:
        name: catalog name, or the URDF file stem.
        model: Pinocchio model with a free-flyer root joint (``nq = 7 + n``, ``nv = 6 + n`` for revolute joints).
            ``q[0:3]`` base position in world (m), ``q[3:7]`` base quaternion (x, y, z, w); ``v[0:6]`` base
            spatial velocity in the base frame (LOCAL).
        collision_model, visual_model: Pinocchio geometry models (meshes resolved).
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
    """

    name: str
    model: pin.Model
    collision_model: pin.GeometryModel
    visual_model: pin.GeometryModel
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
    sole_length: float = 0.2,
    sole_width: float = 0.1,
    package_dirs: list[str | Path] | None = None,
) -> Robot:
    """Load a catalog robot by name, or any humanoid URDF.

    Args:
        name_or_urdf: a catalog name (see :func:`catalog`: ``talos``, ``g1``, ``humanoid15``) or a path to a
            ``.urdf`` file. For a catalog name every other argument is ignored.
        srdf: SRDF path providing named reference configurations (``reference``).
        reference: name of the SRDF reference configuration to use as ``q_ref``.
        reference_joints: joint name -> angle (rad) for ``q_ref`` (joints not given are 0), used when no SRDF
            reference is given.
        left_sole, right_sole, torso: frame names (required for a URDF path).
        left_hand, right_hand: optional hand frame names.
        sole_length, sole_width: contact rectangle (m), centred on the sole frames.
        package_dirs: folders for ``package://`` URIs (example-robot-data's folder is always appended).

    Returns:
        A :class:`Robot` whose ``q_ref`` puts both soles on z = 0.

    Raises:
        UnknownRobotError: ``name_or_urdf`` is neither a catalog name nor a ``.urdf`` path (lists the catalog).
        RobotFileNotFoundError: the URDF or SRDF file does not exist.
        UnknownFrameError: a semantic frame is not in the model.
        UnknownJointError: a ``reference_joints`` key is not a joint.
        RobotDescriptionError: missing semantic frames, unknown SRDF reference, or a non-positive sole size.
    """
    spec = str(name_or_urdf)
    if not spec.lower().endswith(".urdf"):
        names = catalog()
        if spec not in names:
            raise UnknownRobotError(
                f"unknown robot {spec!r}: the catalog has {names}; or pass a path to a .urdf file"
            )
        return _load_catalog(spec)
    return _build(
        name=Path(spec).stem,
        urdf=Path(spec),
        srdf=Path(srdf) if srdf is not None else None,
        reference=reference,
        reference_joints=reference_joints or {},
        frames={},
        left_sole=left_sole,
        right_sole=right_sole,
        torso=torso,
        left_hand=left_hand,
        right_hand=right_hand,
        sole_length=sole_length,
        sole_width=sole_width,
        package_dirs=[str(p) for p in (package_dirs or [])],
    )


def _load_catalog(name: str) -> Robot:
    path = _robots_dir() / f"{name}.toml"
    with path.open("rb") as f:
        desc = tomllib.load(f)
    base = path.parent
    frames = {
        fr["name"]: (fr["parent"], _placement(fr.get("xyz", [0, 0, 0]), fr.get("rpy", [0, 0, 0])))
        for fr in desc.get("frames", [])
    }
    return _build(
        name=name,
        urdf=_resolve_path(desc["urdf"], base),
        srdf=_resolve_path(desc["srdf"], base) if "srdf" in desc else None,
        reference=desc.get("reference"),
        reference_joints=desc.get("reference_joints", {}),
        frames=frames,
        left_sole=desc["left_sole"],
        right_sole=desc["right_sole"],
        torso=desc["torso"],
        left_hand=desc.get("left_hand"),
        right_hand=desc.get("right_hand"),
        sole_length=desc["sole"]["length"],
        sole_width=desc["sole"]["width"],
        package_dirs=[str(base)],
        gait=desc.get("gait", {}),
    )


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
) -> Robot:
    if not urdf.is_file():
        raise RobotFileNotFoundError(f"URDF file not found: {urdf}")
    if srdf is not None and not srdf.is_file():
        raise RobotFileNotFoundError(f"SRDF file not found: {srdf}")
    if left_sole is None or right_sole is None or torso is None:
        raise RobotDescriptionError(
            "left_sole, right_sole and torso frame names are required to load a humanoid from a URDF path"
        )
    if not (sole_length > 0 and sole_width > 0):
        raise RobotDescriptionError(f"sole size must be positive, got {sole_length} x {sole_width} m")
    dirs = [*package_dirs, str(urdf.parent), str(example_robot_data_dir())]
    try:
        model, collision_model, visual_model = pin.buildModelsFromUrdf(
            str(urdf), dirs, pin.JointModelFreeFlyer()
        )
    except (ValueError, RuntimeError) as exc:  # urdfdom/Pinocchio parse errors carry the reason in the message
        raise RobotDescriptionError(f"cannot parse URDF {urdf}: {exc} (fix the URDF: it must be well-formed XML "
                                    f"with one root link and valid joints/links)") from exc
    model.name = name
    for fname, (parent, placement) in frames.items():
        if not model.existFrame(parent):
            raise UnknownFrameError(f"descriptor of {name!r}: parent frame {parent!r} of {fname!r} not in URDF")
        pid = model.getFrameId(parent)
        pframe = model.frames[pid]
        model.addFrame(
            pin.Frame(fname, pframe.parentJoint, pid, pframe.placement * placement, pin.FrameType.OP_FRAME)
        )
    robot = Robot(
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
        sole_length=float(sole_length),
        sole_width=float(sole_width),
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
        pin.loadReferenceConfigurations(model, str(srdf), False)
        names = [entry.key() for entry in model.referenceConfigurations]
        if reference not in names:
            raise RobotDescriptionError(f"SRDF {srdf} has no reference configuration {reference!r}; has {names}")
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
    robot.q_ref = _stand_on_ground(robot, q)
    return robot


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
