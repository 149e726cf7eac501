"""Robot files: the TOML description of a humanoid (``robots/*.toml``, ``--robot my_robot.toml``), read into a
typed :class:`RobotSpec`.

A robot file names the URDF (path relative to the file, absolute, or ``erd:<path>`` inside example-robot-data),
the optional SRDF and reference posture, the semantic frames (soles, torso, hands), frames to add, the sole
rectangle, gait defaults and MuJoCo options. Every key is documented in ``docs/pages/how-to/robot-file.md``. The loader
refuses unknown keys (naming the closest valid one), wrong types, NaN/inf and out-of-range values with a
:class:`~wbc.exceptions.RobotDescriptionError` that names the file, the key and what would be valid; it does not
load the URDF (that is :func:`wbc.robot.load_robot`, which resolves the paths and builds the Pinocchio model).

The module also checks that an URDF or SRDF is well-formed XML before Pinocchio parses it
(:func:`check_xml`), so that a malformed file is reported with the XML parser's line and column.
"""

from __future__ import annotations

import difflib
import math
import warnings
import tomllib
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field, replace
from pathlib import Path

from wbc.exceptions import RobotDescriptionError, RobotFileNotFoundError

__all__ = ["RobotSpec", "FrameSpec", "MujocoOptions", "load_robot_file", "spec_to_toml", "check_xml",
           "TOP_KEYS", "GAIT_KEYS", "STAIRS_KEYS", "TOUCHDOWN_RULES", "MUJOCO_MESHES", "MUJOCO_FEET", "physical_inertials", "package_roots", "lock_zero_range_joints", "LOCKED_RANGE", "MIN_LINK_MASS",
           "INERTIA_RADIUS", "MAX_ROBOT_FILE_BYTES", "MAX_URDF_BYTES", "MAX_URDF_LINKS",
           "MAX_URDF_MOVING_JOINTS", "check_urdf_values"]

#: Largest robot file (TOML) read, in bytes: a robot file is a page of keys (the catalog's are < 2 kB).
MAX_ROBOT_FILE_BYTES = 1_000_000
#: Largest URDF or SRDF read, in bytes (the largest of example-robot-data 6.0.0, tiago_dual.urdf, is 0.21 MB): a
#: larger file is refused before it is parsed.
MAX_URDF_BYTES = 20_000_000
#: Most ``<link>`` elements in a URDF (a humanoid has fewer than 200; example-robot-data's largest, tiago_dual, 130):
#: a URDF with more is refused before Pinocchio parses it.
MAX_URDF_LINKS = 500
#: Most moving (not ``fixed``) joints in a URDF (Talos has 32, G1 with its hands 43): a URDF with more is refused
#: before Pinocchio parses it. The memory of one ``pinocchio.Data`` grows as nv² × the joint count (measured with
#: pinocchio 3 on chains of revolute joints: 87 MB at 104 joints, 261 MB at 154, 587 MB at 204, 1.8 GB at 302).
MAX_URDF_MOVING_JOINTS = 150

#: Top-level keys of a robot file (tables: sole, frames, reference_joints, gait, stairs, mujoco).
TOP_KEYS = ("name", "urdf", "srdf", "reference", "left_sole", "right_sole", "torso", "left_hand", "right_hand",
            "package_dirs", "base_rpy", "sole", "frames", "reference_joints", "gait", "stairs", "touchdown",
            "mujoco")
#: ``touchdown``: what a physics walk (``wbc sim walk``, estimated state) does with a swing sole its state test
#: sets down at the planned landing time while the ankle F/T still reads no load (it hovers a millimetre or two up):
#: ``"state"`` ramps the sole's load in at once; ``"load"`` holds the load the controller may plan on it at 6 % of
#: the weight until the measured force reaches 3 %, then ramps it in
#: (:class:`wbc.dynamics.contact_switching.ContactSwitcher` ``await_load``).
TOUCHDOWN_RULES = ("state", "load")
#: Keys of the ``[gait]`` table (keyword arguments of :func:`wbc.gait.plan_walk`) and their valid ranges.
GAIT_KEYS = {"step_length": (0.0, 1.0), "step_height": (0.0, 0.5), "t_ss": (0.05, 5.0), "t_ds": (0.0, 5.0)}
#: Keys of the ``[stairs]`` table (the walk on a terrain of stairs, :func:`wbc.scenarios.terrain_walk.stair_defaults`)
#: and their valid ranges: ``step_width``, the lateral distance (m) between the feet; ``base_weight``, the weight
#: (≥ 0) of the physics walk's pelvis orientation task (:class:`wbc.sim.walk.WalkScenario` ``base_weight``).
STAIRS_KEYS = {"step_width": (0.02, 1.0), "base_weight": (0.0, 1000.0)}
#: ``[mujoco] meshes``: how meshes MuJoCo cannot read (Collada, ...) are handled.
MUJOCO_MESHES = ("convert", "collision")
#: ``[mujoco] foot``: the plant's foot contact geometry.
MUJOCO_FEET = ("urdf", "box")
_SOLE_KEYS = ("length", "width")
_FRAME_KEYS = ("name", "parent", "xyz", "rpy")
_MUJOCO_KEYS = ("meshes", "foot", "armature")


