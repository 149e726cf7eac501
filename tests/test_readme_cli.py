"""README in step with the CLI: the `wbc walk` usage block lists exactly the walk parser's options, and the
options README says `walk`, `balance` and `sim` share exist on each of them (and not on `bench`)."""

from __future__ import annotations

import re
from pathlib import Path

from wbc.cli import build_parser

README = (Path(__file__).resolve().parents[1] / "README.md").read_text()


def _options(name):
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    return {s for a in sub.choices[name]._actions for s in a.option_strings if s.startswith("--")} - {"--help"}


def test_walk_usage_block_matches_the_parser():
    block = re.search(r"```\n(wbc walk .*?)```", README, re.S).group(1)
    assert set(re.findall(r"--[a-z][a-z0-9-]*", block)) == _options("walk")


def test_shared_options_exist_where_readme_says():
    line = re.search(r"`walk`, `balance` and `sim` share (.*?);", README, re.S).group(1)
    shared = set(re.findall(r"`(--[a-z-]+)`", line))
    assert {"--json", "--log", "--out", "--plot", "--live", "--hold"} <= shared
    for name in ("walk", "balance", "sim"):
        assert shared <= _options(name), name
    assert not ({"--json", "--log", "--live", "--plot"} & _options("bench"))
    assert "--out-dir" in _options("bench") and "`--out-dir`" in README


def test_every_command_is_in_readme():
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    for name in sub.choices:
        assert f"wbc {name}" in README, name
