"""``wbc sim walk`` with the first swing foot chosen: ``python benchmarks/mirror_walk.py left|right ARGS...`` runs
``wbc sim walk ARGS...`` in this process with :class:`wbc.sim.walk.WalkScenario`'s ``first_side`` forced (the CLI
has no flag for it; it swings the left foot first on a forward walk). With ``right`` and ``--push-dir -D`` it is the
sagittal mirror image of the ``left`` run with ``--push-dir D`` at the same ``--push-time`` (record 40)."""

import sys

import wbc.sim.walk as walk_module
from wbc.cli import main

_Walk = walk_module.WalkScenario


class _FirstSide(_Walk):
    def __init__(self, *args, **kwargs):
        kwargs["first_side"] = FIRST_SIDE
        super().__init__(*args, **kwargs)


if __name__ == "__main__":
    FIRST_SIDE = sys.argv[1]
    if FIRST_SIDE not in ("left", "right"):
        raise SystemExit("usage: mirror_walk.py left|right <wbc sim walk arguments>")
    walk_module.WalkScenario = _FirstSide
    sys.exit(main(["sim", "walk", *sys.argv[2:]]))
