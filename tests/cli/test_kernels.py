"""`wbc compile` (the step after `pip install`): it writes numba's on-disk cache of every kernel a later process
needs, so that the next process, and the first `wbc walk`, load every kernel without compiling any. Checked with
numba's own cache log (NUMBA_DEBUG_CACHE=1: "[cache] data saved to ..." when a kernel was compiled and written,
"[cache] data loaded from ..." when read), in a fresh cache folder (NUMBA_CACHE_DIR) per test."""

from __future__ import annotations

import ast
import importlib
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from numba.core.dispatcher import Dispatcher

from wbc.cli import kernels
from wbc.cli.kernels import AFTER, COMPILED_TWICE, LOADER_MODULES, WARM_UP_RUNS, compile_all
from wbc.exceptions import InvalidInputError

ROOT = Path(__file__).resolve().parents[2]


def _run(args: list[str], cache: Path, cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), NUMBA_DEBUG_CACHE="1",
               PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, env=env, cwd=cwd, timeout=900)


def test_loader_modules_lists_every_module_with_a_loader():
    """Every source file that decorates a loader with once_per_process is in LOADER_MODULES, and nothing else."""
    pkg = ROOT / "wbc"
    found = {".".join(p.relative_to(ROOT).with_suffix("").parts) for p in pkg.rglob("*.py")
             if re.search(r"^@once_per_process\b", p.read_text(encoding="utf-8"), re.M)}
    assert found == set(LOADER_MODULES)
    assert len(LOADER_MODULES) == len(set(LOADER_MODULES))


def test_after_lists_every_kernel_a_loader_module_imports_from_another():
    """A loader module that imports a numba kernel from another loader module (its kernels call it, compiled by that
    module's loader too) waits for that module in a parallel compile, unless COMPILED_TWICE names the import: read
    from the modules' own import lines."""
    for name in LOADER_MODULES:
        tree = ast.parse((ROOT / Path(*name.split("."))).with_suffix(".py").read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module in LOADER_MODULES and node.module != name:
                source = importlib.import_module(node.module)
                if any(isinstance(getattr(source, a.name, None), Dispatcher) for a in node.names):
                    assert node.module in AFTER.get(name, ()) + COMPILED_TWICE.get(name, ()), (name, node.module)
    runs = {"wbc " + " ".join(argv) for argv in WARM_UP_RUNS}
    assert all((m in LOADER_MODULES or m in runs) and set(deps) <= set(LOADER_MODULES) for m, deps in AFTER.items())


def test_a_parallel_compile_starts_a_module_after_the_modules_it_waits_for(tmp_path, monkeypatch):
    """Two worker processes, posture made to wait for com: com is done before posture starts, and each module's
    kernels are written to the cache once (numba's cache files, counted on disk)."""
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "cache"))  # the spawned workers inherit it
    monkeypatch.setattr(kernels, "AFTER", {"wbc.tasks.posture": ("wbc.tasks.com",)})
    events = []
    seconds = compile_all(["wbc.tasks.posture", "wbc.tasks.com"], jobs=2,
                          on_start=lambda m: events.append(("start", m)),
                          on_done=lambda m, wall, cpu: events.append(("done", m)))
    assert events == [("start", "wbc.tasks.com"), ("done", "wbc.tasks.com"), ("start", "wbc.tasks.posture"),
                      ("done", "wbc.tasks.posture")]
    assert sorted(seconds) == ["wbc.tasks.com", "wbc.tasks.posture"] and min(seconds.values()) > 0
    assert list((tmp_path / "cache").rglob("com.*.nbi")) and list((tmp_path / "cache").rglob("posture.*.nbi"))


