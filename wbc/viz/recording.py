"""Self-contained HTML recordings of a motion, played by meshcat's viewer offline in any browser.

The file holds meshcat 0.3.2's viewer script and one binary blob of meshcat commands (msgpack, framed by
4-byte little-endian lengths, gzip-compressed, base64) that a few lines of JavaScript feed to the viewer:
the robot meshes, overlay spheres, support polygons, the camera, and one ``set_animation``. No server,
network or browser is needed to write it; nothing is fetched when it is opened.

Mirrored meshes: URDF meshes may carry a negative scale (Talos's right arm and leg use
``meshScale = (1, -1, 1)``). ``meshcat.animation`` turns each ``oMg * diag(scale)`` matrix into a
quaternion, which for a mirrored matrix is garbage. Here each geometry node gets its ``meshScale`` once,
as the node's ``scale`` property, and the animation only carries the rigid part of Pinocchio's ``oMg``
(translation + quaternion of a proper rotation). three.js composes ``T(p) R(quat) S(scale)``, which is
exactly ``oMg * diag(meshScale)`` as Pinocchio's own MeshcatVisualizer displays it.
"""

from __future__ import annotations

import base64
import gzip
import os
import struct
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import meshcat
import numpy as np
import pinocchio as pin
import umsgpack
from scipy.spatial.transform import Rotation

from wbc.exceptions import InvalidInputError
from wbc.robot import Robot
from wbc.viz import _scene

__all__ = ["record_html", "Polygon"]

#: A support polygon shown from ``t_start`` to ``t_end`` (s, same clock as ``t``): vertices (K, 3), world (m).
Polygon = tuple[float, float, np.ndarray]

_FLOAT32_EXT = 0x17  # msgpack extension code that meshcat's msgpack-lite decodes into a Float32Array
_VIEWER_JS = Path(meshcat.__file__).parent / "viewer" / "dist" / "main.min.js"

_HTML = """<!DOCTYPE html>
<html>
<head><meta charset="utf-8"><title>{title}</title>
<style>body {{ margin: 0; }} #meshcat-pane {{ width: 100vw; height: 100vh; overflow: hidden; }}</style>
</head>
<body>
<div id="meshcat-pane"></div>
{legend}
<script>
{viewer_js}
</script>
<script id="wbc-scene" type="application/octet-stream" data-encoding="{encoding}">{payload}</script>
<script>
{follow_js}
var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
(async function () {{
  try {{
    const el = document.getElementById("wbc-scene");
    let bytes = Uint8Array.from(atob(el.textContent.trim()), (c) => c.charCodeAt(0));
    if (el.dataset.encoding === "gzip") {{
      const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream("gzip"));
      bytes = new Uint8Array(await new Response(stream).arrayBuffer());
    }}
    const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    let offset = 0, count = 0;
    while (offset < bytes.length) {{
      const n = view.getUint32(offset, true);
      viewer.handle_command_bytearray(bytes.slice(offset + 4, offset + 4 + n));
      offset += 4 + n;
      count += 1;
    }}
    window.wbcCommandCount = count;
    wbcFollow(viewer);  // orbit around (and follow) /Cameras/target
  }} catch (err) {{
    window.wbcError = String(err);
    console.error("wbc recording:", err);
  }}
}})();
</script>
</body>
</html>
"""


