"""Scene pieces shared by the HTML recorder and the live viewer (internal).

meshcat paths used (all in meshcat's world frame, z up, metres):

* ``/meshcat/<robot>/visuals/<geometry name>``: one node per visual geometry, loaded by Pinocchio's
  :class:`~pinocchio.visualize.MeshcatVisualizer` (collision model skipped);
* ``/meshcat/overlays/<name>``: a small sphere per overlay point (CoM, ZMP, ...), or a folder of lines
  ``/meshcat/overlays/<name>/<i>`` (support polygons, footsteps, footprints, swing trajectories): each overlay
  is its own path, so meshcat's control panel shows and hides it;
* ``/meshcat/floor/plane`` and ``/meshcat/floor/grid``: the ground (z = 0) as a thin slab and a 0.5 m grid of
  short line pieces (meshcat's own ``/Grid`` is hidden: its 20 m lines cross the camera plane and are dropped
  whole by some WebGL renderers (SwiftShader), leaving only the far lines at about the camera's height);
* ``/Cameras/default/rotated/<object>``: the camera; ``/Cameras/target``: an empty node whose position the
  HTML recordings' and the live page's script makes the camera look at (and follow).
"""

from __future__ import annotations

import re
import warnings
from typing import Any

import meshcat
import meshcat.geometry as mg
import numpy as np
import pinocchio as pin
from pinocchio.visualize import MeshcatVisualizer

from wbc.exceptions import InvalidInputError
from wbc.robot import Robot

OVERLAY_ROOT = "/meshcat/overlays"
POLYGON_ROOT = "/meshcat/polygons"
FLOOR_ROOT = "/meshcat/floor"
CAMERA_TARGET = "/Cameras/target"
CAMERA_OBJECT = "/Cameras/default/rotated/<object>"
#: Colours (0xRRGGBB) of well-known overlays; others cycle through ``_PALETTE``.
#: Overlays drawn together in one scene have distinct colours (a test checks it).
OVERLAY_COLORS = {"com": 0xE0262B, "com_ground": 0xF08080, "com_reference": 0x7A0F12, "zmp": 0x1FA34A, "cop": 0x0B5D1E,
                  "zmp_planned": 0x1FA34A, "zmp_executed": 0x9BE15D, "dcm": 0x2B6FE0, "capture_point": 0x2B6FE0,
                  "dcm_planned": 0x2B6FE0, "dcm_executed": 0x7FB2FF, "footsteps_planned": 0xF28C1B,
                  "footprints": 0x222222, "swing_left": 0x9B3FD1, "swing_right": 0x15A5B5,
                  "support_polygon": 0xFFD21F, "contact_forces": 0xD11FB0, "push": 0xFF2020,
                  "contact_force_left": 0xD11FB0, "contact_force_right": 0x8C564B}
_PALETTE = (0xF28C1B, 0x9B3FD1, 0x15A5B5, 0xD4C21A)
OVERLAY_RADIUS = 0.025  # m


class CommandRecorder:
    """Stand-in for meshcat's ``ViewerWindow``: keeps the lowered commands instead of sending them.

    ``meshcat.Visualizer(window=CommandRecorder())`` then works offline, without a server.
    """

    def __init__(self) -> None:
        self.commands: list[dict[str, Any]] = []

    def send(self, command: Any) -> None:
        self.commands.append(command.lower())


def root_name(robot: Robot) -> str:
    """meshcat node name of the robot (its name with path separators removed)."""
    return re.sub(r"[^A-Za-z0-9_.-]", "_", robot.name) or "robot"


def load_robot_visuals(robot: Robot, viewer: meshcat.Visualizer) -> MeshcatVisualizer:
    """Send the robot's visual meshes to ``viewer`` through Pinocchio's MeshcatVisualizer.

    Returns the MeshcatVisualizer (its ``viewerVisualGroupName`` is the visuals folder path, relative to
    ``/meshcat``). Geometry node names are ``visual_model.geometryObjects[i].name``.
    """
    viz = MeshcatVisualizer(robot.model, None, robot.visual_model)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "meshcat.Visualizer has no get_image" for recorder windows
        viz.initViewer(viewer=viewer)
        viz.loadViewerModel(rootNodeName=root_name(robot))
    return viz


def visual_paths(robot: Robot) -> list[str]:
    """Absolute meshcat path of every visual geometry node, in ``visual_model`` order."""
    return [f"/meshcat/{root_name(robot)}/visuals/{g.name}" for g in robot.visual_model.geometryObjects]


def overlay_color(name: str, index: int) -> int:
    return OVERLAY_COLORS.get(name.lower(), _PALETTE[index % len(_PALETTE)])


def overlay_sphere(color: int) -> mg.Mesh:
    """A sphere drawn on top of the robot (no depth test), so a CoM inside the pelvis stays visible."""
    material = mg.MeshLambertMaterial(color=color, opacity=0.9, transparent=True, depthTest=False)
    return mg.Mesh(mg.Sphere(OVERLAY_RADIUS), material)


