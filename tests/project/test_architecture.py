"""The import graph of ``wbc``, derived from the source with ``ast``: no cycle, no import from a higher layer
into a lower one, no import of another module's private names, no access to private attributes defined in another
module, no constant defined twice, and every controller class ticks by one verb, ``solve`` (no ``tick``, no
``compute``).

Every import is counted: module-level, inside functions (lazy), and ``importlib.import_module("wbc...")`` with a
string literal. The layers are data here (not imported from wbc): a module may import modules of its own layer
or of lower layers only.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2] / "wbc"

# Lowest first. A module belongs to the layer of its longest matching prefix.
LAYERS: list[tuple[str, ...]] = [
    ("wbc.exceptions", "wbc.compiled", "wbc.kernel_cache", "wbc.constants", "wbc.tick"),
    ("wbc.geometry", "wbc.lie", "wbc.profiles", "wbc.terrain", "wbc.solvers"),
    ("wbc.robot", "wbc.robot_checks", "wbc.robot_file", "wbc.robot_inspect", "wbc.configuration", "wbc.state"),
    ("wbc.tasks", "wbc.constraints", "wbc.estimation"),
    ("wbc.formulations", "wbc.controllers", "wbc.dynamics", "wbc.solve"),
    ("wbc.gait", "wbc.analysis"),
    ("wbc.scenarios", "wbc.sim"),
    ("wbc.viz", "wbc.ros2", "wbc.bench", "wbc.campaign"),
    ("wbc.cli", "wbc.__main__"),
]
# The package root re-exports the public API; it sits with the layer of its highest export.
PACKAGE_INIT_LAYER = 4


def layer_of(module: str) -> int:
    if module == "wbc":
        return PACKAGE_INIT_LAYER
    best, best_len = None, -1
    for i, prefixes in enumerate(LAYERS):
        for p in prefixes:
            if (module == p or module.startswith(p + ".")) and len(p) > best_len:
                best, best_len = i, len(p)
    if best is None:
        raise AssertionError(f"module {module} is in no layer of tests/project/test_architecture.py: add it to LAYERS")
    return best


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def all_modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted(ROOT.rglob("*.py"))}


def _resolve(current: str, is_pkg: bool, level: int, target: str | None) -> str:
    if level == 0:
        return target or ""
    base = current.split(".") if is_pkg else current.split(".")[:-1]
    base = base[: len(base) - (level - 1)]
    return ".".join(base + ([target] if target else []))


def imports_of(name: str, path: Path, modules: dict[str, Path]) -> list[tuple[str, int, list[str]]]:
    """(imported wbc module, line, names imported from it) for every import in the file, lazy ones included."""
    tree = ast.parse(path.read_text(), filename=str(path))
    is_pkg = path.name == "__init__.py"
    out: list[tuple[str, int, list[str]]] = []
    dynamic = False
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "wbc":
                    out.append((alias.name, node.lineno, []))
        elif isinstance(node, ast.ImportFrom):
            target = _resolve(name, is_pkg, node.level, node.module)
            if target.split(".")[0] != "wbc":
                continue
            plain = []
            for alias in node.names:  # `from wbc.x import y` where y is a submodule imports wbc.x.y
                sub = f"{target}.{alias.name}"
                if sub in modules:
                    out.append((sub, node.lineno, []))
                else:
                    plain.append(alias.name)
            out.append((target, node.lineno, plain))
        elif isinstance(node, ast.Call):
            f = node.func
            fname = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
            if fname in ("import_module", "__import__") and node.args:
                arg = node.args[0]
                if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                    if arg.value.split(".")[0] == "wbc":
                        out.append((arg.value, node.lineno, []))
                else:
                    dynamic = True
    if dynamic:  # a computed module name: every string in the file naming a wbc module counts as imported
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value in modules:
                out.append((node.value, node.lineno, []))
    return out


def graph() -> dict[str, dict[str, list[tuple[int, list[str]]]]]:
    modules = all_modules()
    edges: dict[str, dict[str, list[tuple[int, list[str]]]]] = {}
    for name, path in modules.items():
        edges[name] = {}
        for target, line, names in imports_of(name, path, modules):
            if target not in modules:
                raise AssertionError(f"{name}:{line} imports {target}, which is not a module of wbc")
            if target != name:
                edges[name].setdefault(target, []).append((line, names))
    return edges


def _package_chain(module: str) -> list[str]:
    """Packages whose __init__ runs when ``module`` is imported (wbc.a.b -> wbc, wbc.a)."""
    parts = module.split(".")
    return [".".join(parts[:i]) for i in range(1, len(parts))]


def test_every_module_is_in_a_layer():
    for name in all_modules():
        layer_of(name)


def test_no_import_from_a_higher_layer():
    bad = []
    for src, targets in graph().items():
        for dst, sites in targets.items():
            if layer_of(dst) > layer_of(src) and not src.startswith(dst + ".") and dst != "wbc":
                bad.append(f"{src} (layer {layer_of(src)}) imports {dst} (layer {layer_of(dst)}) at line "
                           f"{sites[0][0]}")
    assert not bad, "imports against the layering:\n" + "\n".join(bad)


def test_no_import_cycle():
    edges = {src: set(dsts) for src, dsts in graph().items()}
    # Importing wbc.a.b runs the __init__ of wbc and wbc.a first: a package __init__ importing its own
    # submodules is not a cycle, but a submodule importing a sibling package does go through its __init__.
    for src in list(edges):
        edges[src] = {d for d in edges[src] if not src.startswith(d + ".") and d != "wbc"}
    state: dict[str, int] = {}
    stack: list[str] = []
    cycles: list[list[str]] = []

    def visit(n: str) -> None:
        state[n] = 1
        stack.append(n)
        for m in sorted(edges.get(n, ())):
            if state.get(m, 0) == 0:
                visit(m)
            elif state[m] == 1:
                cycles.append(stack[stack.index(m):] + [m])
        stack.pop()
        state[n] = 2

    for n in sorted(edges):
        if state.get(n, 0) == 0:
            visit(n)
    assert not cycles, "import cycles:\n" + "\n".join(" -> ".join(c) for c in cycles)


def test_no_private_name_imported_across_modules():
    bad = []
    for src, targets in graph().items():
        for dst, sites in targets.items():
            for line, names in sites:
                for n in names:
                    if n.startswith("_") and not n.startswith("__"):
                        bad.append(f"{src}:{line} imports {n} from {dst}")
    assert not bad, "private names imported across modules:\n" + "\n".join(bad)


def module_constants(path: Path) -> dict[str, int]:
    """{NAME: line} of the module-level UPPER_CASE names a file assigns (its constants; private ones included)."""
    out = {}
    for node in ast.parse(path.read_text(), filename=str(path)).body:
        targets = node.targets if isinstance(node, ast.Assign) else [node.target] if isinstance(node, ast.AnnAssign) \
            else []
        for t in targets:
            if isinstance(t, ast.Name) and t.id.lstrip("_").isupper() and t.id != "__all__":
                out[t.id.lstrip("_")] = node.lineno
    return out


def test_constants_are_defined_once():
    """A constant name is assigned in one module only (the others import it), and gravity's 9.81 is typed once,
    in wbc.constants (models carry their own: Robot.gravity)."""
    where: dict[str, list[str]] = {}
    for name, path in all_modules().items():
        for const, line in module_constants(path).items():
            where.setdefault(const, []).append(f"{name}:{line}")
    twice = {c: sites for c, sites in where.items() if len(sites) > 1}
    assert not twice, "constants defined in more than one module:\n" + "\n".join(
        f"{c}: {', '.join(s)}" for c, s in sorted(twice.items()))
    typed = [f"{name}:{node.lineno}" for name, path in all_modules().items() if name != "wbc.constants"
             for node in ast.walk(ast.parse(path.read_text())) if isinstance(node, ast.Constant)
             and isinstance(node.value, float) and node.value == 9.81]
    assert not typed, "gravity typed outside wbc.constants: " + ", ".join(typed)


def test_the_constant_checker_sees_private_and_annotated_constants(tmp_path):
    src = tmp_path / "m.py"
    src.write_text("A = 1\n_B: float = 2.0\nc = 3\n__all__ = []\nclass K:\n    D = 4\n")
    assert module_constants(src) == {"A": 1, "B": 2}


def test_the_checker_sees_lazy_and_string_imports(tmp_path):
    """The extraction itself: a lazy import inside a function and an importlib string are both found."""
    src = tmp_path / "m.py"
    src.write_text("import importlib\n\ndef f():\n    from wbc.robot import _x\n"
                   "    return importlib.import_module('wbc.sim.cli')\n")
    found = imports_of("wbc.fake", src, {"wbc.robot": src, "wbc.sim.cli": src})
    assert ("wbc.robot", 4, ["_x"]) in found
    assert ("wbc.sim.cli", 5, []) in found
    src.write_text("import importlib\n\ndef f():\n    for m in ('wbc.sim.cli', 'x'):\n"
                   "        importlib.import_module(m)\n")
    assert ("wbc.sim.cli", 4, []) in imports_of("wbc.fake", src, {"wbc.sim.cli": src})


# Underscore names that the standard library documents as public API (https://docs.python.org/3/library/os.html#os._exit).
DOCUMENTED_UNDERSCORE_NAMES = {"os._exit"}
_ATTRIBUTE_FUNCTIONS = ("getattr", "setattr", "hasattr", "delattr")


def _is_private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def private_attributes_defined(tree: ast.AST) -> set[str]:
    """The private attribute names a module defines: ``self._x = ...`` / ``cls._x = ...`` (also augmented, annotated
    or deleted), ``def _x`` / ``class _X`` at any depth, class-level assignments and ``__slots__`` strings."""
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            out.add(node.name)
        if isinstance(node, ast.ClassDef):
            for st in node.body:
                targets = st.targets if isinstance(st, ast.Assign) else \
                    [st.target] if isinstance(st, (ast.AnnAssign, ast.AugAssign)) else []
                for t in targets:
                    if isinstance(t, ast.Name):
                        out.add(t.id)
                        if t.id == "__slots__":
                            out.update(c.value for c in ast.walk(st.value)
                                       if isinstance(c, ast.Constant) and isinstance(c.value, str))
        if isinstance(node, ast.Attribute) and isinstance(node.ctx, (ast.Store, ast.Del)) and \
                isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"):
            out.add(node.attr)
    return {n for n in out if _is_private(n)}


def private_attribute_accesses(path: Path, elsewhere: set[str] = frozenset()) -> list[tuple[int, str]]:
    """(line, source) of each access in the file to a private attribute (``_x``, not a dunder) on an object other
    than ``self``, ``cls`` or ``super()``: ``X._x`` read, written or deleted, and ``getattr/setattr/hasattr/delattr(X,
    "_x")`` with a literal name. ``elsewhere``: the private names the other modules define
    (:func:`private_attributes_defined`).

    Such an access passes only when both hold:

    - it sits inside a class whose own body defines ``_x`` (:func:`private_attributes_defined` of the innermost
      enclosing class): a class's private members on another instance of it, as in ``__eq__(self, other)``; not a
      module-level function, nor another class of the same module (a helper gets what it needs from its owner);
    - no other module defines an attribute named ``_x`` (``elsewhere``): X could be that module's object, so a name
      two modules define is touched through ``self``/``cls`` only;

    and X is not a name bound by an import (a module, another module's class or function). A module may touch
    the private attributes of the objects it defines, never those defined elsewhere (another wbc module, a
    third-party library)."""
    tree = ast.parse(path.read_text(), filename=str(path))
    # Names bound by an import (a module, or a class or function of another module): their private attributes are
    # never the file's own, even when the file defines an attribute of the same name.
    imported = {a.asname or a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.Import)
                for a in n.names} | {a.asname or a.name for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)
                                     for a in n.names}
    out = []

    def visit(node: ast.AST, own: set[str]) -> None:
        if isinstance(node, ast.Attribute):
            name, obj = node.attr, node.value
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and \
                node.func.id in _ATTRIBUTE_FUNCTIONS and len(node.args) >= 2 and \
                isinstance(node.args[1], ast.Constant) and isinstance(node.args[1].value, str):
            name, obj = node.args[1].value, node.args[0]
        else:
            name = obj = None
        if name is not None and _is_private(name) and not (
                isinstance(obj, ast.Name) and obj.id in ("self", "cls")
                or isinstance(obj, ast.Call) and isinstance(obj.func, ast.Name) and obj.func.id == "super"
                or isinstance(node, ast.Attribute) and ast.unparse(node) in DOCUMENTED_UNDERSCORE_NAMES
                or name in own and name not in elsewhere and not (isinstance(obj, ast.Name) and obj.id in imported)):
            out.append((node.lineno, ast.unparse(node)))
        for child in ast.iter_child_nodes(node):
            visit(child, private_attributes_defined(child) if isinstance(child, ast.ClassDef) else own)

    visit(tree, set())
    return sorted(out)


def private_attribute_violations(modules: dict[str, Path]) -> list[str]:
    """``module:line source`` of each access :func:`private_attribute_accesses` flags, every module checked against
    the private names the others define."""
    defined = {name: private_attributes_defined(ast.parse(path.read_text(), filename=str(path)))
               for name, path in modules.items()}
    return [f"{name}:{line} {src}" for name, path in modules.items()
            for line, src in private_attribute_accesses(
                path, set().union(*(d for other, d in defined.items() if other != name)))]


def test_no_private_attribute_accessed_across_modules():
    bad = private_attribute_violations(all_modules())
    assert not bad, f"{len(bad)} accesses to private attributes defined in another module (give the owner a " \
                    f"public surface):\n" + "\n".join(bad)


def test_the_private_attribute_checker_flags_other_modules_attributes_only(tmp_path):
    """A mini-package: ``a`` defines ``A._x``, ``A._m``, ``A._k`` and compares ``_x`` across instances in ``A``
    (passes); its module-level function touching them on an ``obj`` is flagged (not inside the class); ``b``
    reads, writes and getattr's them on an ``A``, writes its own ``_y`` on a ``B`` outside the class (flagged), and
    uses ``self``'s, ``super()``'s and ``os._exit``; ``A._y`` on the imported class is ``a``'s even though ``b``
    defines a ``_y`` too."""
    a = tmp_path / "a.py"
    a.write_text("class A:\n    _k = 1\n    def __init__(self):\n        self._x = 0\n"
                 "    def _m(self):\n        return self._x\n"
                 "    def __eq__(self, other):\n        return self._x == other._x and other._m() == self._k\n\n"
                 "def peek(obj):\n    return obj._x + obj._m() + obj._k\n")
    b = tmp_path / "b.py"
    b.write_text("import os\nfrom a import A\n\n"
                 "class B(A):\n    def __init__(self):\n        super().__init__()\n        self._y = self._x\n"
                 "    def _n(self):\n        return super()._m() + self.__class__.__name__.__len__()\n\n"
                 "def poke(obj: A, other: B):\n    obj._x = 2\n    del obj._k\n"
                 "    f = getattr(obj, '_m')\n    other._y = 1\n    os._exit(0) if f() else None\n"
                 "    return obj.__dict__, hasattr(obj, 'x'), A._y\n")
    assert private_attribute_violations({"a": a, "b": b}) == [
        "a:11 obj._k", "a:11 obj._m", "a:11 obj._x",
        "b:12 obj._x", "b:13 obj._k", "b:14 getattr(obj, '_m')", "b:15 other._y", "b:17 A._y"]


def test_the_private_attribute_checker_flags_a_name_two_modules_define(tmp_path):
    """Two modules each keep a ``self._state``: ``Sim`` reading ``plant._state`` of a ``Plant`` (another module's
    object) is flagged although ``Sim`` defines a ``_state`` of its own; ``Pose.__eq__`` comparing ``other._x``,
    a name only its module defines, passes."""
    plant = tmp_path / "plant.py"
    plant.write_text("class Plant:\n    def __init__(self):\n        self._state = 0.0\n")
    sim = tmp_path / "sim.py"
    sim.write_text("class Sim:\n    def __init__(self, plant):\n        self._state = plant._state\n"
                   "        self.plant = plant\n    def step(self):\n        self._state = self.plant._state\n\n"
                   "class Pose:\n    def __init__(self, x):\n        self._x = x\n"
                   "    def __eq__(self, other):\n        return self._x == other._x\n")
    assert private_attribute_violations({"plant": plant, "sim": sim}) == [
        "sim:3 plant._state", "sim:6 self.plant._state"]


@pytest.mark.parametrize("module", ["wbc.gait.walk", "wbc.cli"])
def test_layers_are_ordered_as_documented(module):
    assert layer_of("wbc.exceptions") < layer_of("wbc.geometry") < layer_of("wbc.robot") < layer_of(
        "wbc.tasks.base") < layer_of("wbc.formulations.velocity") < layer_of("wbc.gait") <= layer_of(module)



# Lab notes in docstrings: a measurement record (a CPU time, a dated run, "measured on <robot>", a number followed
# by "measured", an issue number) belongs in benchmarks/README.md or docs/, never in a docstring, which says what the
# code does (shapes, units, frames, errors, sources). Domain uses of the word stay: "the measured state", "measured
# CoP", "the drift measured at q⁺". Written here, not imported from wbc.
LAB_NOTE_PATTERNS = [
    r"\d\s*(?:µs|us)\b",  # a time in microseconds: always a measured CPU time in this library
    r"[~≈]\s*\d[\d.]*\s*ms\b",  # an approximate time in milliseconds ("≈ 4 ms for a message")
    r"\b(?:median|p50|p99|mean)\b[^.;]{0,40}\d\s*ms\b",  # a timing statistic
    r"\b(?:19|20)\d\d-\d\d-\d\d\b",  # a date
    r"\b\d\d:\d\d\s*UTC\b",  # a time of day
    r"(?<!not )\bmeasured\s*(?::|;|\)|here\b|side by side|too\b|on (?:talos|g1|humanoid15|romeo|h1|this)\b|at \d"
    r"|for \d|\d)",  # "measured on G1 ...", "Measured: ...", "measured 2.09 s"
    r"\(measured(?:\)|:|;|, [A-Z]| on\b| here\b| at \d)",  # "(measured)", "(measured: ...", "(measured, Talos ..."
    r"\d(?:\.\d+)?(?:e-?\d+)?\s*(?:[a-zµ/%°]+\s+)?measured\b",  # "up to 2.2 mm measured"
    r"\bissues? \d+",  # an issue number
    r"\bseeds? \d",  # the seeds of a trial run ("fell on seeds 3 and 38")
    # a time in milliseconds other than the 2 ms control period and a stated period ("every 10 ms", "dt = 4 ms")
    r"(?<!every )(?<!multiple of )(?<!knots of )(?<!dt = )\b(?!2\s*ms\b)\d+(?:\.\d+)?\s*ms\b",
    r"\bmeasured\b.*\b(?:talos|g1|humanoid15|romeo|h1)\b|\b(?:talos|g1|humanoid15|romeo|h1)\b.*\bmeasured\b",
    r"\bmeasured\b[\w\s()-]{0,30}?\d[\d.]*\s*(?:mm|cm|m|s|N|deg|°)(?!\w)",  # "measured CoP margin 5.0 mm"
]


def docstring_lab_notes(path: Path) -> list[tuple[int, str]]:
    """(line, text) of each documentation line of the file matching a lab-note pattern: docstrings (module, class,
    function, attribute: every string literal standing as a statement) and ``#:`` attribute comments."""
    import re

    pats = [re.compile(p, re.IGNORECASE) for p in LAB_NOTE_PATTERNS]
    text = path.read_text()
    out = []
    for node in ast.walk(ast.parse(text, filename=str(path))):
        if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant) and isinstance(node.value.value, str):
            for i, line in enumerate(node.value.value.splitlines()):
                if any(p.search(line) for p in pats):
                    out.append((node.value.lineno + i, line.strip()))
    for i, line in enumerate(text.splitlines(), 1):
        comment = line[line.index("#:"):] if "#:" in line else ""  # a ``#:`` attribute comment, own line or inline
        if comment and any(p.search(comment) for p in pats):
            out.append((i, comment))
    return sorted(out)


