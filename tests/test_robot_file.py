"""Robot files (wbc.robot_file, wbc.robot_inspect, `wbc robot init|check`) and the typed errors of every robot
problem: each bad input is one line on stderr and exit 2 from the command line, a typed error from the API."""

from __future__ import annotations

import math
import re
import shutil
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from wbc.cli import main
from wbc.exceptions import RobotDescriptionError, RobotFileNotFoundError, UnknownFrameError, WbcError
from wbc.robot import catalog, example_robot_data_dir, load_robot
from wbc.robot_file import load_robot_file

ROBOTS = Path(__file__).resolve().parent.parent / "robots"
ERD = example_robot_data_dir() / "example-robot-data" / "robots"


def _cli_error(argv, capsys) -> str:
    code = main(argv)
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    assert len(err.splitlines()) == 1, err
    return err


def _h15_file(tmp_path: Path, extra: str = "", drop: str | None = None) -> Path:
    """humanoid15's robot file copied next to its URDF/SRDF (so relative paths resolve), with edits."""
    for f in ("humanoid15.urdf", "humanoid15.srdf"):
        shutil.copy(ROBOTS / f, tmp_path / f)
    text = (ROBOTS / "humanoid15.toml").read_text()
    if drop is not None:
        text = "\n".join(line for line in text.splitlines() if not line.startswith(drop))
    path = tmp_path / "h15.toml"
    path.write_text(text.replace('urdf = "humanoid15.urdf"', 'urdf = "humanoid15.urdf"\n' + extra, 1))
    return path


def test_catalog_files_load_as_robot_files():
    for name in catalog():
        spec = load_robot_file(ROBOTS / f"{name}.toml")
        assert spec.left_sole and spec.right_sole and spec.torso
    a, b = load_robot("humanoid15"), load_robot(str(ROBOTS / "humanoid15.toml"))
    np.testing.assert_array_equal(a.q_ref, b.q_ref)
    assert (a.sole_length, a.sole_width, a.gait) == (b.sole_length, b.sole_width, b.gait)


EXAMPLES = Path(__file__).resolve().parent.parent / "examples" / "robots"


@pytest.mark.parametrize("name", ["romeo", "human", "alexander"])
def test_example_robot_files_load_and_stand_on_their_soles(name):
    """The robot files of examples/robots (example-robot-data humanoids, written by `wbc robot init`): each loads,
    and in its reference posture both sole frames are level (z up, within 1°) and 0.2–2 m below the CoM (Pinocchio's
    forward kinematics, independent of the file's own checks)."""
    robot = load_robot(str(EXAMPLES / f"{name}.toml"))
    data = robot.model.createData()
    pin.centerOfMass(robot.model, data, robot.q_ref)
    pin.framesForwardKinematics(robot.model, data, robot.q_ref)
    for frame in (robot.left_sole, robot.right_sole):
        oMf = data.oMf[robot.model.getFrameId(frame)]
        assert math.degrees(math.acos(min(1.0, oMf.rotation[2, 2]))) < 1.0, frame
        assert 0.2 < data.com[0][2] - oMf.translation[2] < 2.0, frame