def record_html(
    robot: Robot,
    t: np.ndarray,
    q: np.ndarray,
    path: str | os.PathLike[str],
    *,
    fps: float = 25.0,
    overlays: Mapping[str, np.ndarray] | None = None,
    polygons: Sequence[Polygon] | None = None,
    paths: Mapping[str, Sequence[np.ndarray]] | None = None,
    outlines: Mapping[str, Sequence[np.ndarray]] | None = None,
    arrows: Mapping[str, tuple[np.ndarray, np.ndarray]] | None = None,
    arrow_scale: float = 1e-3,
    legend: bool = True,
    follow_camera: bool = True,
    loop: bool = True,
    compress: bool = True,
    terrain=None,
) -> Path:
    """Write a self-contained HTML animation of a motion.

    Args:
        robot: the robot; its visual model is drawn (the collision model is skipped).
        t: (N,) sample times (s), strictly increasing.
        q: (N, nq) configurations (Pinocchio order; base position in world, quaternion x, y, z, w).
        path: output ``.html`` file (parent folders are created).
        fps: animation frame rate: the samples nearest to a uniform ``fps`` grid are kept (all samples if
            the input is sparser). Poses are not interpolated.
        overlays: name -> (N, 3) world points (m) drawn as small spheres on top of the robot, e.g.
            ``{"com": com, "zmp": zmp}`` ("com" red, "zmp"/"cop" green, "dcm" blue, others cycled).
        polygons: support polygon outlines, each ``(t_start, t_end, vertices (K, 3))``, shown while
            ``t_start <= t < t_end`` (times on the clock of ``t``).
        paths: name -> list of (K, 3) open polylines (world, m) drawn for the whole recording under
            ``/meshcat/overlays/<name>/<i>`` (e.g. swing-foot trajectories).
        outlines: name -> list of (K, 3) closed outlines, same (e.g. planned footsteps, footprints).
        arrows: name -> (origins (N, 3) m, vectors (N, 3)) drawn as a cylinder from the origin along the
            vector, ``arrow_scale`` metres per unit (default 1 mm per N: a 450 N foot force is 0.45 m long).
        arrow_scale: see ``arrows``.
        legend: add an HTML legend (colour -> overlay name) in the page's lower-left corner. Every overlay
            is a separate meshcat path, shown or hidden from meshcat's "Open Controls" panel.
        follow_camera: the camera looks at and follows the base (smoothed over 1 s, at mid robot height);
            else it looks at the mean base position. Mouse orbit and zoom work in both cases.
        loop: replay the animation forever (else once; the viewer's Animations panel replays it).
        compress: gzip the scene (about half the size; decoded with the browser's ``DecompressionStream``,
            Chrome 80+, Firefox 113+, Safari 16.4+). ``False`` writes plain base64 for older browsers.
        terrain: a :class:`wbc.terrain.Terrain` drawn with the floor (boxes, heightfield); None: the floor alone.

    Returns:
        The path written. A 20 s Talos walk at 25 fps is about 6 MB (meshes are most of it).

    Raises:
        InvalidInputError: mis-shaped or non-finite ``t``/``q``/overlays/polygons, ``t`` not increasing,
            ``fps <= 0``, or a base quaternion far from unit norm.
    """
    t, q = _check_motion(robot, t, q, fps)
    idx = _decimate(t, fps)
    times = (t[idx] - t[0]).astype(np.float32)
    q_frames = np.array([_scene.normalized(robot, qi) for qi in q[idx]])
    marks = _check_overlays(overlays, len(t))
    support = _check_polygons(polygons)
    arrow_items = _check_arrows(arrows, len(t))
    lines = _check_paths(paths, "paths") + _check_paths(outlines, "outlines", closed=True)

    recorder = _scene.CommandRecorder()
    vis = meshcat.Visualizer(window=recorder)
    _scene.load_robot_visuals(robot, vis)
    # Pinocchio's loader also sends scaled placements (set_transform) of a blank pose: replaced below.
    recorder.commands = [c for c in recorder.commands if c["type"] != "set_transform"]
    _scene.add_floor(vis)
    if terrain is not None:
        _scene.draw_terrain(vis, terrain)
    entries = {name: _scene.overlay_color(name, i) for i, name in enumerate(marks)}
    for j, (name, closed, items) in enumerate(lines):
        color = _scene.overlay_color(name, len(marks) + j)
        entries[name] = color
        for i, v in enumerate(items):
            vis[f"{_scene.OVERLAY_ROOT}/{name}/{i}"].set_object(_scene.polyline(v, color, closed))
    if support:
        entries["support_polygon"] = _scene.overlay_color("support_polygon", 0)
    animations = [
        *_robot_clips(vis, robot, q_frames, times),
        *_overlay_clips(vis, {name: points[idx] for name, points in marks.items()}, times),
        *_polygon_clips(vis, support, t[0], times),
        *_camera_clips(vis, robot, q_frames, times, fps, follow_camera),
        *_arrow_clips(vis, arrow_items, idx, times, arrow_scale, entries),
    ]
    if len(times) > 1:
        for a in animations:
            a["clip"]["duration"] = float(times[-1])  # equal durations keep looping clips in step
        recorder.commands.append({
            "type": "set_animation",
            "path": "",
            "animations": animations,
            "options": {"play": True, "repetitions": float("inf") if loop else 1},
        })
    return _write(Path(path), recorder.commands, compress, title=f"wbc: {robot.name}",
                  legend=_scene.legend_html(entries) if legend and entries else "")


