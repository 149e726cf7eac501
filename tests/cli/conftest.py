"""Fixtures of the command-line tests."""

from __future__ import annotations

import pytest

from wbc.cli import main


@pytest.fixture
def cli(capsys):
    """Run ``wbc ARGV`` in-process: returns (exit code, stderr stripped, stdout); argparse's own exits included."""
    def run(argv):
        try:
            code = main(argv)
        except SystemExit as exc:
            code = exc.code
        out, err = capsys.readouterr()
        return code, err.strip(), out

    return run
