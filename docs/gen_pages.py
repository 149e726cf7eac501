"""mkdocs-gen-files script (docs/mkdocs.yml): the pages generated at build time, never committed.

- ``reference/cli.md``: ``format_help()`` of ``wbc.cli.build_parser()`` and of every sub-command parser (and
  their own sub-commands), so the reference is the parsers themselves;
- ``reference/api/<module>.md``: one mkdocstrings page per public module of ``wbc`` (``::: wbc.x``), rendered
  from the docstrings, and ``reference/api/index.md`` listing them by layer;
- ``concepts/architecture.md`` from ``docs/architecture.md`` and ``benchmarks.md`` from
  ``benchmarks/README.md`` (one source each).
"""

from __future__ import annotations

import argparse
import os
import pkgutil
import re
import sys
from pathlib import Path

import mkdocs_gen_files

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
os.environ["COLUMNS"] = "88"  # argparse wraps help at the terminal width: fixed, to fit the page

import wbc  # noqa: E402
from wbc.cli import build_parser  # noqa: E402

# -- CLI reference ----------------------------------------------------------------------------------------------


def _subparsers(parser: argparse.ArgumentParser):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            yield from action.choices.items()


def _cli_sections(parser: argparse.ArgumentParser, prefix: str, level: int):
    yield f"{'#' * level} `{prefix}`\n\n```text\n{parser.format_help().rstrip()}\n```\n"
    for name, sub in _subparsers(parser):
        yield from _cli_sections(sub, f"{prefix} {name}", level + 1)


with mkdocs_gen_files.open("reference/cli.md", "w") as f:
    f.write("# CLI reference\n\nGenerated from the `argparse` parsers of `wbc.cli` at build time "
            "(`wbc <command> --help` prints the same text). The [Commands](commands.md) page explains what "
            "each command runs and what its summary means.\n\n")
    f.write("\n".join(_cli_sections(build_parser(), "wbc", 2)))

# -- API reference ----------------------------------------------------------------------------------------------

#: (title, module prefixes) in the order of docs/architecture.md's layers
LAYERS = [
    ("Package root", ["wbc"]),
    ("Errors, constants, compiled kernels", ["wbc.exceptions", "wbc.constants", "wbc.compiled", "wbc.kernel_cache"]),
    ("Geometry, Lie groups, profiles, terrain, solvers",
     ["wbc.geometry", "wbc.lie", "wbc.profiles", "wbc.terrain", "wbc.solvers"]),
    ("Robot, kinematics", ["wbc.robot", "wbc.robot_checks", "wbc.robot_file", "wbc.robot_inspect", "wbc.configuration", "wbc.state"]),
    ("Tasks", ["wbc.tasks"]),
    ("Constraints", ["wbc.constraints"]),
    ("State estimation", ["wbc.estimation"]),
    ("Formulations, controllers", ["wbc.formulations", "wbc.controllers", "wbc.tick", "wbc.dynamics", "wbc.solve"]),
    ("Gait", ["wbc.gait"]),
    ("Analysis", ["wbc.analysis"]),
    ("Scenarios", ["wbc.scenarios"]),
    ("Physics (MuJoCo)", ["wbc.sim"]),
    ("Outputs: viewer, plots, ROS 2, benchmarks, campaigns", ["wbc.viz", "wbc.ros2", "wbc.bench", "wbc.campaign"]),
    ("Command line", ["wbc.cli"]),
]

modules = ["wbc"] + sorted(m.name for m in pkgutil.walk_packages(wbc.__path__, "wbc.")
                           if not any(part.startswith("_") for part in m.name.split("."))
                           and not m.name.startswith("wbc.robots")
                           and not m.name.startswith("wbc.constraints.narrow_phase"))

index = ["# API reference\n", "Rendered from the docstrings (mkdocstrings) at build time, one page per module, in "
         "the layers of [the architecture](../../concepts/architecture.md). Names starting with `_` are "
         "private and not shown.\n"]
placed = set()
for title, prefixes in LAYERS:
    names = [m for m in modules if m not in placed and any(m == p or m.startswith(p + ".") for p in prefixes)
             and (title != "Package root" or m == "wbc")]
    if not names:
        continue
    index.append(f"\n## {title}\n")
    for name in names:
        placed.add(name)
        with mkdocs_gen_files.open(f"reference/api/{name}.md", "w") as f:
            f.write(f"# `{name}`\n\n::: {name}\n")
        index.append(f"- [`{name}`]({name}.md)")
missing = set(modules) - placed
if missing:
    raise RuntimeError(f"gen_pages.py: modules in no layer of LAYERS: {sorted(missing)}")
with mkdocs_gen_files.open("reference/api/index.md", "w") as f:
    f.write("\n".join(index) + "\n")

# -- pages kept in one place elsewhere in the repository --------------------------------------------------------


def _relink(text: str, links: dict[str, str]) -> str:
    for old, new in links.items():
        text = text.replace(f"]({old})", f"]({new})")
    return text


with mkdocs_gen_files.open("concepts/architecture.md", "w") as f:
    f.write((ROOT / "docs" / "architecture.md").read_text())
mkdocs_gen_files.set_edit_path("concepts/architecture.md", "../architecture.md")

bench = (ROOT / "benchmarks" / "README.md").read_text()
# repository-relative file references become plain text (the site has no copy of the source tree)
bench = re.sub(r"\]\((?!https?://)([^)#]+\.(?:py|md|toml))\)", r"] (`\1`)", bench)
with mkdocs_gen_files.open("benchmarks.md", "w") as f:
    f.write(bench)
