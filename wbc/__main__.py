"""``python -m wbc`` = the ``wbc`` console script."""

import sys

try:
    from wbc.cli import main
except KeyboardInterrupt:  # Ctrl-C before main() installs its handlers: same exit code, no traceback
    sys.stderr.write("wbc: interrupted (Ctrl-C) while loading\n")
    sys.exit(130)

sys.exit(main())
