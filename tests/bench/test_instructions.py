"""The environment of a callgrind child (wbc.bench.instructions.callgrind_env): numba's cache key in that
environment must not depend on the CPU the process detects, so that a native run and a run under valgrind (whose
emulated CPU reports other features) read the same cache entries."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

from wbc.bench.instructions import callgrind_env

MAGIC = "from numba.core.codegen import JITCPUCodegen; print(repr(JITCPUCodegen('probe').magic_tuple()))"


def test_env_targets_generic_cpu_in_its_own_cache(monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setenv("NUMBA_CPU_FEATURES", "+avx2")
    monkeypatch.delenv("WBC_CALLGRIND_CPU", raising=False)
    env = callgrind_env()
    assert env["NUMBA_CPU_NAME"] == "generic"
    assert env["NUMBA_CPU_FEATURES"] == ""
    assert Path(env["NUMBA_CACHE_DIR"]) == tmp_path / "wbc" / "numba-generic"


def test_numba_cache_key_is_generic_whatever_the_host_reports(monkeypatch):
    monkeypatch.delenv("WBC_CALLGRIND_CPU", raising=False)
    # numba's cache index is keyed on (target triple, CPU name, CPU features): in the child's environment the
    # last two must be the generic CPU with no feature string, not what LLVM detects on this host
    out = subprocess.run([sys.executable, "-c", MAGIC], env=callgrind_env(), capture_output=True, text=True,
                         check=True).stdout.strip()
    triple, cpu, features = ast.literal_eval(out)
    assert cpu == "generic"
    assert features == ""
    host = subprocess.run([sys.executable, "-c", MAGIC], capture_output=True, text=True, check=True).stdout.strip()
    assert ast.literal_eval(host)[0] == triple


def test_numba_cache_key_of_a_named_cpu_has_no_detected_features(monkeypatch):
    # with another CPU named, numba would append the host's detected features unless told none: the key must
    # be the named CPU alone, or valgrind's run would miss the native run's cache
    monkeypatch.setenv("WBC_CALLGRIND_CPU", "haswell")
    out = subprocess.run([sys.executable, "-c", MAGIC], env=callgrind_env(), capture_output=True, text=True,
                         check=True).stdout.strip()
    assert ast.literal_eval(out)[1:] == ("haswell", "")


def test_a_cpu_argument_overrides_the_environment(monkeypatch, tmp_path):
    # the suite's second count (wbc.bench.suite.HOST_LIKE_CPU) names its CPU by argument, whatever the variable says
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setenv("WBC_CALLGRIND_CPU", "generic")
    env = callgrind_env("haswell")
    assert (env["NUMBA_CPU_NAME"], env["NUMBA_CPU_FEATURES"]) == ("haswell", "")
    assert Path(env["NUMBA_CACHE_DIR"]) == tmp_path / "wbc" / "numba-haswell"
