"""Size rules of the controllers and the velocity formulation, read from the source with ``ast``: no module over
800 lines, no class over 600 lines, no function or method with more than 10 positional parameters (``self``
not counted). Scope: ``wbc/controllers/`` and ``wbc/formulations/velocity.py`` (the compiled kernels of
``velocity_kernel.py`` still take long positional lists: not yet in scope)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2] / "wbc"
FILES = sorted((ROOT / "controllers").glob("*.py")) + [ROOT / "formulations" / "velocity.py"]


def oversized(path: Path, module_lines: int = 800, class_lines: int = 600, positional: int = 10) -> list[str]:
    text = path.read_text()
    bad = []
    if text.count("\n") > module_lines:
        bad.append(f"{path.name}: {text.count(chr(10))} lines > {module_lines}")
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.ClassDef) and node.end_lineno - node.lineno + 1 > class_lines:
            bad.append(f"class {node.name}: {node.end_lineno - node.lineno + 1} lines > {class_lines}")
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            args = [*node.args.posonlyargs, *node.args.args]
            n = len(args) - (1 if args and args[0].arg in ("self", "cls") else 0)
            if n > positional:
                bad.append(f"{node.name}: {n} positional parameters > {positional}")
    return bad


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_sizes(path):
    assert oversized(path) == []


def test_the_checker_flags_each_rule(tmp_path):
    src = tmp_path / "m.py"
    src.write_text("class A:\n" + "    x = 1\n" * 5 + "    def f(self, a, b, c):\n        pass\n")
    assert oversized(src) == []
    assert oversized(src, module_lines=3) == ["m.py: 8 lines > 3"]
    assert oversized(src, class_lines=4) == ["class A: 8 lines > 4"]
    assert oversized(src, positional=2) == ["f: 3 positional parameters > 2"]