@pytest.mark.parametrize("extra, words", [
    ("torsoo = \"torso\"", ["unknown key 'torsoo'", "did you mean 'torso'"]),
    ("base_rpy = [0, nan, 0]", ["base_rpy[1]", "finite"]),
    ("[mujoco]\nmeshes = \"magic\"", ["[mujoco] meshes", "convert"]),
    ("[mujoco]\narmature = -1.0", ["armature", "out of range"]),
    ("[gait]\nt_ss = inf", ["t_ss", "finite"]),
    ("[sole]\nlength = -0.1", ["[sole] length", "out of range"]),
    ("touchdown = \"soon\"", ["touchdown = 'soon'", "'state', 'load'"]),
    ("[stairs]\nstep_width = 0.0", ["[stairs] step_width", "out of range"]),
    ("[stairs]\nstep_wdth = 0.1", ["unknown key 'step_wdth'", "did you mean 'step_width'"]),
    ("[stairs]\nbase_weight = -1.0", ["[stairs] base_weight", "out of range"]),
])
def test_robot_file_key_errors_name_the_key(tmp_path, extra, words):
    path = _h15_file(tmp_path)
    text = path.read_text()
    if extra.startswith("["):
        section = extra.splitlines()[0]
        if section in text:  # replace the existing table's content
            head, _, _ = text.partition(section)
            text = head
        text += "\n" + extra + "\n"
    else:
        text = extra + "\n" + text
    path.write_text(text)
    with pytest.raises(RobotDescriptionError) as exc:
        load_robot(str(path))
    for w in words:
        assert w in str(exc.value), str(exc.value)


def test_missing_required_key_and_malformed_toml(tmp_path):
    path = _h15_file(tmp_path, drop="torso")
    with pytest.raises(RobotDescriptionError, match="missing key 'torso'"):
        load_robot_file(path)
    path.write_text("urdf = \"humanoid15.urdf\"\nleft_sole = = 3\ntorso = 1\n")
    with pytest.raises(RobotDescriptionError, match="malformed TOML.*line"):
        load_robot_file(path)
    with pytest.raises(RobotFileNotFoundError):
        load_robot_file(tmp_path / "nope.toml")


def test_malformed_urdf_and_srdf_give_the_line(tmp_path):
    path = _h15_file(tmp_path)
    text = (tmp_path / "humanoid15.urdf").read_text()
    i = text.index("</link>")
    line = text[:i].count("\n") + 1
    (tmp_path / "humanoid15.urdf").write_text(text[:i] + "</lnk>" + text[i + 7:])  # mismatched tag
    with pytest.raises(RobotDescriptionError, match=rf"humanoid15.urdf:{line}:\d+: malformed XML"):
        load_robot(str(path))
    shutil.copy(ROBOTS / "humanoid15.urdf", tmp_path / "humanoid15.urdf")
    (tmp_path / "humanoid15.srdf").write_text("<robot name='x'>\n<group_state name='standing'>\n</robot>\n")
    with pytest.raises(RobotDescriptionError, match=r"humanoid15.srdf:3:\d+: malformed XML"):
        load_robot(str(path))


def test_srdf_with_unknown_joint_is_a_typed_error(tmp_path):
    path = _h15_file(tmp_path)
    srdf = (tmp_path / "humanoid15.srdf").read_text()
    i = srdf.index("<group_state")
    (tmp_path / "humanoid15.srdf").write_text(srdf[:i] + srdf[i:].replace('<joint name="', '<joint name="zz'))
    with pytest.raises(RobotDescriptionError, match="group_state 'standing' sets no joint of the URDF.*'zz"):
        load_robot(str(path))
    (tmp_path / "humanoid15.srdf").write_text(srdf[:i] + srdf[i:].replace('value="', 'valu="', 1))
    with pytest.raises(RobotDescriptionError, match="SRDF"):  # Pinocchio's RuntimeError "No such node", wrapped
        load_robot(str(path))


def test_missing_mesh_and_unknown_frame_parent(tmp_path):
    path = _h15_file(tmp_path, extra='\n[[frames]]\nname = "extra"\nparent = "no_such_link"\n')
    text = path.read_text()
    # TOML: a table header after top-level keys would swallow them; move the [[frames]] to the end
    body = text.replace('\n[[frames]]\nname = "extra"\nparent = "no_such_link"\n', "\n")
    path.write_text(body + '\n[[frames]]\nname = "extra"\nparent = "no_such_link"\n')
    with pytest.raises(UnknownFrameError, match="no_such_link"):
        load_robot(str(path))
    path.write_text(body)
    # a missing collision mesh: at load; a missing visual mesh: when the visual model is first read (built then)
    (tmp_path / "humanoid15.urdf").write_text(_with_missing_mesh((ROBOTS / "humanoid15.urdf").read_text(),
                                                                 "collision"))
    with pytest.raises(RobotFileNotFoundError, match="foot_missing.stl"):
        load_robot(str(path))
    (tmp_path / "humanoid15.urdf").write_text(_with_missing_mesh((ROBOTS / "humanoid15.urdf").read_text()))
    robot = load_robot(str(path))
    with pytest.raises(RobotFileNotFoundError, match="foot_missing.stl"):
        robot.visual_model