def test_no_lab_notes_in_docstrings():
    bad = [f"{name}:{line} {text}" for name, path in all_modules().items()
           for line, text in docstring_lab_notes(path)]
    assert not bad, f"{len(bad)} docstring lines carry lab notes (move them to benchmarks/README.md or docs/):\n" + \
        "\n".join(bad)


def test_the_lab_note_checker_tells_notes_from_domain_words(tmp_path):
    src = tmp_path / "m.py"
    src.write_text('"""Tick.\n\nThe compiled tick takes 41.2 µs median.\nMeasured on Talos, 2026-11-22: 3 mm.\n'
                   'The held command (measured: 12 ticks) and ≈ 4 ms per message.\n"""\n\n'
                   'def f(q):\n    """Torques for the measured state (q (nq,), measured CoP in m), dt = 2 ms.\n\n'
                   '    Up to 2.2 mm measured (issue 10).\n    """\n\n'
                   '#: a gain (1/s), 159 vs 191 µs median\nK = 1.0\n"""The period, 2 ms (2026-11-22)."""\n'
                   '# an ordinary comment: 5 µs\n'
                   'def g():\n    """Fell on seeds 3 and 38. A tick every 10 ms, dt = 4 ms, 40 ms before touch-down.\n\n'
                   '    Talos: the measured CoP. The measured CoP margin 5.0 mm.\n'
                   '    The measured force reaches 3 % of the weight, every 2 ms.\n    """\n'
                   'L = 0.3  #: fraction of a swing (seed 7 fell with 0.2)\n')
    assert [line for line, _ in docstring_lab_notes(src)] == [3, 4, 5, 11, 14, 16, 19, 21, 24]


