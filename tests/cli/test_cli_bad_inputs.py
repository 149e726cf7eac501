"""Every bad command line is refused before any work: exit code 2, one line on stderr naming the option as typed,
nothing on stdout (no run started, no summary), no file written. In-process (`wbc.cli.main`), parse-time checks."""

from __future__ import annotations

import io
import re

import pytest

from wbc.cli import main

# (argv, text the one-line error must contain). "{tmp}" is a fresh folder, "{corrupt}" a truncated npz file,
# "{file}" an existing regular file, "{folder}" an existing folder.
BAD = [
    # output paths: a folder, a pseudo file system, a device, wrong suffixes, missing folder, same file twice
    (["walk", "--out", "{folder}"], "--out"),
    (["walk", "--out", "/proc/x.html"], "/proc"),
    (["walk", "--json", "/dev/full"], "--json"),
    (["walk", "--json", "/dev/x.json"], "/dev"),
    (["walk", "--plot", "{tmp}/x.txt"], ".png"),
    (["walk", "--log", "{tmp}/x.csv"], ".npz"),
    (["walk", "--out", "{tmp}/x.png"], ".html"),
    (["walk", "--json", "{tmp}/x"], ".json"),
    (["walk", "--log", "{folder}"], "existing folder"),
    (["walk", "--plot", "{tmp}/missing/x.png"], "does not exist"),
    (["balance", "shift", "--out", "/proc/self/x.html"], "/proc"),
    (["sim", "stand", "--video", "{tmp}/x.avi"], ".mp4"),
    (["sim", "stand", "--video", "/proc/x.mp4"], "/proc"),
    (["walk", "--bag", "{folder}"], "--bag"),
    (["walk", "--bag", "/proc/bag"], "/proc"),
    (["bench", "--out-dir", "{file}"], "--out-dir"),
    (["bench", "--out-dir", "/proc/results"], "--out-dir"),
    (["plot", "{corrupt}"], "not a readable npz"),
    (["plot", "{tmp}/none.npz"], "does not exist"),
    (["plot", "{file}", "--out", "{tmp}/x.jpg"], ".png"),
    # sizes, bounded by memory (the message says how much) or physics (the message says why)
    (["walk", "--steps", "100000"], "GiB"),
    (["walk", "--dt", "1e-9"], "--dt"),
    (["walk", "--dt", "0"], "--dt"),
    (["walk", "--dt", "-0.002"], "--dt"),
    (["walk", "--dt", "0.5"], "--dt"),
    (["walk", "--dt", "nan"], "--dt"),
    (["walk", "--steps", "1"], "--steps 1"),
    (["walk", "--steps", "abc"], "--steps"),
    (["sim", "stand", "--duration", "1e9"], "GiB"),
    (["sim", "stand", "--duration", "0"], "--duration"),
    (["sim", "stand", "--duration", "-1"], "--duration"),
    (["sim", "stand", "--duration", "inf"], "--duration"),
    (["sim", "push", "--push-duration", "0"], "--push-duration"),
    (["sim", "walk", "--steps", "1000000"], "GiB"),
    (["sim", "walk", "--steps", "1"], "--steps"),
    (["sim", "walk", "--step-duration", "0"], "--step-duration"),
    (["sim", "walk", "--step-width", "0"], "--step-width"),
    (["sim", "jump", "--height", "1e6"], "weight"),
    (["sim", "jump", "--height", "-0.1"], "--height"),
    (["sim", "jump", "--count", "0"], "--count"),
    (["sim", "jump", "--landing-crouch", "0.2"], "--landing-crouch"),
    (["balance", "jump", "--height", "1e6"], "weight"),
    (["balance", "jump", "--height", "nan"], "--height"),
    (["balance", "jump", "--count", "100000"], "GiB"),
    (["balance", "shift", "--dt", "1e-9"], "--dt"),
    (["bench", "--ticks", "-1"], "--ticks"),
    (["bench", "--ticks", "0"], "--ticks"),
    (["bench", "--repeats", "0"], "--repeats"),
    (["bench", "--warmup", "-1"], "--warmup"),
    # option values
    (["sim", "stand", "--video-size", "abc"], "--video-size"),
    (["sim", "stand", "--video-size", "0x0"], "--video-size"),
    (["sim", "stand", "--video-size", "100000x100000"], "--video-size"),
    (["sim", "stand", "--mu", "0"], "--mu"),
    (["sim", "stand", "--f-min", "-1"], "--f-min"),
    (["sim", "stand", "--force", "nan"], "--force"),
    (["sim", "walk", "--turn", "200"], "--turn"),
    (["sim", "walk", "--delay", "-1"], "--delay"),
    (["walk", "--turn", "nan"], "--turn"),
    (["walk", "--step-width", "0"], "--step-width"),
    (["walk", "--ros2-interface", "a/b"], "--ros2-interface"),
    (["walk", "--ros2-rate", "0"], "--ros2-rate"),
    (["walk", "--hold", "3"], "--hold"),
    (["ros2", "topics", "--wait", "-1"], "--wait"),
    (["ros2", "echo-joint", "right_knee", "--count", "0"], "--count"),
    (["ros2", "joint-publisher", "--rate", "0"], "--rate"),
    # messages name the option the user gave
    (["walk", "--vx=-0.1"], "--vx"),
    (["walk", "--vx", "3"], "--vx"),
    (["walk", "--step-length", "5"], "--step-length"),
    (["sim", "walk", "--vx=-0.1"], "--vx"),
    (["sim", "walk", "--vx", "3"], "--vx"),
    (["sim", "walk", "--step-length", "5"], "--step-length"),
    (["sim", "walk", "--wz", "1000"], "--wz"),
    (["walk", "--wz", "1000"], "--wz"),
    (["walk", "--vy", "5"], "--vy"),
    # names and choices
    (["walk", "--robot", "nope"], "unknown robot 'nope'"),
    (["walk", "--robot", "{file}"], "unknown robot"),
    (["walk", "--solver", "nope"], "--solver"),
    (["balance", "nope"], "behaviour"),
    (["sim", "nope"], "scenario"),
    (["walk", "--storage", "zip"], "--storage"),
    (["walk", "--tf", "none"], "--tf"),
    (["balance", "shift", "--ros2-interface", ""], "--ros2-interface"),
    # more sizes and values
    (["walk", "--steps", "-3"], "--steps -3"),
    (["walk", "--steps", "2.5"], "--steps"),
    (["walk", "--step-width", "-0.1"], "--step-width"),
    (["walk", "--step-width", "nan"], "--step-width"),
    (["walk", "--turn", "1e9"], "--turn"),
    (["walk", "--ros2-rate", "1e9"], "--ros2-rate"),
    (["sim", "stand", "--mu", "nan"], "--mu"),
    (["sim", "stand", "--mu", "-1"], "--mu"),
    (["sim", "walk", "--delay", "nan"], "--delay"),
    (["sim", "jump", "--height", "inf"], "--height"),
    (["sim", "push", "--push-duration", "nan"], "--push-duration"),
    (["balance", "squat", "--dt", "0"], "--dt"),
    (["bench", "--ticks", "abc"], "--ticks"),
    (["bench", "--ticks", "1e12"], "--ticks"),
    # more output paths and option pairs
    (["walk", "--out", ""], "--out"),
    (["walk", "--json", "{tmp}/a.json", "--log", "{tmp}/a.json"], ".npz"),
    (["walk", "--log", "{tmp}/x.npz", "--out", "{tmp}/x.npz"], ".html"),
    (["walk", "--live-start-now"], "--live-start-now"),
    (["walk", "--live", "--hold", "-1"], "--hold"),
    (["sim", "push", "--height", "100"], "--height 100 applies to wbc sim jump only; the push scenario has no height "
                                         "(valid: wbc sim jump --height ..., or leave it out)"),
    (["sim", "walk", "--landing-crouch", "0.05"], "--landing-crouch 0.05 applies to wbc sim jump only"),
]


