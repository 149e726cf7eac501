"""Robot files from the wild: every hostile file (written here into tmp_path, small) is refused by `wbc robot check`
with one line on stderr naming the problem, exit code 2 — never a traceback, a silent fix or an endless load. Each
file is humanoid15's robot file with one edit (its own URDF, the catalog's, copied next to it)."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from wbc.cli import main

ROBOTS = Path(__file__).resolve().parent.parent / "robots"
URDF = (ROBOTS / "humanoid15.urdf").read_text()


def _check(path: Path, capsys) -> str:
    """`wbc robot check path`: exit code 2 and one line on stderr; returns the line."""
    code = main(["robot", "check", str(path)])
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert code == 2, (code, captured.out[-500:], err[-2000:])
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    return err


def _robot(tmp_path: Path, *, urdf: str = URDF, toml: tuple[str, str] | None = None, extra: str = "") -> Path:
    """humanoid15 with its URDF text ``urdf``, one replacement ``toml`` in its robot file and ``extra`` appended."""
    shutil.copy(ROBOTS / "humanoid15.srdf", tmp_path / "humanoid15.srdf")
    (tmp_path / "humanoid15.urdf").write_text(urdf)
    text = (ROBOTS / "humanoid15.toml").read_text()
    if toml is not None:
        assert toml[0] in text
        text = text.replace(*toml)
    path = tmp_path / "robot.toml"
    path.write_text(text + extra)
    return path


def _urdf(old: str, new: str) -> str:
    assert old in URDF
    return URDF.replace(old, new, 1)


def test_the_unedited_file_passes(tmp_path, capsys):
    assert main(["robot", "check", str(_robot(tmp_path))]) == 0
    assert "ok" in capsys.readouterr().out


def test_non_utf8_bytes(tmp_path, capsys):
    path = tmp_path / "robot.toml"
    data = b'urdf = "x.urdf"\nname = "caf\xe9"\n'
    path.write_bytes(data)
    err = _check(path, capsys)
    assert f"{path}:2: not UTF-8 text (byte 0xe9 at offset {data.index(0xe9)}); save the robot file as UTF-8" in err


def test_deeply_nested_array(tmp_path, capsys):
    path = tmp_path / "robot.toml"
    path.write_text("urdf = " + "[" * 100_000 + "]" * 100_000 + "\n")
    assert "nested too deeply" in _check(path, capsys)


def test_a_robot_file_of_megabytes(tmp_path, capsys):
    path = tmp_path / "robot.toml"
    path.write_text('urdf = "x.urdf"\n' + "# padding\n" * 200_000)  # 2 MB of comments
    assert "a robot file is at most 1000000 bytes" in _check(path, capsys)


def test_added_frame_reusing_a_urdf_frame_name(tmp_path, capsys):
    err = _check(_robot(tmp_path, extra='\n[[frames]]\nname = "torso"\nparent = "pelvis"\n'), capsys)
    assert "[[frames]] name 'torso' is already a frame of the URDF" in err, err


@pytest.mark.parametrize("xyz, distance, outside", [((0.15, 0.0), "0.150", "0.050"), ((0.0, 0.3), "0.300", "0.250")])
def test_sole_frame_beside_its_foot_is_refused_although_sole_gives_the_size(tmp_path, capsys, xyz, distance,
                                                                             outside):
    """The left foot is a 0.20 x 0.10 m box whose underside is centred on frame left_sole (URDF comment): a sole
    frame 0.15 m ahead is 0.05 m beyond the toe, one 0.3 m to the side 0.25 m beyond the foot's edge."""
    extra = f'\n[[frames]]\nname = "moved"\nparent = "left_sole"\nxyz = [{xyz[0]}, {xyz[1]}, 0.0]\n'
    path = _robot(tmp_path, toml=('left_sole = "left_sole"', 'left_sole = "moved"'), extra=extra)
    assert "[sole]" in path.read_text()
    err = _check(path, capsys)
    assert f"left sole frame 'moved' is {distance} m from the centre of its foot's contact patch" in err, err
    assert f"and {outside} m outside the patch" in err, err


def test_negative_mass(tmp_path, capsys):
    err = _check(_robot(tmp_path, urdf=_urdf('<mass value="0.3"/>', '<mass value="-3"/>')), capsys)
    assert "link 'left_ankle': mass -3 kg is negative; valid: a mass >= 0 kg" in err, err


def test_infinite_inertia(tmp_path, capsys):
    err = _check(_robot(tmp_path, urdf=_urdf('ixx="0.02535"', 'ixx="1e400"')), capsys)
    assert "<link name='pelvis'> has <inertia ixx='1e400'>: not finite" in err, err


def test_inertia_not_positive_semi_definite(tmp_path, capsys):
    head, sep, tail = URDF.partition('<link name="left_thigh">')
    link, end, rest = tail.partition("</link>")
    values = dict(re.findall(r'(i[xyz]{2})="([^"]+)"', link))
    values["ixy"] = "5"
    bad = re.sub(r'<inertia [^/]*/>', "<inertia " + " ".join(f'{k}="{v}"' for k, v in values.items()) + "/>", link)
    err = _check(_robot(tmp_path, urdf=head + sep + bad + end + rest), capsys)
    v = {k: float(x) for k, x in values.items()}
    lowest = np.linalg.eigvalsh([[v["ixx"], v["ixy"], v["ixz"]], [v["ixy"], v["iyy"], v["iyz"]],
                                 [v["ixz"], v["iyz"], v["izz"]]])[0]
    assert lowest < 0
    assert f"link 'left_thigh': inertia matrix" in err and f"negative principal moment {lowest:.6g}" in err, err