# Numeric constants repeated under related names: two modules assigning the same number to names that share a word
# (after these synonyms) are one constant typed twice; a generic word alone (TOL, WEIGHT, MAX...) relates nothing.
# Written here, not imported from wbc.
CONSTANT_NAME_SYNONYMS = {"TOLERANCE": "TOL", "TIMESTEP": "DT", "PERIOD": "DT"}
CONSTANT_NAME_GENERIC = {"TOL", "WEIGHT", "MAX", "MIN", "DEG", "M", "S", "N", "RATIO", "FRACTION", "BIT"}
# Same value, related names, different meanings: (module.NAME, module.NAME) -> why they are two constants.
DISTINCT_CONSTANTS = {
    ("wbc.gait.blind.BLIND_LIFT", "wbc.gait.terrain_walk.LIFT"):
        "two swing profiles tuned apart: the terrain swing's symmetric rise and set-down fraction vs the blind "
        "swing's rise, whose set-down starts at BLIND_SET_DOWN",
    ("wbc.robot_checks.LIMIT_TOLERANCE", "wbc.robot_file.LIMIT_INVERSION_TOLERANCE"):
        "two checks: a reference posture's excess over its joint limits vs a limit pair's inversion taken as "
        "round-off",
}


def numeric_constants(path: Path) -> list[tuple[str, float, int]]:
    """(NAME, value, line) of the module-level UPPER_CASE names a file assigns a number literal to (bool excluded;
    ``A = B`` naming another constant is a reference, not a second definition)."""
    out = []
    for node in ast.parse(path.read_text(), filename=str(path)).body:
        targets = node.targets if isinstance(node, ast.Assign) else \
            [node.target] if isinstance(node, ast.AnnAssign) and node.value is not None else []
        for t in targets:
            if isinstance(t, ast.Name) and t.id.lstrip("_").isupper():
                try:
                    v = ast.literal_eval(node.value)
                except ValueError:
                    continue
                if isinstance(v, (int, float)) and not isinstance(v, bool):
                    out.append((t.id, v, node.lineno))
    return out


