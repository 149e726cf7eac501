"""`wbc sim --video`: 640×480 by default, lit, a world-fixed floor grid, and a camera that follows the base
(frames decoded back from the MP4 with imageio)."""

from __future__ import annotations

import os

import numpy as np
import pytest

if os.environ.get("MUJOCO_GL", "egl") != "egl" and not os.environ.get("DISPLAY"):
    pytest.skip("offscreen rendering needs MUJOCO_GL=egl", allow_module_level=True)
pytest.importorskip("imageio_ffmpeg")


@pytest.fixture(scope="module")
def frames(robots, tmp_path_factory):
    """Talos standing still while its base slides 0.8 m forward in 1 s (joints fixed), rendered at 5 fps."""
    import imageio.v3 as iio

    from wbc.sim.mujoco_model import build_mujoco_model
    from wbc.sim.video import render_video

    sim = build_mujoco_model(robots("talos"))
    t = np.arange(0.0, 1.0 + 1e-9, 0.05)
    q = np.tile(sim.robot.q_ref, (t.size, 1))
    q[:, 0] += 0.8 * t
    path = render_video(sim, t, q, tmp_path_factory.mktemp("video") / "v.mp4", fps=5)
    return iio.imread(path)


def _shell_column(frame):
    """Mean column (px) of the robot's white shell: near-white, low-saturation pixels."""
    rgb = frame.astype(float)
    white = (rgb.min(axis=2) > 170) & (np.ptp(rgb, axis=2) < 30)
    assert white.sum() > 500  # lit: the shell renders near white over a few thousand pixels
    return float(np.nonzero(white)[1].mean())


def test_default_size_is_640_by_480(frames):
    assert frames.shape[1:] == (480, 640, 3) and len(frames) == 6


def test_the_camera_follows_the_base(frames):
    # the base moved 0.8 m; the tracked robot stays at the same place in the image (a fixed camera 3 m away
    # would see it move by hundreds of pixels)
    assert abs(_shell_column(frames[0]) - _shell_column(frames[-1])) < 8.0


def test_the_floor_grid_moves_under_the_robot(frames):
    # bottom rows show only floor: grid lines are darker than the floor between them, and they are fixed in
    # the world, so the floor's pixels change as the base slides (0.8 m: not a multiple of the 0.5 m grid)
    floor0, floor1 = (f[-60:].astype(float).mean(axis=2) for f in (frames[0], frames[-1]))
    assert np.percentile(floor0, 95) - np.percentile(floor0, 2) > 25.0  # lines vs floor: measured 66 (0 without)
    assert np.mean(np.abs(floor0 - floor1)) > 1.0  # measured 2.8 grey levels (0.0 without the grid)
