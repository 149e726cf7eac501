#!/usr/bin/env bash
# A virtual environment with TSID 1.10 for benchmarks/id_vs_tsid.py (not committed; made once, reused).
#
# TSID cannot be installed beside placo: tsid 1.10.0 needs cmeel-boost ~= 1.90 and the newest `pin`, the project pins
# pin 3.8.0 (boost 1.89) for placo. And its C++ library `libtsid` 1.10.0 is on the package index only as cp314
# wheels (the library does not use Python; the tag is a packaging artefact), which pip refuses on Python 3.11: the
# wheel is downloaded for cp314 and unpacked into the venv's site-packages (a wheel is a zip of that tree).
# pin is held at 4.0.0: with pin 4.1.0 (what `pin` resolves to) libtsid 1.10.0's RobotWrapper aborts on
# construction ("free(): invalid pointer", an ABI change between the Pinocchio it was built with and 4.1).
#
# Usage: bash benchmarks/tsid_venv.sh  →  prints the venv's python (default ~/.cache/wbc/tsid-venv, or $TSID_VENV).
set -euo pipefail
VENV="${TSID_VENV:-${XDG_CACHE_HOME:-$HOME/.cache}/wbc/tsid-venv}"
PY="${PYTHON:-python3.11}"
if [ -x "$VENV/bin/python" ] && "$VENV/bin/python" -c "import tsid, pinocchio; assert pinocchio.__version__ == '4.0.0'" 2>/dev/null; then
    echo "$VENV/bin/python"; exit 0
fi
export PIP_CONSTRAINT=""   # the machine-wide constraints are for the project's environment, not this one
"$PY" -m venv "$VENV"
"$VENV/bin/pip" install -q --upgrade pip >&2
"$VENV/bin/pip" install -q "tsid==1.10.0" --no-deps >&2
"$VENV/bin/pip" install -q "cmeel-boost~=1.90.0" eiquadprog "pin==4.0.0" numpy >&2
TMP="$(mktemp -d)"
"$VENV/bin/pip" download -q "libtsid==1.10.0" --no-deps --only-binary=:all: --python-version 3.14 \
    --platform manylinux_2_28_x86_64 -d "$TMP" >&2
SITE="$("$VENV/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')"
"$VENV/bin/python" -m zipfile -e "$TMP"/libtsid-1.10.0-*.whl "$SITE" >&2
rm -rf "$TMP"
"$VENV/bin/python" -c "import tsid, pinocchio; print('tsid', tsid.__version__ if hasattr(tsid, '__version__') else '1.10.0', 'pin', pinocchio.__version__)" >&2
echo "$VENV/bin/python"
