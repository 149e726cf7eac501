"""Build of the one compiled extension, ``wbc.constraints.narrow_phase`` (C++ on coal: the self-collision
constraint's distances in one call; ``wbc/constraints/self_collision.py``). Everything else is in pyproject.toml.

coal's headers and library come from the ``libcoal`` wheel (the one ``pin`` installs at run time, pinned to the same
version in ``[build-system] requires``), Eigen's headers from ``cmeel-eigen``. The extension is optional: when it
cannot be built (no C++ compiler, no coal headers), the install goes on with a warning and the constraint computes
its distances through Pinocchio's bindings (same results, slower; ``SelfCollisionConstraint.narrow_phase``).
"""

import sys
from pathlib import Path

from setuptools import Extension, setup


def cmeel_include_and_lib():
    """(include dirs, lib dir) of the cmeel prefix holding coal's headers and libcoal.so, or None."""
    for entry in sys.path:
        prefix = Path(entry) / "cmeel.prefix"
        if (prefix / "include" / "coal" / "distance.h").is_file() and (prefix / "lib" / "libcoal.so").exists():
            eigen = [prefix / "include" / "eigen3"] + [Path(e) / "cmeel.prefix" / "include" / "eigen3" for e in sys.path]
            eigen = next((str(e) for e in eigen if (e / "Eigen" / "Core").is_file()), None)
            if eigen is None:
                return None
            return [str(prefix / "include"), eigen], str(prefix / "lib")
    return None


found = cmeel_include_and_lib()
ext_modules = []
if found is None:
    print("warning: coal or Eigen headers not found; wbc.constraints.narrow_phase is not built "
          "(self-collision distances go through Pinocchio's bindings)", file=sys.stderr)
else:
    include_dirs, lib_dir = found
    ext_modules.append(Extension(
        "wbc.constraints.narrow_phase",
        sources=["wbc/constraints/narrow_phase.cpp"],
        include_dirs=include_dirs,
        library_dirs=[lib_dir],
        libraries=["coal"],
        # coal's exported compile definitions (lib/cmake/coal/coalTargets.cmake): the same class layouts
        define_macros=[("COAL_BACKWARD_COMPATIBILITY_WITH_HPP_FCL", None), ("COAL_HAS_OCTOMAP", None),
                       ("COAL_HAVE_OCTOMAP", None), ("OCTOMAP_MAJOR_VERSION", "1"), ("OCTOMAP_MINOR_VERSION", "10"),
                       ("OCTOMAP_PATCH_VERSION", "0")],
        extra_compile_args=["-std=c++17", "-O2", "-Wno-deprecated-declarations"],
        language="c++",
        optional=True,
    ))

setup(ext_modules=ext_modules)