@dataclass(frozen=True)
class FrameSpec:
    """A frame added to the URDF's: ``name`` fixed to frame ``parent`` at translation ``xyz`` (m) and roll-pitch-yaw
    ``rpy`` (rad, fixed axes X then Y then Z) in the parent frame."""

    name: str
    parent: str
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class MujocoOptions:
    """Options of the MuJoCo plant built from the URDF (:func:`wbc.sim.mujoco_model.build_mujoco_model`).

    Attributes:
        meshes: ``"convert"``: meshes MuJoCo cannot read (``.dae``...) are converted to STL with trimesh into a
            cache folder; ``"collision"``: visual meshes are dropped and unreadable collision meshes are replaced by
            their bounding box (with a warning).
        foot: ``"urdf"``: the feet touch the ground through the robot's own foot collision geometry; ``"box"``: a
            thin box of the controller's sole rectangle.
        armature: rotor inertia (kg·m²) added to every actuated joint, in Pinocchio and MuJoCo alike (≥ 0).
    """

    meshes: str = "convert"
    foot: str = "box"
    armature: float = 0.0


@dataclass(frozen=True)
class RobotSpec:
    """The content of a robot file, typed and range-checked; paths are as written (``erd:`` / relative to
    ``base_dir``), resolved by :func:`wbc.robot.load_robot`.

    Attributes:
        name: robot name (default: the file stem).
        base_dir: folder of the robot file (relative paths and ``package://`` are resolved from it).
        urdf, srdf: file paths as written (``srdf`` may be None).
        reference: name of the SRDF ``group_state`` used as the reference posture (None: ``reference_joints``).
        reference_joints: joint name → angle (rad) set on top of the reference posture.
        left_sole, right_sole, torso: frame names (required); left_hand, right_hand: optional frame names.
        sole_length, sole_width: contact rectangle (m), None to derive it from the feet's collision geometry.
        frames: frames to add to the URDF's.
        package_dirs: extra folders for ``package://`` URIs (relative to ``base_dir``).
        base_rpy: orientation (rad, roll-pitch-yaw) of the floating base in the reference posture; a Y-up URDF
            stands with ``[1.5707963, 0, 0]``.
        gait: default walk parameters (subset of :data:`GAIT_KEYS`).
        stairs: walk parameters on stairs that replace the default ones there (subset of :data:`STAIRS_KEYS`).
        touchdown: the physics walk's rule for a sole set down without a measured load, one of
            :data:`TOUCHDOWN_RULES` (default ``"state"``).
        mujoco: plant options.
        source: the file read (None for a spec built in code).
    """

    name: str
    base_dir: Path
    urdf: str
    left_sole: str | None = None
    right_sole: str | None = None
    torso: str | None = None
    srdf: str | None = None
    reference: str | None = None
    reference_joints: dict[str, float] = field(default_factory=dict)
    left_hand: str | None = None
    right_hand: str | None = None
    sole_length: float | None = None
    sole_width: float | None = None
    frames: tuple[FrameSpec, ...] = ()
    package_dirs: tuple[str, ...] = ()
    base_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    gait: dict[str, float] = field(default_factory=dict)
    stairs: dict[str, float] = field(default_factory=dict)
    touchdown: str = "state"
    mujoco: MujocoOptions = field(default_factory=MujocoOptions)
    source: Path | None = None

    def with_overrides(self, **overrides) -> "RobotSpec":
        """A copy with the given fields replaced (None values are ignored); each value is checked as if read from
        the file.

        Raises:
            RobotDescriptionError: an unknown field or an invalid value.
        """
        where = "override"
        valid = {f for f in self.__dataclass_fields__ if f not in ("base_dir", "source", "frames", "mujoco")}
        clean = {}
        for key, value in overrides.items():
            if key not in valid:
                raise RobotDescriptionError(f"{where}: unknown robot field {key!r}; valid: {sorted(valid)}")
            if value is None or (key in ("package_dirs", "reference_joints") and not value):
                continue
            if key in ("sole_length", "sole_width"):
                value = _number(value, f"{where} {key}", lo=0.0, lo_open=True, hi=1.0)
            elif key == "reference_joints":
                value = _joint_table(value, where)
            elif key == "package_dirs":
                value = tuple(self.package_dirs) + tuple(str(p) for p in value)
            elif key == "base_rpy":
                value = _vector(value, f"{where} base_rpy")
            elif key == "gait":
                value = _gait(value, where)
            elif key == "stairs":
                value = _stairs(value, where)
            elif key == "touchdown":
                value = _string(value, f"{where} touchdown")
                if value not in TOUCHDOWN_RULES:
                    raise _fail(where, f"touchdown = {value!r}; valid: {list(TOUCHDOWN_RULES)}")
            else:
                value = _string(value, f"{where} {key}")
            clean[key] = value
        return replace(self, **clean)


