"""Live meshcat view of a running controller, off the control loop's critical path.

:class:`LiveViewer` keeps only the latest state given to :meth:`LiveViewer.update` (a copy, microseconds)
and a background thread shows it at about ``fps`` Hz: each meshcat ``set_transform`` is a blocking round
trip, one per mesh of the pose, which a 500 Hz loop cannot wait for.
The same thread computes the overlays of each shown pose (:class:`~wbc.viz.live_overlays.LiveOverlays`) and
moves ``/Cameras/target`` with the base, which the page of wbc's server (:mod:`wbc.viz._server`) follows.
:class:`RealTimePacer` runs a simulated loop at wall-clock speed.
"""

from __future__ import annotations

import atexit
import contextlib
import io
import math
import subprocess
import threading
import time
import warnings
from collections.abc import Mapping
from typing import Any

import meshcat
import meshcat.transformations as tf
import numpy as np
import pinocchio as pin
import zmq

from wbc.exceptions import InvalidInputError
from wbc.robot import Robot
from wbc.viz import _scene, _server
from wbc.viz.live_overlays import LiveOverlays

__all__ = ["LiveViewer", "RealTimePacer"]


class LiveViewer:
    """Non-blocking live view of a robot in meshcat (browser at :attr:`url`).

    Args:
        robot: the robot; its visual model is shown (collision model skipped).
        fps: display rate of the background thread (Hz); it shows fewer frames if sending takes longer.
        zmq_url: an existing meshcat server (``tcp://127.0.0.1:6000``); ``None`` starts one (a subprocess,
            killed by :meth:`close`) whose zmq *and* web/websocket ports all listen on 127.0.0.1 only
            (``meshcat-server`` 0.3.2 serves the page on every interface).
        open: open the viewer URL in the default web browser.
        overlays: what to draw over each displayed pose, computed in the display thread
            (:class:`wbc.viz.live_overlays.LiveOverlays`); default: ``LiveOverlays(robot)`` (CoM, its ground
            projection, executed DCM and ZMP, support polygon, footprints, swing paths). See :meth:`set_overlays`.
        follow_camera: the camera follows the base (its x, y smoothed over ~0.5 s, at mid robot height); the
            page served by the viewer's own server moves the orbit target with ``/Cameras/target``.
        terrain: a :class:`wbc.terrain.Terrain` drawn with the floor (boxes, heightfield), as in the recordings
            (:func:`wbc.viz.record_html`); None: the floor alone.

    Attributes:
        url: the viewer's web address.
        zmq_url: the meshcat server's ZMQ address (``tcp://127.0.0.1:PORT``), for another client of the same scene.
        frames_displayed: poses sent to meshcat so far.
        displayed_time: ``t`` of the last pose sent (s), or None.
        error: the exception that stopped the display thread (server gone...), else None. The control loop
            is never interrupted by the viewer: check this attribute if frames stop.

    Raises:
        InvalidInputError: ``fps <= 0``.
        ConnectionError: no meshcat server answers at ``zmq_url`` within 3 s.
    """

    def __init__(self, robot: Robot, *, fps: float = 25.0, zmq_url: str | None = None, open: bool = False,
                 overlays: LiveOverlays | None = None, follow_camera: bool = True, terrain=None):
        if not (np.isfinite(fps) and fps > 0):
            raise InvalidInputError(f"fps must be positive, got {fps}")
        self.robot = robot
        self.period = 1.0 / float(fps)
        self.frames_displayed = 0
        self.displayed_time: float | None = None
        self.error: BaseException | None = None
        if zmq_url is not None:
            _probe(zmq_url, timeout=3.0)
        self._server: subprocess.Popen | None = None
        if zmq_url is None:
            self._server, zmq_url, _ = _server.start()
            atexit.register(_kill, self._server)
        with contextlib.redirect_stdout(io.StringIO()):  # meshcat prints the URL itself; the caller decides
            self._vis = meshcat.Visualizer(zmq_url=zmq_url)
        self._vis.window.zmq_socket.setsockopt(zmq.RCVTIMEO, 5000)  # a dead server stops the thread, not hangs
        self.zmq_url: str = zmq_url
        self.url: str = self._vis.url()
        self._viz = _scene.load_robot_visuals(robot, self._vis)
        _scene.add_floor(self._vis)
        if terrain is not None:
            _scene.draw_terrain(self._vis, terrain)
        self._height = _scene.robot_height(robot)
        _scene.set_camera_offset(self._vis, _scene.camera_offset(robot))
        self.follow_camera = bool(follow_camera)
        self._target: np.ndarray | None = None
        self._last_t: float | None = None
        self._move_target(robot.q_ref, None)
        self._viz.display(robot.q_ref)
        if open:
            self._vis.open()
        self._markers: set[str] = set()
        self._footprints = 0
        self._source: LiveOverlays | None = None
        self._pending_source: LiveOverlays | None = overlays or LiveOverlays(robot)
        self._latest: tuple[np.ndarray, float | None, dict[str, np.ndarray]] | None = None
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="wbc-live-viewer", daemon=True)
        self._thread.start()

    def update(self, q: np.ndarray, t: float | None = None, overlays: Mapping[str, Any] | None = None) -> None:
        """Hand the latest state to the display thread; returns at once (a few microseconds).

        Args:
            q: (nq,) configuration (copied).
            t: its time (s), reported as :attr:`displayed_time`.
            overlays: name -> (3,) world point (m) shown as a small sphere (e.g. ``{"zmp": p}``), on top of (and
                replacing same-named) points of the viewer's :class:`LiveOverlays`, computed in the display thread.

        Raises:
            InvalidInputError: ``q`` is not a finite (nq,) vector, or an overlay is not a finite 3-vector.
        """
        q = np.array(q, dtype=float)
        if q.shape != (self.robot.nq,) or not np.isfinite(q).all():
            raise InvalidInputError(f"q must be a finite ({self.robot.nq},) vector, got shape {q.shape}")
        marks = {}
        for name, p in (overlays or {}).items():
            p = np.array(p, dtype=float)
            if p.shape != (3,) or not np.isfinite(p).all():
                raise InvalidInputError(f"overlay {name!r} must be a finite 3-vector, got shape {p.shape}")
            marks[str(name)] = p
        self._latest = (q, t, marks)  # a single reference swap: atomic, no lock
        self._wake.set()

    def wait_for_browser(self, timeout: float | None = None, poll: float = 0.2) -> bool:
        """Block until a browser has the page open (a websocket connected to the server), or ``timeout`` s.

        Uses meshcat's ``wait`` request on a socket of its own (the display thread's socket stays free); Ctrl-C
        interrupts the wait (KeyboardInterrupt). Returns True when a browser is connected, False on timeout.

        Raises:
            InvalidInputError: ``timeout`` negative or not a number.
        """
        if timeout is not None and not (timeout >= 0):
            raise InvalidInputError(f"timeout must be >= 0 s or None, got {timeout!r}")
        sock = zmq.Context.instance().socket(zmq.REQ)
        sock.setsockopt(zmq.LINGER, 0)
        try:
            sock.connect(self.zmq_url)
            sock.send(b"wait")
            end = None if timeout is None else time.monotonic() + timeout
            while end is None or time.monotonic() < end:
                if sock.poll(int(1000 * poll)):
                    sock.recv()
                    return True
            return False
        finally:
            sock.close()

    def set_overlays(self, overlays: LiveOverlays) -> None:
        """Replace what is drawn over the poses (e.g. ``LiveOverlays(robot, plan)`` for a walk) before a run.

        The display thread draws its static items (planned footsteps) before the next pose; returns at once.
        """
        self._pending_source = overlays
        self._wake.set()

    def close(self) -> None:
        """Stop the display thread and, if this viewer started it, the meshcat server. Idempotent."""
        self._stop.set()
        self._wake.set()
        self._thread.join(timeout=10.0)
        if self._server is not None:
            _kill(self._server)
            self._server = None
        self._vis.window.zmq_socket.close(linger=0)

    def __enter__(self) -> LiveViewer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def server_process(self) -> subprocess.Popen | None:
        """The meshcat server subprocess this viewer started (None if it connected to one, or closed)."""
        return self._server

    @property
    def running(self) -> bool:
        """True while the display thread runs."""
        return self._thread.is_alive()

    def _run(self) -> None:
        next_frame = time.perf_counter()
        while not self._stop.is_set():
            self._wake.wait(timeout=0.1)
            self._wake.clear()  # before reading: an update arriving now re-sets it
            state, self._latest = self._latest, None
            if state is None or self._stop.is_set():
                continue
            try:
                self._show(*state)
            except Exception as exc:  # noqa: BLE001 - the viewer must never take the controller down
                self.error = exc
                warnings.warn(f"wbc LiveViewer stopped: {exc!r}", RuntimeWarning, stacklevel=1)
                return
            next_frame = max(next_frame + self.period, time.perf_counter())
            self._stop.wait(max(0.0, next_frame - time.perf_counter()))

    def _move_target(self, q: np.ndarray, t: float | None) -> None:
        """Move ``/Cameras/target`` to the base's x, y (first-order smoothing, 0.5 s) at mid robot height."""
        if not self.follow_camera:
            return
        xy = np.asarray(q[:2], dtype=float)
        if self._target is None or t is None or self._last_t is None or t <= self._last_t:
            self._target = xy.copy()
        else:
            self._target += (1.0 - math.exp(-(t - self._last_t) / 0.5)) * (xy - self._target)
        self._last_t = t
        self._vis[_scene.CAMERA_TARGET].set_transform(
            tf.translation_matrix([self._target[0], self._target[1], 0.5 * self._height]))

    def _draw_static(self, source: LiveOverlays) -> None:
        for name, outlines in source.static().items():
            self._vis[f"{_scene.OVERLAY_ROOT}/{name}"].delete()
            color = _scene.overlay_color(name, 0)
            for i, v in enumerate(outlines):
                self._vis[f"{_scene.OVERLAY_ROOT}/{name}/{i}"].set_object(_scene.polyline(v, color, closed=True))

    def _show(self, q: np.ndarray, t: float | None, marks: dict[str, np.ndarray]) -> None:
        if self._pending_source is not None:
            self._source, self._pending_source = self._pending_source, None
            self._draw_static(self._source)
        q = pin.normalize(self.robot.model, q)
        self._viz.display(q)
        self._move_target(q, t)
        frame = self._source.frame(q, t) if self._source is not None else {}
        points = {**frame.get("points", {}), **marks}  # computed here, in the display thread
        for i, (name, p) in enumerate(points.items()):
            node = self._vis[f"{_scene.OVERLAY_ROOT}/{name}"]
            if name not in self._markers:
                node.set_object(_scene.overlay_sphere(_scene.overlay_color(name, i)))
                self._markers.add(name)
            node.set_transform(tf.translation_matrix(p))
        polygon = frame.get("support_polygon")
        if polygon is not None:
            node = self._vis[f"{_scene.OVERLAY_ROOT}/support_polygon/0"]
            if len(polygon) >= 2:
                node.set_object(_scene.polygon_outline(polygon))
            else:
                node.delete()
        for v in frame.get("footprints", []):
            self._vis[f"{_scene.OVERLAY_ROOT}/footprints/{self._footprints}"].set_object(
                _scene.polyline(v, _scene.overlay_color("footprints", 0), closed=True))
            self._footprints += 1
        for name, v in frame.get("trails", {}).items():
            self._vis[f"{_scene.OVERLAY_ROOT}/{name}/0"].set_object(_scene.polyline(v, _scene.overlay_color(name, 0)))
        self.frames_displayed += 1
        self.displayed_time = t