def _with_missing_mesh(urdf: str, kind: str = "visual") -> str:
    i = urdf.index(f"<{kind}>")
    j = urdf.index(f"</{kind}>", i)
    return urdf[:i] + (f'<{kind}><geometry><mesh filename="package://nowhere/foot_missing.stl"/></geometry>'
                       f'</{kind}>') + urdf[j + len(f"</{kind}>"):]


def test_y_up_model_is_diagnosed_with_the_fix(tmp_path):
    path = tmp_path / "human.toml"
    path.write_text(f'urdf = "erd:human_description/robots/human.urdf"\nleft_sole = "left_foot"\n'
                    f'right_sole = "right_foot"\ntorso = "middle_pelvis"\n[sole]\nlength = 0.2\nwidth = 0.1\n')
    with pytest.raises(RobotDescriptionError) as exc:
        load_robot(str(path))
    msg = str(exc.value)
    assert "Y-up" in msg and "base_rpy" in msg, msg


# -- every bad input listed in the issue: one line, exit 2, before any run ---------------------------------------

@pytest.mark.parametrize("argv, words", [
    (["balance", "shift", "--robot", "humanoid15", "--srdf", "missing.srdf"], ["missing.srdf", "not found"]),
    (["balance", "shift", "--robot", "humanoid15", "--reference", "nosuchpose"], ["nosuchpose"]),
    (["walk", "--robot", "humanoid15", "--left-sole", "nosuchframe"], ["nosuchframe"]),
    (["walk", "--robot", "humanoid15", "--sole-length", "nan"], ["sole_length", "finite"]),
    (["sim", "stand", "--robot", "humanoid15", "--torso", "nosuchframe"], ["nosuchframe"]),
    (["sim", "walk", "--robot", "nosuchrobot"], ["nosuchrobot", "catalog"]),
    (["walk", "--robot", "missing_robot.toml"], ["robot file not found"]),
    (["robot", "check", "missing_robot.toml"], ["robot file not found"]),
])
def test_cli_refuses_options_that_do_not_apply(argv, words, capsys):
    err = _cli_error(argv, capsys)
    for w in words:
        assert w in err, err


def test_reference_joints_nan_on_a_robot_with_srdf():
    with pytest.raises(RobotDescriptionError, match="finite"):
        load_robot("talos", reference_joints={"arm_left_1_joint": math.nan})


def test_overrides_apply_to_a_catalog_robot():
    base = load_robot("humanoid15")
    r = load_robot("humanoid15", sole_length=0.15)
    assert r.sole_length == 0.15 and base.sole_length == pytest.approx(0.19)


def _lock(text: str, joint: str, value: float) -> str:
    i = text.index(f'<joint name="{joint}"')
    j = text.index("</joint>", i)
    block = re.sub(r'lower="[^"]*"', f'lower="{value}"', text[i:j])
    block = re.sub(r'upper="[^"]*"', f'upper="{value}"', block)
    return text[:i] + block + text[j:]


