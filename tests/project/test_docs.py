"""The documentation site builds with ``mkdocs build --strict`` (offline), and every tutorial page runs: its
Python blocks, concatenated in order, execute in a fresh interpreter and their own assertions hold (so do the
Python blocks of the other pages)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import dds_domain_id

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
TUTORIAL = sorted((DOCS / "pages" / "tutorial").glob("*.md"))
# every other hand-written page with Python code runs too (getting started, concepts)
GETTING_STARTED = DOCS / "pages" / "getting-started.md"
OTHER_CODE = sorted(p for p in (DOCS / "pages").rglob("*.md") if p.parent.name != "tutorial"
                    and p != GETTING_STARTED and "```python" in p.read_text())


def _env() -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
    env["NO_MKDOCS_2_WARNING"] = env["DISABLE_MKDOCS_2_WARNING"] = "true"
    env["MPLBACKEND"] = "Agg"
    env["ROS_DOMAIN_ID"] = str(dds_domain_id())  # DDS: a random domain, loopback (the pages call
    from wbc.ros2.dds import loopback_uri                 # use_loopback; set here too for any child process)

    env["CYCLONEDDS_URI"] = loopback_uri()
    return env


def python_blocks(page: Path) -> str:
    return "\n".join(re.findall(r"^```python\n(.*?)^```", page.read_text(), re.S | re.M))


def test_site_builds_strict_offline(tmp_path):
    pytest.importorskip("mkdocstrings_handlers.python", reason="the docs extra: pip install -e '.[docs]'")
    env = _env()
    # offline: any attempt to open a network connection from the build fails it
    env["HTTP_PROXY"] = env["HTTPS_PROXY"] = env["http_proxy"] = env["https_proxy"] = "http://127.0.0.1:9"
    out = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(DOCS / "mkdocs.yml"),
                          "-d", str(tmp_path / "site")], capture_output=True, text=True, timeout=600, env=env)
    assert out.returncode == 0, out.stderr[-4000:]
    site = tmp_path / "site"
    cli = (site / "reference" / "cli.html").read_text()
    from wbc.cli import build_parser

    sub = next(a for a in build_parser()._actions if a.dest == "command")
    for name, parser in sub.choices.items():  # the CLI reference is the parsers' own help
        assert f"wbc {name}" in cli, name
        for action in parser._actions:
            for opt in action.option_strings:
                assert opt in cli, (name, opt)
    api = (site / "reference" / "api" / "wbc.formulations.velocity.html").read_text()
    assert "KinematicController" in api and "min_v" in api  # rendered from the docstring
    for page in TUTORIAL:
        assert (site / "tutorial" / page.with_suffix(".html").name).is_file(), page.name


def test_getting_started_shows_the_readme_example():
    """The first program on the site is README's (which tests/project/test_readme.py runs and checks)."""
    readme = (ROOT / "README.md").read_text()
    first = re.search(r"```python\n(.*?)```", readme, re.S).group(1)
    assert python_blocks(GETTING_STARTED).strip() == first.strip()


def test_tutorial_pages_have_code():
    names = {p.stem for p in TUTORIAL}
    assert {"walking-publisher", "wave", "one-leg", "jump", "urdf", "knee-subscriber"} <= names
    for page in TUTORIAL:
        if page.stem != "index":
            assert python_blocks(page).strip(), page.name


@pytest.mark.parametrize("page", [p for p in TUTORIAL if p.stem != "index"] + OTHER_CODE,
                         ids=lambda p: str(p.relative_to(DOCS / "pages").with_suffix("")))
def test_tutorial_page_runs(page):
    code = python_blocks(page)
    if "wbc.ros2" in code:
        pytest.importorskip("cyclonedds", reason="the ros2 extra: pip install -e '.[ros2]'")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, env=_env(),
                         cwd=ROOT)
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-4000:]
    assert out.stdout.strip(), "the page prints what it shows"


def test_navigation_has_a_top_level_api_reference_item():
    """The site's top navigation (the tabs) names the API reference, not only a sub-item of Reference."""
    nav = (DOCS / "mkdocs.yml").read_text().split("\nnav:\n", 1)[1]
    top = [line[4:].split(":")[0] for line in nav.splitlines() if line.startswith("  - ")]
    assert "API reference" in top, top
