"""``python -m wbc`` = the ``wbc`` console script."""

import sys

from wbc.cli import main

sys.exit(main())