def test_locked_joints_are_not_variables_and_keep_their_value(tmp_path):
    path = _h15_file(tmp_path)
    urdf = (ROBOTS / "humanoid15.urdf").read_text()
    (tmp_path / "humanoid15.urdf").write_text(_lock(_lock(urdf, "neck", 0.3), "torso_yaw", 0.0))
    locked, free = load_robot(str(path)), load_robot("humanoid15")
    assert sorted(locked.locked_joints) == ["neck", "torso_yaw"]
    assert locked.nv == free.nv - 2 and not locked.model.existJointName("neck")
    # independent reference: the unlocked model with neck = 0.3 rad, torso_yaw = 0 (same reference otherwise)
    q = free.q_ref.copy()
    q[free.model.joints[free.joint_id("neck")].idx_q] = 0.3
    q[free.model.joints[free.joint_id("torso_yaw")].idx_q] = 0.0
    d_free, d_locked = free.model.createData(), locked.model.createData()
    pin.framesForwardKinematics(free.model, d_free, q)
    pin.framesForwardKinematics(locked.model, d_locked, locked.q_ref)
    base_free = d_free.oMf[free.model.getFrameId("pelvis")]
    base_locked = d_locked.oMf[locked.model.getFrameId("pelvis")]
    for frame in ("head", "left_sole", "right_hand"):
        a = base_free.actInv(d_free.oMf[free.model.getFrameId(frame)])
        b = base_locked.actInv(d_locked.oMf[locked.model.getFrameId(frame)])
        np.testing.assert_allclose(a.homogeneous, b.homogeneous, atol=1e-12)
    from wbc.sim.mujoco_model import build_mujoco_model

    sim = build_mujoco_model(locked)  # MuJoCo loads the same joints (the locked ones fixed)
    assert sim.model.njnt == 1 + locked.nv - 6