def _name_words(name: str) -> set[str]:
    words = {CONSTANT_NAME_SYNONYMS.get(w, w) for w in name.lstrip("_").split("_") if w}
    return words - CONSTANT_NAME_GENERIC


def repeated_constants(modules: dict[str, Path]) -> list[str]:
    found = [(name, const, value, line) for name, path in modules.items()
             for const, value, line in numeric_constants(path)]
    out = []
    for i, (ma, a, va, la) in enumerate(found):
        for mb, b, vb, lb in found[i + 1:]:
            pair = tuple(sorted((f"{ma}.{a}", f"{mb}.{b}")))
            if ma != mb and va == vb and _name_words(a) & _name_words(b) and pair not in DISTINCT_CONSTANTS:
                out.append(f"{ma}:{la} {a} = {mb}:{lb} {b} = {va!r}")
    return out


def test_no_numeric_constant_typed_twice():
    """The same number under related names in two modules is one constant: define it once, import it."""
    bad = repeated_constants(all_modules())
    assert not bad, f"{len(bad)} numeric constants typed in two modules:\n" + "\n".join(bad)


def test_the_distinct_constants_allow_list_names_existing_pairs():
    """Each allow-listed pair still exists with equal values (a stale entry would hide nothing and mislead)."""
    values = {f"{name}.{c}": v for name, path in all_modules().items() for c, v, _ in numeric_constants(path)}
    for a, b in DISTINCT_CONSTANTS:
        assert a in values and b in values and values[a] == values[b], (a, b)


