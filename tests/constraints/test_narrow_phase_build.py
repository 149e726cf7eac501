"""The build of the C++ narrow phase after the install (wbc.constraints.narrow_phase_build): the headers it needs
found in the run-time wheels, each missing piece refused with one line naming what to install, the compiler
command's flags those of coal's exported definitions, and a build into the package that imports and reports the
coal it was built against."""

import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from wbc.constraints import narrow_phase_build as npb
from wbc.exceptions import SimulationError


def test_the_headers_are_found_in_the_run_time_wheels():
    """coal's headers and libcoal.so (libcoal wheel) and Eigen's headers (cmeel-eigen) are on this environment's path."""
    includes, lib = npb.find_headers()
    assert any((Path(p) / "coal" / "distance.h").is_file() for p in includes)
    assert any((Path(p) / "Eigen" / "Core").is_file() for p in includes)
    assert (Path(lib) / "libcoal.so").exists()


def test_missing_headers_and_compiler_are_refused_with_what_to_install(tmp_path, monkeypatch):
    """No cmeel prefix on the searched path: coal's headers named and `pip install -e .`; a prefix with coal but no
    Eigen: Eigen named; no compiler: the compiler named; build_or_explain turns a failure into one stderr line."""
    with pytest.raises(SimulationError, match=r"coal's headers and libcoal.so .*pip install -e \."):
        npb.find_headers([str(tmp_path)])
    coal = tmp_path / "cmeel.prefix"
    (coal / "include" / "coal").mkdir(parents=True)
    (coal / "include" / "coal" / "distance.h").write_text("")
    (coal / "lib").mkdir()
    (coal / "lib" / "libcoal.so").write_text("")
    with pytest.raises(SimulationError, match="Eigen's headers"):
        npb.find_headers([str(tmp_path)])
    monkeypatch.setenv("CXX", "no-such-compiler-wbc")
    with pytest.raises(SimulationError, match="no C.. compiler `no-such-compiler-wbc`"):
        npb.compile_command(tmp_path / "x.so")
    monkeypatch.setattr(npb, "extension_path", lambda: tmp_path / "narrow_phase.so")
    assert npb.build_or_explain() is None


def test_the_compile_command_holds_coal_s_definitions_and_links_libcoal(tmp_path):
    """The definitions of coal's CMake export (the class layouts the library was built with), C++17, -fPIC, the
    source file, -lcoal and the output path."""
    cmd = npb.compile_command(tmp_path / "out.so")
    for flag in ("-shared", "-fPIC", "-std=c++17", "-DCOAL_HAS_OCTOMAP", "-DOCTOMAP_MINOR_VERSION=10", "-lcoal"):
        assert flag in cmd
    assert cmd[-2:] == ["-o", str(tmp_path / "out.so")]
    assert any(c.endswith("narrow_phase.cpp") for c in cmd)


@pytest.mark.skipif(shutil.which("c++") is None, reason="no C++ compiler (the build is optional)")
def test_an_up_to_date_extension_is_not_rebuilt_and_a_build_imports(tmp_path, monkeypatch):
    """An extension newer than its source is left alone (None); a forced build into another path writes a module that
    imports in a fresh interpreter and reports the coal version of the loaded coal."""
    target = tmp_path / npb.extension_path().name
    monkeypatch.setattr(npb, "extension_path", lambda: target)
    assert npb.build_narrow_phase() == target
    assert npb.build_narrow_phase() is None
    code = textwrap.dedent(f"""
        import importlib.util, coal
        spec = importlib.util.spec_from_file_location("narrow_phase", {str(target)!r})
        m = importlib.util.module_from_spec(spec); spec.loader.exec_module(m)
        print(m.coal_version == coal.__version__, callable(m.new))""")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.stdout.split() == ["True", "True"], out.stderr
    assert not list(tmp_path.glob("*.partial"))