def test_init_stands_a_y_up_model_and_check_refuses_a_turned_foot(tmp_path, capsys):
    out = tmp_path / "human.toml"
    assert main(["robot", "init", str(ERD / "human_description" / "robots" / "human.urdf"), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "up axis: the model's +y" in text
    robot = load_robot(str(out))
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, robot.q_ref)
    left = data.oMf[robot.model.getFrameId(robot.left_sole)]
    assert left.rotation[2, 2] > np.cos(np.radians(5)) and left.translation[1] > 0.05  # flat, left is +y
    assert robot.q_ref[2] > 0.8  # the pelvis of a standing adult
    # iCub of example-robot-data: its foot collision meshes lie across the leg's forward direction
    out = tmp_path / "icub.toml"
    assert main(["robot", "init", str(ERD / "icub_description" / "robots" / "icub.urdf"), "-o", str(out)]) == 0
    capsys.readouterr()
    err = _cli_error(["robot", "check", str(out)], capsys)
    assert "turned across the walking direction" in err and "Fix the foot's <collision> origin rpy" in err


def test_nan_in_urdf_is_named(tmp_path):
    path = _h15_file(tmp_path)
    urdf = (ROBOTS / "humanoid15.urdf").read_text()
    (tmp_path / "humanoid15.urdf").write_text(urdf.replace('<origin xyz="0 0 0.3" rpy="0 0 0"/>',
                                                           '<origin xyz="0 nan 0.3" rpy="0 0 0"/>', 1))
    with pytest.raises(RobotDescriptionError, match="<joint name='neck'> has <origin xyz='0 nan 0.3'>: not finite"):
        load_robot(str(path))


def test_touchdown_rule_is_read_and_written(tmp_path):
    """``touchdown = "load"`` is read, written back by ``spec_to_toml`` and read again (default ``"state"``, not
    written)."""
    from wbc.robot_file import load_robot_file, spec_to_toml

    path = _h15_file(tmp_path, extra='touchdown = "load"')
    spec = load_robot_file(path)
    assert spec.touchdown == "load"
    again = tmp_path / "again.toml"
    again.write_text(spec_to_toml(spec))
    assert load_robot_file(again).touchdown == "load"
    assert load_robot_file(_h15_file(tmp_path)).touchdown == "state"
    assert "touchdown" not in spec_to_toml(load_robot_file(_h15_file(tmp_path)))


def test_stairs_table_sets_the_step_width_on_stairs_only(tmp_path):
    """``[stairs] step_width`` and ``base_weight`` are read, written back by ``spec_to_toml`` and read again; a walk
    planned on stairs (``plan_default_terrain_walk``) sets its feet that far apart, one on flat ground keeps the
    stance's width, and an explicit ``step_width`` wins; the pelvis task's weight is a stair default of the physics
    walk's controller, not of the plan. Oracle: the lateral distance of consecutive footholds in the plan, against
    the soles' distance at the reference posture by Pinocchio's forward kinematics."""
    from wbc.robot_file import load_robot_file, spec_to_toml
    from wbc.scenarios.terrain_walk import STAIR_CONTROLLER_KEYS, plan_default_terrain_walk, stair_defaults
    from wbc.terrain import parse_terrain

    path = _h15_file(tmp_path)
    path.write_text(path.read_text() + "\n[stairs]\nstep_width = 0.15\nbase_weight = 12.5\n")
    spec = load_robot_file(path)
    assert spec.stairs == {"step_width": 0.15, "base_weight": 12.5}
    again = tmp_path / "again.toml"
    again.write_text(spec_to_toml(spec))
    assert load_robot_file(again).stairs == {"step_width": 0.15, "base_weight": 12.5}
    assert STAIR_CONTROLLER_KEYS == ("base_weight",)
    assert stair_defaults(load_robot(str(path)), parse_terrain("stairs:0.05:0.3:4:up")) == {
        "step_length": pytest.approx(0.3), "step_width": 0.15, "base_weight": 12.5}
    assert stair_defaults(load_robot(str(path)), parse_terrain("slope:10")) == {}
    robot = load_robot(str(path))
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, robot.q_ref)
    stance = abs(data.oMf[robot.model.getFrameId(robot.left_sole)].translation[1]
                 - data.oMf[robot.model.getFrameId(robot.right_sole)].translation[1])
    assert abs(stance - 0.15) > 0.02  # the table changes something

    def widths(terrain, **kw):
        walk = plan_default_terrain_walk(robot, terrain, n_steps=4, **kw)
        y = [float(f[1, 3]) for f in walk.footholds]
        return [abs(a - b) for a, b in zip(y, y[1:])]

    assert np.allclose(widths("stairs:0.05:0.3:4:up"), 0.15, atol=1e-9)
    assert np.allclose(widths("flat", step_length=0.1), stance, atol=1e-6)
    assert np.allclose(widths("stairs:0.05:0.3:4:up", step_width=0.2), 0.2, atol=1e-9)
    assert load_robot("humanoid15").stairs == {}


def test_visual_model_is_built_on_first_read(monkeypatch):
    """load_robot leaves the visual meshes unread (a controller run never draws the robot); the first read of
    ``visual_model`` builds the same model as Pinocchio's buildModelsFromUrdf, once."""
    built = []
    build = pin.buildGeomFromUrdf

    def counting(model, urdf, kind, *args):
        built.append(kind)
        return build(model, urdf, kind, *args)

    monkeypatch.setattr(pin, "buildGeomFromUrdf", counting)
    robot = load_robot("talos")
    assert pin.GeometryType.VISUAL not in built and built.count(pin.GeometryType.COLLISION) == 1
    visual = robot.visual_model
    assert robot.visual_model is visual and built.count(pin.GeometryType.VISUAL) == 1
    _, _, ref = pin.buildModelsFromUrdf(str(robot.urdf_path), robot.package_dirs, pin.JointModelFreeFlyer())
    assert visual.ngeoms == ref.ngeoms > 0
    for a, b in zip(visual.geometryObjects, ref.geometryObjects):
        assert (a.name, a.parentJoint, a.parentFrame, a.meshPath) == (b.name, b.parentJoint, b.parentFrame, b.meshPath)
        assert np.array_equal(a.placement.homogeneous, b.placement.homogeneous)
        assert np.array_equal(a.meshScale, b.meshScale)
