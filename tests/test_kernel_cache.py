"""wbc.kernel_cache against numba's own cache: a cached kernel that calls a kernel of another file, the callee
edited, run in fresh processes with and without the check."""

import os
import subprocess
import sys

import pytest

from wbc.kernel_cache import RECORD_NAME, cache_folder, drop_stale_caches, kernel_sources

CALLEE = "import numba as nb\n\n\n@nb.njit(cache=True)\ndef f(x):\n    return x + {k}\n"
CALLER = ("import numba as nb\n\nfrom pkg.callee import f\n\n\n@nb.njit(cache=True)\ndef g(x):\n"
          "    return 10 * f(x)\n")


def _package(tmp_path):
    pkg = tmp_path / "src" / "pkg"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "callee.py").write_text(CALLEE.format(k=1))
    (pkg / "caller.py").write_text(CALLER)
    (pkg / "plain.py").write_text("X = 1  # no kernel\n")
    return pkg


def _g_of_1(tmp_path, pkg, cache_dir, check):
    """g(1) in a fresh process (numba's caches on disk), after drop_stale_caches when ``check``."""
    code = ("from pathlib import Path\nfrom wbc.kernel_cache import drop_stale_caches\n"
            f"{'' if check else '#'}drop_stale_caches(Path({str(pkg)!r}), {cache_dir!r})\n"
            "from pkg.caller import g\nprint(g(1))\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path / "src"), *sys.path]))
    env.pop("NUMBA_CACHE_DIR", None)
    if cache_dir:
        env["NUMBA_CACHE_DIR"] = cache_dir
    out = subprocess.run([sys.executable, "-c", code], env=env, check=True, capture_output=True, text=True, cwd=tmp_path)
    return int(out.stdout.split()[-1])


@pytest.mark.parametrize("in_tree", [True, False], ids=["__pycache__", "NUMBA_CACHE_DIR"])
def test_an_edited_callee_reaches_the_cached_caller_only_with_the_check(tmp_path, in_tree):
    pkg = _package(tmp_path)
    cache_dir = "" if in_tree else str(tmp_path / "numba_cache")
    assert _g_of_1(tmp_path, pkg, cache_dir, check=True) == 20
    assert list(cache_folder(pkg / "caller.py", cache_dir).glob("caller.*.nbi"))  # the caller is cached
    (pkg / "callee.py").write_text(CALLEE.format(k=22))
    assert _g_of_1(tmp_path, pkg, cache_dir, check=False) == 20  # numba alone: the stale 10 * (1 + 1)
    assert _g_of_1(tmp_path, pkg, cache_dir, check=True) == 230  # 10 * (1 + 22)
    assert _g_of_1(tmp_path, pkg, cache_dir, check=True) == 230  # and cached again from the new sources
    assert list(cache_folder(pkg / "caller.py", cache_dir).glob("caller.*.nbi"))


def test_a_touch_or_an_edit_of_a_file_without_kernels_keeps_the_caches(tmp_path):
    pkg = _package(tmp_path)
    assert _g_of_1(tmp_path, pkg, "", check=True) == 20
    cached = sorted((pkg / "__pycache__").glob("*.nb[ic]"))
    assert len(cached) >= 4  # an index and a data file for each of f and g
    os.utime(pkg / "callee.py", ns=(1, 1))  # the content unchanged (a checkout)
    (pkg / "plain.py").write_text("X = 2  # no kernel, edited\n")
    assert drop_stale_caches(pkg, "") == []
    assert sorted((pkg / "__pycache__").glob("*.nb[ic]")) == cached
    (pkg / "callee.py").write_text(CALLEE.format(k=3))
    assert sorted(drop_stale_caches(pkg, "")) == cached
    assert drop_stale_caches(pkg, "") == []  # recorded: the next import drops nothing


def test_the_first_check_without_a_record_drops_existing_caches(tmp_path):
    pkg = _package(tmp_path)
    assert _g_of_1(tmp_path, pkg, "", check=False) == 20
    assert not (pkg / "__pycache__" / RECORD_NAME).exists()
    assert len(drop_stale_caches(pkg, "")) >= 4  # caches of unknown sources: not trusted
    assert (pkg / "__pycache__" / RECORD_NAME).exists()


@pytest.mark.parametrize("record", ["[1, 2]", '{"callee.py": 3}', "{not json"])
def test_a_record_it_did_not_write_counts_as_none(tmp_path, record):
    pkg = _package(tmp_path)
    assert _g_of_1(tmp_path, pkg, "", check=True) == 20
    (pkg / "__pycache__" / RECORD_NAME).write_text(record)
    assert len(drop_stale_caches(pkg, "")) >= 4
    assert drop_stale_caches(pkg, "") == []


def test_a_source_folder_where_no_record_can_be_written_is_not_checked(tmp_path):
    pkg = _package(tmp_path)
    (pkg / "__pycache__").write_text("")  # a file where the cache folder would be: numba cannot cache here either
    assert drop_stale_caches(pkg, "") == []


def test_wbc_kernel_sources_are_the_modules_with_cached_kernels():
    names = {p.name for p in kernel_sources()}
    assert {"active_set.py", "velocity_kernel.py", "idkernel.py", "stabilizer.py"} <= names
    assert "kernel_cache.py" not in names and "exceptions.py" not in names