def test_a_module_with_parts_runs_each_part_as_an_item_before_the_module(tmp_path, monkeypatch):
    """PARTS: posture's loader also given as a part of its own; two worker processes: the part starts first (the
    order given), com beside it, posture only once its part is done, and the part is reported by its own label."""
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(kernels, "AFTER", {})
    monkeypatch.setattr(kernels, "PARTS", {"wbc.tasks.posture": ("_warm_up",)})
    events = []
    seconds = compile_all(["wbc.tasks.posture", "wbc.tasks.com"], jobs=2,
                          on_start=lambda m: events.append(("start", m)),
                          on_done=lambda m, wall, cpu: events.append(("done", m)))
    part = "wbc.tasks.posture:_warm_up"
    assert events[:2] == [("start", part), ("start", "wbc.tasks.com")]
    assert events.index(("done", part)) < events.index(("start", "wbc.tasks.posture"))
    assert sorted(seconds) == sorted([part, "wbc.tasks.com", "wbc.tasks.posture"])
    assert list((tmp_path / "cache").rglob("posture.*.nbi"))


def test_a_first_run_compiles_its_commands_modules_in_worker_processes_with_a_line_each(tmp_path, monkeypatch,
                                                                                      capsys):
    """compile_for_command on an empty cache (NUMBA_CACHE_DIR, inherited by the workers): a first line, then one line
    per module of the command (here two small ones) as each finishes, and their kernels are in the cache; a second
    call finds the cache and does nothing; a command without controller does nothing."""
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(kernels, "COMMAND_MODULES", {"walk": ("wbc.tasks.com", "wbc.tasks.posture")})
    monkeypatch.setattr("wbc.cli.output.KINEMATIC_KERNELS", ("wbc.tasks.com", "wbc.tasks.posture"))
    assert kernels.compile_for_command("walk") > 0
    lines = capsys.readouterr().err.splitlines()
    assert lines[0].startswith("wbc walk: first run: compiling the numba kernels of 2 modules in ")
    assert sorted(line.split(" (")[0] for line in lines[1:]) == ["wbc walk: wbc.tasks.com",
                                                                 "wbc walk: wbc.tasks.posture"]
    assert list((tmp_path / "cache").rglob("com.*.nbi")) and list((tmp_path / "cache").rglob("posture.*.nbi"))
    assert kernels.compile_for_command("walk") is None and kernels.compile_for_command("plot") is None
    assert capsys.readouterr().err == ""


def test_a_first_walk_compiles_every_module_whose_loader_it_runs(tmp_path):
    """COMMAND_MODULES['walk'] holds every loader module a `wbc walk` runs a loader of (listed by the load listener,
    in a process whose cache is the project's own: loading costs seconds once the install step compiled)."""
    code = ("import wbc.compiled as c\nfrom wbc.cli import main\nran = []\n"
            "c.set_load_listener(lambda m, s: ran.append(m))\nmain(['walk', '--steps', '2', '--quiet'])\n"
            "print('RAN', ' '.join(ran))\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    env.pop("NUMBA_CACHE_DIR", None)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=tmp_path,
                         timeout=900)
    assert out.returncode == 0, out.stderr[-2000:]
    ran = set(out.stdout.split("RAN ")[1].split())
    assert ran and ran <= set(kernels.COMMAND_MODULES["walk"]), sorted(ran - set(kernels.COMMAND_MODULES["walk"]))


def test_compile_all_refuses_no_process():
    with pytest.raises(InvalidInputError, match="jobs must be at least 1, got 0"):
        compile_all(["wbc.tasks.com"], jobs=0)


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_compile_writes_the_cache_the_next_process_loads(tmp_path, jobs):
    modules = ["wbc.tasks.com", "wbc.tasks.posture"]
    cache = tmp_path / "cache"
    first = _run(["-m", "wbc", "compile", "--jobs", jobs, *modules], cache, tmp_path)
    assert first.returncode == 0, first.stderr[-2000:]
    saved = re.findall(r"\[cache\] data saved to (\S+)", first.stdout)
    assert saved, first.stdout[-2000:]  # compiled here (in the worker processes with --jobs 2)
    assert len(saved) == len(set(saved)), saved  # each kernel compiled by one process
    assert f"the numba kernels of {len(modules)} modules compiled and cached" in first.stdout
    for name in modules:  # one line per module on stderr when not on a terminal
        assert f"wbc compile: {name} (" in first.stderr
    assert list(cache.rglob("com.*.nbi")) and list(cache.rglob("posture.*.nbc"))
    # a new process constructing the tasks (their loaders run at construction) reads every kernel from the cache
    second = _run(["-c", "import wbc\nfrom wbc.tasks import ComTask, PostureTask\n"
                         "robot = wbc.load_robot('talos')\nComTask(weight=1.0, gain=1.0)\nPostureTask(robot)\n"],
                  cache, tmp_path)
    assert second.returncode == 0, second.stderr[-2000:]
    assert "data loaded from" in second.stdout and "data saved" not in second.stdout, second.stdout[-2000:]


