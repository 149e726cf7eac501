"""MuJoCo simulation of wbc robots (model built from the URDF, closed loop, scenarios, video).

Headless rendering: MuJoCo picks its OpenGL backend from ``MUJOCO_GL`` **when ``mujoco`` is first imported**.
On Linux without a ``DISPLAY`` and without ``MUJOCO_GL`` set, importing :mod:`wbc.sim` sets ``MUJOCO_GL=egl``
(offscreen rendering through EGL; Mesa's llvmpipe on a machine without GPU) so that ``--video`` works; this
only takes effect if ``mujoco`` was not imported before.
"""

import os as _os
import sys as _sys

if _sys.platform.startswith("linux") and "MUJOCO_GL" not in _os.environ and not _os.environ.get("DISPLAY"):
    _os.environ["MUJOCO_GL"] = "egl"
