"""Count the tests of ``tests/`` by the independent reference they check against (grep over each test's source).

    python benchmarks/count_test_references.py [TESTS_DIR] [--list]

A test function's source (with the bodies of the module-level helpers it calls by name, one level deep) is
matched against the patterns below; a test counts once per reference kind it uses, and once in ``any``.
This is a grep, not a proof: it finds the tests that *compute* a reference, it does not judge how well.
"""

from __future__ import annotations

import argparse
import ast
import re
import sys
from pathlib import Path

REFERENCES = {
    "finite differences": r"finite[ _-]?diff|\bfd_|_fd\b|\bnumdiff|central difference|\(\s*\w+\(\s*\w+\s*\+\s*(h|eps)",
    "Pinocchio": r"\bpin\.(?!SE3\b|Quaternion\b|log3\b|exp3\b|rpy\b)\w+\(",
    "MuJoCo": r"\bmujoco\.|\bmj_\w+\(|MjData|mj_step",
    "closed form": r"closed[ -]form|analytic|by hand|exact(ly)? (value|solution)|\bexpected\s*=|np\.(sin|cos|exp)\(",
    "independent solver": r"scipy\.optimize|linprog|\bminimize\(|solve_qp\(|quadprog|proxsuite|\bdaqp\.|placo|pink\b",
}


def tests_with_sources(path: Path) -> list[tuple[str, str]]:
    tree = ast.parse(path.read_text())
    src = path.read_text()
    helpers = {n.name: ast.get_source_segment(src, n) or "" for n in tree.body
               if isinstance(n, ast.FunctionDef) and not n.name.startswith("test")}
    out = []
    nodes = [(n, "") for n in tree.body]
    for node, prefix in nodes:
        if isinstance(node, ast.ClassDef):
            nodes.extend((c, node.name + ".") for c in node.body)
        elif isinstance(node, ast.FunctionDef) and node.name.startswith("test"):
            body = ast.get_source_segment(src, node) or ""
            called = {c.func.id for c in ast.walk(node) if isinstance(c, ast.Call) and isinstance(c.func, ast.Name)}
            body += "\n".join(helpers[h] for h in called if h in helpers)
            out.append((f"{path.name}::{prefix}{node.name}", body))
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("tests", type=Path, nargs="?", default=Path(__file__).resolve().parents[1] / "tests")
    parser.add_argument("--list", action="store_true", help="print each test with its reference kinds")
    args = parser.parse_args(argv)
    counts = {k: 0 for k in REFERENCES}
    total = with_any = 0
    for f in sorted(args.tests.glob("test_*.py")):
        for name, body in tests_with_sources(f):
            total += 1
            kinds = [k for k, pat in REFERENCES.items() if re.search(pat, body)]
            for k in kinds:
                counts[k] += 1
            with_any += bool(kinds)
            if args.list:
                print(f"{name}: {', '.join(kinds) or '-'}")
    print(f"test functions: {total}")
    for k, n in counts.items():
        print(f"  {k:20s} {n}")
    print(f"  {'any of these':20s} {with_any}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