def test_compile_refuses_a_module_without_kernels(tmp_path):
    out = _run(["-m", "wbc", "compile", "wbc.geometry"], tmp_path / "cache", tmp_path)
    assert out.returncode == 2
    assert out.stderr.startswith("wbc compile: error: no numba kernel loader in wbc.geometry")
    assert "compiled and cached" not in out.stdout


def test_compile_refuses_zero_processes(tmp_path):
    out = _run(["-m", "wbc", "compile", "--jobs", "0"], tmp_path / "cache", tmp_path)
    assert out.returncode == 2
    assert out.stderr.strip() == "wbc compile: error: --jobs must be a whole number of processes >= 1, got 0"


def _cache_files(stdout: str) -> set[str]:
    """The cache files (one per kernel signature) numba's cache log says a process loaded or saved."""
    return {Path(m).name for m in re.findall(r"\[cache\] data (?:loaded from|saved to) (\S+)", stdout)}


def test_first_walk_and_sim_after_compile_compile_nothing(tmp_path):
    """The install step `wbc compile` covers every kernel `wbc walk` calls: every cache file the walk reads or writes
    is one `wbc compile` read or wrote (its loaders or its warm-up run, whose cache log compile passes on), and the
    walk writes none; `wbc sim walk` reads its kernels from the cache and writes none. Run on
    the project's own cache (the one the install step fills; a kernel missing there is compiled here once and
    cached), so that the test costs a cache load, not a full compile: the checks hold whether or not the cache was
    warm before."""
    env = dict(os.environ, NUMBA_DEBUG_CACHE="1", PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    env.pop("NUMBA_CACHE_DIR", None)

    def run(*args):
        out = subprocess.run([sys.executable, "-m", "wbc", *args], capture_output=True, text=True, env=env,
                             cwd=tmp_path, timeout=900)
        assert out.returncode == 0, out.stderr[-2000:]
        return out

    # one process (--jobs 1): the same loaders and warm-up run, one cache log. Under two busy loops and another
    # xdist worker, the pool's log lines of a loader's kernels went missing twice (kinematic_finish_packed,
    # command_within_box: compile's log named no file of them, the walk read them; cause not found)
    compile_log = run("compile", "--quiet", "--jobs", "1").stdout
    compiled = _cache_files(compile_log)
    walk = run("walk", "--steps", "2", "--quiet")
    walked = _cache_files(walk.stdout)
    assert walked, walk.stdout[-2000:]  # the walk did read its kernels from the cache
    stems = {name.split("-")[0] for name in walked - compiled}  # module.kernel of each kernel compile did not log
    assert walked <= compiled, (sorted(walked - compiled), [line for line in (compile_log + walk.stdout).splitlines()
                                                            if any(stem in line for stem in stems)])
    assert [line for line in walk.stdout.splitlines() if "data saved" in line] == []
    assert re.search(r"ticks_per_route +compiled \d+\n", walk.stdout), walk.stdout[-3000:]
    sim = run("sim", "walk", "--steps", "2", "--quiet")
    assert len(_cache_files(sim.stdout)) > len(walked), sim.stdout[-2000:]  # the ID and MuJoCo-side kernels too
    assert [line for line in sim.stdout.splitlines() if "data saved" in line] == [], \
        sorted(_cache_files("\n".join(line for line in sim.stdout.splitlines() if "data saved" in line)))
