"""Build of the one compiled extension, ``wbc.constraints.narrow_phase`` (C++ on coal: the self-collision
constraint's distances in one call; ``narrow_phase.cpp``, :mod:`wbc.constraints.self_collision`).

The extension is built after the install, not by it: ``wbc compile`` builds it (beside the numba kernels), or
:func:`build_narrow_phase` directly. No command a first run needs uses it (the walk, balance and sim controllers
hold no self-collision constraint), and without it the constraint computes its distances through Pinocchio's
bindings (same results, slower; ``SelfCollisionConstraint.narrow_phase``). The compiler is the system's C++
compiler (``CXX``, else ``c++``); coal's headers and library come from the ``libcoal`` wheel that ``pin`` installs
(its ``cmeel.prefix``), Eigen's headers from the ``cmeel-eigen`` wheel (a dependency of wbc), the Python headers
from this interpreter (:mod:`sysconfig`). The extension is written next to its source, atomically (a file renamed
into place), so a process that imports it meanwhile finds the old file or the new one.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

from wbc.exceptions import SimulationError

__all__ = ["BUILD_HINT", "build_narrow_phase", "build_or_explain", "compile_command", "extension_path", "find_headers"]

#: What to run to build the extension (the self-collision constraint says it when the extension is missing).
BUILD_HINT = "`wbc compile` builds it (g++ and coal's headers from the libcoal wheel, about a minute of CPU)"

#: coal's exported compile definitions (lib/cmake/coal/coalTargets.cmake of libcoal 3.0.2): the same class layouts
_DEFINES = ("COAL_BACKWARD_COMPATIBILITY_WITH_HPP_FCL", "COAL_HAS_OCTOMAP", "COAL_HAVE_OCTOMAP",
            "OCTOMAP_MAJOR_VERSION=1", "OCTOMAP_MINOR_VERSION=10", "OCTOMAP_PATCH_VERSION=0")


def extension_path() -> Path:
    """The path the built extension is written to and imported from: ``narrow_phase<EXT_SUFFIX>`` next to
    ``narrow_phase.cpp`` (e.g. ``narrow_phase.cpython-311-x86_64-linux-gnu.so``)."""
    return Path(__file__).with_name("narrow_phase" + sysconfig.get_config_var("EXT_SUFFIX"))


def find_headers(search: list[str] | None = None) -> tuple[list[str], str]:
    """The include folders (coal's, Eigen's) and the library folder holding ``libcoal.so``, found in the
    ``cmeel.prefix`` folders of the entries of ``search``.

    Args:
        search: folders to look in (default: ``sys.path``).

    Returns:
        ([coal's include folder, Eigen's include folder], the folder of ``libcoal.so``).

    Raises:
        SimulationError: coal's headers and library, or Eigen's headers, are in none of them (naming what to
            install).
    """
    prefixes = [Path(entry) / "cmeel.prefix" for entry in (sys.path if search is None else search)]
    coal = next((p for p in prefixes if (p / "include" / "coal" / "distance.h").is_file()
                 and (p / "lib" / "libcoal.so").exists()), None)
    if coal is None:
        raise SimulationError("wbc.constraints.narrow_phase cannot be built: coal's headers and libcoal.so are in no "
                              "cmeel.prefix on the Python path (install the pinned `coal` and `pin`: pip install -e .)")
    eigen = next((p / "include" / "eigen3" for p in [coal] + prefixes
                  if (p / "include" / "eigen3" / "Eigen" / "Core").is_file()), None)
    if eigen is None:
        raise SimulationError("wbc.constraints.narrow_phase cannot be built: Eigen's headers are in no cmeel.prefix "
                              "on the Python path (install the pinned `cmeel-eigen`: pip install -e .)")
    return [str(coal / "include"), str(eigen)], str(coal / "lib")


def compile_command(output: Path, search: list[str] | None = None) -> list[str]:
    """The compiler command line that builds the extension into ``output`` (flags as a setuptools build of a C++
    extension: position-independent shared object, -O2, C++17).

    Raises:
        SimulationError: no C++ compiler on the PATH (``CXX``, else ``c++``), or the headers are missing
            (:func:`find_headers`).
    """
    compiler = os.environ.get("CXX", "c++")
    if shutil.which(compiler.split()[0]) is None:
        raise SimulationError(f"wbc.constraints.narrow_phase cannot be built: no C++ compiler `{compiler}` on the "
                              "PATH (install g++, e.g. apt install g++, or set CXX)")
    includes, lib = find_headers(search)
    source = Path(__file__).with_name("narrow_phase.cpp")
    return [*compiler.split(), "-shared", "-fPIC", "-O2", "-std=c++17", "-Wno-deprecated-declarations",
            *(f"-D{d}" for d in _DEFINES), f"-I{sysconfig.get_path('include')}", *(f"-I{i}" for i in includes),
            str(source), f"-L{lib}", "-lcoal", "-o", str(output)]


def build_narrow_phase(force: bool = False) -> Path | None:
    """Build ``wbc.constraints.narrow_phase`` (:func:`compile_command`) into :func:`extension_path`, unless it is
    there and newer than its source (``force``: always). A process that imported the self-collision constraint
    before keeps the narrow phase it found; the next process imports the built extension.

    Returns:
        The extension's path when it was built now, None when it was up to date.

    Raises:
        SimulationError: no compiler, no headers (:func:`find_headers`), or the compiler failed (its last lines of
            output in the message); the folder is not writable (the message says which).
    """
    target = extension_path()
    source = Path(__file__).with_name("narrow_phase.cpp")
    if not force and target.is_file() and target.stat().st_mtime >= source.stat().st_mtime:
        return None
    partial = target.with_name(f".{target.name}.{os.getpid()}.partial")
    command = compile_command(partial)
    try:
        out = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        if out.returncode != 0:
            raise SimulationError(f"wbc.constraints.narrow_phase: the C++ compiler exited with {out.returncode}: "
                                  f"{out.stdout.strip()[-800:]}")
        os.replace(partial, target)
    except PermissionError as exc:
        raise SimulationError(f"wbc.constraints.narrow_phase cannot be written to {target.parent} ({exc.strerror}); "
                              "an editable install (pip install -e .) keeps it in the clone") from None
    finally:
        partial.unlink(missing_ok=True)
    return target


def build_or_explain() -> Path | None:
    """:func:`build_narrow_phase` as ``wbc compile`` runs it: a failure (no compiler, no headers, a compiler error)
    is one line on stderr, not an error (the self-collision constraint then goes through Pinocchio's bindings).

    Returns:
        The extension's path when it was built now, None when it was up to date or could not be built.
    """
    try:
        return build_narrow_phase()
    except SimulationError as exc:
        print(f"wbc compile: {exc} (self-collision distances go through Pinocchio's bindings)", file=sys.stderr,
              flush=True)
        return None