def _robot_clips(vis: meshcat.Visualizer, robot: Robot, q_frames: np.ndarray, times: np.ndarray) -> list[dict]:
    """Node scale = meshScale once; first pose as properties; rigid motion (position, quaternion) clips."""
    clips = []
    positions, quaternions = _visual_poses(robot, q_frames)
    for g, (node, geom) in enumerate(zip(_scene.visual_paths(robot), robot.visual_model.geometryObjects)):
        vis[node].set_property("position", _floats(positions[0, g]))
        vis[node].set_property("quaternion", _floats(quaternions[0, g]))
        vis[node].set_property("scale", _floats(geom.meshScale))
        clips.append(_clip(node, [_track("position", "vector3", times, positions[:, g]),
                                  _track("quaternion", "quaternion", times, quaternions[:, g])]))
    return clips


def _overlay_clips(vis: meshcat.Visualizer, marks: dict[str, np.ndarray], times: np.ndarray) -> list[dict]:
    clips = []
    for i, (name, points) in enumerate(marks.items()):
        node = f"{_scene.OVERLAY_ROOT}/{name}"
        vis[node].set_object(_scene.overlay_sphere(_scene.overlay_color(name, i)))
        vis[node].set_property("position", _floats(points[0]))
        clips.append(_clip(node, [_track("position", "vector3", times, points)]))
    return clips


def _polygon_clips(vis: meshcat.Visualizer, outlines: list[tuple[float, float, np.ndarray]], t0: float,
                   times: np.ndarray) -> list[dict]:
    """One outline per polygon, its ``visible`` switched by a boolean (step) track."""
    clips = []
    for i, (t_start, t_end, vertices) in enumerate(outlines):
        node = f"{_scene.OVERLAY_ROOT}/support_polygon/{i}"
        vis[node].set_object(_scene.polygon_outline(vertices))
        key_t, key_v = [0.0], [bool(t_start <= t0 < t_end)]
        vis[node].set_property("visible", key_v[0])
        for tk, vk in ((t_start - t0, True), (t_end - t0, False)):
            if 0.0 < tk <= times[-1]:
                key_t.append(float(tk))
                key_v.append(vk)
        clips.append(_clip(node, [{"name": ".visible", "type": "bool", "times": key_t, "values": key_v}]))
    return clips


def _camera_clips(vis: meshcat.Visualizer, robot: Robot, q_frames: np.ndarray, times: np.ndarray, fps: float,
                  follow: bool) -> list[dict]:
    """Camera offset, and the ``/Cameras/target`` point it looks at (mid robot height above the base)."""
    xy = q_frames[:, 0:2]
    xy = _smooth(xy, fps) if follow else np.broadcast_to(xy.mean(axis=0), xy.shape)
    targets = np.column_stack([xy, np.full(len(xy), 0.5 * _scene.robot_height(robot))])
    _scene.set_camera_offset(vis, _scene.camera_offset(robot))
    vis[_scene.CAMERA_TARGET].set_property("position", _floats(targets[0]))
    return [_clip(_scene.CAMERA_TARGET, [_track("position", "vector3", times, targets)])] if follow else []


def _check_motion(robot: Robot, t: np.ndarray, q: np.ndarray, fps: float) -> tuple[np.ndarray, np.ndarray]:
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or len(t) == 0:
        raise InvalidInputError(f"t must have shape (N,) with N >= 1, got {t.shape}")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise InvalidInputError("t must be finite and strictly increasing")
    q = _scene.check_q(robot, q)
    if q.shape != (len(t), robot.nq):
        raise InvalidInputError(f"q must have shape (N, nq) = ({len(t)}, {robot.nq}), got {q.shape}")
    if not (np.isfinite(fps) and fps > 0):
        raise InvalidInputError(f"fps must be positive, got {fps}")
    return t, q


