"""The test tree mirrors the package: a test of ``wbc/<package>/<module>.py`` lives in
``tests/<package>/test_<module>[_<topic>].py`` (a top-level module ``wbc/<module>.py`` in
``tests/test_<module>[_<topic>].py``; a package's public API, its ``__init__``, in
``tests/<package>/test_<package>[_<topic>].py``; a catalog robot of ``robots/`` in
``tests/robots/test_<robot>.py``). Tests of the project as a whole (architecture, docs, README, examples, install)
live in ``tests/project/``. Every test-file path the repository's code and documentation name exists (the dated
run records in ``benchmarks/records/`` keep the paths of their day)."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
TESTS = REPO / "tests"
PROJECT_DIR = "project"
ROBOTS_DIR = "robots"
RUN_RECORDS = "benchmarks/records/"


def misplaced_tests(tests: Path, package: Path, robots: Path) -> list[str]:
    """Test files under ``tests`` whose place names no module of ``package`` (the rule of the module docstring),
    each with the modules that would be valid there."""
    bad = []
    for path in sorted(tests.rglob("test_*.py")):
        rel = path.relative_to(tests)
        folders, name = rel.parts[:-1], path.stem[len("test_"):]
        if folders[:1] == (PROJECT_DIR,):
            continue
        if folders == (ROBOTS_DIR,):
            valid = {p.stem for p in robots.glob("*.toml")}
        else:
            where = package.joinpath(*folders)
            if not where.is_dir():
                bad.append(f"{rel}: no package wbc/{'/'.join(folders)}")
                continue
            valid = {p.stem for p in where.glob("*.py") if p.stem != "__init__"}
            if folders:
                valid.add(folders[-1])
        if not any(name == m or name.startswith(m + "_") for m in valid):
            bad.append(f"{rel}: test_{name} names none of {sorted(valid)}")
    return bad


def test_the_test_tree_mirrors_the_package():
    assert misplaced_tests(TESTS, REPO / "wbc", REPO / "robots") == []


def test_the_mirror_checker_flags_topic_files_and_missing_packages(tmp_path):
    pkg, tests, robots = tmp_path / "wbc", tmp_path / "tests", tmp_path / "robots"
    for f in ("qp.py", "sim/__init__.py", "sim/walk.py"):
        (pkg / f).parent.mkdir(parents=True, exist_ok=True)
        (pkg / f).write_text("")
    robots.mkdir()
    (robots / "talos.toml").write_text("")
    good = ["test_qp.py", "test_qp_retries.py", "sim/test_walk.py", "sim/test_walk_terrain.py", "sim/test_sim.py",
            "robots/test_talos.py", "project/test_docs.py"]
    bad = ["test_sim_walk.py", "sim/test_jump.py", "gait/test_swing.py", "robots/test_g1.py", "test_qpx.py"]
    for f in good + bad:
        (tests / f).parent.mkdir(parents=True, exist_ok=True)
        (tests / f).write_text("")
    found = misplaced_tests(tests, pkg, robots)
    assert sorted(line.split(":")[0] for line in found) == sorted(bad)


def test_every_test_path_named_in_the_repository_exists():
    files = subprocess.run(["git", "ls-files"], cwd=REPO, capture_output=True, text=True, check=True).stdout.split()
    named = re.compile(r"\btests/[\w/]+\.py")
    missing = []
    for f in files:
        path = REPO / f
        if path.suffix not in (".py", ".md", ".toml", ".yml") or not path.is_file() or f.startswith(RUN_RECORDS):
            continue
        for m in named.finditer(path.read_text(encoding="utf-8", errors="replace")):
            if not (REPO / m.group(0)).is_file():
                missing.append(f"{f}: {m.group(0)}")
    assert missing == []


def shared_basenames(tests: Path) -> list[str]:
    """Test file names that stand in more than one folder of ``tests`` (the test folders are not packages: pytest
    imports each file under its bare name and refuses the second one at collection)."""
    seen: dict[str, list[str]] = {}
    for path in sorted(tests.rglob("test_*.py")):
        seen.setdefault(path.name, []).append(str(path.relative_to(tests)))
    return [f"{name}: {', '.join(paths)}" for name, paths in seen.items() if len(paths) > 1]


def test_no_two_test_files_share_a_name():
    assert shared_basenames(TESTS) == []


def test_the_name_checker_flags_a_shared_name(tmp_path):
    for folder in ("constraints", "solvers"):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "test_base.py").write_text("")
    assert shared_basenames(tmp_path) == ["test_base.py: constraints/test_base.py, solvers/test_base.py"]
