"""The Commands page of the documentation (docs/pages/reference/commands.md, the command reference that was in
README) in step with the CLI: the `wbc walk` usage block lists exactly the walk parser's options, the options it
says `walk`, `balance` and `sim` share exist on each of them (and not on `bench`), every command is described;
README links to it."""

from __future__ import annotations

import re
from pathlib import Path

from wbc.cli import build_parser

ROOT = Path(__file__).resolve().parents[2]
README = (ROOT / "docs" / "pages" / "reference" / "commands.md").read_text()


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


def test_readme_links_the_commands_page():
    readme = (ROOT / "README.md").read_text()
    assert "(docs/pages/reference/commands.md)" in readme
    for name in ("walk", "balance", "sim", "plot", "robots", "ros2", "bench"):
        assert f"`{name}`" in readme or f"wbc {name}" in readme, name
