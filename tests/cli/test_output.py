"""What the run commands print: summaries rounded to their unit's resolution (full precision stays in --json),
keys that do not apply hidden, and the notice that the numba kernels compile on a first run."""

from __future__ import annotations

import io

import pytest

from wbc.cli.output import add_deadline_misses, compile_notice, format_value, print_summary, uncompiled_kernels


@pytest.fixture(autouse=True)
def fresh_compile_notices(monkeypatch):
    """compile_notice announces a module once per process; each test starts as a fresh process would."""
    monkeypatch.setattr("wbc.cli.output._NOTIFIED", set())


@pytest.mark.parametrize("value, key, text", [
    (-6.9e-18, "com_drift_m", "0"),  # floating-point noise on a length
    (8.4e-7, "max_stance_slip_m", "0"),  # below 1 µm
    (0.0327946, "min_zmp_margin_m", "0.03279"),
    (1234.5678, "tick_time_us", "1235"),
    (0.1234567, "torso_rad", "0.1235"),
    (3, "ticks", "3"),
    (float("nan"), "max_com_error_m", "nan"),
    (True, "passed", "True"),
])
def test_format_value_rounds_to_meaningful_digits(value, key, text):
    assert format_value(value, key) == text


def test_print_summary_hides_what_does_not_apply(capsys):
    print_summary({"com_drift_m": -6.9e-18, "fall_time_s": None, "fall_reason": "", "walked_distance_m": 1.0512345,
                   "max_task_error_rad": {"torso": 0.00056322, "posture": 2e-9}}, hide={"com_drift_m"})
    out = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in out] == ["walked_distance_m", "max_task_error_rad"]
    assert out[0].split()[1] == "1.051"
    assert out[1].split(None, 1)[1] == "torso 0.0005632, posture 0"


def test_compile_notice_when_a_kernel_module_has_no_cache(tmp_path, monkeypatch):
    import wbc

    pkg = tmp_path / "wbc"
    (pkg / "tasks").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "tasks" / "com.py").write_text("import numba as nb\n\n\n@nb.njit(cache=True)\ndef f(x):\n    return x\n")
    (pkg / "plain.py").write_text("x = 1  # no kernels\n")
    monkeypatch.setattr(wbc, "__file__", str(pkg / "__init__.py"))
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    assert uncompiled_kernels() == ["wbc.tasks.com"]
    stream = io.StringIO()
    assert compile_notice("wbc walk", stream=stream)
    assert "compiling the numba kernels" in stream.getvalue() and "cached" in stream.getvalue()
    (pkg / "tasks" / "__pycache__").mkdir()
    (pkg / "tasks" / "__pycache__" / "com.f-4.py311.nbi").write_bytes(b"")  # numba's index of the cached kernel
    assert uncompiled_kernels() == []
    stream = io.StringIO()
    assert not compile_notice("wbc walk", stream=stream) and stream.getvalue() == ""


def test_the_kernel_lists_name_modules_with_cached_kernels():
    """Every module the notice checks exists and has a numba kernel compiled with cache=True."""
    import importlib.util
    import re

    from wbc.cli.output import DYNAMICS_KERNELS, KINEMATIC_KERNELS

    for name in (*KINEMATIC_KERNELS, *DYNAMICS_KERNELS):
        spec = importlib.util.find_spec(name)
        assert spec is not None and spec.origin, name
        with open(spec.origin, encoding="utf-8") as f:
            assert re.search(r"@(?:nb\.|numba\.)?n?jit\([^)]*cache=True", f.read()), name


def test_status_lines_only_on_a_terminal(monkeypatch, capsys):
    import argparse
    import sys

    from wbc.cli.output import status

    class Tty(io.StringIO):
        def isatty(self):
            return True

    tty = Tty()
    monkeypatch.setattr(sys, "stderr", tty)
    status(argparse.Namespace(quiet=False), "wbc walk: loading talos ...")
    status(argparse.Namespace(quiet=True), "hidden")
    assert tty.getvalue() == "wbc walk: loading talos ...\n"
    monkeypatch.setattr(sys, "stderr", io.StringIO())
    status(argparse.Namespace(quiet=False), "not a terminal")
    assert sys.stderr.getvalue() == ""