def test_the_repeated_constant_checker(tmp_path):
    (tmp_path / "a.py").write_text("SIM_DT = 0.002\nMAX_TILT_DEG = 30.0\nPUSH_TOL = 0.01\nREF = SIM_DT\n")
    (tmp_path / "b.py").write_text("MAX_TIMESTEP = 0.002\nFALL_TILT_DEG = 30.0\nFLAT_TOL = 0.01\n"
                                   "_TILT_DEG = 31.0\nREF = 0.002\n")
    bad = repeated_constants({"a": tmp_path / "a.py", "b": tmp_path / "b.py"})
    assert bad == ["a:1 SIM_DT = b:1 MAX_TIMESTEP = 0.002", "a:2 MAX_TILT_DEG = b:2 FALL_TILT_DEG = 30.0"]


def gravity_beside_a_robot(path: Path) -> list[tuple[int, str]]:
    """(line, function) of each use of ``GRAVITY`` (the constant for places with no model) where a robot is at
    hand, whose model carries gravity (``robot.gravity``): in a function with a ``robot`` argument or variable, or
    in a class that keeps ``self.robot``."""
    tree = ast.parse(path.read_text(), filename=str(path))
    out: dict[int, str] = {}  # line -> innermost function or class (ast.walk visits outer scopes first)

    def uses(node):
        return [n.lineno for n in ast.walk(node) if isinstance(n, ast.Name) and n.id == "GRAVITY"]

    for node in ast.walk(tree):
        if isinstance(node, ast.ClassDef):
            keeps = any(isinstance(n, ast.Attribute) and n.attr == "robot" and isinstance(n.value, ast.Name)
                        and n.value.id == "self" and isinstance(n.ctx, ast.Store) for n in ast.walk(node))
            if keeps:
                out.update((line, node.name) for line in uses(node))
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            has = any(isinstance(n, ast.Name) and n.id == "robot" for n in ast.walk(node)) or \
                any(a.arg == "robot" for a in node.args.args + node.args.kwonlyargs)
            if has:
                out.update((line, node.name) for line in uses(node))
    return sorted(out.items())


