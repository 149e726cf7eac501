"""``wbc plot`` on a file that is not a wbc log: one line, exit 2, and never numpy's advice to load pickles."""

from __future__ import annotations

import zipfile

import numpy as np


def test_a_text_file_is_not_an_npz_log(cli, tmp_path):
    code, err, out = cli(["plot", "/etc/passwd", "--out", str(tmp_path / "p.png")])
    assert (code, out) == (2, "")
    assert err == ("wbc plot: error: '/etc/passwd' is not a readable npz log (not a zip archive of arrays; a run "
                   "writes one with --log FILE.npz)")
    assert list(tmp_path.iterdir()) == []  # no PNG written


def test_pickled_arrays_are_refused_without_suggesting_unsafe_loading(cli, tmp_path):
    np.save(tmp_path / "t.npy", np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with zipfile.ZipFile(tmp_path / "pickled.npz", "w") as z:
        z.write(tmp_path / "t.npy", "t.npy")
    code, err, out = cli(["plot", str(tmp_path / "pickled.npz")])
    assert (code, out) == (2, "")
    assert err == (f"wbc plot: error: '{tmp_path / 'pickled.npz'}' is not a readable npz log (it holds pickled "
                   "Python objects, which wbc never loads; a wbc log holds arrays only)")
    assert "allow_pickle" not in err and "pickle.load" not in err
