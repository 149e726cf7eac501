"""Size rules read from the source with ``ast``. The controllers and the velocity formulation: no module over 800
lines, no class over 600 lines, no function or method with more than 10 positional parameters (``self`` not
counted). Every module of ``wbc/``: no function or method with more than 10 positional parameters (compiled kernels
included: they take namedtuple workspaces), but for the functions of :data:`OVER_TEN`, not yet rewritten. The QP core
(formulations + solvers + controllers) at most :data:`CORE_LINES` lines."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2] / "wbc"
FILES = sorted((ROOT / "controllers").glob("*.py")) + [ROOT / "formulations" / "velocity.py"]

#: the functions of wbc/ still over 10 positional parameters (qualified name: its count), each a compiled kernel or a
#: helper whose arguments are yet to be grouped into a namedtuple workspace (named without their module, so that a
#: function moved to another module keeps its entry); the list may only shrink. Empty since the s65 branches: every
#: function of wbc/ takes at most 10.
OVER_TEN = {
}

#: the QP core's packages (issue 59: formulations + solvers + controllers)
CORE = ("formulations", "solvers", "controllers")
#: issue 59's goal for the QP core is 7,000 lines (as ``wc -l`` counts them), met at 6,996: this ceiling is the count
#: after its last cut (9,941 at 67ee7a6; 8,933 after the s66 branches, 8,954 with the tick budget's estimate of a first
#: re-solve the same day; 7,909 at 9401dee; 7,839 at 5142ab4; 7,609 without the dead clip_box_into; 7,573 after the s94
#: cuts: the kinematic kernels' QP a QPData, unread seconds returns and dead parameters gone, the layout checks inside
#: the layout updates, solver docstrings that repeated another in their module referring to it; 7,031 with the ID
#: kernel on the dense active set alone, record 86: the block strategy and the equality step gone; 6,996 with both
#: ticks calling solve_qp_into with their ActiveSetSettings, record 87: id_solve and its buffers gone, and four
#: forwarders or repeated lines folded) and goes down with each cut
CORE_LINES = 6996


def positional(node: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """Positional parameters of a function (``self``/``cls`` not counted)."""
    args = [*node.args.posonlyargs, *node.args.args]
    return len(args) - (1 if args and args[0].arg in ("self", "cls") else 0)


def long_signatures(root: Path, limit: int = 10) -> dict[str, list[str]]:
    """{qualified name (``f``, ``Class.method``): ["module.py:line n", …]} of every function under ``root`` with more
    than ``limit`` positional parameters."""
    found: dict[str, list[str]] = {}

    def visit(node: ast.AST, prefix: str, path: Path) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.ClassDef):
                visit(child, f"{prefix}{child.name}.", path)
            elif isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                if positional(child) > limit:
                    found.setdefault(prefix + child.name, []).append(
                        f"{path.relative_to(root)}:{child.lineno} {positional(child)}")
                visit(child, f"{prefix}{child.name}.", path)

    for path in sorted(root.rglob("*.py")):
        visit(ast.parse(path.read_text()), "", path)
    return found


def oversized(path: Path, module_lines: int = 800, class_lines: int = 600, max_positional: int = 10) -> list[str]:
    text = path.read_text()
    bad = []
    if text.count("\n") > module_lines:
        bad.append(f"{path.name}: {text.count(chr(10))} lines > {module_lines}")
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.ClassDef) and node.end_lineno - node.lineno + 1 > class_lines:
            bad.append(f"class {node.name}: {node.end_lineno - node.lineno + 1} lines > {class_lines}")
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and positional(node) > max_positional:
            bad.append(f"{node.name}: {positional(node)} positional parameters > {max_positional}")
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
    assert oversized(src, max_positional=2) == ["f: 3 positional parameters > 2"]
    (tmp_path / "k.py").write_text("def g(a, b, c, *, d, e):\n    pass\n")
    assert long_signatures(tmp_path, limit=2) == {"A.f": ["m.py:7 3"], "g": ["k.py:1 3"]}
    assert long_signatures(tmp_path, limit=3) == {}


def test_no_function_of_wbc_takes_more_than_ten_positional_parameters():
    """Every function of wbc/ over 10 positional parameters is one of OVER_TEN, with at most its listed count; and
    each of OVER_TEN is still over 10 (a function brought to 10 or fewer leaves the list)."""
    found = long_signatures(ROOT)
    new = {name: where for name, where in found.items() if name not in OVER_TEN
           or any(int(w.rsplit(" ", 1)[1]) > OVER_TEN[name] for w in where)}
    assert new == {}, f"functions over 10 positional parameters (group them into a namedtuple): {new}"
    assert sorted(set(OVER_TEN) - set(found)) == [], "no longer over 10: remove them from OVER_TEN"


def core_lines(root: Path = ROOT) -> int:
    """Lines (newline characters, as ``wc -l`` counts them) of the modules of the QP core's packages under root."""
    return sum(p.read_text().count("\n") for package in CORE for p in sorted((root / package).glob("*.py")))


def test_the_qp_core_does_not_grow(tmp_path):
    assert core_lines() <= CORE_LINES <= 7000  # 7,000: issue 59's goal
    for package in CORE:  # the count itself, on a tree of known size
        (tmp_path / package).mkdir()
        (tmp_path / package / "m.py").write_text("a = 1\nb = 2\n")
    (tmp_path / "solvers" / "notes.txt").write_text("not a module\n")
    assert core_lines(tmp_path) == 6