@pytest.mark.parametrize("attr", ["velocity", "effort"])
def test_negative_speed_and_effort_limits(tmp_path, capsys, attr):
    old = 'velocity="10" effort="150"'
    new = old.replace(f'{attr}="', f'{attr}="-')
    err = _check(_robot(tmp_path, urdf=_urdf(old, new)), capsys)
    value = "-10" if attr == "velocity" else "-150"
    assert f"joint 'left_knee': <limit {attr}=\"{value}\"> is negative" in err, err


def test_zero_joint_axis(tmp_path, capsys):
    old = '<axis xyz="0 1 0"/>\n    <limit lower="0" upper="2.4"'
    err = _check(_robot(tmp_path, urdf=_urdf(old, old.replace("0 1 0", "0 0 0"))), capsys)
    assert "joint 'left_knee': <axis xyz=\"0 0 0\"> has no direction" in err, err


def _chain(n_links: int, moving: bool) -> str:
    """A URDF of ``n_links`` links in a chain (revolute or fixed joints)."""
    inertial = ('<inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>'
                '</inertial>')
    kind = 'type="revolute"><axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1" effort="1"/' if moving \
        else 'type="fixed"'
    parts = ['<?xml version="1.0"?>\n<robot name="chain">', f'<link name="l0">{inertial}</link>']
    for i in range(1, n_links):
        parts.append(f'<link name="l{i}">{inertial}</link><joint name="j{i}" {kind}><parent link="l{i - 1}"/>'
                     f'<child link="l{i}"/><origin xyz="0 0 0.01"/></joint>')
    return "\n".join(parts + ["</robot>\n"])


def _chain_file(tmp_path: Path, urdf_text: str) -> Path:
    (tmp_path / "chain.urdf").write_text(urdf_text)
    path = tmp_path / "chain.toml"
    path.write_text('urdf = "chain.urdf"\nleft_sole = "l1"\nright_sole = "l2"\ntorso = "l0"\n')
    return path


def test_urdf_of_more_than_500_links(tmp_path, capsys):
    err = _check(_chain_file(tmp_path, _chain(501, moving=False)), capsys)
    assert "more than 500 <link> elements" in err, err


def test_urdf_of_more_than_150_moving_joints(tmp_path, capsys):
    err = _check(_chain_file(tmp_path, _chain(152, moving=True)), capsys)
    assert "more than 150 moving joints" in err, err


def test_urdf_of_200_megabytes_is_not_read(tmp_path, capsys):
    path = _chain_file(tmp_path, _chain(3, moving=True))
    with open(tmp_path / "chain.urdf", "r+b") as f:
        f.truncate(200_000_000)  # sparse: 200 MB by its size, nothing written
    err = _check(path, capsys)
    assert "200.0 MB; at most 20 MB is read" in err, err


@pytest.mark.parametrize("edit, words", [
    (("step_length = 0.10", "step_length = 0.9"), ["'step_length': 0.9", "misses a sole target by"]),
    (("step_height = 0.04", "step_height = 0.45"), ["the legs cannot follow the gait", "misses a sole target by"]),
    (("t_ss = 0.7\nt_ds = 0.25", "t_ss = 0.1\nt_ds = 0.05"), ["x its URDF speed limit in a nominal walk"]),
])
def test_gait_table_checked_against_the_legs(tmp_path, capsys, edit, words):
    err = _check(_robot(tmp_path, toml=edit), capsys)
    for w in words:
        assert w in err, err


def test_stairs_step_width_narrower_than_the_sole(tmp_path, capsys):
    err = _check(_robot(tmp_path, extra="\n[stairs]\nstep_width = 0.03\n"), capsys)
    assert "[stairs] step_width = 0.03 m puts the feet over each other (sole width 0.100 m)" in err, err


def test_a_wrong_sole_frame_is_offered_only_frames_at_the_feet(tmp_path, capsys):
    """Talos's robot file with its left sole named 'rgbd': the close matches are frames of the feet (its head camera
    frames, rgbd_*, are the closest names of the whole model but cannot be a sole)."""
    text = (ROBOTS / "talos.toml").read_text()
    path = tmp_path / "talos.toml"
    path.write_text(text.replace('left_sole = "left_sole_link"', 'left_sole = "rgbd"'))
    err = _check(path, capsys)
    assert "robot 'talos' has no frame 'rgbd' for its left sole; close matches among the frames at the feet: [" in err
    offered = re.findall(r"'([^']+)'", err.split("close matches among the frames at the feet:")[1])
    assert "left_sole_link" in offered and not any(n.startswith("rgbd") for n in offered), offered
    # the offered frames are at the feet: within 0.3 m of the ground in the neutral posture (Pinocchio, not wbc)
    import pinocchio as pin

    from wbc.robot import load_robot

    model = load_robot("talos").model
    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    z = {f.name: data.oMf[i].translation[2] for i, f in enumerate(model.frames)}
    assert all(z[n] - min(z.values()) <= 0.3 for n in offered), {n: z[n] for n in offered}


def test_a_fifo_named_like_a_robot_file_is_not_called_missing(tmp_path, capsys):
    import os

    path = tmp_path / "robot.toml"
    os.mkfifo(path)  # opening it to read would block until a writer comes: it is never opened
    err = _check(path, capsys)
    assert err == (f"wbc robot: error: {path} is not a regular file (a pipe, device or socket); a robot file is a "
                   ".toml file (docs/pages/how-to/robot-file.md)"), err
