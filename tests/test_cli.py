"""CLI edge cases: each is refused (or answered) before any run, with a message naming the valid range and the
documented exit code (0 ok, 2 bad input)."""

from __future__ import annotations

import re

import numpy as np
import pytest

import wbc
from wbc.cli import build_parser, deadline_misses, leg_reach, main


def _run(argv, capsys):
    code = main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"wbc {wbc.__version__}"


def test_every_help_has_a_description():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    assert {"walk", "balance", "sim", "bench", "plot"} <= set(sub.choices)
    for name, p in sub.choices.items():
        text = p.format_help()
        body = text.split("\n\n")[1]  # the paragraph after "usage: ..."
        assert not body.startswith(("positional arguments", "options")), f"wbc {name} --help has no description"
        assert len(body.split()) >= 4, (name, body)


@pytest.mark.parametrize("steps", [1, 0, -3])
def test_walk_refuses_fewer_than_two_steps(steps, capsys):
    code, out, err = _run(["walk", "--steps", str(steps)], capsys)
    assert code == 2
    assert f"--steps {steps}" in err and "steps >= 2" in err
    assert "ticks" not in out  # nothing ran


def test_walk_refuses_a_step_beyond_the_legs_reach(talos, capsys):
    code, out, err = _run(["walk", "--step-length", "5"], capsys)
    assert code == 2
    m = re.search(r"valid: 0 <= step length <= ([0-9.]+) m", err)
    assert m and "beyond the reach" in err
    assert float(m.group(1)) == pytest.approx(leg_reach(talos), abs=1e-3)
    code, _, err = _run(["walk", "--step-length", "-0.1"], capsys)
    assert code == 2 and "valid: 0 <= step length" in err


def test_leg_reach_of_talos_is_plausible(talos):
    # Talos's thigh and shank are 0.38 m and 0.325 m (URDF joint offsets); its hip sits ~0.9 m high in the
    # half-sitting pose: the soles can span a few decimetres, more than the 0.30 m steps known to walk.
    reach = leg_reach(talos)
    assert 0.3 < reach < 2 * 0.8


def test_output_into_a_missing_folder_is_refused_and_not_created(tmp_path, capsys):
    target = tmp_path / "nonexistent_dir" / "x.html"
    for opt in ("--out", "--json", "--log", "--plot"):
        code, out, err = _run(["walk", opt, str(target)], capsys)
        assert code == 2, opt
        assert "does not exist" in err and "nonexistent_dir" in err
        assert not target.parent.exists()


def test_hold_needs_live_and_a_finite_duration(capsys):
    code, _, err = _run(["balance", "shift", "--hold", "3"], capsys)
    assert code == 2 and "--hold only applies with --live" in err
    code, _, err = _run(["balance", "shift", "--live", "--hold", "-1"], capsys)
    assert code == 2 and "--hold must be" in err


def test_plot_of_a_missing_log(tmp_path, capsys):
    code, _, err = _run(["plot", str(tmp_path / "none.npz")], capsys)
    assert code == 2 and "does not exist" in err


def test_deadline_misses_counts_ticks_over_the_period():
    assert deadline_misses(np.array([1e-3, 2e-3, 2.0001e-3, 5e-3]), 2e-3) == 2
    assert deadline_misses(np.zeros(0), 2e-3) == 0


@pytest.fixture(scope="module")
def talos(robots):
    return robots("talos")