def test_compile_notice_reads_the_cache_that_numba_cache_dir_names(tmp_path, monkeypatch):
    """With NUMBA_CACHE_DIR set, a module counts as compiled once numba itself has written its index there (a real
    compilation in a child process is the reference for numba's folder layout)."""
    import subprocess
    import sys

    import wbc

    pkg = tmp_path / "src" / "wbc"
    (pkg / "tasks").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "tasks" / "__init__.py").write_text("")
    (pkg / "tasks" / "com.py").write_text("import numba as nb\n\n\n@nb.njit(cache=True)\ndef f(x):\n    return x\n")
    cache = tmp_path / "numba_cache"
    monkeypatch.setattr(wbc, "__file__", str(pkg / "__init__.py"))
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(cache))
    assert uncompiled_kernels() == ["wbc.tasks.com"]
    assert compile_notice("wbc walk", stream=io.StringIO())
    env = {k: v for k, v in __import__("os").environ.items() if k != "PYTHONPATH"}
    env.update(NUMBA_CACHE_DIR=str(cache), PYTHONPATH=str(tmp_path / "src"))
    subprocess.run([sys.executable, "-c", "from wbc.tasks.com import f; f(1)"], env=env, check=True,
                   cwd=tmp_path)
    assert not any((pkg / "tasks").glob("__pycache__/*.nbi"))  # numba wrote under NUMBA_CACHE_DIR only
    assert uncompiled_kernels() == []
    assert not compile_notice("wbc walk", stream=io.StringIO())


def test_compile_notice_then_reports_each_module_as_its_kernels_become_ready(tmp_path, monkeypatch):
    import time

    import wbc
    from wbc.compiled import once_per_process, set_load_listener

    pkg = tmp_path / "wbc"
    (pkg / "tasks").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "tasks" / "com.py").write_text("import numba as nb\n\n\n@nb.njit(cache=True)\ndef f(x):\n    return x\n")
    monkeypatch.setattr(wbc, "__file__", str(pkg / "__init__.py"))
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)

    def slow():  # stands for a loader whose kernels compile
        time.sleep(0.6)
        return 7

    def fast():  # a loader that finds its cache
        return 8

    slow.__module__ = "wbc.tasks.com"
    fast.__module__ = "wbc.tasks.frame"
    slow, fast = once_per_process(slow), once_per_process(fast)
    stream = io.StringIO()
    previous = set_load_listener(None)
    try:
        assert compile_notice("wbc walk", stream=stream)
        assert slow() == 7 and fast() == 8 and slow() is None
    finally:
        set_load_listener(previous)
    lines = stream.getvalue().splitlines()
    assert len(lines) == 2 and "compiling the numba kernels" in lines[0]
    assert lines[1].startswith("wbc walk: wbc.tasks.com kernels ready (") and lines[1].endswith(" s)")
    assert float(lines[1].split("(")[1].split()[0]) >= 0.6


def test_deadline_misses_are_counted_past_the_period_and_placed_beside_the_tick_times():
    summary = {"ticks": 4, "tick_time_us": {"median": 1.0}, "deadline_misses": -1, "passed": True}
    add_deadline_misses(summary, [0.001, 0.002, 0.0021, 0.05], 0.002)  # 2 ticks longer than 2 ms (not the equal one)
    assert list(summary) == ["ticks", "tick_time_us", "deadline_misses", "passed"]
    assert summary["deadline_misses"] == 2
    other = {"ticks": 1}
    add_deadline_misses(other, [0.003], 0.002)
    assert other == {"ticks": 1, "deadline_misses": 1}