def polyline(vertices: np.ndarray, color: int, closed: bool = False):
    """Open (Line) or closed (LineLoop) polyline through ``vertices`` (K, 3), world frame (m)."""
    cls = mg.LineLoop if closed else mg.Line
    return cls(mg.PointsGeometry(np.asarray(vertices).T.astype(np.float32)), mg.LineBasicMaterial(color=color))


#: JavaScript (plain string, no format braces) defining ``wbcFollow(viewer)``: every animation frame, the orbit
#: controls' target and the camera move by how much ``/Cameras/target`` moved, so the camera follows that node
#: and mouse orbit/zoom keep working. With ``/Cameras/default`` left at identity, the camera's parent frame is
#: three.js's world frame.
FOLLOW_JS = """
function wbcFollow(viewer) {
  const node = viewer.scene_tree.find(["Cameras", "target"]).object;
  const step = () => {
    const delta = node.getWorldPosition(viewer.controls.target.clone()).sub(viewer.controls.target);
    if (delta.lengthSq() > 0) {
      viewer.controls.target.add(delta);
      viewer.camera.position.add(delta);
      viewer.set_dirty();
    }
    requestAnimationFrame(step);
  };
  step();
}
"""

#: JavaScript defining ``wbcLiveLegend(viewer)``: a legend box (``#wbc-legend``) listing the children of
#: ``/meshcat/overlays`` present in the scene with their material colour, refreshed every second (the live
#: viewer adds overlays as they appear).
LIVE_LEGEND_JS = """
function wbcLiveLegend(viewer) {
  const box = document.createElement("div");
  box.id = "wbc-legend";
  box.style.cssText = "position:fixed;left:8px;bottom:8px;padding:6px 8px;background:rgba(255,255,255,0.85);" +
                      "font:12px sans-serif;border-radius:4px;z-index:10";
  document.body.appendChild(box);
  let shown = "";
  const refresh = () => {
    const root = viewer.scene_tree.find(["meshcat", "overlays"]);
    const rows = [];
    for (const name of Object.keys(root.children)) {
      let color = null;
      root.children[name].object.traverse(o => {
        if (color === null && o.material && o.material.color) color = o.material.color.getHexString();
      });
      if (color !== null) rows.push([name, color]);
    }
    const key = JSON.stringify(rows);
    if (key !== shown) {
      shown = key;
      box.innerHTML = "<b>overlays</b> (toggle under Open Controls &rsaquo; meshcat &rsaquo; overlays)" +
        rows.map(([n, c]) => '<div class="wbc-legend-row" data-overlay="' + n + '"><span style="display:inline-block;' +
          'width:12px;height:12px;margin-right:6px;background:#' + c + '"></span>' + n + '</div>').join("");
    }
  };
  refresh();
  setInterval(refresh, 1000);
}
"""


def legend_html(entries: dict[str, int]) -> str:
    """A fixed HTML box listing overlay names with their colours (0xRRGGBB)."""
    rows = "".join(
        f'<div><span style="display:inline-block;width:12px;height:12px;margin-right:6px;'
        f'background:#{color:06x}"></span>{name}</div>' for name, color in entries.items())
    return ('<div id="wbc-legend" style="position:fixed;left:8px;bottom:8px;padding:6px 8px;background:'
            'rgba(255,255,255,0.85);font:12px sans-serif;border-radius:4px;z-index:10">'
            '<b>overlays</b> (toggle under Open Controls &rsaquo; meshcat &rsaquo; overlays)' + rows + '</div>')


def polygon_outline(vertices: np.ndarray, color: int = 0xFFD21F) -> mg.LineLoop:
    """Closed outline through ``vertices`` (K, 3), world frame (m)."""
    return mg.LineLoop(mg.PointsGeometry(vertices.T.astype(np.float32)), mg.LineBasicMaterial(color=color))


def add_floor(viewer: meshcat.Visualizer, half_extent: float = 10.0, step: float = 0.5) -> None:
    """Ground at z = 0 (world, m): a light slab whose top is at z = 0 and a grid of ``step`` squares, drawn as
    ``step``-long line pieces (a renderer that drops a line crossing the camera plane then drops only a piece).
    Hides meshcat's default ``/Grid``."""
    import meshcat.transformations as tf

    viewer["/Grid"].set_property("visible", False)
    size = 2.0 * half_extent
    viewer[f"{FLOOR_ROOT}/plane"].set_object(mg.Box([size, size, 0.002]), mg.MeshLambertMaterial(color=0xC8CCD0))
    viewer[f"{FLOOR_ROOT}/plane"].set_transform(tf.translation_matrix([0.0, 0.0, -0.001]))
    ticks = np.arange(-half_extent, half_extent + 1e-9, step)
    a, b = ticks[:-1], ticks[1:]
    pieces = []
    for v in ticks:
        for u0, u1 in zip(a, b):
            pieces += [[u0, v, 0.0], [u1, v, 0.0], [v, u0, 0.0], [v, u1, 0.0]]
    points = np.array(pieces, dtype=np.float32).T
    points[2] += 0.001  # just above the slab
    viewer[f"{FLOOR_ROOT}/grid"].set_object(mg.LineSegments(mg.PointsGeometry(points),
                                                            mg.LineBasicMaterial(color=0x50565E)))


