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
    for opt, suffix in (("--out", ".html"), ("--json", ".json"), ("--log", ".npz"), ("--plot", ".png")):
        code, out, err = _run(["walk", opt, str(target.with_suffix(suffix))], capsys)
        assert code == 2, opt
        assert "does not exist" in err and "nonexistent_dir" in err
        assert not target.parent.exists()
    code, _, err = _run(["sim", "stand", "--video", str(target.with_suffix(".mp4"))], capsys)
    assert code == 2 and "--video" in err and "does not exist" in err and not target.parent.exists()


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


# Summary keys that need no unit suffix: names, flags, counts and lists of text; each is listed with why.
UNITLESS = {
    "robot", "behaviour", "scenario", "controller", "solver", "state_source", "stabilizer", "touchdown_detection",
    "fall_reason", "passed", "failed_criteria", "nan", "fell", "completed",  # names, flags, text
    "ticks", "steps", "touchdowns", "deadline_misses", "solver_failures", "relaxed_qp_ticks", "relaxed_ticks",
    "joint_position_violations", "joint_velocity_violations", "ticks_per_route", "ticks_per_path",  # counts
}
UNIT_SUFFIXES = ("_m", "_s", "_rad", "_us", "_n", "_nm", "_mps", "_hz", "_kg", "_ratio", "_fraction", "_factor")


def _unlabelled(summary: dict) -> list[str]:
    return sorted(k for k, v in summary.items() if isinstance(v, (int, float, dict, list)) and not
                  isinstance(v, bool) and k not in UNITLESS and not k.endswith(UNIT_SUFFIXES))


@pytest.fixture(scope="module")
def walk3(tmp_path_factory):
    """`wbc walk --steps 3` (Talos, default 0.15 m steps) with its JSON summary and npz log."""
    folder = tmp_path_factory.mktemp("walk3")
    js, log = folder / "s.json", folder / "w.npz"
    assert main(["walk", "--steps", "3", "--quiet", "--json", str(js), "--log", str(log)]) == 0
    import json

    with np.load(log) as z:
        data = {k: z[k] for k in z.files}
    return json.loads(js.read_text()), data


def test_steps_n_walks_n_steps(walk3):
    summary, log = walk3
    support = log["support"]
    # N steps = N single-support phases in the executed support sequence; the feet advance (N - 1) x 0.15 m
    phases = support[np.r_[True, np.diff(support) != 0]]
    assert int(np.sum(phases != 0)) == 3 and summary["steps"] == 3
    mid0 = 0.5 * (log["left_sole"][0, :2, 3] + log["right_sole"][0, :2, 3])
    mid1 = 0.5 * (log["left_sole"][-1, :2, 3] + log["right_sole"][-1, :2, 3])
    assert np.linalg.norm(mid1 - mid0) == pytest.approx(2 * 0.15, abs=0.005)
    assert summary["walked_distance_m"] == pytest.approx(np.linalg.norm(mid1 - mid0), abs=1e-9)


def test_walk_summary_keys_carry_units(walk3):
    summary, _ = walk3
    assert _unlabelled(summary) == []
    assert summary["dt_s"] == 0.002 and "dt" not in summary


def test_balance_summary_keys_carry_units(robots):
    from wbc.scenarios.balance import balance_summary, run_balance

    robot = robots("humanoid15")
    summary = balance_summary(robot, run_balance(robot, "shift"))
    assert _unlabelled(summary) == []
    assert "max_task_error" not in summary and {"com"} <= set(summary["max_task_error_m"])
    assert {"torso", "posture"} <= set(summary["max_task_error_rad"])


def test_every_npz_key_of_the_walk_log_is_in_the_readme(walk3):
    from pathlib import Path

    readme = (Path(__file__).resolve().parents[2] / "docs" / "pages" / "reference" / "commands.md").read_text()
    paragraph = re.search(r"`--log` writes an npz with (.*?)Row k", readme, re.S).group(1)
    documented = set(re.findall(r"`([a-z_]+)`", paragraph))
    _, log = walk3
    assert set(log) == documented, (set(log) - documented, documented - set(log))


def test_bench_quick_exits_0(tmp_path, capsys):
    """`wbc bench --quick` (every section, few repeats) is a pipeline check: exit code 0 when it works."""
    code = main(["bench", "--quick", "--out-dir", str(tmp_path)])
    out = capsys.readouterr()
    assert code == 0, out.out[-2000:] + out.err[-2000:]
    assert (tmp_path / "results.md").is_file()


def test_top_level_help_is_whole_sentences_and_lists_every_sim_scenario(capsys):
    """`wbc --help`: the description ends its sentence (not "... wbc compile (also"), and the sim line names all 8
    scenarios the sim command accepts."""
    import argparse

    from wbc.cli import build_parser

    parser = build_parser()
    assert parser.description == ("Command line: wbc walk, wbc balance, wbc sim, wbc bench, wbc plot, wbc compile "
                                  "(also python -m wbc).")
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    sim_help = next(c.help for c in sub._choices_actions if c.dest == "sim")
    scenarios = next(a for a in sub.choices["sim"]._actions if a.dest == "scenario").choices
    assert sim_help.endswith(": " + ", ".join(scenarios)) and len(scenarios) == 8
    for name in ("stand", "sway", "one-leg", "push", "walk", "wave", "jump", "push-step"):
        assert name in scenarios