def _fail(where: str, msg: str) -> RobotDescriptionError:
    return RobotDescriptionError(f"{where}: {msg}")


def _unknown(where: str, table: str, key: str, valid) -> RobotDescriptionError:
    close = difflib.get_close_matches(key, list(valid), n=1)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    return _fail(where, f"unknown key {key!r} in {table}{hint}; valid keys: {list(valid)}")


def _string(value, where: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise _fail(where, f"must be a non-empty string, got {value!r}")
    return value


def _number(value, where: str, *, lo: float | None = None, hi: float | None = None, lo_open: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(float(value)):
        raise _fail(where, f"must be a finite number, got {value!r}")
    v = float(value)
    if lo is not None and (v < lo or (lo_open and v <= lo)) or hi is not None and v > hi:
        lo_s = "" if lo is None else f"{lo} {'<' if lo_open else '<='} "
        hi_s = "" if hi is None else f" <= {hi}"
        raise _fail(where, f"{v} out of range (valid: {lo_s}value{hi_s})")
    return v


def _vector(value, where: str) -> tuple[float, float, float]:
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise _fail(where, f"must be a list of 3 numbers, got {value!r}")
    return tuple(_number(x, f"{where}[{i}]") for i, x in enumerate(value))  # type: ignore[return-value]


def _table(value, where: str) -> dict:
    if not isinstance(value, dict):
        raise _fail(where, f"must be a table, got {type(value).__name__} {value!r}")
    return value


def _joint_table(value, where: str) -> dict[str, float]:
    value = _table(value, f"{where} [reference_joints]")
    return {_string(k, f"{where} [reference_joints] key"): _number(v, f"{where} [reference_joints] {k}")
            for k, v in value.items()}


def _number_table(value, where: str, table: str, keys: dict[str, tuple[float, float]],
                  lo_open: tuple[str, ...] = ()) -> dict[str, float]:
    """A table of numbers, each key one of ``keys`` and within its range (open below for the keys in ``lo_open``)."""
    value = _table(value, f"{where} [{table}]")
    out = {}
    for k, v in value.items():
        if k not in keys:
            raise _unknown(where, f"[{table}]", k, keys)
        lo, hi = keys[k]
        out[k] = _number(v, f"{where} [{table}] {k}", lo=lo, hi=hi, lo_open=k in lo_open)
    return out


def _gait(value, where: str) -> dict[str, float]:
    return _number_table(value, where, "gait", GAIT_KEYS, lo_open=("t_ss",))


def _stairs(value, where: str) -> dict[str, float]:
    return _number_table(value, where, "stairs", STAIRS_KEYS, lo_open=("step_width",))


def parse_robot_spec(desc: dict, *, base_dir: Path, name: str, where: str, source: Path | None = None) -> RobotSpec:
    """Check a robot-file table (as parsed from TOML) and return its :class:`RobotSpec`.

    Raises:
        RobotDescriptionError: an unknown key, a missing required key, a wrong type, NaN/inf or an out-of-range
            value; the message starts with ``where`` and names the key and what is valid.
    """
    for k in desc:
        if k not in TOP_KEYS:
            raise _unknown(where, "the top level", k, TOP_KEYS)
    if "urdf" not in desc:
        raise _fail(where, "missing key 'urdf' (path of the URDF, relative to the robot file, or erd:<path> in "
                           "example-robot-data)")
    kw: dict = {}
    for k in ("name", "urdf", "srdf", "reference", "left_sole", "right_sole", "torso", "left_hand", "right_hand"):
        if k in desc:
            kw[k] = _string(desc[k], f"{where} {k}")
    for k in ("left_sole", "right_sole", "torso"):
        if k not in kw:
            raise _fail(where, f"missing key {k!r} (a frame name of the URDF, or one added under [[frames]]); "
                               f"`wbc robot init my.urdf` writes a starting file with the frames it finds")
    if "reference" in kw and "srdf" not in kw:
        raise _fail(where, f"reference = {kw['reference']!r} needs an srdf = \"...\" with that group_state")
    if "package_dirs" in desc:
        dirs = desc["package_dirs"]
        if not isinstance(dirs, list):
            raise _fail(where, f"package_dirs must be a list of folder paths, got {dirs!r}")
        kw["package_dirs"] = tuple(_string(d, f"{where} package_dirs[{i}]") for i, d in enumerate(dirs))
    if "base_rpy" in desc:
        kw["base_rpy"] = _vector(desc["base_rpy"], f"{where} base_rpy")
    if "sole" in desc:
        sole = _table(desc["sole"], f"{where} [sole]")
        for k, v in sole.items():
            if k not in _SOLE_KEYS:
                raise _unknown(where, "[sole]", k, _SOLE_KEYS)
            kw[f"sole_{k}"] = _number(v, f"{where} [sole] {k} (m)", lo=0.0, lo_open=True, hi=1.0)
    if "frames" in desc:
        frames = desc["frames"]
        if not isinstance(frames, list):
            raise _fail(where, "frames must be an array of tables ([[frames]] with name, parent, xyz, rpy)")
        out = []
        for i, fr in enumerate(frames):
            w = f"{where} [[frames]] #{i + 1}"
            fr = _table(fr, w)
            for k in fr:
                if k not in _FRAME_KEYS:
                    raise _unknown(where, f"[[frames]] #{i + 1}", k, _FRAME_KEYS)
            for k in ("name", "parent"):
                if k not in fr:
                    raise _fail(w, f"missing key {k!r}")
            out.append(FrameSpec(_string(fr["name"], f"{w} name"), _string(fr["parent"], f"{w} parent"),
                                 _vector(fr.get("xyz", [0, 0, 0]), f"{w} xyz"),
                                 _vector(fr.get("rpy", [0, 0, 0]), f"{w} rpy")))
        names = [f.name for f in out]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise _fail(where, f"[[frames]] names {dup} given more than once")
        kw["frames"] = tuple(out)
    if "reference_joints" in desc:
        kw["reference_joints"] = _joint_table(desc["reference_joints"], where)
    if "gait" in desc:
        kw["gait"] = _gait(desc["gait"], where)
    if "stairs" in desc:
        kw["stairs"] = _stairs(desc["stairs"], where)
    if "touchdown" in desc:
        kw["touchdown"] = _string(desc["touchdown"], f"{where} touchdown")
        if kw["touchdown"] not in TOUCHDOWN_RULES:
            raise _fail(where, f"touchdown = {kw['touchdown']!r}; valid: {list(TOUCHDOWN_RULES)}")
    if "mujoco" in desc:
        mj = _table(desc["mujoco"], f"{where} [mujoco]")
        for k in mj:
            if k not in _MUJOCO_KEYS:
                raise _unknown(where, "[mujoco]", k, _MUJOCO_KEYS)
        opts = {}
        for k, choices in (("meshes", MUJOCO_MESHES), ("foot", MUJOCO_FEET)):
            if k in mj:
                if mj[k] not in choices:
                    raise _fail(where, f"[mujoco] {k} = {mj[k]!r}; valid: {list(choices)}")
                opts[k] = mj[k]
        if "armature" in mj:
            opts["armature"] = _number(mj["armature"], f"{where} [mujoco] armature (kg·m²)", lo=0.0, hi=10.0)
        kw["mujoco"] = MujocoOptions(**opts)
    kw.setdefault("name", name)
    return RobotSpec(base_dir=base_dir, source=source, **kw)


def load_robot_file(path: str | Path) -> RobotSpec:
    """Read and check a robot file (TOML, format in ``docs/pages/how-to/robot-file.md``).

    Args:
        path: the ``.toml`` file.

    Returns:
        Its :class:`RobotSpec` (paths not yet resolved, the URDF not yet loaded).

    Raises:
        RobotFileNotFoundError: no such file.
        RobotDescriptionError: a folder or a file that is not regular (a FIFO, a device), malformed TOML (with the parser's line and column), or any key problem listed in
            :func:`parse_robot_spec`.
    """
    path = Path(path)
    if path.exists() and not path.is_file():
        kind = "a folder" if path.is_dir() else "not a regular file (a pipe, device or socket)"
        raise RobotDescriptionError(f"{path} is {kind}; a robot file is a .toml file (docs/pages/how-to/robot-file.md)")
    if not path.is_file():
        raise RobotFileNotFoundError(f"robot file not found: {path}")
    size = path.stat().st_size
    if size > MAX_ROBOT_FILE_BYTES:
        raise RobotDescriptionError(f"{path}: {size} bytes; a robot file is at most {MAX_ROBOT_FILE_BYTES} bytes "
                                    f"(a page of keys: docs/pages/how-to/robot-file.md)")
    data = path.read_bytes()
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        raise RobotDescriptionError(f"{path}:{line}: not UTF-8 text (byte 0x{data[exc.start]:02x} at offset "
                                    f"{exc.start}); save the robot file as UTF-8") from None
    try:
        desc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise RobotDescriptionError(f"{path}: malformed TOML: {exc}") from exc
    except RecursionError:
        raise RobotDescriptionError(f"{path}: arrays or tables nested too deeply for the TOML parser; a robot file "
                                    f"nests at most 2 levels (docs/pages/how-to/robot-file.md)") from None
    return parse_robot_spec(desc, base_dir=path.resolve().parent, name=path.stem, where=str(path), source=path)


def _toml_value(v) -> str:
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(round(v, 6))
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return str(v)


def spec_to_toml(spec: RobotSpec, comments: dict[str, str] | None = None) -> str:
    """The TOML text of ``spec`` (the inverse of :func:`load_robot_file`), with an optional ``# comment`` line
    above each key named in ``comments`` (key names as in the file: ``urdf``, ``sole``, ``frames``...)."""
    comments = comments or {}
    lines: list[str] = []

    def note(key):
        for c in comments.get(key, "").splitlines():
            lines.append(f"# {c}")

    note("header")
    for k in ("name", "urdf", "srdf", "reference", "left_sole", "right_sole", "torso", "left_hand", "right_hand"):
        v = getattr(spec, k)
        if v is not None:
            note(k)
            lines.append(f"{k} = {_toml_value(v)}")
    if spec.package_dirs:
        lines.append(f"package_dirs = {_toml_value(list(spec.package_dirs))}")
    if any(spec.base_rpy):
        note("base_rpy")
        lines.append(f"base_rpy = {_toml_value(list(spec.base_rpy))}")
    if spec.touchdown != "state":
        note("touchdown")
        lines.append(f"touchdown = {_toml_value(spec.touchdown)}")
    if spec.sole_length is not None or spec.sole_width is not None:
        lines.append("")
        note("sole")
        lines.append("[sole]")
        for k in ("length", "width"):
            v = getattr(spec, f"sole_{k}")
            if v is not None:
                lines.append(f"{k} = {_toml_value(v)}")
    for fr in spec.frames:
        lines.append("")
        note(f"frames.{fr.name}")
        lines += ["[[frames]]", f"name = {_toml_value(fr.name)}", f"parent = {_toml_value(fr.parent)}",
                  f"xyz = {_toml_value(list(fr.xyz))}", f"rpy = {_toml_value(list(fr.rpy))}"]
    if spec.reference_joints:
        lines += ["", "[reference_joints]"]
        lines += [f"{k} = {_toml_value(float(v))}" for k, v in spec.reference_joints.items()]
    if spec.gait:
        lines.append("")
        note("gait")
        lines.append("[gait]")
        lines += [f"{k} = {_toml_value(float(v))}" for k, v in spec.gait.items()]
    if spec.stairs:
        lines.append("")
        note("stairs")
        lines.append("[stairs]")
        lines += [f"{k} = {_toml_value(float(v))}" for k, v in spec.stairs.items()]
    lines.append("")
    note("mujoco")
    lines += ["[mujoco]", f"meshes = {_toml_value(spec.mujoco.meshes)}", f"foot = {_toml_value(spec.mujoco.foot)}",
              f"armature = {_toml_value(float(spec.mujoco.armature))}", ""]
    return "\n".join(lines)


def check_xml(path: Path, kind: str) -> ET.ElementTree:
    """Parse ``path`` as XML and return the tree.

    Args:
        path: an URDF or SRDF file.
        kind: ``"URDF"`` or ``"SRDF"`` (for the message), with the expected root element ``robot``.

    Raises:
        RobotDescriptionError: not well-formed XML (the message gives the parser's line and column), or a root
            element other than ``<robot>``.
    """
    size = path.stat().st_size
    if size > MAX_URDF_BYTES:
        raise RobotDescriptionError(f"{kind} {path}: {size / 1e6:.1f} MB; at most {MAX_URDF_BYTES / 1e6:g} MB is read "
                                    f"(a humanoid's {kind} is well under 1 MB)")
    try:
        tree = _parse_bounded(path, kind)
    except ET.ParseError as exc:
        line, col = exc.position
        raise RobotDescriptionError(
            f"{kind} {path}:{line}:{col + 1}: malformed XML ({exc.msg if hasattr(exc, 'msg') else exc}); fix the "
            f"file at that line") from exc
    root = tree.getroot()
    if root.tag != "robot":
        raise RobotDescriptionError(f"{kind} {path}: root element is <{root.tag}>, expected <robot>")
    for owner in list(root.iter("link")) + list(root.iter("joint")) + list(root.iter("group_state")):
        for el in owner.iter():
            for attr, text in el.attrib.items():
                if attr in _NUMERIC_ATTRIBUTES and not all(math.isfinite(x) for x in _numbers(text)):
                    raise RobotDescriptionError(
                        f"{kind} {path}: <{owner.tag} name={owner.get('name')!r}> has <{el.tag} {attr}="
                        f"{text!r}>: not finite; give finite numbers (|x| < 1.8e308)")
    return tree


def _parse_bounded(path: Path, kind: str) -> ET.ElementTree:
    """Parse ``path`` incrementally, stopping at the ``MAX_URDF_LINKS`` + 1-th ``<link>`` or the
    ``MAX_URDF_MOVING_JOINTS`` + 1-th moving ``<joint>`` (time and memory bounded by that many, not by the file).

    Raises:
        ET.ParseError: not well-formed XML.
        RobotDescriptionError: more than ``MAX_URDF_LINKS`` links or ``MAX_URDF_MOVING_JOINTS`` moving joints.
    """
    links = moving = 0
    events = ET.iterparse(path, events=("end",))
    for _, el in events:
        if el.tag == "link":
            links += 1
            if links > MAX_URDF_LINKS:
                raise RobotDescriptionError(f"{kind} {path}: more than {MAX_URDF_LINKS} <link> elements; at most "
                                            f"{MAX_URDF_LINKS} are loaded (a humanoid has fewer than 200)")
        elif el.tag == "joint" and el.get("type", "fixed") != "fixed" and el.find("child") is not None:
            moving += 1
            if moving > MAX_URDF_MOVING_JOINTS:
                raise RobotDescriptionError(f"{kind} {path}: more than {MAX_URDF_MOVING_JOINTS} moving joints; at "
                                            f"most {MAX_URDF_MOVING_JOINTS} are loaded (a humanoid has fewer than 80)")
    return ET.ElementTree(events.root)


def _numbers(text: str) -> list[float]:
    """The numbers of a space-separated attribute (tokens that are not numbers are left to urdfdom's parser)."""
    out = []
    for token in text.split():
        try:
            out.append(float(token))
        except ValueError:
            pass
    return out


#: Relative tolerance on a negative principal moment of inertia (round-off of a matrix written with few digits;
#: 1e-12 kg·m² is tolerated on top).
INERTIA_EIGEN_TOLERANCE = 1e-9


def check_urdf_values(path: Path, root: ET.Element) -> None:
    """Refuse the physical values of a URDF that no robot can have, before they are loaded: a negative mass, an
    inertia matrix with a negative principal moment (not positive semi-definite), a negative speed or effort limit,
    a revolute, continuous or prismatic joint with a zero axis. (Non-finite numbers: :func:`check_xml`; a zero mass
    or moment on a moving link is made physical by :func:`physical_inertials`.)

    Args:
        path: the URDF (for the message).
        root: its ``<robot>`` element.

    Raises:
        RobotDescriptionError: names the link or joint, the value and what is valid.
    """
    import numpy as np

    for link in root.iter("link"):
        inertial = link.find("inertial")
        if inertial is None:
            continue
        where = f"URDF {path}: link {link.get('name')!r}"
        mass_el = inertial.find("mass")
        mass = _numbers(mass_el.get("value", "")) if mass_el is not None else []
        if mass and mass[0] < 0:
            raise RobotDescriptionError(f"{where}: mass {mass[0]:g} kg is negative; valid: a mass >= 0 kg")
        el = inertial.find("inertia")
        if el is None:
            continue
        v = {k: (_numbers(el.get(k, "0")) or [0.0])[0] for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
        lam = np.linalg.eigvalsh(np.array([[v["ixx"], v["ixy"], v["ixz"]], [v["ixy"], v["iyy"], v["iyz"]],
                                           [v["ixz"], v["iyz"], v["izz"]]]))
        if lam[0] < -(INERTIA_EIGEN_TOLERANCE * float(np.abs(lam).max()) + 1e-12):
            raise RobotDescriptionError(
                f"{where}: inertia matrix {[v[k] for k in v]} (ixx ixy ixz iyy iyz izz) has a negative principal "
                f"moment {lam[0]:.6g} kg·m²; valid: a positive semi-definite matrix")
    for joint in root.iter("joint"):
        where = f"URDF {path}: joint {joint.get('name')!r}"
        limit = joint.find("limit")
        for attr, valid in (("velocity", "a speed limit >= 0 rad/s or m/s (0 locks the joint)"),
                            ("effort", "an effort limit >= 0 N·m or N")):
            value = _numbers(limit.get(attr, "")) if limit is not None else []
            if value and value[0] < 0:
                raise RobotDescriptionError(f"{where}: <limit {attr}=\"{limit.get(attr)}\"> is negative; valid: "
                                            f"{valid}")
        axis = joint.find("axis")
        if joint.get("type") in ("revolute", "continuous", "prismatic") and axis is not None:
            xyz = _numbers(axis.get("xyz", "1 0 0"))
            if len(xyz) == 3 and math.hypot(*xyz) < 1e-9:
                raise RobotDescriptionError(f"{where}: <axis xyz=\"{axis.get('xyz')}\"> has no direction (a joint "
                                            f"that moves nothing); valid: a non-zero vector")


_NUMERIC_ATTRIBUTES = {"xyz", "rpy", "value", "lower", "upper", "effort", "velocity", "ixx", "ixy", "ixz", "iyy",
                       "iyz", "izz", "radius", "length", "size", "scale", "damping", "friction"}


#: Mass (kg) given to a URDF link moved by a joint that has no mass (MuJoCo refuses massless moving bodies).
MIN_LINK_MASS = 1e-3
#: Radius (m) of the solid sphere whose inertia 2/5 m r² is the floor of a link's principal moments.
INERTIA_RADIUS = 0.01


def physical_inertials(root: ET.Element) -> list[str]:
    """Make every link's ``<inertial>`` physical, in place, so that Pinocchio and MuJoCo (which refuses the
    others) load the same masses:

    * a link moved by a non-fixed joint with no ``<inertial>`` or a mass ≤ 0 gets ``MIN_LINK_MASS`` kg at its
      origin;
    * for a link moved by a joint, a principal moment below 2/5 · m · ``INERTIA_RADIUS``² (a point mass, a zero matrix; a negative moment is
      refused before, by :func:`check_urdf_values`) is raised to it, and a moment larger than the sum of the other two (triangle inequality) is lowered
      to that sum; the principal axes are kept.

    Args:
        root: the ``<robot>`` element of a URDF.

    Returns:
        one sentence per link changed (empty: the URDF was already physical).
    """
    import numpy as np

    moving = {j.find("child").get("link") for j in root.iter("joint")
              if j.get("type") not in ("fixed", None) and j.find("child") is not None}
    notes = []
    for link in root.iter("link"):
        name = link.get("name")
        inertial = link.find("inertial")
        mass_el = inertial.find("mass") if inertial is not None else None
        try:
            mass = float(mass_el.get("value")) if mass_el is not None else 0.0
        except (TypeError, ValueError):
            raise RobotDescriptionError(f"URDF link {name!r}: <mass value={mass_el.get('value')!r}> is not a "
                                        f"number") from None
        if not math.isfinite(mass):
            raise RobotDescriptionError(f"URDF link {name!r}: mass {mass} is not finite")
        if mass <= 0.0:
            if name not in moving:
                continue
            if inertial is None:
                inertial = ET.SubElement(link, "inertial")
            for child in list(inertial):
                inertial.remove(child)
            ET.SubElement(inertial, "origin", xyz="0 0 0", rpy="0 0 0")
            ET.SubElement(inertial, "mass", value=repr(MIN_LINK_MASS))
            i0 = 0.4 * MIN_LINK_MASS * INERTIA_RADIUS**2
            ET.SubElement(inertial, "inertia", ixx=repr(i0), iyy=repr(i0), izz=repr(i0), ixy="0", ixz="0", iyz="0")
            notes.append(f"link {name!r} (moved by a joint) has no mass: given {MIN_LINK_MASS} kg, a sphere of "
                         f"radius {INERTIA_RADIUS} m at its origin")
            continue
        if name not in moving:
            continue  # a fixed link's inertia is merged into its moving parent's, by Pinocchio and MuJoCo alike
        el = inertial.find("inertia")
        keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
        try:
            v = {k: float(el.get(k, 0.0)) if el is not None else 0.0 for k in keys}
        except (TypeError, ValueError):
            raise RobotDescriptionError(f"URDF link {name!r}: an <inertia> value is not a number") from None
        if not all(math.isfinite(x) for x in v.values()):
            raise RobotDescriptionError(f"URDF link {name!r}: <inertia> {v} is not finite")
        mat = np.array([[v["ixx"], v["ixy"], v["ixz"]], [v["ixy"], v["iyy"], v["iyz"]],
                        [v["ixz"], v["iyz"], v["izz"]]])
        lam, vec = np.linalg.eigh(mat)
        floor = 0.4 * mass * INERTIA_RADIUS**2
        fixed = np.maximum(lam, floor)
        for _ in range(3):
            for i in range(3):
                others = fixed.sum() - fixed[i]
                if fixed[i] > others:
                    fixed[i] = others
        if np.allclose(fixed, lam, rtol=1e-9, atol=1e-12 * max(1.0, float(np.abs(lam).max()))):
            continue
        new = vec @ np.diag(fixed) @ vec.T
        if el is None:
            el = ET.SubElement(inertial, "inertia")
        for k, (a, b) in zip(keys, ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))):
            el.set(k, repr(float(new[a, b])))
        notes.append(f"link {name!r}: principal moments {np.round(lam, 9).tolist()} kg·m² are not physical "
                     f"(each > 0, each ≤ the sum of the other two); raised/lowered to "
                     f"{np.round(fixed, 9).tolist()}")
    return notes


def package_roots(urdf: Path, root: ET.Element) -> list[str]:
    """Folders that resolve the URDF's ``package://NAME/...`` URIs found by walking up from the URDF: an ancestor
    folder called NAME (a package installed as ``share/NAME/...``, e.g. ``icub-models``' ``share/iCub``) gives its
    parent. Packages not found this way must be given in ``package_dirs``."""
    names = set()
    for mesh in root.iter("mesh"):
        ref = mesh.get("filename", "")
        if ref.startswith("package://"):
            names.add(ref[len("package://"):].lstrip("/").split("/", 1)[0])
    out = []
    for parent in Path(urdf).resolve().parents:
        if parent.name in names and str(parent.parent) not in out:
            out.append(str(parent.parent))
    return out


#: A revolute or prismatic joint whose range (upper − lower, rad or m) is at most this is locked.
LOCKED_RANGE = 1e-9


#: rad or m: limits inverted by at most this much are round-off (the joint is locked at their middle); by more, the
#: URDF is refused (``wbc.robot``'s limit check)
LIMIT_INVERSION_TOLERANCE = 1e-6


def lock_zero_range_joints(root: ET.Element) -> list[str]:
    """Turn every revolute or prismatic joint whose ``<limit>`` range is empty (upper − lower ≤ ``LOCKED_RANGE``:
    locked at that value) or whose speed limit is 0 (``velocity="0"``: locked at 0, or at the limit nearest to 0)
    into a fixed joint, in place, so that it is not a variable of Pinocchio's model (nor of any
    QP) and MuJoCo's plant has the same joints: the joint origin becomes ``origin · motion(axis, lower)``
    (a rotation about, or a translation along, the joint axis).

    Args:
        root: the ``<robot>`` element of a URDF.

    Returns:
        the names of the joints locked.
    """
    import numpy as np
    import pinocchio as pin

    locked = []
    for joint in root.iter("joint"):
        kind = joint.get("type")
        limit = joint.find("limit")
        if kind not in ("revolute", "prismatic") or limit is None:
            continue
        try:
            lo, hi = float(limit.get("lower", "0")), float(limit.get("upper", "0"))
            speed = float(limit.get("velocity", "inf"))
        except ValueError:
            continue
        if not (math.isfinite(lo) and math.isfinite(hi)):
            continue
        if hi < lo - LIMIT_INVERSION_TOLERANCE:
            continue  # inverted limits: a typed error when the model is built (wbc.robot), not a lock
        if hi - lo <= LOCKED_RANGE:
            if hi < lo:  # inverted by round-off: locked at the middle
                warnings.warn(f"joint {joint.get('name')!r}: limits inverted by {lo - hi:.3g} ≤ "
                              f"{LIMIT_INVERSION_TOLERANCE:g} rad (round-off): locked at the middle", stacklevel=2)
                lo = 0.5 * (lo + hi)
        elif speed == 0.0:  # a zero speed limit: the joint cannot move; locked at 0 (or the nearest limit)
            lo = min(max(0.0, lo), hi)
        else:
            continue
        origin = joint.find("origin")
        xyz = [float(x) for x in (origin.get("xyz", "0 0 0") if origin is not None else "0 0 0").split()]
        rpy = [float(x) for x in (origin.get("rpy", "0 0 0") if origin is not None else "0 0 0").split()]
        axis_el = joint.find("axis")
        axis = np.array([float(x) for x in (axis_el.get("xyz", "1 0 0") if axis_el is not None else "1 0 0")
                         .split()])
        axis = axis / np.linalg.norm(axis)
        placement = pin.SE3(pin.rpy.rpyToMatrix(*rpy), np.array(xyz))
        if kind == "revolute":
            motion = pin.SE3(pin.AngleAxis(lo, axis).matrix(), np.zeros(3))
        else:
            motion = pin.SE3(np.eye(3), lo * axis)
        new = placement * motion
        if origin is None:
            origin = ET.SubElement(joint, "origin")
        origin.set("xyz", " ".join(repr(float(x)) for x in new.translation))
        origin.set("rpy", " ".join(repr(float(x)) for x in pin.rpy.matrixToRpy(new.rotation)))
        joint.set("type", "fixed")
        locked.append(joint.get("name"))
    return locked