def robot_height(robot: Robot) -> float:
    """Rough robot height (m): highest visual geometry origin in ``q_ref``, at least 0.5 m."""
    data = robot.model.createData()
    gdata = robot.visual_model.createData()
    pin.forwardKinematics(robot.model, data, robot.q_ref)
    pin.updateGeometryPlacements(robot.model, data, robot.visual_model, gdata)
    zmax = max((float(M.translation[2]) for M in gdata.oMg), default=0.0)
    return max(zmax + 0.1, 0.5)


def camera_offset(robot: Robot) -> np.ndarray:
    """Camera position relative to the point it looks at (mid robot height above the base; world frame, m),
    in front of the robot's right."""
    return robot_height(robot) * np.array([0.8, -1.0, 0.2])


def set_camera_offset(viewer: meshcat.Visualizer, offset: np.ndarray) -> None:
    """Place the default camera at ``offset`` (3,) from the point it looks at (world frame, m).

    meshcat 0.3.2 cannot move the orbit-controls target by command: it stays at the world origin (a
    translated ``/Cameras/default`` moves the camera but not where it looks). The camera object hangs under
    ``/Cameras/default/rotated`` (+90 deg about x, three.js is y-up), so a world offset (dx, dy, dz) is the
    local position (dx, dz, -dy). The HTML recordings and the live viewer's page move the target with
    JavaScript (:data:`FOLLOW_JS`, following ``CAMERA_TARGET``).
    """
    dx, dy, dz = (float(v) for v in offset)
    viewer[CAMERA_OBJECT].set_property("position", [dx, dz, -dy])


def check_q(robot: Robot, q: np.ndarray, what: str = "q") -> np.ndarray:
    """``q`` as a float (nq,) or (N, nq) array (a copy).

    Raises:
        InvalidInputError: wrong last dimension or NaN/inf.
    """
    q = np.array(q, dtype=float)
    if q.ndim not in (1, 2) or q.shape[-1] != robot.nq:
        raise InvalidInputError(f"{what} must have shape (nq,) or (N, nq) with nq = {robot.nq}, got {q.shape}")
    if not np.all(np.isfinite(q)):
        raise InvalidInputError(f"{what} contains NaN or inf")
    return q


def normalized(robot: Robot, q: np.ndarray) -> np.ndarray:
    """(nq,) configuration with its base quaternion renormalised.

    Raises:
        InvalidInputError: the quaternion norm is off by more than 1e-3 (not a rounding error).
    """
    if not pin.isNormalized(robot.model, q, 1e-3):
        raise InvalidInputError(f"base quaternion q[3:7] = {q[3:7]} is not unit norm")
    return pin.normalize(robot.model, q)


TERRAIN_ROOT = "/meshcat/terrain"


def draw_terrain(viewer: meshcat.Visualizer, terrain) -> None:
    """Draw a :class:`wbc.terrain.Terrain` under ``/meshcat/terrain``: each box as a box, the heightfield as a
    triangle mesh (the triangles of :meth:`wbc.terrain.Heightfield.height`); the base plane is the floor of
    :func:`add_floor` moved to ``terrain.floor_z``."""
    import meshcat.transformations as tf

    if terrain.floor_z != 0.0:
        viewer[FLOOR_ROOT].set_transform(tf.translation_matrix([0.0, 0.0, float(terrain.floor_z)]))
    material = mg.MeshLambertMaterial(color=0xA8A29A)
    for i, box in enumerate(terrain.boxes):
        node = viewer[f"{TERRAIN_ROOT}/box_{i}"]
        node.set_object(mg.Box(box.size.tolist()), material)
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = box.rotation, box.center
        node.set_transform(T)
    hf = terrain.heightfield
    if hf is not None:
        ny, nx = hf.heights.shape
        xs = hf.origin[0] + hf.spacing * np.arange(nx)
        ys = hf.origin[1] + hf.spacing * np.arange(ny)
        X, Y = np.meshgrid(xs, ys)
        verts = np.c_[X.ravel(), Y.ravel(), hf.heights.ravel()]
        idx = np.arange(ny * nx).reshape(ny, nx)
        a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
        faces = np.r_[np.c_[a, b, d], np.c_[a, d, c]]  # split along (i, j)-(i+1, j+1), counter-clockwise from above
        viewer[f"{TERRAIN_ROOT}/heightfield"].set_object(mg.TriangularMeshGeometry(verts, faces), material)
