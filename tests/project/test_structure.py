"""Structure rules of ``wbc``, read from the source with ``ast``:

- no module of ``wbc/`` over 800 lines and no class over 600 lines, save the exceptions of :data:`SIZE_EXCEPTIONS`
  (one line of reason each; an exception the source no longer needs fails too, so that the list only shrinks);
- no public top-level function or class defined in two modules of ``wbc/`` (a re-export, ``from m import f``, is
  not a definition; private ``_names`` cannot be imported across modules, see ``test_architecture.py``), save the
  names of :data:`SHARED_NAMES`;
- every module of the packages of :data:`MIRRORED` has its test file ``tests/<package>/test_<module>.py``, or
  ``tests/<package>/test_<package>_<module>.py`` where another folder holds a ``test_<module>.py`` (pytest imports
  each test file under its bare name: no two may share one, ``tests/project/test_layout.py``), save the modules of
  :data:`UNMIRRORED`.

The thresholds are written here, not read from ``wbc``.
"""

from __future__ import annotations

import ast
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
WBC = REPO / "wbc"
MODULE_LINES = 800
CLASS_LINES = 600

#: path under ``wbc/`` → why it may exceed :data:`MODULE_LINES` / hold a class over :data:`CLASS_LINES`.
SIZE_EXCEPTIONS = {
}

#: public name → why several modules define it.
SHARED_NAMES = {
    "register": "the wbc.cli command protocol: every command module's register(subparsers)",
    "main": "entry points: wbc.cli's, and the meshcat server process's (wbc/viz/_server.py)",
}

#: packages of ``wbc/`` whose every module has a test file of its name.
MIRRORED = ("tasks", "constraints", "formulations", "solvers", "controllers", "gait", "estimation")

#: ``package/module`` → why it has no test file of its name yet (an entry the tree no longer needs fails too).
UNMIRRORED = {
}


def _modules(root: Path) -> list[Path]:
    return sorted(p for p in root.rglob("*.py") if not p.is_symlink() and "robots" not in p.relative_to(root).parts)


def oversized(root: Path, module_lines: int = MODULE_LINES, class_lines: int = CLASS_LINES) -> dict[str, list[str]]:
    """path under ``root`` → its size violations (module lines, then each class over ``class_lines``)."""
    out: dict[str, list[str]] = {}
    for path in _modules(root):
        text = path.read_text()
        bad = []
        n = text.count("\n")
        if n > module_lines:
            bad.append(f"{n} lines > {module_lines}")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.ClassDef) and node.end_lineno - node.lineno + 1 > class_lines:
                bad.append(f"class {node.name}: {node.end_lineno - node.lineno + 1} lines > {class_lines}")
        if bad:
            out[path.relative_to(root).as_posix()] = bad
    return out


def defined_twice(root: Path) -> dict[str, list[str]]:
    """Public top-level function or class name → the modules (paths under ``root``) that define it, for the names
    two or more define."""
    where: dict[str, list[str]] = {}
    for path in _modules(root):
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and \
                    not node.name.startswith("_"):
                where.setdefault(node.name, []).append(path.relative_to(root).as_posix())
    return {name: paths for name, paths in sorted(where.items()) if len(paths) > 1}


def untested_modules(root: Path, tests: Path, packages=MIRRORED) -> list[str]:
    """``package/module`` of each module of ``packages`` with neither ``tests/<package>/test_<module>.py`` nor
    ``tests/<package>/test_<package>_<module>.py``."""
    return [f"{pkg}/{p.stem}" for pkg in packages for p in sorted((root / pkg).glob("*.py"))
            if p.stem != "__init__" and not any((tests / pkg / f"test_{name}.py").is_file()
                                                for name in (p.stem, f"{pkg}_{p.stem}"))]


def beyond_exceptions(found, exceptions: dict) -> tuple[dict, list]:
    """(the violations ``found`` (key → details) that ``exceptions`` does not list, the listed keys no longer
    found): what to fix, and what to remove from the list."""
    found = found if isinstance(found, dict) else dict.fromkeys(found, "")
    return {k: v for k, v in found.items() if k not in exceptions}, sorted(set(exceptions) - set(found))


def test_no_module_over_800_lines_nor_class_over_600():
    bad, stale = beyond_exceptions(oversized(WBC), SIZE_EXCEPTIONS)
    assert bad == {}, "split these (one concept per module):\n" + "\n".join(f"{p}: {v}" for p, v in bad.items())
    assert stale == [], f"these are within the limits now: remove them from SIZE_EXCEPTIONS: {stale}"


def test_no_name_defined_in_two_modules():
    bad, stale = beyond_exceptions(defined_twice(WBC), SHARED_NAMES)
    assert bad == {}, "keep one definition and import it:\n" + "\n".join(f"{n}: {p}" for n, p in bad.items())
    assert stale == [], f"these are defined once now: remove them from SHARED_NAMES: {stale}"


def test_every_module_of_the_core_packages_has_its_test_file():
    bad, stale = beyond_exceptions(untested_modules(WBC, REPO / "tests"), UNMIRRORED)
    assert bad == {}, f"{len(bad)} modules without tests/<package>/test_<module>.py: {sorted(bad)}"
    assert stale == [], f"these have their test file now: remove them from UNMIRRORED: {stale}"


def test_the_checkers_flag_a_planted_violation_of_each_rule(tmp_path):
    root, tests = tmp_path / "wbc", tmp_path / "tests"
    (root / "tasks").mkdir(parents=True)
    (tests / "tasks").mkdir(parents=True)
    (root / "tasks" / "frame.py").write_text("class Big:\n" + "    x = 1\n" * 7 + "\n\ndef helper():\n    pass\n")
    (root / "tasks" / "com.py").write_text("from wbc.tasks.frame import helper\n\n\ndef _local():\n    pass\n")
    (root / "geometry.py").write_text("def _local():\n    pass\n")
    (tests / "tasks" / "test_frame.py").write_text("")
    assert oversized(root) == {} and defined_twice(root) == {} and untested_modules(root, tests, ("tasks",)) == \
        ["tasks/com"]
    assert oversized(root, module_lines=10, class_lines=5) == {
        "tasks/frame.py": ["12 lines > 10", "class Big: 8 lines > 5"]}
    (root / "geometry.py").write_text("def helper():\n    pass\n")
    assert defined_twice(root) == {"helper": ["geometry.py", "tasks/frame.py"]}
    (tests / "tasks" / "test_tasks_com.py").write_text("")
    assert untested_modules(root, tests, ("tasks",)) == []