def test_gravity_comes_from_the_model_where_a_robot_is_at_hand():
    bad = [f"{name}:{line} in {where}" for name, path in all_modules().items()
           for line, where in gravity_beside_a_robot(path)]
    assert not bad, f"{len(bad)} uses of wbc.constants.GRAVITY beside a robot (use robot.gravity):\n" + \
        "\n".join(bad)


def test_the_gravity_checker(tmp_path):
    src = tmp_path / "m.py"
    src.write_text("from wbc.constants import GRAVITY\n\ndef omega(z, g=GRAVITY):\n    return (g / z) ** 0.5\n\n"
                   "def bound(robot, g=GRAVITY):\n    return g\n\nclass S:\n    def __init__(self, sim):\n"
                   "        self.robot = sim.robot\n    def f(self):\n        return GRAVITY\n")
    assert gravity_beside_a_robot(src) == [(6, "bound"), (13, "S")]


def module_aliases(path: Path) -> list[tuple[int, str]]:
    """(line, source) of each alias: at module level ``a = b`` or ``A = B.c`` where ``b``/``B`` is a function or
    class the module defines, in a class body ``a = b`` where ``b`` is a method of that class (a second name for one
    thing; give the thing its public name instead)."""
    tree = ast.parse(path.read_text(), filename=str(path))
    scopes = [tree] + [n for n in ast.walk(tree) if isinstance(n, ast.ClassDef)]
    out = []
    for scope in scopes:
        defined = {n.name for n in scope.body if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))}
        for node in scope.body:
            if isinstance(node, ast.Assign) and all(isinstance(t, ast.Name) for t in node.targets):
                root = node.value
                while isinstance(root, ast.Attribute) and scope is tree:
                    root = root.value
                if isinstance(root, ast.Name) and root.id in defined:
                    out.append((node.lineno, ast.unparse(node)))
    return sorted(out)