def _decimate(t: np.ndarray, fps: float) -> np.ndarray:
    """Indices of the samples nearest to the grid t0 + k / fps, k = 0 .. floor((t[-1] - t0) fps)."""
    grid = t[0] + np.arange(int(np.floor((t[-1] - t[0]) * fps + 1e-9)) + 1) / fps
    right = np.searchsorted(t, grid).clip(0, len(t) - 1)
    left = (right - 1).clip(0)
    return np.unique(np.where(np.abs(t[right] - grid) < np.abs(t[left] - grid), right, left))


def _check_overlays(overlays: Mapping[str, np.ndarray] | None, n: int) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    for name, points in (overlays or {}).items():
        p = np.asarray(points, dtype=float)
        if p.shape != (n, 3) or not np.all(np.isfinite(p)):
            raise InvalidInputError(f"overlay {name!r} must be a finite (N, 3) = ({n}, 3) array, got {p.shape}")
        key = "".join(c if c.isalnum() or c in "_-." else "_" for c in str(name)) or "overlay"
        out[key] = p
    return out


def _check_arrows(arrows, n: int) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    out = {}
    for name, item in (arrows or {}).items():
        try:
            origin, vec = (np.asarray(a, dtype=float) for a in item)
        except (TypeError, ValueError) as exc:
            raise InvalidInputError(f"arrow {name!r} must be (origins (N, 3), vectors (N, 3))") from exc
        if origin.shape != (n, 3) or vec.shape != (n, 3) or not (np.isfinite(origin).all() and np.isfinite(vec).all()):
            raise InvalidInputError(f"arrow {name!r}: origins and vectors must be finite ({n}, 3) arrays, got "
                                    f"{origin.shape} and {vec.shape}")
        key = "".join(c if c.isalnum() or c in "_-." else "_" for c in str(name)) or "arrow"
        out[key] = (origin, vec)
    return out


def _arrow_clips(vis, arrows, idx, times, scale: float, entries: dict) -> list[dict]:
    """Unit cylinder (along local y, meshcat's convention) moved, turned and stretched along each vector."""
    import meshcat.geometry as mg

    clips = []
    y = np.array([0.0, 1.0, 0.0])
    for name, (origin, vec) in arrows.items():
        color = _scene.overlay_color(name, len(entries))
        entries[name] = color
        o, v = origin[idx], vec[idx] * scale
        length = np.linalg.norm(v, axis=1)
        d = np.where(length[:, None] > 1e-9, v / np.maximum(length, 1e-12)[:, None], y)
        axis = np.cross(y, d)
        s = np.linalg.norm(axis, axis=1)
        c = d @ y
        angle = np.arctan2(s, c)
        axis = np.where(s[:, None] > 1e-9, axis / np.maximum(s, 1e-12)[:, None], np.array([1.0, 0.0, 0.0]))
        quat = Rotation.from_rotvec(axis * angle[:, None]).as_quat()
        node = f"{_scene.OVERLAY_ROOT}/{name}"
        material = mg.MeshLambertMaterial(color=color, opacity=0.8, transparent=True, depthTest=False)  # seen through the legs
        vis[node].set_object(mg.Mesh(mg.Cylinder(1.0, radius=0.012), material))
        pos = o + 0.5 * v
        scl = np.c_[np.ones(len(o)), np.maximum(length, 1e-4), np.ones(len(o))]
        vis[node].set_property("position", _floats(pos[0]))
        vis[node].set_property("quaternion", _floats(quat[0]))
        vis[node].set_property("scale", _floats(scl[0]))
        clips.append(_clip(node, [_track("position", "vector3", times, pos),
                                  _track("quaternion", "quaternion", times, quat),
                                  _track("scale", "vector3", times, scl)]))
    return clips


def _check_paths(paths: Mapping[str, Sequence[np.ndarray]] | None, what: str,
                 closed: bool = False) -> list[tuple[str, bool, list[np.ndarray]]]:
    out = []
    for name, items in (paths or {}).items():
        arrays = []
        for i, v in enumerate(items):
            v = np.asarray(v, dtype=float)
            if v.ndim != 2 or v.shape[1] != 3 or len(v) < 2 or not np.all(np.isfinite(v)):
                raise InvalidInputError(f"{what} {name!r}[{i}] must be a finite (K >= 2, 3) array, got {v.shape}")
            arrays.append(v)
        key = "".join(c if c.isalnum() or c in "_-." else "_" for c in str(name)) or "path"
        out.append((key, closed, arrays))
    return out