@pytest.fixture
def paths(tmp_path):
    folder = tmp_path / "folder"
    folder.mkdir()
    (tmp_path / "file.npz").write_bytes(b"not a zip")
    corrupt = tmp_path / "corrupt.npz"
    import numpy as np

    buf = io.BytesIO()
    np.savez(buf, t=np.zeros(100), q=np.zeros((100, 3)), com=np.zeros((100, 3)))
    corrupt.write_bytes(buf.getvalue()[:300])  # a log truncated mid-write
    return {"tmp": str(tmp_path), "folder": str(folder), "file": str(tmp_path / "file.npz"), "corrupt": str(corrupt)}


@pytest.mark.parametrize("argv, expected", BAD, ids=[" ".join(a) for a, _ in BAD])
def test_bad_input_is_one_line_exit_2_before_any_work(argv, expected, paths, capsys):
    argv = [a.format(**paths) for a in argv]
    expected = expected.format(**paths)
    before = sorted(p.name for p in __import__("pathlib").Path(paths["tmp"]).rglob("*"))
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's own errors
        code = exc.code
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert code == 2, (argv, code, out[-500:], err[-500:])
    assert len(lines) == 1, err
    assert re.match(r"wbc [a-z0-9-]+(?: [a-z-]+)?: error: ", lines[0]), lines[0]
    assert expected in lines[0], lines[0]
    assert "Traceback" not in err
    assert out == "", out  # nothing ran: no summary, no URL, no "written to"
    after = sorted(p.name for p in __import__("pathlib").Path(paths["tmp"]).rglob("*"))
    assert after == before  # nothing written


