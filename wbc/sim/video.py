"""MP4 videos of simulated motions, rendered offscreen by MuJoCo (``mujoco.Renderer``) and encoded with imageio.

Rendering replays a logged motion (``SimRun.q``, Pinocchio conventions) into the MuJoCo model after the run, so
the closed loop is never slowed down by rendering. The camera tracks the floating base at a fixed distance
(free camera, azimuth/elevation in degrees) over a floor grid of 0.5 m squares drawn into the rendered scene
(so the motion shows against the ground). Encoding uses ``imageio`` with the ``imageio-ffmpeg`` plugin
(H.264, yuv420p). Headless Linux needs ``MUJOCO_GL=egl`` set before ``mujoco`` is imported (see
:mod:`wbc.sim`) and the EGL/Mesa system libraries. Debian 12 packages that provide what MuJoCo's EGL backend
loads here: ``libegl1`` (libEGL, glvnd; depends on ``libglvnd0`` and ``libegl-mesa0``), ``libopengl0``
(libOpenGL) and ``libgl1-mesa-dri`` (``swrast_dri.so``: llvmpipe software rendering).
"""

from __future__ import annotations

import importlib
import os
from pathlib import Path

import mujoco
import numpy as np

from wbc.exceptions import InvalidInputError, SimulationError
from wbc.sim.mujoco_runtime import MujocoModel

__all__ = ["render_video"]


def render_video(sim: MujocoModel, t: np.ndarray, q: np.ndarray, path, *, fps: float = 25.0, width: int = 640,
                 height: int = 480, distance: float = 3.0, azimuth: float = 150.0, elevation: float = -15.0,
                 max_frames: int | None = None) -> Path:
    """Render the motion ``(t, q)`` to an MP4 file.

    Args:
        sim: the MuJoCo model the motion was simulated with.
        t: (N,) times (s), increasing. q: (N, nq) configurations (Pinocchio conventions).
        path: output ``.mp4``. fps: video frame rate (the samples nearest to a uniform grid are shown).
        width, height: frame size (pixels; at most the model's offscreen buffer, 640×480 by default).
        distance (m), azimuth, elevation (deg): tracking camera.
        max_frames: cap on the number of frames (None: all).

    Returns:
        The path written.

    Raises:
        InvalidInputError: mis-shaped inputs or a bad size/fps.
        SimulationError: no OpenGL context (headless without ``MUJOCO_GL=egl``) or imageio-ffmpeg missing.
    """
    t = np.asarray(t, dtype=float)
    q = np.asarray(q, dtype=float)
    if t.ndim != 1 or q.ndim != 2 or q.shape != (t.size, sim.robot.nq) or t.size == 0:
        raise InvalidInputError(f"t (N,) and q (N, {sim.robot.nq}) expected, got {t.shape} and {q.shape}")
    if not (fps > 0 and width > 0 and height > 0):
        raise InvalidInputError("fps, width and height must be positive")
    try:
        import imageio.v2 as imageio
        importlib.import_module("imageio_ffmpeg")  # the ffmpeg plugin imageio needs for mp4
    except ImportError as exc:
        raise SimulationError("--video needs imageio and imageio-ffmpeg: pip install -e \".[video]\" (from the wbc "
                              "clone)") from exc
    grid = np.arange(t[0], t[-1] + 1e-9, 1.0 / fps)
    idx = np.unique(np.clip(np.searchsorted(t, grid), 0, t.size - 1))
    if max_frames is not None:
        idx = idx[:max_frames]
    model = sim.model
    w = min(int(width), int(model.vis.global_.offwidth))
    h = min(int(height), int(model.vis.global_.offheight))
    try:
        renderer = mujoco.Renderer(model, h, w)
    except Exception as exc:  # mujoco.FatalError without a GL context
        raise SimulationError(
            f"MuJoCo offscreen rendering failed ({exc}); on a headless machine set MUJOCO_GL=egl before "
            f"importing mujoco (current MUJOCO_GL={os.environ.get('MUJOCO_GL')!r}) and install libegl1 "
            f"libgl1-mesa-dri") from exc
    data = mujoco.MjData(model)
    # A brighter headlight than MuJoCo's default (ambient 0.1, diffuse 0.4): rendering only, restored after.
    light = model.vis.headlight
    saved = (light.ambient.copy(), light.diffuse.copy())
    light.ambient[:], light.diffuse[:] = 0.35, 0.75
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.distance, cam.azimuth, cam.elevation = distance, azimuth, elevation
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        with imageio.get_writer(path, fps=fps, codec="libx264", macro_block_size=8, pixelformat="yuv420p") as writer:
            for i in idx:
                sim.set_state(q[i], data=data)
                cam.lookat[:] = [data.qpos[0], data.qpos[1], 0.6 * data.qpos[2]]
                renderer.update_scene(data, camera=cam)
                _add_floor_grid(renderer.scene, data.qpos[:2])
                writer.append_data(renderer.render())
    finally:
        renderer.close()
        light.ambient[:], light.diffuse[:] = saved
    return path


def _add_floor_grid(scene, center_xy, half: float = 4.0, step: float = 0.5) -> None:
    """Dark 8 mm lines every ``step`` m on the floor (z = 0), fixed in the world, within ``half`` m of the base:
    the uniform floor alone hides that the tracked robot moves. Added to the rendered scene only."""
    ticks = np.arange(-half, half + 1e-9, step)
    cx, cy = (np.round(np.asarray(center_xy, dtype=float) / step) * step).tolist()
    rgba = np.array([0.25, 0.25, 0.28, 1.0], dtype=np.float32)
    eye = np.eye(3).ravel()
    for k in ticks:
        for size, pos in (([half, 0.004, 0.0005], [cx, cy + k, 0.001]), ([0.004, half, 0.0005], [cx + k, cy, 0.001])):
            if scene.ngeom >= scene.maxgeom:
                return
            mujoco.mjv_initGeom(scene.geoms[scene.ngeom], mujoco.mjtGeom.mjGEOM_BOX, np.array(size), np.array(pos),
                                eye, rgba)
            scene.ngeom += 1