def _check_polygons(polygons: Sequence[Polygon] | None) -> list[tuple[float, float, np.ndarray]]:
    out = []
    for i, item in enumerate(polygons or []):
        try:
            t_start, t_end, vertices = item
        except (TypeError, ValueError) as exc:
            raise InvalidInputError(f"polygon {i} must be (t_start, t_end, vertices (K, 3))") from exc
        v = np.asarray(vertices, dtype=float)
        if v.ndim != 2 or v.shape[1] != 3 or len(v) < 2 or not np.all(np.isfinite(v)):
            raise InvalidInputError(f"polygon {i}: vertices must be a finite (K >= 2, 3) array, got {v.shape}")
        if not float(t_start) < float(t_end):
            raise InvalidInputError(f"polygon {i}: t_start {t_start} must be < t_end {t_end}")
        out.append((float(t_start), float(t_end), v))
    return out


def _visual_poses(robot: Robot, q_frames: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(F, G, 3) positions and (F, G, 4) quaternions (x, y, z, w) of Pinocchio's ``oMg``, sign-continuous."""
    model, gmodel = robot.model, robot.visual_model
    data, gdata = model.createData(), gmodel.createData()
    n_frames, n_geoms = len(q_frames), gmodel.ngeoms
    pos = np.empty((n_frames, n_geoms, 3))
    rot = np.empty((n_frames, n_geoms, 3, 3))
    for f, qf in enumerate(q_frames):
        pin.forwardKinematics(model, data, qf)
        pin.updateGeometryPlacements(model, data, gmodel, gdata)
        for g, M in enumerate(gdata.oMg):
            pos[f, g] = M.translation
            rot[f, g] = M.rotation
    quat = Rotation.from_matrix(rot.reshape(-1, 3, 3)).as_quat().reshape(n_frames, n_geoms, 4)
    flips = np.sign(np.einsum("fgi,fgi->fg", quat[1:], quat[:-1]))
    flips[flips == 0] = 1.0
    quat[1:] *= np.cumprod(flips, axis=0)[..., None]
    return pos, quat


def _smooth(xy: np.ndarray, fps: float) -> np.ndarray:
    """Moving average over about one second (edges padded), (F, 2) -> (F, 2)."""
    w = max(1, min(len(xy), int(round(fps))))
    padded = np.pad(xy, ((w // 2, w - 1 - w // 2), (0, 0)), mode="edge")
    kernel = np.ones(w) / w
    return np.column_stack([np.convolve(padded[:, k], kernel, mode="valid") for k in range(2)])


def _floats(v: Any) -> list[float]:
    return [float(x) for x in np.asarray(v).ravel()]


def _f32(a: np.ndarray) -> umsgpack.Ext:
    return umsgpack.Ext(_FLOAT32_EXT, np.ascontiguousarray(a, dtype="<f4").tobytes())


def _track(prop: str, kind: str, times: np.ndarray, values: np.ndarray) -> dict[str, Any]:
    """A three.js keyframe track in its JSON form (``times`` s, flat ``values``), as Float32Arrays."""
    return {"name": "." + prop, "type": kind, "times": _f32(times), "values": _f32(values.reshape(-1))}


def _clip(node: str, tracks: list[dict[str, Any]]) -> dict[str, Any]:
    # fps 1: three.js scales key times by 1 / fps, so times stay in seconds.
    return {"path": node, "clip": {"fps": 1.0, "name": "default", "tracks": tracks}}


def _write(path: Path, commands: list[dict[str, Any]], compress: bool, title: str, legend: str = "") -> Path:
    blob = b"".join(struct.pack("<I", len(b)) + b for b in map(umsgpack.packb, commands))
    if compress:
        blob = gzip.compress(blob, compresslevel=6, mtime=0)
    html = _HTML.format(
        title=title,
        legend=legend,
        viewer_js=_VIEWER_JS.read_text(encoding="utf-8"),
        follow_js=_scene.FOLLOW_JS,
        encoding="gzip" if compress else "none",
        payload=base64.b64encode(blob).decode("ascii"),
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(html, encoding="utf-8")
    return path