def test_sizes_name_the_memory_needed(capsys):
    code = main(["walk", "--steps", "100000"])
    err = capsys.readouterr().err
    m = re.search(r"need ≈ ([0-9.e+]+) GiB", err)
    assert code == 2 and m
    # 100000 steps of talos's 1.1 s gait at 2 ms: 5.5e7 ticks; at the stated kB per tick, hundreds of GiB
    per_tick = float(re.search(r"~(\d+) kB per tick", err).group(1)) * 1000
    assert float(m.group(1)) == pytest.approx((100000 + 2) * 1.1 / 0.002 * per_tick / 2**30, rel=0.01)


def test_every_angle_option_is_in_degrees():
    """One unit for angles: every option whose value is an angle (yaw per step, turn rate, push direction, joint
    position noise) says deg in its help, and none of them says rad."""
    from wbc.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    angle_opts = []
    for name, p in sub.choices.items():
        for a in p._actions:
            text = (a.help or "").lower()
            if any(s in a.option_strings for s in ("--turn", "--wz", "--push-dir", "--q-noise")):
                angle_opts.append((name, a.option_strings[0]))
                assert "deg" in text and not re.search(r"\brad\b", text), (name, a.option_strings, text)
    assert ("walk", "--turn") in angle_opts and ("sim", "--turn") in angle_opts


def test_walk_turn_is_degrees_per_step(monkeypatch):
    """`wbc walk --turn 10` plans 10° of yaw per step (what `sim walk --turn 10` does)."""
    import math

    import wbc.scenarios.walk as walk_mod
    from wbc.cli import walk as cli_walk

    seen = {}

    class Stop(Exception):
        pass

    def fake_plan(robot, **kw):
        seen.update(kw)
        raise Stop

    monkeypatch.setattr(walk_mod, "plan_default_walk", fake_plan)
    with pytest.raises(Stop):
        main(["walk", "--turn", "10", "--steps", "3", "--quiet"])
    assert seen["turn"] == pytest.approx(math.radians(10.0))
    assert cli_walk  # the module under test


def test_broken_pipe_is_quiet(monkeypatch, capsys):
    """`wbc robots | head -1`: the reader goes away; wbc stops quietly with exit 0, no traceback."""
    class Closed(io.StringIO):
        def write(self, s):
            raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr("sys.stdout", Closed())
    assert main(["robots"]) == 0
    assert "Traceback" not in capsys.readouterr().err
