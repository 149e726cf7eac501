"""A campaign's results folder is locked by the campaign using it: a second campaign on it, from another process,
is refused with one line naming the holder's pid (before, both ran every trial); the lock goes with its holder,
even one killed by SIGKILL."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from wbc.campaign import default_spec
from wbc.campaign.store import ResultStore
from wbc.cli import main
from wbc.exceptions import InvalidInputError

ROOT = Path(__file__).resolve().parents[2]


def _holder(out: Path, spec_dict: dict) -> subprocess.Popen:
    """A process holding ``out``'s store (it prints "held" once it does, then sleeps)."""
    code = ("import sys, time\nfrom wbc.campaign.store import ResultStore\n"
            f"ResultStore({str(out)!r}, {spec_dict!r})\nprint('held', flush=True)\ntime.sleep(600)\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True, env=env, cwd=ROOT)
    assert proc.stdout.readline().strip() == "held"
    return proc


def test_a_second_campaign_on_a_locked_folder_is_refused_with_the_holders_pid(tmp_path, capsys):
    out = tmp_path / "c"
    spec = default_spec("push", trials=3, seed=1)
    proc = _holder(out, spec.as_dict())
    try:
        with pytest.raises(InvalidInputError, match=rf"in use by another campaign \(pid {proc.pid} on "):
            ResultStore(out, spec.as_dict())
        code = main(["campaign", "run", "--kind", "push", "--trials", "3", "--seed", "1", "--no-plots",
                     "--no-progress", "--results", str(out)])
        err = capsys.readouterr().err.strip()
        assert code == 2 and len(err.splitlines()) == 1, err
        assert f"is in use by another campaign (pid {proc.pid} on " in err, err
        assert list((out / "trials").glob("*.parquet")) == []  # no trial ran
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=60)
    # the holder is gone (killed): the folder is free again
    store = ResultStore(out, spec.as_dict())
    store.close()


def test_the_lock_is_released_by_close_and_taken_again_by_the_same_process(tmp_path):
    out = tmp_path / "c"
    spec = default_spec("push", trials=3, seed=1).as_dict()
    first = ResultStore(out, spec)
    ResultStore(out, spec)  # the same process: no conflict with itself
    first.close()
    proc = _holder(out, spec)  # another process can take it now
    try:
        with pytest.raises(InvalidInputError, match=f"pid {proc.pid}"):
            ResultStore(out, spec)
    finally:
        proc.kill()
        proc.wait(timeout=60)
    ResultStore(out, spec).close()  # the killed holder's lock went with it