def test_no_alias_names():
    bad = [f"{name}:{line} {src}" for name, path in all_modules().items() for line, src in module_aliases(path)]
    assert not bad, f"{len(bad)} module-level aliases:\n" + "\n".join(bad)


def test_the_alias_checker(tmp_path):
    src = tmp_path / "m.py"
    src.write_text("import os\n\ndef _f():\n    pass\n\nclass K:\n    x = 1\n    def solve(self):\n        pass\n"
                   "    compute = solve\n    y = x\n\nf = _f\nX = K.x\nSEP = os.sep\nk = K()\n")
    assert module_aliases(src) == [(10, "compute = solve"), (13, "f = _f"), (14, "X = K.x")]


# -- one verb for a controller's tick ------------------------------------------------------------------------------
CONTROLLERS = ("KinematicController", "InverseDynamicsController", "IDBalanceController", "StanceController",
               "WalkController", "BalanceController", "JointPDController", "PerturbedController")
CONTROLLER_VERB = "solve"
RETIRED_VERBS = {"tick", "compute"}


def controller_methods(root: Path) -> dict[str, set[str]]:
    """Every class under ``root`` whose name ends in ``Controller`` → the names its body defines (functions and
    assignments) together with those of its bases among the classes under ``root`` (resolved by class name)."""
    classes: dict[str, tuple[list[str], set[str]]] = {}
    for path in sorted(root.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if not isinstance(node, ast.ClassDef):
                continue
            bases = [b.id if isinstance(b, ast.Name) else b.attr for b in node.bases
                     if isinstance(b, (ast.Name, ast.Attribute))]
            names = {n.name for n in node.body if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))}
            names |= {t.id for n in node.body if isinstance(n, (ast.Assign, ast.AnnAssign))
                      for t in (n.targets if isinstance(n, ast.Assign) else [n.target]) if isinstance(t, ast.Name)}
            classes[node.name] = (bases, names)

    def methods(name: str, seen: frozenset = frozenset()) -> set[str]:
        bases, names = classes.get(name, ([], set()))
        return set(names).union(*(methods(b, seen | {name}) for b in bases if b not in seen))

    return {name: methods(name) for name in classes if name.endswith("Controller")}