class RealTimePacer:
    """Keeps a simulated loop in step with the wall clock.

    Call :meth:`wait` with the simulated time of each tick; it sleeps until that time has elapsed on the
    wall clock since the first call (divided by ``speed``). Deadlines are absolute, so sleep overshoot does
    not accumulate (``loop_rate_limiters.RateLimiter`` re-anchors every tick, so its overshoot does).

    Args:
        speed: simulated seconds per wall-clock second (1 = real time, 0.5 = slow motion).
        max_lag: when the loop is later than this (s), the clock is re-anchored instead of rushing to catch up.

    Attributes:
        late_ticks: calls that found the loop more than ``max_lag`` late.

    Raises:
        InvalidInputError: ``speed <= 0`` or ``max_lag < 0``.
    """

    def __init__(self, *, speed: float = 1.0, max_lag: float = 0.1):
        if not (np.isfinite(speed) and speed > 0) or not max_lag >= 0:
            raise InvalidInputError(f"speed must be > 0 and max_lag >= 0, got {speed}, {max_lag}")
        self.speed = float(speed)
        self.max_lag = float(max_lag)
        self.late_ticks = 0
        self._origin: float | None = None  # wall-clock time at which the simulated time is 0

    def wait(self, t: float) -> float:
        """Sleep until simulated time ``t`` (s) is due; returns how late the call was (s, >= 0)."""
        now = time.perf_counter()
        if self._origin is None:
            self._origin = now - t / self.speed
        lag = now - (self._origin + t / self.speed)
        if lag < 0.0:
            time.sleep(-lag)
            return 0.0
        if lag > self.max_lag:
            self.late_ticks += 1
            self._origin = now - t / self.speed
        return lag


def _kill(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.kill()
    proc.wait(timeout=10.0)
    for pipe in (proc.stdin, proc.stdout):
        if pipe is not None:
            with contextlib.suppress(OSError):
                pipe.close()


def _probe(zmq_url: str, timeout: float) -> None:
    """Raise ConnectionError unless a meshcat server answers at ``zmq_url`` within ``timeout`` s."""
    sock = zmq.Context.instance().socket(zmq.REQ)
    sock.setsockopt(zmq.LINGER, 0)
    sock.setsockopt(zmq.RCVTIMEO, int(timeout * 1000))
    try:
        sock.connect(zmq_url)
        sock.send(b"url")
        sock.recv()
    except zmq.ZMQError as exc:
        raise ConnectionError(f"no meshcat server answers at {zmq_url!r} (start one with meshcat-server)") from exc
    finally:
        sock.close()