def verb_violations(found: dict[str, set[str]]) -> list[str]:
    """Controllers without ``solve`` or with a retired verb (``tick``, ``compute``)."""
    bad = []
    for name, methods in sorted(found.items()):
        if CONTROLLER_VERB not in methods:
            bad.append(f"{name}: no {CONTROLLER_VERB}")
        bad += [f"{name}: {verb}" for verb in sorted(methods & RETIRED_VERBS)]
    return bad


def test_every_controller_ticks_by_solve_only():
    found = controller_methods(ROOT)
    assert set(CONTROLLERS) <= set(found), sorted(set(CONTROLLERS) - set(found))
    assert verb_violations(found) == []


def test_the_controller_verb_checker(tmp_path):
    (tmp_path / "a.py").write_text("class BaseController:\n    def solve(self, q, v):\n        pass\n\n"
                                   "class Mixin:\n    compute = None\n")
    (tmp_path / "b.py").write_text("from a import BaseController, Mixin\n\n"
                                   "class ChildController(BaseController):\n    pass\n\n"
                                   "class MixedController(BaseController, Mixin):\n    pass\n\n"
                                   "class OldController:\n    def tick(self, q, v):\n        pass\n")
    found = controller_methods(tmp_path)
    assert set(found) == {"BaseController", "ChildController", "MixedController", "OldController"}
    assert verb_violations(found) == ["MixedController: compute", "OldController: no solve", "OldController: tick"]
